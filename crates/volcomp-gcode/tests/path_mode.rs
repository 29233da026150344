//! The path-control mode (G61, G61.1, G64 P Q) each motion carries, as
//! LinuxCNC 2.9 reads it (`Interp::convert_control_mode`,
//! src/emc/rs274ngc/interp_convert.cc). The expected tolerances are what
//! LinuxCNC's own `rs274` prints for the same program (its canon calls
//! `SET_MOTION_CONTROL_MODE(mode, P)` and `SET_NAIVECAM_TOLERANCE(Q)`, in
//! program units):
//!
//! ```text
//! G21 G64 P0.005          CANON_CONTINUOUS, 0.005000   NAIVECAM 0.0050
//! G20 G64 P0.001 Q0.002   CANON_CONTINUOUS, 0.001000   NAIVECAM 0.0020
//! G61                     CANON_EXACT_PATH
//! G61.1                   CANON_EXACT_STOP
//! G64                     CANON_CONTINUOUS, 0.000000   NAIVECAM 0.0000
//! G64 Q0.003              CANON_CONTINUOUS, 0.000000   NAIVECAM 0.0030
//! G64 P-1                 CANON_CONTINUOUS, 0.000000   NAIVECAM 0.0000
//! ```
//!
//! and for `G61 G1 X1`, `M70`, `G64 P0.01 G1 X2`, `M72`, `G1 X3`: EXACT_PATH
//! before the first feed, CONTINUOUS 0.01 before the second and EXACT_PATH
//! again (M72's restore) before the third.

use std::io::Cursor;
use volcomp_gcode::{InterpOptions, Motion, PathMode, Setup, Walker};

fn modes(program: &str) -> Vec<PathMode> {
    let mut w = Walker::new(
        Cursor::new(program.as_bytes().to_vec()),
        Some("t.ngc".into()),
        Setup::default(),
        InterpOptions::default(),
    );
    let mut motions: Vec<Motion> = Vec::new();
    while let Some(ev) = w.next_line().unwrap() {
        motions.extend_from_slice(ev.motions);
    }
    motions.iter().map(|m| m.path_mode).collect()
}

fn blend(p: f64, q: f64) -> PathMode {
    PathMode::Blend {
        tolerance_mm: p,
        naive_cam_mm: q,
    }
}

fn close(a: PathMode, b: PathMode) {
    match (a, b) {
        (
            PathMode::Blend {
                tolerance_mm: p1,
                naive_cam_mm: q1,
            },
            PathMode::Blend {
                tolerance_mm: p2,
                naive_cam_mm: q2,
            },
        ) => assert!(
            (p1 - p2).abs() < 1e-12 && (q1 - q2).abs() < 1e-12,
            "{a:?} {b:?}"
        ),
        _ => assert_eq!(a, b),
    }
}

#[test]
fn each_motion_carries_the_mode_rs274_reports() {
    let m = modes(
        "G21 G90 G1 X0 Y0 Z0 F100\n\
         G64 P0.005\nG1 X1\n\
         G20\nG64 P0.001 Q0.002\nG1 X0.1\n\
         G61\nG1 X0.2\n\
         G61.1\nG1 X0.3\n\
         G64\nG1 X0.4\n\
         G64 Q0.003\nG1 X0.5\n\
         G64 P-1\nG1 X0.6\nM2\n",
    );
    let expected = [
        // LinuxCNC starts in G64 without P.
        blend(0.0, 0.0),
        blend(0.005, 0.005),
        // Program units (inch) at the time of G64, in mm.
        blend(0.0254, 0.0508),
        PathMode::ExactPath,
        PathMode::ExactStop,
        blend(0.0, 0.0),
        blend(0.0, 0.0762),
        blend(0.0, 0.0),
    ];
    assert_eq!(m.len(), expected.len());
    for (a, b) in m.into_iter().zip(expected) {
        close(a, b);
    }
}

#[test]
fn a_mode_on_the_motion_line_applies_to_its_motion_and_m72_restores_it() {
    let m = modes(
        "G21 G90 G1 X0 Y0 Z0 F100\n\
         G61 G1 X1\n\
         M70\n\
         G64 P0.01 G1 X2\n\
         M72\n\
         G1 X3\nM2\n",
    );
    close(m[1], PathMode::ExactPath);
    close(m[2], blend(0.01, 0.01));
    close(m[3], PathMode::ExactPath);
}
