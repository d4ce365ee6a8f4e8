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

/// Staging folders are `.dentsim-staging.<pid>.<random>`: the pid tells a live batch from one a
/// killed process left behind.
const STAGE_PREFIX: &str = ".dentsim-staging.";

/// Removes staging folders in `dir` whose process is gone (killed mid-write: its files never
/// reached the destination). Only where `/proc` tells which processes live.
fn remove_abandoned_stages(dir: &Path) {
    if !Path::new("/proc/self").exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let Some(pid) = name.strip_prefix(STAGE_PREFIX).and_then(|rest| rest.split('.').next()).and_then(|p| p.parse::<u32>().ok()) else {
            continue;
        };
        if !Path::new(&format!("/proc/{pid}")).exists() {
            let _ = std::fs::remove_dir_all(entry.path());
        }
    }
}

/// Several files that appear together or not at all: each is written into a hidden staging
/// folder inside the destination (same file system), and [`Batch::commit`] renames them all into
/// place, putting back whatever it replaced if one rename fails. Dropped without `commit` (an
/// error, a panic), the staging folder and everything in it is removed: the destination is as
/// before. Files come out of the staging folder by name; writers write there as they would into
/// the destination ([`write`], [`write_via`] or any path writer).
pub struct Batch {
    dir: PathBuf,
    stage: tempfile::TempDir,
}

impl Batch {
    /// Stages files for `dir` (created if missing).
    pub fn new(dir: &Path) -> Result<Batch, Error> {
        let err = |source| Error { path: dir.to_owned(), source };
        std::fs::create_dir_all(dir).map_err(err)?;
        remove_abandoned_stages(dir);
        let prefix = format!("{STAGE_PREFIX}{}.", std::process::id());
        let stage = tempfile::Builder::new().prefix(&prefix).tempdir_in(dir).map_err(err)?;
        Ok(Batch { dir: dir.to_owned(), stage })
    }

    /// The staging folder: write the batch's files here.
    pub fn dir(&self) -> &Path {
        self.stage.path()
    }

    /// The destination folder.
    pub fn destination(&self) -> &Path {
        &self.dir
    }

    /// Where a staged path lands: the same name in the destination (for error messages).
    pub fn final_path(&self, staged: &Path) -> PathBuf {
        staged.strip_prefix(self.stage.path()).map_or_else(|_| staged.to_owned(), |rest| self.dir.join(rest))
    }

    /// Renames every staged file into the destination. On an error the files already renamed are
    /// taken back and the ones they replaced restored; the error names the destination file.
    pub fn commit(self) -> Result<Vec<PathBuf>, Error> {
        self.commit_with(&mut |from, to| std::fs::rename(from, to))
    }

    /// `commit` with its renames done by `rename` (tests inject failures through it).
    fn commit_with(self, rename: &mut dyn FnMut(&Path, &Path) -> std::io::Result<()>) -> Result<Vec<PathBuf>, Error> {
        let stage = self.stage.path();
        let err = |path: &Path, source| Error { path: path.to_owned(), source };
        let mut names = Vec::new();
        for entry in std::fs::read_dir(stage).map_err(|e| err(&self.dir, e))? {
            let entry = entry.map_err(|e| err(&self.dir, e))?;
            let name = entry.file_name();
            // Dot files are writers' own temporaries, never outputs.
            if entry.file_type().map_err(|e| err(&self.dir, e))?.is_file() && !name.to_string_lossy().starts_with('.') {
                File::open(entry.path()).and_then(|f| f.sync_all()).map_err(|e| err(&self.dir.join(&name), e))?;
                names.push(name);
            }
        }
        names.sort();
        let replaced = stage.join(".replaced");
        std::fs::create_dir(&replaced).map_err(|e| err(&self.dir, e))?;
        let mut done: Vec<(PathBuf, bool)> = Vec::new();
        // Puts back what was replaced with plain renames (an injected fault is for the commit).
        let undo = |done: &[(PathBuf, bool)]| {
            for (target, had_old) in done.iter().rev() {
                let name = target.file_name().expect("a file name");
                if *had_old {
                    let _ = std::fs::rename(replaced.join(name), target);
                } else {
                    let _ = std::fs::remove_file(target);
                }
            }
        };
        for name in &names {
            let target = self.dir.join(name);
            let had_old = match rename(&target, &replaced.join(name)) {
                Ok(()) => true,
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => false,
                Err(e) => {
                    undo(&done);
                    return Err(err(&target, e));
                }
            };
            if let Err(e) = rename(&stage.join(name), &target) {
                if had_old {
                    let _ = std::fs::rename(replaced.join(name), &target);
                }
                undo(&done);
                return Err(err(&target, e));
            }
            done.push((target, had_old));
        }
        // The renames themselves made durable; where the folder cannot be opened, the files are
        // in place all the same.
        if let Ok(d) = File::open(&self.dir) {
            let _ = d.sync_all();
        }
        Ok(done.into_iter().map(|(p, _)| p).collect())
    }
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

    #[test]
    fn a_batch_appears_whole_and_replaces_old_files() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("a.json"), b"old a").unwrap();
        std::fs::write(dir.path().join("keep.txt"), b"other").unwrap();
        let batch = Batch::new(dir.path()).unwrap();
        write(&batch.dir().join("a.json"), |w| w.write_all(b"new a")).unwrap();
        write(&batch.dir().join("b.vtp"), |w| w.write_all(b"new b")).unwrap();
        assert_eq!(std::fs::read(dir.path().join("a.json")).unwrap(), b"old a", "nothing shows before commit");
        assert_eq!(batch.final_path(&batch.dir().join("b.vtp")), dir.path().join("b.vtp"));
        let written = batch.commit().unwrap();
        assert_eq!(written, [dir.path().join("a.json"), dir.path().join("b.vtp")]);
        assert_eq!(names(dir.path()), ["a.json", "b.vtp", "keep.txt"]);
        assert_eq!(std::fs::read(dir.path().join("a.json")).unwrap(), b"new a");
    }

    #[test]
    fn a_dropped_batch_leaves_the_folder_as_it_was() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("a.json"), b"old a").unwrap();
        {
            let batch = Batch::new(dir.path()).unwrap();
            write(&batch.dir().join("a.json"), |w| w.write_all(b"new a")).unwrap();
            write(&batch.dir().join("b.vtp"), |w| w.write_all(b"new b")).unwrap();
        }
        assert_eq!(names(dir.path()), ["a.json"]);
        assert_eq!(std::fs::read(dir.path().join("a.json")).unwrap(), b"old a");
    }

    #[test]
    fn a_failed_rename_puts_back_what_was_replaced_and_names_the_file() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("a.json"), b"old a").unwrap();
        std::fs::write(dir.path().join("c.stl"), b"old c").unwrap();
        let batch = Batch::new(dir.path()).unwrap();
        for name in ["a.json", "b.vtp", "c.stl"] {
            write(&batch.dir().join(name), |w| w.write_all(b"new")).unwrap();
        }
        // a.json aside, a.json in, b.vtp in, c.stl aside, then c.stl's own rename fails.
        let mut n = 0;
        let e = batch
            .commit_with(&mut |from, to| {
                n += 1;
                if n == 5 { Err(std::io::Error::other("injected")) } else { std::fs::rename(from, to) }
            })
            .unwrap_err();
        assert!(e.path.ends_with("c.stl") && e.to_string().contains("injected"), "{e}");
        assert_eq!(names(dir.path()), ["a.json", "c.stl"]);
        assert_eq!(std::fs::read(dir.path().join("a.json")).unwrap(), b"old a");
        assert_eq!(std::fs::read(dir.path().join("c.stl")).unwrap(), b"old c");
    }

    #[test]
    fn a_batch_clears_stages_abandoned_by_dead_processes_and_keeps_live_ones() {
        if !Path::new("/proc/self").exists() {
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        // No process has pid u32::MAX - 1 (above any pid_max); ours lives.
        let dead = dir.path().join(format!("{STAGE_PREFIX}{}.abc", u32::MAX - 1));
        let live = dir.path().join(format!("{STAGE_PREFIX}{}.def", std::process::id()));
        for d in [&dead, &live] {
            std::fs::create_dir(d).unwrap();
            std::fs::write(d.join("enamel.vtp"), b"half").unwrap();
        }
        Batch::new(dir.path()).unwrap().commit().unwrap();
        assert!(!dead.exists() && live.exists());
    }
}
