//! Guards the headless renderer (`shadow_hand::render`): frames of the real
//! model are not blank, show the hand, and change when the hand, the object or
//! the touch sensors change. Set `FMSR_RENDER_DUMP=DIR` to keep the frames as PPM.

use fmsr_core::Env;
use fmsr_core::spec::JointAction;
use fmsr_envs::prelude::*;
use fmsr_envs::shadow_hand::render::{Camera, HandScene, HandView, Image};

const SKY_TOP: [u8; 3] = [112, 217, 143];

fn scene(object: HandObject) -> HandScene {
    let assets = fetch_hand_assets(None).unwrap();
    HandScene::load(&assets, object).unwrap()
}

/// Fraction of pixels that are not (close to) the sky.
fn foreground(image: &Image) -> f64 {
    let sky = |p: [u8; 3]| p.iter().zip(SKY_TOP).all(|(&a, b)| a.abs_diff(b) <= 6);
    let n = image.rgb.chunks(3).filter(|p| !sky([p[0], p[1], p[2]])).count();
    n as f64 / (image.width * image.height) as f64
}

/// Fraction of pixels that differ by more than 8 in some channel.
fn changed(a: &Image, b: &Image) -> f64 {
    let n = a.rgb.chunks(3).zip(b.rgb.chunks(3)).filter(|(p, q)| p.iter().zip(*q).any(|(x, y)| x.abs_diff(*y) > 8));
    n.count() as f64 / (a.width * a.height) as f64
}

/// Number of distinct colours (a flat, unshaded drawing has a handful).
fn distinct_colors(image: &Image) -> usize {
    image.rgb.chunks(3).collect::<std::collections::HashSet<_>>().len()
}

fn dump(name: &str, image: &Image) {
    if let Some(dir) = std::env::var_os("FMSR_RENDER_DUMP") {
        let mut bytes = format!("P6\n{} {}\n255\n", image.width, image.height).into_bytes();
        bytes.extend_from_slice(&image.rgb);
        std::fs::write(std::path::Path::new(&dir).join(format!("{name}.ppm")), bytes).unwrap();
    }
}

fn reset_view(env: &mut ShadowHand<RapierHand>) -> HandView {
    env.reset(3).unwrap();
    env.view()
}

#[test]
fn frames_show_the_hand_and_follow_its_motion() {
    let scene = scene(HandObject::Block);
    let camera = Camera::gym(240, 180);
    let mut env = ShadowHandConfig::test_block().init().unwrap();
    let first = scene.render(&reset_view(&mut env), &camera).unwrap();
    dump("rest", &first);
    let fg = foreground(&first);
    assert!((0.1..0.9).contains(&fg), "the hand covers {fg:.3} of the frame");
    assert!(distinct_colors(&first) > 100, "a shaded frame, not a flat one: {} colours", distinct_colors(&first));

    // Flex every finger and the wrist for 10 steps.
    let action = JointAction(vec![1.0; 20]);
    for _ in 0..10 {
        env.step(&action).unwrap();
    }
    let flexed = scene.render(&env.view(), &camera).unwrap();
    dump("flexed", &flexed);
    assert!(changed(&first, &flexed) > 0.02, "flexing the hand changed {:.4} of the pixels", changed(&first, &flexed));
}

#[test]
fn the_object_goal_and_touch_sensors_are_drawn() {
    let scene = scene(HandObject::Block);
    let camera = Camera::gym(240, 180);
    let mut env = ShadowHandConfig::test_block().init().unwrap();
    let view = reset_view(&mut env);
    let base = scene.render(&HandView { touch_active: vec![false; 92], ..view.clone() }, &camera).unwrap();

    let (s, c) = (std::f64::consts::FRAC_PI_4.sin(), std::f64::consts::FRAC_PI_4.cos());
    let turned = HandView { object_quaternion: [c, 0.0, 0.0, s], touch_active: vec![false; 92], ..view.clone() };
    let turned = scene.render(&turned, &camera).unwrap();
    assert!(changed(&base, &turned) > 0.002, "turning the object changed {:.4}", changed(&base, &turned));

    let goal = HandView { goal_quaternion: [0.0, 1.0, 0.0, 0.0], touch_active: vec![false; 92], ..view.clone() };
    let goal = scene.render(&goal, &camera).unwrap();
    assert!(changed(&base, &goal) > 0.002, "turning the goal changed {:.4}", changed(&base, &goal));

    let touched = scene.render(&HandView { touch_active: vec![true; 92], ..view }, &camera).unwrap();
    dump("touched", &touched);
    let red = touched.rgb.chunks(3).filter(|p| p[0] > 150 && p[1] < 60 && p[2] < 60).count();
    assert!(red > 200, "{red} red pixels with every touch sensor active");
}

#[test]
fn the_egg_is_drawn() {
    let scene = scene(HandObject::Egg);
    let mut env = ShadowHandConfig { object: HandObject::Egg, ..ShadowHandConfig::test_block() }.init().unwrap();
    let image = scene.render(&reset_view(&mut env), &Camera::gym(160, 120)).unwrap();
    dump("egg", &image);
    assert!(foreground(&image) > 0.1);
}

#[test]
fn a_view_of_the_wrong_shape_is_an_error() {
    let scene = scene(HandObject::Block);
    let view = HandView {
        qpos: vec![0.0; 3],
        object_position: [1.0, 0.87, 0.2],
        object_quaternion: [1.0, 0.0, 0.0, 0.0],
        goal_position: [1.0, 0.87, 0.2],
        goal_quaternion: [1.0, 0.0, 0.0, 0.0],
        touch_active: vec![false; 92],
    };
    let err = scene.render(&view, &Camera::gym(16, 16)).unwrap_err();
    assert!(err.to_string().contains("view.qpos"), "{err}");
}
