//! The one on-disk framing of everything a run keeps: checkpoints, the learners'
//! states, the replay log's segments and policy files.
//!
//! A file is a header and a body:
//!
//! ```text
//! magic (8 bytes) | format version (u32, LE) | checksum of the body (u64, LE) | body
//! ```
//!
//! The body is one serde value encoded with [`postcard`]: compact, with `f32`
//! and `f64` stored bit for bit, so a restored run continues exactly. The
//! checksum turns a truncated or corrupted file into an error before any byte
//! of it is interpreted, and serde's cautious preallocation keeps a corrupted
//! length field from allocating more than the file holds.
//!
//! The checksum is CRC-32C ([`crc32c`], zero-extended to 64 bits), the one the
//! TensorBoard writer uses too.
//!
//! ```
//! use fmsr_core::persist::{decode, encode, Format, FormatError};
//! const EXAMPLE: Format = Format::new(b"EXAMPLE\0", 2).reads_from(1);
//! let bytes = encode(&EXAMPLE, &vec![1.5f32, -0.25]).unwrap();
//! let back: Vec<f32> = decode(&EXAMPLE, &bytes).unwrap();
//! assert_eq!(back, [1.5, -0.25]);
//! let newer = Format::new(b"EXAMPLE\0", 3).reads_from(3);
//! assert!(matches!(decode::<Vec<f32>>(&newer, &bytes), Err(FormatError::Version { found: 2, .. })));
//! ```

use std::io::Write;
use std::path::{Path, PathBuf};

use serde::Serialize;
use serde::de::DeserializeOwned;

use crate::error::CoreError;

/// Bytes before the body: magic, version and checksum.
pub const HEADER_LEN: usize = 20;

/// One kind of file: its magic number, the version this build writes, and
/// the oldest version it still reads (with the same body).
///
/// ```
/// use fmsr_core::persist::Format;
/// // Version 5 written, 4 still read.
/// const CHECKPOINT: Format = Format::new(b"FMSRCKPT", 5).reads_from(4);
/// assert!(CHECKPOINT.reads(4) && !CHECKPOINT.reads(3) && !CHECKPOINT.reads(6));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Format {
    /// The first 8 bytes of every file of this kind.
    pub magic: &'static [u8; 8],
    /// The version this build writes.
    pub version: u32,
    /// The oldest version this build reads; defaults to `version`.
    pub oldest: u32,
}

impl Format {
    /// A kind of file of which this build reads and writes only `version`.
    ///
    /// ```
    /// let f = fmsr_core::persist::Format::new(b"EXAMPLE\0", 2);
    /// assert_eq!(f.oldest, 2);
    /// ```
    #[must_use]
    pub const fn new(magic: &'static [u8; 8], version: u32) -> Self {
        Self { magic, version, oldest: version }
    }

    /// Also reads the versions from `oldest` on, whose body is the same.
    ///
    /// ```
    /// let f = fmsr_core::persist::Format::new(b"EXAMPLE\0", 2).reads_from(1);
    /// assert!(f.reads(1) && f.reads(2));
    /// ```
    #[must_use]
    pub const fn reads_from(self, oldest: u32) -> Self {
        Self { oldest, ..self }
    }

    /// Whether this build reads files of `version`.
    ///
    /// ```
    /// assert!(!fmsr_core::persist::Format::new(b"EXAMPLE\0", 2).reads(1));
    /// ```
    #[must_use]
    pub const fn reads(&self, version: u32) -> bool {
        self.oldest <= version && version <= self.version
    }

    /// The magic number as text, for errors.
    fn name(&self) -> String {
        self.magic.iter().take_while(|&&b| b != 0).map(|&b| char::from(b)).collect()
    }
}

/// The checksum of a body as a header stores it: CRC-32C (Castagnoli),
/// zero-extended to 64 bits.
///
/// ```
/// // The CRC-32C check value.
/// assert_eq!(fmsr_core::persist::checksum(b"123456789"), 0xE306_9283);
/// ```
#[must_use]
pub fn checksum(bytes: &[u8]) -> u64 {
    u64::from(crc32c::crc32c(bytes))
}

/// Why bytes could not be written or read back.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FormatError {
    /// The file does not start with the expected magic number.
    #[error("not a {expected} file (bad magic)")]
    Magic {
        /// The kind of file expected, from its magic number.
        expected: String,
    },
    /// The file was written by a build with a format version this one does not read.
    #[error("{}", version_message(*.found, *.oldest, *.newest))]
    Version {
        /// The version in the file.
        found: u32,
        /// The oldest version this build reads.
        oldest: u32,
        /// The version this build writes.
        newest: u32,
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

/// What a version error says, with what to do about it.
fn version_message(found: u32, oldest: u32, newest: u32) -> String {
    let reads = if oldest == newest { format!("version {newest}") } else { format!("versions {oldest} to {newest}") };
    if found > newest {
        format!("format version {found}, this build reads {reads}: the file was written by a newer fmsr; update fmsr")
    } else {
        format!(
            "format version {found}, this build reads {reads}: read it with the fmsr that wrote it (a run's \
             provenance.json names its commit), or train or export it again with this one"
        )
    }
}

/// Encodes `value` behind the header of `format`'s current version.
///
/// # Errors
/// [`FormatError::Encode`] when serde refuses the value.
pub fn encode<T: Serialize + ?Sized>(format: &Format, value: &T) -> Result<Vec<u8>, FormatError> {
    let body = postcard::to_stdvec(value).map_err(|e| FormatError::Encode(e.to_string()))?;
    let mut out = Vec::with_capacity(body.len() + HEADER_LEN);
    out.extend_from_slice(format.magic);
    out.extend_from_slice(&format.version.to_le_bytes());
    out.extend_from_slice(&checksum(&body).to_le_bytes());
    out.extend_from_slice(&body);
    Ok(out)
}

/// The version in a file's header, once its magic is `format`'s.
///
/// ```
/// use fmsr_core::persist::{encode, version, Format};
/// const F: Format = Format::new(b"EXAMPLE\0", 7);
/// assert_eq!(version(&F, &encode(&F, &1u8).unwrap()), Ok(7));
/// ```
///
/// # Errors
/// [`FormatError::Magic`] for a file of another kind or shorter than a header.
pub fn version(format: &Format, bytes: &[u8]) -> Result<u32, FormatError> {
    let header = bytes.get(..HEADER_LEN).filter(|h| &h[..8] == format.magic);
    let header = header.ok_or_else(|| FormatError::Magic { expected: format.name() })?;
    Ok(u32::from_le_bytes([header[8], header[9], header[10], header[11]]))
}

/// Decodes bytes of any version `format` reads, written by [`encode`].
///
/// # Errors
/// The first check that fails: magic, version, checksum, then the body.
pub fn decode<T: DeserializeOwned>(format: &Format, bytes: &[u8]) -> Result<T, FormatError> {
    let found = version(format, bytes)?;
    if !format.reads(found) {
        return Err(FormatError::Version { found, oldest: format.oldest, newest: format.version });
    }
    let (header, body) = bytes.split_at(HEADER_LEN);
    let stored = u64::from_le_bytes(header[12..20].try_into().expect("a header holds 8 checksum bytes"));
    if checksum(body) != stored {
        return Err(FormatError::Checksum);
    }
    postcard::from_bytes(body).map_err(|e| FormatError::Body(e.to_string()))
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

    const TEST: Format = Format::new(b"TESTFILE", 3).reads_from(2);

    /// A file of `version` framed by hand.
    fn framed(version: u32, body: &[u8]) -> Vec<u8> {
        let mut out = TEST.magic.to_vec();
        out.extend_from_slice(&version.to_le_bytes());
        out.extend_from_slice(&checksum(body).to_le_bytes());
        out.extend_from_slice(body);
        out
    }

    proptest! {
        // Guards the framing: any corruption of a valid file is a typed error,
        // but for a version field turned into another version the format
        // reads, whose body is by definition the same: that reads back the
        // same values.
        #[test]
        fn corrupted_bytes_are_errors(values in proptest::collection::vec(any::<f32>(), 1..64),
                                      flip in 0usize..1024, bit in 0u8..8, cut in 0usize..1024) {
            let bits = |v: &[f32]| v.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            let good = encode(&TEST, &values).unwrap();
            let back: Vec<f32> = decode(&TEST, &good).unwrap();
            prop_assert_eq!(bits(&back), bits(&values));
            let mut bad = good.clone();
            let i = flip % bad.len();
            bad[i] ^= 1 << bit;
            let version = u32::from_le_bytes(bad[8..12].try_into().unwrap());
            match decode::<Vec<f32>>(&TEST, &bad) {
                Ok(back) if (8..12).contains(&i) && TEST.reads(version) => {
                    prop_assert_eq!(bits(&back), bits(&values));
                }
                other => prop_assert!(other.is_err(), "byte {} bit {} read as {:?}", i, bit, other),
            }
            prop_assert!(decode::<Vec<f32>>(&TEST, &good[..cut % good.len()]).is_err());
        }

        // Guards the versions a format reads: an older one it names reads
        // back as the current one does.
        #[test]
        fn older_versions_read_back(values in proptest::collection::vec(any::<f32>(), 0..64)) {
            let body = postcard::to_stdvec(&values).unwrap();
            let back: Vec<f32> = decode(&TEST, &framed(2, &body)).unwrap();
            prop_assert_eq!(back.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                            values.iter().map(|v| v.to_bits()).collect::<Vec<_>>());
            prop_assert_eq!(encode(&TEST, &values).unwrap(), framed(3, &body));
        }
    }

    #[test]
    fn versions_outside_the_range_say_what_to_do() {
        let body = postcard::to_stdvec(&1u8).unwrap();
        let old = decode::<u8>(&TEST, &framed(1, &body)).unwrap_err();
        assert_eq!(old, FormatError::Version { found: 1, oldest: 2, newest: 3 });
        assert!(old.to_string().contains("read it with the fmsr that wrote it"), "{old}");
        let new = decode::<u8>(&TEST, &framed(4, &body)).unwrap_err();
        assert!(new.to_string().contains("update fmsr"), "{new}");
        assert!(matches!(decode::<u8>(&TEST, b"TESTFILE"), Err(FormatError::Magic { .. })));
    }
}
