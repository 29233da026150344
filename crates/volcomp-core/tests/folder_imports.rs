//! The library's folders depend on each other one way (docs/architecture.md,
//! "Dependency order"): this test reads every `crate::…` path in `src/`,
//! maps each file to its top-level folder or file (`src/io/…` → `io`,
//! `src/error.rs` → `error`; names re-exported at the crate root to the
//! folder that defines them) and checks every edge against [`ORDER`].
//!
//! Test modules are left out: a test may use any folder (the examples).
//! An edge from a folder to one *later* in the order goes up against it
//! and can close an import circle. The edges that still do are listed in
//! [`KNOWN_UPWARD`] with the files that make them: a new one fails the
//! test, and so does a listed one that is gone (take it off the list).
//! A circle inside one folder or file is fine.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The library's top-level folders and files, lowest first: each may use
/// the ones before it, never one after it. `lib` and `prelude` only
/// re-export.
const ORDER: &[&str] = &[
    "limits",
    "rng",
    "linalg",
    "geometry",
    "progress",
    "error",
    "text",
    "model",
    "io",
    "identify",
    "compensate",
    "simulate",
    "plan",
    "surface",
    "report",
    "ballbar",
    "example",
    "request",
];

/// Edges that still go up against [`ORDER`], each with why it is left
/// (to be removed by moving the shared type down; docs/architecture.md).
const KNOWN_UPWARD: &[(&str, &str)] = &[];

/// Every `.rs` file under `dir`.
fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("src/ is readable") {
        let path = entry.expect("a directory entry").path();
        if path.is_dir() {
            files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// `text` without `//` comments (doc comments name paths in prose) and
/// without its top-level test modules (tests may use any folder). A
/// top-level module ends at the first line that is `}` alone (rustfmt).
fn code(text: &str) -> String {
    let mut out = Vec::new();
    let mut lines = text.lines().peekable();
    while let Some(l) = lines.next() {
        if l == "#[cfg(test)]" && lines.peek().is_some_and(|n| n.starts_with("mod ")) {
            for inner in lines.by_ref() {
                if inner == "}" {
                    break;
                }
            }
            continue;
        }
        out.push(match l.find("//") {
            Some(i) => &l[..i],
            None => l,
        });
    }
    out.join("\n")
}

/// The first identifier of `text`.
fn ident(text: &str) -> Option<&str> {
    let t = text.trim_start();
    let end = t
        .find(|c: char| !(c.is_alphanumeric() || c == '_'))
        .unwrap_or(t.len());
    (end > 0).then(|| &t[..end])
}

/// The first path segment after every `crate::` of `code` (each segment
/// of a `crate::{a::…, b::…}` group).
fn crate_paths(code: &str) -> Vec<String> {
    let mut out = Vec::new();
    for (i, _) in code.match_indices("crate::") {
        if i > 0 && code[..i].ends_with(|c: char| c.is_alphanumeric() || c == '_') {
            continue; // `volcomp_crate::` or the like
        }
        let rest = &code[i + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            // The top-level items of the group.
            let (mut depth, mut start) = (0usize, 0usize);
            for (j, c) in group.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => {
                        out.extend(ident(&group[start..j]).map(str::to_string));
                        break;
                    }
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        out.extend(ident(&group[start..j]).map(str::to_string));
                        start = j + 1;
                    }
                    _ => {}
                }
            }
        } else if let Some(id) = ident(rest) {
            out.push(id.to_string());
        }
    }
    out
}

/// Names the crate root re-exports (`pub use model::ErrorModel;`), with
/// the folder that defines them.
fn root_names(lib: &str) -> BTreeMap<String, String> {
    let mut names = BTreeMap::new();
    for stmt in code(lib).split(';') {
        let Some(rest) = stmt.trim().strip_prefix("pub use ") else {
            continue;
        };
        let Some(unit) = ident(rest) else { continue };
        let items = match (rest.find('{'), rest.rfind('}')) {
            (Some(a), Some(b)) => rest[a + 1..b].split(',').collect::<Vec<_>>(),
            _ => vec![rest.rsplit("::").next().unwrap_or("")],
        };
        for item in items {
            let name = item.rsplit(" as ").next().unwrap_or(item);
            if let Some(n) = ident(name) {
                names.insert(n.to_string(), unit.to_string());
            }
        }
    }
    names
}

/// The files of test modules declared in a file of their own
/// (`#[cfg(test)] mod tests;`), with every file under them.
fn test_files(all: &[PathBuf]) -> Vec<PathBuf> {
    let mut tests = Vec::new();
    for path in all {
        let text = std::fs::read_to_string(path).expect("a source file");
        let mut lines = text.lines().peekable();
        while let Some(l) = lines.next() {
            let Some(name) = lines
                .peek()
                .filter(|_| l == "#[cfg(test)]")
                .and_then(|n| n.strip_prefix("mod "))
                .and_then(|n| n.strip_suffix(';'))
            else {
                continue;
            };
            // `a/mod.rs` declares `a/name.rs`; `a/b.rs` declares `a/b/name.rs`.
            let dir = match path.file_name().and_then(|f| f.to_str()) {
                Some("mod.rs" | "lib.rs") => path.parent().expect("a folder").to_path_buf(),
                _ => path.with_extension(""),
            };
            for candidate in [dir.join(format!("{name}.rs")), dir.join(name)] {
                tests.extend(all.iter().filter(|p| p.starts_with(&candidate)).cloned());
            }
        }
    }
    tests
}

/// Every edge between top-level folders, with the files that make it.
fn edges(src: &Path) -> BTreeMap<(String, String), BTreeSet<String>> {
    let lib = std::fs::read_to_string(src.join("lib.rs")).expect("lib.rs");
    let roots = root_names(&lib);
    let mut all = Vec::new();
    files(src, &mut all);
    let tests = test_files(&all);
    let mut edges: BTreeMap<(String, String), BTreeSet<String>> = BTreeMap::new();
    for path in all.iter().filter(|p| !tests.contains(*p)) {
        let rel = path.strip_prefix(src).expect("under src");
        let first = rel.components().next().expect("a component");
        let from = first.as_os_str().to_string_lossy();
        let from = from.trim_end_matches(".rs").to_string();
        if from == "lib" || from == "prelude" {
            continue;
        }
        let text = std::fs::read_to_string(path).expect("a source file");
        for segment in crate_paths(&code(&text)) {
            let to = roots.get(&segment).cloned().unwrap_or(segment);
            if to != from && ORDER.contains(&to.as_str()) {
                edges
                    .entry((from.clone(), to))
                    .or_default()
                    .insert(rel.display().to_string());
            }
        }
    }
    edges
}

#[test]
fn folders_depend_on_each_other_one_way() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    // Every top-level folder and file has its place in the order.
    for entry in std::fs::read_dir(&src).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().to_string();
        let unit = name.trim_end_matches(".rs");
        assert!(
            ORDER.contains(&unit) || unit == "lib" || unit == "prelude",
            "src/{name} has no place in ORDER (folder_imports.rs) nor in docs/architecture.md's dependency order: add it"
        );
    }
    let position = |u: &str| ORDER.iter().position(|o| *o == u).unwrap();
    let edges = edges(&src);
    assert!(
        edges.len() > 30,
        "the scan found too few edges ({}): is it reading src/?",
        edges.len()
    );
    let upward: BTreeMap<_, _> = edges
        .iter()
        .filter(|((from, to), _)| position(from) < position(to))
        .collect();
    let mut problems = Vec::new();
    for ((from, to), files) in &upward {
        if !KNOWN_UPWARD.contains(&(from.as_str(), to.as_str())) {
            problems.push(format!(
                "{from} uses {to}, which comes after it in the dependency order ({}): move the shared item down, or use it from a later folder",
                files.iter().cloned().collect::<Vec<_>>().join(", ")
            ));
        }
    }
    for (from, to) in KNOWN_UPWARD {
        if !upward.contains_key(&(from.to_string(), to.to_string())) {
            problems.push(format!(
                "{from} no longer uses {to}: take ({from:?}, {to:?}) off KNOWN_UPWARD"
            ));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn the_scan_reads_groups_and_root_names() {
    let code = code("use crate::{error::ModelError, io::table::{A, B}};\nlet x = crate::model::f(); // crate::report\n#[cfg(test)]\nmod tests {\n    use crate::example;\n}\nuse crate::plan;\n");
    assert_eq!(crate_paths(&code), ["error", "io", "model", "plan"]);
    let roots = root_names("pub use compensate::{\n    MachineSetup, Segmentation,\n};\npub use model::axis_table::AxisTableMap;\npub mod io;");
    assert_eq!(roots["MachineSetup"], "compensate");
    assert_eq!(roots["Segmentation"], "compensate");
    assert_eq!(roots["AxisTableMap"], "model");
}
