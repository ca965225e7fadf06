//! Live training curves: every run writes TensorBoard event files beside its
//! `metrics.csv`, so `tensorboard --logdir runs/` follows training as it
//! happens. After every epoch one scalar per statistic is appended, at the
//! run's environment step count:
//!
//! | tag | value |
//! |---|---|
//! | `success/eval`, `success/train`, `drop/eval` | success and drop rates |
//! | `agent_<name>/return`, `.../critic_loss`, `.../actor_loss` | per agent |
//! | `agent_<name>/task_reward_abs`, `.../shadow_reward_abs` | per-step reward magnitudes |
//! | `occupancy/<feature>`, `eval_feature/<feature>` | per stability feature |
//! | `speed/env_steps_per_sec`, `speed/updates_per_sec` | throughput |
//!
//! The files are TensorFlow's record format: per record its length (u64 LE),
//! the masked CRC-32C of the length, an `Event` protobuf, and its masked CRC.
//! The three protobuf messages a scalar needs are declared here with `prost`'s
//! derive (the same `event.proto` field numbers), so building needs no
//! `protoc`; [`read_events`] reads any event file back and checks every CRC.
//! A resumed run opens a new file in the same directory; TensorBoard merges them.

use std::io::Write as _;
use std::path::{Path, PathBuf};

use fmsr_core::CoreError;
use fmsr_core::spec::EnvSpec;
use fmsr_core::trainer::EpochStats;
use prost::Message;

use crate::experiment::ExperimentError;

/// `tensorflow.Event`: one record of an event file.
#[derive(Clone, PartialEq, Message)]
pub struct Event {
    /// Seconds since the Unix epoch.
    #[prost(double, tag = "1")]
    pub wall_time: f64,
    /// The global step (here: environment steps).
    #[prost(int64, tag = "2")]
    pub step: i64,
    /// The payload.
    #[prost(oneof = "What", tags = "3, 5")]
    pub what: Option<What>,
}

/// The payloads of [`Event`] that fmsr writes.
#[derive(Clone, PartialEq, prost::Oneof)]
pub enum What {
    /// The first record of a file: `brain.Event:2`.
    #[prost(string, tag = "3")]
    FileVersion(String),
    /// Scalars.
    #[prost(message, tag = "5")]
    Summary(Summary),
}

/// `tensorflow.Summary`.
#[derive(Clone, PartialEq, Message)]
pub struct Summary {
    /// The values.
    #[prost(message, repeated, tag = "1")]
    pub value: Vec<SummaryValue>,
}

/// `tensorflow.Summary.Value` with a scalar.
#[derive(Clone, PartialEq, Message)]
pub struct SummaryValue {
    /// The series' name.
    #[prost(string, tag = "1")]
    pub tag: String,
    /// The scalar.
    #[prost(oneof = "Scalar", tags = "2")]
    pub value: Option<Scalar>,
}

/// `Summary.Value.simple_value`.
#[derive(Clone, PartialEq, prost::Oneof)]
pub enum Scalar {
    /// A float scalar.
    #[prost(float, tag = "2")]
    SimpleValue(f32),
}

fn masked_crc(bytes: &[u8]) -> u32 {
    let crc = crc32c::crc32c(bytes);
    crc.rotate_right(15).wrapping_add(0xa282_ead8)
}

/// An open event file of one run.
#[derive(Debug)]
pub struct EventWriter {
    path: PathBuf,
    file: std::fs::File,
}

impl EventWriter {
    /// A new event file `events.out.tfevents.<seconds>.fmsr.<pid>` in `dir`.
    ///
    /// # Errors
    /// [`ExperimentError::Io`].
    pub fn create(dir: &Path) -> Result<Self, ExperimentError> {
        let io = |path: &Path| {
            let path = path.to_path_buf();
            move |source| ExperimentError::Io { path, source }
        };
        std::fs::create_dir_all(dir).map_err(io(dir))?;
        let now = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap_or_default();
        let path = dir.join(format!("events.out.tfevents.{:010}.fmsr.{}", now.as_secs(), std::process::id()));
        let file = std::fs::File::create(&path).map_err(io(&path))?;
        let mut writer = Self { path, file };
        writer
            .write(0, What::FileVersion("brain.Event:2".into()))
            .map_err(|source| ExperimentError::Io { path: writer.path.clone(), source })?;
        Ok(writer)
    }

    /// The file.
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.path
    }

    fn write(&mut self, step: i64, what: What) -> std::io::Result<()> {
        let now = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap_or_default();
        let event = Event { wall_time: now.as_secs_f64(), step, what: Some(what) };
        let body = event.encode_to_vec();
        let len = (body.len() as u64).to_le_bytes();
        let mut record = Vec::with_capacity(body.len() + 16);
        record.extend_from_slice(&len);
        record.extend_from_slice(&masked_crc(&len).to_le_bytes());
        record.extend_from_slice(&body);
        record.extend_from_slice(&masked_crc(&body).to_le_bytes());
        self.file.write_all(&record).and_then(|()| self.file.flush())
    }

    /// Appends one epoch's scalars (see the [module docs](self)) at its env step count.
    ///
    /// # Errors
    /// [`CoreError::Io`].
    pub fn write_epoch(&mut self, stats: &EpochStats, spec: &EnvSpec) -> Result<(), CoreError> {
        let value = |tag: String, v: f64| SummaryValue { tag, value: Some(Scalar::SimpleValue(v as f32)) };
        let mut values = vec![
            value("success/eval".into(), stats.success_rate),
            value("success/train".into(), stats.train_success_rate),
            value("drop/eval".into(), stats.drop_rate),
            value("speed/env_steps_per_sec".into(), stats.env_steps_per_sec),
            value("speed/updates_per_sec".into(), stats.updates_per_sec),
        ];
        if let Some(held) = stats.held_success_rate {
            values.insert(1, value("success/eval_held".into(), held));
        }
        let agent_series: [(&str, &[f64]); 8] = [
            ("return", &stats.returns),
            ("critic_loss", &stats.critic_loss),
            ("actor_loss", &stats.actor_loss),
            ("task_reward_abs", &stats.task_reward_abs),
            ("shadow_reward_abs", &stats.shadow_reward_abs),
            ("batch_task_reward_abs", &stats.batch_task_reward_abs),
            ("batch_shadow_reward_abs", &stats.batch_shadow_reward_abs),
            ("q_mean", &stats.q_mean),
        ];
        for (name, series) in agent_series {
            for (agent, v) in spec.agents.iter().zip(series) {
                values.push(value(format!("agent_{}/{name}", agent.name), *v));
            }
        }
        for (name, series) in [("occupancy", &stats.occupancy), ("eval_feature", &stats.eval_feature_rates)] {
            for (feature, v) in spec.features.iter().zip(series) {
                values.push(value(format!("{name}/{feature}"), *v));
            }
        }
        let step = i64::try_from(stats.env_steps).unwrap_or(i64::MAX);
        self.write(step, What::Summary(Summary { value: values }))
            .map_err(|source| CoreError::Io { path: self.path.clone(), source })
    }
}

/// Every event of the event file at `path`, each record's CRCs checked.
///
/// # Errors
/// [`ExperimentError::Io`], and [`ExperimentError::Parse`] for a truncated
/// record, a CRC mismatch or an undecodable event.
pub fn read_events(path: &Path) -> Result<Vec<Event>, ExperimentError> {
    let bytes = std::fs::read(path).map_err(|source| ExperimentError::Io { path: path.into(), source })?;
    let bad = |message: String| ExperimentError::parse(path, message);
    let mut rest = &bytes[..];
    let mut events = Vec::new();
    while !rest.is_empty() {
        let take = |rest: &mut &[u8], n: usize| -> Result<Vec<u8>, ExperimentError> {
            let (head, tail) = rest.split_at_checked(n).ok_or_else(|| bad("truncated record".into()))?;
            *rest = tail;
            Ok(head.to_vec())
        };
        let word = |b: Vec<u8>| b.iter().rev().fold(0u64, |v, &x| (v << 8) | u64::from(x));
        let len_bytes = take(&mut rest, 8)?;
        if word(take(&mut rest, 4)?) != u64::from(masked_crc(&len_bytes)) {
            return Err(bad(format!("length CRC mismatch in record {}", events.len())));
        }
        let len = usize::try_from(word(len_bytes)).map_err(|_| bad("record length overflows".into()))?;
        let body = take(&mut rest, len)?;
        if word(take(&mut rest, 4)?) != u64::from(masked_crc(&body)) {
            return Err(bad(format!("CRC mismatch in record {}", events.len())));
        }
        events.push(
            Event::decode(&body[..])
                .map_err(|e| ExperimentError::parse_source(path, format!("event {}", events.len()), e))?,
        );
    }
    Ok(events)
}

/// The scalars of `events` as (tag, step, value), in file order.
#[must_use]
pub fn scalars(events: &[Event]) -> Vec<(String, i64, f32)> {
    events
        .iter()
        .filter_map(|e| match &e.what {
            Some(What::Summary(s)) => Some((e.step, s)),
            _ => None,
        })
        .flat_map(|(step, s)| {
            s.value.iter().filter_map(move |v| v.value.as_ref().map(|&Scalar::SimpleValue(x)| (v.tag.clone(), step, x)))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    // Guards the record format against TensorFlow's: the masked CRC-32C of
    // known bytes, as TensorFlow's `crc32c.masked_crc` computes it.
    #[test]
    fn masked_crc_matches_tensorflow() {
        // crc32c("123456789") = 0xE3069283 (the CRC-32C check value).
        assert_eq!(crc32c::crc32c(b"123456789"), 0xE306_9283);
        // TensorFlow's mask of a zero CRC (the empty string) is its delta.
        assert_eq!(masked_crc(b""), 0xa282_ead8);
    }
}
