//! The one on-disk framing of everything a run keeps: checkpoints, the learners'
//! states and the replay log's segments.
//!
//! A file is a header and a body:
//!
//! ```text
//! magic (8 bytes) | format version (u32, LE) | FNV-1a 64 of the body (u64, LE) | body
//! ```
//!
//! The body is one serde value encoded with [`postcard`]: compact, with `f32`
//! and `f64` stored bit for bit, so a restored run continues exactly. The
//! checksum turns a truncated or corrupted file into an error before any byte
//! of it is interpreted, and serde's cautious preallocation keeps a corrupted
//! length field from allocating more than the file holds.
//!
//! ```
//! use fmsr_core::persist::{decode, encode, FormatError};
//! let bytes = encode(b"EXAMPLE\0", 1, &vec![1.5f32, -0.25]).unwrap();
//! let back: Vec<f32> = decode(b"EXAMPLE\0", 1, &bytes).unwrap();
//! assert_eq!(back, [1.5, -0.25]);
//! assert!(matches!(decode::<Vec<f32>>(b"EXAMPLE\0", 2, &bytes), Err(FormatError::Version { found: 1, .. })));
//! ```

use std::io::Write;
use std::path::{Path, PathBuf};

use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::error::CoreError;

/// Bytes before the body: magic, version and checksum.
pub const HEADER_LEN: usize = 20;

/// Why bytes could not be written or read back.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FormatError {
    /// The file does not start with the expected magic number.
    #[error("not a {expected} file (bad magic)")]
    Magic {
        /// The kind of file expected, from its magic number.
        expected: String,
    },
    /// The file was written by a build with another format version.
    #[error("format version {found}, this build reads {expected}")]
    Version {
        /// The version this build reads.
        expected: u32,
        /// The version in the file.
        found: u32,
    },
    /// The body does not match its checksum.
    #[error("checksum mismatch (truncated or corrupted file)")]
    Checksum,
    /// The body does not decode as the expected value.
    #[error("undecodable body: {0}")]
    Body(String),
    /// The value could not be encoded.
    #[error("could not encode: {0}")]
    Encode(String),
}

/// FNV-1a, 64 bit: the checksum of every file a run writes.
///
/// ```
/// assert_eq!(fmsr_core::persist::fnv1a(b""), 0xcbf2_9ce4_8422_2325);
/// ```
#[must_use]
pub fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3))
}

/// Encodes `value` behind the header (`magic`, `version`, checksum).
///
/// # Errors
/// [`FormatError::Encode`] when serde refuses the value.
pub fn encode<T: Serialize + ?Sized>(magic: &[u8; 8], version: u32, value: &T) -> Result<Vec<u8>, FormatError> {
    let body = postcard::to_stdvec(value).map_err(|e| FormatError::Encode(e.to_string()))?;
    let mut out = Vec::with_capacity(body.len() + HEADER_LEN);
    out.extend_from_slice(magic);
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&fnv1a(&body).to_le_bytes());
    out.extend_from_slice(&body);
    Ok(out)
}

/// Decodes bytes written by [`encode`] with the same `magic` and `version`.
///
/// # Errors
/// The first check that fails: magic, version, checksum, then the body.
pub fn decode<T: DeserializeOwned>(magic: &[u8; 8], version: u32, bytes: &[u8]) -> Result<T, FormatError> {
    let (header, body) = bytes.split_at_checked(HEADER_LEN).ok_or_else(|| magic_error(magic))?;
    if &header[..8] != magic {
        return Err(magic_error(magic));
    }
    let word = |range: std::ops::Range<usize>| header[range].iter().rev().fold(0u64, |v, &b| (v << 8) | u64::from(b));
    let found = word(8..12) as u32;
    if found != version {
        return Err(FormatError::Version { expected: version, found });
    }
    if fnv1a(body) != word(12..20) {
        return Err(FormatError::Checksum);
    }
    postcard::from_bytes(body).map_err(|e| FormatError::Body(e.to_string()))
}

fn magic_error(magic: &[u8; 8]) -> FormatError {
    let name: String = magic.iter().take_while(|&&b| b != 0).map(|&b| char::from(b)).collect();
    FormatError::Magic { expected: name }
}

/// Writes `bytes` to `path` atomically: a temporary file in the same folder,
/// flushed to disk, then renamed over `path`. A crash leaves either the old or the
/// new file, never a torn one.
///
/// ```
/// let dir = tempfile::tempdir().unwrap();
/// let path = dir.path().join("run").join("eval.json");
/// fmsr_core::persist::write_atomic(&path, b"{}").unwrap();
/// assert_eq!(std::fs::read(&path).unwrap(), b"{}");
/// ```
///
/// # Errors
/// [`CoreError::Io`] naming `path`.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), CoreError> {
    let io = |source| CoreError::Io { path: path.to_path_buf(), source };
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(io)?;
    let file_name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp: PathBuf = dir.join(format!(".{file_name}.tmp{}", std::process::id()));
    let mut f = std::fs::File::create(&tmp).map_err(io)?;
    f.write_all(bytes).map_err(io)?;
    f.sync_all().map_err(io)?;
    drop(f);
    std::fs::rename(&tmp, path).map_err(io)?;
    if let Ok(d) = std::fs::File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    proptest! {
        // Guards the framing: any corruption of a valid file is a typed error.
        #[test]
        fn corrupted_bytes_are_errors(values in proptest::collection::vec(any::<f32>(), 1..64),
                                      flip in 0usize..1024, bit in 0u8..8, cut in 0usize..1024) {
            let good = encode(b"TESTFILE", 3, &values).unwrap();
            let back: Vec<f32> = decode(b"TESTFILE", 3, &good).unwrap();
            prop_assert_eq!(back.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                            values.iter().map(|v| v.to_bits()).collect::<Vec<_>>());
            let mut bad = good.clone();
            let i = flip % bad.len();
            bad[i] ^= 1 << bit;
            prop_assert!(decode::<Vec<f32>>(b"TESTFILE", 3, &bad).is_err());
            prop_assert!(decode::<Vec<f32>>(b"TESTFILE", 3, &good[..cut % good.len()]).is_err());
        }
    }
}
