//! Information sharing (IS, paper section III.C, eq. 8), independent of the
//! algorithm.
//!
//! With a symmetric doubly stochastic mixing matrix `M` over the agents' graph,
//! one consensus step replaces each agent's shared-shape parameters by the
//! weighted average of its neighbours':
//!
//! ```text
//! theta_i <- sum_j M[i][j] * theta_j                                  (eq. 8)
//! ```
//!
//! [`InformationSharing`] decides *when* and *what* is mixed — after the
//! critic step (target critics or both), after the actor step (target actors
//! or both), on parameters or, in gradient mode, on the gradients before the
//! optimiser step — and calls [`SharedParameters::consensus_step`] of whatever
//! holds the parameters. Every algorithm of `fmsr-nn` calls the same two hooks
//! at the same two places of its update, so IS means the same for all of them.

mod config;

use fmsr_graph::MixingMatrix;
use serde::{Deserialize, Serialize};

pub use self::config::{MixingChoice, SharingConfig};

/// What information sharing mixes (docs/design.md 3.7).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum ShareMode {
    /// Mix the trunk parameters after each update (eq. 8, default).
    #[default]
    Parameters,
    /// Mix the trunk gradients before each optimiser step.
    Gradients,
}

/// Which networks information sharing mixes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum ShareTarget {
    /// The actors' trunks (default).
    #[default]
    Actors,
    /// The critics' trunks.
    Critics,
    /// Both.
    Both,
}

/// Information sharing as a learner applies it: the validated mixing matrix
/// over the agents (node `i` = agent `i`), the mode and the target.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Sharing {
    /// The symmetric doubly stochastic mixing matrix `M` of eq. 8.
    pub mixing: fmsr_graph::MixingMatrix,
    /// Parameters (default) or gradients.
    pub mode: ShareMode,
    /// Actors (default), critics or both.
    pub target: ShareTarget,
}

/// Which kind of the agents' networks a consensus step acts on (in
/// fmsr-nn a "group" is something else: agents whose networks are stacked together).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum NetworkKind {
    /// The actors' trunks.
    Actors,
    /// The critics' trunks.
    Critics,
}

/// Parameters (or gradients) of `N` agents that have one block of equal shape
/// each, which a consensus step can mix.
pub trait SharedParameters {
    /// The error of the holder.
    type Error;

    /// `theta_i <- sum_j M[i][j] theta_j` over the blocks of the networks of `kind`.
    fn consensus_step(&mut self, kind: NetworkKind, mixing: &MixingMatrix) -> Result<(), Self::Error>;
}

/// When and what information sharing mixes; see the [module docs](self).
#[derive(Debug, Clone, PartialEq)]
pub struct InformationSharing {
    sharing: Option<Sharing>,
}

impl InformationSharing {
    /// Information sharing as configured (`None`: agents share nothing).
    #[must_use]
    pub fn new(sharing: Option<Sharing>) -> Self {
        Self { sharing }
    }

    /// The configuration, if sharing is on.
    #[must_use]
    pub fn sharing(&self) -> Option<&Sharing> {
        self.sharing.as_ref()
    }

    fn applies(&self, mode: ShareMode, kind: NetworkKind) -> Option<&MixingMatrix> {
        let s = self.sharing.as_ref()?;
        let target = matches!(
            (s.target, kind),
            (ShareTarget::Both, _)
                | (ShareTarget::Actors, NetworkKind::Actors)
                | (ShareTarget::Critics, NetworkKind::Critics)
        );
        (s.mode == mode && target).then_some(&s.mixing)
    }

    /// Whether the gradients of `kind` are mixed before its optimiser step.
    #[must_use]
    pub fn mixes_gradients(&self, kind: NetworkKind) -> bool {
        self.applies(ShareMode::Gradients, kind).is_some()
    }

    /// Gradient mode: mixes the gradients of `kind` held by `grads`, if configured.
    pub fn mix_gradients<P: SharedParameters>(&self, kind: NetworkKind, grads: &mut P) -> Result<(), P::Error> {
        match self.applies(ShareMode::Gradients, kind) {
            Some(m) => grads.consensus_step(kind, m),
            None => Ok(()),
        }
    }

    /// Parameter mode: mixes the parameters of `kind` after its optimiser step, if configured.
    pub fn mix_parameters<P: SharedParameters>(&self, kind: NetworkKind, params: &mut P) -> Result<(), P::Error> {
        match self.applies(ShareMode::Parameters, kind) {
            Some(m) => params.consensus_step(kind, m),
            None => Ok(()),
        }
    }

    /// Whether the shared parts of `kind` must start identical (they are mixed at all).
    #[must_use]
    pub fn shares(&self, kind: NetworkKind) -> bool {
        self.applies(ShareMode::Gradients, kind).is_some() || self.applies(ShareMode::Parameters, kind).is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fmsr_graph::{Graph, MetropolisHastings, MixingRule};

    /// Records which kinds were mixed.
    #[derive(Default)]
    struct Log(Vec<NetworkKind>);

    impl SharedParameters for Log {
        type Error = ();
        fn consensus_step(&mut self, kind: NetworkKind, _: &MixingMatrix) -> Result<(), ()> {
            self.0.push(kind);
            Ok(())
        }
    }

    // Guards the config's mixing choice: each `rule` of `[sharing.mixing]`
    // builds that rule's matrix, with its alpha, on a graph where the rules
    // differ (nothing else called `MixingChoice::matrix`, so swapped arms or
    // a dropped alpha went unseen); a user matrix is validated against the
    // graph; mode and target are passed on, and a disabled config shares nothing.
    #[test]
    fn each_mixing_choice_builds_its_rules_matrix() {
        use fmsr_graph::{Lazy, MaxDegree};
        // Degrees 1, 3, 1, 2, 2, 1: the edge 4-5 has weight 1/3 under MH, 1/4 under max-degree.
        let graph = Graph::from_edges(6, &[(0, 1), (1, 2), (1, 3), (3, 4), (4, 5)]).unwrap();
        let mh = MetropolisHastings.mixing_matrix(&graph).unwrap();
        let maxdeg = MaxDegree.mixing_matrix(&graph).unwrap();
        assert_ne!(mh, maxdeg);
        let lazy = |rule: &dyn MixingRule, alpha| Lazy::new(rule, alpha).unwrap().mixing_matrix(&graph).unwrap();
        let cases = [
            (MixingChoice::MetropolisHastings, mh.clone()),
            (MixingChoice::MaxDegree, maxdeg.clone()),
            (MixingChoice::LazyMetropolisHastings { alpha: 0.3 }, lazy(&MetropolisHastings, 0.3)),
            (MixingChoice::LazyMaxDegree { alpha: 0.7 }, lazy(&MaxDegree, 0.7)),
            (MixingChoice::Matrix { rows: maxdeg.to_rows() }, maxdeg.clone()),
        ];
        for (choice, want) in cases {
            assert_eq!(choice.matrix(&graph).unwrap(), want, "{choice:?}");
            let config =
                SharingConfig { mode: ShareMode::Gradients, target: ShareTarget::Both, mixing: choice, enabled: true };
            let built = config.build(&graph).unwrap().unwrap();
            assert_eq!((built.mixing, built.mode, built.target), (want, ShareMode::Gradients, ShareTarget::Both));
            assert_eq!(SharingConfig { enabled: false, ..config }.build(&graph).unwrap(), None);
        }
        // The complete graph's weights put weight on non-edges of this graph.
        let complete = MaxDegree.mixing_matrix(&Graph::complete(6)).unwrap().to_rows();
        assert!(MixingChoice::Matrix { rows: complete }.matrix(&graph).is_err());
        assert!(MixingChoice::LazyMaxDegree { alpha: 0.0 }.matrix(&graph).is_err());
    }

    // Guards the schedule: mode and target decide exactly which hook mixes,
    // for all six pairs, and the two hooks are told apart (a log of kinds
    // alone let a gradient-mode config that mixed parameters pass).
    #[test]
    fn mode_and_target_pick_the_hooks() {
        let graph = Graph::ring(3);
        let mixing = MetropolisHastings.mixing_matrix(&graph).unwrap();
        let is = |mode, target| InformationSharing::new(Some(Sharing { mixing: mixing.clone(), mode, target }));
        // (hook, kind) in the order an update calls them: critic step, then actor step.
        let run = |s: &InformationSharing| {
            let (mut grads, mut params) = (Log::default(), Log::default());
            let mut calls = Vec::new();
            for kind in [NetworkKind::Critics, NetworkKind::Actors] {
                s.mix_gradients(kind, &mut grads).unwrap();
                calls.extend(grads.0.drain(..).map(|k| (ShareMode::Gradients, k)));
                s.mix_parameters(kind, &mut params).unwrap();
                calls.extend(params.0.drain(..).map(|k| (ShareMode::Parameters, k)));
            }
            calls
        };
        let kinds = |target| match target {
            ShareTarget::Actors => vec![NetworkKind::Actors],
            ShareTarget::Critics => vec![NetworkKind::Critics],
            ShareTarget::Both => vec![NetworkKind::Critics, NetworkKind::Actors],
        };
        for mode in [ShareMode::Parameters, ShareMode::Gradients] {
            for target in [ShareTarget::Actors, ShareTarget::Critics, ShareTarget::Both] {
                let s = is(mode, target);
                let want: Vec<_> = kinds(target).into_iter().map(|k| (mode, k)).collect();
                assert_eq!(run(&s), want, "{mode:?} {target:?}");
                for kind in [NetworkKind::Critics, NetworkKind::Actors] {
                    let mixed = kinds(target).contains(&kind);
                    assert_eq!(s.shares(kind), mixed, "{mode:?} {target:?} {kind:?}");
                    assert_eq!(
                        s.mixes_gradients(kind),
                        mixed && mode == ShareMode::Gradients,
                        "{mode:?} {target:?} {kind:?}"
                    );
                }
            }
        }
        let off = InformationSharing::new(None);
        assert!(run(&off).is_empty());
        assert!(!off.shares(NetworkKind::Actors) && !off.shares(NetworkKind::Critics));
    }
}
