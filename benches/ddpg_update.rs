//! One joint DDPG update of the 6 Shadow Hand agents at the paper's sizes,
//! with the real shapes of the egg task (the actors' inputs and actions, the
//! critics' input, read from the environment and the paper config's graph;
//! 3 x 256 hidden layers, Adam), at batch 1024 (the paper's 4 x 256) and 256,
//! on one and on two threads, and action selection for one observation.
//!
//! Before criterion's timings it prints how far the update is from the
//! machine's limit, measured in the same run: the update's GEMM work in
//! GFLOP (counted from the shapes, [`update_flops`]), its time and achieved
//! GFLOP/s, and the GEMM ceiling, burn's matmul alone on the same layer
//! shapes (forward, input-gradient and weight-gradient products of every
//! layer), on one thread and on all cores; then the ratio.
//!
//! The networks live on `FMSR_DEVICE` (default `cpu`; `wgpu:0`, `wgpu:cpu`
//! or `vulkan:0` with the matching cargo feature, see `fmsr_nn::device`),
//! stacked as `FMSR_STACKING` says (`auto`, default; `per_agent`; `all`).
//! `FMSR_BENCH_CONFIG` names the experiment whose task and graph give the
//! shapes (default `configs/egg_dense_fmsr_is.toml`); the Shadow Hand model
//! must be fetched (`cargo run --release -- assets fetch`).
//!
//! On a device other than the CPU it first checks that three joint updates
//! there equal those on the CPU within float tolerance, and prints the outcome.
//!
//! Run with `cargo bench --bench ddpg_update`. With `FMSR_PYTORCH_REFERENCE=1`
//! it also runs `scripts/pytorch_reference/run.sh` (a venv with the PyTorch
//! CPU wheel, timing the same update in Python) and prints our time / PyTorch
//! time measured in the same run.

use std::hint::black_box;
use std::process::Command;
use std::sync::OnceLock;
use std::time::Instant;

use burn::tensor::{Tensor, TensorData};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use fmsr::experiment::ExperimentConfig;
use fmsr_core::Env;
use fmsr_core::agent::{Batch, ObservationLayout};
use fmsr_core::policy::{ActMode, Policy};
use fmsr_core::replay::ReplayConfig;
use fmsr_nn::{LearnerParts, Maddpg, MaddpgConfig, NetworkConfig, Stacking};

/// The paper's batch first: its target is at 1024, and a GPU lease's time
/// limit that ends the bench in a later shape's first use then loses 256,
/// measured in every lease so far (in one lease 1024 came second and was not
/// timed).
const BATCHES: [usize; 2] = [1024, 256];
const HIDDEN: usize = 256;
const LAYERS: usize = 3;

/// The egg task's observation layout: the agents, their local views and
/// their graph neighbours, as a run of the paper's config builds it.
fn layout() -> ObservationLayout {
    static LAYOUT: OnceLock<ObservationLayout> = OnceLock::new();
    LAYOUT
        .get_or_init(|| {
            let path = std::env::var_os("FMSR_BENCH_CONFIG").map_or_else(
                || std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/egg_dense_fmsr_is.toml"),
                std::path::PathBuf::from,
            );
            let config = ExperimentConfig::load(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            let env = config
                .env_config()
                .init()
                .unwrap_or_else(|e| panic!("the Shadow Hand (`cargo run --release -- assets fetch`): {e}"));
            let spec = env.spec().clone();
            let graph = config.graph.build(&spec).expect("the config's graph");
            ObservationLayout::from_graph(spec, &graph).expect("a valid layout")
        })
        .clone()
}

/// Multiply-adds per row of one linear stack `inputs -> hidden^layers -> outputs`.
fn mlp_macs(inputs: usize, outputs: usize) -> usize {
    inputs * HIDDEN + (LAYERS - 1) * HIDDEN * HIDDEN + HIDDEN * outputs
}

/// The GEMM floating-point operations of one joint MADDPG update at batch
/// `n`: with `A` the actors' and `C` the critics' multiply-adds per row,
/// the critic step runs the target actors and target critics forward (`A +
/// C`), the online critics forward and backward (weights `C`, inputs `C`
/// less their first layer's), the actor step the actors forward, the critics
/// forward at the actors' actions and back to those actions (inputs `C`; the
/// critics' weights take no gradient there) and the actors backward (weights
/// `A`, inputs `A` less their first layer's): `4A + 6C` less the two first
/// layers' input products, two FLOPs a multiply-add.
fn update_flops(layout: &ObservationLayout, n: usize) -> f64 {
    let spec = layout.spec();
    let critic_in = spec.obs_dim + spec.goal_dim + spec.action_dim;
    let (mut actors, mut actor_first) = (0, 0);
    for (i, agent) in spec.agents.iter().enumerate() {
        actors += mlp_macs(layout.actor_input_dim(i), agent.action_slots.len());
        actor_first += layout.actor_input_dim(i) * HIDDEN;
    }
    let na = spec.agents.len();
    let critics = na * mlp_macs(critic_in, 1);
    let macs = 4 * actors - actor_first + 6 * critics - na * critic_in * HIDDEN;
    2.0 * macs as f64 * n as f64
}

/// Every `(m, k, n)` product of one forward and backward pass of the
/// networks at batch `rows`: per layer `in -> out`, the forward `[rows, in] x
/// [in, out]`, the input gradient `[rows, out] x [out, in]` and the weight
/// gradient `[in, rows] x [rows, out]`.
fn gemm_shapes(layout: &ObservationLayout, rows: usize) -> Vec<(usize, usize, usize)> {
    let spec = layout.spec();
    let critic_in = spec.obs_dim + spec.goal_dim + spec.action_dim;
    let mut stacks: Vec<(usize, usize)> =
        (0..spec.agents.len()).map(|i| (layout.actor_input_dim(i), spec.agents[i].action_slots.len())).collect();
    stacks.extend(std::iter::repeat_n((critic_in, 1), spec.agents.len()));
    let mut shapes = Vec::new();
    for (inputs, outputs) in stacks {
        let widths: Vec<usize> =
            std::iter::once(inputs).chain(std::iter::repeat_n(HIDDEN, LAYERS)).chain([outputs]).collect();
        for w in widths.windows(2) {
            let (i, o) = (w[0], w[1]);
            shapes.extend([(rows, i, o), (rows, o, i), (i, rows, o)]);
        }
    }
    shapes
}

/// GFLOP/s of burn's matmul alone over `shapes` on the flex CPU backend, on
/// `threads` OS threads at once, each running every product in a one-thread
/// rayon pool (as the agents' groups run on `networks.threads`): the best of
/// five passes, each product's inputs made beforehand.
fn gemm_ceiling(shapes: &[(usize, usize, usize)], threads: usize) -> f64 {
    let flops: f64 = shapes.iter().map(|&(m, k, n)| 2.0 * (m * k * n) as f64).sum();
    let barrier = std::sync::Barrier::new(threads);
    let best = std::thread::scope(|scope| {
        let workers: Vec<_> = (0..threads)
            .map(|t| {
                let barrier = &barrier;
                scope.spawn(move || {
                    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a one-thread pool");
                    pool.install(|| {
                        let device = fmsr_nn::Device::flex();
                        let pairs: Vec<(Tensor<2>, Tensor<2>)> = shapes
                            .iter()
                            .enumerate()
                            .map(|(s, &(m, k, n))| {
                                let salt = 1000 * t + s;
                                let a = Tensor::<2>::from_data(TensorData::new(values(m * k, salt), [m, k]), &device);
                                let b =
                                    Tensor::<2>::from_data(TensorData::new(values(k * n, salt + 500), [k, n]), &device);
                                (a, b)
                            })
                            .collect();
                        (0..5)
                            .map(|_| {
                                barrier.wait();
                                let start = Instant::now();
                                for (a, b) in &pairs {
                                    black_box(a.clone().matmul(b.clone()).into_data());
                                }
                                start.elapsed().as_secs_f64()
                            })
                            .collect::<Vec<f64>>()
                    })
                })
            })
            .collect();
        let times: Vec<Vec<f64>> = workers.into_iter().map(|w| w.join().expect("a GEMM thread")).collect();
        // A pass ends when its slowest thread does.
        (0..5).map(|p| times.iter().map(|t| t[p]).fold(0.0, f64::max)).fold(f64::INFINITY, f64::min)
    });
    threads as f64 * flops / best / 1e9
}

/// The update's time and GFLOP/s at batch `n` with `threads` agent threads,
/// the median of `iters` updates after a warm-up.
fn update_rate(n: usize, threads: usize, iters: usize) -> (f64, f64) {
    let layout = layout();
    let b = batch(&layout, n);
    let mut l = learner(threads);
    for _ in 0..3 {
        l.learn_batch(&b, &BOUNDS).expect("learn");
    }
    let mut times: Vec<f64> = (0..iters)
        .map(|_| {
            let start = Instant::now();
            black_box(l.learn_batch(&b, &BOUNDS).expect("learn"));
            start.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    let median = times[iters / 2];
    (median, update_flops(&layout, n) / median / 1e9)
}

/// How far the update is from the limit: its GFLOP/s against the GEMM
/// ceiling on the same shapes, on one thread (one rayon thread for the
/// kernels, one agent thread) and on two (two agent threads; the ceiling
/// two threads of GEMM at once), measured here.
fn limits(_c: &mut Criterion) {
    if std::env::var("FMSR_DEVICE").is_ok_and(|d| d != "cpu") {
        return; // the ceiling is the CPU's
    }
    let layout = layout();
    let spec = layout.spec();
    let inputs: Vec<usize> = (0..spec.agents.len()).map(|i| layout.actor_input_dim(i)).collect();
    println!(
        "shapes: actor inputs {inputs:?}, critic input {}, {LAYERS} x {HIDDEN} hidden; one update at batch 1024 is {:.2} GFLOP of GEMM",
        spec.obs_dim + spec.goal_dim + spec.action_dim,
        update_flops(&layout, 1024) / 1e9
    );
    let cores = std::thread::available_parallelism().map_or(1, std::num::NonZero::get);
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("a one-thread pool");
    let mut defaults = Vec::new();
    for n in BATCHES {
        let shapes = gemm_shapes(&layout, n);
        for threads in [1, 2] {
            let (secs, rate) =
                if threads == 1 { one.install(|| update_rate(n, 1, 15)) } else { update_rate(n, threads, 15) };
            let ceiling = gemm_ceiling(&shapes, threads);
            defaults.push(((n, threads), secs, ceiling));
            println!(
                "joint update, batch {n}, {threads} thread(s) ({cores} cores): {:.1} ms, {rate:.1} GFLOP/s; GEMM ceiling \
                 on the same shapes {ceiling:.1} GFLOP/s; update / ceiling = {:.2}",
                secs * 1e3,
                rate / ceiling
            );
        }
    }
    // The same updates with the `fmsr` binary's allocator settings (glibc's
    // freed memory kept for the next step, fmsr::allocator), set from here on:
    // criterion's timings below run with them, as training does.
    if !fmsr::allocator::keep_freed_memory() {
        println!("allocator: glibc's defaults (no glibc here to set)");
        return;
    }
    for ((n, threads), default, ceiling) in defaults {
        let (secs, rate) =
            if threads == 1 { one.install(|| update_rate(n, 1, 15)) } else { update_rate(n, threads, 15) };
        println!(
            "joint update, batch {n}, {threads} thread(s), freed memory kept (fmsr::allocator): {:.1} ms, \
             {rate:.1} GFLOP/s; kept / glibc defaults = {:.2}; update / ceiling = {:.2}",
            secs * 1e3,
            secs / default,
            rate / ceiling
        );
    }
}

/// Deterministic pseudo-random values in [-1, 1).
fn values(len: usize, salt: usize) -> Vec<f32> {
    let mut x = (salt as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
    (0..len)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 40) as f32 / (1u64 << 23) as f32 - 1.0
        })
        .collect()
}

fn batch(layout: &ObservationLayout, n: usize) -> Batch {
    let spec = layout.spec();
    let na = spec.num_agents();
    Batch {
        size: n,
        obs: values(n * spec.obs_dim, 1),
        next_obs: values(n * spec.obs_dim, 2),
        goals: values(n * spec.goal_dim, 3),
        actions: values(n * spec.action_dim, 4),
        actor_inputs: (0..na).map(|i| values(n * layout.actor_input_dim(i), 10 + i)).collect(),
        next_actor_inputs: (0..na).map(|i| values(n * layout.actor_input_dim(i), 20 + i)).collect(),
        task_rewards: values(n, 5),
        features: values(n * 2, 6),
        rewards: (0..na).map(|i| values(n, 30 + i).into_iter().map(|r| r - 1.0).collect()).collect(),
    }
}

/// The device named by `FMSR_DEVICE` (default `cpu`).
fn device() -> fmsr_nn::Device {
    let name = std::env::var("FMSR_DEVICE").unwrap_or_else(|_| "cpu".into());
    name.parse::<fmsr_nn::DeviceSpec>().and_then(|d| d.device()).unwrap_or_else(|e| panic!("FMSR_DEVICE: {e}"))
}

/// The agent stacking named by `FMSR_STACKING` (default `auto`).
fn stacking() -> Stacking {
    let name = std::env::var("FMSR_STACKING").unwrap_or_else(|_| "auto".into());
    serde_json::from_value(serde_json::Value::String(name)).unwrap_or_else(|e| panic!("FMSR_STACKING: {e}"))
}

fn learner(threads: usize) -> Maddpg {
    learner_on(threads, device(), stacking())
}

fn learner_on(threads: usize, device: fmsr_nn::Device, stacking: Stacking) -> Maddpg {
    let net = NetworkConfig::new().with_threads(threads).with_stacking(stacking);
    let parts = LearnerParts::new(layout(), net, ReplayConfig::default(), 0.99).with_device(device);
    Maddpg::new(parts, MaddpgConfig::new()).expect("a valid learner")
}

/// Losses of three joint updates at batch 256 and the final parameters of every agent.
fn three_updates(device: fmsr_nn::Device, stacking: Stacking) -> (Vec<f32>, Vec<f32>) {
    let layout = layout();
    let mut l = learner_on(1, device, stacking);
    let mut losses = Vec::new();
    for step in 0..3 {
        let mut b = batch(&layout, 256);
        b.obs = values(b.obs.len(), 100 + step);
        let (c, a) = l.learn_batch(&b, &BOUNDS).expect("learn");
        losses.extend(c.into_iter().chain(a));
    }
    let params = (0..layout.spec().num_agents()).flat_map(|i| {
        let (a, c) = l.params(i).expect("params");
        a.into_iter().chain(c)
    });
    (losses, params.collect())
}

/// The largest `|a - b| / (atol + rtol |b|)`: at most 1 is within tolerance.
fn worst(a: &[f32], b: &[f32], atol: f32, rtol: f32) -> f32 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(x, y)| (x - y).abs() / (atol + rtol * y.abs())).fold(0.0, f32::max)
}

/// Before timing a device other than the CPU: three joint updates on it
/// against burn's flex CPU backend, one stack per agent, with the tolerances
/// of tests/gpu.rs (losses 1e-4 relative; parameters 1e-3 relative + 2e-3).
/// Prints the outcome; a device that computes something else is still timed.
/// `FMSR_PARITY=0` skips the check, `FMSR_PARITY=1` runs it on the CPU too
/// (with `FMSR_STACKING=all`: the stacked network against one per agent).
fn parity(_c: &mut Criterion) {
    let on_cpu = std::env::var("FMSR_DEVICE").map_or(true, |d| d == "cpu");
    match std::env::var("FMSR_PARITY").as_deref() {
        Ok("0") => return,
        Ok("1") => {}
        _ if on_cpu => return,
        _ => {}
    }
    let (dev_losses, dev_params) = three_updates(device(), stacking());
    let (cpu_losses, cpu_params) = three_updates(fmsr_nn::Device::flex(), Stacking::PerAgent);
    let (l, p) = (worst(&dev_losses, &cpu_losses, 1e-5, 1e-4), worst(&dev_params, &cpu_params, 2e-3, 1e-3));
    let verdict = if l <= 1.0 && p <= 1.0 { "equal within tolerance" } else { "DIFFERENT" };
    println!(
        "parity with the CPU, three joint updates at batch 256: {verdict} (losses {l:.3}, parameters {p:.3}; 1 = tolerance)"
    );
}

/// Q-target bounds of the 6 agents (wide: nothing is clipped).
const BOUNDS: [(f32, f32); 6] = [(-100.0, 0.0); 6];

fn joint_update(c: &mut Criterion) {
    let layout = layout();
    for n in BATCHES {
        let b = batch(&layout, n);
        let mut group = c.benchmark_group(format!("ddpg_joint_update_6_agents_b{n}_3x256"));
        group.sample_size(10);
        group.throughput(Throughput::Elements(1));
        for threads in [1, 2] {
            let mut l = learner(threads);
            warm_up(&format!("batch {n}, {threads} thread(s)"), || drop(l.learn_batch(&b, &BOUNDS).expect("learn")));
            group.bench_function(format!("threads_{threads}"), |bench| {
                bench.iter(|| black_box(l.learn_batch(black_box(&b), &BOUNDS).expect("learn")));
            });
        }
        group.finish();
    }

    let mut l = learner(2);
    let inputs: Vec<Vec<f32>> = (0..6).map(|i| values(layout.actor_input_dim(i), 40 + i)).collect();
    warm_up("action selection", || drop(l.act(&inputs, 1, ActMode::Evaluate).expect("act")));
    c.bench_function("ddpg_act_6_agents_one_observation", |bench| {
        bench.iter(|| black_box(l.act(black_box(&inputs), 1, ActMode::Evaluate).expect("act")));
    });
}

/// Untimed calls before criterion's own warm-up, until the shape is warm: at
/// least three, then on until a call is within 1.5x the fastest so far (for at
/// most five minutes), and prints how many it took. On a GPU the first use of
/// each shape compiles and tunes kernels, which took minutes at batch 1024 on
/// an H200 and fell into criterion's samples (a median of 916 ms over a range
/// of 24 ms to 2.7 s), and three calls were not enough there (the bench's
/// 200 s ran out at batch 1024). Whether the tuning goes on past the first
/// call or the first call alone took that long was not seen: the printed line
/// says. On the CPU three calls are enough.
fn warm_up(what: &str, mut f: impl FnMut()) {
    const LIMIT_S: f64 = 300.0;
    let start = Instant::now();
    let (mut calls, mut best, mut last) = (0usize, f64::INFINITY, f64::INFINITY);
    while calls < 3 || (last > 1.5 * best && start.elapsed().as_secs_f64() < LIMIT_S) {
        let t = Instant::now();
        f();
        last = t.elapsed().as_secs_f64();
        best = best.min(last);
        calls += 1;
    }
    println!(
        "warm-up {what}: {calls} untimed calls in {:.1} s (the last {:.2} ms, the fastest {:.2} ms)",
        start.elapsed().as_secs_f64(),
        last * 1e3,
        best * 1e3
    );
}

/// Our updates/s over `iters` joint updates after a warm-up.
fn our_rate(threads: usize, iters: usize) -> f64 {
    let layout = layout();
    let b = batch(&layout, 256);
    let mut l = learner(threads);
    for _ in 0..3 {
        l.learn_batch(&b, &BOUNDS).expect("learn");
    }
    let start = Instant::now();
    for _ in 0..iters {
        black_box(l.learn_batch(&b, &BOUNDS).expect("learn"));
    }
    iters as f64 / start.elapsed().as_secs_f64()
}

fn pytorch_reference(_c: &mut Criterion) {
    if std::env::var("FMSR_PYTORCH_REFERENCE").as_deref() != Ok("1") {
        return;
    }
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/scripts/pytorch_reference/run.sh");
    let layout = layout();
    let inputs: Vec<String> = (0..layout.spec().num_agents()).map(|i| layout.actor_input_dim(i).to_string()).collect();
    let out = match Command::new("bash").arg(script).env("FMSR_ACTOR_INPUTS", inputs.join(",")).output() {
        Ok(out) if out.status.success() => out,
        Ok(out) => {
            eprintln!("pytorch reference failed ({}):\n{}", out.status, String::from_utf8_lossy(&out.stderr));
            return;
        }
        Err(e) => {
            eprintln!("could not run {script}: {e}");
            return;
        }
    };
    let stdout = String::from_utf8_lossy(&out.stdout);
    print!("{stdout}");
    // Lines `updates/s threads=T: X` from update.py.
    for threads in [1, 2] {
        let key = format!("updates/s threads={threads}:");
        let torch =
            stdout.lines().find_map(|l| l.strip_prefix(key.as_str())).and_then(|v| v.trim().parse::<f64>().ok());
        let ours = our_rate(threads, 30);
        match torch {
            Some(torch) => println!(
                "joint update, {threads} thread(s): fmsr-nn {ours:.2} updates/s ({:.1} ms), PyTorch {torch:.2} updates/s ({:.1} ms); \
                 our time / PyTorch time = {:.2}",
                1e3 / ours,
                1e3 / torch,
                torch / ours
            ),
            None => println!("joint update, {threads} thread(s): fmsr-nn {ours:.2} updates/s; no PyTorch number"),
        }
    }
}

criterion_group! {
    name = benches;
    // No plots: criterion's plotters backend needs system fonts that CI images may lack.
    config = Criterion::default().without_plots();
    targets = parity, limits, joint_update, pytorch_reference
}
criterion_main!(benches);
