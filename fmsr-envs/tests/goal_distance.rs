//! Guards the task's goal distance: by default the full angle
//! between orientations, as gym's `manipulate.py` measures rotation goals, so
//! an egg lying on its side at the goal's heading is neither rewarded as at
//! the goal nor counted a success (the yaw distance, kept for the old
//! records, did both); and a reset as gym's: an upright object on the palm,
//! an upright goal turned about Z.

use fmsr_core::Env;
use fmsr_core::spec::JointAction;
use fmsr_envs::shadow_hand::rotation::{full_angle, tilt};
use fmsr_envs::shadow_hand::{GoalDistance, HandObject, HandPhysics, ShadowHandConfig};

fn mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    let [w1, x1, y1, z1] = a;
    let [w2, x2, y2, z2] = b;
    [
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    ]
}

fn egg(distance: GoalDistance) -> ShadowHandConfig {
    ShadowHandConfig { object: HandObject::Egg, goal_distance: distance, success_threshold: 0.4, ..Default::default() }
}

#[test]
fn a_tilted_egg_at_the_goals_heading_is_not_at_the_goal() {
    for (distance, at_goal) in [(GoalDistance::Full, false), (GoalDistance::Yaw, true)] {
        let mut env = egg(distance).init().unwrap();
        let obs = env.reset(3).unwrap();
        let goal = obs.desired_goal.clone();
        let goal_q = [goal[3], goal[4], goal[5], goal[6]].map(f64::from);
        // The goal's heading, then 1.3 rad about the object's own X axis: on its side.
        let side = mul(goal_q, [(0.65f64).cos(), (0.65f64).sin(), 0.0, 0.0]);
        let mut achieved = goal.clone();
        achieved[3..7].copy_from_slice(&side.map(|v| v as f32));
        let d = env.goal_distance(&achieved, &goal);
        let reward = env.goal_reward(&achieved, &goal);
        assert_eq!(d < 0.4, at_goal, "{distance:?}: distance {d}");
        assert!((reward + d).abs() < 1e-6, "{distance:?}: dense R1 = -distance, got {reward} for {d}");
        // The step's success flag counts by the same distance: the egg set on
        // its side at the goal's heading, the hand holding still for one step.
        let (pos, _) = env.physics().object_pose();
        env.physics_mut().set_object_pose(pos, side);
        let step = env.step(&JointAction::zeros(20)).unwrap();
        let o = &step.observation;
        assert!(tilt(&o.achieved_goal[3..7]) > 0.9, "the egg is on its side");
        assert_eq!(step.info.is_success, at_goal, "{distance:?}: the success flag after a step on its side");
    }
}

#[test]
fn a_reset_puts_an_upright_object_on_the_palm_and_an_upright_goal() {
    let mut env = egg(GoalDistance::Full).init().unwrap();
    for seed in 0..5 {
        let obs = env.reset(seed).unwrap();
        let (pos, _) = env.physics().object_pose();
        assert!(pos[2] > 0.04, "seed {seed}: on the palm");
        assert!(tilt(&obs.desired_goal[3..7]) < 1e-6, "seed {seed}: the goal is upright");
        let d = env.goal_distance(&obs.achieved_goal, &obs.desired_goal);
        assert!((d - full_angle(&obs.achieved_goal[3..7], &obs.desired_goal[3..7])).abs() < 1e-7);
    }
}
