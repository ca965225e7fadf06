//! The labels and parsing of experiments.

use std::path::Path;

use fmsr_envs::shadow_hand::GoalDistance;
use fmsr_nn::TargetClip;

use super::{Engine, ExperimentConfig, ExperimentError, Stack};

// Guards the report's grouping: a single agent owning the whole hand is a
// configuration of its own, never pooled with the paper's six-agent Sparse.
#[test]
fn a_single_agent_config_is_labelled_apart_from_the_paper_method() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/lite");
    let single = ExperimentConfig::load(&root.join("block_single_agent_sparse.toml")).unwrap();
    let six = ExperimentConfig::load(&root.join("block_sparse.toml")).unwrap();
    assert_eq!((single.label(), six.label()), ("Sparse, 1 agent".to_string(), "Sparse".to_string()));
}

// Guards the reproducibility of a run: its config.toml names every setting
// of its algorithm, also those the experiment file left to their defaults,
// so a later change of a default (say `teammates`) cannot change a run
// that is resumed or evaluated.
#[test]
fn a_written_config_records_the_algorithms_settings() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/block_dense_fmsr_is_quick.toml");
    assert!(!std::fs::read_to_string(&path).unwrap().contains("[maddpg]"));
    let written = ExperimentConfig::load(&path).unwrap().to_toml().unwrap();
    let table: toml::Table = written.parse().unwrap();
    let maddpg = table.get("maddpg").and_then(toml::Value::as_table).expect("a [maddpg] section");
    for key in ["polyak", "teammates", "action_l2"] {
        assert!(maddpg.contains_key(key), "[maddpg] lacks `{key}`:\n{written}");
    }
    assert!(!table.contains_key("matd3") && !table.contains_key("masac"), "{written}");
}

// Guards the report's grouping of the teammates ablation: its runs are
// labelled apart from the method's.
#[test]
fn the_current_teammates_ablation_is_labelled_apart() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/lite");
    let ablation = ExperimentConfig::load(&root.join("ablation/block_dense_fmsr_is_current_teammates.toml")).unwrap();
    let method = ExperimentConfig::load(&root.join("block_dense_fmsr_is.toml")).unwrap();
    assert_eq!(ablation.label(), "Dense+FMSR+IS, current teammates");
    assert_eq!(method.label(), "Dense+FMSR+IS");
}

// Guards the report's grouping by algorithm and training engine: a MATD3
// or MuJoCo-trained run was once labelled as the method alone, and so
// pooled with the MADDPG, rapier runs as one more seed.
#[test]
fn other_algorithms_and_engines_are_labelled_apart() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/lite");
    let method = ExperimentConfig::load(&root.join("block_dense.toml")).unwrap();
    let with =
        |algorithm: &str, engine| ExperimentConfig { algorithm: algorithm.into(), engine, ..method.clone() }.label();
    assert_eq!(with("maddpg", Engine::Rapier), "Dense");
    assert_eq!(with("matd3", Engine::Rapier), "Dense, MATD3");
    assert_eq!(with("masac", Engine::Mujoco), "Dense, MASAC, trained on MuJoCo");
    assert_eq!(with("maddpg", Engine::Mujoco), "Dense, trained on MuJoCo");
    assert_eq!(with("not_registered_here", Engine::Rapier), "Dense, NOT_REGISTERED_HERE");
}

// Guards the report's grouping of the full-angle experiments: E3's runs with
// another shadow weight, E5's information sharing on gradients and the
// runs of the yaw-only task before it were labelled as the method alone,
// so a report over them and E2's runs pooled them as more seeds of
// Dense+FMSR+IS, and `fmsr run` set the yaw-era policy beside its run.
#[test]
fn shadow_weight_and_sharing_changes_are_labelled_apart() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/lite");
    let method = ExperimentConfig::load(&root.join("egg_dense_fmsr_is.toml")).unwrap();
    assert_eq!(method.label(), "Dense+FMSR+IS");
    let alpha = ExperimentConfig::load(&root.join("alpha/egg_dense_fmsr_is_alpha003.toml")).unwrap();
    assert_eq!(alpha.label(), "Dense+FMSR+IS, alpha 0.03, trained on MuJoCo");
    let gradients = ExperimentConfig::load(&root.join("ablation/egg_dense_fmsr_is_gradient_sharing.toml")).unwrap();
    assert_eq!(gradients.label(), "Dense+FMSR+IS, IS on gradients");
    let mut critics = method.clone();
    critics.sharing.get_or_insert_with(Default::default).target = fmsr_core::sharing::ShareTarget::Both;
    assert_eq!(critics.label(), "Dense+FMSR+IS, IS on actors and critics");
    // A saved run of the yaw-only task is another task; a saved config that
    // names no distance is refused, naming the key.
    let saved = method.to_toml().unwrap();
    let yaw = saved.replace("goal_distance = \"full\"", "goal_distance = \"yaw\"");
    assert_eq!(ExperimentConfig::from_saved_toml(&yaw, &root).unwrap().label(), "Dense+FMSR+IS, yaw distance");
    let none = saved.replace("goal_distance = \"full\"\n", "");
    let err = ExperimentConfig::from_saved_toml(&none, &root).unwrap_err().to_string();
    assert!(err.contains("env.goal_distance"), "{err}");
    // Dense+FMSR neither shares nor changes its label for sharing's defaults.
    let fmsr = ExperimentConfig::load(&root.join("egg_dense_fmsr.toml")).unwrap();
    assert_eq!(fmsr.label(), "Dense+FMSR");
}

/// `section.key` → value of every setting of a TOML file (the run's name left out).
fn settings(path: &Path) -> std::collections::BTreeMap<String, toml::Value> {
    let table: toml::Table = std::fs::read_to_string(path).unwrap().parse().unwrap();
    let mut out = std::collections::BTreeMap::new();
    for (key, value) in table {
        match value {
            toml::Value::Table(section) => {
                out.extend(section.into_iter().map(|(k, v)| (format!("{key}.{k}"), v)));
            }
            value if key != "name" => drop(out.insert(key, value)),
            _ => {}
        }
    }
    out
}

/// The TOML files of `dir`, sorted.
fn toml_files(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    files
}

/// The settings in which the ablation config `path` differs from its
/// method's lite config in `root`, and the labels of the two.
fn changes(root: &Path, path: &Path) -> (String, std::collections::BTreeSet<String>, [String; 2]) {
    let a = settings(path);
    let name = |key: &str| a[key].as_str().unwrap().to_string();
    let base = format!("{}_{}.toml", name("env.object"), name("method"));
    let b = settings(&root.join(&base));
    let changed = a.keys().chain(b.keys()).filter(|k| a.get(*k) != b.get(*k)).cloned().collect();
    let label = |p: &Path| ExperimentConfig::load(p).unwrap().label();
    (base.clone(), changed, [label(path), label(&root.join(base))])
}

// Guards the paper-budget pair on MuJoCo: each config
// in configs/mujoco/ is the paper's config of its name with `engine`
// changed, and with the shadow reward's `alpha` (chosen by E3) at most.
#[test]
fn paper_configs_on_mujoco_change_the_engine_alone() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs");
    let files = toml_files(&root.join("mujoco"));
    assert!(!files.is_empty());
    for path in files {
        let paper = root.join(path.file_name().unwrap());
        let (a, b) = (settings(&path), settings(&paper));
        let changed: std::collections::BTreeSet<_> =
            a.keys().chain(b.keys()).filter(|k| a.get(*k) != b.get(*k)).cloned().collect();
        assert!(changed.contains("engine"), "{}", path.display());
        assert!(
            changed.iter().all(|k| k == "engine" || k == "trainer.shadow.alpha"),
            "{} against {}: {changed:?}",
            path.display(),
            paper.display()
        );
        assert_eq!(a["engine"].as_str(), Some("mujoco"), "{}", path.display());
        let name = |p: &Path| ExperimentConfig::load(p).unwrap().name;
        assert_eq!(name(&path), name(&paper), "{}: the run keeps the paper config's name", path.display());
    }
}

// Guards what E6 and E7 compare: each config in configs/lite/paper_stack/
// is its method's lite config with `stack = "paper"` alone, each in
// configs/lite/attribution/ changes exactly one of the settings that
// stack owns, to the stack's value, and every one is labelled apart.
#[test]
fn the_paper_stack_runs_change_what_they_say() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/lite");
    let stack = toml_files(&root.join("paper_stack"));
    assert_eq!(stack.len(), 2);
    for path in &stack {
        let (base, changed, [label, method]) = changes(&root, path);
        assert_eq!(changed, ["stack".to_string()].into(), "{} against {base}", path.display());
        assert_eq!(label, format!("{method}, paper stack"));
    }
    let attribution = toml_files(&root.join("attribution"));
    let mut owned = std::collections::BTreeSet::new();
    for path in &attribution {
        let (base, changed, [label, method]) = changes(&root, path);
        assert_eq!(changed.len(), 1, "{} against {base}: {changed:?}", path.display());
        let key = changed.into_iter().next().unwrap();
        let rule = Stack::OWNED.iter().find(|o| o.key == key).expect("a setting the paper stack owns");
        assert_eq!(settings(path)[&key].as_str(), Some(rule.paper), "{}", path.display());
        assert_ne!(label, method);
        owned.insert(key);
    }
    assert_eq!(owned.len(), Stack::OWNED.len(), "one attribution run per owned setting");
}

// Guards the preset's ownership: `stack = "paper"` sets both settings,
// refuses a file that contradicts it (naming the key), and a run's
// config.toml reads back as the same experiment.
#[test]
fn the_paper_stack_owns_its_settings() {
    let text = "name = \"x\"\nmethod = \"dense\"\nstack = \"paper\"\n";
    let config = ExperimentConfig::from_toml(text, "x.toml".as_ref()).unwrap();
    assert_eq!(config.env.goal_distance, GoalDistance::Gym);
    assert_eq!(config.networks.target_clip, TargetClip::HerBaselines);
    assert_eq!(config.networks.normalizer_stats, fmsr_nn::NormalizerStats::StoredEpisodes);
    let again = ExperimentConfig::from_saved_toml(&config.to_toml().unwrap(), "x.toml".as_ref()).unwrap();
    assert_eq!(again, config);
    for (extra, key) in [
        ("[env]\ngoal_distance = \"full\"\n", "env.goal_distance"),
        ("[networks]\ntarget_clip = \"reward_bounds\"\n", "networks.target_clip"),
        ("[networks]\nnormalizer_stats = \"sampled_batches\"\n", "networks.normalizer_stats"),
    ] {
        let err = ExperimentConfig::from_toml(&format!("{text}{extra}"), "x.toml".as_ref()).unwrap_err();
        assert!(matches!(&err, ExperimentError::Config { key: k, .. } if k == key), "{extra}: {err}");
        assert!(err.to_string().contains("stack"), "{err}");
    }
    // The stack's own values are no contradiction, and without the preset each is free.
    let agreeing = format!("{text}[env]\ngoal_distance = \"gym\"\n");
    assert!(ExperimentConfig::from_toml(&agreeing, "x.toml".as_ref()).is_ok());
    let free = "name = \"x\"\nmethod = \"dense\"\n[networks]\ntarget_clip = \"her_baselines\"\n";
    let free = ExperimentConfig::from_toml(free, "x.toml".as_ref()).unwrap();
    assert_eq!((free.stack, free.env.goal_distance), (Stack::Fmsr, GoalDistance::Full));
    assert_eq!(free.label(), "Dense, HER target clip");
}

// Guards what the ablations of docs/notebook/results.md claim: each config in
// configs/lite/ablation/ is its method's lite config with one setting
// changed, each in ablation/combined/ changes two or more of those
// settings at once, and their runs are labelled apart from the method's.
#[test]
fn every_ablation_changes_one_setting_of_its_methods_config() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/lite");
    let mut switches = std::collections::BTreeSet::new();
    let singles = toml_files(&root.join("ablation"));
    for path in &singles {
        let (base, changed, [ablation, method]) = changes(&root, path);
        assert_eq!(changed.len(), 1, "{} against {base}: {changed:?}", path.display());
        assert_ne!(ablation, method, "{}", path.display());
        switches.extend(changed);
    }
    assert!(singles.len() >= 5, "{} ablation configs", singles.len());
    for path in toml_files(&root.join("ablation/combined")) {
        let (base, changed, [ablation, method]) = changes(&root, &path);
        assert!(changed.len() >= 2, "{} against {base}: {changed:?}", path.display());
        assert!(changed.is_subset(&switches), "{}: {changed:?} not all single switches", path.display());
        assert_ne!(ablation, method, "{}", path.display());
    }
}
