//! The plan of a command's inputs and outputs, checked before any work.
//!
//! Every output is compared with every input and with every other output.
//! Two names are the same file when they reach the same inode (device and
//! inode number: this sees through symbolic links, `..` and hard links); a
//! name that does not exist yet is compared by its canonical path (the
//! longest existing ancestor canonicalised, the rest normalised), which also
//! catches two outputs that would both create the same new file.
//!
//! Special files (devices, FIFOs, sockets) are not compared: writing two
//! outputs to `/dev/null` is legitimate, and nothing is replaced there.
//! Standard input and output (`-`) are compared by what they are
//! redirected from and to: `- < part.ngc` and `-o part.ngc`, or `-o - >>
//! part.ngc` with `part.ngc` as an input, are the same file.
//!
//! Files are also read that no option names: the tables a model TOML
//! names, the set-up's `var_file`, subroutine files found while the
//! program runs, the files named inside a controller's INI or `.CMA`.
//! Every file is read through `volcomp_geom::inputs`, which records it;
//! [`OutputPlan::check`] compares the outputs with every file recorded so
//! far, and the output files compare their destination with every file
//! recorded by then just before anything is put in place
//! (`super::file::commit_all`), so a file read half-way through the work
//! is protected too.

use std::fmt;
use std::path::{Component, Path, PathBuf};
use volcomp_geom::inputs::{self, FileId};

pub use crate::error::domain::{PlanError, Role};

/// The inputs and outputs of one command.
#[derive(Debug, Clone, Default)]
pub struct OutputPlan {
    inputs: Vec<Role>,
    outputs: Vec<Role>,
}

impl fmt::Display for PlanError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PlanError::OverwritesInput { output, input } => {
                write!(
                    f,
                    "refusing to write {} to {}: it is the same file as the input {} ({}); nothing was written: choose another output path",
                    output.flag,
                    shown_path(&output.path),
                    input.flag,
                    shown_path(&input.path)
                )
            }
            PlanError::OverwritesRead { output, read } => write!(
                f,
                "refusing to write {} to {}: it is {} ({}), which this command read; nothing was written: choose another output path",
                output.flag,
                shown_path(&output.path),
                read.role,
                shown_path(&read.path)
            ),
            PlanError::SameOutput { first, second } if first.path == Path::new("-") => write!(
                f,
                "{} and {} both write to standard output (-): send one of them to a file",
                first.flag, second.flag
            ),
            PlanError::SameOutput { first, second } => write!(
                f,
                "{} ({}) and {} ({}) name the same file, so one would replace the other: choose different paths",
                first.flag,
                shown_path(&first.path),
                second.flag,
                shown_path(&second.path)
            ),
        }
    }
}

impl std::error::Error for PlanError {}

/// What a name refers to, for comparison.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Identity {
    /// `-`: the standard stream.
    Stream,
    /// An existing regular file or directory.
    Inode(u64, u64),
    /// A file that does not exist yet, by canonical path.
    Absent(PathBuf),
    /// A device, FIFO or socket: never a conflict.
    Special,
}

fn identity(path: &Path) -> Identity {
    if path.as_os_str() == "-" {
        return Identity::Stream;
    }
    match std::fs::metadata(path) {
        Ok(m) => match FileId::of(&m) {
            Some(id) => Identity::Inode(id.dev, id.ino),
            None => Identity::Special,
        },
        Err(_) => Identity::Absent(canonical_absent(path)),
    }
}

/// What an input reads: `-` is what standard input is redirected from.
fn input_identity(path: &Path) -> Identity {
    match (path.as_os_str() == "-", inputs::stdin_id()) {
        (true, Some(id)) => Identity::Inode(id.dev, id.ino),
        _ => identity(path),
    }
}

/// The file an output would replace, if it exists and is a regular file:
/// `-` is what standard output is redirected to.
fn replaced_file(path: &Path, id: &Identity) -> Option<FileId> {
    match id {
        Identity::Stream => inputs::stdout_id(),
        Identity::Inode(dev, ino) => Some(FileId {
            dev: *dev,
            ino: *ino,
        }),
        Identity::Absent(_) | Identity::Special => {
            let _ = path;
            None
        }
    }
}

use crate::io::shown_path;

/// The canonical form of a path that need not exist: a dangling symbolic
/// link is followed to where it points, the longest existing ancestor is
/// canonicalised and the rest normalised (`.` dropped, `..` applied).
pub fn canonical_absent(path: &Path) -> PathBuf {
    let mut path = absolute(path);
    // Follow a dangling link chain (bounded, as the kernel bounds it to 40).
    for _ in 0..40 {
        match std::fs::read_link(&path) {
            Ok(t) => {
                path = match path.parent() {
                    Some(p) if t.is_relative() => p.join(t),
                    _ => t,
                };
            }
            Err(_) => break,
        }
    }
    let path = normalise(&path);
    let mut existing = path.as_path();
    let mut rest = Vec::new();
    loop {
        if let Ok(c) = existing.canonicalize() {
            let mut out = c;
            for r in rest.iter().rev() {
                out.push(r);
            }
            return normalise(&out);
        }
        match (existing.parent(), existing.file_name()) {
            (Some(p), Some(n)) => {
                rest.push(n.to_os_string());
                existing = p;
            }
            _ => return path,
        }
    }
}

fn absolute(path: &Path) -> PathBuf {
    if path.is_absolute() {
        path.to_path_buf()
    } else {
        std::env::current_dir()
            .map(|d| d.join(path))
            .unwrap_or_else(|_| path.to_path_buf())
    }
}

fn normalise(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                out.pop();
            }
            other => out.push(other.as_os_str()),
        }
    }
    out
}

impl OutputPlan {
    /// An empty plan.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds an input read by the command.
    pub fn input(&mut self, flag: impl Into<String>, path: impl AsRef<Path>) -> &mut Self {
        self.inputs.push(Role {
            flag: flag.into(),
            path: path.as_ref().to_path_buf(),
        });
        self
    }

    /// Adds an input if present.
    pub fn input_opt(&mut self, flag: &str, path: Option<impl AsRef<Path>>) -> &mut Self {
        if let Some(p) = path {
            self.input(flag, p);
        }
        self
    }

    /// Adds a map or model file and every file it names (the `tables` of a
    /// 21-component model TOML), all as inputs of `flag`.
    pub fn map_input(&mut self, flag: &str, path: impl AsRef<Path>) -> &mut Self {
        let path = path.as_ref();
        self.input(flag, path);
        let name = crate::io::shown_name(&crate::io::file_name(path));
        for t in referenced_files(path) {
            self.input(format!("{flag} (a table named in {name})"), t);
        }
        self
    }

    /// Adds an output written by the command.
    pub fn output(&mut self, flag: impl Into<String>, path: impl AsRef<Path>) -> &mut Self {
        self.outputs.push(Role {
            flag: flag.into(),
            path: path.as_ref().to_path_buf(),
        });
        self
    }

    /// Adds an output if present.
    pub fn output_opt(&mut self, flag: &str, path: Option<impl AsRef<Path>>) -> &mut Self {
        if let Some(p) = path {
            self.output(flag, p);
        }
        self
    }

    /// The outputs, in the order they were added.
    pub fn outputs(&self) -> &[Role] {
        &self.outputs
    }

    /// Refuses the plan if an output names an input, a file read so far
    /// (`volcomp_geom::inputs`) or another output.
    pub fn check(&self) -> Result<(), PlanError> {
        let inputs: Vec<Identity> = self
            .inputs
            .iter()
            .map(|r| input_identity(&r.path))
            .collect();
        let outputs: Vec<Identity> = self.outputs.iter().map(|r| identity(&r.path)).collect();
        let read = inputs::read_so_far();
        for (i, (out, oid)) in self.outputs.iter().zip(&outputs).enumerate() {
            if *oid == Identity::Special {
                continue;
            }
            let replaced = replaced_file(&out.path, oid);
            for (inp, iid) in self.inputs.iter().zip(&inputs) {
                // Standard input and standard output are different streams
                // unless both are redirected to one file.
                let same = match (replaced, iid) {
                    (Some(f), Identity::Inode(dev, ino)) => f.dev == *dev && f.ino == *ino,
                    _ => *oid != Identity::Stream && oid == iid,
                };
                if same {
                    return Err(PlanError::OverwritesInput {
                        output: out.clone(),
                        input: inp.clone(),
                    });
                }
            }
            if let Some(r) = replaced.and_then(|f| read.iter().find(|r| r.id == f)) {
                return Err(PlanError::OverwritesRead {
                    output: out.clone(),
                    read: Box::new(r.clone()),
                });
            }
            for (other, id2) in self.outputs[..i].iter().zip(&outputs) {
                if oid == id2 {
                    return Err(PlanError::SameOutput {
                        first: other.clone(),
                        second: out.clone(),
                    });
                }
            }
        }
        Ok(())
    }
}

/// The table files a 21-component model TOML names (`tables = "…"` or a
/// list), resolved relative to the TOML; empty for anything else.
pub fn referenced_files(path: &Path) -> Vec<PathBuf> {
    let is_toml = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("toml"));
    if !is_toml {
        return Vec::new();
    }
    // Bounded read; a file that cannot be read is refused later by the
    // model reader with its own message.
    let Ok(text) = inputs::read_to_string(path, "the map") else {
        return Vec::new();
    };
    let Ok(value) = text.parse::<toml::Table>() else {
        return Vec::new();
    };
    let dir = path.parent().unwrap_or(Path::new(""));
    let names: Vec<String> = match value.get("tables") {
        Some(toml::Value::String(s)) => vec![s.clone()],
        Some(toml::Value::Array(a)) => a
            .iter()
            .filter_map(|v| v.as_str().map(str::to_string))
            .collect(),
        _ => Vec::new(),
    };
    names.into_iter().map(|n| dir.join(n)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(inputs: &[&Path], outputs: &[&Path]) -> Result<(), PlanError> {
        let mut p = OutputPlan::new();
        for (k, i) in inputs.iter().enumerate() {
            p.input(format!("in{k}"), i);
        }
        for (k, o) in outputs.iter().enumerate() {
            p.output(format!("out{k}"), o);
        }
        p.check()
    }

    #[test]
    fn same_file_through_symlink_dotdot_and_hard_link() {
        let d = tempfile::tempdir().unwrap();
        let a = d.path().join("a.csv");
        std::fs::write(&a, "x").unwrap();
        std::fs::create_dir(d.path().join("sub")).unwrap();
        std::os::unix::fs::symlink(&a, d.path().join("link.csv")).unwrap();
        std::fs::hard_link(&a, d.path().join("hard.csv")).unwrap();
        for alias in ["link.csv", "hard.csv", "sub/../a.csv", "./a.csv"] {
            let o = d.path().join(alias);
            let e = plan(&[&a], &[&o]).unwrap_err();
            assert!(matches!(e, PlanError::OverwritesInput { .. }), "{alias}");
            assert!(e.to_string().contains("out0") && e.to_string().contains("in0"));
        }
        // A different file is fine.
        plan(&[&a], &[&d.path().join("b.csv")]).unwrap();
    }

    #[test]
    fn two_outputs_creating_one_new_file() {
        let d = tempfile::tempdir().unwrap();
        std::fs::create_dir(d.path().join("sub")).unwrap();
        let x = d.path().join("new.ngc");
        let y = d.path().join("sub/../new.ngc");
        let e = plan(&[], &[&x, &y]).unwrap_err();
        assert!(matches!(e, PlanError::SameOutput { .. }));
        // A dangling link to the other output's (new) path.
        std::os::unix::fs::symlink(&x, d.path().join("dangling")).unwrap();
        assert!(plan(&[], &[&x, &d.path().join("dangling")]).is_err());
    }

    #[test]
    fn special_files_and_streams() {
        let null = Path::new("/dev/null");
        plan(&[null], &[null, null]).unwrap();
        let dash = Path::new("-");
        // Reading stdin and writing stdout is a filter, not a conflict.
        plan(&[dash], &[dash]).unwrap();
        assert!(plan(&[], &[dash, dash]).is_err());
    }

    #[test]
    fn model_tables_are_inputs() {
        let d = tempfile::tempdir().unwrap();
        let toml = d.path().join("model.toml");
        std::fs::write(
            &toml,
            "model = \"kinematic-21\"\ntables = \"model_tables.csv\"\n",
        )
        .unwrap();
        std::fs::write(d.path().join("model_tables.csv"), "x").unwrap();
        let mut p = OutputPlan::new();
        p.map_input("MAP", &toml)
            .output("-o", d.path().join("model_tables.csv"));
        let e = p.check().unwrap_err().to_string();
        assert!(e.contains("model_tables.csv") && e.contains("MAP"), "{e}");
    }
}
