//! Guards the configurable agent partition of the Shadow Hand:
//! a custom partition that owns every actuator once builds an env whose agents
//! own exactly those slots and observe their fingers; one that misses, repeats
//! or misnames an actuator is rejected with an error naming the actuator.

use fmsr_core::Env;
use fmsr_envs::EnvError;
use fmsr_envs::shadow_hand::{HandAgent, ShadowHandConfig};

fn agent(name: &str, actuators: &[&str]) -> HandAgent {
    HandAgent { name: name.into(), actuators: actuators.iter().map(|s| (*s).to_owned()).collect() }
}

/// The paper's partition with the thumb split into base and tip.
fn split_thumb() -> Vec<HandAgent> {
    let mut agents = HandAgent::paper();
    agents.pop();
    agents.push(agent("thumb_base", &["THJ4", "THJ3", "THJ2"]));
    agents.push(agent("thumb_tip", &["THJ1", "THJ0"]));
    agents
}

#[test]
fn default_is_the_paper_partition() {
    let env = ShadowHandConfig::default().init().unwrap();
    let names: Vec<_> = env.spec().agents.iter().map(|a| a.name.as_str()).collect();
    assert_eq!(names, ["wrist", "index", "middle", "ring", "little", "thumb"]);
    let explicit = ShadowHandConfig { agents: Some(HandAgent::paper()), ..Default::default() }.init().unwrap();
    assert_eq!(explicit.spec(), env.spec());
}

#[test]
fn custom_partition_owns_its_slots() {
    let env = ShadowHandConfig { agents: Some(split_thumb()), ..Default::default() }.init().unwrap();
    let spec = env.spec();
    assert_eq!(spec.agents.len(), 7);
    assert_eq!(spec.agents[5].action_slots, vec![15, 16, 17]);
    assert_eq!(spec.agents[6].action_slots, vec![18, 19]);
    // Both thumb agents observe the whole thumb (its joints and touch sensors).
    assert_eq!(spec.agents[5].local_obs_dim, spec.agents[6].local_obs_dim);
    spec.validate().unwrap();
}

#[test]
fn bad_partitions_name_the_actuator() {
    let check = |agents: Vec<HandAgent>, needle: &str| {
        let err = ShadowHandConfig { agents: Some(agents), ..Default::default() }.init().unwrap_err();
        assert!(matches!(err, EnvError::InvalidConfig { key: "env.agents", .. }), "{err}");
        assert!(err.to_string().contains(needle), "`{err}` does not mention {needle}");
    };
    let mut missing = HandAgent::paper();
    missing[5].actuators.retain(|a| a != "THJ0");
    check(missing, "THJ0");
    let mut twice = HandAgent::paper();
    twice[0].actuators.push("FFJ3".into());
    check(twice, "FFJ3");
    let mut unknown = HandAgent::paper();
    unknown[1].actuators.push("FFJ9".into());
    check(unknown, "FFJ9");
    let mut same_name = HandAgent::paper();
    same_name[1].name = "wrist".into();
    check(same_name, "wrist");
}
