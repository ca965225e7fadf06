//! Guards the engine chosen at run time (`ShadowHandConfig::init_engine`):
//! the hand behind `EnginePhysics` steps exactly as the hand on its backend's
//! own type (the dispatch changes nothing), and an engine this build lacks is
//! a typed error naming the cargo feature.

use fmsr_core::Env;
use fmsr_core::spec::JointAction;
use fmsr_envs::shadow_hand::{Engine, HandPhysics, ShadowHandConfig};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Observations, rewards and features of 10 steps of seeded random actions.
fn trajectory<E: Env>(env: &mut E) -> Vec<(Vec<f32>, f32, Vec<f32>)> {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    env.reset(3).unwrap();
    (0..10)
        .map(|_| {
            let a = JointAction((0..env.spec().action_dim).map(|_| rng.random_range(-1.0..=1.0)).collect());
            let out = env.step(&a).unwrap();
            (out.observation.global, out.reward, out.info.features)
        })
        .collect()
}

#[test]
fn the_engine_dispatch_steps_as_the_backend_itself() {
    let mut direct = ShadowHandConfig::default().init().unwrap();
    let mut chosen = ShadowHandConfig::default().init_engine(Engine::Rapier).unwrap();
    assert_eq!(chosen.physics().engine(), Engine::Rapier);
    assert_eq!(trajectory(&mut direct), trajectory(&mut chosen));
    assert_eq!(direct.physics().timestep(), chosen.physics().timestep());
}

#[cfg(not(feature = "mujoco"))]
#[test]
fn an_engine_not_compiled_in_is_a_typed_error() {
    use fmsr_envs::EnvError;
    let err = ShadowHandConfig::default().init_engine(Engine::Mujoco).expect_err("no MuJoCo in this build");
    assert!(matches!(err, EnvError::EngineUnavailable { engine: "mujoco", feature: "mujoco" }), "{err}");
    assert!(err.to_string().contains("cargo feature `mujoco`"), "{err}");
}
