use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Vdb(#[from] dentsim_vdb::Error),
    /// A device or tool path error (it names the file, row and column).
    #[error(transparent)]
    Device(#[from] dentsim_devices::Error),
    #[error("{}: {message}", path.display())]
    File { path: PathBuf, message: String },
    #[error("tissue table {source_name}: {message}")]
    TissueTable { source_name: String, message: String },
    #[error("{what}: {message}")]
    Invalid { what: String, message: String },
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

impl From<dentsim_atomic::Error> for Error {
    fn from(e: dentsim_atomic::Error) -> Self {
        Error::File { path: e.path, message: e.source.to_string() }
    }
}

/// What a run stopped by its caller (a GUI's abort) says.
pub const STOPPED: &str = "stopped on request";

/// The error of a run its caller stopped part-way; `what` names the run.
pub fn stopped(what: impl Into<String>) -> Error {
    invalid(what, STOPPED)
}

/// An [`Error::Invalid`]: `what` names the input or field, `message` what was wrong with it.
pub fn invalid(what: impl Into<String>, message: impl Into<String>) -> Error {
    Error::Invalid { what: what.into(), message: message.into() }
}
