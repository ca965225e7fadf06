//! Guards training on several processes (feature `mpi`).
//!
//! Run as a plain test (`cargo test --features mpi --test mpi`), this program
//! starts itself under `mpirun -np 2 --oversubscribe` and checks that:
//! - a 2-rank run learns TeamReach (MADDPG, Dense+FMSR+IS), and the ranks'
//!   parameters are identical after every update;
//! - `mpirun -np 2 fmsr train` trains the hand, writes every rank's files from
//!   rank 0, resumes with 2 ranks, and refuses to resume with 3 or with 1.
//!
//! Started by mpirun (as each rank), it runs the TeamReach part.

mod common;

use std::path::Path;
use std::process::{Command, Output};
use std::sync::Arc;

use fmsr::mpi::{Mpi, MpiCommunicator};
use fmsr::prelude::*;

fn main() {
    if fmsr::run::launched_with_several_ranks() {
        rank_main();
    } else {
        team_reach_learns_on_two_ranks();
        the_cli_trains_and_resumes_on_two_ranks();
        println!("mpi: all checks passed");
    }
}

fn mpirun(np: usize, program: &str, args: &[&str]) -> Output {
    Command::new("mpirun")
        .args(["-np", &np.to_string(), "--oversubscribe", program])
        .args(args)
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .env("RUST_BACKTRACE", "0")
        .output()
        .expect("mpirun (scripts/setup_mpi.sh installs it)")
}

fn text(out: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr))
}

fn team_reach_learns_on_two_ranks() {
    let me = std::env::current_exe().unwrap();
    let out = mpirun(2, me.to_str().unwrap(), &[]);
    let t = text(&out);
    assert!(out.status.success(), "{t}");
    let success: f64 = t
        .lines()
        .find_map(|l| l.strip_prefix("rank 0: test success "))
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or_else(|| panic!("no result in: {t}"));
    assert!(t.contains("rank 0: parameters identical after every update"), "{t}");
    assert!(success >= 0.9, "2-rank TeamReach test success {success}: {t}");
    println!("mpi: 2-rank TeamReach test success {success}");
}

/// MADDPG that checks after every update that all ranks hold the same parameters.
struct Checked {
    inner: Maddpg,
    comm: Arc<MpiCommunicator>,
    updates: usize,
}

impl Policy for Checked {
    type Error = NnError;

    fn num_agents(&self) -> usize {
        self.inner.num_agents()
    }

    fn act(&mut self, inputs: &[Vec<f32>], n: usize, mode: ActMode) -> Result<PolicyOutput, NnError> {
        self.inner.act(inputs, n, mode)
    }
}

impl Algorithm for Checked {
    fn store(&mut self, episode: &Episode) -> Result<(), NnError> {
        self.inner.store(episode)
    }

    fn update(&mut self, rewards: &dyn RewardModel) -> Result<UpdateStats, NnError> {
        let stats = self.inner.update(rewards)?;
        let mut params = Vec::new();
        for agent in 0..self.inner.num_agents() {
            let (actor, critic) = self.inner.params(agent)?;
            params.extend(actor);
            params.extend(critic);
        }
        let all = self.comm.all_gather(&params);
        let (mine, other) = all.split_at(params.len());
        let same = mine.iter().zip(other).all(|(a, b)| a.to_bits() == b.to_bits());
        assert!(same, "rank {}: parameters differ between the ranks after update {}", self.comm.rank(), self.updates);
        self.updates += 1;
        Ok(stats)
    }

    fn save_state(&self, include_storage: bool) -> Result<Vec<u8>, NnError> {
        self.inner.save_state(include_storage)
    }

    fn load_state(&mut self, bytes: &[u8]) -> Result<(), NnError> {
        self.inner.load_state(bytes)
    }

    fn storage_capacity(&self) -> usize {
        self.inner.storage_capacity()
    }

    fn restore_storage(&mut self, total: u64, episodes: &[Episode]) -> Result<(), NnError> {
        self.inner.restore_storage(total, episodes)
    }
}

fn rank_main() {
    let mpi = Mpi::init().unwrap();
    let comm = Arc::new(mpi.communicator());
    let method = Method::DenseFmsrIs;
    let config = common::trainer_config(method, 3, 10);
    let env = common::team_reach(method);
    let parts = common::parts(&env, method, 3, config.gamma_for(env.spec().episode_len))
        .with_communicator(Box::new(comm.clone()));
    let layout = parts.layout.clone();
    let learner = Checked { inner: Maddpg::new(parts, MaddpgConfig::new()).unwrap(), comm: comm.clone(), updates: 0 };
    let mut trainer = Trainer::new(config, env, learner, layout).unwrap().with_communicator(comm.clone()).unwrap();
    trainer.train(|_, _| Ok(())).unwrap();
    let last = trainer.history().last().unwrap();
    let rank = comm.rank();
    println!("rank {rank}: test success {}", last.success_rate);
    println!("rank {rank}: parameters identical after every update ({} updates)", trainer.algorithm().updates);
}

fn the_cli_trains_and_resumes_on_two_ranks() {
    let fmsr = env!("CARGO_BIN_EXE_fmsr");
    let tmp = tempfile::tempdir().unwrap();
    let config = tiny_config(tmp.path());
    let run = tmp.path().join("run");
    let run_s = run.to_str().unwrap();
    let out = mpirun(2, fmsr, &["train", "--config", config.to_str().unwrap(), "--out", run_s]);
    assert!(out.status.success(), "{}", text(&out));
    for f in ["checkpoint.bin", "checkpoint.replay", "checkpoint.worker1.e000001.bin", "checkpoint.worker1.replay"] {
        assert!(run.join(f).exists(), "{f} missing");
    }
    let metrics = |run: &Path| std::fs::read_to_string(run.join("metrics.jsonl")).unwrap().lines().count();
    assert_eq!(metrics(&run), 1);

    let out = mpirun(3, fmsr, &["train", "--out", run_s, "--resume", "--epochs", "2"]);
    assert!(!out.status.success());
    assert!(text(&out).contains("mpirun -np 2"), "{}", text(&out));
    let out = Command::new(fmsr).args(["train", "--out", run_s, "--resume", "--epochs", "2"]).output().unwrap();
    assert!(!out.status.success());
    assert!(text(&out).contains("mpirun -np 2"), "{}", text(&out));

    let out = mpirun(2, fmsr, &["train", "--out", run_s, "--resume", "--epochs", "2"]);
    assert!(out.status.success(), "{}", text(&out));
    assert_eq!(metrics(&run), 2);
    assert!(run.join("checkpoint.worker1.e000002.bin").exists());
    assert!(!run.join("checkpoint.worker1.e000001.bin").exists(), "a stale worker checkpoint was kept");
    println!("mpi: the CLI trains, resumes and refuses other rank counts");
}

/// The tiny config of the CLI tests with totals that split over 1, 2 and 3
/// ranks, so the rank count is what a resume checks.
fn tiny_config(dir: &Path) -> std::path::PathBuf {
    let text = common::tiny_config_text()
        .replace("episodes_per_cycle = 2", "episodes_per_cycle = 6")
        .replace("batch_size = 32", "batch_size = 48");
    let path = dir.join("tiny.toml");
    std::fs::write(&path, text).unwrap();
    path
}
