//! Several outputs written to temporaries and put in place together
//! ([`Staged`]), and the record of what a run declared and wrote
//! ([`Ledger`]), so that an error can say which outputs were written
//! before it and which were left as they were.

use super::{commit_all, OutputError, OutputFile, OutputPlan, PlanError};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

/// Why a staged output could not be written.
#[derive(Debug)]
pub enum StageError<E> {
    /// Writing the output failed (the first write error, with its path).
    Io(PathBuf, io::Error),
    /// The output could not be created.
    Output(OutputError),
    /// The caller's writer failed otherwise.
    Writer(E),
}

/// Outputs written to temporaries and put in place together by
/// [`Staged::commit`]: a failure anywhere leaves every destination as it was
/// (or, if a rename fails half-way, says which were written).
#[derive(Default)]
pub struct Staged {
    files: Vec<OutputFile>,
}

impl Staged {
    /// Nothing staged yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Writes one output (`-` is standard output) into its temporary,
    /// buffered; a write error on it is reported with its path, whatever
    /// `write` made of it.
    pub fn write<E>(
        &mut self,
        target: &Path,
        write: impl FnOnce(&mut dyn Write) -> Result<(), E>,
    ) -> Result<(), StageError<E>> {
        let file = OutputFile::create(target).map_err(StageError::Output)?;
        let tracking = Tracking {
            inner: file,
            failed: None,
        };
        let mut w = BufWriter::with_capacity(1 << 16, tracking);
        let result = write(&mut w);
        let flushed = w.flush();
        let tracked = w.into_inner().map_err(|e| e.into_error());
        let first_failure = match &tracked {
            Ok(t) => t.failed.as_ref().map(copy),
            Err(e) => Some(copy(e)),
        };
        let io = |e| StageError::Io(target.to_path_buf(), e);
        if let Some(e) = first_failure {
            return Err(io(e));
        }
        result.map_err(StageError::Writer)?;
        flushed.map_err(io)?;
        self.files.push(tracked.map_err(io)?.inner);
        Ok(())
    }

    /// Puts every staged output in place, recording in `ledger` what was
    /// written.
    pub fn commit(self, ledger: &Ledger) -> Result<(), OutputError> {
        let paths: Vec<PathBuf> = self
            .files
            .iter()
            .map(|f| f.path().to_path_buf())
            .filter(|p| p.as_os_str() != "-")
            .collect();
        match commit_all(self.files) {
            Ok(()) => {
                lock(&ledger.written).extend(paths);
                Ok(())
            }
            Err(e) => {
                if let OutputError::Partial { written, .. } = &e {
                    lock(&ledger.written).extend(written.iter().cloned());
                }
                Err(e)
            }
        }
    }
}

fn copy(e: &io::Error) -> io::Error {
    io::Error::new(e.kind(), e.to_string())
}

/// Remembers the first write error of an output.
struct Tracking {
    inner: OutputFile,
    failed: Option<io::Error>,
}

impl Tracking {
    fn note<T>(&mut self, r: io::Result<T>) -> io::Result<T> {
        if let (Err(e), None) = (&r, &self.failed) {
            self.failed = Some(copy(e));
        }
        r
    }
}

impl Write for Tracking {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let r = self.inner.write(buf);
        self.note(r)
    }

    fn flush(&mut self) -> io::Result<()> {
        let r = self.inner.flush();
        self.note(r)
    }
}

/// The outputs a run declared (in checked [`OutputPlan`]s) and those put
/// in place so far.
#[derive(Default)]
pub struct Ledger {
    planned: Mutex<Vec<PathBuf>>,
    written: Mutex<Vec<PathBuf>>,
}

fn lock(m: &Mutex<Vec<PathBuf>>) -> MutexGuard<'_, Vec<PathBuf>> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl Ledger {
    /// An empty record (usable as a `static`).
    pub const fn new() -> Self {
        Ledger {
            planned: Mutex::new(Vec::new()),
            written: Mutex::new(Vec::new()),
        }
    }

    /// Refuses a plan whose outputs name an input or each other, and
    /// records its outputs. Call it before any work: nothing has been
    /// written when it fails.
    pub fn check(&self, plan: &OutputPlan) -> Result<(), PlanError> {
        plan.check()?;
        let mut planned = lock(&self.planned);
        for r in plan.outputs() {
            if r.path.as_os_str() != "-" && !planned.contains(&r.path) {
                planned.push(r.path.clone());
            }
        }
        Ok(())
    }

    /// After a failure: which declared outputs were written before it and
    /// which were not (left as they were), if any were written.
    pub fn note(&self) -> Option<String> {
        let written = lock(&self.written);
        if written.is_empty() {
            return None;
        }
        let planned = lock(&self.planned);
        let show = |v: &[&PathBuf]| {
            if v.is_empty() {
                "none".to_string()
            } else {
                let v: Vec<String> = v.iter().map(|p| p.display().to_string()).collect();
                v.join(", ")
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
}
