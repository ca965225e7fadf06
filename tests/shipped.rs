//! Guards the shipped policies and the README's commands over them
//! (regression): the READMEs' `report pretrained/*/` stopped working when
//! directories of experiments' runs (`pretrained/e2_egg_full_mujoco/`, which
//! holds neither a run nor a policy file) joined `pretrained/`, and no test
//! ran the command. Every policy file in `pretrained/` opens with this build
//! and carries its evaluation on the fixed test set, and every `report` of
//! `README.md` and `pretrained/README.md` names only what `fmsr report` reads.
//! Every shipped policy is at half precision (the tree's room) and carries
//! evaluations measured at that precision, which `fmsr eval` repeats.

use std::path::PathBuf;

use fmsr::artefacts::PolicyFile;
use fmsr::nn::PolicyPrecision;
use fmsr::report::RunRecord;

/// The paths a shell pattern of the README matches, sorted (as a shell's glob).
fn matches(pattern: &str) -> Vec<PathBuf> {
    let mut paths: Vec<PathBuf> = glob::glob(pattern).unwrap().map(Result::unwrap).collect();
    paths.sort();
    paths
}

#[test]
fn every_shipped_policy_opens_and_carries_its_test_evaluation() {
    // A long run's rescue point (`rescue/rescue.fmsr`) is the state a running
    // run goes on from, not a policy; its best snapshot so far is not tracked.
    let files: Vec<PathBuf> = matches("pretrained/**/*.fmsr")
        .into_iter()
        .filter(|p| !p.components().any(|c| c.as_os_str() == "rescue") && !p.ends_with("best_so_far.fmsr"))
        .collect();
    assert!(files.len() >= 5, "the shipped policies are gone: {files:?}");
    for file in files {
        let record = RunRecord::open(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        assert!(record.eval.is_some(), "{} carries no evaluation on the fixed test set", file.display());
        assert!(!record.metrics.is_empty(), "{} carries no learning curve", file.display());
        let policy = PolicyFile::read(&file).unwrap();
        assert_eq!(policy.precision(), PolicyPrecision::Half, "{} is not shipped at half precision", file.display());
        for eval in &policy.evals {
            assert_eq!(
                eval.precision,
                PolicyPrecision::Half,
                "{} carries an evaluation ({} {:?}) of its actors at another precision",
                file.display(),
                eval.engine,
                eval.set
            );
        }
    }
}

#[test]
fn the_readmes_report_commands_name_only_what_report_reads() {
    for readme in ["README.md", "pretrained/README.md"] {
        let text = std::fs::read_to_string(readme).unwrap();
        // The commands over what the repository ships (others name runs a reader trains first).
        let commands: Vec<&str> = text
            .lines()
            .filter_map(|l| l.trim_start().strip_prefix("cargo run --release -- report "))
            .filter(|args| args.starts_with("pretrained/"))
            .collect();
        assert!(!commands.is_empty(), "{readme} has no `fmsr report` command over pretrained/");
        for command in commands {
            report_reads_what_it_names(readme, command);
        }
    }
}

/// The paths of a README's `report ARGS --out ...` open as `fmsr report` opens them.
fn report_reads_what_it_names(readme: &str, command: &str) {
    let args = command.split(" --").next().unwrap();
    for pattern in args.split_whitespace() {
        let paths = matches(pattern);
        assert!(!paths.is_empty(), "{readme}'s `report {args}`: {pattern} matches nothing");
        for path in paths {
            RunRecord::open(&path)
                .unwrap_or_else(|e| panic!("{readme}'s `report {args}` fails on {}: {e}", path.display()));
        }
    }
}
