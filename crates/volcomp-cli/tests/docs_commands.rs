//! Every documented command runs as written.
//!
//! The commands of every ```` ```sh ```` (or ```` ```bash ````) block of
//! `README.md` and `docs/*.md` are run, in the order they appear, with the
//! `volcomp` binary under test first on the `PATH`, in a fresh copy of
//! `examples/data/` per document (the example inputs the docs are written
//! against; a user copies that folder and runs the commands there). A
//! command that exits non-zero fails the test, naming the document, the line
//! and the command's standard error.
//!
//! Conventions for documents:
//!
//! * ```` ```sh ```` / ```` ```bash ````: every command is run by `bash -o
//!   pipefail`, one logical line at a time (a trailing `\` continues the
//!   line); `#` comments are the shell's.
//! * `cargo run [--release] [-p volcomp-cli] -- ARGS` runs `volcomp ARGS`;
//!   other `cargo` commands (test, build, install …) are not run here.
//! * Blocks that must not run (INI snippets, output, placeholders) use
//!   ```` ```text ````, ```` ```ini ```` or ```` ```sh-norun ````.
//! * Commands use the files of `examples/data/` (see its README.md) or files
//!   an earlier command of the same document wrote.
//!
//! `examples/data/` itself is checked against its generator
//! (`crates/volcomp-cli/examples/example_data.rs`), byte for byte.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::common;

/// Longest a documented command may take before it counts as hanging.
const COMMAND_LIMIT: Duration = Duration::from_secs(600);

/// One command of a document.
#[derive(Debug, PartialEq)]
struct DocCommand {
    /// 1-based line of the command's first line.
    line: usize,
    /// The command with continuation lines joined.
    text: String,
}

/// Whether a fence's info string marks a block whose commands are run.
fn runnable(info: &str) -> bool {
    matches!(
        info.split_whitespace().next().unwrap_or(""),
        "sh" | "bash" | "shell"
    )
}

/// The commands of the runnable blocks of a Markdown text.
fn extract(markdown: &str) -> Vec<DocCommand> {
    let mut out = Vec::new();
    let mut fence: Option<(String, bool)> = None;
    let mut pending: Option<DocCommand> = None;
    for (i, raw) in markdown.lines().enumerate() {
        let trimmed = raw.trim_start();
        if let Some(rest) = trimmed.strip_prefix("```") {
            match &fence {
                None => fence = Some(("```".into(), runnable(rest.trim()))),
                Some(_) if rest.trim().is_empty() => {
                    if let Some(p) = pending.take() {
                        out.push(p);
                    }
                    fence = None;
                }
                Some(_) => {}
            }
            continue;
        }
        let Some((_, true)) = &fence else { continue };
        let (body, continues) = match raw.trim_end().strip_suffix('\\') {
            Some(b) => (b, true),
            None => (raw.trim_end(), false),
        };
        match &mut pending {
            Some(p) => {
                p.text.push(' ');
                p.text.push_str(body.trim());
            }
            None => {
                let t = body.trim();
                if t.is_empty() || t.starts_with('#') {
                    continue;
                }
                pending = Some(DocCommand {
                    line: i + 1,
                    text: t.to_string(),
                });
            }
        }
        if !continues {
            if let Some(p) = pending.take() {
                out.push(p);
            }
        }
    }
    out
}

/// What to do with a documented command.
#[derive(Debug, PartialEq)]
enum Plan {
    /// Run this shell text.
    Run(String),
    /// Not run here (why).
    Skip(&'static str),
}

fn plan(command: &str) -> Plan {
    let words: Vec<&str> = command.split_whitespace().collect();
    if words.first() != Some(&"cargo") {
        return Plan::Run(command.to_string());
    }
    if words.get(1) == Some(&"run") {
        return Plan::Run(match command.split_once(" -- ") {
            Some((_, rest)) => format!("volcomp {}", rest.trim()),
            None => "volcomp".into(),
        });
    }
    Plan::Skip("cargo command (build and test tooling)")
}

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn documents(root: &Path) -> Vec<PathBuf> {
    let mut docs = vec![root.join("README.md")];
    let mut more: Vec<PathBuf> = std::fs::read_dir(root.join("docs"))
        .expect("docs/ exists")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().and_then(|e| e.to_str()) == Some("md"))
        .collect();
    more.sort();
    docs.extend(more);
    docs
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let target = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &target);
        } else {
            std::fs::copy(e.path(), &target).unwrap();
        }
    }
}

/// Runs `text` with bash in `dir`; Err(stderr) on failure.
fn run_shell(text: &str, dir: &Path, path_env: &str) -> Result<(), String> {
    let mut child = Command::new("bash")
        .arg("-o")
        .arg("pipefail")
        .arg("-c")
        .arg(text)
        .current_dir(dir)
        .env("PATH", path_env)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot run bash: {e}"))?;
    // Drain stderr on a thread so a chatty command cannot block on a full pipe.
    let mut stderr = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = std::io::Read::read_to_string(&mut stderr, &mut s);
        s
    });
    let start = Instant::now();
    let status = loop {
        match child.try_wait() {
            Ok(Some(s)) => break s,
            Ok(None) if start.elapsed() > COMMAND_LIMIT => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(format!(
                    "did not finish within {} s",
                    COMMAND_LIMIT.as_secs()
                ));
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(20)),
            Err(e) => return Err(format!("cannot wait for bash: {e}")),
        }
    };
    let err = reader.join().unwrap_or_default();
    if status.success() {
        Ok(())
    } else {
        Err(format!("{status}\n{err}"))
    }
}

#[test]
fn every_documented_command_runs_as_written() {
    let root = workspace_root();
    let data = root.join("examples/data");
    assert!(data.is_dir(), "no example data at {}", data.display());
    // `volcomp` on the PATH is the binary under test.
    let bin_dir = common::tempdir("docs-bin");
    std::os::unix::fs::symlink(env!("CARGO_BIN_EXE_volcomp"), bin_dir.join("volcomp")).unwrap();
    let path_env = format!(
        "{}:{}",
        bin_dir.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut failures = Vec::new();
    let (mut ran, mut skipped) = (0, 0);
    for doc in documents(&root) {
        let name = doc
            .strip_prefix(&root)
            .unwrap_or(&doc)
            .display()
            .to_string();
        let text = std::fs::read_to_string(&doc).unwrap();
        let commands = extract(&text);
        if commands.is_empty() {
            continue;
        }
        let dir = common::tempdir(&format!("docs-{}", name.replace(['/', '.'], "-")));
        copy_dir(&data, &dir);
        for c in commands {
            match plan(&c.text) {
                Plan::Skip(why) => {
                    println!("{name}:{}: skipped ({why}): {}", c.line, c.text);
                    skipped += 1;
                }
                Plan::Run(shell) => {
                    ran += 1;
                    match run_shell(&shell, &dir, &path_env) {
                        Ok(()) => println!("{name}:{}: ok: {}", c.line, c.text),
                        Err(e) => failures.push(format!(
                            "{name}:{}: `{}` failed (run in {}): {e}",
                            c.line,
                            c.text,
                            dir.display()
                        )),
                    }
                }
            }
        }
    }
    println!(
        "{ran} documented commands run, {skipped} skipped, {} failed",
        failures.len()
    );
    assert!(failures.is_empty(), "\n{}\n", failures.join("\n\n"));
    // The docs hold dozens of commands; finding few means the extraction broke.
    assert!(ran >= 30, "only {ran} documented commands found");
}

#[test]
fn the_example_data_is_what_its_generator_writes() {
    let data = workspace_root().join("examples/data");
    for (name, text) in crate::example_data::files() {
        let path = data.join(&name);
        let committed =
            std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(
            committed == text,
            "{} differs from what crates/volcomp-cli/examples/example_data.rs writes: run `cargo run -p volcomp-cli --example example_data -- examples/data`",
            path.display()
        );
    }
}

#[test]
fn a_failing_command_is_reported_with_its_stderr() {
    let dir = common::tempdir("docs-failing");
    let bin_dir = common::tempdir("docs-failing-bin");
    std::os::unix::fs::symlink(env!("CARGO_BIN_EXE_volcomp"), bin_dir.join("volcomp")).unwrap();
    let path_env = format!("{}:/usr/bin:/bin", bin_dir.display());
    let err = run_shell("volcomp map iso230-2 no-such-runs.csv", &dir, &path_env).unwrap_err();
    assert!(err.contains("no-such-runs.csv"), "{err}");
    // A pipe fails when its first command fails (pipefail).
    assert!(run_shell(
        "volcomp map iso230-2 no-such-runs.csv | cat",
        &dir,
        &path_env
    )
    .is_err());
    assert!(run_shell("volcomp --version | cat", &dir, &path_env).is_ok());
}

#[test]
fn extraction_joins_continuations_and_skips_comments_and_other_blocks() {
    let md = "intro\n```sh\n# a comment\nvolcomp a \\\n    --b c\n\nvolcomp d # trailing\n```\n\
              ```text\nvolcomp never\n```\n```sh-norun\nvolcomp never\n```\n```bash\ncargo test --workspace\n```\n";
    let got = extract(md);
    assert_eq!(
        got,
        vec![
            DocCommand {
                line: 4,
                text: "volcomp a --b c".into()
            },
            DocCommand {
                line: 7,
                text: "volcomp d # trailing".into()
            },
            DocCommand {
                line: 16,
                text: "cargo test --workspace".into()
            },
        ]
    );
    assert_eq!(
        plan("cargo run --release -- demo --out-dir x"),
        Plan::Run("volcomp demo --out-dir x".into())
    );
    assert_eq!(plan("cargo run --release"), Plan::Run("volcomp".into()));
    assert!(matches!(plan("cargo test --workspace"), Plan::Skip(_)));
    assert_eq!(
        plan("volcomp moves part.ngc"),
        Plan::Run("volcomp moves part.ngc".into())
    );
}
