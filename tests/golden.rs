//! Guards that a redesign of the code changes nothing numerically. A short
//! run of each algorithm on the Shadow Hand (rapier, six agents, Dense+FMSR+IS
//! with information sharing) gives bit for bit the epoch statistics and the
//! evaluation episode recorded in `tests/data/golden.json` before any code
//! moved.
//!
//! Each run covers one sharing path: MADDPG mixes the actors' parameters (the
//! paper's), MATD3 the parameters of actors and critics, MASAC the critics'
//! gradients. Three epochs, so the critics of one epoch drive the actors'
//! updates of the next, and the greedy episode that follows reads every actor
//! and its normaliser.
//!
//! The numbers are bit patterns of one CPU's arithmetic: burn's and faer's
//! kernels choose their SIMD paths at run time. The file holds one recording
//! per set of instruction sets (its `commit`: the code that made it); a CPU
//! compares against the recording of its own sets, and **on a CPU without one
//! the test fails**, saying how to record. CI records one for its own CPU in a
//! step of its own that says so in its output (`FMSR_GOLDEN=record-if-missing`:
//! records only where the file has none for this CPU), before the tests. To
//! record this CPU's (beside the others; only on code whose numbers are the
//! reference, or when numbers are meant to change, in a commit of its own that
//! says why): `FMSR_GOLDEN=record FMSR_GOLDEN_COMMIT=<commit> cargo test --test integration -- golden::`.
//!
//! Besides the epochs and the greedy episode, each trace holds CRC-32Cs of the
//! final parameters (every agent's online actor and critic) and of the saved
//! policy state (actors and normalisers). The whole learner state is not
//! hashed: its optimiser records (burn's burnpack) do not serialise the same
//! bytes twice (two saves of one learner measured 486 652 and 487 152 bytes),
//! though they restore the same moments. A recording made again keeps, in
//! `equivalent_to`, the earlier recordings whose every value it repeats, so
//! that the chain of equivalence is in the data.
//!
//! The runs train the task of the recordings: the yaw goal distance and at
//! least 10 active sensors for `contacts` (`env.goal_distance = "yaw"`,
//! `env.min_active_touch = 10`), fmsr's earlier defaults: that the yaw
//! distance still gives these numbers bit for bit is what lets every earlier
//! record be reproduced. Statistics added to `EpochStats` since a recording
//! was made are compared when the recording has them.
//!
//! burn's CPU backend is built with its `x86-v4` feature: `gemm` runs
//! AVX-512 kernels on a CPU with AVX-512F and its AVX2/FMA kernels
//! elsewhere, so an AVX-512F CPU (`... avx512f` below) computes other bits
//! than an AVX2 one. The file holds two recordings: the AVX2 CPUs' (it
//! repeats bit for bit the one an AVX-512F CPU made while gemm ran its AVX2
//! kernels there too, `equivalent_to`), and the AVX-512F CPUs' (made on an
//! Intel Xeon VM with gemm's AVX-512 kernels, from the code of the AVX2
//! recording's last check). The two agree to about seven significant
//! digits in the first epoch's losses and drift apart after, as two
//! summation orders do.

use crate::common;

use fmsr::experiment::ExperimentConfig;
use fmsr::prelude::*;
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::path::Path;

const GOLDEN: &str = "tests/data/golden.json";
const EPOCHS: usize = 3;
/// The seed of the greedy episode after training.
const EPISODE_SEED: u64 = 4_242;

/// What one run leaves: its epochs (without wall-clock timings) and its greedy episode.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Trace {
    /// The algorithm and its sharing path.
    run: String,
    /// Every epoch's statistics, timings zeroed.
    history: Vec<Value>,
    /// Steps of the greedy episode.
    steps: usize,
    /// CRC-32C of the little-endian bits of its joint actions.
    actions_crc: u32,
    /// CRC-32C of the little-endian bits of its observations (locals, global, goals).
    observations_crc: u32,
    /// Its first joint action, to read a difference by eye.
    first_action: Vec<f32>,
    /// CRC-32C of the final parameters: every agent's online actor, then its
    /// (first) critic, little-endian (absent in recordings made before the
    /// field existed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    params_crc: Option<u32>,
    /// CRC-32C of the saved policy state (`PolicyState::save_policy`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    policy_crc: Option<u32>,
}

/// One CPU's recording.
#[derive(Debug, Serialize, Deserialize)]
struct Recording {
    /// The instruction sets of the CPU that recorded the traces.
    cpu: String,
    /// The commit whose code recorded them.
    commit: String,
    /// Earlier recordings of this CPU whose every value this one repeats
    /// (what was compared, in words), newest first.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    equivalent_to: Vec<Equivalence>,
    traces: Vec<Trace>,
}

/// An earlier recording that a later one repeats.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct Equivalence {
    /// The earlier recording's commit.
    commit: String,
    /// What was compared.
    checked: String,
}

/// The file: one recording per set of instruction sets.
#[derive(Debug, Default, Serialize, Deserialize)]
struct Golden {
    recordings: Vec<Recording>,
}

/// The target architecture and the SIMD instruction sets its kernels choose from.
fn cpu() -> String {
    #[cfg(target_arch = "x86_64")]
    {
        let mut s = String::from("x86_64");
        for (name, on) in [
            ("sse4.1", std::arch::is_x86_feature_detected!("sse4.1")),
            ("avx", std::arch::is_x86_feature_detected!("avx")),
            ("avx2", std::arch::is_x86_feature_detected!("avx2")),
            ("fma", std::arch::is_x86_feature_detected!("fma")),
            ("avx512f", std::arch::is_x86_feature_detected!("avx512f")),
        ] {
            if on {
                s.push(' ');
                s.push_str(name);
            }
        }
        s
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        std::env::consts::ARCH.to_string()
    }
}

/// The tiny Shadow Hand config (tests/common) with `algorithm` and `sharing`.
fn config(algorithm: &str, sharing: &str) -> ExperimentConfig {
    let mut text = common::tiny_config_text();
    let from = "[sharing]\nmode = \"parameters\"\ntarget = \"actors\"\n";
    assert_eq!(text.matches(from).count(), 1, "the quick config's sharing changed: update this test");
    text = text.replace(from, &format!("[sharing]\n{sharing}\n"));
    text = format!("algorithm = \"{algorithm}\"\n{text}");
    let env = "[env]\n";
    assert_eq!(text.matches(env).count(), 1, "the quick config's [env] changed: update this test");
    text = text.replace(env, "[env]\ngoal_distance = \"yaw\"\nmin_active_touch = 10\n");
    let mut config = ExperimentConfig::from_toml(&text, Path::new("golden.toml")).unwrap();
    config.trainer.epochs = EPOCHS;
    config
}

fn crc(values: impl Iterator<Item = f32>) -> u32 {
    let bytes: Vec<u8> = values.flat_map(f32::to_le_bytes).collect();
    crc32c::crc32c(&bytes)
}

fn trace(algorithm: &str, sharing: &str) -> Trace {
    let config = config(algorithm, sharing);
    // Built through the Shadow Hand's registry entry, as `fmsr train` builds it.
    let envs = config.task_envs(config.trainer.num_envs()).unwrap();
    let mut trainer = config.build_trainer(envs).unwrap();
    trainer.train(|_, _| Ok(())).unwrap();
    let history = trainer
        .history()
        .iter()
        .map(|s| {
            let s = EpochStats { env_steps_per_sec: 0.0, updates_per_sec: 0.0, seconds: 0.0, ..s.clone() };
            serde_json::to_value(s).unwrap()
        })
        .collect();
    let learner = trainer.algorithm();
    let params: Vec<f32> = (0..learner.num_agents())
        .flat_map(|i| {
            let (actor, critic) = learner.params(i).unwrap();
            actor.into_iter().chain(critic)
        })
        .collect();
    let policy_crc = crc32c::crc32c(&learner.save_policy().unwrap());
    let episode = trainer.rollout(EPISODE_SEED, ActMode::Evaluate).unwrap();
    let observations = episode.observations.iter().flat_map(|o| {
        let parts = o.locals.iter().chain([&o.global, &o.achieved_goal, &o.desired_goal]);
        parts.flat_map(|a| a.iter().copied()).collect::<Vec<f32>>()
    });
    Trace {
        run: format!("{algorithm}, {}", sharing.replace('\n', ", ")),
        history,
        steps: episode.actions.len(),
        actions_crc: crc(episode.actions.iter().flat_map(|a| a.0.iter().copied())),
        observations_crc: crc(observations),
        first_action: episode.actions[0].0.clone(),
        params_crc: Some(crc(params.into_iter())),
        policy_crc: Some(policy_crc),
    }
}

fn traces() -> Vec<Trace> {
    [
        ("maddpg", "mode = \"parameters\"\ntarget = \"actors\""),
        ("matd3", "mode = \"parameters\"\ntarget = \"both\""),
        ("masac", "mode = \"gradients\"\ntarget = \"critics\""),
    ]
    .into_iter()
    .map(|(algorithm, sharing)| trace(algorithm, sharing))
    .collect()
}

#[test]
fn every_algorithm_repeats_its_recorded_run_bit_for_bit() {
    let cpu = cpu();
    let mut golden: Golden = serde_json::from_slice(&std::fs::read(GOLDEN).unwrap()).unwrap();
    let mode = std::env::var("FMSR_GOLDEN").unwrap_or_default();
    let missing = !golden.recordings.iter().any(|r| r.cpu == cpu);
    if mode == "record" || (mode == "record-if-missing" && missing) {
        let commit = std::env::var("FMSR_GOLDEN_COMMIT").expect("FMSR_GOLDEN_COMMIT: the commit being recorded");
        let equivalent_to = golden.recordings.iter().find(|r| r.cpu == cpu).map(|r| r.equivalent_to.clone());
        golden.recordings.retain(|r| r.cpu != cpu);
        let recording =
            Recording { cpu: cpu.clone(), commit, equivalent_to: equivalent_to.unwrap_or_default(), traces: traces() };
        golden.recordings.push(recording);
        std::fs::write(GOLDEN, serde_json::to_string_pretty(&golden).unwrap() + "\n").unwrap();
        eprintln!("golden: RECORDED this CPU's traces (`{cpu}`) in {GOLDEN}; later runs compare against them");
        return;
    }
    if mode == "record-if-missing" {
        eprintln!("golden: {GOLDEN} has a recording for this CPU (`{cpu}`): nothing recorded");
        return;
    }
    let Some(recording) = golden.recordings.iter().find(|r| r.cpu == cpu) else {
        let known: Vec<&str> = golden.recordings.iter().map(|r| r.cpu.as_str()).collect();
        panic!(
            "{GOLDEN} holds recordings of {known:?}, none of this CPU's `{cpu}`: nothing to compare. Record one at a \
             commit whose numbers are the reference: FMSR_GOLDEN=record FMSR_GOLDEN_COMMIT=<commit> cargo test --test integration -- golden::"
        );
    };
    let now = traces();
    assert_eq!(now.len(), recording.traces.len());
    for (now, then) in now.iter().zip(&recording.traces) {
        assert_eq!(now.run, then.run, "the runs of the golden test changed: record anew");
        assert_eq!(now.history.len(), then.history.len(), "{}: epochs", now.run);
        for (epoch, (a, b)) in now.history.iter().zip(&then.history).enumerate() {
            let (Value::Object(a), Value::Object(b)) = (a, b) else {
                panic!("{}: epoch {epoch} is not a map", now.run)
            };
            for (key, recorded) in b {
                assert_eq!(
                    a.get(key),
                    Some(recorded),
                    "{}: epoch {epoch}'s `{key}` differs from the recording",
                    now.run
                );
            }
        }
        // The hashes are compared where the recording has them.
        let episode = |t: &Trace, hashes: bool| Trace {
            history: Vec::new(),
            params_crc: t.params_crc.filter(|_| hashes),
            policy_crc: t.policy_crc.filter(|_| hashes),
            ..t.clone()
        };
        let hashes = then.params_crc.is_some();
        assert_eq!(
            episode(now, hashes),
            episode(then, hashes),
            "{}: the greedy episode or the final parameters differ from the recording",
            now.run
        );
    }
}
