//! The replay buffer's guarantees.

use super::*;
use crate::agent::ActorView;
use crate::spec::AgentSpec;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

const T: usize = 5;

fn spec() -> EnvSpec {
    let agent = |n: &str, s: Vec<usize>, d| AgentSpec { name: n.into(), action_slots: s, local_obs_dim: d };
    EnvSpec {
        agents: vec![agent("a", vec![0], 1), agent("b", vec![1, 2], 2)],
        action_dim: 3,
        obs_dim: 2,
        goal_dim: 1,
        episode_len: T,
        features: vec!["f".into()],
        reward_range: (-10.0, 0.0),
    }
}

/// Episode `e`: global observation (e, t), achieved goal 10 e + t, desired
/// goal -1 - e, action (t, e, -t), feature t mod 2.
fn episode(e: usize) -> Episode {
    let ef = e as f32;
    let obs = |t: usize| Observation {
        global: vec![ef, t as f32],
        locals: vec![vec![t as f32], vec![ef, t as f32]],
        achieved_goal: vec![10.0 * ef + t as f32],
        desired_goal: vec![-1.0 - ef],
    };
    Episode {
        observations: (0..=T).map(obs).collect(),
        actions: (0..T).map(|t| JointAction(vec![t as f32, ef, -(t as f32)])).collect(),
        infos: (0..T).map(|t| StepInfo { features: vec![(t % 2) as f32], ..StepInfo::default() }).collect(),
        log_probs: Vec::new(),
    }
}

proptest::proptest! {
    // Guards resuming from the replay log: the last `min(total, capacity)`
    // episodes put back in place give the buffer the uninterrupted run had.
    #[test]
    fn restoring_the_log_rebuilds_the_stored_buffer(capacity in 1usize..6, total in 0usize..15) {
        let spec = spec();
        let mut stored = ReplayBuffer::new(&spec, capacity * T).unwrap();
        (0..total).for_each(|e| stored.store(&episode(e)).unwrap());
        let kept: Vec<Episode> = (total.saturating_sub(capacity)..total).map(episode).collect();
        let mut restored = ReplayBuffer::new(&spec, capacity * T).unwrap();
        restored.restore_log(total as u64, &kept).unwrap();
        proptest::prop_assert_eq!(&restored, &stored);
        restored.store(&episode(99)).unwrap();
        stored.store(&episode(99)).unwrap();
        proptest::prop_assert_eq!(&restored, &stored);
        let mut short = ReplayBuffer::new(&spec, capacity * T).unwrap();
        proptest::prop_assert!(short.restore_log(total as u64 + 1, &kept).is_err() || total >= capacity);
        proptest::prop_assert!(short.restore_log(total as u64, &kept[..kept.len().saturating_sub(1)]).is_err() || kept.is_empty());
    }
}

#[test]
fn her_future_relabels_with_later_achieved_goals_and_recomputed_rewards() {
    let spec = spec();
    let layout = ObservationLayout::new(spec.clone(), vec![vec![1], vec![0]]).unwrap();
    let mut buffer = ReplayBuffer::new(&spec, 100).unwrap();
    for e in 0..4 {
        buffer.store(&episode(e)).unwrap();
    }
    let reward = |a: &[f32], d: &[f32]| -(a[0] - d[0]).abs();
    let agent_rewards = |task: f32, phi: &[f32], out: &mut [f32]| {
        out[0] = task;
        out[1] = task + phi[0];
    };
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let b = buffer.sample(8000, &HerConfig::default(), &layout, &mut rng, &reward, &agent_rewards).unwrap();
    let mut relabelled = 0;
    // counts[t][t']: samples at step t relabelled with the goal achieved at t'.
    let mut counts = [[0usize; T + 1]; T];
    for i in 0..b.size {
        let (e, t) = (b.obs[2 * i] as usize, b.obs[2 * i + 1] as usize);
        assert_eq!(b.next_obs[2 * i + 1] as usize, t + 1);
        let goal = b.goals[i];
        if goal >= 0.0 {
            // a future achieved goal 10 e + t' with t < t' <= T
            let future = goal as usize - 10 * e;
            assert!(future > t && future <= T, "sample ({e}, {t}) relabelled with t' = {future}");
            counts[t][future] += 1;
            relabelled += 1;
        } else {
            assert_eq!(goal, -1.0 - e as f32);
        }
        let achieved_next = 10.0 * e as f32 + (t + 1) as f32;
        assert_eq!(b.task_rewards[i], reward(&[achieved_next], &[goal]));
        assert_eq!(b.rewards[0][i], b.task_rewards[i]);
        assert_eq!(b.rewards[1][i], b.task_rewards[i] + (t % 2) as f32);
        assert_eq!(&b.actions[3 * i..3 * i + 3], &[t as f32, e as f32, -(t as f32)]);
        // agent a: local t, goal, then b's previous action (zeros at t = 0)
        let prev = if t == 0 { [0.0, 0.0] } else { [e as f32, -((t - 1) as f32)] };
        assert_eq!(&b.actor_inputs[0][4 * i..4 * i + 4], &[t as f32, goal, prev[0], prev[1]]);
        assert_eq!(&b.next_actor_inputs[0][4 * i..4 * i + 4], &[(t + 1) as f32, goal, e as f32, -(t as f32)]);
        // agent b: local (e, t), goal, then a's previous action
        let prev_a = if t == 0 { 0.0 } else { (t - 1) as f32 };
        assert_eq!(&b.actor_inputs[1][4 * i..4 * i + 4], &[e as f32, t as f32, goal, prev_a]);
    }
    let frac = relabelled as f64 / b.size as f64;
    assert!((frac - 0.8).abs() < 0.02, "relabelled fraction {frac}");
    // The "future" strategy draws t' uniformly from t+1..=T (HER baselines'
    // `t + 1 + uniform(T - t)`): each count lies within 4.5 standard
    // deviations of its binomial mean, so a draw that favoured the episode's
    // end, or skipped t+1 or T, fails.
    for (t, row) in counts.iter().enumerate() {
        let n: usize = row.iter().sum();
        let p = 1.0 / (T - t) as f64;
        let (mean, sd) = (n as f64 * p, (n as f64 * p * (1.0 - p)).sqrt());
        for (future, &c) in row.iter().enumerate().skip(t + 1) {
            assert!((c as f64 - mean).abs() <= 4.5 * sd.max(1.0), "t = {t}: t' = {future} drawn {c} times of {n}");
        }
    }
}

// Guards the normalisers' sample of HER baselines' `store_episode`: the
// latest episodes only, the newest first after the ring has wrapped.
#[test]
fn sampling_the_latest_episodes_draws_only_them() {
    let spec = spec();
    let layout = ObservationLayout::new(spec.clone(), vec![vec![1], vec![0]]).unwrap();
    let mut buffer = ReplayBuffer::new(&spec, 3 * T).unwrap();
    for e in 0..5 {
        buffer.store(&episode(e)).unwrap();
    }
    let reward = |_: &[f32], _: &[f32]| 0.0;
    let agent_rewards = |_: f32, _: &[f32], out: &mut [f32]| out.fill(0.0);
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let her = HerConfig::default();
    for (latest, allowed) in [(1, vec![4]), (2, vec![3, 4]), (3, vec![2, 3, 4])] {
        let b = buffer.sample_latest(latest, 600, &her, &layout, &mut rng, &reward, &agent_rewards).unwrap();
        let seen: std::collections::BTreeSet<usize> = (0..b.size).map(|i| b.obs[2 * i] as usize).collect();
        assert_eq!(seen.into_iter().collect::<Vec<_>>(), allowed, "latest {latest}");
    }
    for latest in [0, 4] {
        assert!(buffer.sample_latest(latest, 1, &her, &layout, &mut rng, &reward, &agent_rewards).is_err());
    }
}

// Guards the `global` actor view (an ablation): every actor's
// sampled input starts with the global observation of its step (its
// local one under the default view, tested above), then the goal and the
// neighbours' previous actions.
#[test]
fn actors_of_the_global_view_sample_the_global_observation() {
    let spec = spec();
    let layout = ObservationLayout::new(spec.clone(), vec![vec![1], vec![0]]).unwrap().with_view(ActorView::Global);
    assert_eq!((layout.actor_input_dim(0), layout.actor_input_dim(1)), (2 + 1 + 2, 2 + 1 + 1));
    let mut buffer = ReplayBuffer::new(&spec, 100).unwrap();
    for e in 0..4 {
        buffer.store(&episode(e)).unwrap();
    }
    let reward = |a: &[f32], d: &[f32]| -(a[0] - d[0]).abs();
    let agent_rewards = |task: f32, _: &[f32], out: &mut [f32]| out.fill(task);
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let b = buffer.sample(200, &HerConfig::default(), &layout, &mut rng, &reward, &agent_rewards).unwrap();
    for i in 0..b.size {
        let (obs, next) = (&b.obs[2 * i..2 * i + 2], &b.next_obs[2 * i..2 * i + 2]);
        assert_eq!(&b.actor_inputs[0][5 * i..5 * i + 3], &[obs[0], obs[1], b.goals[i]]);
        assert_eq!(&b.next_actor_inputs[0][5 * i..5 * i + 3], &[next[0], next[1], b.goals[i]]);
        assert_eq!(&b.actor_inputs[1][4 * i..4 * i + 3], &[obs[0], obs[1], b.goals[i]]);
    }
    let o = episode(2).observations[3].clone();
    let inputs = layout.actor_inputs(&o, &JointAction(vec![0.5, 0.25, 0.125]));
    assert_eq!(inputs, vec![vec![2.0, 3.0, -3.0, 0.25, 0.125], vec![2.0, 3.0, -3.0, 0.5]]);
}

#[test]
fn overwrites_oldest_when_full_and_checks_shapes() {
    let spec = spec();
    let mut buffer = ReplayBuffer::new(&spec, 2 * T).unwrap();
    assert_eq!(buffer.capacity_episodes(), 2);
    for e in 0..3 {
        buffer.store(&episode(e)).unwrap();
    }
    assert_eq!(buffer.episodes(), 2);
    let layout = ObservationLayout::new(spec.clone(), vec![vec![], vec![]]).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let b = buffer.sample(200, &HerConfig { replay_k: 0 }, &layout, &mut rng, &|_, _| 0.0, &|_, _, _| {}).unwrap();
    assert!(b.obs.chunks(2).all(|o| o[0] != 0.0), "episode 0 was overwritten");
    let mut bad = episode(0);
    bad.actions.pop();
    assert!(matches!(buffer.store(&bad), Err(CoreError::EpisodeShape { what: "actions", .. })));
    let empty = ReplayBuffer::new(&spec, 10).unwrap();
    assert!(matches!(
        empty.sample(1, &HerConfig::default(), &layout, &mut rng, &|_, _| 0.0, &|_, _, _| {}),
        Err(CoreError::EmptyReplay)
    ));
}

/// Reads a buffer the way learners restore it: postcard, then the consistency check.
fn decode(bytes: &[u8]) -> Result<ReplayBuffer, String> {
    let buffer: ReplayBuffer = postcard::from_bytes(bytes).map_err(|e| e.to_string())?;
    buffer.check_consistency().map_err(|e| e.to_string())?;
    Ok(buffer)
}

// Guards the serde round trip of checkpoints and the consistency check behind it.
#[test]
fn serde_round_trip_and_inconsistent_buffers_rejected() {
    let spec = spec();
    let mut buffer = ReplayBuffer::new(&spec, 3 * T).unwrap();
    for e in 0..2 {
        buffer.store(&episode(e)).unwrap();
    }
    let bytes = postcard::to_stdvec(&buffer).unwrap();
    assert_eq!(decode(&bytes).unwrap(), buffer);
    assert!(decode(&bytes[..bytes.len() - 3]).is_err());
    assert!(buffer.is_compatible(&spec));
    let mut short = buffer.clone();
    short.actions.truncate(5);
    assert!(short.check_consistency().is_err());
    let mut huge = buffer;
    huge.len = usize::MAX;
    huge.capacity = usize::MAX;
    assert!(huge.check_consistency().is_err(), "overflowing sizes are errors");
}

/// Cases per fuzz property: small in `cargo test`, more with `FMSR_FUZZ_CASES`.
fn fuzz_cases() -> u32 {
    std::env::var("FMSR_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(256)
}

fn valid_bytes() -> Vec<u8> {
    let mut buffer = ReplayBuffer::new(&spec(), 100).unwrap();
    for e in 0..3 {
        buffer.store(&episode(e)).unwrap();
    }
    postcard::to_stdvec(&buffer).unwrap()
}

/// A buffer that reads back must also sample without panicking.
fn read_and_sample(bytes: &[u8]) {
    if let Ok(buffer) = decode(bytes)
        && buffer.is_compatible(&spec())
    {
        let layout = ObservationLayout::new(spec(), vec![vec![1], vec![0]]).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
        let _ = buffer.sample(8, &HerConfig::default(), &layout, &mut rng, &|_, _| 0.0, &|_, _, _| {});
    }
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(fuzz_cases()))]

    // Guards the replay reader of checkpoints (postcard + check_consistency): bit flips,
    // truncations and random bytes give an error or a consistent buffer,
    // never a panic or a huge allocation from a corrupted length field.
    #[test]
    fn corrupted_replay_bytes_never_panic(
        flips in proptest::collection::vec((0usize..10_000, 0u8..8), 1..4),
        cut in proptest::option::of(0usize..10_000),
        noise in proptest::collection::vec(proptest::num::u8::ANY, 0..256),
    ) {
        let good = valid_bytes();
        let mut bytes = good.clone();
        for (at, bit) in flips {
            let i = at % bytes.len();
            bytes[i] ^= 1 << bit;
        }
        if let Some(c) = cut {
            bytes.truncate(c % (good.len() + 1));
        }
        read_and_sample(&bytes);
        let mut random = good[..good.len().min(16)].to_vec();
        random.extend(&noise);
        read_and_sample(&random);
        read_and_sample(&noise);
    }
}
