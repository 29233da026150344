//! Writing results: atomic file output and the CLI's error type.

use std::fmt;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

/// Everything that can stop a command, with a message meant for a person.
#[derive(Debug)]
pub enum CliError {
    /// A message that already says what and where.
    Message(String),
    /// An I/O failure on a named path.
    Io(PathBuf, io::Error),
    /// Writing to standard output failed.
    Stdout(io::Error),
}

impl CliError {
    /// A closed standard output (e.g. piped into `head`).
    pub fn is_broken_pipe(&self) -> bool {
        matches!(self, CliError::Stdout(e) if e.kind() == io::ErrorKind::BrokenPipe)
    }
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CliError::Message(m) => f.write_str(m),
            CliError::Io(p, e) => write!(f, "{}: {e}", p.display()),
            CliError::Stdout(e) => write!(f, "cannot write to standard output: {e}"),
        }
    }
}

impl<E: std::error::Error> From<E> for CliError {
    fn from(e: E) -> Self {
        CliError::Message(e.to_string())
    }
}

/// Writes a file atomically: into a temporary file beside it, renamed over
/// the target only when `write` succeeds. Refuses to overwrite `input`.
pub fn write_atomically(
    target: &Path,
    inputs: &[&Path],
    write: impl FnOnce(&mut dyn Write) -> Result<(), CliError>,
) -> Result<(), CliError> {
    for input in inputs {
        if same_file(target, input) {
            return Err(CliError::Message(format!(
                "refusing to overwrite the input {}: choose another output path with -o",
                input.display()
            )));
        }
    }
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let tmp = tempfile::Builder::new()
        .prefix(".volcomp-")
        .suffix(".tmp")
        .tempfile_in(&dir)
        .map_err(|e| CliError::Io(dir.clone(), e))?;
    let mut w = io::BufWriter::with_capacity(1 << 16, tmp);
    write(&mut w)?;
    let tmp = w
        .into_inner()
        .map_err(|e| CliError::Io(target.to_path_buf(), e.into_error()))?;
    // The temporary file is private (0600); give the result the permissions
    // of the input it was made from, or of an ordinary new file.
    let permissions = inputs
        .iter()
        .find_map(|p| std::fs::metadata(p).ok().map(|m| m.permissions()))
        .or_else(|| {
            std::fs::metadata(&dir)
                .ok()
                .map(|m| m.permissions())
                .map(|mut p| {
                    use std::os::unix::fs::PermissionsExt as _;
                    p.set_mode(0o644);
                    p
                })
        });
    if let Some(p) = permissions {
        tmp.as_file()
            .set_permissions(p)
            .map_err(|e| CliError::Io(target.to_path_buf(), e))?;
    }
    tmp.persist(target)
        .map_err(|e| CliError::Io(target.to_path_buf(), e.error))?;
    Ok(())
}

fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    }
}
