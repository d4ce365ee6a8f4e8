//! Files written whole or not at all, for every dentsim crate (vdb, cbct, sim): the content is
//! staged under a temporary name in the target's folder (so the rename cannot cross file
//! systems), fsynced, then renamed over the target. On any error, or a panic, the temporary is
//! removed and the target is untouched; the error names the target.
//!
//! Its own crate because no existing one fits: `vdb` is the C++ crate `cbct` must not depend
//! on, and `cbct` (scans) is no dependency for `vdb`.
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// A failed atomic write; `path` is the target (never the temporary).
#[derive(Debug, thiserror::Error)]
#[error("{}: {source}", path.display())]
pub struct Error {
    pub path: PathBuf,
    #[source]
    pub source: std::io::Error,
}

/// Writes `path` through `fill`.
pub fn write(path: &Path, fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>) -> Result<(), Error> {
    write_via(path, |staged| {
        let mut w = BufWriter::new(File::create(staged).map_err(|source| Error { path: path.to_owned(), source })?);
        fill(&mut w).and_then(|()| w.flush()).map_err(|source| Error { path: path.to_owned(), source })
    })
}

/// Lets `write` fill the file at a staged path (for writers that take a path: OpenVDB, image
/// encoders, a session's log thread), then fsyncs it and renames it to `path`. The staged name
/// keeps `path`'s extension, for writers that pick the format by it. `write`'s own error comes
/// back as it is.
pub fn write_via<T, E: From<Error>>(path: &Path, write: impl FnOnce(&Path) -> Result<T, E>) -> Result<T, E> {
    let err = |source: std::io::Error| Error { path: path.to_owned(), source };
    let Some(name) = path.file_name() else {
        return Err(err(std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a file path")).into());
    };
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let prefix = format!(".{}.", name.to_string_lossy());
    let suffix = path.extension().map_or(".tmp".to_string(), |e| format!(".tmp.{}", e.to_string_lossy()));
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(&suffix);
    #[cfg(unix)]
    {
        // tempfile's default 0600 would make every output private; 0666 less the umask is
        // what a plain File::create gives.
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    // Dropped without `persist` (an error, a panic), the staged file is removed.
    let staged = builder.tempfile_in(dir).map_err(err)?;
    let value = write(staged.path())?;
    // Opened again: a path writer may have replaced the staged file rather than written into it.
    File::open(staged.path()).and_then(|f| f.sync_all()).map_err(err)?;
    staged.persist(path).map_err(|e| err(e.error))?;
    Ok(value)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut n: Vec<String> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        n.sort();
        n
    }

    #[test]
    fn writes_whole_files_and_replaces_old_ones() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.json");
        write(&path, |w| w.write_all(b"first")).unwrap();
        write(&path, |w| w.write_all(b"second")).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"second");
        assert_eq!(names(dir.path()), ["a.json"]);
    }

    #[test]
    fn a_failed_fill_leaves_the_old_file_and_no_temporary_and_names_the_target() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.json");
        write(&path, |w| w.write_all(b"old")).unwrap();
        let e = write(&path, |w| {
            w.write_all(b"half")?;
            Err(std::io::Error::other("disk on fire"))
        })
        .unwrap_err();
        assert_eq!(e.path, path);
        let text = e.to_string();
        assert!(text.contains("a.json") && text.contains("disk on fire") && !text.contains(".a.json."), "{text}");
        assert_eq!(std::fs::read(&path).unwrap(), b"old");
        assert_eq!(names(dir.path()), ["a.json"]);
    }

    #[test]
    fn path_writers_see_the_extension_and_their_errors_come_back() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("plot.png");
        let seen = write_via(&path, |staged| -> Result<PathBuf, Error> {
            std::fs::write(staged, b"png").map_err(|source| Error { path: path.clone(), source })?;
            Ok(staged.to_owned())
        })
        .unwrap();
        assert_eq!(seen.extension().unwrap(), "png");
        assert_eq!(seen.parent(), Some(dir.path()));
        assert_eq!(std::fs::read(&path).unwrap(), b"png");
        #[derive(Debug)]
        enum Mine {
            Atomic,
            Writer(&'static str),
        }
        impl From<Error> for Mine {
            fn from(_: Error) -> Self {
                Mine::Atomic
            }
        }
        let r: Result<(), Mine> = write_via(&dir.path().join("b.vdb"), |staged| {
            std::fs::write(staged, b"partial").unwrap();
            Err(Mine::Writer("grid refused"))
        });
        assert!(matches!(r, Err(Mine::Writer("grid refused"))), "{r:?}");
        assert_eq!(names(dir.path()), ["plot.png"]);
    }

    #[test]
    fn a_missing_folder_is_an_error_naming_the_target() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("no/such/folder/a.csv");
        let e = write(&path, |w| w.write_all(b"x")).unwrap_err();
        assert_eq!(e.path, path);
    }

    #[cfg(unix)]
    #[test]
    fn outputs_get_the_usual_permissions_not_tempfiles_private_ones() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let (ours, plain) = (dir.path().join("a"), dir.path().join("b"));
        write(&ours, |w| w.write_all(b"x")).unwrap();
        std::fs::write(&plain, b"x").unwrap();
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode(&ours), mode(&plain));
    }
}
