//! One error type for every reader, writer and algorithm in this crate, so a caller (CLI, plugin)
//! can show a message naming the file, the field and what was expected.

use std::path::PathBuf;

pub type Result<T> = std::result::Result<T, Error>;

impl From<dentsim_atomic::Error> for Error {
    fn from(e: dentsim_atomic::Error) -> Self {
        Error::Io { path: e.path, source: e.source }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{path}: field {field}: {message}")]
    Field { path: PathBuf, field: String, message: String },
    #[error("{path}: truncated: {field} needs {expected} bytes, only {found} available")]
    Truncated { path: PathBuf, field: String, expected: u64, found: u64 },
    #[error("{path}: empty folder: no files to read")]
    EmptyFolder { path: PathBuf },
    #[error("{path}: no DICOM image found ({notes})")]
    NoImage { path: PathBuf, notes: String },
    #[error("{path}: non-image DICOM: no Pixel Data (7FE0,0010) / Rows / Columns")]
    NonImage { path: PathBuf },
    #[error("{folder}: mixed series: Series Instance UID {uid_a} ({file_a}) and {uid_b} ({file_b}); choose one with series_uid")]
    MixedSeries { folder: PathBuf, uid_a: String, file_a: PathBuf, uid_b: String, file_b: PathBuf },
    #[error("{folder}: missing slice between {file_a} (position {pos_a:.3} mm along the normal) and {file_b} ({pos_b:.3} mm): gap {gap:.3} mm, expected about {expected:.3} mm")]
    MissingSlice { folder: PathBuf, file_a: PathBuf, file_b: PathBuf, pos_a: f64, pos_b: f64, gap: f64, expected: f64 },
    #[error("{path}: unreadable slice ({reason}); the series has a gap where it belongs, between {file_a} and {file_b}")]
    BadSlice { path: PathBuf, reason: String, file_a: PathBuf, file_b: PathBuf },
    #[error("{path}: field {field}: inconsistent with the rest of the series: expected {expected}, found {found}")]
    Inconsistent { path: PathBuf, field: String, expected: String, found: String },
    #[error("{path}: 4-D image (dim = {dims:?}); only 3-D volumes are supported")]
    FourD { path: PathBuf, dims: Vec<i64> },
    #[error("{path}: NaN voxel value at index [{}, {}, {}]", index[0], index[1], index[2])]
    NaN { path: PathBuf, index: [usize; 3] },
    #[error("{path}: volume of {bytes} bytes as f32 exceeds the memory cap of {cap} bytes (ReadOptions::max_bytes)")]
    TooLarge { path: PathBuf, bytes: u64, cap: u64 },
    #[error("{path}: unknown format: expected a folder (DICOM series), .dcm, .nii, .nii.gz, .mha or .mhd")]
    UnknownFormat { path: PathBuf },
    #[error("{path}: DICOM: {message}")]
    Dicom { path: PathBuf, message: String },
    #[error("invalid argument {what}: {message}")]
    Invalid { what: String, message: String },
}

impl Error {
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io { path: path.into(), source }
    }
    pub(crate) fn field(path: impl Into<PathBuf>, field: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Field { path: path.into(), field: field.into(), message: message.into() }
    }
    pub(crate) fn invalid(what: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Invalid { what: what.into(), message: message.into() }
    }
}
