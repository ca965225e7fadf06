//! Guards the readers of everything a run keeps against corrupted input: the
//! TOML config loader, the checkpoint reader, the replay log's reader and the
//! policy file reader get random bytes, truncations
//! and bit flips of valid files, and answer with a typed error (or, for a
//! config, a valid config) every time: never a panic. Case counts are small
//! in `cargo test`; `FMSR_FUZZ_CASES=N` runs more.

use crate::common;

use std::path::Path;
use std::sync::OnceLock;

use fmsr::experiment::ExperimentConfig;
use fmsr::prelude::*;
use proptest::prelude::*;

fn cases() -> u32 {
    std::env::var("FMSR_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(64)
}

/// Flips `flips` bits of `bytes` and cuts it at `cut`.
fn corrupt(bytes: &[u8], flips: &[(usize, u8)], cut: Option<usize>) -> Vec<u8> {
    let mut out = bytes.to_vec();
    for &(at, bit) in flips {
        let i = at % out.len();
        out[i] ^= 1 << bit;
    }
    if let Some(c) = cut {
        out.truncate(c % (bytes.len() + 1));
    }
    out
}

/// A valid checkpoint (and its replay log) of a one-epoch TeamReach run, written once.
fn checkpoint() -> &'static (tempfile::TempDir, Vec<u8>) {
    static CHECKPOINT: OnceLock<(tempfile::TempDir, Vec<u8>)> = OnceLock::new();
    CHECKPOINT.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("checkpoint.bin");
        let mut t = common::team_reach_trainer(Method::DenseFmsrIs, 1, 1);
        t.train(|t, _| t.save_checkpoint(&path)).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        (dir, bytes)
    })
}

/// A valid policy file of the quick block config carrying a TeamReach policy (the reader checks the framing and
/// every part's syntax; whether the policy fits an env is the learner's check, fuzzed above).
fn policy_file() -> &'static Vec<u8> {
    static FILE: OnceLock<Vec<u8>> = OnceLock::new();
    FILE.get_or_init(|| {
        let mut t = common::team_reach_trainer(Method::DenseFmsrIs, 1, 1);
        t.train(|_, _| Ok(())).unwrap();
        let file = fmsr::artefacts::PolicyFile {
            config: ExperimentConfig::load(Path::new("configs/block_dense_fmsr_is_quick.toml")).unwrap(),
            provenance: fmsr::provenance::Provenance::of_this_process(Path::new(".")),
            metrics: t.history().to_vec(),
            evals: Vec::new(),
            epochs: t.epoch(),
            env_steps: 1000,
            policy: t.algorithm().save_policy().unwrap(),
        };
        let bytes = file.to_bytes().unwrap();
        let back = fmsr::artefacts::PolicyFile::from_bytes(&bytes, Path::new("x.fmsr")).unwrap();
        assert_eq!(back, file);
        bytes
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(cases()))]

    #[test]
    fn corrupted_configs_are_errors_not_panics(
        flips in proptest::collection::vec((0usize..4096, 0u8..8), 0..4),
        cut in proptest::option::of(0usize..4096),
        insert in "[ -~\\n]{0,40}",
        at in 0usize..4096,
    ) {
        let path = Path::new("configs/block_dense_fmsr_is_quick.toml");
        let base = std::fs::read(path).unwrap();
        let mut bytes = corrupt(&base, &flips, cut);
        let i = at % (bytes.len() + 1);
        bytes.splice(i..i, insert.bytes());
        let text = String::from_utf8_lossy(&bytes);
        if let Ok(config) = ExperimentConfig::from_toml(&text, path) {
            // A config that loads also writes and reads back.
            let again = ExperimentConfig::from_toml(&config.to_toml().unwrap(), path).unwrap();
            prop_assert_eq!(again, config);
        }
    }

    #[test]
    fn corrupted_checkpoints_are_errors_not_panics(
        flips in proptest::collection::vec((0usize..1 << 24, 0u8..8), 1..4),
        cut in proptest::option::of(0usize..1 << 24),
        noise in proptest::collection::vec(any::<u8>(), 0..64),
    ) {
        let (dir, good) = checkpoint();
        let path = dir.path().join(format!("fuzz-{}.bin", std::process::id()));
        let mut fresh = common::team_reach_trainer(Method::DenseFmsrIs, 1, 1);
        for bytes in [corrupt(good, &flips, cut), [&good[..20.min(good.len())], &noise[..]].concat(), noise.clone()] {
            std::fs::write(&path, &bytes).unwrap();
            let result = fresh.load_checkpoint(&path);
            prop_assert!(result.is_err(), "a corrupted checkpoint was accepted");
        }
    }

    #[test]
    fn corrupted_replay_segments_are_errors_not_panics(
        flips in proptest::collection::vec((0usize..1 << 24, 0u8..8), 1..4),
        cut in proptest::option::of(0usize..1 << 24),
    ) {
        let (dir, good) = checkpoint();
        let segment = dir.path().join("checkpoint.replay").join(format!("{:020}.seg", 0));
        let segment_bytes = std::fs::read(&segment).unwrap();
        let bad = corrupt(&segment_bytes, &flips, cut);
        prop_assume!(bad != segment_bytes);
        let case = tempfile::tempdir().unwrap();
        std::fs::write(case.path().join("checkpoint.bin"), good).unwrap();
        std::fs::create_dir(case.path().join("checkpoint.replay")).unwrap();
        std::fs::write(case.path().join("checkpoint.replay").join(format!("{:020}.seg", 0)),
                       bad).unwrap();
        let mut fresh = common::team_reach_trainer(Method::DenseFmsrIs, 1, 1);
        let result = fresh.load_checkpoint(&case.path().join("checkpoint.bin"));
        prop_assert!(result.is_err(), "a corrupted replay segment was accepted");
    }

    #[test]
    fn corrupted_policy_files_are_errors_not_panics(
        flips in proptest::collection::vec((0usize..1 << 24, 0u8..8), 1..4),
        cut in proptest::option::of(0usize..1 << 24),
        noise in proptest::collection::vec(any::<u8>(), 0..64),
    ) {
        let good = policy_file();
        let read = |bytes: &[u8]| fmsr::artefacts::PolicyFile::from_bytes(bytes, Path::new("x.fmsr"));
        let damaged = corrupt(good, &flips, cut);
        prop_assume!(&damaged != good);
        for bytes in [damaged, [&good[..20], &noise[..]].concat(), noise.clone()] {
            prop_assert!(read(&bytes).is_err(), "a corrupted policy file was accepted");
        }
    }
}
