//! Fetching the Shadow Hand model (MJCF files and meshes) from the PyPI wheel of
//! `gymnasium-robotics` 1.4.2 into a local cache. The model is never committed.
//!
//! [`fetch_hand_assets`] runs `python3 -m pip download --no-deps gymnasium-robotics==1.4.2`
//! into the cache directory, checks the wheel's sha256 against [`WHEEL_SHA256`],
//! extracts `gymnasium_robotics/envs/assets/{hand,stls/hand,textures}/*` and the
//! licence, and reuses the extracted files afterwards.
//!
//! **This downloads from PyPI on first use** (building a Shadow Hand env calls
//! it). The explicit step is `fmsr assets fetch`; `fmsr assets path` prints the
//! cache directory. Offline and without a cached model, the error names the
//! command to run.
//!
//! The cache directory is, in order: the argument, `$FMSR_ASSETS_DIR`,
//! `$XDG_CACHE_HOME/fmsr`, `$HOME/.cache/fmsr` — never a crate's source
//! folder or cargo's directories, so it works the same for a registry or git
//! dependency ([`default_assets_dir`]).

use std::fs;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Mutex;

use sha2::{Digest, Sha256};

use crate::error::EnvError;

/// The PyPI package that publishes the model.
pub const PACKAGE: &str = "gymnasium-robotics==1.4.2";
/// File name of the wheel pip downloads.
pub const WHEEL_NAME: &str = "gymnasium_robotics-1.4.2-py3-none-any.whl";
/// sha256 of [`WHEEL_NAME`], pinned from the file pip downloaded from PyPI
/// (observed, not published by us).
pub const WHEEL_SHA256: &str = "a1743530431cb377e6b3b956d284bc96436fc68bac1648ef205054c178e7dc4b";
/// Environment variable that overrides the default cache directory.
pub const ASSETS_DIR_ENV: &str = "FMSR_ASSETS_DIR";

const EXTRACT_DIR: &str = "gymnasium_robotics-1.4.2";
const COMPLETE_MARK: &str = ".complete";
const PREFIX: &str = "gymnasium_robotics/envs/assets/";
const WANTED: [&str; 4] = ["hand/", "stls/hand/", "textures/", "LICENSE.md"];

/// The extracted model files.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct HandAssets {
    /// The `assets` folder: holds `hand/`, `stls/hand/` and `textures/`.
    pub root: PathBuf,
}

impl HandAssets {
    /// The folder of the hand MJCF files.
    #[must_use]
    pub fn hand_dir(&self) -> PathBuf {
        self.root.join("hand")
    }

    /// The scene file of the block (or egg) task with 92 touch sensors.
    #[must_use]
    pub fn scene(&self, object: &str) -> PathBuf {
        self.hand_dir().join(format!("manipulate_{object}_touch_sensors.xml"))
    }
}

/// The default cache directory: `$FMSR_ASSETS_DIR`, else the platform cache
/// directory `$XDG_CACHE_HOME/fmsr` or `$HOME/.cache/fmsr` (relative or empty
/// values are ignored, as the XDG specification says).
///
/// # Errors
/// [`EnvError::AssetFetch`] when none of the variables gives an absolute path.
pub fn default_assets_dir() -> Result<PathBuf, EnvError> {
    let var = |name: &str| std::env::var_os(name).map(PathBuf::from).filter(|p| p.is_absolute());
    if let Some(dir) = var(ASSETS_DIR_ENV) {
        return Ok(dir);
    }
    if let Some(cache) = var("XDG_CACHE_HOME") {
        return Ok(cache.join("fmsr"));
    }
    var("HOME").map(|home| home.join(".cache").join("fmsr")).ok_or_else(|| EnvError::AssetFetch {
        reason: "no cache directory: none of FMSR_ASSETS_DIR, XDG_CACHE_HOME, HOME is an absolute path".into(),
        hint: format!("set {ASSETS_DIR_ENV} to a folder for the model, then run: fmsr assets fetch"),
    })
}

/// The commands that fetch the model into `dir` by hand.
#[must_use]
pub fn fetch_hint(dir: &Path) -> String {
    format!("fmsr assets fetch (or: python3 -m pip download --no-deps {PACKAGE} -d {}, then run again)", dir.display())
}

static FETCH_LOCK: Mutex<()> = Mutex::new(());

/// Makes sure the model is in the cache `dir` (or [`default_assets_dir`]) and
/// returns where it is. Downloads with pip only when neither the extracted files
/// nor the wheel are there. Safe to call from several threads and processes.
pub fn fetch_hand_assets(dir: Option<&Path>) -> Result<HandAssets, EnvError> {
    let dir = match dir {
        Some(d) => d.to_path_buf(),
        None => default_assets_dir()?,
    };
    let assets = HandAssets { root: dir.join(EXTRACT_DIR).join("assets") };
    if dir.join(EXTRACT_DIR).join(COMPLETE_MARK).exists() {
        return Ok(assets);
    }
    let _guard = FETCH_LOCK.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    if dir.join(EXTRACT_DIR).join(COMPLETE_MARK).exists() {
        return Ok(assets);
    }
    fs::create_dir_all(&dir).map_err(|source| EnvError::Io { what: "creating", path: dir.clone(), source })?;
    let wheel = dir.join(WHEEL_NAME);
    if !wheel.exists() {
        download_wheel(&dir)?;
    }
    check_hash(&wheel)?;
    extract(&wheel, &dir)?;
    Ok(assets)
}

fn unique_tmp(dir: &Path, what: &str) -> PathBuf {
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.subsec_nanos());
    dir.join(format!(".tmp-{what}-{}-{nanos}", std::process::id()))
}

fn download_wheel(dir: &Path) -> Result<(), EnvError> {
    let tmp = unique_tmp(dir, "pip");
    let out = Command::new("python3")
        .args(["-m", "pip", "download", "--no-deps", "--disable-pip-version-check", PACKAGE, "-d"])
        .arg(&tmp)
        .output();
    let hint = fetch_hint(dir);
    let out =
        out.map_err(|e| EnvError::AssetFetch { reason: format!("cannot run python3 ({e})"), hint: hint.clone() })?;
    let downloaded = tmp.join(WHEEL_NAME);
    if !out.status.success() || !downloaded.exists() {
        let _ = fs::remove_dir_all(&tmp);
        let stderr = String::from_utf8_lossy(&out.stderr);
        let last = stderr.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("no output");
        return Err(EnvError::AssetFetch {
            reason: format!("pip download failed (offline with no cached model?): {last}"),
            hint,
        });
    }
    let target = dir.join(WHEEL_NAME);
    // Another process may have won the race; either file is the same wheel.
    if fs::rename(&downloaded, &target).is_err() && !target.exists() {
        return Err(EnvError::AssetFetch { reason: format!("cannot move the wheel to {}", target.display()), hint });
    }
    let _ = fs::remove_dir_all(&tmp);
    Ok(())
}

fn check_hash(wheel: &Path) -> Result<(), EnvError> {
    let bytes =
        fs::read(wheel).map_err(|source| EnvError::Io { what: "reading", path: wheel.to_path_buf(), source })?;
    let found = Sha256::digest(&bytes).iter().map(|b| format!("{b:02x}")).collect::<String>();
    if found != WHEEL_SHA256 {
        return Err(EnvError::AssetHash { path: wheel.to_path_buf(), expected: WHEEL_SHA256.into(), found });
    }
    Ok(())
}

fn extract(wheel: &Path, dir: &Path) -> Result<(), EnvError> {
    let io = |what: &'static str, path: &Path| {
        let path = path.to_path_buf();
        move |source| EnvError::Io { what, path, source }
    };
    let file = fs::File::open(wheel).map_err(io("opening", wheel))?;
    let bad_zip = |e: zip::result::ZipError| EnvError::AssetFetch {
        reason: format!("cannot read {}: {e}; delete it and retry", wheel.display()),
        hint: fetch_hint(dir),
    };
    let mut archive = zip::ZipArchive::new(file).map_err(bad_zip)?;
    let tmp = unique_tmp(dir, "extract");
    for i in 0..archive.len() {
        let mut entry = archive.by_index(i).map_err(bad_zip)?;
        let name = entry.name().to_owned();
        let Some(rel) = name.strip_prefix(PREFIX) else { continue };
        if entry.is_dir() || !WANTED.iter().any(|w| rel.starts_with(w)) || rel.contains("..") {
            continue;
        }
        let out = tmp.join("assets").join(rel);
        if let Some(parent) = out.parent() {
            fs::create_dir_all(parent).map_err(io("creating", parent))?;
        }
        let mut data = Vec::with_capacity(usize::try_from(entry.size()).unwrap_or(0));
        entry.read_to_end(&mut data).map_err(io("extracting", &out))?;
        fs::write(&out, data).map_err(io("writing", &out))?;
    }
    fs::write(tmp.join(COMPLETE_MARK), WHEEL_SHA256).map_err(io("writing", &tmp))?;
    let target = dir.join(EXTRACT_DIR);
    if fs::rename(&tmp, &target).is_err() {
        // Lost a race with another process (or a stale, incomplete folder).
        let _ = fs::remove_dir_all(&tmp);
        if !target.join(COMPLETE_MARK).exists() {
            return Err(EnvError::AssetFetch {
                reason: format!("{} exists but is incomplete; delete it and retry", target.display()),
                hint: fetch_hint(dir),
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offline_without_cache_says_what_to_run() {
        let hint = fetch_hint(Path::new("/some/cache"));
        assert!(hint.contains("pip download --no-deps gymnasium-robotics==1.4.2 -d /some/cache"));
        let err = EnvError::AssetFetch { reason: "pip download failed".into(), hint };
        assert!(err.to_string().contains("To fetch it, run: fmsr assets fetch"), "{err}");
    }
}
