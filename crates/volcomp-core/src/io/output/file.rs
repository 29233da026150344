//! One output file: written completely or not at all.
//!
//! - A regular file (or a name that does not exist yet) is written to a
//!   temporary file in the same directory and renamed over the destination
//!   only when every output of the command is complete ([`commit_all`]). On
//!   Linux the temporary is unnamed (`O_TMPFILE`, open(2)): it has no name
//!   until it is linked just before the rename, so even `SIGKILL` leaves
//!   nothing behind. Elsewhere (or on a file system without `O_TMPFILE`) it
//!   is a named `.volcomp-*.tmp` file, removed on drop and on SIGINT,
//!   SIGTERM and SIGHUP (see [`super::signals`]).
//! - A symbolic link to a regular file is followed: its target is replaced,
//!   the link stays.
//! - Anything else — a character device (`/dev/null`, `/dev/full`, a
//!   terminal), a FIFO, a socket, `/dev/stdout` — is opened and written
//!   through, never replaced: renaming over it would destroy the device.
//! - `-` is standard output (spooled until commit, so a failed command
//!   sends nothing rather than half a result).

use super::signals;
use std::fs::{File, OpenOptions, Permissions};
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use volcomp_geom::inputs;

pub use crate::error::domain::OutputError;

impl OutputError {
    /// The underlying I/O error, if any.
    pub fn io_error(&self) -> Option<&io::Error> {
        match self {
            OutputError::Io { source, .. } => Some(source),
            OutputError::Partial { cause, .. } => cause.io_error(),
            OutputError::Refused { .. } => None,
        }
    }

    /// Whether this failure is on standard output.
    pub fn is_stdout(&self) -> bool {
        matches!(self, OutputError::Io { path, .. } if path.as_os_str() == "-")
    }
}

fn list(paths: &[PathBuf]) -> String {
    if paths.is_empty() {
        return "none".into();
    }
    paths
        .iter()
        .map(|p| crate::io::shown_path(p))
        .collect::<Vec<_>>()
        .join(", ")
}

impl std::fmt::Display for OutputError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            OutputError::Io { path, source } if path.as_os_str() == "-" => {
                write!(f, "cannot write to standard output: {source}")
            }
            OutputError::Io { path, source } => {
                write!(f, "{}: {source}", crate::io::shown_path(path))
            }
            OutputError::Refused { path, why } => {
                write!(f, "{}: {why}", crate::io::shown_path(path))
            }
            OutputError::Partial {
                written,
                not_written,
                cause,
            } => write!(
                f,
                "{cause}\n  written: {}\n  NOT written (left as they were): {}",
                list(written),
                list(not_written)
            ),
        }
    }
}

impl std::error::Error for OutputError {}

enum Sink {
    /// Standard output, spooled in an unnamed temporary file until commit
    /// (so a failure half-way sends nothing), or written directly when no
    /// temporary file can be made.
    Stdout(Option<File>),
    /// Written through: a device, FIFO or socket.
    Through(File),
    /// A temporary renamed over `target` on commit.
    Replace {
        file: File,
        /// The regular file (link target) replaced, or created.
        target: PathBuf,
        /// The temporary's name when it has one (no `O_TMPFILE`).
        named: Option<PathBuf>,
        /// Permissions to give the result (those of the file replaced).
        permissions: Option<Permissions>,
    },
}

/// An output being written. Write to it (it is unbuffered: wrap it in a
/// `BufWriter` and flush that), then [`OutputFile::commit`] it or pass it to
/// [`commit_all`]. Dropped without commit, it leaves the destination as it was.
pub struct OutputFile {
    shown: PathBuf,
    sink: Sink,
    committed: bool,
}

/// Follows a chain of symbolic links to the last name (which need not exist).
fn follow_links(path: &Path) -> Result<PathBuf, String> {
    let mut p = path.to_path_buf();
    for _ in 0..40 {
        match std::fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => {
                let t = std::fs::read_link(&p).map_err(|e| e.to_string())?;
                p = match p.parent() {
                    Some(dir) if t.is_relative() => dir.join(t),
                    _ => t,
                };
            }
            _ => return Ok(p),
        }
    }
    Err("too many levels of symbolic links".into())
}

impl OutputFile {
    /// Opens the output `path` (`-`: standard output). Nothing at `path`
    /// changes until commit, except for special files, which are written
    /// through as bytes arrive.
    pub fn create(path: &Path) -> Result<OutputFile, OutputError> {
        let shown = path.to_path_buf();
        let err = |source: io::Error| OutputError::Io {
            path: shown.clone(),
            source,
        };
        if path.as_os_str() == "-" {
            let out = OutputFile {
                shown,
                sink: Sink::Stdout(tempfile::tempfile().ok()),
                committed: false,
            };
            out.check_not_read()?;
            return Ok(out);
        }
        let existing = match std::fs::metadata(path) {
            Ok(m) => Some(m),
            Err(e) if e.kind() == io::ErrorKind::NotFound => None,
            Err(e) => return Err(err(e)),
        };
        if let Some(m) = &existing {
            if m.is_dir() {
                return Err(OutputError::Refused {
                    path: shown,
                    why: "is a directory: name a file to write".into(),
                });
            }
            if !m.is_file() {
                // Device, FIFO, socket: write through, never replace.
                let file = OpenOptions::new().write(true).open(path).map_err(err)?;
                return Ok(OutputFile {
                    shown,
                    sink: Sink::Through(file),
                    committed: false,
                });
            }
        }
        let target = follow_links(path).map_err(|why| OutputError::Refused {
            path: shown.clone(),
            why,
        })?;
        let dir = match target.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let permissions = existing.map(|m| m.permissions());
        let (file, named) = signals::create_temporary(&dir).map_err(|source| OutputError::Io {
            path: dir.clone(),
            source,
        })?;
        let out = OutputFile {
            shown,
            sink: Sink::Replace {
                file,
                target,
                named,
                permissions,
            },
            committed: false,
        };
        // Files read so far (named inside other inputs) are refused before
        // any work; those read during it, at commit.
        out.check_not_read()?;
        Ok(out)
    }

    /// The output as the user named it.
    pub fn path(&self) -> &Path {
        &self.shown
    }

    fn io_err(&self, source: io::Error) -> OutputError {
        OutputError::Io {
            path: self.shown.clone(),
            source,
        }
    }

    /// Flushes and makes the content durable before it is put in place.
    fn finish(&mut self) -> Result<(), OutputError> {
        let r = match &mut self.sink {
            Sink::Stdout(None) => io::stdout().flush(),
            Sink::Stdout(Some(spool)) => {
                use std::io::Seek as _;
                let mut out = io::stdout().lock();
                spool
                    .seek(io::SeekFrom::Start(0))
                    .and_then(|_| io::copy(spool, &mut out))
                    .and_then(|_| out.flush())
            }
            Sink::Through(f) => f.flush(),
            Sink::Replace {
                file, permissions, ..
            } => {
                let set = match permissions {
                    Some(p) => file.set_permissions(p.clone()),
                    None => Ok(()),
                };
                set.and_then(|_| file.sync_all())
            }
        };
        r.map_err(|e| self.io_err(e))
    }

    /// Puts the content in place (the rename over the destination).
    fn put_in_place(&mut self) -> Result<(), OutputError> {
        let r = match &mut self.sink {
            Sink::Replace {
                file,
                target,
                named,
                ..
            } => signals::persist(file, named.take(), target),
            _ => Ok(()),
        };
        self.committed = true;
        r.map_err(|e| self.io_err(e))
    }

    /// Refuses to put this output in place over a file the command read
    /// (`volcomp_geom::inputs`): the plan was checked before the work, but
    /// files are read during it too (a subroutine file found on the
    /// subroutine path, a table named in another file).
    pub fn check_not_read(&self) -> Result<(), OutputError> {
        let replaced = match &self.sink {
            Sink::Replace { target, .. } => inputs::FileId::of_path(target),
            Sink::Stdout(_) => inputs::stdout_id(),
            Sink::Through(_) => None,
        };
        match replaced.and_then(inputs::find) {
            Some(read) => Err(OutputError::Refused {
                path: self.shown.clone(),
                why: format!(
                    "refusing to write it: it is {} ({}), which this command read; nothing was written: choose another output path",
                    read.role,
                    crate::io::shown_path(&read.path)
                ),
            }),
            None => Ok(()),
        }
    }

    /// Completes this one output.
    pub fn commit(mut self) -> Result<(), OutputError> {
        self.check_not_read()?;
        self.finish()?;
        self.put_in_place()
    }
}

impl Write for OutputFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        match &mut self.sink {
            Sink::Stdout(Some(f)) | Sink::Through(f) => f.write(buf),
            Sink::Stdout(None) => io::stdout().write(buf),
            Sink::Replace { file, .. } => file.write(buf),
        }
    }

    fn flush(&mut self) -> io::Result<()> {
        match &mut self.sink {
            Sink::Stdout(Some(f)) | Sink::Through(f) => f.flush(),
            Sink::Stdout(None) => io::stdout().flush(),
            Sink::Replace { file, .. } => file.flush(),
        }
    }
}

impl Drop for OutputFile {
    fn drop(&mut self) {
        if let Sink::Replace { named: Some(n), .. } = &self.sink {
            if !self.committed {
                signals::discard(n);
            }
        }
    }
}

/// Completes several outputs together: all are flushed and made durable
/// first (a full disk shows here, before anything is replaced), then
/// renamed into place one after the other. If a rename fails after others
/// succeeded, the error lists which outputs were written and which not.
pub fn commit_all(mut files: Vec<OutputFile>) -> Result<(), OutputError> {
    for f in &files {
        f.check_not_read()?;
    }
    for f in files.iter_mut() {
        f.finish()?;
    }
    let mut written = Vec::new();
    let mut rest = files.into_iter();
    while let Some(mut f) = rest.next() {
        if let Err(e) = f.put_in_place() {
            if written.is_empty() {
                return Err(e);
            }
            let mut not_written = vec![f.shown.clone()];
            not_written.extend(rest.map(|r| r.shown.clone()));
            return Err(OutputError::Partial {
                written,
                not_written,
                cause: Box::new(e),
            });
        }
        written.push(f.shown.clone());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn leftovers(dir: &Path) -> Vec<String> {
        std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.contains(".volcomp-"))
            .collect()
    }

    #[test]
    fn replaces_only_on_commit() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("out.txt");
        std::fs::write(&p, "old").unwrap();
        let mut f = OutputFile::create(&p).unwrap();
        f.write_all(b"new").unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "old");
        drop(f);
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "old");
        let mut f = OutputFile::create(&p).unwrap();
        f.write_all(b"new").unwrap();
        f.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "new");
        assert!(leftovers(d.path()).is_empty());
    }

    #[test]
    fn symlink_is_written_through_its_target() {
        let d = tempfile::tempdir().unwrap();
        let target = d.path().join("real.txt");
        std::fs::write(&target, "old").unwrap();
        let link = d.path().join("link.txt");
        std::os::unix::fs::symlink("real.txt", &link).unwrap();
        let mut f = OutputFile::create(&link).unwrap();
        f.write_all(b"new").unwrap();
        f.commit().unwrap();
        assert!(std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "new");
    }

    #[test]
    fn keeps_the_permissions_of_the_file_replaced() {
        use std::os::unix::fs::PermissionsExt as _;
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("out.txt");
        std::fs::write(&p, "old").unwrap();
        std::fs::set_permissions(&p, Permissions::from_mode(0o640)).unwrap();
        let mut f = OutputFile::create(&p).unwrap();
        f.write_all(b"new").unwrap();
        f.commit().unwrap();
        let mode = std::fs::metadata(&p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o640);
    }

    #[test]
    fn dev_null_stays_a_device_and_dev_full_reports_no_space() {
        use std::os::unix::fs::FileTypeExt as _;
        let mut f = OutputFile::create(Path::new("/dev/null")).unwrap();
        f.write_all(b"x").unwrap();
        f.commit().unwrap();
        assert!(std::fs::metadata("/dev/null")
            .unwrap()
            .file_type()
            .is_char_device());
        if Path::new("/dev/full").exists() {
            let mut f = OutputFile::create(Path::new("/dev/full")).unwrap();
            let e = f.write_all(b"x").unwrap_err();
            assert_eq!(e.raw_os_error(), Some(28), "ENOSPC: {e}");
            assert!(std::fs::metadata("/dev/full")
                .unwrap()
                .file_type()
                .is_char_device());
        }
    }

    #[test]
    fn a_directory_is_refused() {
        let d = tempfile::tempdir().unwrap();
        let e = OutputFile::create(d.path()).err().unwrap();
        assert!(e.to_string().contains("is a directory"), "{e}");
    }

    #[test]
    fn partial_commit_names_what_was_written() {
        let d = tempfile::tempdir().unwrap();
        let a = d.path().join("a.txt");
        let sub = d.path().join("sub");
        std::fs::create_dir(&sub).unwrap();
        let b = sub.join("b.txt");
        let mut fa = OutputFile::create(&a).unwrap();
        fa.write_all(b"A").unwrap();
        let mut fb = OutputFile::create(&b).unwrap();
        fb.write_all(b"B").unwrap();
        // Make b's rename fail: its directory is replaced by a file.
        std::fs::remove_dir_all(&sub).ok();
        std::fs::write(&sub, "not a dir").unwrap();
        let e = commit_all(vec![fa, fb]).unwrap_err();
        let text = e.to_string();
        assert!(matches!(e, OutputError::Partial { .. }), "{text}");
        assert!(
            text.contains("written: ") && text.contains("a.txt"),
            "{text}"
        );
        assert!(
            text.contains("NOT written") && text.contains("b.txt"),
            "{text}"
        );
        assert_eq!(std::fs::read_to_string(&a).unwrap(), "A");
    }
}
