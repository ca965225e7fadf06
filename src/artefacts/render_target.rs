//! Where renderings of a run's episodes go (`fmsr render`, reports).

use std::path::{Path, PathBuf};

use super::run_dir::RunDir;
use crate::error::ExperimentError;
use crate::experiment::Engine;

/// Where `fmsr render` writes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum RenderTarget {
    /// An animated GIF (and its frame strip beside it, `<stem>-strip.png`).
    Gif(PathBuf),
    /// A directory of `frame-000.png`, ...
    Frames(PathBuf),
}

impl RenderTarget {
    /// A `.gif` path is a GIF, a path without extension a directory of PNG frames.
    ///
    /// # Errors
    /// [`ExperimentError::Render`] for other extensions (`.mp4` is not written:
    /// no well-kept pure-Rust encoder; make one from the PNG frames with ffmpeg).
    pub fn from_path(path: &Path) -> Result<Self, ExperimentError> {
        match path.extension().and_then(|e| e.to_str()) {
            Some("gif") => Ok(Self::Gif(path.to_path_buf())),
            None => Ok(Self::Frames(path.to_path_buf())),
            Some(other) => Err(ExperimentError::Render {
                what: path.display().to_string(),
                reason: format!("`.{other}` is not an output format: give a `.gif` file or a directory for PNG frames"),
            }),
        }
    }

    /// The default target of a run: `RUN/render/episode-<K>-<engine>.gif`.
    #[must_use]
    pub fn default_for(dir: &RunDir, episode: usize, engine: Engine) -> Self {
        Self::Gif(dir.root().join("render").join(format!("episode-{episode}-{}.gif", engine.key())))
    }

    /// The frame strip written beside a GIF.
    #[must_use]
    pub fn strip_path(&self) -> Option<PathBuf> {
        match self {
            Self::Gif(p) => Some(
                p.with_file_name(format!("{}-strip.png", p.file_stem().and_then(|s| s.to_str()).unwrap_or("episode"))),
            ),
            Self::Frames(_) => None,
        }
    }
}
