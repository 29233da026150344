//! Free-form surface compensation from on-machine probing: the mirror method.
//!
//! A semi-finishing pass should leave the stock `D` on the ideal finishing
//! surface `S_F`; the part is probed on the machine, and the finishing pass is
//! corrected so that it removes what the probing found:
//!
//! * For the ideal point `P_P` (closest point of `S_F` to the measured point
//!   `P_R`, outward unit normal `V_N`), the mirror surface lies halfway
//!   between `S_F` and the ideal semi-finished surface:
//!   `P_M = P_P + (D/2)·V_N`.
//! * `D_M = (P_R − P_M)·V_N` is the signed distance of the measured point to
//!   the mirror surface, and the compensation point is `P_C = P_R − 2·D_M·V_N`,
//!   the reflection of `P_R` in the mirror surface. Material left (undercut)
//!   becomes a target below `S_F` (overcut) and vice versa, so a finishing
//!   pass that repeats the machine's error lands on `S_F`.
//! * A smooth surface is fitted through the compensation points. It is kept
//!   as a normal offset of the nominal surface,
//!   `S_C(u, v) = S_F(u, v) + δ(u, v)·n(u, v)`, with `δ` a bicubic B-spline
//!   over `S_F`'s parameters through the heights `δ_k = (P_C − P_P)·V_N`
//!   (least squares to a stated tolerance, or interpolation of a probe grid).
//!   `S_C` passes through (within the tolerance of) every `P_C`; fitting
//!   the points in space instead would add the shape error of a new surface
//!   through a coarse probe grid (micrometres on curved parts) to the µm-size
//!   correction.
//! * Every cutter-location (CL) point of a ball-end finishing program is moved
//!   by `δ·n` at its contact point (the foot of the ball centre on `S_F`) and
//!   written back through the G-code engine, byte for byte unchanged
//!   elsewhere (see [`compensate_finishing`]).
//!
//! Frames and units: the nominal surface, the probe points and the finishing
//! program's coordinates share one frame, the *program frame* (work
//! coordinates, mm). Deviations are in µm, positive away from the material
//! (ISO: actual − nominal along the outward normal; positive = material
//! left, an undercut). The finishing program's tool axis is +Z.
//!
//! Metrics ([`DeviationStats`]): mean, standard deviation, and the profile
//! error of ISO 1101 style: the width of the zone centred on the nominal
//! surface that contains every deviation, `2·max|d|`; the range `max − min`
//! (the zone allowed to float) is reported too.
//!
//! Where each part lives:
//!
//! * `io`: the input files — probe points and grid nominals (CSV, through
//!   [`crate::io::table`]), B-spline nominals (TOML), the format dispatch
//!   ([`read_nominal`], [`NominalFormat`]).
//! * `nominal`: the ideal surface `S_F` ([`NominalSurface`]): material side,
//!   regularity, concave radius, closest points.
//! * `method`: matching, mirror and compensation points ([`mirror`],
//!   [`match_points`]), the deviation field and the result types.
//! * `fit`: least squares with the control net chosen by leave-one-out, or
//!   interpolation of a probe grid.
//! * `compensated`: `S_C = S_F + δ·n` as grid nodes and as a B-spline.
//! * `finishing`: the ball-end finishing program's rewrite
//!   ([`compensate_finishing`]).
//! * `stats`: [`DeviationStats`].
//! * [`report`]: the summary, the CSV report, the JSON structures and the
//!   compensated surface files as text.
//! * [`advice`]: the help texts of refusals that point at an option.

pub mod advice;
mod compensated;
mod finishing;
mod fit;
mod io;
mod method;
mod nominal;
pub mod report;
mod stats;

pub use compensated::{CompensatedSurface, GridNode};
pub use finishing::{
    compensate_finishing, program_frame_offset, BallTool, ClPoint, Contact, FinishingOptions,
    FinishingSummary, SurfaceModel,
};
pub use io::{
    read_bspline_toml, read_grid_csv, read_nominal, read_probe_points, write_bspline_toml,
    NominalFormat, PointGrid, ProbePoint,
};
pub use method::{
    match_points, mirror, DeviationField, FitInfo, FitKind, FitMethod, MatchedPoint, MirrorOptions,
    MirrorResult, MIN_POINTS,
};
pub use nominal::{Foot, MaterialSide, NominalSurface};
pub use stats::{deviation_stats, DeviationStats};

use crate::error::CompensationError;
use volcomp_gcode::{GcodeError, Vec3};

pub use crate::error::domain::MirrorError;

impl From<GcodeError> for MirrorError {
    fn from(e: GcodeError) -> Self {
        MirrorError::Program(CompensationError::Gcode(e))
    }
}

pub(crate) fn method_error(message: impl Into<String>, help: impl Into<String>) -> MirrorError {
    MirrorError::Method {
        message: message.into(),
        help: help.into(),
    }
}

pub(crate) fn v3(a: [f64; 3]) -> Vec3 {
    Vec3::from_array(a)
}

pub(crate) fn fmt_point(p: Vec3) -> String {
    format!("({:.4}, {:.4}, {:.4})", p.x, p.y, p.z)
}

/// Shared fixtures of the mirror method's unit tests.
#[cfg(test)]
pub(crate) mod test_support {
    use crate::surface::bspline::{self, BSplineSurface, Parameterization};

    /// A flat 30 × 30 mm square at z = 0 (bicubic, 4 × 4 control points).
    pub(crate) fn plane_surface() -> BSplineSurface<3> {
        let pts: Vec<[f64; 3]> = (0..16)
            .map(|k| {
                let (i, j) = (k / 4, k % 4);
                [i as f64 * 10.0, j as f64 * 10.0, 0.0]
            })
            .collect();
        bspline::interpolate(&pts, 4, 4, 3, 3, &Parameterization::Uniform).unwrap()
    }
}
