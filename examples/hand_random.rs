//! Random actions on the rapier3d Shadow Hand block task: prints, per env
//! step, the object's angle error about Z, its contact points with the hand,
//! the number of active touch sensors and the two stability features.
//!
//! Run with `cargo run --release --example hand_random [episodes] [egg]`. The
//! model (gymnasium-robotics 1.4.2) is fetched with pip into
//! the cache (`$FMSR_ASSETS_DIR`, else `~/.cache/fmsr`; `fmsr assets path`) on first use.

use fmsr_core::spec::JointAction;
use fmsr_core::{ContactReadout, Env};
use fmsr_envs::shadow_hand::{HandObject, ShadowHandConfig};
use rand::rngs::StdRng;
use rand::{RngExt, SeedableRng};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let episodes: u64 = args.get(1).map_or(Ok(1), |s| s.parse())?;
    let object = if args.iter().any(|a| a == "egg") { HandObject::Egg } else { HandObject::Block };
    let mut env = ShadowHandConfig { object, ..ShadowHandConfig::test_block() }.init()?;
    let mut rng = StdRng::seed_from_u64(0);
    for episode in 0..episodes {
        env.reset(episode)?;
        println!("episode {episode} ({object:?}): initial angle error {:.3} rad", env.angle_error());
        println!("step  angle_err  contacts  touch  safe_region  contacts_feat  dropped");
        let mut successes = 0;
        for step in 0..env.spec().episode_len {
            let action = JointAction((0..env.spec().action_dim).map(|_| rng.random_range(-1.0..1.0)).collect());
            let out = env.step(&action)?;
            let contacts = env.object_contacts();
            successes += usize::from(out.info.is_success);
            println!(
                "{step:4}  {:9.3}  {:8}  {:5}  {:11}  {:13}  {:7}",
                env.angle_error(),
                contacts.points.len(),
                contacts.active_touch_sensors,
                out.info.features[0],
                out.info.features[1],
                out.info.dropped
            );
        }
        println!("episode {episode}: {successes} steps within 0.4 rad of the goal");
    }
    Ok(())
}
