//! Algorithms found by name: the registry behind an experiment's
//! `algorithm = "<name>"` and its `[<name>]` section.
//!
//! An entry is an update rule that implements
//! [`ConfiguredRule`]: its name
//! ([`UpdateRule::NAME`](fmsr_nn::UpdateRule::NAME)), its settings with
//! their defaults, and how the rule is made from them. MADDPG, MATD3 and
//! MASAC are registered from the start, like any other; a rule of your own
//! crate is registered with one call, and then fmsr's configs, experiment
//! factory, runner and command line ([`crate::cli`]) train, resume, export,
//! evaluate and report it as they do the three:
//!
//! ```
//! use fmsr::algorithms;
//! use fmsr::nn::MaddpgRule;
//! assert_eq!(algorithms::names(), ["maddpg", "masac", "matd3"]);
//! // Registering a rule again is harmless; another rule of a taken name is refused.
//! algorithms::register::<MaddpgRule>()?;
//! # Ok::<(), fmsr::error::ExperimentError>(())
//! ```
//!
//! A config's section is resolved against the rule's settings: keys it
//! names replace the defaults, an unknown key is refused naming the key, and
//! the run's `config.toml` writes every setting out (so a later change of a
//! default never changes a saved run). The registry is one per process, as
//! the command line that reads configs is.

use std::any::{Any, TypeId};
use std::collections::BTreeMap;
use std::marker::PhantomData;
use std::sync::{Arc, LazyLock, PoisonError, RwLock};

use fmsr_nn::{AnyLearner, ConfiguredRule, LearnerParts, MaddpgRule, MasacRule, Matd3Rule, OffPolicy, Teammates};

use crate::error::ExperimentError;

/// Keys of an experiment that no algorithm may take as its name.
const RESERVED: [&str; 14] = [
    "name",
    "task",
    "method",
    "stack",
    "algorithm",
    "engine",
    "device",
    "env",
    "trainer",
    "replay",
    "networks",
    "sharing",
    "graph",
    "eval",
];

/// A registered algorithm's settings, read once: the rule's own
/// [`ConfiguredRule::Config`], every setting resolved (the section's keys
/// over the rule's defaults), beside the registry's entry that reads it.
/// An experiment keeps these from the moment it is loaded; building,
/// labelling and writing a run take them as they are.
#[derive(Clone)]
pub struct AlgorithmSettings {
    entry: Arc<dyn Entry>,
    config: Arc<dyn Any + Send + Sync>,
}

impl AlgorithmSettings {
    /// The settings of algorithm `name` from its section (absent: the
    /// rule's defaults), checked by the rule.
    ///
    /// # Errors
    /// [`ExperimentError::Config`] for an unknown algorithm or key, or a
    /// value of the wrong type, naming the key; the rule's own checks.
    pub fn resolve(name: &str, section: Option<&toml::Table>) -> Result<Self, ExperimentError> {
        let entry = find(name)?;
        let config = entry.resolve(section)?;
        let settings = Self { entry, config };
        settings.entry.validate(&*settings.config)?;
        Ok(settings)
    }

    /// Rule `R`'s own settings.
    ///
    /// # Errors
    /// [`ExperimentError::Config`] when these are another rule's settings.
    pub fn get<R: ConfiguredRule>(&self) -> Result<&R::Config, ExperimentError> {
        self.config.downcast_ref::<R::Config>().ok_or_else(|| {
            ExperimentError::config(
                R::NAME,
                format!("these are the settings of `{}`, not of `{}`", self.entry.name(), R::NAME),
            )
        })
    }

    /// The settings as the rule's TOML section, every setting written out.
    ///
    /// # Errors
    /// [`ExperimentError::Config`] when a value cannot be written as TOML.
    pub fn to_table(&self) -> Result<toml::Table, ExperimentError> {
        self.entry.write(&*self.config)
    }

    /// Which teammates' actions the actors' loss takes.
    #[must_use]
    pub fn teammates(&self) -> Teammates {
        self.entry.teammates(&*self.config)
    }

    /// The learner of these settings on `parts`.
    ///
    /// # Errors
    /// The rule's checks of its parts ([`ExperimentError::Nn`]).
    pub fn build(&self, parts: LearnerParts) -> Result<AnyLearner, ExperimentError> {
        self.entry.build(&*self.config, parts)
    }

    /// The algorithm's part of a run's label.
    pub(crate) fn label(&self) -> Option<String> {
        self.entry.label()
    }
}

impl PartialEq for AlgorithmSettings {
    fn eq(&self, other: &Self) -> bool {
        self.entry.rule() == other.entry.rule() && self.entry.eq(&*self.config, &*other.config)
    }
}

impl std::fmt::Debug for AlgorithmSettings {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.entry.debug(&*self.config, f)
    }
}

/// What the registry keeps of one rule. Its methods take the rule's
/// settings as the [`AlgorithmSettings`] it made hold them (`&dyn Any`: the
/// rule's `Config`).
pub(crate) trait Entry: Send + Sync {
    /// The rule's type, to tell a second registration from a clash.
    fn rule(&self) -> TypeId;

    /// The rule's name.
    fn name(&self) -> &'static str;

    /// The settings of `section` (absent: all defaults); the error names the key.
    fn resolve(&self, section: Option<&toml::Table>) -> Result<Arc<dyn Any + Send + Sync>, ExperimentError>;

    /// The settings written out as the rule's section.
    fn write(&self, config: &dyn Any) -> Result<toml::Table, ExperimentError>;

    /// Checks the settings as the rule does.
    fn validate(&self, config: &dyn Any) -> Result<(), ExperimentError>;

    /// The algorithm's part of a run's label.
    fn label(&self) -> Option<String>;

    /// Which teammates' actions the actors' loss takes.
    fn teammates(&self, config: &dyn Any) -> Teammates;

    /// The learner of these settings on `parts`.
    fn build(&self, config: &dyn Any, parts: LearnerParts) -> Result<AnyLearner, ExperimentError>;

    /// Whether two of the rule's settings are equal.
    fn eq(&self, a: &dyn Any, b: &dyn Any) -> bool;

    /// The settings as the rule's `Debug` writes them.
    fn debug(&self, config: &dyn Any, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result;
}

struct RuleEntry<R>(PhantomData<fn() -> R>);

impl<R: ConfiguredRule> RuleEntry<R> {
    /// The rule's settings; [`AlgorithmSettings`] pairs every entry with
    /// settings it resolved itself, so another type is a bug of this module.
    fn config(config: &dyn Any) -> &R::Config {
        config.downcast_ref::<R::Config>().expect("an entry is only given the settings it resolved")
    }
}

impl<R: ConfiguredRule> Entry for RuleEntry<R> {
    fn rule(&self) -> TypeId {
        TypeId::of::<R>()
    }

    fn name(&self) -> &'static str {
        R::NAME
    }

    fn resolve(&self, section: Option<&toml::Table>) -> Result<Arc<dyn Any + Send + Sync>, ExperimentError> {
        Ok(Arc::new(resolve_section(R::NAME, &R::default_config(), section)?))
    }

    fn write(&self, config: &dyn Any) -> Result<toml::Table, ExperimentError> {
        toml::Table::try_from(Self::config(config))
            .map_err(|e| ExperimentError::config_source(R::NAME, "the settings cannot be written as TOML", e))
    }

    fn validate(&self, config: &dyn Any) -> Result<(), ExperimentError> {
        Ok(R::from_config(Self::config(config).clone()).validate()?)
    }

    fn label(&self) -> Option<String> {
        R::label()
    }

    fn teammates(&self, config: &dyn Any) -> Teammates {
        R::teammates(Self::config(config))
    }

    fn build(&self, config: &dyn Any, parts: LearnerParts) -> Result<AnyLearner, ExperimentError> {
        let rule = R::from_config(Self::config(config).clone());
        Ok(AnyLearner::new(OffPolicy::with_rule(parts, rule)?))
    }

    fn eq(&self, a: &dyn Any, b: &dyn Any) -> bool {
        a.downcast_ref::<R::Config>() == b.downcast_ref::<R::Config>()
    }

    fn debug(&self, config: &dyn Any, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Debug::fmt(Self::config(config), f)
    }
}

type Registry = BTreeMap<&'static str, Arc<dyn Entry>>;

static REGISTRY: LazyLock<RwLock<Registry>> = LazyLock::new(|| {
    let mut registry = Registry::new();
    for (name, entry) in [
        (<MaddpgRule as fmsr_nn::UpdateRule>::NAME, Arc::new(RuleEntry::<MaddpgRule>(PhantomData)) as Arc<dyn Entry>),
        (<Matd3Rule as fmsr_nn::UpdateRule>::NAME, Arc::new(RuleEntry::<Matd3Rule>(PhantomData))),
        (<MasacRule as fmsr_nn::UpdateRule>::NAME, Arc::new(RuleEntry::<MasacRule>(PhantomData))),
    ] {
        registry.insert(name, entry);
    }
    RwLock::new(registry)
});

/// Registers rule `R` under its name, so that configs may say
/// `algorithm = "<R::NAME>"` and set its settings in `[<R::NAME>]`.
/// Registering the same rule again does nothing.
///
/// # Errors
/// [`ExperimentError::Register`] when another rule holds the name, or the
/// name is not a lowercase key (`a-z`, `0-9`, `_`, starting with a letter)
/// or is one of an experiment's own keys (`env`, `trainer`, ...).
pub fn register<R: ConfiguredRule>() -> Result<(), ExperimentError> {
    let name = R::NAME;
    let refuse = |reason: String| Err(ExperimentError::Register { name: name.into(), reason });
    if let Err(reason) = check_key(name) {
        return refuse(reason);
    }
    let mut registry = REGISTRY.write().unwrap_or_else(PoisonError::into_inner);
    match registry.get(name) {
        Some(entry) if entry.rule() == TypeId::of::<R>() => Ok(()),
        Some(_) => refuse(format!("another rule is registered as `{name}`")),
        None => {
            registry.insert(name, Arc::new(RuleEntry::<R>(PhantomData)));
            Ok(())
        }
    }
}

/// The settings of section `[name]` (absent: all of `defaults`) as a `C`:
/// keys it names replace the defaults, and a key the settings do not have is
/// refused. The error names the key, and keeps the decoder's error.
pub(crate) fn resolve_section<C: serde::Serialize + serde::de::DeserializeOwned>(
    name: &str,
    defaults: &C,
    section: Option<&toml::Table>,
) -> Result<C, ExperimentError> {
    let mut merged = toml::Table::try_from(defaults)
        .map_err(|e| ExperimentError::config_source(name, "the defaults cannot be written as TOML", e))?;
    for (k, v) in section.into_iter().flatten() {
        if !merged.contains_key(k) {
            let mut names: Vec<_> = merged.keys().cloned().collect();
            names.sort();
            return Err(ExperimentError::config(
                format!("{name}.{k}"),
                format!("unknown key `{name}.{k}`, expected one of {}", names.join(", ")),
            ));
        }
        merged.insert(k.clone(), v.clone());
    }
    C::deserialize(toml::Value::Table(merged))
        .map_err(|e| ExperimentError::config_source(name, format!("`[{name}]` does not read as its settings"), e))
}

/// Whether `name` is a lowercase key: `a-z`, `0-9` and `_`, starting with a letter.
pub(crate) fn is_lowercase_key(name: &str) -> bool {
    let mut chars = name.chars();
    chars.next().is_some_and(|c| c.is_ascii_lowercase())
        && chars.all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_')
}

/// Whether `name` may name a section of an experiment: a lowercase key
/// (`a-z`, `0-9`, `_`, starting with a letter) that is none of an
/// experiment's own keys; `Err` says why not.
pub(crate) fn check_key(name: &str) -> Result<(), String> {
    if !is_lowercase_key(name) {
        return Err("a name is a lowercase key: a-z, 0-9 and _, starting with a letter".into());
    }
    if RESERVED.contains(&name) {
        return Err(format!("`{name}` is an experiment's own key"));
    }
    Ok(())
}

/// The registered algorithms' names, sorted.
#[must_use]
pub fn names() -> Vec<&'static str> {
    REGISTRY.read().unwrap_or_else(PoisonError::into_inner).keys().copied().collect()
}

/// The entry of algorithm `name`.
///
/// # Errors
/// [`ExperimentError::Config`] for key `algorithm`, listing the registered names.
pub(crate) fn find(name: &str) -> Result<Arc<dyn Entry>, ExperimentError> {
    let registry = REGISTRY.read().unwrap_or_else(PoisonError::into_inner);
    registry.get(name).cloned().ok_or_else(|| {
        ExperimentError::config(
            "algorithm",
            format!(
                "no algorithm `{name}`; registered: {} (a rule of your own crate is registered with \
             fmsr::algorithms::register)",
                registry.keys().copied().collect::<Vec<_>>().join(", ")
            ),
        )
    })
}

/// The learner of algorithm `name` on `parts`, with the settings of
/// `section` (absent: the defaults), as an experiment builds it.
///
/// # Errors
/// [`ExperimentError::Config`] for an unknown name or setting, the rule's
/// own checks ([`ExperimentError::Nn`]).
pub fn build(name: &str, section: Option<&toml::Table>, parts: LearnerParts) -> Result<AnyLearner, ExperimentError> {
    AlgorithmSettings::resolve(name, section)?.build(parts)
}

#[cfg(test)]
mod tests {
    use super::*;
    use fmsr_nn::{MaddpgConfig, UpdateRule};

    #[derive(Debug, Clone)]
    struct Impostor;

    impl UpdateRule for Impostor {
        const NAME: &'static str = "maddpg";

        fn act(
            &mut self,
            _: &mut fmsr_nn::Learner,
            _: &[Vec<f32>],
            _: usize,
            _: fmsr_core::policy::ActMode,
        ) -> Result<fmsr_core::policy::PolicyOutput, fmsr_nn::NnError> {
            unreachable!("never built")
        }

        fn step(
            &mut self,
            _: &mut fmsr_nn::Learner,
            _: &fmsr_nn::BatchTensors,
        ) -> Result<fmsr_nn::StepLosses, fmsr_nn::NnError> {
            unreachable!("never built")
        }

        fn targets(&self) -> (f64, bool) {
            (0.95, true)
        }
    }

    impl ConfiguredRule for Impostor {
        type Config = MaddpgConfig;

        fn default_config() -> MaddpgConfig {
            MaddpgConfig::new()
        }

        fn from_config(_: MaddpgConfig) -> Self {
            Impostor
        }
    }

    // Guards the registry's one promise: a name finds one rule. A second
    // rule of a taken name is refused, and the first still answers.
    #[test]
    fn a_taken_name_is_refused_and_keeps_its_rule() {
        let err = register::<Impostor>().unwrap_err();
        assert!(matches!(&err, ExperimentError::Register { name, .. } if name == "maddpg"), "{err}");
        assert_eq!(find("maddpg").unwrap().rule(), TypeId::of::<MaddpgRule>());
        register::<MaddpgRule>().unwrap();
    }

    // Guards the reserved names against drift: every top-level key a run's
    // config.toml can hold, but the algorithm's section, is one no rule may take.
    #[test]
    fn every_key_of_an_experiment_is_reserved() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/block_dense_fmsr_is_quick.toml");
        let config = crate::experiment::ExperimentConfig::load(&path).unwrap();
        let table: toml::Table = config.to_toml().unwrap().parse().unwrap();
        for key in table.keys().filter(|k| **k != config.algorithm) {
            assert!(RESERVED.contains(&key.as_str()), "`{key}` is not reserved");
        }
    }

    #[test]
    fn unknown_names_and_keys_are_refused_naming_them() {
        let err = find("iddpg_not_registered").map(|_| ()).unwrap_err();
        assert!(err.to_string().contains("iddpg_not_registered") && err.to_string().contains("maddpg, masac, matd3"));
        let section: toml::Table = "polyak = 0.9\nwarp = 1".parse().unwrap();
        let err = AlgorithmSettings::resolve("matd3", Some(&section)).unwrap_err();
        assert!(err.to_string().contains("`matd3.warp`"), "{err}");
        let section: toml::Table = "polyak = 0.9".parse().unwrap();
        let settings = AlgorithmSettings::resolve("matd3", Some(&section)).unwrap();
        assert_eq!(settings.get::<Matd3Rule>().unwrap().polyak, 0.9);
        let written = settings.to_table().unwrap();
        assert_eq!(written["polyak"].as_float(), Some(0.9));
        assert_eq!(written.len(), toml::Table::try_from(fmsr_nn::Matd3Config::new()).unwrap().len());
        // A value of the wrong type: the error names the section and keeps the decoder's.
        let section: toml::Table = "polyak = \"high\"".parse().unwrap();
        let err = AlgorithmSettings::resolve("matd3", Some(&section)).unwrap_err();
        assert!(matches!(&err, ExperimentError::Config { key, .. } if key == "matd3"), "{err}");
        let source = std::error::Error::source(&err).expect("the decoder's error").to_string();
        assert!(source.contains("polyak"), "{source}");
        let err = settings.get::<MaddpgRule>().unwrap_err();
        assert!(err.to_string().contains("settings of `matd3`, not of `maddpg`"), "{err}");
    }
}
