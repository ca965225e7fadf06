//! Guards the collector seam end to end: a user-defined `OccupancyEstimator`
//! (undiscounted mean over the last episodes) and a user-defined
//! `ShadowReward` (a square-root utility) plug into training through the
//! public API only, and their shadow reward raises the occupancy of its
//! feature (the safe region of TeamReach) above the Dense baseline's. The
//! run is `examples/custom_shadow_reward.rs`'s own, so the example is what is
//! tested.

#[path = "../examples/custom_shadow_reward.rs"]
#[allow(dead_code)]
mod custom_shadow_reward;

#[test]
fn user_estimator_and_utility_raise_their_feature() {
    let (user, estimate) = custom_shadow_reward::train(true).unwrap();
    let (dense, _) = custom_shadow_reward::train(false).unwrap();
    eprintln!("safe_region rate: sqrt utility + mean-of-recent estimator {user:.3}, Dense {dense:.3}");
    assert!(estimate > 0.0, "the user's estimator saw the feature");
    assert!(user > dense + 0.1, "user shadow reward {user} vs Dense {dense}");
}
