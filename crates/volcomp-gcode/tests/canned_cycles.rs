//! Canned cycles G73 and G83 (peck drilling) with moves derived by hand from
//! LinuxCNC 2.9's `convert_cycle_g73`/`convert_cycle_g83` and `CYCLE_MACRO`
//! (src/emc/rs274ngc/interp_cycles.cc), and the errors LinuxCNC raises for
//! canned cycles, checked against rs274 when it is installed.

use crate::common;
use volcomp_gcode::{GcodeError, Motion, MotionKind};

fn run(program: &str) -> Result<Vec<Motion>, GcodeError> {
    common::motions(program)
}

/// rs274's first message line for `program` (None when not installed).
fn rs274_message(program: &str) -> Option<String> {
    let run = common::rs274(format!("{program}M2\n").as_bytes())?;
    Some(run.message(program).unwrap_or_default())
}

/// (feed?, x, y, z) of each motion of the last `n`.
fn tail(motions: &[Motion], n: usize) -> Vec<(bool, [f64; 3])> {
    motions[motions.len() - n..]
        .iter()
        .map(|m| {
            (
                matches!(m.kind, MotionKind::Feed),
                [m.end.x, m.end.y, m.end.z],
            )
        })
        .collect()
}

fn assert_moves(got: &[(bool, [f64; 3])], want: &[(bool, [f64; 3])]) {
    assert_eq!(got.len(), want.len(), "{got:?}");
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        assert_eq!(g.0, w.0, "move {i}: feed/rapid, {got:?}");
        for k in 0..3 {
            assert!((g.1[k] - w.1[k]).abs() < 1e-9, "move {i}: {g:?} != {w:?}");
        }
    }
}

const R: bool = false;
const F: bool = true;

#[test]
fn g83_pecks_back_to_r_and_down_to_0_254_mm_above_the_last_depth() {
    // Start Z10 above R2: rapid over the hole at Z10, down to R; pecks of
    // Q2 from R: depths 0, -2, -4 (each: feed down, rapid to R, rapid to
    // depth + 0.254), then feed to the bottom -5 and rapid to the initial
    // level 10 (G98).
    let m = run("G21 G17 G90 F100\nG0 X0 Y0 Z10\nG98 G83 X1 Y2 Z-5 R2 Q2\n").unwrap();
    let p = |f, z| (f, [1.0, 2.0, z]);
    assert_moves(
        &tail(&m, 13),
        &[
            p(R, 10.0),
            p(R, 2.0),
            p(F, 0.0),
            p(R, 2.0),
            p(R, 0.254),
            p(F, -2.0),
            p(R, 2.0),
            p(R, -1.746),
            p(F, -4.0),
            p(R, 2.0),
            p(R, -3.746),
            p(F, -5.0),
            p(R, 10.0),
        ],
    );
}

#[test]
fn g73_chip_breaks_0_254_mm_up_and_retracts_to_r_in_g99() {
    // R1, Q1.5: depths -0.5, -2 (feed, rapid up 0.254); -3.5 is not above
    // the bottom -3.5, so the last feed goes to the bottom; G99 retracts
    // to R.
    let m = run("G21 G17 G90 F100\nG0 X0 Y0 Z5\nG99 G73 X3 Y4 Z-3.5 R1 Q1.5\n").unwrap();
    let p = |f, z| (f, [3.0, 4.0, z]);
    assert_moves(
        &tail(&m, 8),
        &[
            p(R, 5.0),
            p(R, 1.0),
            p(F, -0.5),
            p(R, -0.246),
            p(F, -2.0),
            p(R, -1.746),
            p(F, -3.5),
            p(R, 1.0),
        ],
    );
}

#[test]
fn g83_incremental_with_repeats() {
    // G91 from Z10: R = 10 - 7 = 3, bottom = R - 6 = -3; each repeat steps
    // X2 Y1. Pecks of 2.5 from 3: 0.5, -2 (then -4.5 is past the bottom).
    let m = run("G21 G17 G90 F100\nG0 X0 Y0 Z10\nG91 G98 G83 X2 Y1 Z-6 R-7 Q2.5 L2\n").unwrap();
    let hole = |x: f64, y: f64| {
        vec![
            (F, [x, y, 0.5]),
            (R, [x, y, 3.0]),
            (R, [x, y, 0.754]),
            (F, [x, y, -2.0]),
            (R, [x, y, 3.0]),
            (R, [x, y, -1.746]),
            (F, [x, y, -3.0]),
            (R, [x, y, 10.0]),
        ]
    };
    let mut want = vec![(R, [2.0, 1.0, 10.0]), (R, [2.0, 1.0, 3.0])];
    want.extend(hole(2.0, 1.0));
    want.extend([(R, [4.0, 2.0, 10.0]), (R, [4.0, 2.0, 3.0])]);
    want.extend(hole(4.0, 2.0));
    assert_moves(&tail(&m, want.len()), &want);
}

#[test]
fn g83_in_inches_backs_off_0_010_inch() {
    // R0.1 Q0.15: depths -0.05, -0.2; then the bottom -0.3. Each re-entry
    // stops 0.010 in above the last depth.
    let m = run("G20 G17 G90 F10\nG0 X0 Y0 Z1\nG99 G83 X1 Y2 Z-0.3 R0.1 Q0.15\n").unwrap();
    let p = |f, z: f64| (f, [25.4, 50.8, z * 25.4]);
    assert_moves(
        &tail(&m, 10),
        &[
            p(R, 1.0),
            p(R, 0.1),
            p(F, -0.05),
            p(R, 0.1),
            p(R, -0.04),
            p(F, -0.2),
            p(R, 0.1),
            p(R, -0.19),
            p(F, -0.3),
            p(R, 0.1),
        ],
    );
}

fn refused(program: &str, line: u64, column: usize, needle: &str, linuxcnc: &str) {
    let e = run(program).expect_err(program);
    assert_eq!((e.line, e.column), (line, column), "{program}: {e}");
    assert!(
        e.message.to_lowercase().contains(&needle.to_lowercase()),
        "{program}: {e}"
    );
    assert!(!e.help.is_empty(), "{program}: no advice in {e}");
    if let Some(msg) = rs274_message(program) {
        assert!(
            msg.to_lowercase().contains(&linuxcnc.to_lowercase()),
            "{program}: rs274 says {msg:?}"
        );
    }
}

#[test]
fn cycle_errors_are_located_as_linuxcnc_raises_them() {
    let head = "G21 F100\nG0 Z5\n";
    let cases: [(&str, u64, usize, &str); 11] = [
        ("G83 X1 Z-1 R1 Q0\n", 3, 15, "negative or zero q value used"),
        ("G83 X1 Z-1 R1\n", 3, 1, "q word missing with g83"),
        (
            "G81 X1 Z2 R1\n",
            3,
            11,
            "r less than z in cycle in xy plane",
        ),
        (
            "G81 X1 Z-1 R1 L0\n",
            3,
            15,
            "cannot do zero repeats of cycle",
        ),
        ("G84 X1 Z-1 R1\n", 3, 1, "spindle not turning in g84"),
        (
            "M3\nG74 X1 Z-1 R1\n",
            4,
            1,
            "spindle turning clockwise in g74",
        ),
        ("M4\nG74 X1 Z-1 R1 L2\n", 4, 15, "L word with no"),
        ("G86 X1 Z-1 R1 P1\n", 3, 1, "spindle not turning in g86"),
        ("G87 X1 Z-1 R1 I1 J1\n", 3, 1, "k word missing with g87"),
        (
            "G18 G81 X1 Z-1 R1\n",
            3,
            5,
            "y value unspecified in xz plane canned cycle",
        ),
        (
            "G0 X0 Y0\nG91 G81 ^30 Z-1 R-1 L2\n",
            4,
            9,
            "incremental motion with polar coordinates is indeterminate when at the origin",
        ),
    ];
    for (block, line, col, msg) in cases {
        refused(&format!("{head}{block}"), line, col, msg, msg);
    }
}
