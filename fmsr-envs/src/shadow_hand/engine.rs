//! The physics engine chosen at run time: [`Engine`] names it (a config's
//! `engine = "rapier"`), [`EnginePhysics`] is either backend behind one type,
//! so a program builds, trains, evaluates and renders the hand with one code
//! path whatever the engine ([`ShadowHandConfig::init_engine`]).
//!
//! The dispatch is one `match` per physics call, a few calls per env step,
//! each of which runs `substeps` (20 in the paper's configs) physics steps.

use fmsr_core::env::ObjectContacts;
use serde::{Deserialize, Serialize};

#[cfg(feature = "mujoco")]
use super::mujoco::MujocoHand;
use super::physics::HandPhysics;
use super::rapier::RapierHand;
use super::{ShadowHand, ShadowHandConfig};
use crate::error::EnvError;

/// Which physics engine runs the Shadow Hand.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Engine {
    /// rapier3d, pure Rust (default).
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

    /// Whether this build can run the engine (MuJoCo needs the cargo feature `mujoco`).
    ///
    /// ```
    /// use fmsr_envs::shadow_hand::Engine;
    /// assert!(Engine::Rapier.available());
    /// assert_eq!(Engine::Mujoco.available(), cfg!(feature = "mujoco"));
    /// ```
    #[must_use]
    pub fn available(self) -> bool {
        match self {
            Engine::Rapier => true,
            Engine::Mujoco => cfg!(feature = "mujoco"),
        }
    }
}

/// Either physics backend of the Shadow Hand, chosen by [`Engine`] at run time.
#[derive(Debug)]
pub enum EnginePhysics {
    /// rapier3d (boxed: its state is some 7 kB, MuJoCo's a pointer).
    Rapier(Box<RapierHand>),
    /// MuJoCo.
    #[cfg(feature = "mujoco")]
    Mujoco(MujocoHand),
}

impl EnginePhysics {
    /// The engine this backend is.
    #[must_use]
    pub fn engine(&self) -> Engine {
        match self {
            EnginePhysics::Rapier(_) => Engine::Rapier,
            #[cfg(feature = "mujoco")]
            EnginePhysics::Mujoco(_) => Engine::Mujoco,
        }
    }
}

/// Calls `$body` with `$p` bound to the backend inside `$self`.
macro_rules! dispatch {
    ($self:expr, $p:ident => $body:expr) => {
        match $self {
            EnginePhysics::Rapier($p) => $body,
            #[cfg(feature = "mujoco")]
            EnginePhysics::Mujoco($p) => $body,
        }
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
    /// [`EnvError::EngineUnavailable`] for MuJoCo in a build without the
    /// feature `mujoco`; otherwise the errors of [`ShadowHandConfig::init`]
    /// or `init_mujoco`.
    pub fn init_engine(self, engine: Engine) -> Result<ShadowHand<EnginePhysics>, EnvError> {
        let physics = match engine {
            Engine::Rapier => EnginePhysics::Rapier(Box::new(self.rapier_physics()?)),
            #[cfg(feature = "mujoco")]
            Engine::Mujoco => EnginePhysics::Mujoco(self.mujoco_physics(super::MujocoSettings::default())?),
            #[cfg(not(feature = "mujoco"))]
            Engine::Mujoco => return Err(EnvError::EngineUnavailable { engine: engine.key(), feature: "mujoco" }),
        };
        self.init_with(physics)
    }
}
