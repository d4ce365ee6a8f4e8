use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("{}: {message}", path.display())]
    File { path: PathBuf, message: String },
    /// A bad value in a tool path: `row` counts data rows from 1 (the header is row 0).
    #[error("{source_name}: row {row}, column '{column}': {message}")]
    Path { source_name: String, row: usize, column: String, message: String },
    #[error("device profile {source_name}: {message}")]
    Profile { source_name: String, message: String },
    #[error("{what}: {message}")]
    Invalid { what: String, message: String },
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
