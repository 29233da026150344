//! Writing results through the library's output layer
//! (`volcomp_core::io::output`), and the CLI's error type.
//!
//! Every command first declares its inputs and outputs in an
//! [`OutputPlan`] and checks it ([`check`]) before any work; then it
//! writes each output with [`write_atomically`] (one output) or stages
//! several in [`Staged`] and puts them in place together.

use std::fmt;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
pub use volcomp_core::io::output::OutputPlan;
use volcomp_core::io::output::{commit_all, OutputError, OutputFile};

/// Everything that can stop a command, with a message meant for a person.
#[derive(Debug)]
pub enum CliError {
    /// A message that already says what and where.
    Message(String),
    /// An I/O failure on a named path.
    Io(PathBuf, io::Error),
    /// Writing to standard output failed.
    Stdout(io::Error),
    /// An output could not be written (or only some were).
    Output(OutputError),
}

impl CliError {
    /// A closed standard output (e.g. piped into `head`).
    pub fn is_broken_pipe(&self) -> bool {
        let pipe = |e: &io::Error| e.kind() == io::ErrorKind::BrokenPipe;
        match self {
            CliError::Stdout(e) => pipe(e),
            CliError::Io(p, e) => p.as_os_str() == "-" && pipe(e),
            CliError::Output(o) => o.is_stdout() && o.io_error().is_some_and(pipe),
            CliError::Message(_) => false,
        }
    }
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CliError::Message(m) => f.write_str(m),
            CliError::Io(p, e) if p.as_os_str() == "-" => {
                write!(f, "cannot write to standard output: {e}")
            }
            CliError::Io(p, e) => write!(f, "{}: {e}", p.display()),
            CliError::Stdout(e) => write!(f, "cannot write to standard output: {e}"),
            CliError::Output(e) => write!(f, "{e}"),
        }
    }
}

impl<E: std::error::Error> From<E> for CliError {
    fn from(e: E) -> Self {
        CliError::Message(e.to_string())
    }
}

/// The outputs the command declared, and those put in place so far: if
/// the command fails after some were written, `main` says which.
static PLANNED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
static WRITTEN: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn lock(m: &'static Mutex<Vec<PathBuf>>) -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// Refuses a plan whose outputs name an input or each other. Call it
/// before any work: nothing has been written when it fails.
pub fn check(plan: &OutputPlan) -> Result<(), CliError> {
    plan.check().map_err(|e| CliError::Message(e.to_string()))?;
    let mut planned = lock(&PLANNED);
    for r in plan.outputs() {
        if r.path.as_os_str() != "-" && !planned.contains(&r.path) {
            planned.push(r.path.clone());
        }
    }
    Ok(())
}

/// After a failure: which declared outputs were written before it and
/// which were not (left as they were), if any were written.
pub fn outputs_note() -> Option<String> {
    let written = lock(&WRITTEN);
    if written.is_empty() {
        return None;
    }
    let planned = lock(&PLANNED);
    let show = |v: &[&PathBuf]| {
        if v.is_empty() {
            "none".to_string()
        } else {
            v.iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        }
    };
    let done: Vec<&PathBuf> = written.iter().collect();
    let not: Vec<&PathBuf> = planned.iter().filter(|p| !written.contains(p)).collect();
    Some(format!(
        "  written before the error: {}\n  NOT written (left as they were): {}",
        show(&done),
        show(&not)
    ))
}

/// Outputs written to temporaries and put in place together by
/// [`Staged::commit`]: a failure anywhere leaves every destination as it was
/// (or, if a rename fails half-way, says which were written).
#[derive(Default)]
pub struct Staged {
    files: Vec<OutputFile>,
}

impl Staged {
    pub fn new() -> Self {
        Self::default()
    }

    /// Writes one output (`-` is standard output) into its temporary.
    pub fn write(
        &mut self,
        target: &Path,
        write: impl FnOnce(&mut dyn Write) -> Result<(), CliError>,
    ) -> Result<(), CliError> {
        let file = OutputFile::create(target).map_err(CliError::Output)?;
        let mut w = BufWriter::with_capacity(
            1 << 16,
            Tracking {
                inner: file,
                failed: None,
            },
        );
        let result = write(&mut w);
        let flushed = w.flush();
        let tracked = w.into_inner().map_err(|e| e.into_error());
        // A write error on this output is reported with its path, whatever
        // the writer made of it.
        let first_failure = match &tracked {
            Ok(t) => t
                .failed
                .as_ref()
                .map(|e| io::Error::new(e.kind(), e.to_string())),
            Err(e) => Some(io::Error::new(e.kind(), e.to_string())),
        };
        if let Some(e) = first_failure {
            return Err(CliError::Io(target.to_path_buf(), e));
        }
        result?;
        flushed.map_err(|e| CliError::Io(target.to_path_buf(), e))?;
        let file = tracked
            .map_err(|e| CliError::Io(target.to_path_buf(), e))?
            .inner;
        self.files.push(file);
        Ok(())
    }

    /// Puts every staged output in place.
    pub fn commit(self) -> Result<(), CliError> {
        let paths: Vec<PathBuf> = self
            .files
            .iter()
            .map(|f| f.path().to_path_buf())
            .filter(|p| p.as_os_str() != "-")
            .collect();
        match commit_all(self.files) {
            Ok(()) => {
                lock(&WRITTEN).extend(paths);
                Ok(())
            }
            Err(e) => {
                if let OutputError::Partial { written, .. } = &e {
                    lock(&WRITTEN).extend(written.iter().cloned());
                }
                Err(CliError::Output(e))
            }
        }
    }
}

/// Remembers the first write error of an output.
struct Tracking {
    inner: OutputFile,
    failed: Option<io::Error>,
}

impl Write for Tracking {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.inner.write(buf).inspect_err(|e| {
            if self.failed.is_none() {
                self.failed = Some(io::Error::new(e.kind(), e.to_string()));
            }
        })
    }

    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush().inspect_err(|e| {
            if self.failed.is_none() {
                self.failed = Some(io::Error::new(e.kind(), e.to_string()));
            }
        })
    }
}

/// Writes one output completely or not at all (see `volcomp_core::io::output`);
/// refuses to write over any of `inputs`. Commands with several outputs
/// check an [`OutputPlan`] first and use [`Staged`].
pub fn write_atomically(
    target: &Path,
    inputs: &[&Path],
    write: impl FnOnce(&mut dyn Write) -> Result<(), CliError>,
) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    for i in inputs {
        plan.input("input", i);
    }
    plan.output("output", target);
    check(&plan)?;
    let mut staged = Staged::new();
    staged.write(target, write)?;
    staged.commit()
}
