//! [`RapierSettings`]: the rapier backend's solver settings (speed against
//! fidelity) and the switches of the fixes of [`super`].

use serde::{Deserialize, Serialize};

/// Solver settings of the rapier backend (the speed/fidelity trade-off).
///
/// The task always advances the model's time (`substeps` x 0.002 s = 0.04 s per
/// env step); `timestep` is the length of one rapier step within it, so
/// `timestep = 0.008` covers an env step with 5 rapier steps. Each rapier step
/// (and each of its `solver_iterations`) rebuilds the multibody mass matrix, which
/// dominates the cost, while `pgs_iterations` add solver passes without that
/// rebuild. Measured against MuJoCo 3.17 on the block (settings table in
/// `tests/shadow_hand_settings.rs`):
///
/// | timestep | solver it. | PGS it. | rest z (m) | tracking (rad) | active touch | env steps/s |
/// |---|---|---|---|---|---|---|
/// | MuJoCo 0.002 x 20 | - | - | 0.1661 | 0.057 | 5.15 | 1563 |
/// | 0.002 | 4 | 1 | 0.1661 | 0.085 | 3.23 | 56 |
/// | 0.002 | 2 | 1 | 0.1661 | 0.074 | 3.32 | 101 |
/// | 0.002 | 1 | 1 | 0.1664 | 0.069 | 3.25 | 182 |
/// | 0.004 | 1 | 4 | 0.1663 | 0.073 | 3.38 | 339 |
/// | 0.008 | 2 | 1 | 0.1662 | 0.066 | 3.42 | 391 |
/// | **0.008** (default) | **1** | **4** | 0.1660 | 0.058 | 3.88 | 649 |
/// | 0.0133 | 1 | 4 | 0.1663 | 0.046 | 4.38 | 1052 |
/// | 0.02 | 1 | 4 | 0.1665 | 0.038 | 4.94 | 1563 |
///
/// (tracking: mean `|q - ctrl|` of the 20 actuated joints after 1 s at `a = +-0.5`;
/// active touch: mean active sensors per step over 20 episodes of random actions,
/// none of which dropped the block in any row; steps/s with random actions on one
/// core of a 2-core machine shared with other builds, load average 4-5, so only
/// the ratios between rows mean much.) The default is the setting closest to
/// MuJoCo's rest height and tracking error, at ~6x the speed of `fine()`.
/// (The active-touch column predates [`RapierSettings::touch_every_contact`]:
/// the sensors then read only the object's contacts. With every contact, as
/// MuJoCo counts them, random actions give 5.20 active sensors a step against
/// MuJoCo's 4.86; `examples/engine_parity.rs` measures both fidelity settings
/// against MuJoCo, and `docs/notebook/results.md` holds its table.)
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RapierSettings {
    /// Physics timestep (s); MuJoCo's model uses 0.002.
    pub timestep: f64,
    /// `IntegrationParameters::num_solver_iterations` (rapier's substeps).
    pub solver_iterations: usize,
    /// `IntegrationParameters::num_internal_pgs_iterations`.
    pub pgs_iterations: usize,
    /// `IntegrationParameters::num_internal_stabilization_iterations`.
    pub stabilization_iterations: usize,
    /// Distance below which contacts are predicted (m).
    pub prediction_distance: f64,
    /// Reuse contacts of pairs that barely moved (`IntegrationParameters::contact_recycling`).
    pub contact_recycling: bool,
    /// Touch sensors read every contact of their body inside their box, as
    /// MuJoCo's do (finger on finger included), not only the object's contacts.
    pub touch_every_contact: bool,
    /// Torsional friction of `condim >= 4` contacts (the object's `condim="4"`):
    /// after each step, the spin of the object about each contact normal
    /// relative to the touching body is opposed by an angular impulse of at most
    /// `mu_torsion` x the contact's normal impulse (MuJoCo's second friction
    /// coefficient, 0.005 m here), never more than stops that spin.
    pub torsional_friction: bool,
    /// The J1/J0 tendon's slack: the coupled distal joint moves freely while the
    /// tendon length `c_0 q_0 + c_k q_k` is inside its range (+-0.001 m, about
    /// +-0.14 rad of J0), and the coupling engages at the ends of the range, as
    /// MuJoCo's tendon limit does. Off: the coupling is an equality at length 0.
    pub tendon_slack: bool,
}

impl Default for RapierSettings {
    fn default() -> Self {
        Self {
            timestep: 0.008,
            solver_iterations: 1,
            pgs_iterations: 4,
            stabilization_iterations: 1,
            prediction_distance: 0.002,
            contact_recycling: true,
            touch_every_contact: true,
            torsional_friction: true,
            tendon_slack: true,
        }
    }
}

impl RapierSettings {
    /// MuJoCo's own step (0.002 s) with 2 solver iterations: about 6x slower than
    /// the default, for comparisons.
    #[must_use]
    pub fn fine() -> Self {
        Self { timestep: 0.002, solver_iterations: 2, pgs_iterations: 1, ..Self::default() }
    }

    /// The default solver without the fidelity settings: touch sensors read
    /// only the object's contacts, contacts have no torsional friction and the
    /// J1/J0 coupling has no slack (how the earliest runs were simulated, before
    /// the fidelity settings), for comparisons.
    ///
    /// ```
    /// use fmsr_envs::shadow_hand::RapierSettings;
    /// let before = RapierSettings::without_fidelity();
    /// assert!(!before.touch_every_contact && !before.torsional_friction && !before.tendon_slack);
    /// assert_eq!(before.timestep, RapierSettings::default().timestep);
    /// ```
    #[must_use]
    pub fn without_fidelity() -> Self {
        Self { touch_every_contact: false, torsional_friction: false, tendon_slack: false, ..Self::default() }
    }
}
