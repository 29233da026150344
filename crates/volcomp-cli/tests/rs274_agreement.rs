//! `volcomp moves` against LinuxCNC's stand-alone interpreter `rs274`, motion
//! by motion.
//!
//! Every program of the bundled corpus (`tests/corpus/` at the workspace
//! root, see its `SOURCES.md`) and every fixture under `tests/fixtures/rs274/`
//! is run through both interpreters with the same machine set-up:
//!
//! * a volcomp setup TOML (work offsets G54 … G59.3, tool lengths 1 … 99,
//!   G28/G30 reference points, all in mm), and
//! * the equivalent rs274 tool table and parameter (var) file, both in
//!   **inches**, as the stand-alone rs274 reads them.
//!
//! Every set-up value is a whole number of hundredths of an inch, so it is
//! exact with four decimals in both inches and millimetres: rs274 then prints
//! the offsets it applies without rounding.
//!
//! rs274 prints each motion in program units and in the current coordinate
//! system. The LinuxCNC canonical layer turns that into machine coordinates
//! by adding the offsets it was last given (`SET_G5X_OFFSET`,
//! `SET_G92_OFFSET`, `USE_TOOL_LENGTH_OFFSET`, each printed in the units in
//! effect when it was called); this test does the same:
//! `q = printed + g5x + g92 + tool length offset`, converted to mm, which is
//! the axis frame (machine coordinates, docs/design.md,
//! "Frames") that `volcomp moves` prints.
//!
//! Tolerance per axis: rs274 prints four decimals, so a printed number is off
//! by at most 0.5e-4 program units. The tolerance is 0.6e-4 program units
//! (converted to mm) for the motion's own coordinate, plus the same for every
//! non-zero offset component that entered the sum (each was rounded when it
//! was printed), plus 1e-6 mm for volcomp's six printed decimals.
//!
//! Known rs274 rejections are checked explicitly: the fixture
//! `tests/fixtures/k0/helical_k0.nc` (`K0` on G17 helical arcs, as FreeCAD
//! writes them) and the corpus file BOTTLE.NC (absolute arc centres). Both
//! are also compared in full against rs274 runs on a fixed copy (K0 words
//! removed, resp. `G90.1` prepended).
//!
//! The set-up: G54 … G59.3 offsets are distinct and non-zero, tool n is
//! (16 + n) · 2.54 mm long, G28 and G30 are distinct points, the machine
//! starts at 0, 0, 0 (where rs274 starts).
//!
//! What this test works around in rs274 (LinuxCNC 2.9):
//!
//! * it keeps its tool data in a memory-mapped file `$HOME/.tool.mmap`;
//!   concurrent runs sharing it die with SIGBUS, so each run gets its own
//!   HOME (and every run gets a fresh var file, which rs274 rewrites);
//! * it does not convert an active tool length offset when G20/G21 switch
//!   the units (the offset keeps its number, so later positions are off), so
//!   the fixtures never switch units while G43 is active.
//!
//! Run with `cargo test -p volcomp-cli --test cli_tests rs274_agreement:: -- --nocapture`
//! to see the summary. Without rs274 the test is skipped loudly, except when
//! the environment variable `CI` is set: there it fails. `VOLCOMP_RS274` may
//! name the rs274 binary.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use crate::common;
use crate::rs274;

use rs274::compare::*;
use rs274::*;

// ---------------------------------------------------------------------------
// Jobs.

#[derive(Clone)]
enum Job {
    /// A program both interpreters are expected to accept.
    Plain {
        name: String,
        path: PathBuf,
        fixture: bool,
    },
    /// A program rs274 refuses as written ([`K0`], [`ABSOLUTE_CENTRES`]).
    Refused {
        path: PathBuf,
        case: &'static Refused,
    },
}

#[derive(Default)]
struct Outcome {
    /// One line for the summary.
    summary: String,
    /// Motions compared.
    motions: usize,
    /// Files compared in full.
    compared: usize,
    /// Largest difference among agreeing motions, mm.
    max_dev_mm: f64,
    failures: Vec<String>,
}

impl Outcome {
    fn absorb(&mut self, c: Comparison) {
        self.motions = c.pairs;
        self.max_dev_mm = c.max_dev_mm;
        self.compared = 1;
        self.failures.extend(c.failures);
    }
    /// `, max deviation … µm` and a MISMATCH flag.
    fn tail(&self) -> String {
        format!(
            " (max deviation {:.2} µm){}",
            self.max_dev_mm * 1000.0,
            if self.failures.is_empty() {
                ""
            } else {
                ", MISMATCH"
            }
        )
    }
}

fn run_plain(tools: &Tools, name: &str, path: &Path, fixture: bool, work: &Path) -> Outcome {
    let mut o = Outcome::default();
    let rs = match run_rs274(tools, path, work) {
        Ok(r) => r,
        Err(e) => {
            o.failures.push(format!("{name}: {e}"));
            o.summary = format!("{name}: ERROR {e}");
            return o;
        }
    };
    if let Some(why) = rs.rejected {
        if fixture {
            o.failures.push(format!(
                "{name}: rs274 rejects this fixture ({why}); fixtures must be valid LinuxCNC G-code"
            ));
        }
        o.summary = format!("{name}: skipped, rs274 rejects it ({why})");
        return o;
    }
    match run_volcomp(tools, path, &[]) {
        Ok(v) => {
            o.absorb(compare(name, &rs.motions, &v));
            o.summary = format!("{name}: {} motions compared{}", o.motions, o.tail());
        }
        Err(e) => {
            o.failures.push(format!(
                "{name}: rs274 accepts the program ({} motions) but {e}",
                rs.motions.len()
            ));
            o.summary = format!("{name}: volcomp FAILED");
        }
    }
    o
}

/// A program rs274 refuses as written: volcomp refuses it too by default,
/// at its line and with a way out, accepts it with `flag`, and must then
/// agree motion by motion with rs274 on a copy that rs274 accepts.
struct Refused {
    name: &'static str,
    /// What volcomp must refuse, and where.
    what: &'static str,
    line: u64,
    /// What the refusal must mention besides the line: (text, what it is).
    mentions: &'static [(&'static str, &'static str)],
    flag: &'static str,
    /// The copy rs274 accepts: its file name, how it is made, what it is.
    copy: &'static str,
    fix: fn(&[u8]) -> Vec<u8>,
    compared: &'static str,
}

/// The K0 fixture: rs274 refuses K0 on G17 arcs (as FreeCAD writes them);
/// the same program without the K0 words is valid LinuxCNC G-code.
const K0: Refused = Refused {
    name: K0_FIXTURE,
    what: "K0 on the G17 arc as LinuxCNC does",
    line: K0_LINE,
    mentions: &[("--accept-k0", "--accept-k0")],
    flag: "--accept-k0",
    copy: "helical-without-K0.nc",
    fix: |text| {
        String::from_utf8_lossy(text)
            .replace(" K0.000", "")
            .into_bytes()
    },
    compared: "--accept-k0 vs rs274 on a copy without K0",
};

/// BOTTLE.NC: absolute arc centres without G90.1; rs274 accepts the program
/// with G90.1 in front.
const ABSOLUTE_CENTRES: Refused = Refused {
    name: BOTTLE,
    what: "the arc (centres are absolute)",
    line: BOTTLE_ARC_LINE,
    mentions: &[("G90.1", "G90.1"), ("absolute", "absolute centres")],
    flag: "--absolute-arc-centers",
    copy: "BOTTLE-G90.1.ngc",
    fix: |text| [&b"G90.1\n"[..], text].concat(),
    compared: "--absolute-arc-centers vs rs274 with G90.1 prepended",
};

fn run_refused(tools: &Tools, path: &Path, work: &Path, case: &Refused) -> Outcome {
    let (name, line) = (case.name, case.line);
    let mut o = Outcome::default();
    let mut notes = Vec::new();
    // rs274 on the original: refused.
    match run_rs274(tools, path, &work.join("original")) {
        Ok(rs) => match &rs.rejected {
            Some(why) => notes.push(format!("rs274 rejects the original ({why})")),
            None => notes.push("rs274 accepts the original".into()),
        },
        Err(e) => o.failures.push(format!("{name}: {e}")),
    }
    // volcomp refuses it by default, naming the line and the way out …
    match run_volcomp(tools, path, &[]) {
        Ok(_) => o.failures.push(format!(
            "{name}: volcomp must refuse {} of line {line}, but it succeeded",
            case.what
        )),
        Err(e) => {
            let mut missing = Vec::new();
            if !e.contains(&format!(":{line}:")) {
                missing.push(format!("line {line}"));
            }
            for (text, what) in case.mentions {
                if !e.contains(text) {
                    missing.push(what.to_string());
                }
            }
            if !missing.is_empty() {
                o.failures.push(format!(
                    "{name}: volcomp's error does not mention {}: {e}",
                    missing.join(", ")
                ));
            }
        }
    }
    // … and accepts it with the flag.
    let accepted = run_volcomp(tools, path, &[case.flag]);
    if let Err(e) = &accepted {
        o.failures.push(format!(
            "{name}: volcomp {} must accept it, but {e}",
            case.flag
        ));
    }
    // Compared with rs274 on the copy rs274 accepts.
    let text = match std::fs::read(path) {
        Ok(t) => t,
        Err(e) => {
            o.failures.push(format!("{name}: {e}"));
            return o;
        }
    };
    std::fs::create_dir_all(work).unwrap();
    let copy = work.join(case.copy);
    std::fs::write(&copy, (case.fix)(&text)).unwrap();
    let label = format!("{name} ({})", case.compared);
    match (run_rs274(tools, &copy, &work.join("copy")), accepted) {
        (Ok(rs), Ok(v)) => {
            if let Some(why) = rs.rejected {
                o.failures
                    .push(format!("{label}: rs274 rejects the copy: {why}"));
            } else {
                o.absorb(compare(&label, &rs.motions, &v));
                o.compared = 1;
            }
        }
        (Err(e), _) => o.failures.push(format!("{label}: {e}")),
        (_, Err(_)) => {}
    }
    o.summary = format!(
        "{name}: {}; volcomp refuses line {line} too; {} motions compared ({}){}",
        notes.join("; "),
        o.motions,
        case.compared,
        o.tail()
    );
    o
}

fn list_files(dir: &Path, keep: impl Fn(&str) -> bool) -> Vec<(String, PathBuf)> {
    let mut v: Vec<(String, PathBuf)> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .filter_map(|p| {
            let name = p.file_name()?.to_str()?.to_string();
            keep(&name).then_some((name, p))
        })
        .collect();
    v.sort();
    v
}

/// The bundled corpus: every program in `tests/corpus/` (not its SOURCES.md).
/// It is part of the repository, so a missing or thin corpus is a failure.
fn corpus_files(dir: &Path) -> Vec<(String, PathBuf)> {
    let files = list_files(dir, |n| !n.ends_with(".md"));
    assert!(
        files.len() >= 11,
        "expected the 11 bundled corpus programs in {}, found {}",
        dir.display(),
        files.len()
    );
    files
}

#[test]
fn volcomp_moves_agree_with_rs274() {
    let Some(rs274) = find_rs274() else {
        common::missing(
            common::RS274,
            "volcomp moves against LinuxCNC (or set VOLCOMP_RS274)",
        );
        return;
    };

    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    let corpus_dir = manifest.join("../../tests/corpus");
    let fixture_dir = manifest.join("tests/fixtures/rs274");

    let tools = tools(rs274, "agreement");
    let dir = tools.dir.clone();

    let mut jobs = Vec::new();
    let corpus = corpus_files(&corpus_dir);
    jobs.push(Job::Refused {
        path: manifest.join("tests/fixtures/k0").join(K0_FIXTURE),
        case: &K0,
    });
    for (name, path) in corpus {
        jobs.push(match name.as_str() {
            BOTTLE => Job::Refused {
                path,
                case: &ABSOLUTE_CENTRES,
            },
            _ => Job::Plain {
                name: format!("corpus/{name}"),
                path,
                fixture: false,
            },
        });
    }
    let fixtures = list_files(&fixture_dir, |n| n.ends_with(".ngc"));
    assert!(
        !fixtures.is_empty(),
        "no fixtures in {}",
        fixture_dir.display()
    );
    for (name, path) in fixtures {
        jobs.push(Job::Plain {
            name: format!("fixture/{name}"),
            path,
            fixture: true,
        });
    }

    // Run the jobs on a few threads; the biggest corpus files dominate.
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<(usize, Outcome)>> = Mutex::new(Vec::new());
    let threads = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(2)
        .clamp(2, 8);
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::SeqCst);
                let Some(job) = jobs.get(i) else { break };
                let work = tools.dir.join(format!("job{i}"));
                let outcome = match job {
                    Job::Plain {
                        name,
                        path,
                        fixture,
                    } => run_plain(&tools, name, path, *fixture, &work),
                    Job::Refused { path, case } => run_refused(&tools, path, &work, case),
                };
                // Keep the work files of failing programs only.
                if outcome.failures.is_empty() {
                    let _ = std::fs::remove_dir_all(&work);
                }
                results.lock().unwrap().push((i, outcome));
            });
        }
    });
    let mut results = results.into_inner().unwrap();
    results.sort_by_key(|(i, _)| *i);

    let mut failures = Vec::new();
    let (mut files, mut motions) = (0, 0);
    println!("volcomp moves vs rs274 ({}):", tools.rs274.display());
    for (_, o) in &results {
        println!("  {}", o.summary);
        files += o.compared;
        motions += o.motions;
        failures.extend(o.failures.iter().cloned());
    }
    println!(
        "{files} files compared, {motions} motions compared, {} failures",
        failures.len()
    );
    if failures.is_empty() {
        let _ = std::fs::remove_dir_all(&dir);
    } else {
        println!(
            "(work files of the failing programs kept in {})",
            dir.display()
        );
        panic!(
            "volcomp moves disagrees with rs274:\n\n{}\n",
            failures.join("\n\n")
        );
    }
}

/// An error map over ±5 m on every axis (clamped anyway): a few µm of
/// positioning slope, waviness and straightness, with backlash, so that every
/// program of the corpus is compensated, split and given take-up moves.
fn wide_map() -> String {
    let mut csv = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
    for (a, name) in ["X", "Y", "Z"].iter().enumerate() {
        for (dir, backlash) in [("forward", 0.0), ("reverse", 3.0)] {
            for k in 0..=1000 {
                let p = -5000.0 + 10.0 * k as f64;
                let wave = 2.0 * (p / 37.0).sin();
                let mut e = [0.3 * wave, -0.2 * wave, 0.25 * wave];
                e[a] = 0.004 * p / 10.0 + wave + backlash;
                csv.push_str(&format!(
                    "{name},{dir},{p},{:.4},{:.4},{:.4}\n",
                    e[0], e[1], e[2]
                ));
            }
        }
    }
    csv
}

/// The set-up both interpreters run under, in a fresh directory
/// `volcomp-rs274-NAME-…` of its own.
pub(crate) fn tools(rs274: PathBuf, name: &str) -> Tools {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos())
        .unwrap_or(0);
    let dir = std::env::temp_dir().join(format!(
        "volcomp-rs274-{name}-{}-{nanos}",
        std::process::id()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    let setup = dir.join("setup.toml");
    std::fs::write(&setup, setup_toml()).unwrap();
    let tool_table = dir.join("tools.tbl");
    std::fs::write(&tool_table, rs274_tool_table()).unwrap();
    Tools {
        rs274,
        volcomp: PathBuf::from(env!("CARGO_BIN_EXE_volcomp")),
        dir,
        setup,
        tool_table,
        var_text: rs274_var_file(),
    }
}

#[test]
fn compensated_corpus_programs_are_accepted_by_rs274() {
    let Some(rs274) = find_rs274() else {
        common::missing(common::RS274, "the compensated corpus on rs274");
        return;
    };
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    let corpus_dir = manifest.join("../../tests/corpus");
    let tools = tools(rs274, "compensated");
    let dir = tools.dir.clone();
    let map = dir.join("map.csv");
    std::fs::write(&map, wide_map()).unwrap();
    let mut files = corpus_files(&corpus_dir);
    files.push((
        K0_FIXTURE.to_string(),
        manifest.join("tests/fixtures/k0").join(K0_FIXTURE),
    ));
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<(String, Result<String, String>)>> = Mutex::new(Vec::new());
    std::thread::scope(|s| {
        for _ in 0..2 {
            s.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::SeqCst);
                let Some((name, path)) = files.get(i) else {
                    break;
                };
                let work = tools.dir.join(format!("c{i}"));
                let _ = std::fs::create_dir_all(&work);
                let out = work.join("compensated.ngc");
                let mut cmd = Command::new(&tools.volcomp);
                cmd.arg("compensate")
                    .arg(path)
                    .arg("--setup")
                    .arg(&tools.setup)
                    .arg("--map")
                    .arg(&map)
                    .arg("--clamp")
                    .arg("--segment-length")
                    .arg("5")
                    .arg("-o")
                    .arg(&out);
                if name == BOTTLE {
                    cmd.arg("--absolute-arc-centers");
                }
                if name == K0_FIXTURE {
                    // LinuxCNC refuses the original's K0; the output has
                    // no arc left to carry it.
                    cmd.arg("--accept-k0");
                }
                let result = match cmd.stdin(Stdio::null()).output() {
                    Err(e) => Err(format!("cannot run volcomp: {e}")),
                    Ok(o) if !o.status.success() => Err(format!(
                        "volcomp compensate failed: {}",
                        String::from_utf8_lossy(&o.stderr)
                    )),
                    Ok(o) => match read_as_posted(name, &out)
                        .and_then(|p| run_rs274(&tools, &p, &work))
                    {
                        Err(e) => Err(e),
                        Ok(run) => match run.rejected {
                            Some(why) => Err(format!(
                                "rs274 rejects the compensated program {}: {why}",
                                out.display()
                            )),
                            None => Ok(format!(
                                "{} motions; {}",
                                run.motions.len(),
                                String::from_utf8_lossy(&o.stderr).trim()
                            )),
                        },
                    },
                };
                if result.is_ok() {
                    let _ = std::fs::remove_dir_all(&work);
                }
                results.lock().unwrap().push((name.clone(), result));
            });
        }
    });
    let mut results = results.into_inner().unwrap();
    results.sort();
    let mut failures = Vec::new();
    for (name, r) in &results {
        match r {
            Ok(summary) => println!("  {name}: accepted by rs274 ({summary})"),
            Err(e) => failures.push(format!("{name}: {e}")),
        }
    }
    println!(
        "{} compensated corpus programs checked, {} failures",
        results.len(),
        failures.len()
    );
    if failures.is_empty() {
        let _ = std::fs::remove_dir_all(&dir);
    } else {
        panic!("{}", failures.join("\n\n"));
    }
}

/// The compensated program as rs274 must read it to read it as its own
/// controller does: BOTTLE.NC was posted for a controller that reads I/J as
/// absolute centres without G90.1, and its arcs are written so
/// (`--absolute-arc-centers`); rs274 has no such option, so a copy opened by
/// G90.1 stands in for that controller. Every other program is read as it is.
fn read_as_posted(name: &str, out: &Path) -> Result<PathBuf, String> {
    if name != BOTTLE {
        return Ok(out.to_path_buf());
    }
    let text =
        std::fs::read_to_string(out).map_err(|e| format!("cannot read {}: {e}", out.display()))?;
    // A program opened by `%` must keep it first.
    let with = match text.strip_prefix("%\n") {
        Some(rest) => format!("%\nG90.1\n{rest}"),
        None => format!("G90.1\n{text}"),
    };
    let copy = out.with_extension("g90_1.ngc");
    std::fs::write(&copy, with).map_err(|e| format!("cannot write {}: {e}", copy.display()))?;
    Ok(copy)
}

/// rs274 prints `%5d N%5d` and a long N word runs into the call's name
/// (seen on LinuxCNC's tests/abort 3D_Chips.ngc, `N1001100`): the harness
/// must still see the motion, with its N word.
#[test]
fn the_harness_reads_calls_whose_n_word_runs_into_the_name() {
    let text = " 4818 N1001100STRAIGHT_FEED(48.0000, -27.2250, -2.9440, 0.0000, 0.0000, 0.0000)\n\
                \x20  12 N.....  NURBS_FEED(1.0000, 2.0000)\n\
                \x20  13 N00010  ARC_FEED(1.0000, 0.0000, 0.0000, 0.0000, 1, 0.0000, 0.0000, 0.0000, 0.0000)\n";
    let m = rs274::parse_rs274_output(text).unwrap();
    assert_eq!(m.len(), 3);
    assert_eq!(m[0].end, [48.0, -27.225, -2.944]);
    assert_eq!(
        m[0].call,
        "N1001100 STRAIGHT_FEED(48.0000, -27.2250, -2.9440, 0.0000, 0.0000, 0.0000)"
    );
    assert!(matches!(&m[1].kind, rs274::Kind::Other(n) if n == "NURBS_FEED"));
    assert_eq!(m[2].end, [1.0, 0.0, 0.0]);
    assert!(m[2].call.starts_with("N00010 ARC_FEED"));
}
