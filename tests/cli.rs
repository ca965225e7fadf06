//! Guards the `fmsr` command end to end: train -> eval -> report on a
//! tiny budget on the rapier Shadow Hand writes every file of a run and a report;
//! `--resume` continues a run; bad configs, and settings that contradict their
//! owner (`method`, `algorithm`), are rejected before the run directory exists
//! with a message that names the key; each algorithm trains on the hand; a
//! run killed at any moment resumes to the uninterrupted run's history; a
//! policy file (`fmsr export`) gives its run's results wherever a run is read,
//! and a damaged one is an error naming what is wrong; training's progress
//! reaches a log one line per epoch.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::cli::{FMSR, fmsr, text, tiny_config, trained_tiny_run};

#[test]
fn train_eval_report_and_resume() {
    let tmp = tempfile::tempdir().unwrap();
    let config = tiny_config(tmp.path(), "");
    let run = tmp.path().join("run");
    let (config_s, run_s) = (config.to_str().unwrap(), run.to_str().unwrap());

    let out = fmsr(&["train", "--config", config_s, "--out", run_s, "--seed", "3"]);
    assert!(out.status.success(), "{}", text(&out));
    for f in ["config.toml", "checkpoint.bin", "metrics.jsonl", "metrics.csv", "provenance.json"] {
        assert!(run.join(f).exists(), "{f} missing");
    }
    // stderr is a pipe here, as in `fmsr train > log 2>&1`: one line per epoch
    // instead of the progress bar, which hides itself without a terminal.
    let log = String::from_utf8_lossy(&out.stderr);
    assert_eq!(log.lines().filter(|l| l.starts_with("epoch 1/1 | ")).count(), 1, "{log}");
    assert!(log.contains(" env steps/s | ") && log.contains(" updates/s | ") && log.contains("| ETA 0 s"), "{log}");
    let provenance: fmsr::provenance::Provenance =
        serde_json::from_slice(&std::fs::read(run.join("provenance.json")).unwrap()).unwrap();
    assert!(provenance.command.iter().any(|a| a == "--seed"), "{provenance:?}");
    // The binary's own commit (build.rs), not only the directory's: a kept
    // binary run from a newer checkout once recorded the checkout's commit alone.
    assert_eq!(provenance.build_commit.as_deref(), option_env!("FMSR_BUILD_COMMIT"), "{provenance:?}");
    assert_eq!(std::fs::read_to_string(run.join("metrics.jsonl")).unwrap().lines().count(), 1);

    // A second train into the same directory must not overwrite the run.
    let out = fmsr(&["train", "--config", config_s, "--out", run_s]);
    assert!(!out.status.success());
    assert!(text(&out).contains("--resume"), "{}", text(&out));

    // Resume for one more epoch, from a directory without `configs/`: a resumed
    // run reads only its own config.toml (regression: it used to load the
    // default --config first and fail there).
    let out = Command::new(FMSR)
        .args(["train", "--out", run_s, "--resume", "--epochs", "2", "--quiet"])
        .current_dir(tmp.path())
        .env("RUST_BACKTRACE", "0")
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", text(&out));
    assert!(!text(&out).contains("epoch 2/2"), "--quiet printed progress: {}", text(&out));
    assert_eq!(std::fs::read_to_string(run.join("metrics.jsonl")).unwrap().lines().count(), 2);
    assert!(std::fs::read_to_string(run.join("config.toml")).unwrap().contains("seed = 3"));

    // TensorBoard: one event file per process, whose scalars read back with the
    // epochs' env steps and values.
    let metrics: Vec<serde_json::Value> = std::fs::read_to_string(run.join("metrics.jsonl"))
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let mut files: Vec<PathBuf> = std::fs::read_dir(&run)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.file_name().unwrap().to_string_lossy().starts_with("events.out.tfevents."))
        .collect();
    files.sort();
    assert_eq!(files.len(), 2, "{files:?}");
    let mut success = Vec::new();
    for f in &files {
        let scalars = fmsr::tensorboard::scalars(&fmsr::tensorboard::read_events(f).unwrap());
        assert!(scalars.iter().any(|(tag, ..)| tag == "agent_thumb/shadow_reward_abs"), "{scalars:?}");
        assert!(scalars.iter().any(|(tag, ..)| tag == "occupancy/contacts"), "{scalars:?}");
        success.extend(scalars.into_iter().filter(|(tag, ..)| tag == "success/eval").map(|(_, step, v)| (step, v)));
    }
    success.sort_by_key(|&(step, _)| step);
    let expected: Vec<(i64, f32)> = metrics
        .iter()
        .map(|m| (m["env_steps"].as_i64().unwrap(), m["success_rate"].as_f64().unwrap() as f32))
        .collect();
    assert_eq!(success, expected);

    let out = fmsr(&["eval", run_s]);
    assert!(out.status.success(), "{}", text(&out));
    assert!(text(&out).contains("| block | Dense+FMSR+IS |"), "{}", text(&out));
    let eval: serde_json::Value = serde_json::from_slice(&std::fs::read(run.join("eval.json")).unwrap()).unwrap();
    assert_eq!(eval["episodes"], 2);
    assert_eq!(eval["trace"]["q_msv"].as_array().unwrap().len(), 100);
    // The chance level of the test set travels with the evaluation.
    assert_eq!(eval["records"].as_array().unwrap().len(), 2);
    assert!(text(&out).contains("for a hand that holds still (the same episodes simulated"), "{}", text(&out));

    let report = tmp.path().join("report");
    let out = fmsr(&["report", run_s, "--out", report.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out));
    let summary = std::fs::read_to_string(report.join("summary.md")).unwrap();
    assert!(summary.contains("Table I") && summary.contains("Dense+FMSR+IS"), "{summary}");
    assert!(summary.contains("## Against chance") && summary.contains("| Holding still |"), "{summary}");
    for f in ["fig3_block.png", "fig4_block.png", "render/00-tiny.png"] {
        let png = std::fs::read(report.join(f)).unwrap();
        assert_eq!(&png[..4], b"\x89PNG", "{f} is not a PNG");
    }
    // The report draws test episode 0 of each run and shows its frame strip.
    assert!(summary.contains("## Test episode 0, rendered"), "{summary}");
    assert!(summary.contains("](render/00-tiny.gif)") && summary.contains("](render/00-tiny.png)"), "{summary}");
    assert!(run.join("render/episode-0-rapier.gif").exists());
}

/// `eval.json` as JSON without its wall time.
fn eval_results(path: &Path) -> serde_json::Value {
    let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap();
    v.as_object_mut().unwrap().remove("seconds");
    v
}

// Guards policy files: `fmsr export` writes the policy alone, a small part of
// the checkpoint; `eval`, `render` and `report` read the file (or a directory
// holding `policy.fmsr`) and give the run's results exactly; `fmsr run` sets
// its run beside the shipped policy of its configuration.
#[test]
fn an_exported_policy_gives_the_results_of_its_run() {
    let tmp = tempfile::tempdir().unwrap();
    let run = trained_tiny_run(tmp.path());
    let run_s = run.to_str().unwrap();
    assert!(fmsr(&["eval", run_s]).status.success());
    let shipped = tmp.path().join("pretrained/tiny");
    std::fs::create_dir_all(&shipped).unwrap();
    let file = shipped.join("policy.fmsr");
    let file_s = file.to_str().unwrap();
    let out = fmsr(&["export", run_s, "--out", file_s]);
    assert!(out.status.success(), "{}", text(&out));
    let (policy, checkpoint) =
        (std::fs::metadata(&file).unwrap().len(), std::fs::metadata(run.join("checkpoint.bin")).unwrap().len());
    assert!(
        policy * 4 < checkpoint,
        "the policy file ({policy} B) is not much smaller than the checkpoint ({checkpoint} B)"
    );

    // eval: the same results, checked against the evaluation the file carries.
    let again = tmp.path().join("again.json");
    let out = fmsr(&["eval", file_s, "--out", again.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out));
    assert!(text(&out).contains("the same results as the evaluation the file carries"), "{}", text(&out));
    assert_eq!(eval_results(&again), eval_results(&run.join("eval.json")));
    let out = fmsr(&["eval", shipped.to_str().unwrap(), "--episodes", "1"]);
    assert!(
        out.status.success() && text(&out).contains("differs from the evaluation the file carries"),
        "{}",
        text(&out)
    );

    // render: the same frames.
    let (a, b) = (tmp.path().join("run.gif"), tmp.path().join("file.gif"));
    for (source, gif) in [(run_s, &a), (file_s, &b)] {
        let out = fmsr(&["render", source, "--out", gif.to_str().unwrap(), "--width", "64", "--height", "48"]);
        assert!(out.status.success(), "{}", text(&out));
    }
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());

    // report: the file's row stands beside the run's, with its learning curve.
    let report = tmp.path().join("report");
    let out = fmsr(&["report", run_s, file_s, "--out", report.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out));
    let summary = std::fs::read_to_string(report.join("summary.md")).unwrap();
    assert!(summary.contains("| block | Dense+FMSR+IS (policy file) |"), "{summary}");
    assert!(summary.contains("| block | Dense+FMSR+IS |"), "{summary}");
    // Runs given by absolute paths are named from the report (its links work
    // wherever the two move together), never by the machine's path.
    let file_link = "[../pretrained/tiny/policy.fmsr](../pretrained/tiny/policy.fmsr)";
    assert!(summary.contains(&format!("| {file_link} | block | Dense+FMSR+IS (policy file) | 0 | 1 |")), "{summary}");
    assert!(!summary.contains(tmp.path().to_str().unwrap()), "{summary}");
    assert!(shipped.join("render/episode-0-rapier.gif").exists(), "the report draws a policy file beside it");

    // The main job's report sets the newcomer's run beside the shipped policy.
    let config = tmp.path().join("tiny.toml");
    let run2 = tmp.path().join("run2");
    let pretrained = tmp.path().join("pretrained");
    let out = fmsr(&[
        "run",
        "--config",
        config.to_str().unwrap(),
        "--out",
        run2.to_str().unwrap(),
        "--pretrained",
        pretrained.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(out.status.success(), "{}", text(&out));
    let summary = std::fs::read_to_string(run2.join("report/summary.md")).unwrap();
    assert!(
        summary.contains("Dense+FMSR+IS (policy file)") && summary.contains("](../../pretrained/tiny/policy.fmsr)"),
        "{summary}"
    );
    // The run holds its report: it is named, not shown as `..`.
    assert!(summary.contains("[run2](..)") && !summary.contains("[..]"), "{summary}");
}

// Guards the policy file reader: another format version, a damaged file, a
// file of another kind and a directory without a policy are errors that say
// what is wrong, never a panic.
#[test]
fn bad_policy_files_are_errors_naming_what_is_wrong() {
    let tmp = tempfile::tempdir().unwrap();
    let run = trained_tiny_run(tmp.path());
    let file = tmp.path().join("tiny.fmsr");
    assert!(fmsr(&["export", run.to_str().unwrap(), "--out", file.to_str().unwrap()]).status.success());
    let good = std::fs::read(&file).unwrap();
    let bad = tmp.path().join("bad.fmsr");
    let check = |bytes: &[u8], expected: &str| {
        std::fs::write(&bad, bytes).unwrap();
        for cmd in ["eval", "render", "report"] {
            let out = fmsr(&[cmd, bad.to_str().unwrap()]);
            assert!(!out.status.success() && text(&out).contains(expected), "{cmd}: {}", text(&out));
            assert!(!text(&out).contains("panicked"), "{}", text(&out));
        }
    };
    let mut newer = good.clone();
    newer[8..12].copy_from_slice(&3u32.to_le_bytes());
    check(&newer, "policy file: format version 3, this build reads version 2: the file was written by a newer fmsr");
    check(&good[..good.len() / 2], "checksum mismatch");
    let mut flipped = good.clone();
    flipped[good.len() - 10] ^= 4;
    check(&flipped, "checksum mismatch");
    check(&std::fs::read(run.join("checkpoint.bin")).unwrap(), "not an fmsr policy file");
    let empty = tmp.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let out = fmsr(&["eval", empty.to_str().unwrap()]);
    assert!(!out.status.success() && text(&out).contains("holds neither a run"), "{}", text(&out));
    let out = fmsr(&["export", empty.to_str().unwrap()]);
    assert!(!out.status.success() && text(&out).contains("holds neither a run"), "{}", text(&out));
    // A run that has not trained yet (its config, no checkpoint).
    std::fs::copy(run.join("config.toml"), empty.join("config.toml")).unwrap();
    let out = fmsr(&["export", empty.to_str().unwrap()]);
    assert!(!out.status.success() && text(&out).contains("no checkpoint.bin"), "{}", text(&out));
    // A policy file is written again only to a file named with --out.
    let out = fmsr(&["export", file.to_str().unwrap(), "--precision", "half"]);
    assert!(!out.status.success() && text(&out).contains("--out"), "{}", text(&out));
}

// Guards the `graph.actor_observation` switch: `"global"` actors train on
// the hand, the configuration's label names them, a checkpoint of local
// actors is not resumed as global ones, and an unknown value is refused.
#[test]
fn global_actors_train_and_are_told_apart() {
    let tmp = tempfile::tempdir().unwrap();
    let config = tiny_config(tmp.path(), "[graph]\nactor_observation = \"global\"\n");
    let run = tmp.path().join("global");
    let out = fmsr(&["train", "--config", config.to_str().unwrap(), "--out", run.to_str().unwrap(), "--quiet"]);
    assert!(out.status.success(), "{}", text(&out));
    let written = std::fs::read_to_string(run.join("config.toml")).unwrap();
    assert!(written.contains("actor_observation = \"global\""), "{written}");
    let out = fmsr(&["eval", run.to_str().unwrap()]);
    assert!(out.status.success() && text(&out).contains("| Dense+FMSR+IS, global actors |"), "{}", text(&out));

    let local_dir = tmp.path().join("local");
    std::fs::create_dir(&local_dir).unwrap();
    let local = trained_tiny_run(&local_dir);
    let text_local = std::fs::read_to_string(local.join("config.toml")).unwrap();
    assert!(text_local.contains("actor_observation = \"local\""), "{text_local}");
    std::fs::write(local.join("config.toml"), text_local.replace("\"local\"", "\"global\"")).unwrap();
    let out = fmsr(&["train", "--out", local.to_str().unwrap(), "--resume", "--epochs", "2"]);
    assert!(!out.status.success() && text(&out).contains("agent 0 actor"), "{}", text(&out));

    let bad = tiny_config(tmp.path(), "[graph]\nactor_observation = \"everything\"\n");
    let out = fmsr(&["train", "--config", bad.to_str().unwrap(), "--out", tmp.path().join("bad").to_str().unwrap()]);
    assert!(!out.status.success() && text(&out).contains("actor_observation"), "{}", text(&out));
}

/// The tiny config with `networks.critic = critic` and method `method`.
fn critic_config(dir: &Path, name: &str, method: &str, critic: &str) -> PathBuf {
    let mut text = common::tiny_config_text()
        .replace("method = \"dense_fmsr_is\"", &format!("method = \"{method}\""))
        .replace("layers = 2\n", &format!("layers = 2\ncritic = \"{critic}\"\n"));
    if method == "sparse" {
        // Sparse has no shadow rewards and no information sharing: drop their sections.
        for section in ["[trainer.shadow]", "[sharing]"] {
            let start = text.find(section).unwrap();
            let end = text[start + 1..].find("\n[").map_or(text.len(), |e| start + e + 2);
            text.replace_range(start..end, "");
        }
    }
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, text).unwrap();
    path
}

// Guards the `networks.critic` switch: a critic trunk shared by the agents
// and one critic for all train on the hand and are named in the label; one
// critic is refused where shadow rewards give each finger its own reward; a
// checkpoint of per-agent critics is not resumed as shared ones.
#[test]
fn shared_critics_train_and_are_told_apart() {
    let tmp = tempfile::tempdir().unwrap();
    for (name, method, critic, label) in [
        ("trunk", "dense_fmsr_is", "shared_trunk", "| Dense+FMSR+IS, shared critic trunk |"),
        ("one", "sparse", "shared", "| Sparse, shared critic |"),
    ] {
        let config = critic_config(tmp.path(), name, method, critic);
        let run = tmp.path().join(name);
        let out = fmsr(&["train", "--config", config.to_str().unwrap(), "--out", run.to_str().unwrap(), "--quiet"]);
        assert!(out.status.success(), "{}", text(&out));
        let written = std::fs::read_to_string(run.join("config.toml")).unwrap();
        assert!(written.contains(&format!("critic = \"{critic}\"")), "{written}");
        let out = fmsr(&["eval", run.to_str().unwrap()]);
        assert!(out.status.success() && text(&out).contains(label), "{}", text(&out));
    }

    let bad = critic_config(tmp.path(), "bad", "dense_fmsr_is", "shared");
    let out = fmsr(&["train", "--config", bad.to_str().unwrap(), "--out", tmp.path().join("bad").to_str().unwrap()]);
    assert!(!out.status.success() && text(&out).contains("networks.critic"), "{}", text(&out));

    // A run of per-agent critics resumed as a shared trunk: on the CPU the
    // groups differ (one per agent against one of all); with one group for
    // both, the saved values tell them apart.
    for (stacking, expected) in [("auto", "shared critics need one group"), ("all", "networks.critic")] {
        let config = critic_config(tmp.path(), stacking, "dense_fmsr_is", "per_agent");
        let with_stacking = std::fs::read_to_string(&config)
            .unwrap()
            .replace("critic = \"per_agent\"\n", &format!("critic = \"per_agent\"\nstacking = \"{stacking}\"\n"));
        std::fs::write(&config, with_stacking).unwrap();
        let run = tmp.path().join(format!("own_{stacking}"));
        let out = fmsr(&["train", "--config", config.to_str().unwrap(), "--out", run.to_str().unwrap(), "--quiet"]);
        assert!(out.status.success(), "{}", text(&out));
        let written = std::fs::read_to_string(run.join("config.toml")).unwrap();
        std::fs::write(run.join("config.toml"), written.replace("\"per_agent\"", "\"shared_trunk\"")).unwrap();
        let out = fmsr(&["train", "--out", run.to_str().unwrap(), "--resume", "--epochs", "2"]);
        assert!(!out.status.success() && text(&out).contains(expected), "{}", text(&out));
    }
}

/// The RGBA frames of a GIF file.
fn gif_frames(path: &Path) -> Vec<Vec<u8>> {
    let mut options = gif::DecodeOptions::new();
    options.set_color_output(gif::ColorOutput::RGBA);
    let mut decoder = options.read_info(std::fs::File::open(path).unwrap()).unwrap();
    let mut frames = Vec::new();
    while let Some(frame) = decoder.read_next_frame().unwrap() {
        frames.push(frame.buffer.to_vec());
    }
    frames
}

/// Fraction of RGBA pixels differing by more than 8 in some channel.
fn changed(a: &[u8], b: &[u8]) -> f64 {
    let n = a.chunks(4).zip(b.chunks(4)).filter(|(p, q)| p.iter().zip(*q).any(|(x, y)| x.abs_diff(*y) > 8)).count();
    n as f64 / (a.len() / 4) as f64
}

// Guards `fmsr render`: a GIF of one frame per env step whose frames are not
// blank and change as the hand moves; PNG frames into a directory; clear
// errors for an episode outside the test set and an unknown format.
#[test]
fn render_writes_a_gif_and_png_frames_of_a_test_episode() {
    let tmp = tempfile::tempdir().unwrap();
    let run = trained_tiny_run(tmp.path());
    let (run_s, gif) = (run.to_str().unwrap(), tmp.path().join("ep.gif"));
    let out =
        fmsr(&["render", run_s, "--episode", "1", "--out", gif.to_str().unwrap(), "--width", "160", "--height", "120"]);
    assert!(out.status.success(), "{}", text(&out));
    let frames = gif_frames(&gif);
    assert_eq!(frames.len(), 100, "one frame per step of the tiny config's 100-step episode");
    let colors = frames[0].chunks(4).collect::<std::collections::HashSet<_>>().len();
    assert!(colors > 20, "the first frame has {colors} colours");
    let moved = changed(&frames[0], &frames[99]);
    assert!(moved > 0.005, "the last frame differs from the first in {moved:.4} of the pixels");
    assert!(tmp.path().join("ep-strip.png").exists());

    let dir = tmp.path().join("frames");
    let out = fmsr(&["render", run_s, "--out", dir.to_str().unwrap(), "--width", "64", "--height", "48"]);
    assert!(out.status.success(), "{}", text(&out));
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 100);
    assert_eq!(&std::fs::read(dir.join("frame-000.png")).unwrap()[..4], b"\x89PNG");

    let out = fmsr(&["render", run_s, "--episode", "2"]);
    assert!(!out.status.success() && text(&out).contains("episode 2 is not in the test set"), "{}", text(&out));
    let out = fmsr(&["render", run_s, "--out", tmp.path().join("ep.mp4").to_str().unwrap()]);
    assert!(!out.status.success() && text(&out).contains("`.mp4` is not an output format"), "{}", text(&out));
}

#[test]
fn bad_configs_are_rejected_naming_the_key() {
    let tmp = tempfile::tempdir().unwrap();
    type Edit = fn(String) -> String;
    let cases: [(Edit, &str); 17] = [
        (|t| t + "[run]\ncheckpoint_replay = false\n", "`run`"),
        (|t| t.replace("batch_size = 32", "batch_size = \"many\""), "batch_size"),
        (|t| t.replace("hidden = 32", "hiden = 32"), "networks.hiden"),
        // One owner per setting: the method owns the task reward, shadow rewards and sharing.
        (|t| t.replace("[env]\n", "[env]\nreward = \"sparse\"\n"), "env.reward"),
        // Named itself, not as `drop_height` (the key its check once shared).
        (|t| t.replace("[env]\n", "[env]\ntouch_threshold = -1.0\n"), "`touch_threshold`"),
        (|t| t.replace("[sharing]\n", "[sharing]\nenabled = false\n"), "sharing.enabled"),
        (|t| t.replace("method = \"dense_fmsr_is\"", "method = \"dense_fmsr\""), "`sharing`"),
        // A section of an algorithm that is not chosen.
        (|t| t + "[matd3]\npolicy_delay = 3\n", "matd3"),
        (|t| t.replace("[networks]", "[ddpg]"), "[networks]"),
        (
            |t| {
                t.replace(
                    "mixing = { rule = \"metropolis_hastings\" }",
                    "mixing = { rule = \"matrix\", rows = [[0.5, 0.5], [0.5, 0.5]] }",
                )
            },
            "sharing.mixing",
        ),
        (
            |t| {
                t.replace(
                    "mixing = { rule = \"metropolis_hastings\" }",
                    "mixing = { rule = \"matrix\", rows = [[0.9, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0], \
                     [0, 0, 0, 1, 0, 0], [0, 0, 0, 0, 1, 0], [0, 0, 0, 0, 0, 1]] }",
                )
            },
            "row 0",
        ),
        (|t| t + "[graph]\nedges = [[\"thumb\", \"pinky\"]]\n", "pinky"),
        (|t| t.replace("threshold = 0.4", "threshold = -1.0"), "eval.threshold"),
        // Caught when the file is read, under its own key (it was once caught after
        // the environment loaded, under `trainer.shadow.assignment`).
        (|t| t.replace("alpha = 0.1", "alpha = -0.1"), "trainer.shadow.alpha"),
        (|t| t + "[[env.agents]]\nname = \"hand\"\nactuators = [\"WRJ1\", \"WRJ0\"]\n", "env.agents"),
        // A device this build does not have, and one that does not exist.
        (|t| format!("device = \"vulkan:0\"\n{t}"), "device `vulkan:0`"),
        (|t| format!("device = \"gpu\"\n{t}"), "device `gpu`"),
    ];
    for (i, (edit, key)) in cases.iter().enumerate() {
        let dir = tmp.path().join(format!("case{i}"));
        std::fs::create_dir_all(&dir).unwrap();
        let config = tiny_config(&dir, "");
        let original = std::fs::read_to_string(&config).unwrap();
        let edited = edit(original.clone());
        assert_ne!(edited, original, "case {i} changed nothing");
        std::fs::write(&config, edited).unwrap();
        let out = fmsr(&["train", "--config", config.to_str().unwrap(), "--out", dir.join("run").to_str().unwrap()]);
        assert!(!out.status.success(), "case {i} was accepted");
        assert!(text(&out).contains(key), "case {i}: the error does not name `{key}`:\n{}", text(&out));
        assert!(!dir.join("run").exists(), "case {i} created the run directory");
    }
}

// Guards `fmsr train --resume --engine`: a resumed run keeps its engine, as it
// keeps its seed. `--engine` once replaced the run's engine silently: the rest
// of the run trained on the other engine, config.toml was rewritten to name it,
// and the run's earlier `eval.json` then read as that engine's evaluation.
#[test]
fn a_resumed_run_keeps_its_engine() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    std::fs::create_dir_all(&run).unwrap();
    // A run directory of the tiny (rapier) config, saved as a run saves it; refusing needs no checkpoint.
    let saved = fmsr::experiment::ExperimentConfig::load(&tiny_config(tmp.path(), "")).unwrap().to_toml().unwrap();
    std::fs::write(run.join("config.toml"), saved).unwrap();
    let before = std::fs::read_to_string(run.join("config.toml")).unwrap();
    assert!(before.contains("engine = \"rapier\""), "{before}");
    let run_s = run.to_str().unwrap();
    let out = fmsr(&["train", "--out", run_s, "--resume", "--engine", "mujoco"]);
    assert!(!out.status.success(), "{}", text(&out));
    assert!(text(&out).contains("a resumed run keeps its engine"), "{}", text(&out));
    assert_eq!(std::fs::read_to_string(run.join("config.toml")).unwrap(), before);
    // Its own engine named again is no change: this run fails later, for want of a checkpoint.
    let out = fmsr(&["train", "--out", run_s, "--resume", "--engine", "rapier"]);
    assert!(!text(&out).contains("keeps its engine"), "{}", text(&out));
}

#[test]
fn every_algorithm_trains_on_the_hand() {
    let tmp = tempfile::tempdir().unwrap();
    for algorithm in ["maddpg", "matd3", "masac"] {
        let dir = tmp.path().join(algorithm);
        std::fs::create_dir_all(&dir).unwrap();
        let config = tiny_config(&dir, "");
        let text_in = std::fs::read_to_string(&config).unwrap();
        let edited = text_in
            .replace("method = \"dense_fmsr_is\"", &format!("method = \"dense_fmsr_is\"\nalgorithm = \"{algorithm}\""));
        std::fs::write(&config, edited).unwrap();
        let run = dir.join("run");
        let out = fmsr(&["train", "--config", config.to_str().unwrap(), "--out", run.to_str().unwrap()]);
        assert!(out.status.success(), "{algorithm}: {}", text(&out));
        assert!(std::fs::read_to_string(run.join("config.toml")).unwrap().contains(algorithm));
        assert_eq!(std::fs::read_to_string(run.join("metrics.jsonl")).unwrap().lines().count(), 1);
    }
}

/// The epochs of a run's `metrics.jsonl` without wall-clock timings.
fn learning_history(run: &Path) -> Vec<serde_json::Value> {
    let text = std::fs::read_to_string(run.join("metrics.jsonl")).unwrap();
    text.lines()
        .map(|line| {
            let mut v: serde_json::Value = serde_json::from_str(line).unwrap();
            for timing in ["seconds", "env_steps_per_sec", "updates_per_sec"] {
                v.as_object_mut().unwrap().remove(timing);
            }
            v
        })
        .collect()
}

/// Guards runs that never lose data: a run killed with SIGKILL at
/// pseudo-random moments, each time also left with the debris of a crash
/// inside a checkpoint (a torn temporary checkpoint, a replay segment the
/// checkpoint does not count yet), and resumed, ends with exactly the history
/// and the replay log of an uninterrupted run.
#[test]
fn killed_runs_resume_to_the_uninterrupted_history() {
    let tmp = tempfile::tempdir().unwrap();
    let config = tiny_config(tmp.path(), "");
    let (full, killed) = (tmp.path().join("full"), tmp.path().join("killed"));
    let args = |run: &Path| {
        ["train", "--config", config.to_str().unwrap(), "--seed", "5", "--epochs", "6", "--out", run.to_str().unwrap()]
            .map(str::to_owned)
            .to_vec()
    };
    let start = std::time::Instant::now();
    let out = Command::new(FMSR).args(args(&full)).output().unwrap();
    assert!(out.status.success(), "{}", text(&out));
    let run_seconds = start.elapsed().as_secs_f64();

    let (mut state, mut kills) = (0x2545_F491_4F6C_DD1Du64, 0);
    loop {
        let mut a = args(&killed);
        if killed.join("checkpoint.bin").exists() {
            a.push("--resume".into());
        }
        let mut child = Command::new(FMSR).args(&a).stdout(std::process::Stdio::null()).spawn().unwrap();
        state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        let delay = run_seconds * (0.1 + 0.4 * (state >> 11) as f64 / (1u64 << 53) as f64);
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs_f64(delay);
        let status = loop {
            if let Some(status) = child.try_wait().unwrap() {
                break Some(status);
            }
            if std::time::Instant::now() >= deadline {
                break None;
            }
            std::thread::sleep(std::time::Duration::from_millis(5));
        };
        match status {
            Some(status) => {
                assert!(status.success(), "the resumed run failed");
                break;
            }
            None => {
                child.kill().unwrap(); // SIGKILL
                child.wait().unwrap();
                kills += 1;
                leave_crash_debris(&full, &killed);
            }
        }
        assert!(kills < 40, "the run never finished");
    }
    assert!(kills >= 2, "only {kills} kills: the test did not interrupt the run");
    assert_eq!(learning_history(&killed), learning_history(&full));
    let segments = |run: &Path| {
        let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(run.join("checkpoint.replay"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "seg"))
            .map(|p| (p.file_name().unwrap().to_string_lossy().into_owned(), std::fs::read(&p).unwrap()))
            .collect();
        files.sort();
        files
    };
    assert_eq!(segments(&killed), segments(&full), "the replay logs differ");
}

/// What a kill inside a checkpoint write leaves: a torn temporary checkpoint
/// and the next replay segment already written (the uninterrupted run's, which
/// is byte for byte what the killed run would have written).
fn leave_crash_debris(full: &Path, killed: &Path) {
    let Ok(bytes) = std::fs::read(full.join("checkpoint.bin")) else { return };
    let _ = std::fs::create_dir_all(killed.join("checkpoint.replay"));
    std::fs::write(killed.join(".checkpoint.bin.tmp4242"), &bytes[..bytes.len() / 2]).unwrap();
    let epochs = std::fs::read_to_string(killed.join("metrics.jsonl")).map_or(0, |t| t.lines().count());
    // The tiny config stores 2 episodes an epoch.
    let next = format!("{:020}.seg", 2 * epochs);
    if let Ok(segment) = std::fs::read(full.join("checkpoint.replay").join(&next)) {
        std::fs::write(killed.join("checkpoint.replay").join(next), segment).unwrap();
    }
}

/// Guards the model cache location: with `FMSR_ASSETS_DIR` unset, the cache
/// is the platform's (`$XDG_CACHE_HOME/fmsr`, else `$HOME/.cache/fmsr`), never
/// inside a crate's source; the first fetch puts the model there. The wheel is
/// copied from the test cache so no network is needed.
#[test]
fn the_model_cache_is_the_platform_cache() {
    let home = tempfile::tempdir().unwrap();
    let run = |args: &[&str], xdg: Option<&Path>| {
        let mut cmd = Command::new(FMSR);
        cmd.args(args).env_remove("FMSR_ASSETS_DIR").env("HOME", home.path()).env("RUST_BACKTRACE", "0");
        match xdg {
            Some(x) => cmd.env("XDG_CACHE_HOME", x),
            None => cmd.env_remove("XDG_CACHE_HOME"),
        };
        cmd.output().unwrap()
    };
    let cache = home.path().join(".cache").join("fmsr");
    let out = run(&["assets", "path"], None);
    assert!(out.status.success(), "{}", text(&out));
    assert_eq!(String::from_utf8_lossy(&out.stdout).trim(), cache.to_str().unwrap());
    let xdg = home.path().join("xdg");
    let out = run(&["assets", "path"], Some(&xdg));
    assert_eq!(String::from_utf8_lossy(&out.stdout).trim(), xdg.join("fmsr").to_str().unwrap());

    // Seed the new cache with the wheel of the test cache, then fetch: the model lands under HOME.
    let wheel = fmsr_envs::shadow_hand::assets::WHEEL_NAME;
    let test_cache = fmsr_envs::shadow_hand::assets::fetch_hand_assets(None).unwrap();
    let source = test_cache.root.parent().unwrap().parent().unwrap().join(wheel);
    std::fs::create_dir_all(&cache).unwrap();
    std::fs::copy(&source, cache.join(wheel)).unwrap();
    let out = run(&["assets", "fetch"], None);
    assert!(out.status.success(), "{}", text(&out));
    let root = PathBuf::from(String::from_utf8_lossy(&out.stdout).trim());
    assert!(root.starts_with(&cache), "{}", root.display());
    assert!(root.join("hand").join("manipulate_block_touch_sensors.xml").exists());
}

/// Guards the MuJoCo binary's library lookup: the binary built with
/// `--features mujoco` carries an rpath to MuJoCo's library, so it starts
/// without `LD_LIBRARY_PATH` (which Cargo sets for this test process, so it
/// is removed here).
#[cfg(feature = "mujoco")]
#[test]
fn the_mujoco_binary_starts_without_ld_library_path() {
    let out = Command::new(FMSR).args(["assets", "path"]).env_remove("LD_LIBRARY_PATH").output().unwrap();
    assert!(out.status.success(), "{}", text(&out));
}

/// Guards cross-engine evaluation: a policy trained on rapier is evaluated on
/// MuJoCo's test set into `eval-mujoco.json`, and the report shows both
/// evaluations in its cross-engine table.
#[cfg(feature = "mujoco")]
#[test]
fn a_rapier_policy_is_evaluated_on_mujoco() {
    let tmp = tempfile::tempdir().unwrap();
    let run = trained_tiny_run(tmp.path());
    let run_s = run.to_str().unwrap();
    for engine in [None, Some("mujoco")] {
        let mut args = vec!["eval", run_s];
        args.extend(engine.map(|e| ["--engine", e]).into_iter().flatten());
        let out = fmsr(&args);
        assert!(out.status.success(), "{}", text(&out));
    }
    let cross: serde_json::Value =
        serde_json::from_slice(&std::fs::read(run.join("eval-mujoco.json")).unwrap()).unwrap();
    assert_eq!((cross["engine"].as_str(), cross["trained_on"].as_str()), (Some("mujoco"), Some("rapier")));
    let report = tmp.path().join("report");
    let out = fmsr(&["report", run_s, "--out", report.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out));
    let summary = std::fs::read_to_string(report.join("summary.md")).unwrap();
    assert!(summary.contains("## Cross-engine evaluation"), "{summary}");
    assert!(summary.contains("| rapier | rapier |") && summary.contains("| rapier | mujoco |"), "{summary}");

    // The same policy drawn on MuJoCo, through the same model.
    let gif = tmp.path().join("mujoco.gif");
    let out = fmsr(&[
        "render",
        run_s,
        "--engine",
        "mujoco",
        "--out",
        gif.to_str().unwrap(),
        "--width",
        "64",
        "--height",
        "48",
    ]);
    assert!(out.status.success(), "{}", text(&out));
    assert_eq!(gif_frames(&gif).len(), 100);
}

/// Without the `mujoco` feature, evaluating on MuJoCo is a clear error.
#[cfg(not(feature = "mujoco"))]
#[test]
fn evaluating_on_mujoco_without_the_feature_is_a_clear_error() {
    let tmp = tempfile::tempdir().unwrap();
    let run = trained_tiny_run(tmp.path());
    let run_s = run.to_str().unwrap();
    let out = fmsr(&["eval", run_s, "--engine", "mujoco"]);
    assert!(!out.status.success());
    assert!(text(&out).contains("mujoco"), "{}", text(&out));
    assert!(!run.join("eval-mujoco.json").exists());
}

// Guards an installed `fmsr` used outside a checkout: the default experiment
// was a path relative to the working directory, so `fmsr train` (and `fmsr
// run`) without --config failed anywhere but the repository's root. Where no
// file is at the default path, the copy built into the binary is read.
#[test]
fn the_default_experiment_needs_no_checkout() {
    let tmp = tempfile::tempdir().unwrap();
    let out = std::process::Command::new(FMSR)
        .current_dir(tmp.path())
        .args(["train", "--epochs", "0", "--out", "run", "--quiet"])
        .env("RUST_BACKTRACE", "0")
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", text(&out));
    let config = std::fs::read_to_string(tmp.path().join("run/config.toml")).unwrap();
    assert!(config.contains("name = \"egg_dense_fmsr_is_quick\""), "{config}");
}
