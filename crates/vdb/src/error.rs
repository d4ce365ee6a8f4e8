use std::path::PathBuf;

/// Errors from the OpenVDB layer; each names the operation or file that failed.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("OpenVDB {op}: {message}")]
    OpenVdb { op: &'static str, message: String },
    #[error("{}: {message}", path.display())]
    File { path: PathBuf, message: String },
    #[error("{op}: {message}")]
    Invalid { op: &'static str, message: String },
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

impl From<dentsim_atomic::Error> for Error {
    fn from(e: dentsim_atomic::Error) -> Self {
        Error::File { path: e.path, message: e.source.to_string() }
    }
}

pub(crate) fn openvdb(op: &'static str) -> impl FnOnce(cxx::Exception) -> Error {
    move |e| Error::OpenVdb { op, message: e.what().to_owned() }
}
