//! Every file volcomp reads goes through this module, which remembers it.
//!
//! A command reads the files it is given (a program, a map, a set-up) and
//! the files those name (the tables of a model TOML, the set-up's
//! `var_file`, a subroutine file found on the subroutine path while the
//! program runs, the compensation files of a LinuxCNC INI, the tables of a
//! `.CMA`). An output must replace none of them. The output layer
//! (`volcomp_core::io::output`) compares every output with every file
//! recorded here — by device and inode, read from the open descriptor, so a
//! symbolic link, `..` or a hard link cannot hide a file — when it checks
//! the command's plan and again just before it puts any output in place.
//!
//! The module is in the lowest crate so that the G-code engine's own reads
//! (subroutine files, the var file) are recorded like the others. The
//! library crates refuse `std::fs::read`, `read_to_string` and
//! `File::open` outside this module (clippy's `disallowed_methods`, see
//! `clippy.toml`), so a new reader cannot forget to record its file.
//!
//! Files read whole are bounded: [`read`] refuses a file larger than
//! [`max_file_bytes`] (256 MiB unless the front end sets another limit)
//! before it reads more than that, so `/dev/zero` or a runaway export is
//! refused in a fraction of a second instead of filling memory. Programs,
//! which may be large and are streamed, are opened with [`open`].

// The one place that opens input files.
#![allow(clippy::disallowed_methods)]

use std::fs::File;
use std::io::{self, Read as _};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

/// The default bound on one file read whole: 256 MiB. An axis-table map of
/// a million points per axis takes about 90 MB; larger inputs are almost
/// always the wrong file (an image, a device, a log).
pub const DEFAULT_MAX_FILE_BYTES: u64 = 256 * 1024 * 1024;

static MAX_FILE_BYTES: AtomicU64 = AtomicU64::new(DEFAULT_MAX_FILE_BYTES);

/// The bound on one file read whole, in bytes.
pub fn max_file_bytes() -> u64 {
    MAX_FILE_BYTES.load(Ordering::Relaxed)
}

/// Sets the bound on one file read whole (`u64::MAX`: none). A front end
/// sets it once from its option (the CLI's `--max-input-size`).
pub fn set_max_file_bytes(bytes: u64) {
    MAX_FILE_BYTES.store(bytes, Ordering::Relaxed);
}

/// One file read by this process.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReadFile {
    /// The path it was opened by.
    pub path: PathBuf,
    /// What it was read as: `the map`, `the var file named in machine.toml`,
    /// `the subroutine file of o<probe> call`…
    pub role: String,
    /// Device and inode of the file, from its open descriptor.
    pub id: FileId,
    /// The path made absolute when it was read (the working directory may
    /// change since); `None` for standard input.
    pub absolute: Option<PathBuf>,
}

impl ReadFile {
    /// Whether its name still leads to the file read (a file read and
    /// deleted since may have left its inode number to a new file, which
    /// was never read).
    fn alive(&self) -> bool {
        self.absolute
            .as_deref()
            .is_none_or(|p| FileId::of_path(p) == Some(self.id))
    }
}

/// Device and inode number: the identity of a file whatever its name.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct FileId {
    /// Device.
    pub dev: u64,
    /// Inode number.
    pub ino: u64,
}

impl FileId {
    /// The identity of a regular file or directory, `None` for anything
    /// else (devices, FIFOs, sockets: reading one replaces nothing, and
    /// writing `/dev/null` twice is no conflict).
    pub fn of(meta: &std::fs::Metadata) -> Option<FileId> {
        #[cfg(unix)]
        {
            use std::os::unix::fs::MetadataExt as _;
            (meta.is_file() || meta.is_dir()).then(|| FileId {
                dev: meta.dev(),
                ino: meta.ino(),
            })
        }
        #[cfg(not(unix))]
        {
            let _ = meta;
            None
        }
    }

    /// The identity of what `path` names now (links followed), if it is a
    /// regular file or directory.
    pub fn of_path(path: &Path) -> Option<FileId> {
        std::fs::metadata(path).ok().as_ref().and_then(FileId::of)
    }
}

static READ: Mutex<Vec<ReadFile>> = Mutex::new(Vec::new());

fn ledger() -> std::sync::MutexGuard<'static, Vec<ReadFile>> {
    READ.lock().unwrap_or_else(|e| e.into_inner())
}

fn record(file: &File, path: &Path, role: &str) -> io::Result<std::fs::Metadata> {
    let meta = file.metadata()?;
    if let Some(id) = FileId::of(&meta) {
        note(id, path, role);
    }
    Ok(meta)
}

fn note(id: FileId, path: &Path, role: &str) {
    let entry = ReadFile {
        path: path.to_path_buf(),
        role: role.to_string(),
        id,
        absolute: (path.as_os_str() != "-")
            .then(|| std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf())),
    };
    let mut read = ledger();
    match read.iter_mut().find(|r| r.id == id) {
        Some(old) if old.alive() => {}
        Some(stale) => *stale = entry,
        None => read.push(entry),
    }
}

/// The identity of what standard input (descriptor 0) reads, when it is
/// a regular file (`volcomp compensate - < part.ngc`).
pub fn stdin_id() -> Option<FileId> {
    #[cfg(unix)]
    {
        use std::os::fd::AsFd as _;
        let fd = io::stdin().as_fd().try_clone_to_owned().ok()?;
        FileId::of(&File::from(fd).metadata().ok()?)
    }
    #[cfg(not(unix))]
    None
}

/// The identity of what standard output (descriptor 1) writes to, when it
/// is a regular file (`volcomp … -o - >> part.ngc`).
pub fn stdout_id() -> Option<FileId> {
    #[cfg(unix)]
    {
        use std::os::fd::AsFd as _;
        let fd = io::stdout().as_fd().try_clone_to_owned().ok()?;
        FileId::of(&File::from(fd).metadata().ok()?)
    }
    #[cfg(not(unix))]
    None
}

/// Records standard input as a file read, as `role`, when it is a regular
/// file.
pub fn record_stdin(role: &str) {
    if let Some(id) = stdin_id() {
        note(id, Path::new("-"), role);
    }
}

/// Opens `path` for reading, recording it as `role`. For streamed inputs
/// (programs); files read whole go through [`read`], which bounds them.
pub fn open(path: &Path, role: &str) -> io::Result<File> {
    let file = File::open(path)?;
    record(&file, path, role)?;
    Ok(file)
}

/// Reads the whole of `path`, recorded as `role`, refusing more than
/// [`max_file_bytes`] bytes.
pub fn read(path: &Path, role: &str) -> io::Result<Vec<u8>> {
    read_at_most(path, role, max_file_bytes())
}

/// Reads the whole of `path`, recorded as `role`, refusing a file of more
/// than `limit` bytes — before reading it when its size is known, after
/// `limit + 1` bytes for a device or a pipe. The error is of kind
/// [`io::ErrorKind::FileTooLarge`] and gives the limit.
pub fn read_at_most(path: &Path, role: &str, limit: u64) -> io::Result<Vec<u8>> {
    let file = File::open(path)?;
    let meta = record(&file, path, role)?;
    if meta.is_dir() {
        return Err(io::Error::new(
            io::ErrorKind::IsADirectory,
            "is a directory, not a file",
        ));
    }
    if meta.is_file() && meta.len() > limit {
        return Err(too_large(Some(meta.len()), limit));
    }
    let capacity = if meta.is_file() { meta.len() } else { 0 };
    let mut bytes = Vec::with_capacity(usize::try_from(capacity).unwrap_or(0));
    file.take(limit.saturating_add(1)).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(too_large(None, limit));
    }
    Ok(bytes)
}

/// [`read`] as UTF-8 text (an error of kind `InvalidData` otherwise).
pub fn read_to_string(path: &Path, role: &str) -> io::Result<String> {
    String::from_utf8(read(path, role)?).map_err(|e| {
        io::Error::new(
            io::ErrorKind::InvalidData,
            format!(
                "byte {} is not UTF-8 text: save the file as UTF-8",
                e.utf8_error().valid_up_to() + 1
            ),
        )
    })
}

/// Bytes as people read them: `256 MiB`, `1.5 GiB`, `300 bytes`.
pub fn show_bytes(n: u64) -> String {
    const UNITS: [(&str, u64); 3] = [("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)];
    for (name, size) in UNITS {
        if n >= size {
            let v = n as f64 / size as f64;
            return if v.fract() == 0.0 {
                format!("{v:.0} {name}")
            } else {
                format!("{v:.1} {name}")
            };
        }
    }
    format!("{n} bytes")
}

/// The help of an input refused for its size: the words a front end
/// rewords with its flag.
pub const TOO_LARGE_HELP: &str = "raise the input size limit if this really is the file";

fn too_large(size: Option<u64>, limit: u64) -> io::Error {
    let what = match size {
        Some(s) if show_bytes(s) == format!("{s} bytes") => {
            format!("the file holds {s} bytes, more than")
        }
        Some(s) => format!("the file holds {} ({s} bytes), more than", show_bytes(s)),
        None => "the file (a device or a pipe) gives more than".to_string(),
    };
    io::Error::new(
        io::ErrorKind::FileTooLarge,
        format!(
            "{what} the {} one input file may have ({TOO_LARGE_HELP})",
            show_bytes(limit)
        ),
    )
}

/// Every file read so far that its name still leads to (see [`find`]).
pub fn read_so_far() -> Vec<ReadFile> {
    let read = ledger().clone();
    read.into_iter().filter(ReadFile::alive).collect()
}

/// The file read so far whose identity is `id`, if any: one whose name
/// still leads to that identity (a file read and deleted since may have
/// left its inode number to a new file, which was never read).
pub fn find(id: FileId) -> Option<ReadFile> {
    let entry = ledger().iter().find(|r| r.id == id).cloned()?;
    entry.alive().then_some(entry)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_read_is_recorded_once_by_identity() {
        let d = tempfile_dir();
        let a = d.join("a.csv");
        std::fs::write(&a, "x").unwrap();
        let link = d.join("link.csv");
        std::os::unix::fs::symlink(&a, &link).unwrap();
        assert_eq!(read(&a, "the map").unwrap(), b"x");
        assert_eq!(read_to_string(&link, "again").unwrap(), "x");
        let id = FileId::of_path(&a).unwrap();
        let r = find(id).unwrap();
        assert_eq!(
            (r.path.as_path(), r.role.as_str()),
            (a.as_path(), "the map")
        );
        assert_eq!(read_so_far().iter().filter(|r| r.id == id).count(), 1);
        std::fs::remove_dir_all(d).unwrap();
    }

    #[test]
    fn a_file_read_and_deleted_is_forgotten() {
        let d = tempfile_dir();
        let a = d.join("gone.csv");
        std::fs::write(&a, "x").unwrap();
        read(&a, "the map").unwrap();
        let id = FileId::of_path(&a).unwrap();
        assert!(find(id).is_some());
        std::fs::remove_file(&a).unwrap();
        // Its inode number may be given to the next file created.
        assert!(find(id).is_none());
        assert!(read_so_far().iter().all(|r| r.id != id));
        std::fs::remove_dir_all(d).unwrap();
    }

    #[test]
    fn a_device_is_read_up_to_the_limit_and_refused() {
        if !Path::new("/dev/zero").exists() {
            return;
        }
        let e = read_at_most(Path::new("/dev/zero"), "map", 1000).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::FileTooLarge);
        assert!(
            e.to_string()
                .starts_with("the file (a device or a pipe) gives more than the 1000 bytes"),
            "{e}"
        );
        // Devices are not recorded: writing one replaces nothing.
        assert!(FileId::of_path(Path::new("/dev/zero")).is_none());
    }

    #[test]
    fn a_regular_file_over_the_limit_is_refused_by_its_size() {
        let d = tempfile_dir();
        let a = d.join("big.csv");
        std::fs::write(&a, vec![b'0'; 2048]).unwrap();
        let e = read_at_most(&a, "map", 1024).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::FileTooLarge);
        assert!(
            e.to_string()
                .starts_with("the file holds 2 KiB (2048 bytes), more than the 1 KiB"),
            "{e}"
        );
        assert_eq!(read_at_most(&a, "map", 2048).unwrap().len(), 2048);
        std::fs::remove_dir_all(d).unwrap();
    }

    #[test]
    fn bytes_are_shown_in_binary_units() {
        assert_eq!(show_bytes(256 << 20), "256 MiB");
        assert_eq!(show_bytes(1536 << 20), "1.5 GiB");
        assert_eq!(show_bytes(300), "300 bytes");
    }

    /// A fresh directory (this crate has no dev-dependency for one).
    fn tempfile_dir() -> PathBuf {
        use std::sync::atomic::AtomicUsize;
        static N: AtomicUsize = AtomicUsize::new(0);
        let d = std::env::temp_dir().join(format!(
            "volcomp-geom-inputs-{}-{}",
            std::process::id(),
            N.fetch_add(1, Ordering::Relaxed)
        ));
        std::fs::create_dir_all(&d).unwrap();
        d
    }
}
