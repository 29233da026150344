//! The simulation's metrics on whole programs: facts that hold on every
//! program, checked on the bundled real programs (`tests/corpus`) and on
//! generated programs with retraced passes, multi-depth roughing, repeated
//! contours, multi-turn helices, canned cycles and long rapids.
//!
//! 1. Uncompensated, the contour error never exceeds the largest error the
//!    map can produce: every actual sample lies within that error of its
//!    command, and the command lies on the nominal move (on arcs within the
//!    chord tolerance, as the controller is simulated along chords).
//! 2. A program judged against itself (`--reference P`) gives exactly the
//!    figures of the plain simulation.
//! 3. A program compensated by volcomp, judged against its original, is
//!    measured at the targets the compensation run itself solved for: every
//!    point is the end of an original feed move, judged at the command the
//!    compensation wrote for that end.

use std::io::Cursor;
use std::path::{Path, PathBuf};
use volcomp_core::compensate::{
    compensate_program, survey_style, CompensateOptions, PointRecord, Segmentation,
};
use volcomp_core::example::example_map;
use volcomp_core::model::axis_table::AxisTableMap;
use volcomp_core::simulate::report::{simulate_program, SegmentError, SimReport};
use volcomp_gcode::{InterpOptions, MotionSource, Setup, Vec3, Walker};

const CHORD_TOLERANCE_MM: f64 = 1e-4;

fn walker(text: &str, setup: &Setup, options: InterpOptions) -> Walker<Cursor<Vec<u8>>> {
    Walker::new(
        Cursor::new(text.as_bytes().to_vec()),
        Some("p.ngc".into()),
        setup.clone(),
        options,
    )
}

/// The largest error the map can produce over the box `lo`…`hi` (axis
/// frame, mm), from its table rows alone (the map interpolates linearly
/// between rows, and holds the end rows outside the table when clamped):
/// per component, the sum over the three axes of the largest magnitude any
/// row in reach gives it; a dead-band lag mixes such components axis by
/// axis, so the bound is the norm of that per-component bound (µm).
fn map_bound_um(map: &AxisTableMap, lo: Vec3, hi: Vec3) -> f64 {
    let csv = map.to_csv();
    let rows: Vec<(usize, f64, [f64; 3])> = csv
        .lines()
        .skip(1)
        .map(|row| {
            let f: Vec<&str> = row.split(',').collect();
            let a = match f[0] {
                "X" => 0,
                "Y" => 1,
                "Z" => 2,
                other => panic!("axis {other}"),
            };
            let e = [3, 4, 5].map(|k| f[k].parse::<f64>().unwrap());
            (a, f[2].parse().unwrap(), e)
        })
        .collect();
    let mut per_axis = [[0.0f64; 3]; 3];
    for a in 0..3 {
        let first = rows
            .iter()
            .filter(|r| r.0 == a)
            .map(|r| r.1)
            .fold(f64::MAX, f64::min);
        let last = rows
            .iter()
            .filter(|r| r.0 == a)
            .map(|r| r.1)
            .fold(f64::MIN, f64::max);
        // Rows one table step (2 mm) beyond the box bracket its ends.
        let (from, to) = (lo[a].max(first) - 2.1, hi[a].min(last) + 2.1);
        for (_, _, e) in rows.iter().filter(|r| r.0 == a && r.1 >= from && r.1 <= to) {
            for k in 0..3 {
                per_axis[a][k] = per_axis[a][k].max(e[k].abs());
            }
        }
    }
    (0..3)
        .map(|k| (0..3).map(|a| per_axis[a][k]).sum::<f64>().powi(2))
        .sum::<f64>()
        .sqrt()
}

/// The box (axis frame, mm) of a program's moves.
fn moves_box(text: &str, setup: &Setup, interp: InterpOptions) -> Result<(Vec3, Vec3), String> {
    let mut w = walker(text, setup, interp);
    let mut lo = Vec3::new(f64::MAX, f64::MAX, f64::MAX);
    let mut hi = Vec3::new(f64::MIN, f64::MIN, f64::MIN);
    while let Some(ev) = w.next_line().map_err(|e| e.to_string())? {
        // Where the tool goes along the program's own moves (arcs bulge
        // between their ends; the machine's start position is no part).
        let program = ev
            .motions
            .iter()
            .filter(|m| matches!(m.source, MotionSource::Program | MotionSource::Cycle));
        for m in program {
            let mut points = vec![m.end];
            if let volcomp_gcode::MotionKind::Arc(arc) = m.kind {
                points.extend((0..=64).map(|k| arc.point_at(f64::from(k) / 64.0)));
            }
            for p in points {
                for a in 0..3 {
                    lo[a] = lo[a].min(p[a]);
                    hi[a] = hi[a].max(p[a]);
                }
            }
        }
    }
    Ok((lo, hi))
}

struct Run {
    report: SimReport,
    segments: Vec<SegmentError>,
}

fn simulate(
    text: &str,
    reference: Option<&str>,
    map: &AxisTableMap,
    setup: &Setup,
    options: InterpOptions,
) -> Run {
    let mut segments = Vec::new();
    let mut r = reference.map(|t| walker(t, setup, options));
    let report = simulate_program(
        &mut walker(text, setup, options),
        "p.ngc",
        r.as_mut(),
        map,
        CHORD_TOLERANCE_MM,
        |s| segments.push(*s),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    Run { report, segments }
}

/// What the simulation of `text`, named `name`, says when it refuses it
/// (G54 at 300, 200, 150; the interpreter's defaults).
fn refusal(name: &str, text: &str, reference: Option<&str>, map: &AxisTableMap) -> String {
    let (setup, options) = (
        setup_at(Vec3::new(300.0, 200.0, 150.0)),
        InterpOptions::default(),
    );
    let mut r = reference.map(|t| walker(t, &setup, options));
    let mut w = walker(text, &setup, options);
    simulate_program(&mut w, name, r.as_mut(), map, 1e-4, |_| {})
        .unwrap_err()
        .to_string()
}

fn compensate(
    text: &str,
    map: &AxisTableMap,
    setup: &Setup,
    interp: InterpOptions,
    options: &CompensateOptions,
) -> (String, Vec<PointRecord>) {
    let mut out = Vec::new();
    let mut records = Vec::new();
    compensate_program(
        &mut walker(text, setup, interp),
        "p.ngc",
        map,
        &survey_style(text.as_bytes()),
        options,
        &mut out,
        |r| records.push(*r),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    (String::from_utf8(out).unwrap(), records)
}

/// The figures, without the field that says where the nominal path came from.
fn figures(r: &SimReport) -> SimReport {
    SimReport { nominal: "", ..*r }
}

/// Checks the three facts on one program; returns the plain and the
/// compensated figures.
fn check(
    name: &str,
    text: &str,
    map: &AxisTableMap,
    setup: &Setup,
    interp: InterpOptions,
    strict: bool,
) -> (SimReport, SimReport) {
    let (lo, hi) = moves_box(text, setup, interp).unwrap();
    let bound = map_bound_um(map, lo, hi) + CHORD_TOLERANCE_MM * 1e3;
    let own = simulate(text, None, map, setup, interp);
    assert!(
        own.report.contour_max_um <= bound,
        "{name}: contour max {} µm above the map's bound {bound} µm",
        own.report.contour_max_um
    );
    assert!(own.report.point_max_um <= bound, "{name}: {:?}", own.report);
    let own_ref = simulate(text, Some(text), map, setup, interp);
    assert_eq!(
        figures(&own.report),
        figures(&own_ref.report),
        "{name}: judged against itself"
    );
    assert_eq!(own.segments, own_ref.segments, "{name}");

    // The figures of the default compensation, returned (kept from the
    // first pass of the loop rather than computed a second time).
    let mut default_after = None;
    for options in [
        CompensateOptions::default(),
        CompensateOptions {
            segmentation: Segmentation::Off,
            ..Default::default()
        },
    ] {
        let (out, records) = compensate(text, map, setup, interp, &options);
        let after = simulate(&out, Some(text), map, setup, interp);
        // Same targets: the ends of the original's feed moves, in order.
        let targets = |run: &Run| -> Vec<(u64, Vec3)> {
            run.segments
                .iter()
                .filter_map(|s| s.target_mm.map(|t| (s.nominal_line, t)))
                .collect()
        };
        assert_eq!(targets(&own), targets(&after), "{name}: {options:?}");
        assert_eq!(own.report.points, after.report.points, "{name}");
        // Each is judged at the command the compensation wrote for it.
        let mut next = 0;
        for s in after.segments.iter().filter(|s| s.target_mm.is_some()) {
            let t = s.target_mm.unwrap();
            let k = records[next..]
                .iter()
                .position(|r| r.line == s.nominal_line && r.target_mm == t)
                .unwrap_or_else(|| {
                    panic!(
                        "{name}: no compensated point for line {} {t:?}",
                        s.nominal_line
                    )
                });
            next += k + 1;
            // Equal up to a written step: compensation keeps an original
            // word whose new value is within half a step of it (0.13 µm
            // in inch with 5 decimals).
            let command = records[next - 1].command_mm;
            assert!(
                (command - s.command_mm).max_abs() < 2e-4,
                "{name}: line {}: judged at {:?}, compensated to {command:?}",
                s.nominal_line,
                s.command_mm
            );
        }
        // In mm with 4 decimals, compensated to within the written
        // resolution (0.1 µm steps), the solver's residual and the map's
        // curvature over a ≤ 1 mm segment: far below the uncompensated
        // error, on every sample. Real programs (inch, 5 decimals, moves
        // shorter than the backlash) are held to the map's bound.
        let (contour_limit, point_limit) = if !strict || options.segmentation == Segmentation::Off {
            (bound, bound)
        } else {
            (1.0, 1.0)
        };
        assert!(
            after.report.contour_max_um <= contour_limit
                && after.report.point_max_um <= point_limit,
            "{name}: {options:?}: {:?}",
            after.report
        );
        if options == CompensateOptions::default() {
            default_after = Some(after.report);
        }
    }
    (own.report, default_after.expect("the default compensation"))
}

fn setup_at(g54: Vec3) -> Setup {
    let mut s = Setup::default();
    s.work_offsets_mm[0] = g54;
    for t in 1..=99 {
        s.tool_lengths_mm.insert(t, 0.0);
    }
    s
}

/// The generated programs: (name, text), at G54 = (300, 200, 150).
fn generated() -> Vec<(&'static str, String)> {
    let mut out = Vec::new();
    // A square traced forwards and back three times.
    let mut p = String::from("G21 G90 G17 F800\nG0 X0 Y0 Z0\n");
    for _ in 0..3 {
        p += "G1 X40\nG1 Y30\nG1 X0\nG1 Y0\nG1 Y30\nG1 X40\nG1 Y0\nG1 X0\n";
    }
    p += "M2\n";
    out.push(("retraced square", p));
    // Multi-depth roughing: a zigzag pocket at five depths, retracting.
    let mut p = String::from("G21 G90 F600\nG0 X-50 Y-30 Z5\n");
    for d in 1..=5 {
        p += &format!("G1 Z{}\n", -2 * d);
        for k in 0..7 {
            let y = -30 + 10 * k;
            let (a, b) = if k % 2 == 0 { (-50, 50) } else { (50, -50) };
            p += &format!("G1 X{a} Y{y}\nG1 X{b}\n");
        }
        p += "G0 Z5\nG0 X-50 Y-30\n";
    }
    p += "M30\n";
    out.push(("multi-depth roughing", p));
    // Repeated contours: a circle three times, then a two-turn helix down;
    // in G61, so the quarter points' take-ups are exact (under G64 they
    // fold, leaving up to the reversal value by design).
    let p = "G21 G90 G17 G61 F500\nG0 X20 Y0 Z1\nG1 Z0\nG2 X20 Y0 I-20 J0\nG2 X20 Y0 I-20 J0\nG3 X20 Y0 I-20 J0\nG2 X20 Y0 Z-4 I-20 J0 P2\nG0 Z10\nM2\n".to_string();
    out.push(("repeated circles and helix", p));
    // Steep helices of small radius (thread milling, helical entry): 0.3 mm
    // radius rising 1 mm per quarter turn (the helix climbs twice as fast
    // as it turns: a point's angle about the axis says little about where
    // its closest point is).
    let mut p = String::from("G21 G90 G17 F300\nG0 X0.3 Y0 Z1\nG1 Z0\n");
    let quarter = [
        ("0", "0.3", "-0.3", "0"),
        ("-0.3", "0", "0", "-0.3"),
        ("0", "-0.3", "0.3", "0"),
        ("0.3", "0", "0", "0.3"),
    ];
    for k in 0..20 {
        let (x, y, i, j) = quarter[k % 4];
        p += &format!("G3 X{x} Y{y} Z{} I{i} J{j}\n", k + 1);
    }
    p += "G0 Z30\nM2\n";
    out.push(("steep small helices", p));
    // Long rapids across the table between small contours, and drilling.
    let mut p = String::from("G21 G90 G17 F400\nG0 X-140 Y-90 Z20\n");
    for (x, y) in [(-140i32, -90i32), (140, 90), (-140, 90), (140, -90)] {
        p += &format!(
            "G0 X{x} Y{y} Z20\nG1 Z-1\nG1 X{} \nG1 Y{}\nG0 Z20\n",
            x - 5 * x.signum(),
            y - 5 * y.signum()
        );
    }
    p += "G98 G81 X0 Y0 Z-10 R2\nX10\nG85 X20 Y5 Z-8 R2\nG80\nG0 Z50\nM2\n";
    out.push(("long rapids and cycles", p));
    out
}

#[test]
fn generated_programs_are_measured_against_the_blocks_they_were_written_for() {
    let map = example_map();
    let setup = setup_at(Vec3::new(300.0, 200.0, 150.0));
    for (name, text) in generated() {
        let (before, after) = check(name, &text, &map, &setup, InterpOptions::default(), true);
        assert!(before.points > 0 && before.samples > 0, "{name}");
        assert!(
            after.contour_rms_um < before.contour_rms_um / 10.0,
            "{name}"
        );
    }
}

#[test]
fn a_retraced_pass_is_judged_against_its_own_block() {
    // Pitch error 0.1 µm/mm along X only (forward and reverse alike): a
    // pass to X40 and back to X0 along the same line. The tool arrives at
    // X = 40.004 (4 µm past the end of the first block): the return block
    // starts there. Every sample of the return lies on the X axis, so its
    // distance to the return segment X40…X0 is the overshoot beyond X40 only
    // at its start; the contour max is 4 µm (at the end of the first block)
    // and the point errors are 4 µm at X40 and 0 at X0.
    let csv = {
        let mut c = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
        for (name, dir) in [
            ("X", "forward"),
            ("X", "reverse"),
            ("Y", "forward"),
            ("Y", "reverse"),
            ("Z", "forward"),
            ("Z", "reverse"),
        ] {
            for p in [-100, 300] {
                let ex = if name == "X" { 0.1 * f64::from(p) } else { 0.0 };
                c += &format!("{name},{dir},{p},{ex},0,0\n");
            }
        }
        c
    };
    let map = AxisTableMap::from_csv(&csv, "m.csv").unwrap();
    let text = "G0 X0 Y0 Z0\nG1 X40 F100\nG1 X0\nM2\n";
    let run = simulate(
        text,
        None,
        &map,
        &Setup::default(),
        InterpOptions::default(),
    );
    let points: Vec<f64> = run.segments.iter().filter_map(|s| s.point_um).collect();
    assert_eq!(points.len(), 2);
    assert!(
        (points[0] - 4.0).abs() < 1e-9 && points[1].abs() < 1e-9,
        "{points:?}"
    );
    assert!(
        (run.report.contour_max_um - 4.0).abs() < 1e-9,
        "{:?}",
        run.report
    );
}

#[test]
fn a_far_move_is_refused_at_its_line_not_sampled() {
    let mut map = example_map();
    map.clamp = true;
    // 180 m in one block, every coordinate within the ±100 m the
    // interpreter accepts: the simulation's own limit refuses it.
    let text = "G21 G90\nG0 X-90000 Y0 Z0\nG1 X89000 F100\nM2\n";
    let err = refusal("far.ngc", text, None, &map);
    assert!(
        err.starts_with("far.ngc:3:") && err.contains("refuses moves longer"),
        "{err}"
    );
}

#[test]
fn a_reference_that_is_not_the_original_is_refused_at_the_line() {
    let map = example_map();
    let text = "G21 G90 F500\nG0 X0 Y0 Z0\nG1 X10\nG1 Y10\nM2\n";
    let other = "G21 G90 F500\nG0 X0 Y0 Z0\nG1 X10\nM2\n";
    let err = refusal("p.ngc", text, Some(other), &map);
    assert!(
        err.starts_with("p.ngc:4:") && err.contains("reference"),
        "{err}"
    );
}

fn corpus_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/corpus")
}

/// The work offset that puts the middle of a program's moves at the middle
/// of the example map, or `None` when its moves do not fit the map.
fn centring_offset(text: &str, interp: InterpOptions) -> Result<Option<Vec3>, String> {
    let mut w = walker(text, &setup_at(Vec3::ZERO), interp);
    let (mut lo, mut hi) = (
        Vec3::new(f64::MAX, f64::MAX, f64::MAX),
        Vec3::new(f64::MIN, f64::MIN, f64::MIN),
    );
    while let Some(ev) = w.next_line().map_err(|e| e.to_string())? {
        for m in ev
            .motions
            .iter()
            .filter(|m| matches!(m.source, MotionSource::Program | MotionSource::Cycle))
        {
            for p in [m.start, m.end] {
                for a in 0..3 {
                    lo[a] = lo[a].min(p[a]);
                    hi[a] = hi[a].max(p[a]);
                }
            }
        }
    }
    let travel = volcomp_core::example::TRAVEL_MM;
    let mut g54 = Vec3::ZERO;
    for a in 0..3 {
        if hi[a] - lo[a] > travel[a] - 2.0 {
            return Ok(None);
        }
        g54[a] = 0.5 * travel[a] - 0.5 * (lo[a] + hi[a]);
    }
    Ok(Some(g54))
}

/// Checks the facts on one bundled program; `false` when it does not read
/// or is larger than the map (not simulated).
fn check_corpus_program(path: &Path, map: &AxisTableMap) -> bool {
    let name = path.file_name().unwrap().to_string_lossy().to_string();
    let text = String::from_utf8_lossy(&std::fs::read(path).unwrap()).into_owned();
    // Programs written with absolute arc centres are read as such.
    let mut found = None;
    for interp in [
        InterpOptions::default(),
        InterpOptions {
            absolute_arc_centers: true,
            ..InterpOptions::default()
        },
    ] {
        if let Ok(offset) = centring_offset(&text, interp) {
            found = Some((offset, interp));
            break;
        }
    }
    let Some((Some(g54), interp)) = found else {
        eprintln!("{name}: not simulated (does not read, or is larger than the map)");
        return false;
    };
    let (before, after) = check(&name, &text, map, &setup_at(g54), interp, false);
    eprintln!(
        "{name}: contour RMS {:.3} → {:.3} µm, max {:.3} → {:.3} µm; point RMS {:.3} → {:.3} µm",
        before.contour_rms_um,
        after.contour_rms_um,
        before.contour_max_um,
        after.contour_max_um,
        before.point_rms_um,
        after.point_rms_um
    );
    true
}

#[test]
fn every_corpus_program_satisfies_the_facts() {
    // Some programs set their own work offsets (G10) and leave the map's
    // range: the error is held at the table ends there, which keeps it
    // within the same bound.
    let mut map = example_map();
    map.clamp = true;
    let mut entries: Vec<_> = std::fs::read_dir(corpus_dir())
        .expect("tests/corpus")
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e != "md"))
        .collect();
    // The programs are independent: checked on every core (the test is the
    // longest of the suite), each thread taking the next program, the
    // largest first so that no thread is left with a long one at the end.
    entries.sort_by_key(|p| std::cmp::Reverse(std::fs::metadata(p).map_or(0, |m| m.len())));
    let next = std::sync::atomic::AtomicUsize::new(0);
    let checked = std::sync::Mutex::new(Vec::new());
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get().min(4));
    std::thread::scope(|scope| {
        for _ in 0..threads {
            scope.spawn(|| loop {
                let k = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let Some(path) = entries.get(k) else { break };
                if check_corpus_program(path, &map) {
                    checked.lock().unwrap().push(path.clone());
                }
            });
        }
    });
    let checked = checked.into_inner().unwrap();
    // Every bundled program but one that the interpreter refuses reads.
    assert!(checked.len() >= 10, "only {checked:?}");
}

#[test]
fn without_trace_comments_the_order_of_the_blocks_pairs_or_the_program_is_refused() {
    let map = example_map();
    let setup = setup_at(Vec3::new(300.0, 200.0, 150.0));
    let interp = InterpOptions::default();
    let text = "G21 G90 F500\nG0 X0 Y0 Z0\nG1 X10.5 Y3\nG1 Y20\nG1 X-7 Z-2\nG1 X0 Y0 Z0\nM2\n";
    // One line per block (no splits, no take-ups): the order pairs them,
    // with exactly the figures of the traced program.
    let plain = CompensateOptions {
        segmentation: Segmentation::Off,
        take_up: false,
        ..Default::default()
    };
    let untraced = |options: CompensateOptions| {
        let options = CompensateOptions {
            trace_comments: false,
            ..options
        };
        compensate(text, &map, &setup, interp, &options).0
    };
    let (traced, _) = compensate(text, &map, &setup, interp, &plain);
    let untraced_plain = untraced(plain);
    let a = simulate(&traced, Some(text), &map, &setup, interp);
    let b = simulate(&untraced_plain, Some(text), &map, &setup, interp);
    assert_eq!(a.report, b.report);
    // Split lines without tags cannot be paired: refused, not misjudged.
    let split = untraced(CompensateOptions::default());
    let err = refusal("c.ngc", &split, Some(text), &map);
    assert!(
        err.starts_with("c.ngc:") && err.contains("without trace comments"),
        "{err}"
    );
}

/// A cutter-compensated helix down in an o-word loop whose body has one
/// moving line (as LinuxCNC's mmount.ngc mills its holes): every run of
/// that line has the same line number and, under compensation, no written
/// line of its own, so the compensated program's tagged lines are paired
/// with the run whose motions they lie on. Judged against the original
/// (not refused), the compensated path is ten times closer to it than the
/// original run uncompensated.
#[test]
fn a_compensated_loop_of_one_line_is_paired_run_by_run() {
    // In G61: every take-up exact (under G64 a fold may leave up to the
    // reversal value).
    let text = "G21 G90 G17 G61 F500\n#1 = 0\nG0 X30 Y10 Z1\nG41.1 D4 G0 X20 Y0\n\
                o100 while [#1 GT -4]\nG3 X20 Y0 I-20 J0 Z[#1 - 1]\n#1 = [#1 - 1]\n\
                o100 endwhile\nG3 X20 Y0 I-20 J0\nG40 G0 X30 Y10\nG0 Z10\nM2\n";
    let map = example_map();
    let setup = setup_at(Vec3::new(300.0, 200.0, 150.0));
    let interp = InterpOptions::default();
    let (out, _) = compensate(text, &map, &setup, interp, &CompensateOptions::default());
    let before = simulate(text, None, &map, &setup, interp).report;
    let after = simulate(&out, Some(text), &map, &setup, interp).report;
    assert!(before.contour_rms_um > 1.0, "{before:?}");
    assert!(
        after.contour_rms_um < before.contour_rms_um / 10.0
            && after.contour_max_um < before.contour_max_um / 5.0,
        "before {before:?}\nafter {after:?}\n{out}"
    );
}
