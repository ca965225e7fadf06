//! What a run leaves on disk and where: the run directory ([`RunDir`]), the
//! policy file ([`PolicyFile`]) and either as a [`Source`] of a policy, the
//! evaluation file ([`EvalReport`]) and where renderings go
//! ([`RenderTarget`]).
//!
//! This is the bottom of the crate's artefact code: evaluation
//! ([`crate::evaluate`]), rendering ([`crate::render`]) and reports
//! ([`crate::report`]) read and write through it and never import each other.

mod eval_file;
mod policy_file;
mod render_target;
mod run_dir;

#[cfg(feature = "report")]
pub(crate) use self::eval_file::read_json;
pub use self::eval_file::{
    EpisodeRecord, EpisodeTrace, EvalReport, FinalOrientation, StillBaseline, SuccessRule, read_eval, write_eval,
};
pub use self::policy_file::{POLICY_FILE_NAME, POLICY_FILE_VERSION, PolicyFile, Source, matching_policies};
pub use self::render_target::RenderTarget;
pub use self::run_dir::{RunDir, RunLock};
pub use fmsr_core::metrics::classify;
