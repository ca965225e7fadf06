//! Guards the physics of the rapier Shadow Hand against the MuJoCo 3.17
//! numbers of the same model (measured with the `mujoco` wheel on the same
//! files): the block rests on the palm at mid-range controls at 0.1661 m (the
//! block/egg band is 0.166-0.171 m); position servos track their targets
//! (MuJoCo: mean |q - ctrl| 0.057 rad after 1 s at a = +-0.5) with each joint
//! moving the right way (at least a quarter of the target change; MuJoCo's
//! weakest, LFJ4 and THJ3, reach about half) and the distal J0 following J1 with the tendon's sign;
//! touch sensors under the resting block fire and those on the backs of the
//! fingers do not; random actions for 4 s stay finite; the same seed gives the
//! same trajectory; the contact read-out is consistent.

use fmsr_core::spec::JointAction;
use fmsr_core::{ContactReadout, Env};
use fmsr_envs::shadow_hand::model::{ACTUATORS, HAND_JOINTS};
use fmsr_envs::shadow_hand::{
    HandObject, HandPhysics, RapierHand, RapierSettings, ShadowHandConfig, fetch_hand_assets, load_rapier_model,
};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The physics alone, at the env's default settings.
fn hand() -> RapierHand {
    hand_with(ShadowHandConfig::default().rapier)
}

/// The physics alone, with `settings`.
fn hand_with(settings: RapierSettings) -> RapierHand {
    let assets = fetch_hand_assets(None).unwrap();
    let model = load_rapier_model(&assets, HandObject::Block).unwrap();
    RapierHand::new(model, settings).unwrap()
}

/// Resets, holds `ctrl = mid + a * half_range` for `secs` and returns the object heights per env step.
fn hold(h: &mut RapierHand, a: f64, secs: f64) -> (Vec<f64>, Vec<f64>) {
    h.reset();
    let ctrl: Vec<f64> = h.ctrl_range().iter().map(|r| (r[0] + r[1]) / 2.0 + a * (r[1] - r[0]) / 2.0).collect();
    h.set_ctrl(&ctrl);
    let heights = (0..(secs / 0.04).round() as usize)
        .map(|_| {
            h.step(20);
            h.object_pose().0[2]
        })
        .collect();
    (heights, ctrl)
}

#[test]
fn block_rests_on_palm_for_2s_at_mid_controls() {
    let mut h = hand();
    let (z, _) = hold(&mut h, 0.0, 2.0);
    // After 0.4 s of settling, the height stays within 1 mm of MuJoCo's band.
    for (i, &zi) in z.iter().enumerate().skip(10) {
        assert!((0.165..=0.172).contains(&zi), "step {i}: block height {zi}");
    }
}

#[test]
fn joints_track_position_targets() {
    let mut h = hand();
    let mut q = [[0.0; 24]; 2];
    let mut ctrl = [vec![], vec![]];
    let mut err = Vec::new();
    for (k, a) in [0.5, -0.5].into_iter().enumerate() {
        ctrl[k] = hold(&mut h, a, 1.0).1;
        h.hand_qpos(&mut q[k]);
        for (i, name) in ACTUATORS.iter().enumerate() {
            let j = HAND_JOINTS.iter().position(|n| n == name).unwrap();
            err.push((q[k][j] - ctrl[k][i]).abs());
        }
    }
    let mean = err.iter().sum::<f64>() / err.len() as f64;
    assert!(mean < 0.12, "mean tracking error {mean} (MuJoCo 0.057)");
    for (i, name) in ACTUATORS.iter().enumerate() {
        let j = HAND_JOINTS.iter().position(|n| n == name).unwrap();
        let (dq, dc) = (q[0][j] - q[1][j], ctrl[0][i] - ctrl[1][i]);
        assert!(dq > 0.25 * dc, "{name}: moved {dq} for a target change of {dc}");
    }
    // The coupled distal joints J0 follow J1 with the same sign (the tendon T_xxJ1c).
    for f in ["FF", "MF", "RF", "LF"] {
        let j1 = HAND_JOINTS.iter().position(|n| *n == format!("{f}J1")).unwrap();
        let ratio = q[0][j1 + 1] / q[0][j1];
        assert!((0.9..1.3).contains(&ratio), "{f}J0 / {f}J1 = {ratio}");
    }
}

// The backs of the fingers do not touch the block; they may touch each other
// (the little fingertip's back rests on the ring finger), which MuJoCo's touch
// rule counts, so the backs are checked with sensors that read only the object.
#[test]
fn touch_sensors_under_resting_block_fire_and_backs_do_not() {
    let mut h = hand_with(RapierSettings::without_fidelity());
    hold(&mut h, 0.0, 1.0);
    let names = h.touch_names().to_vec();
    let active: Vec<&String> = names.iter().zip(h.touch()).filter(|(_, t)| **t > 0.0).map(|(n, _)| n).collect();
    assert!(active.len() >= 2, "active: {active:?}");
    assert!(active.iter().any(|n| n.contains("palm")), "the palm carries the block: {active:?}");
    for (n, t) in names.iter().zip(h.touch()) {
        if n.contains("back") {
            assert_eq!(*t, 0.0, "{n} reads {t}");
        }
    }
    assert!(h.touch().iter().all(|t| t.is_finite() && *t >= 0.0));
}

#[test]
fn random_actions_for_4s_stay_finite() {
    let mut env = ShadowHandConfig::default().init().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    env.reset(5).unwrap();
    for _ in 0..100 {
        let a = JointAction((0..20).map(|_| rng.random_range(-1.0..1.0)).collect());
        let out = env.step(&a).unwrap();
        assert!(out.observation.global.iter().all(|v| v.is_finite()));
        assert!(out.reward.is_finite() && out.reward <= 0.0);
    }
    let (p, q) = env.physics().object_pose();
    assert!(p.iter().chain(&q).all(|v| v.is_finite() && v.abs() < 10.0), "{p:?} {q:?}");
}

#[test]
fn same_seed_same_trajectory() {
    let run = || {
        let mut env = ShadowHandConfig::default().init().unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let mut obs = vec![env.reset(9).unwrap()];
        for _ in 0..15 {
            let a = JointAction((0..20).map(|_| rng.random_range(-1.0..1.0)).collect());
            obs.push(env.step(&a).unwrap().observation);
        }
        obs
    };
    assert_eq!(run(), run());
    let mut env = ShadowHandConfig::default().init().unwrap();
    let (a, b) = (env.reset(9).unwrap(), env.reset(10).unwrap());
    assert_ne!(a.desired_goal, b.desired_goal);
}

#[test]
fn contact_readout_matches_touch_and_object() {
    let mut env = ShadowHandConfig::default().init().unwrap();
    env.reset(4).unwrap();
    let out = env.step(&JointAction::zeros(20)).unwrap();
    let contacts = env.object_contacts();
    assert!(!contacts.points.is_empty());
    assert_eq!(contacts.active_touch_sensors, env.active_touch_count());
    let (p, _) = env.physics().object_pose();
    for (c, x) in contacts.center_of_mass.iter().zip(p) {
        assert!((c - x).abs() < 1e-4);
    }
    let mut up = f64::MIN;
    for c in &contacts.points {
        let n = c.normal;
        assert!(((n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt() - 1.0).abs() < 1e-3);
        assert!(c.normal_force > 0.0);
        // Within 6 cm of the object centre (the block's half-diagonal is 4.3 cm).
        let d: f64 = c.position.iter().zip(p).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt();
        assert!(d < 0.06, "contact {d} m from the centre");
        up = f64::max(up, n[2]);
    }
    // The hand carries the block from below: some contact normal points up into it.
    assert!(up > 0.5, "largest upward normal component {up}");
    assert_eq!(out.info.features.len(), 2);
}

// Guards `RapierSettings::touch_every_contact` (MuJoCo's touch rule): with the
// object out of the hand, a fist's finger-on-finger contacts register on the
// touch sensors, and they do not when sensors read only the object's contacts.
#[test]
fn touch_sensors_read_finger_on_finger_contacts_as_mujoco_does() {
    let mut active = Vec::new();
    for every in [true, false] {
        let mut h = hand_with(RapierSettings { touch_every_contact: every, ..RapierSettings::default() });
        h.set_object_pose([3.0, 3.0, 0.1], [1.0, 0.0, 0.0, 0.0]);
        let fist: Vec<f64> = h.ctrl_range().iter().map(|r| r[1]).collect();
        h.set_ctrl(&fist);
        let mut most = 0;
        for _ in 0..25 {
            h.step(20);
            most = most.max(h.touch().iter().filter(|&&t| t > 0.0).count());
        }
        active.push(most);
    }
    assert!(active[0] >= 2, "a fist touches itself: {} sensors active", active[0]);
    assert_eq!(active[1], 0, "without the object, object-only sensors stay silent");
}

// Guards `RapierSettings::torsional_friction`: it acts on the object's
// condim-4 contacts (a block spun on the palm keeps less of its spin with it
// than without). The spin is read after one rapier step: the impulse acts at
// the end of each step, so the yaw turned within that step cannot show it.
#[test]
fn torsional_friction_slows_a_block_spun_on_the_palm() {
    let mut spin = Vec::new();
    for torsion in [true, false] {
        let mut h = hand_with(RapierSettings { torsional_friction: torsion, ..RapierSettings::default() });
        let mid: Vec<f64> = h.ctrl_range().iter().map(|r| (r[0] + r[1]) / 2.0).collect();
        h.set_ctrl(&mid);
        h.step(200);
        h.set_object_velocity([0.0; 3], [0.0, 0.0, 30.0]);
        h.step(4);
        let w = h.object_qvel();
        spin.push((w[3] * w[3] + w[4] * w[4] + w[5] * w[5]).sqrt());
    }
    println!("spin left 8 ms after a 30 rad/s spin: with torsion {:.3} rad/s, without {:.3}", spin[0], spin[1]);
    assert!(spin[0] < spin[1], "{spin:?}");
}

// Guards `RapierSettings::tendon_slack`: MuJoCo's `T_xxJ1c` tendons hold
// `0.00705 q_J0 - 0.00805 q_J1` within +-0.001 m, a band the distal joints
// use under random actions (a little past its ends, as MuJoCo's soft limit
// allows); without slack the length stays at zero.
#[test]
fn the_j1_j0_tendons_use_their_slack_and_keep_their_range() {
    let mut longest = Vec::new();
    for slack in [true, false] {
        let mut h = hand_with(RapierSettings { tendon_slack: slack, ..RapierSettings::default() });
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut q = [0.0; 24];
        let mut most: f64 = 0.0;
        for step in 0..100 {
            if step % 5 == 0 {
                let ctrl: Vec<f64> = h.ctrl_range().iter().map(|r| rng.random_range(r[0]..=r[1])).collect();
                h.set_ctrl(&ctrl);
            }
            h.step(20);
            h.hand_qpos(&mut q);
            for f in ["FF", "MF", "RF", "LF"] {
                let at = |j: &str| q[HAND_JOINTS.iter().position(|&n| n == format!("{f}{j}")).unwrap()];
                most = most.max((0.00705 * at("J0") - 0.00805 * at("J1")).abs());
            }
        }
        longest.push(most);
    }
    println!("longest |tendon length| (m): with slack {:.5}, without {:.5}", longest[0], longest[1]);
    assert!(longest[0] > 3e-4 && longest[0] <= 1.5e-3, "with slack: {}", longest[0]);
    assert!(longest[1] < 2e-4, "without slack: {}", longest[1]);
}
