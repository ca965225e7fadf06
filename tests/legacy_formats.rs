//! Guards the switch of checksum from FNV-1a to CRC-32C (issue 39, item 7):
//! files written before it still read. `tests/data/legacy_d4db16e` was
//! written by the release build of d4db16e, the last commit with FNV-1a
//! (checkpoint format 3, replay segment 1, learner state 5, policy file 1,
//! policy state 1), from a worktree of that commit:
//!
//! ```text
//! fmsr train --config tiny.toml --out run --quiet   # tests/common's tiny config,
//!     # with hidden = 8, layers = 1, episodes_per_cycle = 1
//! fmsr eval run --episodes 2
//! fmsr export run --out policy.fmsr
//! ```
//!
//! The run resumes for a second epoch, after which its checkpoint and its new
//! replay segment are framed with CRC-32C, and the old segment still reads on
//! a second resume; the policy file evaluates to the evaluation it carries.

use crate::common;

use std::path::Path;

use common::cli::{fmsr, text};

const LEGACY: &str = "tests/data/legacy_d4db16e";

/// The format version and checksum words of a framed file's header.
fn header(path: &Path) -> (u32, u64) {
    let bytes = std::fs::read(path).unwrap();
    let word = |r: std::ops::Range<usize>| bytes[r].iter().rev().fold(0u64, |v, &b| (v << 8) | u64::from(b));
    (word(8..12) as u32, word(12..20))
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        if entry.file_type().unwrap().is_dir() {
            copy_dir(&entry.path(), &to.join(entry.file_name()));
        } else {
            std::fs::copy(entry.path(), to.join(entry.file_name())).unwrap();
        }
    }
}

fn segments(run: &Path) -> Vec<std::path::PathBuf> {
    let mut all: Vec<_> =
        std::fs::read_dir(run.join("checkpoint.replay")).unwrap().map(|e| e.unwrap().path()).collect();
    all.sort();
    all
}

#[test]
fn a_run_written_with_fnv_resumes_and_writes_crc32c() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    copy_dir(&Path::new(LEGACY).join("run"), &run);
    assert_eq!(header(&run.join("checkpoint.bin")).0, 3, "the fixture is not the old format");
    let old_segment = segments(&run)[0].clone();
    assert_eq!(header(&old_segment).0, 1);

    let run_s = run.to_str().unwrap();
    let out = fmsr(&["train", "--out", run_s, "--resume", "--epochs", "2", "--quiet"]);
    assert!(out.status.success(), "{}", text(&out));
    assert_eq!(std::fs::read_to_string(run.join("metrics.jsonl")).unwrap().lines().count(), 2);
    let (version, checksum) = header(&run.join("checkpoint.bin"));
    assert_eq!(version, 4);
    let body = &std::fs::read(run.join("checkpoint.bin")).unwrap()[fmsr_core::persist::HEADER_LEN..];
    assert_eq!(checksum, u64::from(crc32c::crc32c(body)));
    let all = segments(&run);
    assert!(all.len() >= 2 && all.contains(&old_segment), "{all:?}");
    assert!(all.iter().filter(|s| **s != old_segment).all(|s| header(s).0 == 2), "{all:?}");

    // The log now holds segments of both framings; a resume reads them all.
    let out = fmsr(&["train", "--out", run_s, "--resume", "--epochs", "3", "--quiet"]);
    assert!(out.status.success(), "{}", text(&out));
    assert_eq!(std::fs::read_to_string(run.join("metrics.jsonl")).unwrap().lines().count(), 3);
}

#[test]
fn a_policy_file_written_with_fnv_evaluates_as_it_did() {
    let policy = Path::new(LEGACY).join("policy.fmsr");
    assert_eq!(header(&policy).0, 1, "the fixture is not the old format");
    let out = fmsr(&["eval", policy.to_str().unwrap(), "--episodes", "2"]);
    assert!(out.status.success(), "{}", text(&out));
    assert!(text(&out).contains("the same results as the evaluation the file carries"), "{}", text(&out));
}

#[test]
fn a_file_of_a_format_no_build_wrote_is_refused_with_what_to_do() {
    let tmp = tempfile::tempdir().unwrap();
    let mut bytes = std::fs::read(Path::new(LEGACY).join("policy.fmsr")).unwrap();
    bytes[8..12].copy_from_slice(&0u32.to_le_bytes());
    let policy = tmp.path().join("policy.fmsr");
    std::fs::write(&policy, &bytes).unwrap();
    let out = fmsr(&["eval", policy.to_str().unwrap(), "--episodes", "2"]);
    assert!(!out.status.success());
    let message = text(&out);
    assert!(message.contains("format version 0") && message.contains("versions 1 to 2"), "{message}");
    assert!(message.contains("read it with the fmsr that wrote it"), "{message}");
}
