//! Splines (G5, G5.1, G5.2/G5.3) and the extra axes A B C U V W, read as
//! LinuxCNC 2.9 reads them. Expected values are derived by hand in each test
//! (Bernstein polynomials, a rational circle, linear interpolation); the
//! end points are also checked against `rs274` by the agreement fixtures
//! `splines_g5.ngc`, `nurbs_g52.ngc` and `extra_axes.ngc`.

use crate::common;
use volcomp_gcode::{GcodeError, Motion, MotionKind, MotionSource, Setup};

fn run(program: &str) -> Result<Vec<Motion>, GcodeError> {
    run_with(program, Setup::default())
}

/// On a machine with all nine axes (the default is X Y Z A B C).
fn run_nine(program: &str) -> Result<Vec<Motion>, GcodeError> {
    let setup = Setup {
        axes: volcomp_gcode::AxisLetters::parse("XYZABCUVW").unwrap(),
        ..Setup::default()
    };
    run_with(program, setup)
}

fn run_with(program: &str, setup: Setup) -> Result<Vec<Motion>, GcodeError> {
    common::motions_with(program, setup)
}

fn spline_chords(motions: &[Motion], line: u64) -> Vec<Motion> {
    motions
        .iter()
        .filter(|m| m.line == line && m.source == MotionSource::Spline)
        .copied()
        .collect()
}

#[test]
fn g5_1_quadratic_lies_on_its_parabola() {
    // Control points (0,0), (2,2), (4,0): x = 4u, y = 4u(1 − u), so
    // y = x − x²/4; the midpoint u = ½ is (2, 1).
    let m = run("G21 G17 F100\nG0 X0 Y0 Z-1\nG5.1 I2 J2 X4 Y0\nM2\n").unwrap();
    let c = spline_chords(&m, 3);
    assert!(c.len() > 10);
    for s in &c {
        assert!(matches!(s.kind, MotionKind::Feed));
        assert!((s.end.y - (s.end.x - s.end.x * s.end.x / 4.0)).abs() < 1e-12);
        assert_eq!(s.end.z, -1.0);
    }
    let last = c.last().unwrap();
    assert_eq!((last.end.x, last.end.y), (4.0, 0.0));
    let top = c.iter().map(|s| s.end.y).fold(0.0, f64::max);
    assert!(top <= 1.0 && top > 1.0 - 1e-4);
    // Chords are within the tolerance: the sagitta of the parabola over a
    // chord spanning Δx is (Δx)²/16 (|y''| = ½).
    for w in c.windows(2) {
        let dx = w[1].end.x - w[0].end.x;
        assert!(dx * dx / 16.0 <= 1e-4 + 1e-15);
    }
}

#[test]
fn g5_without_i_j_continues_the_previous_tangent() {
    // First G5 from (0,0): P = 4, Q = −3 at the end (1,1). The second G5
    // omits I and J, so its first control point is (1,1) − (4,−3) = (−3,4);
    // with P0 Q−3 to (2,2) its third is (2,−1). B(u) = (1−u)³P0 + 3u(1−u)²P1
    // + 3u²(1−u)P2 + u³P3 must hold at every chord end u = k/n.
    let m = run("G21 F100\nG0 X0 Y0\nG5 I0 J3 P4 Q-3 X1 Y1\nG5 P0 Q-3 X2 Y2\nM2\n").unwrap();
    let c = spline_chords(&m, 4);
    let n = c.len();
    let p = [(1.0, 1.0), (-3.0, 4.0), (2.0, -1.0), (2.0, 2.0)];
    for (k, s) in c.iter().enumerate() {
        let u = (k + 1) as f64 / n as f64;
        let b = [
            (1.0 - u).powi(3),
            3.0 * u * (1.0 - u).powi(2),
            3.0 * u * u * (1.0 - u),
            u.powi(3),
        ];
        let x: f64 = (0..4).map(|i| b[i] * p[i].0).sum();
        let y: f64 = (0..4).map(|i| b[i] * p[i].1).sum();
        assert!((s.end.x - x).abs() < 1e-12 && (s.end.y - y).abs() < 1e-12);
    }
    assert_eq!(c[0].start.x, 1.0);
}

#[test]
fn g5_2_rational_quadratic_is_a_quarter_circle() {
    // Weights 1, √½, 1 on (10,0), (10,10), (0,10): the quarter circle of
    // radius 10 about the origin. Every chord end is on it, and every
    // chord's midpoint is within the tolerance (1e-4 mm) inside it.
    let w = std::f64::consts::FRAC_1_SQRT_2;
    let prog =
        format!("G21 F100\nG0 X10 Y0 Z2\nG5.2 X10 Y10 P{w} L3\nX0 Y10 P1\nG5.3\nG1 Z0\nM2\n");
    let m = run(&prog).unwrap();
    let c = spline_chords(&m, 5);
    assert!(c.len() > 4);
    assert!(m
        .iter()
        .all(|x| x.line != 3 && x.line != 4 || x.source != MotionSource::Spline));
    for s in &c {
        assert!((s.end.x.hypot(s.end.y) - 10.0).abs() < 1e-9);
        let mid = (s.start + s.end) * 0.5;
        let sag = 10.0 - mid.x.hypot(mid.y);
        assert!((0.0..=1e-4).contains(&sag), "sagitta {sag}");
        assert_eq!(s.end.z, 2.0);
    }
    assert_eq!(
        (c.last().unwrap().end.x, c.last().unwrap().end.y),
        (0.0, 10.0)
    );
    // The next move starts where the NURBS ended.
    let next = m.iter().find(|x| x.line == 6).unwrap();
    assert_eq!((next.start.x, next.start.y), (0.0, 10.0));
}

#[test]
fn g5_leaves_the_motion_mode_unchanged() {
    // LinuxCNC's convert_motion does not set the motion mode for G5/G5.1:
    // a line of axis words after it is a G0 here.
    let m = run("G21 F100\nG0 X0 Y0\nG5.1 I1 J1 X2 Y0\nX5 Y5\nM2\n").unwrap();
    let last = m.last().unwrap();
    assert!(matches!(last.kind, MotionKind::Rapid));
    assert_eq!(last.source, MotionSource::Program);
}

#[test]
fn spline_refusals_follow_linuxcnc() {
    common::refused(&[
        ("G18 F100\nG5 I0 J1 P1 Q1 X1 Y1\n", "XY plane"),
        ("F100\nG5 I1 P1 Q1 X1 Y1\n", "both I and J"),
        ("F100\nG5 I1 J1 X1 Y1\n", "both P and Q"),
        ("F100\nG5.1 I1 X1 Y1\n", "both I and J"),
        ("F100\nG5 I1 J1 P1 Q1 X1 Y1 Z1\n", "Z word"),
        ("F100\nG5 I1 J1 P1 Q1 X1 Y1 A1\n", "extra axes"),
        ("F100\nG5.3\n", "without a G5.2"),
        ("F100\nG5.2 X1 P1\n", "both X and Y"),
        ("F100\nG5.2 X1 Y1 P1 L4\nX2 Y2 P1\nG5.3\n", "order L = 4"),
        ("F100\nG5.2 X1 Y1 P1\nX2 Y2\n", "positive weight"),
        ("G5.1 I1 J1 X1 Y1\n", "zero feed rate"),
    ]);
}

#[test]
fn extra_axes_are_carried_linearly_and_uncompensated() {
    let m = run_nine(
        "G21 G90 F100\nG0 X0 Y0 Z0\nG1 X10 A90 B-5\nG2 X20 Y0 I5 J0 C30 W2\nG91 G1 A-10 U1\nG20 G1 U1 A1\nM2\n",
    )
    .unwrap();
    assert_eq!(m[1].extra.start, [0.0; 6]);
    assert_eq!(m[1].extra.end, [90.0, -5.0, 0.0, 0.0, 0.0, 0.0]);
    assert!(matches!(m[2].kind, MotionKind::Arc(_)));
    assert_eq!(m[2].extra.end, [90.0, -5.0, 30.0, 0.0, 0.0, 2.0]);
    // Halfway along the arc the extra axes are halfway.
    assert_eq!(m[2].extra.at(0.5), [90.0, -5.0, 15.0, 0.0, 0.0, 1.0]);
    // G91: increments; the tool point does not move.
    assert_eq!(m[3].extra.end, [80.0, -5.0, 30.0, 1.0, 0.0, 2.0]);
    assert_eq!(m[3].start, m[3].end);
    // G20: U in inches (25.4 mm), A in degrees whatever the units.
    assert_eq!(m[4].extra.end, [81.0, -5.0, 30.0, 26.4, 0.0, 2.0]);
}

#[test]
fn extra_axes_refusals() {
    common::refused(&[
        ("G0 X0 Y0 Z0\nG81 X1 Y1 Z-1 R1 A3 F100\n", "canned cycle"),
        ("G10 L2 P1 X0 A10\n", "G10"),
        ("G28 A0\n", "G28"),
    ]);
}

#[test]
fn g92_offsets_the_extra_axes() {
    // At A30, G92 A0 makes the current A program 0: A90 is then A120 on the
    // machine; G92.1 clears it (A90 is A90), G53 ignores it.
    let m = run("G0 X0 A30\nG92 A0\nG0 A90\nG92.1\nG0 A90\nG92 A0\nG53 G0 A10\nM2\n").unwrap();
    let a: Vec<f64> = m.iter().map(|x| x.extra.end[0]).collect();
    assert_eq!(a, [30.0, 120.0, 90.0, 10.0]);
}

#[test]
fn g28_without_words_sends_the_extra_axes_home() {
    // LinuxCNC's G28 without axis words moves every axis to the G28
    // position; volcomp's set-up has none for the extra axes: 0.
    let m = run("G0 X1 A30\nG28\nM2\n").unwrap();
    let last = m.last().unwrap();
    assert_eq!(last.extra.end, [0.0; 6]);
    assert_eq!(m[m.len() - 2].extra.end[0], 30.0);
}

/// rs274's refusal message for `program`, `None` when it accepts it or is
/// not installed (then only volcomp's side is checked).
fn rs274_refusal(program: &str) -> Option<String> {
    common::rs274(format!("{program}M2\n").as_bytes())?.message(program)
}

#[test]
fn refusals_that_linuxcnc_shares_are_refused_by_rs274_too() {
    // (program, volcomp's message contains, rs274's message contains)
    let cases = [
        (
            "G18 F100\nG5 I0 J1 P1 Q1 X1 Y1\n",
            "XY plane",
            "Splines must be in the XY plane",
        ),
        (
            "F100\nG5 I1 P1 Q1 X1 Y1\n",
            "both I and J",
            "Must specify both I and J, or neither",
        ),
        (
            "F100\nG5 I1 J1 X1 Y1\n",
            "both P and Q",
            "Must specify both P and Q with G5",
        ),
        (
            "F100\nG5.1 I1 X1 Y1\n",
            "both I and J",
            "Must specify both I and J with G5.1",
        ),
        (
            "F100\nG5 I1 J1 P1 Q1 X1 Y1 Z1\n",
            "Z word",
            "Splines may not have motion in Z",
        ),
        (
            "F100\nG5 I1 J1 P1 Q1 X1 Y1 A1\n",
            "extra axes",
            "Splines may not have motion in Z",
        ),
        (
            "F100\nG5.3\n",
            "without a G5.2",
            "Cannot use G5.3 without G5.2 first",
        ),
        (
            "F100\nG5.2 X1 P1\n",
            "both X and Y",
            "You must specify both X and Y",
        ),
        (
            "F100\nG5.2 X1 Y1 P1 L4\nX2 Y2 P1\nG5.3\n",
            "order L = 4",
            "at least equal to the order L = 4",
        ),
        (
            "F100\nG5.2 X1 Y1 P1\nX2 Y2\n",
            "positive weight",
            "Must specify positive weight P",
        ),
        (
            "G5.1 I1 J1 X1 Y1\n",
            "zero feed rate",
            "Cannot make arc with zero feed rate",
        ),
        (
            "G0 X0 Y0 Z0\nG81 X1 Y1 Z-1 R1 A3 F100\n",
            "canned cycle",
            "Cannot put an a in canned cycle",
        ),
        ("M10\n", "unknown M code", "Unknown m code used"),
        ("M200\n", "unknown M code", "M-code greater than 199"),
        ("M150\n", "M100–M199", "Unknown m code used"),
        (
            "M3 M4\n",
            "same modal group",
            "Two m codes used from same modal group",
        ),
        (
            "M7 M8\n",
            "same modal group",
            "Two m codes used from same modal group",
        ),
        ("M72\n", "M72 without a state", "Cannot restore context"),
        ("G999\n", "not a G code", "G-code out of range"),
    ];
    for (prog, ours, theirs) in cases {
        let e = run(prog).expect_err(prog);
        assert!(e.to_string().contains(ours), "{prog}: {e}");
        if let Some(msg) = rs274_refusal(prog) {
            assert!(msg.contains(theirs), "{prog}: rs274 says {msg:?}");
        } else if ["/usr/bin/rs274", "/usr/local/bin/rs274"]
            .iter()
            .any(|p| std::path::Path::new(p).exists())
        {
            panic!("{prog}: rs274 accepts it");
        }
    }
}

#[test]
fn m70_m72_restore_and_what_stays_refused() {
    // M72 restores G91 → G90 and F: X10 is absolute again.
    let m = run("G21 G90 F100\nG0 X1\nM70\nG91 F50\nM72\nG1 X10\nM2\n").unwrap();
    assert_eq!(m.last().unwrap().end.x, 10.0);
    assert_eq!(m.last().unwrap().feed, 100.0);
    // M73 at the top level stores the state (M72 restores it), as LinuxCNC.
    let m = run("G21 G90 F100\nM73\nG91\nM72\nG0 X3\nM2\n").unwrap();
    assert_eq!(m.last().unwrap().end.x, 3.0);
    common::refused(&[
        ("M70\nG91\nM72 G0 X1\n", "own"),
        ("M70\nG43 H0\nG92 X1\nM72\n", "G92"),
    ]);
}

#[test]
fn accepted_here_as_in_rs274() {
    // Programs LinuxCNC runs that volcomp runs too.
    for prog in [
        "G21 F100\nG0 X0 Y0 Z0\nG1 X1 A10 B2 C3\nG2 X2 Y1 I1 J0 A20\n",
        "G21 F100\nG0 X0 Y0\nG5 I0 J1 P1 Q-1 X2 Y0\nX3\n",
        "G21 F100\nG0 X0 Y0\nG5.2 P2 L4\nX1 Y1 P1\nX2 Y1 P1\nX3 Y0 P1\nG5.3\n",
        "M62 P0\nM48\nM53 P1\nM19\nM61 Q1\n",
    ] {
        run(prog).unwrap_or_else(|e| panic!("{prog}: {e}"));
        if let Some(msg) = rs274_refusal(prog) {
            panic!("{prog}: rs274 refuses it: {msg}");
        }
    }
}

#[test]
fn words_of_axes_the_machine_lacks_are_refused_as_linuxcnc_refuses_them() {
    // The default machine is rs274's X Y Z A B C: U is refused at its column.
    let e = run("G21 G90 F100\nG1 X1 U2\nM2\n").unwrap_err();
    assert_eq!((e.line, e.column), (2, 7), "{e}");
    assert!(e.message.contains("Bad character 'u' used"), "{e}");
    assert!(e.help.contains("axes = \"XYZABCU\""), "{e}");
    // A machine of X, Y, Z alone refuses A too; one with U accepts it.
    let xyz = Setup {
        axes: volcomp_gcode::AxisLetters::parse("XYZ").unwrap(),
        ..Setup::default()
    };
    assert!(run_with("G21 F100\nG1 X1 A2\nM2\n", xyz).is_err());
    assert!(run_nine("G21 F100\nG1 X1 U2\nM2\n").is_ok());
}
