use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Vdb(#[from] dentsim_vdb::Error),
    #[error("{}: {message}", path.display())]
    File { path: PathBuf, message: String },
    #[error("tissue table {source_name}: {message}")]
    TissueTable { source_name: String, message: String },
    #[error("{what}: {message}")]
    Invalid { what: String, message: String },
}

pub type Result<T, E = Error> = std::result::Result<T, E>;

pub(crate) fn invalid(what: impl Into<String>, message: impl Into<String>) -> Error {
    Error::Invalid { what: what.into(), message: message.into() }
}
