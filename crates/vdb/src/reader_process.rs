//! Runs OpenVDB's reader on a file's bytes in a fresh process: the reader program
//! (`cpp/vdb/read_child.cc`, built by build.rs and embedded here) started with
//! `std::process::Command` (fork+exec, safe in a threaded process). Not a fork that parses: a fork
//! of a process busy on other threads copies their locks and TBB state mid-use, and its child
//! could wait forever (a valid file's read timed out about once in 100–400 loaded runs).
//!
//! The program is written once per process into a sealed memfd and run as `/proc/self/fd/N`, so
//! every binary linking this crate (the CLI, test binaries, the ParaView plugin) carries it with
//! no install path. Where the kernel refuses to run memfds (`vm.memfd_noexec`), an unnamed
//! temporary file (`O_TMPFILE`, mode 0700, in the temp folder) holds it instead.
use std::ffi::CStr;
use std::fs::{File, OpenOptions};
use std::io::{self, Read, Seek, SeekFrom, Write};
use std::os::fd::{AsRawFd, FromRawFd};
use std::os::unix::fs::OpenOptionsExt;
use std::os::unix::process::{CommandExt, ExitStatusExt};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

static READER: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/dentsim-vdb-reader"));

/// An executable copy of the reader program, open for the process's life.
struct Program {
    _file: File,
    path: String,
}

static IN_MEMFD: OnceLock<Result<Program, String>> = OnceLock::new();
static IN_TEMP_FILE: OnceLock<Result<Program, String>> = OnceLock::new();
/// Set once running the memfd was refused: every later read goes straight to the temp file.
static MEMFD_REFUSED: AtomicBool = AtomicBool::new(false);

fn memfd(name: &CStr, flags: libc::c_uint) -> io::Result<File> {
    // SAFETY: a valid C string; the new descriptor is owned by the File alone.
    let fd = unsafe { libc::memfd_create(name.as_ptr(), flags) };
    if fd < 0 {
        return Err(io::Error::last_os_error());
    }
    // SAFETY: fd is a fresh descriptor nothing else owns.
    Ok(unsafe { File::from_raw_fd(fd) })
}

fn install_in_memfd() -> io::Result<Program> {
    let flags = libc::MFD_CLOEXEC | libc::MFD_ALLOW_SEALING;
    // MFD_EXEC asks for an executable memfd where vm.memfd_noexec exists; older kernels refuse
    // the flag itself, and their memfds are executable anyway.
    let mut file = match memfd(c"dentsim-vdb-reader", flags | libc::MFD_EXEC) {
        Err(e) if e.raw_os_error() == Some(libc::EINVAL) => memfd(c"dentsim-vdb-reader", flags)?,
        other => other?,
    };
    file.write_all(READER)?;
    let seals = libc::F_SEAL_SHRINK | libc::F_SEAL_GROW | libc::F_SEAL_WRITE | libc::F_SEAL_SEAL;
    // SAFETY: fcntl on a descriptor this File owns.
    if unsafe { libc::fcntl(file.as_raw_fd(), libc::F_ADD_SEALS, seals) } != 0 {
        return Err(io::Error::last_os_error());
    }
    let path = format!("/proc/self/fd/{}", file.as_raw_fd());
    Ok(Program { _file: file, path })
}

fn install_in_temp_file() -> io::Result<Program> {
    let mut writer = OpenOptions::new()
        .read(true)
        .write(true)
        .mode(0o700)
        .custom_flags(libc::O_TMPFILE | libc::O_CLOEXEC)
        .open(std::env::temp_dir())?;
    writer.write_all(READER)?;
    // Run through a read-only descriptor: a file open for writing cannot be executed (ETXTBSY).
    let file = File::open(format!("/proc/self/fd/{}", writer.as_raw_fd()))?;
    drop(writer);
    let path = format!("/proc/self/fd/{}", file.as_raw_fd());
    Ok(Program { _file: file, path })
}

/// The kernel refused to run the program from where it is (a noexec memfd or mount).
fn exec_refused(e: &io::Error) -> bool {
    matches!(e.raw_os_error(), Some(libc::EACCES | libc::EPERM | libc::ENOEXEC))
}

fn start(program: &Program, max_bytes: u64, input: &File, output: &File) -> io::Result<Child> {
    let mut attempt = 0;
    loop {
        let spawned = Command::new(&program.path)
            .arg0("dentsim-vdb-reader")
            .arg(max_bytes.to_string())
            .stdin(Stdio::from(input.try_clone()?))
            .stdout(Stdio::from(output.try_clone()?))
            .stderr(Stdio::piped())
            .spawn();
        match spawned {
            // Another thread's fork may hold a copy of the temp file's writer until it execs.
            Err(e) if e.raw_os_error() == Some(libc::ETXTBSY) && attempt < 100 => {
                attempt += 1;
                std::thread::sleep(Duration::from_millis(10));
            }
            other => return other,
        }
    }
}

/// Starts the reader on `input`, from the memfd copy or, if the kernel refuses that, the temp file.
fn spawn(max_bytes: u64, input: &File, output: &File) -> Result<Child, String> {
    let mut why = Vec::new();
    if !MEMFD_REFUSED.load(Ordering::Relaxed) {
        match IN_MEMFD.get_or_init(|| install_in_memfd().map_err(|e| e.to_string())) {
            Ok(program) => match start(program, max_bytes, input, output) {
                Ok(child) => return Ok(child),
                Err(e) if exec_refused(&e) => {
                    MEMFD_REFUSED.store(true, Ordering::Relaxed);
                    why.push(format!("from a memfd: {e}"));
                }
                Err(e) => return Err(format!("could not start OpenVDB's reader process: {e}")),
            },
            Err(e) => why.push(format!("in a memfd: {e}")),
        }
    }
    let started = match IN_TEMP_FILE.get_or_init(|| install_in_temp_file().map_err(|e| e.to_string())) {
        Ok(program) => start(program, max_bytes, input, output).map_err(|e| e.to_string()),
        Err(e) => Err(e.clone()),
    };
    started.map_err(|e| {
        why.push(format!("from a temporary file in {}: {e}", std::env::temp_dir().display()));
        format!("could not start OpenVDB's reader process ({})", why.join("; "))
    })
}

/// Parses `bytes` with OpenVDB in the reader process, its memory capped at its size + `max_bytes`,
/// and returns the grids as OpenVDB's writer wrote them back (uncompressed), or why not. The
/// process is killed at `timeout_ms` and always reaped.
pub(crate) fn guarded_read(bytes: &[u8], max_bytes: u64, timeout_ms: u64) -> Result<Vec<u8>, String> {
    guarded_read_by(bytes, max_bytes, timeout_ms, |input, output| spawn(max_bytes, input, output))
}

fn guarded_read_by(
    bytes: &[u8],
    max_bytes: u64,
    timeout_ms: u64,
    spawn: impl FnOnce(&File, &File) -> Result<Child, String>,
) -> Result<Vec<u8>, String> {
    fn io_err(what: &'static str) -> impl Fn(io::Error) -> String {
        move |e| format!("could not {what} for OpenVDB's reader: {e}")
    }
    let mut input = memfd(c"dentsim-vdb-input", libc::MFD_CLOEXEC).map_err(io_err("hold the bytes"))?;
    input.write_all(bytes).map_err(io_err("hold the bytes"))?;
    let mut output = memfd(c"dentsim-vdb-read", libc::MFD_CLOEXEC).map_err(io_err("make room"))?;
    // Clamped (~35 years) so a huge timeout cannot overflow the clock.
    let deadline = Instant::now() + Duration::from_millis(timeout_ms.min(1 << 40));
    let mut child = spawn(&input, &output)?;
    drop(input);
    let (status, message) = match wait(&mut child, deadline) {
        Ok(Some(done)) => done,
        Ok(None) => return Err(format!("OpenVDB's reader did not finish within {} s (corrupt file?)", timeout_ms / 1000)),
        Err(e) => return Err(format!("could not wait for OpenVDB's reader: {e}")),
    };
    if let Some(sig) = status.signal() {
        if sig == libc::SIGKILL {
            // The kernel's OOM killer, or the cap hit outside an allocation.
            return Err(format!(
                "reading it asks for more than {} MiB of memory (corrupt sizes, or over the memory limit)",
                max_bytes >> 20
            ));
        }
        return Err(format!("OpenVDB's reader crashed on it (signal {sig}, {}): the file is corrupt", signal_name(sig)));
    }
    if status.success() {
        let mut clean = Vec::new();
        output
            .seek(SeekFrom::Start(0))
            .and_then(|_| output.read_to_end(&mut clean))
            .map_err(|e| format!("could not read back the grids OpenVDB's reader handed back: {e}"))?;
        if clean.is_empty() {
            return Err("OpenVDB's reader handed nothing back".into());
        }
        return Ok(clean);
    }
    if message.is_empty() {
        return Err(format!("OpenVDB's reader failed (exit status {})", status.code().unwrap_or(-1)));
    }
    Err(String::from_utf8_lossy(&message).into_owned())
}

/// Waits for the child's exit, collecting its message (at most 4 KiB); `None` when the deadline
/// came first (the child is then killed). The child is reaped in every case.
fn wait(child: &mut Child, deadline: Instant) -> io::Result<Option<(ExitStatus, Vec<u8>)>> {
    let result = wait_inner(child, deadline);
    if !matches!(result, Ok(Some(_))) {
        let _ = child.kill();
        let _ = child.wait();
    }
    result
}

fn wait_inner(child: &mut Child, deadline: Instant) -> io::Result<Option<(ExitStatus, Vec<u8>)>> {
    let Some(mut pipe) = child.stderr.take() else {
        return Err(io::Error::other("no message pipe"));
    };
    let mut message = Vec::new();
    let mut chunk = [0u8; 1024];
    let mut open = true;
    loop {
        if let Some(status) = child.try_wait()? {
            // What the child wrote before it exited is in the pipe already.
            while open && readable(&pipe, 0)? {
                match pipe.read(&mut chunk) {
                    Ok(0) | Err(_) => open = false,
                    Ok(n) => keep(&mut message, &chunk[..n]),
                }
            }
            return Ok(Some((status, message)));
        }
        let left = deadline.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Ok(None);
        }
        let slice = left.min(Duration::from_millis(20));
        if !open {
            // End of file: the child is exiting; its status follows at once.
            std::thread::sleep(slice.min(Duration::from_millis(1)));
            continue;
        }
        if readable(&pipe, slice.as_millis() as libc::c_int)? {
            match pipe.read(&mut chunk) {
                Ok(0) => open = false,
                Ok(n) => keep(&mut message, &chunk[..n]),
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
    }
}

fn keep(message: &mut Vec<u8>, chunk: &[u8]) {
    let room = 4096usize.saturating_sub(message.len());
    message.extend_from_slice(&chunk[..chunk.len().min(room)]);
}

/// Whether `pipe` has data or end of file within `timeout_ms`.
fn readable(pipe: &impl AsRawFd, timeout_ms: libc::c_int) -> io::Result<bool> {
    let mut p = libc::pollfd { fd: pipe.as_raw_fd(), events: libc::POLLIN, revents: 0 };
    // SAFETY: one valid pollfd.
    let r = unsafe { libc::poll(&mut p, 1, timeout_ms) };
    if r < 0 {
        let e = io::Error::last_os_error();
        return if e.kind() == io::ErrorKind::Interrupted { Ok(false) } else { Err(e) };
    }
    Ok(r > 0)
}

fn signal_name(sig: i32) -> String {
    // SAFETY: strsignal returns a valid C string (or null), copied before another call.
    let name = unsafe { libc::strsignal(sig) };
    if name.is_null() {
        return "unknown signal".into();
    }
    // SAFETY: checked non-null above; glibc's strsignal strings are NUL-terminated.
    unsafe { CStr::from_ptr(name) }.to_string_lossy().into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{read_unguarded, write_file, LevelSet, ReadLimits};
    use glam::DVec3;

    /// Both homes of the program run it: the memfd, and the temp file kept for kernels that
    /// refuse to run memfds (this machine may not, so the fallback is run here directly).
    #[test]
    fn the_reader_runs_from_a_memfd_and_from_a_temp_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("ball.vdb");
        let ball = LevelSet::from_sdf(0.1, 3.0, DVec3::splat(-1.0), DVec3::splat(1.0), |p| p.length() - 1.0).unwrap();
        write_file(&path, &[&ball]).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        for (home, program) in [("memfd", install_in_memfd()), ("temp file", install_in_temp_file())] {
            let program = program.unwrap_or_else(|e| panic!("{home}: {e}"));
            let clean = guarded_read_by(&bytes, 1 << 30, 60_000, |i, o| start(&program, 1 << 30, i, o).map_err(|e| e.to_string()))
                .unwrap_or_else(|e| panic!("{home}: {e}"));
            let grids = read_unguarded(&clean, &ReadLimits::default()).unwrap();
            assert_eq!(grids.len(), 1, "{home}");
            assert_eq!(grids[0].level_set.as_ref().unwrap().volume(), ball.volume(), "{home}");
        }
    }
}
