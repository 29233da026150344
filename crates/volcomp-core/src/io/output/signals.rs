//! Temporary files that never outlive the process.
//!
//! On Linux a temporary is created unnamed (`O_TMPFILE`, see open(2)) and
//! given a name only for the instant between `linkat` and `rename`; the
//! kernel frees it if the process dies, even by `SIGKILL`. Where that is not
//! available the temporary is a named `.volcomp-*.tmp` file, kept in a
//! registry: [`install_cleanup`] removes every registered file on SIGINT,
//! SIGTERM and SIGHUP before the process ends with the signal's default
//! action (so the shell still sees "killed by SIGINT").
//!
//! The registry's lock is held while a temporary is named and renamed, and
//! by the signal handler while it cleans up: a signal that arrives during a
//! rename waits for it, so a destination is always either the old content
//! or the complete new one.

use std::fs::File;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

static TEMPORARIES: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn registry() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    TEMPORARIES.lock().unwrap_or_else(|e| e.into_inner())
}

/// Removes the named temporaries on SIGINT, SIGTERM and SIGHUP, then ends
/// the process as the signal would have. Installs a handler thread once per
/// process; a program embedding the library calls it if it wants this.
pub fn install_cleanup() -> io::Result<()> {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    static INSTALLED: std::sync::OnceLock<()> = std::sync::OnceLock::new();
    if INSTALLED.get().is_some() {
        return Ok(());
    }
    let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP])?;
    let _ = INSTALLED.set(());
    std::thread::Builder::new()
        .name("volcomp-signals".into())
        .spawn(move || {
            if let Some(sig) = signals.forever().next() {
                let held = registry();
                for p in held.iter() {
                    let _ = std::fs::remove_file(p);
                }
                // Ends the process with the signal's default action while
                // the lock is held, so no new temporary appears meanwhile.
                let _ = signal_hook::low_level::emulate_default_handler(sig);
                std::process::exit(128 + sig);
            }
        })?;
    Ok(())
}

/// A temporary in `dir`: unnamed where possible (`None`), else named and
/// registered for clean-up.
pub(super) fn create_temporary(dir: &Path) -> io::Result<(File, Option<PathBuf>)> {
    // `VOLCOMP_NAMED_TEMPORARIES=1` forces the portable path (named files
    // and signal clean-up) on Linux too, so that it can be tested there.
    #[cfg(target_os = "linux")]
    if std::env::var_os("VOLCOMP_NAMED_TEMPORARIES").is_none() {
        use rustix::fs::{openat, Mode, OFlags, CWD};
        if let Ok(fd) = openat(
            CWD,
            dir,
            OFlags::RDWR | OFlags::TMPFILE | OFlags::CLOEXEC,
            Mode::from_bits_truncate(0o666),
        ) {
            return Ok((File::from(fd), None));
        }
    }
    let (file, path) = named_temporary(dir)?;
    Ok((file, Some(path)))
}

fn named_temporary(dir: &Path) -> io::Result<(File, PathBuf)> {
    let mut held = registry();
    let tmp = tempfile::Builder::new()
        .prefix(".volcomp-")
        .suffix(".tmp")
        .permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666))
        .tempfile_in(dir)?;
    let (file, path) = tmp.into_parts();
    let path = path.keep().map_err(|e| e.error)?;
    held.push(path.clone());
    Ok((file, path))
}

/// Removes a named temporary that will not be used.
pub(super) fn discard(path: &Path) {
    let mut held = registry();
    let _ = std::fs::remove_file(path);
    held.retain(|p| p != path);
}

/// Puts a finished temporary in place over `target` (replacing it).
pub(super) fn persist(file: &mut File, named: Option<PathBuf>, target: &Path) -> io::Result<()> {
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let named = match named {
        Some(n) => n,
        None => link_unnamed(file, &dir)?,
    };
    let mut held = registry();
    let r = std::fs::rename(&named, target);
    if r.is_err() {
        let _ = std::fs::remove_file(&named);
    }
    held.retain(|p| *p != named);
    r
}

/// Gives an unnamed temporary a name in `dir` (registered for clean-up).
#[cfg(target_os = "linux")]
fn link_unnamed(file: &mut File, dir: &Path) -> io::Result<PathBuf> {
    use rustix::fs::{linkat, AtFlags, CWD};
    use std::os::fd::AsRawFd as _;
    static COUNTER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let mut held = registry();
    for _ in 0..100 {
        let n = COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let name = dir.join(format!(".volcomp-{}-{n}.tmp", std::process::id()));
        let proc_path = format!("/proc/self/fd/{}", file.as_raw_fd());
        match linkat(CWD, proc_path.as_str(), CWD, &name, AtFlags::SYMLINK_FOLLOW) {
            Ok(()) => {
                held.push(name.clone());
                return Ok(name);
            }
            Err(rustix::io::Errno::EXIST) => continue,
            Err(_) => {
                // No /proc: copy into a named temporary instead.
                drop(held);
                return copy_to_named(file, dir);
            }
        }
    }
    Err(io::Error::new(
        io::ErrorKind::AlreadyExists,
        "no free temporary name",
    ))
}

#[cfg(not(target_os = "linux"))]
fn link_unnamed(file: &mut File, dir: &Path) -> io::Result<PathBuf> {
    copy_to_named(file, dir)
}

fn copy_to_named(file: &mut File, dir: &Path) -> io::Result<PathBuf> {
    use std::io::Seek as _;
    let (mut named, path) = named_temporary(dir)?;
    let r = file
        .seek(io::SeekFrom::Start(0))
        .and_then(|_| io::copy(file, &mut named))
        .and_then(|_| named.sync_all());
    match r {
        Ok(()) => Ok(path),
        Err(e) => {
            discard(&path);
            Err(e)
        }
    }
}
