//! Under G61, an axis that a take-up block leaves ahead of its new target
//! stands on the line after it until the target catches up
//! (docs/compensation.md, "An axis left ahead by a take-up block stands").
//!
//! A reversing axis' switch moves the other axes' errors too (its
//! straightness across them: the shop map's Z switch moves X by
//! 0.33 µm). On the take-up block the other axes follow that step only in
//! their own direction ([`super::points`] `take_up_command`): an axis
//! whose new target lies behind its command would have to reverse, cross
//! its own band of several micrometres and reverse again as its target
//! moves on, so its command stays where it is and the tool starts the
//! next piece off by the step. The piece's end is solved in the new state,
//! so the command written to it runs from the held value to the target
//! there, and the tool's offset fades linearly over the whole piece (10 mm
//! on the shop map's zigzag_y, 85 % of its band mean square; bench/eval
//! judge.py). Standing until the target has caught up and then following
//! it leaves the same offset at the piece's start but fades it over only
//! the share `f` of the piece the target needs: the mean square of the
//! piece falls to `f` of what it was. The machine stands on the take-up
//! block anyway (G61); the target inserted at `f` turns the path by the
//! axis' drift alone (tenths of a micrometre per millimetre), far below
//! the planner's tangency tolerance.

use crate::compensate::solve::{solve_fixed_in, PointSolution};
use crate::error::ModelError;
use crate::model::{AxisCells, Directions, ErrorModel};
use volcomp_gcode::Vec3;

/// The least offset (mm) worth a target of its own: the G61 contour
/// tolerance (`options::DEFAULT_EXACT_CONTOUR_TOLERANCE_UM`, 0.05 µm).
const LEAST_OFFSET_MM: f64 = 0.05e-3;

/// How far past its command the target is at the inserted point (mm): one
/// step of five decimals, so that its solution there, quantized, does not
/// fall behind the command (which would read as the axis reversing).
const MARGIN_MM: f64 = 0.01e-3;

/// [`stand_share`] on the piece from `t_prev` to `t_end` (run at
/// `v_mm_s`) after the take-up `tu`, `point` the solution at `t_end`: the
/// new state's solution at `t_prev` solved here, and the share kept only
/// where it leaves both parts of the piece at least a smooth ramp's piece
/// long (`points::shortest_ramp_piece_mm`: the planner runs them at the
/// feed). Not inlined: it runs only under G61 on lines, and its code kept
/// apart leaves the walk over targets as it was.
#[inline(never)]
pub(super) fn stand_share_on_piece(
    (cells, model, options): (&mut AxisCells, &dyn ErrorModel, &super::CompensateOptions),
    (t_prev, t_end, v_mm_s): (Vec3, Vec3, f64),
    tu: Vec3,
    point: &PointSolution,
) -> Result<Option<f64>, ModelError> {
    let shortest = super::points::shortest_ramp_piece_mm(options, v_mm_s);
    let len = (t_end - t_prev).norm();
    if len.is_nan() || len < 2.0 * shortest {
        return Ok(None);
    }
    let sol_start = solve_fixed_in(
        cells,
        model,
        options.method,
        t_prev,
        point.s,
        [false; 3],
        tu,
    )?
    .q_mm;
    Ok(
        stand_share(tu, sol_start, point.q_mm, point.s, point.reversed)
            .filter(|f| f * len >= shortest && (1.0 - f) * len >= shortest),
    )
}

/// The share of the piece after a take-up block at which every axis the
/// block left ahead of its new target has been caught up: `tu` the
/// take-up's command, `sol_start` the new state's solution at the piece's
/// start and `sol_end` at its end (the solution runs linearly between
/// them: the piece lies between two table points), `s` the new state and
/// `reversed` the reversing axes (their commands are the take-up's own).
/// `None` where no axis is ahead of its target by [`LEAST_OFFSET_MM`], or
/// one such axis' target does not catch it up inside the piece.
pub(super) fn stand_share(
    tu: Vec3,
    sol_start: Vec3,
    sol_end: Vec3,
    s: Directions,
    reversed: [bool; 3],
) -> Option<f64> {
    let mut share: Option<f64> = None;
    for a in (0..3).filter(|a| !reversed[*a]) {
        let sign = s[a].sign();
        let ahead = (tu[a] - sol_start[a]) * sign;
        if ahead.is_nan() || ahead < LEAST_OFFSET_MM {
            continue;
        }
        let gain = (sol_end[a] - sol_start[a]) * sign;
        let f = (ahead + MARGIN_MM) / gain;
        if !(f > 0.0 && f < 1.0) {
            return None;
        }
        share = Some(share.map_or(f, |g| g.max(f)));
    }
    share
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compensate::test_support::um;
    use crate::model::Direction;

    #[test]
    fn an_axis_left_ahead_stands_until_its_target_catches_up() {
        // zigzag_y on the shop map (L8, the Z take-up at Y −10, judge.py's
        // map at X 238 Y 190 Z 149.7): Z's switch moves X's error by
        // +0.329 µm, X moving forward is left 0.33 µm ahead of its new
        // target, which rises 0.81 µm over the 10 mm piece to Y 0. By hand
        // it catches up at (0.33 + 0.01)/0.81 = 0.4198 of the piece.
        let s = [Direction::Forward; 3];
        let tu = um(0.0, 0.0, 6.84);
        let start = um(-0.33, 0.0, 6.84);
        let end = um(0.48, 10_000.0, 8.23);
        let f = stand_share(tu, start, end, s, [false, false, true]).unwrap();
        assert!((f - 0.34 / 0.81).abs() < 1e-12, "{f}");
        // Moving backward the same in mirror.
        let back = [Direction::Reverse, Direction::Forward, Direction::Forward];
        let m = |v: Vec3| Vec3::new(-v.x, v.y, v.z);
        let g = stand_share(m(tu), m(start), m(end), back, [false, false, true]).unwrap();
        assert!((g - f).abs() < 1e-12, "{g}");
        // Left behind (its target ahead): it follows on the block, none.
        assert_eq!(
            stand_share(tu, um(0.33, 0.0, 6.84), end, s, [false, false, true]),
            None
        );
        // Ahead by less than the contour tolerance: none.
        assert_eq!(
            stand_share(tu, um(-0.04, 0.0, 6.84), end, s, [false, false, true]),
            None
        );
        // Its target not caught up inside the piece (rising 0.2 µm only).
        assert_eq!(
            stand_share(
                tu,
                start,
                um(-0.13, 10_000.0, 8.23),
                s,
                [false, false, true]
            ),
            None
        );
        // A reversing axis is the take-up's own: never counted.
        assert_eq!(stand_share(tu, start, end, s, [true, false, true]), None);
    }
}
