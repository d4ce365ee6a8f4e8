use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("{}: {message}", path.display())]
    File { path: PathBuf, message: String },
    /// A bad value in a tool path; `at` says where in `source_name`: `row 2 column y` (data rows
    /// count from 1, the header is row 0), `header`, `point 3 array Orientation`.
    #[error("{source_name} {at}: {message}")]
    Path { source_name: String, at: String, message: String },
    #[error("device profile {source_name}: {message}")]
    Profile { source_name: String, message: String },
    #[error("{what}: {message}")]
    Invalid { what: String, message: String },
}

impl Error {
    pub(crate) fn path(source_name: &str, at: impl Into<String>, message: String) -> Self {
        Error::Path { source_name: source_name.into(), at: at.into(), message }
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
