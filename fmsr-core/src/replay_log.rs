//! The replay log: every stored episode, kept on disk in append-only segments
//! beside a run's checkpoint, so that a resumed run gets back the replay it had
//! at every budget without writing the whole buffer at every checkpoint.
//!
//! A checkpoint at `run/checkpoint.bin` keeps its segments in
//! `run/checkpoint.replay/`. Each checkpoint writes one new segment, the
//! episodes stored since the previous one, named by the store index of its
//! first episode (`00000000000000000200.seg` holds episodes 200, 201, ...), in
//! the framing of [`crate::persist`]. The checkpoint records how many episodes
//! were stored; resuming reads back the last `min(stored, capacity)` of them
//! (the replay buffer's window) and puts them back in place with
//! [`crate::Algorithm::restore_storage`]. Segments that lie wholly before that
//! window are deleted once the checkpoint that makes them unnecessary is on disk.
//!
//! The order of a checkpoint's writes keeps every moment of a crash safe:
//! 1. the new segment (atomically), 2. the checkpoint (atomically), 3. pruning.
//!
//! A crash between 1 and 2 leaves a segment that starts at the old checkpoint's
//! count: reading ignores it, and the resumed run writes it again.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::CoreError;
use crate::persist;
use crate::replay::Episode;

/// Version 2 (CRC-32C).
const FORMAT: persist::Format = persist::Format::new(b"FMSRSEGM", 2);
const EXTENSION: &str = "seg";

/// One segment: consecutive episodes from store index `first`.
#[derive(Serialize, Deserialize)]
struct Segment {
    first: u64,
    episodes: Vec<Episode>,
}

/// The episodes stored since the last checkpoint (the count of all stored
/// episodes is the trainer's). Holds at most `window` episodes: older ones can
/// never be needed again.
#[derive(Debug, Clone, Default)]
pub struct ReplayLog {
    pending: VecDeque<Episode>,
}

impl ReplayLog {
    /// Records one stored episode; keeps at most `window` pending.
    pub fn push(&mut self, episode: Episode, window: usize) {
        self.pending.push_back(episode);
        while self.pending.len() > window {
            self.pending.pop_front();
        }
    }

    /// The segment folder of the checkpoint at `checkpoint`: `<checkpoint>.replay/`.
    #[must_use]
    pub fn dir(checkpoint: &Path) -> PathBuf {
        let mut name = checkpoint.file_stem().map(|s| s.to_os_string()).unwrap_or_default();
        name.push(".replay");
        checkpoint.with_file_name(name)
    }

    /// The pending episodes as one segment, its file name and bytes (none if
    /// nothing is pending), forgetting them; `stored` episodes have been stored
    /// in all, the pending ones last. The caller writes the file into the
    /// segment folder ([`ReplayLog::dir`]); worker 0 writes every worker's.
    ///
    /// # Errors
    /// [`CoreError::Corrupt`] when an episode cannot be encoded.
    pub fn take_segment(&mut self, stored: u64) -> Result<Option<(String, Vec<u8>)>, CoreError> {
        if self.pending.is_empty() {
            return Ok(None);
        }
        let first = stored.saturating_sub(self.pending.len() as u64);
        let name = format!("{first:020}.{EXTENSION}");
        let segment = Segment { first, episodes: self.pending.drain(..).collect() };
        let bytes = persist::encode(&FORMAT, &segment)
            .map_err(|e| CoreError::Corrupt { path: name.clone().into(), reason: e.to_string() })?;
        Ok(Some((name, bytes)))
    }

    /// Deletes the segments of `dir` that hold only episodes before `keep_from`
    /// (a segment ends where the next one starts).
    ///
    /// # Errors
    /// I/O errors.
    pub fn prune(dir: &Path, keep_from: u64) -> Result<(), CoreError> {
        let segments = list(dir)?;
        for pair in segments.windows(2) {
            if pair[1].0 <= keep_from {
                std::fs::remove_file(&pair[0].1).map_err(|source| CoreError::Io { path: pair[0].1.clone(), source })?;
            }
        }
        Ok(())
    }

    /// The episodes with store indices `from .. to`, read from the segments in `dir`.
    ///
    /// # Errors
    /// [`CoreError::Io`], [`CoreError::Corrupt`] for a damaged segment, and
    /// [`CoreError::Corrupt`] naming the missing indices when the segments do
    /// not hold them all.
    pub fn read(dir: &Path, from: u64, to: u64) -> Result<Vec<Episode>, CoreError> {
        if from >= to {
            return Ok(Vec::new());
        }
        let segments = list(dir)?;
        // The last segment starting at or before `from`, and every later one starting before `to`.
        let start = segments.iter().rposition(|(first, _)| *first <= from).unwrap_or(0);
        let mut episodes = Vec::new();
        let mut next = from;
        for (first, path) in segments[start..].iter().take_while(|(first, _)| *first < to) {
            let bytes = std::fs::read(path).map_err(|source| CoreError::Io { path: path.clone(), source })?;
            let corrupt = |reason: String| CoreError::Corrupt { path: path.clone(), reason };
            let segment: Segment = persist::decode(&FORMAT, &bytes).map_err(|e| corrupt(e.to_string()))?;
            if segment.first != *first {
                return Err(corrupt(format!("holds episodes from {}, its name says {first}", segment.first)));
            }
            if *first > next {
                break;
            }
            let skip = usize::try_from(next - first).unwrap_or(usize::MAX);
            let wanted = usize::try_from(to - next).unwrap_or(usize::MAX);
            let before = episodes.len();
            episodes.extend(segment.episodes.into_iter().skip(skip).take(wanted));
            next += (episodes.len() - before) as u64;
        }
        if next != to {
            return Err(CoreError::Corrupt {
                path: dir.to_path_buf(),
                reason: format!("the replay log lacks episode {next} of {from}..{to} (a segment is missing)"),
            });
        }
        Ok(episodes)
    }
}

/// The segments of `dir` as (first index, path), in order; none if `dir` is absent.
fn list(dir: &Path) -> Result<Vec<(u64, PathBuf)>, CoreError> {
    let io = |source| CoreError::Io { path: dir.to_path_buf(), source };
    let entries = match std::fs::read_dir(dir) {
        Ok(entries) => entries,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(io(e)),
    };
    let mut segments = Vec::new();
    for entry in entries {
        let path = entry.map_err(io)?.path();
        let first = path.file_stem().and_then(|s| s.to_str()).and_then(|s| s.parse().ok());
        if let (true, Some(first)) = (path.extension().is_some_and(|e| e == EXTENSION), first) {
            segments.push((first, path));
        }
    }
    segments.sort();
    Ok(segments)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::{JointAction, Observation, StepInfo};

    fn episode(e: u64) -> Episode {
        let o = Observation { global: vec![e as f32], locals: vec![], achieved_goal: vec![], desired_goal: vec![] };
        Episode {
            observations: vec![o.clone(), o],
            actions: vec![JointAction(vec![e as f32])],
            infos: vec![StepInfo::default()],
            log_probs: vec![],
        }
    }

    /// Writes the pending episodes' segment, as a checkpoint does.
    fn flush(log: &mut ReplayLog, dir: &Path, stored: u64) {
        if let Some((name, bytes)) = log.take_segment(stored).unwrap() {
            crate::persist::write_atomic(&dir.join(name), &bytes).unwrap();
        }
    }

    fn ids(episodes: &[Episode]) -> Vec<u64> {
        episodes.iter().map(|e| e.observations[0].global[0] as u64).collect()
    }

    // Guards the log's bookkeeping: segments written at checkpoints give back
    // any window of store indices, pruning keeps the window, and a missing
    // segment is an error naming the missing episodes.
    #[test]
    fn segments_give_back_the_window() {
        let dir = tempfile::tempdir().unwrap();
        let seg = dir.path().join("checkpoint.replay");
        let mut log = ReplayLog::default();
        for checkpoint in 0..4 {
            (0..5).for_each(|k| log.push(episode(checkpoint * 5 + k), 8));
            flush(&mut log, &seg, checkpoint * 5 + 5);
        }
        assert_eq!(ids(&ReplayLog::read(&seg, 0, 20).unwrap()), (0..20).collect::<Vec<_>>());
        assert_eq!(ids(&ReplayLog::read(&seg, 7, 13).unwrap()), (7..13).collect::<Vec<_>>());
        ReplayLog::prune(&seg, 12).unwrap();
        assert_eq!(ids(&ReplayLog::read(&seg, 12, 20).unwrap()), (12..20).collect::<Vec<_>>());
        let err = ReplayLog::read(&seg, 3, 20).unwrap_err();
        assert!(err.to_string().contains("lacks episode 3 of 3..20"), "{err}");
        // The window bounds what is pending: only the newest 8 of 30 are written.
        (20..50).for_each(|e| log.push(episode(e), 8));
        flush(&mut log, &seg, 50);
        assert_eq!(ids(&ReplayLog::read(&seg, 42, 50).unwrap()), (42..50).collect::<Vec<_>>());
        assert!(ReplayLog::read(&seg, 40, 50).is_err());
    }

    // Guards crash safety: a segment written before a crash that the
    // checkpoint never counted is ignored, and a damaged one is an error.
    #[test]
    fn uncounted_and_damaged_segments() {
        let dir = tempfile::tempdir().unwrap();
        let seg = dir.path().join("c.replay");
        let mut log = ReplayLog::default();
        (0..4).for_each(|e| log.push(episode(e), 100));
        flush(&mut log, &seg, 4);
        (4..6).for_each(|e| log.push(episode(e), 100));
        flush(&mut log, &seg, 6);
        assert_eq!(ids(&ReplayLog::read(&seg, 0, 4).unwrap()), vec![0, 1, 2, 3]);
        let path = seg.join(format!("{:020}.seg", 4));
        let mut bytes = std::fs::read(&path).unwrap();
        let n = bytes.len();
        bytes[n - 3] ^= 1;
        std::fs::write(&path, bytes).unwrap();
        assert!(matches!(ReplayLog::read(&seg, 0, 6), Err(CoreError::Corrupt { .. })));
        assert_eq!(ReplayLog::dir(Path::new("run/checkpoint.bin")), Path::new("run/checkpoint.replay"));
    }
}
