//! `fmsr render`: one episode of the fixed test set, played by a run's policy
//! and drawn frame by frame ([`fmsr_envs::shadow_hand::render`]), as an animated
//! GIF at the env step rate (0.04 s a frame), or as PNG frames.
//!
//! Each frame carries the step, the angle error to the goal and the number of
//! active touch sensors; the last one names the outcome (success, incomplete or
//! drop) as `fmsr eval` classifies it. The frames are drawn on the CPU from the
//! joint angles and poses the engine reports, so an episode simulated on rapier
//! or MuJoCo is shown through the same model on any machine.

use std::path::{Path, PathBuf};

use plotters::prelude::*;

use fmsr_core::metrics::{EpisodeOutcome, FailureType};
use fmsr_core::persist::write_atomic;
use fmsr_core::prelude::*;
use fmsr_envs::shadow_hand::render::{Camera, HandScene, HandView, Image};
use fmsr_envs::shadow_hand::{HandPhysics, ShadowHand, fetch_hand_assets};

use crate::artefacts::{RenderTarget, RunDir, Source, classify};
use crate::experiment::{Engine, ExperimentConfig, ExperimentError};

/// Frames are drawn this many times larger, then averaged down (anti-aliasing).
const SUPERSAMPLE: usize = 2;
/// How long the last frame stays up in a GIF (1/100 s), so the outcome can be read.
const FINAL_HOLD_CS: u16 = 150;

/// One test episode as played: what each step showed, and how it ended.
#[derive(Debug, Clone, PartialEq)]
pub struct EpisodeFilm {
    /// The run's configuration label, e.g. `Dense+FMSR+IS`.
    pub method: String,
    /// The engine it was simulated on.
    pub engine: Engine,
    /// Index in the fixed test set.
    pub episode: usize,
    /// The episode's seed.
    pub seed: u64,
    /// The scene after every step.
    pub views: Vec<HandView>,
    /// The angle to the goal after every step (rad).
    pub angle_errors: Vec<f32>,
    /// The test success threshold (rad).
    pub threshold: f32,
    /// Simulated time of one step (s).
    pub step_seconds: f64,
    /// How the episode ended.
    pub outcome: EpisodeOutcome,
}

impl EpisodeFilm {
    /// The outcome in words: `success`, `incomplete` or `drop`.
    #[must_use]
    pub fn outcome_label(&self) -> &'static str {
        match self.outcome {
            EpisodeOutcome::Success => "success",
            EpisodeOutcome::Failure(FailureType::Incomplete) => "incomplete",
            EpisodeOutcome::Failure(FailureType::Drop) => "drop",
        }
    }
}

/// Plays test episode `episode` of `config.eval` with the policy of the run in
/// `dir` (its last checkpoint) on `env`, an environment of `engine`.
///
/// # Errors
/// [`ExperimentError::Cli`] when `episode` is not in the test set; errors of
/// the checkpoint, the environment or the policy.
pub fn record_episode<P: HandPhysics + Send>(
    config: &ExperimentConfig,
    env: ShadowHand<P>,
    engine: Engine,
    dir: &RunDir,
    episode: usize,
) -> Result<EpisodeFilm, ExperimentError> {
    record_source_episode(config, env, engine, &Source::Run(dir.clone()), episode)
}

/// As [`record_episode`] with the policy of `source`: a run's last checkpoint
/// or a policy file (`config` is `source`'s).
///
/// # Errors
/// As [`record_episode`].
pub fn record_source_episode<P: HandPhysics + Send>(
    config: &ExperimentConfig,
    env: ShadowHand<P>,
    engine: Engine,
    source: &Source,
    episode: usize,
) -> Result<EpisodeFilm, ExperimentError> {
    let seeds = config.eval.seeds();
    let seed = *seeds.get(episode).ok_or_else(|| ExperimentError::Cli {
        arg: "--episode",
        reason: format!("episode {episode} is not in the test set of {} episodes (0..{})", seeds.len(), seeds.len()),
    })?;
    let mut trainer = config.build_trainer(vec![env])?;
    source.load_into(&mut trainer)?;
    let (mut views, mut angle_errors) = (Vec::new(), Vec::new());
    let played = trainer.rollout_with(seed, ActMode::Evaluate, &mut |env, _| {
        views.push(env.view());
        angle_errors.push(env.angle_error());
    })?;
    let last = angle_errors.last().copied().unwrap_or(f32::INFINITY);
    let outcome = classify(last, config.eval.threshold, played.infos.iter().any(|i| i.dropped));
    Ok(EpisodeFilm {
        method: config.label(),
        engine,
        episode,
        seed,
        views,
        angle_errors,
        threshold: config.eval.threshold,
        step_seconds: crate::experiment::MODEL_TIMESTEP * config.env.substeps as f64,
        outcome,
    })
}

/// Draws every step of `film` from `camera`, with the overlay.
///
/// # Errors
/// [`ExperimentError::Env`] when a view does not fit the scene.
pub fn draw_film(scene: &HandScene, film: &EpisodeFilm, camera: &Camera) -> Result<Vec<Image>, ExperimentError> {
    let big = Camera { width: camera.width * SUPERSAMPLE, height: camera.height * SUPERSAMPLE, ..*camera };
    let steps = film.views.len();
    film.views
        .iter()
        .enumerate()
        .map(|(t, view)| {
            let mut image = scene.render(view, &big)?.downsample(SUPERSAMPLE);
            let touch = view.touch_active.iter().filter(|&&a| a).count();
            let lines = [
                format!("step {}/{steps}   angle error {:.2} rad   touch {touch}/92", t + 1, film.angle_errors[t]),
                format!("{} | {} | test episode {}", film.method, film.engine.key(), film.episode),
            ];
            let verdict = (t + 1 == steps).then(|| film.outcome_label());
            overlay(&mut image, &lines, verdict)?;
            Ok(image)
        })
        .collect()
}

/// Writes the step lines at the top and bottom and, on the last frame, the verdict.
fn overlay(image: &mut Image, lines: &[String; 2], verdict: Option<&str>) -> Result<(), ExperimentError> {
    crate::font::register_font();
    let (w, h) = (image.width as u32, image.height as u32);
    let err = |e: DrawingAreaErrorKind<_>| ExperimentError::Render { what: "overlay".into(), reason: e.to_string() };
    let root = BitMapBackend::with_buffer(&mut image.rgb, (w, h)).into_drawing_area();
    let size = (h / 20).max(10);
    let font = ("sans-serif", size).into_font().color(&BLACK);
    root.draw(&Rectangle::new([(0, 0), (w as i32, (size + 6) as i32)], WHITE.mix(0.7).filled())).map_err(err)?;
    root.draw(&Text::new(lines[0].clone(), (4, 3), font.clone())).map_err(err)?;
    root.draw(&Text::new(lines[1].clone(), (4, (h - size - 4) as i32), font)).map_err(err)?;
    if let Some(v) = verdict {
        let color = if v == "success" { RGBColor(20, 120, 20) } else { RGBColor(180, 20, 20) };
        let big = ("sans-serif", 2 * size).into_font().color(&color);
        root.draw(&Text::new(v.to_uppercase(), (4, (2 * size + 10) as i32), big)).map_err(err)?;
    }
    root.present().map_err(err)
}

/// The first, middle and last frames side by side.
#[must_use]
pub fn frame_strip(frames: &[Image]) -> Image {
    let picks: Vec<&Image> = match frames.len() {
        0 => Vec::new(),
        n => [0, n / 2, n - 1].iter().map(|&i| &frames[i]).collect(),
    };
    Image::hstack(&picks, [255, 255, 255])
}

/// `image` as PNG bytes.
///
/// # Errors
/// [`ExperimentError::Render`] if the encoder fails.
pub fn png_bytes(image: &Image) -> Result<Vec<u8>, ExperimentError> {
    let mut bytes = Vec::new();
    let mut encoder = png::Encoder::new(&mut bytes, image.width as u32, image.height as u32);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let err = |e: png::EncodingError| ExperimentError::Render { what: "png".into(), reason: e.to_string() };
    let mut writer = encoder.write_header().map_err(err)?;
    writer.write_image_data(&image.rgb).map_err(err)?;
    writer.finish().map_err(err)?;
    Ok(bytes)
}

/// `frames` as an endlessly looping GIF, `delay_cs` hundredths of a second per
/// frame, the last one held longer.
///
/// # Errors
/// [`ExperimentError::Render`] for frames larger than a GIF allows or an encoder failure.
pub fn gif_bytes(frames: &[Image], delay_cs: u16) -> Result<Vec<u8>, ExperimentError> {
    let Some(first) = frames.first() else { return Ok(Vec::new()) };
    let too_big = || ExperimentError::Render { what: "gif".into(), reason: "frames over 65535 pixels".into() };
    let (w, h) =
        (u16::try_from(first.width).map_err(|_| too_big())?, u16::try_from(first.height).map_err(|_| too_big())?);
    let err = |e: gif::EncodingError| ExperimentError::Render { what: "gif".into(), reason: e.to_string() };
    let mut bytes = Vec::new();
    {
        let mut encoder = gif::Encoder::new(&mut bytes, w, h, &[]).map_err(err)?;
        encoder.set_repeat(gif::Repeat::Infinite).map_err(err)?;
        for (i, image) in frames.iter().enumerate() {
            let mut frame = gif::Frame::from_rgb_speed(w, h, &image.rgb, 10);
            frame.delay = if i + 1 == frames.len() { FINAL_HOLD_CS } else { delay_cs };
            encoder.write_frame(&frame).map_err(err)?;
        }
    }
    Ok(bytes)
}

/// Draws `film` and writes it to `target`; returns the files written.
///
/// # Errors
/// Errors of drawing, encoding or writing.
pub fn write_film(
    scene: &HandScene,
    film: &EpisodeFilm,
    camera: &Camera,
    target: &RenderTarget,
) -> Result<Vec<PathBuf>, ExperimentError> {
    let frames = draw_film(scene, film, camera)?;
    let write = |path: &Path, bytes: &[u8]| -> Result<PathBuf, ExperimentError> {
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent).map_err(|source| ExperimentError::Io { path: parent.into(), source })?;
        }
        write_atomic(path, bytes)?;
        Ok(path.to_path_buf())
    };
    match target {
        RenderTarget::Gif(path) => {
            let delay = (100.0 * film.step_seconds).round().clamp(1.0, 6000.0) as u16;
            let mut files = vec![write(path, &gif_bytes(&frames, delay)?)?];
            if let Some(strip) = target.strip_path() {
                files.push(write(&strip, &png_bytes(&frame_strip(&frames))?)?);
            }
            Ok(files)
        }
        RenderTarget::Frames(dir) => frames
            .iter()
            .enumerate()
            .map(|(i, f)| write(&dir.join(format!("frame-{i:03}.png")), &png_bytes(f)?))
            .collect(),
    }
}

/// Loads the drawable scene of the run's object from the model cache.
///
/// # Errors
/// Errors of fetching or reading the model.
pub fn load_scene(config: &ExperimentConfig) -> Result<HandScene, ExperimentError> {
    let assets = fetch_hand_assets(config.env_config().assets_dir.as_deref())?;
    Ok(HandScene::load(&assets, config.env.object)?)
}
