//! The physics engine chosen at run time: [`Engine`] names it (a config's
//! `engine = "rapier"`), [`EnginePhysics`] is either backend behind one type,
//! so a program builds, trains, evaluates and renders the hand with one code
//! path whatever the engine ([`ShadowHandConfig::init_engine`]).
//!
//! The dispatch is one `match` per physics call, a few calls per env step,
//! each of which runs `substeps` (20 in the paper's configs) physics steps.
// A build with neither engine feature has no backend: every call's arguments go unused.
#![cfg_attr(not(any(feature = "rapier", feature = "mujoco")), allow(unused_variables, unreachable_code))]

use fmsr_core::env::ObjectContacts;
use serde::{Deserialize, Serialize};

#[cfg(feature = "mujoco")]
use super::mujoco::MujocoHand;
use super::physics::HandPhysics;
#[cfg(feature = "rapier")]
use super::rapier::RapierHand;
use super::{ShadowHand, ShadowHandConfig};
use crate::error::EnvError;

/// Which physics engine runs the Shadow Hand.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Engine {
    /// rapier3d, pure Rust (default; cargo feature `rapier`, on by default).
    #[default]
    Rapier,
    /// MuJoCo 3.17 (cargo feature `mujoco`).
    Mujoco,
}

impl Engine {
    /// Every engine, rapier first.
    pub const ALL: [Engine; 2] = [Engine::Rapier, Engine::Mujoco];

    /// The engine's name in configs and file names.
    ///
    /// ```
    /// use fmsr_envs::shadow_hand::Engine;
    /// assert_eq!(Engine::Mujoco.key(), "mujoco");
    /// assert_eq!(Engine::default().key(), "rapier");
    /// ```
    #[must_use]
    pub fn key(self) -> &'static str {
        match self {
            Engine::Rapier => "rapier",
            Engine::Mujoco => "mujoco",
        }
    }

    /// Whether this build can run the engine (each needs its cargo feature,
    /// `rapier` or `mujoco`).
    ///
    /// ```
    /// use fmsr_envs::shadow_hand::Engine;
    /// assert_eq!(Engine::Rapier.available(), cfg!(feature = "rapier"));
    /// assert_eq!(Engine::Mujoco.available(), cfg!(feature = "mujoco"));
    /// ```
    #[must_use]
    pub fn available(self) -> bool {
        match self {
            Engine::Rapier => cfg!(feature = "rapier"),
            Engine::Mujoco => cfg!(feature = "mujoco"),
        }
    }
}

/// Either physics backend of the Shadow Hand, chosen by [`Engine`] at run time
/// (a variant per engine this build has: without either feature, none).
#[derive(Debug)]
pub enum EnginePhysics {
    /// rapier3d (boxed: its state is some 7 kB, MuJoCo's a pointer).
    #[cfg(feature = "rapier")]
    Rapier(Box<RapierHand>),
    /// MuJoCo.
    #[cfg(feature = "mujoco")]
    Mujoco(MujocoHand),
}

impl EnginePhysics {
    /// The engine this backend is.
    #[must_use]
    pub fn engine(&self) -> Engine {
        match *self {
            #[cfg(feature = "rapier")]
            EnginePhysics::Rapier(_) => Engine::Rapier,
            #[cfg(feature = "mujoco")]
            EnginePhysics::Mujoco(_) => Engine::Mujoco,
        }
    }
}

/// Calls `$body` with `$p` bound to the backend inside `$self`.
#[cfg(any(feature = "rapier", feature = "mujoco"))]
macro_rules! dispatch {
    ($self:expr, $p:ident => $body:expr) => {
        match $self {
            #[cfg(feature = "rapier")]
            EnginePhysics::Rapier($p) => $body,
            #[cfg(feature = "mujoco")]
            EnginePhysics::Mujoco($p) => $body,
        }
    };
}

/// A build without engines has no `EnginePhysics` value to call.
#[cfg(not(any(feature = "rapier", feature = "mujoco")))]
macro_rules! dispatch {
    ($self:expr, $p:ident => $body:expr) => {
        match *$self {}
    };
}

impl HandPhysics for EnginePhysics {
    fn timestep(&self) -> f64 {
        dispatch!(self, p => p.timestep())
    }

    fn ctrl_range(&self) -> &[[f64; 2]] {
        dispatch!(self, p => p.ctrl_range())
    }

    fn touch_names(&self) -> &[String] {
        dispatch!(self, p => p.touch_names())
    }

    fn reset(&mut self) {
        dispatch!(self, p => p.reset());
    }

    fn set_object_pose(&mut self, position: [f64; 3], quaternion: [f64; 4]) {
        dispatch!(self, p => p.set_object_pose(position, quaternion));
    }

    fn set_ctrl(&mut self, ctrl: &[f64]) {
        dispatch!(self, p => p.set_ctrl(ctrl));
    }

    fn step(&mut self, substeps: usize) {
        dispatch!(self, p => p.step(substeps));
    }

    fn hand_qpos(&self, out: &mut [f64]) {
        dispatch!(self, p => p.hand_qpos(out));
    }

    fn hand_qvel(&self, out: &mut [f64]) {
        dispatch!(self, p => p.hand_qvel(out));
    }

    fn object_pose(&self) -> ([f64; 3], [f64; 4]) {
        dispatch!(self, p => p.object_pose())
    }

    fn object_qvel(&self) -> [f64; 6] {
        dispatch!(self, p => p.object_qvel())
    }

    fn touch(&self) -> &[f64] {
        dispatch!(self, p => p.touch())
    }

    fn palm_center(&self) -> [f64; 3] {
        dispatch!(self, p => p.palm_center())
    }

    fn object_contacts(&self) -> ObjectContacts {
        dispatch!(self, p => p.object_contacts())
    }
}

impl ShadowHandConfig {
    /// The hand on `engine` (MuJoCo with its default settings): the one place
    /// a program turns an engine's name into physics.
    ///
    /// # Errors
    /// [`EnvError::EngineUnavailable`] for an engine whose feature (`rapier`,
    /// `mujoco`) this build lacks; otherwise the errors of building that
    /// engine's physics (`rapier_physics`, `init_mujoco`).
    pub fn init_engine(self, engine: Engine) -> Result<ShadowHand<EnginePhysics>, EnvError> {
        let physics = match engine {
            #[cfg(feature = "rapier")]
            Engine::Rapier => EnginePhysics::Rapier(Box::new(self.rapier_physics()?)),
            #[cfg(not(feature = "rapier"))]
            Engine::Rapier => return Err(EnvError::EngineUnavailable { engine: engine.key(), feature: "rapier" }),
            #[cfg(feature = "mujoco")]
            Engine::Mujoco => EnginePhysics::Mujoco(self.mujoco_physics(super::MujocoSettings::default())?),
            #[cfg(not(feature = "mujoco"))]
            Engine::Mujoco => return Err(EnvError::EngineUnavailable { engine: engine.key(), feature: "mujoco" }),
        };
        self.init_with(physics)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Guards the engines' features: an engine left out of the build is refused
    /// by name, before any model is fetched (CI runs it without either engine).
    #[test]
    fn an_engine_left_out_is_refused_by_its_feature() {
        for engine in Engine::ALL.into_iter().filter(|e| !e.available()) {
            match ShadowHandConfig::default().init_engine(engine) {
                Err(EnvError::EngineUnavailable { engine: name, feature }) => {
                    assert_eq!((name, feature), (engine.key(), engine.key()));
                }
                other => panic!("{engine:?} without its feature gave {other:?}"),
            }
        }
    }
}
