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
//! Run with `cargo test -p volcomp-cli --test rs274_agreement -- --nocapture`
//! to see the summary. Without rs274 the test is skipped loudly, except when
//! the environment variable `CI` is set: there it fails. `VOLCOMP_RS274` may
//! name the rs274 binary.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

const MM_PER_INCH: f64 = 25.4;
/// Rounding bound of a number rs274 prints with four decimals, with margin.
const PRINT_TOL: f64 = 0.6e-4;
/// volcomp prints six decimals of a millimetre.
const SLACK_MM: f64 = 1e-6;
/// Mismatches reported per file before giving up on it.
const MAX_REPORTS_PER_FILE: usize = 6;
/// Motions that must agree again after a run of extra motions.
const RESYNC_WINDOW: usize = 3;
/// Longest run of extra motions on one side that is recognised as such.
const MAX_EXTRA: usize = 8;

/// FreeCAD-style helical arcs with `K0.000` on G17 arcs (own fixture).
const K0_FIXTURE: &str = "helical_k0.nc";
/// The first G17 arc with a K word in it.
const K0_LINE: u64 = 6;
const BOTTLE: &str = "MaestroFusion360__easy_gcode_plot__BOTTLE.NC";
const BOTTLE_ARC_LINE: u64 = 12;

// ---------------------------------------------------------------------------
// Machine set-up, written for both interpreters.

/// A length given in hundredths of an inch: exact in both unit systems.
#[derive(Clone, Copy)]
struct Hundredths(i64);

impl Hundredths {
    fn inch(self) -> String {
        let sign = if self.0 < 0 { "-" } else { "" };
        let a = self.0.unsigned_abs();
        format!("{sign}{}.{:02}", a / 100, a % 100)
    }
    fn mm(self) -> String {
        // 0.01 in = 0.254 mm: thousandths of a millimetre.
        let sign = if self.0 < 0 { "-" } else { "" };
        let a = self.0.unsigned_abs() * 254;
        format!("{sign}{}.{:03}", a / 1000, a % 1000)
    }
}

/// G54 … G59.3 in P order.
const WORK_SYSTEMS: [&str; 9] = [
    "G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3",
];

fn work_offset(i: usize) -> [Hundredths; 3] {
    let i = i as i64;
    [
        Hundredths(1000 + 150 * i),
        Hundredths(-600 + 45 * i),
        Hundredths(-1500 - 20 * i),
    ]
}

fn tool_length(n: u32) -> Hundredths {
    Hundredths(10 * (16 + i64::from(n)))
}

const G28_POINT: [Hundredths; 3] = [Hundredths(500), Hundredths(250), Hundredths(100)];
const G30_POINT: [Hundredths; 3] = [Hundredths(-300), Hundredths(400), Hundredths(200)];

fn triple_mm(v: [Hundredths; 3]) -> String {
    format!("[{}, {}, {}]", v[0].mm(), v[1].mm(), v[2].mm())
}

fn setup_toml() -> String {
    let mut s = String::from("# generated by tests/rs274_agreement.rs\nunits = \"mm\"\nstart = [0, 0, 0]\n\n[work_offsets]\n");
    for (i, name) in WORK_SYSTEMS.iter().enumerate() {
        writeln!(s, "\"{name}\" = {}", triple_mm(work_offset(i))).unwrap();
    }
    s.push_str("\n[tools]\n");
    for n in 1..=99 {
        writeln!(s, "{n} = {}", tool_length(n).mm()).unwrap();
    }
    s.push_str("\n[reference]\n");
    writeln!(s, "G28 = {}", triple_mm(G28_POINT)).unwrap();
    writeln!(s, "G30 = {}", triple_mm(G30_POINT)).unwrap();
    s
}

fn rs274_tool_table() -> String {
    let mut s = String::new();
    for n in 1..=99 {
        writeln!(s, "T{n} P{n} Z{} D0", tool_length(n).inch()).unwrap();
    }
    s
}

fn rs274_var_file() -> String {
    let mut s = String::new();
    let mut put = |n: u32, v: [Hundredths; 3]| {
        for (k, h) in v.iter().enumerate() {
            writeln!(s, "{} {}", n + k as u32, h.inch()).unwrap();
        }
    };
    put(5161, G28_POINT);
    put(5181, G30_POINT);
    for i in 0..WORK_SYSTEMS.len() {
        put(5221 + 20 * i as u32, work_offset(i));
    }
    s.push_str("5220 1\n");
    let mut lines: Vec<&str> = s.lines().collect();
    lines.sort_by_key(|l| l.split(' ').next().unwrap().parse::<u32>().unwrap());
    lines.join("\n") + "\n"
}

// ---------------------------------------------------------------------------
// Motions.

#[derive(Debug, Clone, PartialEq)]
enum Kind {
    Rapid,
    Feed,
    ArcCw,
    ArcCcw,
    /// A canonical motion volcomp has no counterpart for.
    Other(String),
}

impl Kind {
    fn name(&self) -> &str {
        match self {
            Kind::Rapid => "rapid",
            Kind::Feed => "feed",
            Kind::ArcCw => "arc_cw",
            Kind::ArcCcw => "arc_ccw",
            Kind::Other(s) => s,
        }
    }
    fn from_volcomp(s: &str) -> Kind {
        match s {
            "rapid" => Kind::Rapid,
            "feed" => Kind::Feed,
            "arc_cw" => Kind::ArcCw,
            "arc_ccw" => Kind::ArcCcw,
            other => Kind::Other(other.to_string()),
        }
    }
}

/// One motion of rs274, already in machine coordinates (mm).
#[derive(Debug, Clone)]
struct RefMotion {
    kind: Kind,
    end: [f64; 3],
    /// Arc centre: the two in-plane axes and their values.
    center: Option<[(usize, f64); 2]>,
    /// Tolerance per axis, mm.
    tol: [f64; 3],
    /// The canonical call as rs274 printed it.
    call: String,
}

/// One row of `volcomp moves`.
#[derive(Debug, Clone)]
struct VolMotion {
    line: u64,
    kind: Kind,
    end: [f64; 3],
    center: Option<[f64; 3]>,
}

/// What rs274 made of a program.
struct Rs274Run {
    motions: Vec<RefMotion>,
    /// `Some(message)` when rs274 refused the program (the motions are then
    /// those before the refused line).
    rejected: Option<String>,
}

/// The canonical layer's state while reading rs274's output.
struct Canon {
    mm_per_unit: f64,
    g5x: [f64; 3],
    g92: [f64; 3],
    tlo: [f64; 3],
    /// Rounding allowance of each offset, mm.
    g5x_tol: [f64; 3],
    g92_tol: [f64; 3],
    tlo_tol: [f64; 3],
    /// In-plane axes (first, second) and the normal axis of ARC_FEED.
    plane: (usize, usize, usize),
}

impl Canon {
    fn new() -> Self {
        Self {
            mm_per_unit: 1.0,
            g5x: [0.0; 3],
            g92: [0.0; 3],
            tlo: [0.0; 3],
            g5x_tol: [0.0; 3],
            g92_tol: [0.0; 3],
            tlo_tol: [0.0; 3],
            plane: (0, 1, 2),
        }
    }

    fn offset(&self, axis: usize) -> f64 {
        self.g5x[axis] + self.g92[axis] + self.tlo[axis]
    }

    fn tol(&self, axis: usize) -> f64 {
        PRINT_TOL * self.mm_per_unit
            + self.g5x_tol[axis]
            + self.g92_tol[axis]
            + self.tlo_tol[axis]
            + SLACK_MM
    }

    /// Stores an offset printed in the current units, with its allowance.
    fn set(&self, values: &[f64]) -> ([f64; 3], [f64; 3]) {
        let mut v = [0.0; 3];
        let mut t = [0.0; 3];
        for a in 0..3 {
            v[a] = values[a] * self.mm_per_unit;
            t[a] = if values[a] != 0.0 {
                PRINT_TOL * self.mm_per_unit
            } else {
                0.0
            };
        }
        (v, t)
    }

    fn machine(&self, printed: [f64; 3]) -> [f64; 3] {
        let mut q = [0.0; 3];
        for a in 0..3 {
            q[a] = printed[a] * self.mm_per_unit + self.offset(a);
        }
        q
    }
}

/// The numbers of a call's argument list; at least `min` of them.
fn numbers(args: &str, min: usize) -> Result<Vec<f64>, String> {
    let v = args
        .split([',', ' '])
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| {
            s.parse::<f64>()
                .map_err(|_| format!("cannot read `{s}` as a number"))
        })
        .collect::<Result<Vec<f64>, String>>()?;
    if v.len() < min {
        return Err(format!(
            "expected at least {min} numbers, found {}",
            v.len()
        ));
    }
    Ok(v)
}

/// Reads rs274's canonical-call listing into machine-frame motions.
fn parse_rs274_output(text: &str) -> Result<Vec<RefMotion>, String> {
    let mut canon = Canon::new();
    let mut out = Vec::new();
    for raw in text.lines() {
        // `   10 N..... STRAIGHT_FEED(10.0000, 2.0000, ...)`: a call number,
        // the block's N word (`N.....` when it has none), the call. The
        // call's name is the upper-case identifier before the first `(`.
        let Some(open) = raw.find('(') else {
            continue;
        };
        let Some(close) = raw.rfind(')') else {
            continue;
        };
        let start = raw[..open]
            .rfind(|c: char| !(c.is_ascii_uppercase() || c.is_ascii_digit() || c == '_'))
            .map_or(0, |k| k + 1);
        let name = &raw[start..open];
        let args = &raw[open + 1..close];
        let n_word = raw[..start]
            .split_whitespace()
            .nth(1)
            .filter(|n| !n.starts_with("N."));
        let call = match n_word {
            Some(n) => format!("{n} {}", &raw[start..=close]),
            None => raw[start..=close].to_string(),
        };
        let bad = |e: String| format!("rs274 output `{raw}`: {e}");
        match name {
            "USE_LENGTH_UNITS" => {
                canon.mm_per_unit = match args.trim() {
                    "CANON_UNITS_MM" => 1.0,
                    "CANON_UNITS_INCHES" => MM_PER_INCH,
                    "CANON_UNITS_CM" => 10.0,
                    other => return Err(bad(format!("unknown units {other}"))),
                }
            }
            "SELECT_PLANE" => {
                canon.plane = match args.trim() {
                    "CANON_PLANE_XY" => (0, 1, 2),
                    "CANON_PLANE_XZ" => (2, 0, 1),
                    "CANON_PLANE_YZ" => (1, 2, 0),
                    other => return Err(bad(format!("unknown plane {other}"))),
                }
            }
            "SET_G5X_OFFSET" => {
                let n = numbers(args, 4).map_err(bad)?;
                (canon.g5x, canon.g5x_tol) = canon.set(&n[1..4]);
            }
            "SET_G92_OFFSET" => {
                let n = numbers(args, 3).map_err(bad)?;
                (canon.g92, canon.g92_tol) = canon.set(&n[0..3]);
            }
            "USE_TOOL_LENGTH_OFFSET" => {
                let n = numbers(args, 3).map_err(bad)?;
                (canon.tlo, canon.tlo_tol) = canon.set(&n[0..3]);
            }
            "STRAIGHT_TRAVERSE" | "STRAIGHT_FEED" => {
                let n = numbers(args, 3).map_err(bad)?;
                let kind = if name == "STRAIGHT_TRAVERSE" {
                    Kind::Rapid
                } else {
                    Kind::Feed
                };
                out.push(RefMotion {
                    kind,
                    end: canon.machine([n[0], n[1], n[2]]),
                    center: None,
                    tol: [canon.tol(0), canon.tol(1), canon.tol(2)],
                    call: call.clone(),
                });
            }
            "ARC_FEED" => {
                // first_end, second_end, first_centre, second_centre,
                // rotation, axis_end, a, b, c
                let n = numbers(args, 6).map_err(bad)?;
                let (f, s, ax) = canon.plane;
                let mut printed = [0.0; 3];
                printed[f] = n[0];
                printed[s] = n[1];
                printed[ax] = n[5];
                let end = canon.machine(printed);
                let cf = n[2] * canon.mm_per_unit + canon.offset(f);
                let cs = n[3] * canon.mm_per_unit + canon.offset(s);
                let kind = if n[4] < 0.0 {
                    Kind::ArcCw
                } else {
                    Kind::ArcCcw
                };
                out.push(RefMotion {
                    kind,
                    end,
                    center: Some([(f, cf), (s, cs)]),
                    tol: [canon.tol(0), canon.tol(1), canon.tol(2)],
                    call: call.clone(),
                });
            }
            "STRAIGHT_PROBE" | "RIGID_TAP" | "NURBS_FEED" | "SPLINE_FEED" => {
                out.push(RefMotion {
                    kind: Kind::Other(name.to_string()),
                    end: [f64::NAN; 3],
                    center: None,
                    tol: [0.0; 3],
                    call: call.clone(),
                });
            }
            _ => {}
        }
    }
    Ok(out)
}

fn parse_volcomp_csv(text: &str) -> Result<Vec<VolMotion>, String> {
    let mut lines = text.lines();
    let header = lines.next().unwrap_or("");
    if header != "line,column,kind,source,x_mm,y_mm,z_mm,cx_mm,cy_mm,cz_mm" {
        return Err(format!("unexpected CSV header `{header}`"));
    }
    let mut out = Vec::new();
    for row in lines {
        let f: Vec<&str> = row.split(',').collect();
        if f.len() != 10 {
            return Err(format!("CSV row `{row}` does not have 10 fields"));
        }
        let num = |s: &str| {
            s.parse::<f64>()
                .map_err(|_| format!("CSV row `{row}`: `{s}` is not a number"))
        };
        let line = f[0]
            .parse::<u64>()
            .map_err(|_| format!("CSV row `{row}`: bad line number"))?;
        let end = [num(f[4])?, num(f[5])?, num(f[6])?];
        let center = if f[7].is_empty() {
            None
        } else {
            Some([num(f[7])?, num(f[8])?, num(f[9])?])
        };
        out.push(VolMotion {
            line,
            kind: Kind::from_volcomp(f[2]),
            end,
            center,
        });
    }
    Ok(out)
}

// ---------------------------------------------------------------------------
// Running the two interpreters.

struct Tools {
    rs274: PathBuf,
    volcomp: PathBuf,
    /// Shared temporary directory (setup, tool table).
    dir: PathBuf,
    setup: PathBuf,
    tool_table: PathBuf,
    var_text: String,
}

fn find_rs274() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("VOLCOMP_RS274") {
        return Some(PathBuf::from(p)).filter(|p| p.is_file());
    }
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|d| d.join("rs274"))
        .find(|p| p.is_file())
}

fn run_rs274(tools: &Tools, program: &Path, work: &Path) -> Result<Rs274Run, String> {
    std::fs::create_dir_all(work).map_err(|e| format!("{}: {e}", work.display()))?;
    // rs274 rewrites its var file at the end: every run gets a fresh one.
    let var = work.join("params.var");
    std::fs::write(&var, &tools.var_text).map_err(|e| format!("{}: {e}", var.display()))?;
    let out_path = work.join("canon.txt");
    let _ = std::fs::remove_file(&out_path);
    // rs274 2.9 keeps its tool data in a memory-mapped file `$HOME/.tool.mmap`;
    // concurrent runs sharing it crash (SIGBUS). Each run gets its own HOME.
    let out = Command::new(&tools.rs274)
        .current_dir(work)
        .env("HOME", work)
        .arg("-g")
        .arg("-t")
        .arg(&tools.tool_table)
        .arg("-v")
        .arg(&var)
        .arg(program)
        .arg(&out_path)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| format!("cannot run {}: {e}", tools.rs274.display()))?;
    let text = std::fs::read_to_string(&out_path).unwrap_or_default();
    let motions = parse_rs274_output(&text)?;
    // A clean run prints only "executing" (stderr); anything else is an error.
    let chatter: Vec<String> = String::from_utf8_lossy(&out.stderr)
        .lines()
        .chain(String::from_utf8_lossy(&out.stdout).lines())
        .map(str::trim)
        .filter(|l| !l.is_empty() && *l != "executing")
        .map(str::to_string)
        .collect();
    let rejected = if !out.status.success() || !chatter.is_empty() {
        Some(format!("{}: {}", out.status, chatter.join(" | ")))
    } else {
        None
    };
    Ok(Rs274Run { motions, rejected })
}

/// `Ok(motions)` or `Err(stderr)` when volcomp refused the program.
fn run_volcomp(tools: &Tools, program: &Path, extra: &[&str]) -> Result<Vec<VolMotion>, String> {
    let out = Command::new(&tools.volcomp)
        .arg("moves")
        .arg("--setup")
        .arg(&tools.setup)
        .args(extra)
        .arg(program)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| format!("cannot run volcomp: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "volcomp exited with {}:\n{}",
            out.status,
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    parse_volcomp_csv(&String::from_utf8_lossy(&out.stdout))
}

// ---------------------------------------------------------------------------
// Comparison.

fn fmt3(v: [f64; 3]) -> String {
    format!("({:.6}, {:.6}, {:.6})", v[0], v[1], v[2])
}

fn describe_ref(m: &RefMotion) -> String {
    let mut s = format!("{} to {}", m.kind.name(), fmt3(m.end));
    if let Some(c) = m.center {
        let axis = ["x", "y", "z"];
        write!(
            s,
            " centre {}={:.6} {}={:.6}",
            axis[c[0].0], c[0].1, axis[c[1].0], c[1].1
        )
        .unwrap();
    }
    write!(s, " [rs274: {}]", m.call).unwrap();
    s
}

fn describe_vol(m: &VolMotion) -> String {
    let mut s = format!("{} to {}", m.kind.name(), fmt3(m.end));
    if let Some(c) = m.center {
        write!(s, " centre {}", fmt3(c)).unwrap();
    }
    write!(s, " (line {})", m.line).unwrap();
    s
}

/// Why a pair differs, or `None`.
fn differ(r: &RefMotion, v: &VolMotion) -> Option<String> {
    if r.kind != v.kind {
        return Some(format!(
            "kind differs: rs274 {}, volcomp {}",
            r.kind.name(),
            v.kind.name()
        ));
    }
    let axis = ["X", "Y", "Z"];
    let mut why = Vec::new();
    for (a, name) in axis.iter().enumerate() {
        let d = (r.end[a] - v.end[a]).abs();
        if d.is_nan() || d > r.tol[a] {
            why.push(format!(
                "end {name} off by {d:.6} mm (tolerance {:.6})",
                r.tol[a]
            ));
        }
    }
    match (r.center, v.center) {
        (Some(rc), Some(vc)) => {
            for (a, value) in rc {
                let d = (value - vc[a]).abs();
                if d.is_nan() || d > r.tol[a] {
                    why.push(format!(
                        "centre {} off by {:.6} mm (tolerance {:.6})",
                        axis[a], d, r.tol[a]
                    ));
                }
            }
        }
        (Some(_), None) => why.push("volcomp gives no arc centre".into()),
        _ => {}
    }
    if why.is_empty() {
        None
    } else {
        Some(why.join("; "))
    }
}

/// Whether the two sequences agree for the next few motions from `i`, `j`
/// (or both end there).
fn aligned(reference: &[RefMotion], i: usize, volcomp: &[VolMotion], j: usize) -> bool {
    if i >= reference.len() || j >= volcomp.len() {
        return i >= reference.len() && j >= volcomp.len();
    }
    reference[i..]
        .iter()
        .zip(&volcomp[j..])
        .take(RESYNC_WINDOW)
        .all(|(r, v)| differ(r, v).is_none())
}

/// Largest coordinate difference of a pair that agrees, mm.
fn deviation(r: &RefMotion, v: &VolMotion) -> f64 {
    let mut d = (0..3)
        .map(|a| (r.end[a] - v.end[a]).abs())
        .fold(0.0, f64::max);
    if let (Some(rc), Some(vc)) = (r.center, v.center) {
        for (a, value) in rc {
            d = d.max((value - vc[a]).abs());
        }
    }
    d
}

/// The result of comparing one program.
struct Comparison {
    /// Pairs of motions compared.
    pairs: usize,
    /// Largest difference among the pairs that agree, mm.
    max_dev_mm: f64,
    failures: Vec<String>,
}

/// Motions compared and failure messages.
///
/// The sequences are compared in order. Where they stop agreeing, a few
/// motions of look-ahead tell an extra motion on one side (reported as such,
/// then skipped) from a motion that differs.
fn compare(label: &str, reference: &[RefMotion], volcomp: &[VolMotion]) -> Comparison {
    let mut failures = Vec::new();
    let (mut i, mut j, mut pairs, mut problems) = (0, 0, 0, 0);
    let mut max_dev_mm = 0.0_f64;
    let mut report = |failures: &mut Vec<String>, msg: String| {
        problems += 1;
        if problems <= MAX_REPORTS_PER_FILE {
            failures.push(msg);
        }
    };
    // Where, in volcomp's sequence, a motion volcomp lacks would go.
    let between = |j: usize| match (
        j.checked_sub(1).and_then(|p| volcomp.get(p)),
        volcomp.get(j),
    ) {
        (Some(a), Some(b)) => format!(
            "between volcomp motion #{} (line {}) and #{j} (line {})",
            j - 1,
            a.line,
            b.line
        ),
        (None, Some(b)) => format!("before volcomp's first motion (line {})", b.line),
        (Some(a), None) => format!("after volcomp's last motion (line {})", a.line),
        (None, None) => "volcomp has no motion at all".to_string(),
    };
    while i < reference.len() && j < volcomp.len() {
        let Some(why) = differ(&reference[i], &volcomp[j]) else {
            max_dev_mm = max_dev_mm.max(deviation(&reference[i], &volcomp[j]));
            i += 1;
            j += 1;
            pairs += 1;
            continue;
        };
        if let Some(k) = (1..=MAX_EXTRA).find(|&k| aligned(reference, i + k, volcomp, j)) {
            let extra: Vec<String> = (i..i + k)
                .map(|n| format!("\n    rs274 #{n}: {}", describe_ref(&reference[n])))
                .collect();
            report(
                &mut failures,
                format!(
                    "{label}: rs274 emits {k} motion(s) that volcomp does not, {}:{}\n    volcomp #{j}: {}",
                    between(j),
                    extra.concat(),
                    describe_vol(&volcomp[j])
                ),
            );
            i += k;
        } else if let Some(k) = (1..=MAX_EXTRA).find(|&k| aligned(reference, i, volcomp, j + k)) {
            let extra: Vec<String> = (j..j + k)
                .map(|n| format!("\n    volcomp #{n}: {}", describe_vol(&volcomp[n])))
                .collect();
            report(
                &mut failures,
                format!(
                    "{label}: volcomp emits {k} motion(s) that rs274 does not, before rs274 motion #{i}:{}\n    rs274 #{i}: {}",
                    extra.concat(),
                    describe_ref(&reference[i])
                ),
            );
            j += k;
        } else {
            report(
                &mut failures,
                format!(
                    "{label}: motion #{i} (volcomp #{j}, volcomp line {}): {why}\n    rs274:   {}\n    volcomp: {}",
                    volcomp[j].line,
                    describe_ref(&reference[i]),
                    describe_vol(&volcomp[j])
                ),
            );
            i += 1;
            j += 1;
            pairs += 1;
        }
    }
    if i < reference.len() {
        report(
            &mut failures,
            format!(
                "{label}: rs274 has {} more motion(s) at the end, {}; the first is rs274 #{i}: {}",
                reference.len() - i,
                between(j),
                describe_ref(&reference[i])
            ),
        );
    }
    if j < volcomp.len() {
        report(
            &mut failures,
            format!(
                "{label}: volcomp has {} more motion(s) at the end; the first is volcomp #{j}: {}",
                volcomp.len() - j,
                describe_vol(&volcomp[j])
            ),
        );
    }
    if problems > MAX_REPORTS_PER_FILE {
        failures.push(format!(
            "{label}: … and {} more disagreements (rs274 {} motions, volcomp {})",
            problems - MAX_REPORTS_PER_FILE,
            reference.len(),
            volcomp.len()
        ));
    }
    Comparison {
        pairs,
        max_dev_mm,
        failures,
    }
}

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
    /// The K0 fixture: rs274 refuses K0 on G17 arcs.
    K0 { path: PathBuf },
    /// BOTTLE.NC: absolute arc centres without G90.1.
    Bottle { path: PathBuf },
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

fn run_k0(tools: &Tools, path: &Path, work: &Path) -> Outcome {
    let name = K0_FIXTURE;
    let mut o = Outcome::default();
    let mut notes = Vec::new();
    // rs274 on the original: refused at the first K0 arc.
    match run_rs274(tools, path, &work.join("original")) {
        Ok(rs) => match &rs.rejected {
            Some(why) => notes.push(format!("rs274 rejects the original ({why})")),
            None => notes.push("rs274 accepts the original".into()),
        },
        Err(e) => o.failures.push(format!("{name}: {e}")),
    }
    // volcomp accepts K0 by default …
    let accepted = run_volcomp(tools, path, &[]);
    if let Err(e) = &accepted {
        o.failures.push(format!(
            "{name}: volcomp must accept K0 on G17 arcs by default, but {e}"
        ));
    }
    // … and refuses it with --strict-k0, naming the line.
    match run_volcomp(tools, path, &["--strict-k0"]) {
        Ok(_) => o.failures.push(format!(
            "{name}: volcomp --strict-k0 must refuse K0 on the G17 arc of line {K0_LINE}, but it succeeded"
        )),
        Err(e) => {
            if !e.contains(&format!(":{K0_LINE}:")) {
                o.failures.push(format!(
                    "{name}: volcomp --strict-k0 fails but does not name line {K0_LINE}: {e}"
                ));
            }
        }
    }
    // The same program without the K0 words is valid LinuxCNC G-code: volcomp
    // on the original must agree with rs274 on that copy, motion by motion.
    let text = match std::fs::read(path) {
        Ok(t) => t,
        Err(e) => {
            o.failures.push(format!("{name}: {e}"));
            return o;
        }
    };
    let text = String::from_utf8_lossy(&text);
    let stripped = text.replace(" K0.000", "");
    let copy = work.join("helical-without-K0.nc");
    std::fs::create_dir_all(work).unwrap();
    std::fs::write(&copy, stripped).unwrap();
    let label = format!("{name} (rs274 on a copy without K0)");
    match (run_rs274(tools, &copy, &work.join("stripped")), accepted) {
        (Ok(rs), Ok(v)) => {
            if let Some(why) = rs.rejected {
                o.failures
                    .push(format!("{label}: rs274 still rejects it: {why}"));
            } else {
                o.absorb(compare(&label, &rs.motions, &v));
                o.compared = 1;
            }
        }
        (Err(e), _) => o.failures.push(format!("{label}: {e}")),
        (_, Err(_)) => {}
    }
    o.summary = format!(
        "{name}: {}; --strict-k0 names line {K0_LINE}; {} motions compared against the copy without K0{}",
        notes.join("; "),
        o.motions,
        o.tail()
    );
    o
}

fn run_bottle(tools: &Tools, path: &Path, work: &Path) -> Outcome {
    let name = BOTTLE;
    let mut o = Outcome::default();
    let mut notes = Vec::new();
    match run_rs274(tools, path, &work.join("original")) {
        Ok(rs) => match &rs.rejected {
            Some(why) => notes.push(format!("rs274 rejects the original ({why})")),
            None => notes.push("rs274 accepts the original".into()),
        },
        Err(e) => o.failures.push(format!("{name}: {e}")),
    }
    match run_volcomp(tools, path, &[]) {
        Ok(_) => o.failures.push(format!(
            "{name}: volcomp must refuse the arc of line {BOTTLE_ARC_LINE} (centres are absolute), but it succeeded"
        )),
        Err(e) => {
            let mut missing = Vec::new();
            if !e.contains(&format!(":{BOTTLE_ARC_LINE}:")) {
                missing.push(format!("line {BOTTLE_ARC_LINE}"));
            }
            if !e.contains("G90.1") {
                missing.push("G90.1".to_string());
            }
            if !e.contains("absolute") {
                missing.push("absolute centres".to_string());
            }
            if !missing.is_empty() {
                o.failures.push(format!(
                    "{name}: volcomp's error does not mention {}: {e}",
                    missing.join(", ")
                ));
            }
        }
    }
    let absolute = run_volcomp(tools, path, &["--absolute-arc-centers"]);
    if let Err(e) = &absolute {
        o.failures.push(format!(
            "{name}: volcomp --absolute-arc-centers must accept it, but {e}"
        ));
    }
    // With G90.1 in front rs274 accepts the program: compare.
    let text = match std::fs::read(path) {
        Ok(t) => t,
        Err(e) => {
            o.failures.push(format!("{name}: {e}"));
            return o;
        }
    };
    let mut fixed = b"G90.1\n".to_vec();
    fixed.extend_from_slice(&text);
    std::fs::create_dir_all(work).unwrap();
    let copy = work.join("BOTTLE-G90.1.ngc");
    std::fs::write(&copy, fixed).unwrap();
    let label = format!("{name} (--absolute-arc-centers vs rs274 with G90.1 prepended)");
    match (run_rs274(tools, &copy, &work.join("g901")), absolute) {
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
        "{name}: {}; volcomp refuses line {BOTTLE_ARC_LINE} with a G90.1 hint; {} motions compared (--absolute-arc-centers vs rs274 with G90.1){}",
        notes.join("; "),
        o.motions,
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
        if std::env::var_os("CI").is_some() {
            panic!("rs274 (LinuxCNC's stand-alone interpreter, Debian package linuxcnc-uspace) is not installed, and CI is set: CI must install it");
        }
        let banner = "!".repeat(78);
        eprintln!("{banner}\n!! SKIPPED rs274_agreement: rs274 is not installed (apt install linuxcnc-uspace,\n!! or set VOLCOMP_RS274). volcomp moves was NOT checked against LinuxCNC.\n{banner}");
        println!("SKIPPED: rs274 not installed");
        return;
    };

    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    let corpus_dir = manifest.join("../../tests/corpus");
    let fixture_dir = manifest.join("tests/fixtures/rs274");

    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos())
        .unwrap_or(0);
    let dir = std::env::temp_dir().join(format!(
        "volcomp-rs274-agreement-{}-{nanos}",
        std::process::id()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    let setup = dir.join("setup.toml");
    std::fs::write(&setup, setup_toml()).unwrap();
    let tool_table = dir.join("tools.tbl");
    std::fs::write(&tool_table, rs274_tool_table()).unwrap();
    let tools = Tools {
        rs274,
        volcomp: PathBuf::from(env!("CARGO_BIN_EXE_volcomp")),
        dir: dir.clone(),
        setup,
        tool_table,
        var_text: rs274_var_file(),
    };

    let mut jobs = Vec::new();
    let corpus = corpus_files(&corpus_dir);
    jobs.push(Job::K0 {
        path: manifest.join("tests/fixtures/k0").join(K0_FIXTURE),
    });
    for (name, path) in corpus {
        jobs.push(match name.as_str() {
            BOTTLE => Job::Bottle { path },
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
                    Job::K0 { path } => run_k0(&tools, path, &work),
                    Job::Bottle { path } => run_bottle(&tools, path, &work),
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

#[test]
fn compensated_corpus_programs_are_accepted_by_rs274() {
    let Some(rs274) = find_rs274() else {
        if std::env::var_os("CI").is_some() {
            panic!("rs274 (Debian package linuxcnc-uspace) is not installed, and CI is set: CI must install it");
        }
        eprintln!(
            "!! SKIPPED compensated_corpus_programs_are_accepted_by_rs274: rs274 is not installed"
        );
        println!("SKIPPED: rs274 not installed");
        return;
    };
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    let corpus_dir = manifest.join("../../tests/corpus");
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos())
        .unwrap_or(0);
    let dir = std::env::temp_dir().join(format!(
        "volcomp-rs274-compensated-{}-{nanos}",
        std::process::id()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    let setup = dir.join("setup.toml");
    std::fs::write(&setup, setup_toml()).unwrap();
    let tool_table = dir.join("tools.tbl");
    std::fs::write(&tool_table, rs274_tool_table()).unwrap();
    let map = dir.join("map.csv");
    std::fs::write(&map, wide_map()).unwrap();
    let tools = Tools {
        rs274,
        volcomp: PathBuf::from(env!("CARGO_BIN_EXE_volcomp")),
        dir: dir.clone(),
        setup,
        tool_table,
        var_text: rs274_var_file(),
    };
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
                let result = match cmd.stdin(Stdio::null()).output() {
                    Err(e) => Err(format!("cannot run volcomp: {e}")),
                    Ok(o) if !o.status.success() => Err(format!(
                        "volcomp compensate failed: {}",
                        String::from_utf8_lossy(&o.stderr)
                    )),
                    Ok(o) => match run_rs274(&tools, &out, &work) {
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
