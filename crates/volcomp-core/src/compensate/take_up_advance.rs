//! Under G61, a take-up block whose switch moves an axis' correction
//! against that axis' motion ends a little way along the line after the
//! corner, where the axis' own motion has caught the step up
//! (docs/compensation.md, "A correction that jumps against an axis'
//! motion: the take-up ends along the line").
//!
//! At a G61 corner the machine stops and a take-up block carries the
//! reversing axes across their dead bands ([`super::points`]
//! `take_up_command`). Each switch also moves the tool across the other
//! axes by the switching axis' straightness (docs/design.md, "The
//! 21-component model": an axis-table map's straightness may differ per
//! direction). Where that step runs against an axis' new motion, the axis
//! cannot follow it on the block: an axis that keeps its direction would
//! have to reverse, cross its band and reverse again; a reversing axis
//! whose command turns back by less than its band never leaves its old
//! flank (the dead band of docs/compensation.md, "Take-ups folded into
//! the move"). The tool then starts the line off by the step, which on a
//! map whose straightness switches by micrometres (bench/coarse_map.py:
//! ±1–2.5 µm) is micrometres.
//!
//! The line's own motion does the rest. An axis moving along the line at
//! direction cosine `u_a` (in its new direction) gains `u_a · d` of
//! command over `d` mm of path, so a step `m_a` against its motion is
//! caught up once the path has advanced `d_a = m_a / u_a`. The take-up
//! block therefore ends at the point `d = max_a d_a` along the line,
//! solved in the new state: every reversing axis has crossed its band,
//! every other axis has moved only in its own direction, and the tool is
//! on the path when the block ends and on the rest of the line. Only
//! lines, and only where every such axis moves along the line: a static
//! axis' step is the existing take-up's (it reverses).
//!
//! The machine stands on the take-up block anyway (G61: LinuxCNC's
//! tp.c `tpSetupTangent` stops at a corner that is not tangent), so the
//! block only grows by `d` (tens of micrometres, capped at
//! [`MAX_ADVANCE_MM`]), run from rest to rest.

use crate::compensate::solve::{solve_fixed_in, Method, PointSolution};
use crate::error::ModelError;
use crate::model::{AxisCells, Directions, ErrorModel};
use volcomp_gcode::Vec3;

use super::frame::Frame;

/// The least step against an axis' motion worth an advance (mm): the G61
/// contour tolerance (`options::DEFAULT_EXACT_CONTOUR_TOLERANCE_UM`,
/// 0.05 µm), as for a stand ([`super::take_up_stand`]).
const LEAST_STEP_MM: f64 = 0.05e-3;

/// How far past the step the advance goes (mm of command): one step of
/// five decimals, so that the quantized command does not fall short of it.
const MARGIN_MM: f64 = 0.01e-3;

/// The longest advance (mm of path). A take-up block of this length from
/// rest to rest takes `2·√(d/a)` = 20 ms at 1,000 mm/s² (bench/cycle_time's
/// machine), against 7 ms for a 12 µm band alone; the line after it, which
/// starts from rest either way, is shorter by `d`. Beyond it the stand on
/// the line ([`super::take_up_stand`]) is left to do the work.
pub(super) const MAX_ADVANCE_MM: f64 = 0.1;

/// The smallest direction cosine an axis may catch its step up with: a
/// step of 1 µm then needs 0.02 mm of path.
const LEAST_COSINE: f64 = 0.02;

/// How far along the line (mm of path) the take-up block must end for
/// every axis to have caught up its step: `q_prev` the command before the
/// block, `sol_start` the new state's solution at the corner, `u` the
/// line's unit direction (axis frame), `s` the new state, `bands_mm` each
/// axis' band to cross (zero for an axis that keeps its direction).
/// `Some(0.0)` where no axis is short of its need by [`LEAST_STEP_MM`];
/// `None` where one is and does not move along the line in its direction.
pub(super) fn advance_needed_mm(
    q_prev: Vec3,
    sol_start: Vec3,
    u: Vec3,
    s: Directions,
    bands_mm: [f64; 3],
) -> Option<f64> {
    let mut d = 0.0_f64;
    for a in 0..3 {
        let sign = s[a].sign();
        let short = bands_mm[a] - (sol_start[a] - q_prev[a]) * sign;
        if short.is_nan() {
            return None;
        }
        if short < LEAST_STEP_MM {
            continue;
        }
        let gain = u[a] * sign;
        if gain.is_nan() || gain < LEAST_COSINE {
            return None;
        }
        d = d.max((short + MARGIN_MM) / gain);
    }
    Some(d)
}

/// The take-up block's end moved `d` along the piece from `t_prev` to
/// `t_end` ([`advance_needed_mm`]), solved in the new state and on the
/// output's grid; `None` where no advance is needed, where it would be
/// longer than [`MAX_ADVANCE_MM`] or leave less than `shortest_mm` of the
/// piece, or where the solved command does not do what it must (every
/// reversing axis across its band, no axis against its direction, none
/// past the piece's end). `q_prev` and `s_old` the command and state
/// before the block, `tu` the take-up as `take_up_command` made it,
/// `point` the solution at `t_end` (its new state and reversing axes).
#[allow(clippy::too_many_arguments)]
#[inline(never)]
pub(super) fn advanced_take_up(
    (cells, model, method): (&mut AxisCells, &dyn ErrorModel, Method),
    (q_prev, s_old): (Vec3, Directions),
    (t_prev, t_end): (Vec3, Vec3),
    point: &PointSolution,
    tu: Vec3,
    shortest_mm: f64,
    frame: &Frame,
) -> Result<Option<Vec3>, ModelError> {
    // Each reversing axis' own lag, as the dead band carries it
    // (points.rs `switch_lags_mm`): the command's travel it must cross.
    let lags = super::points::switch_lags_mm(cells, model, q_prev, s_old, point.s, point.reversed)?;
    let mut bands_mm = [0.0; 3];
    for a in 0..3 {
        if point.reversed[a] {
            bands_mm[a] = (lags[a][a] * point.s[a].sign()).max(0.0);
        }
    }
    let along = t_end - t_prev;
    let len = along.norm();
    if len.is_nan() || len <= 0.0 {
        return Ok(None);
    }
    let u = along * (1.0 / len);
    let s = point.s;
    let sol_start = solve_fixed_in(cells, model, method, t_prev, s, [false; 3], tu)?.q_mm;
    let d = match advance_needed_mm(q_prev, sol_start, u, s, bands_mm) {
        Some(d) if d > 0.0 && d <= MAX_ADVANCE_MM && len - d >= shortest_mm => d,
        _ => return Ok(None),
    };
    let q = solve_fixed_in(
        cells,
        model,
        method,
        t_prev + u * d,
        s,
        [false; 3],
        sol_start,
    )?
    .q_mm;
    let mut q = frame.quantize(q, q_prev);
    for a in 0..3 {
        let sign = s[a].sign();
        // An axis the block would take past the piece's end (a static
        // axis whose solution drifts by a fraction of the contour
        // tolerance along the piece) stops at that end, as a take-up
        // never passes the segment's own command (points.rs).
        let past = (q[a] - point.q_mm[a]) * sign;
        if past > 0.0 {
            if past > LEAST_STEP_MM {
                return Ok(None);
            }
            q[a] = point.q_mm[a];
        }
        let moved = (q[a] - q_prev[a]) * sign;
        if moved.is_nan() || moved < bands_mm[a] - LEAST_STEP_MM {
            return Ok(None);
        }
    }
    // Kept only where the tool leaves the path on the way by less than
    // the block at the corner leaves it off at its end, the offset the
    // advance is for (the dead band's offsets over a block, points.rs
    // `fold_deviation_from_mm`: where the reversing axes' bands are
    // crossed at different rates, a block leaves the path on its way too,
    // and that the advance does not remove).
    // What the block at the corner leaves counts its end too: where its
    // command stops short of the new state's solution across the line
    // (an axis that keeps its direction cannot step back), the tool starts
    // the line off by that much and the line's own end takes the whole
    // line to bring it back.
    let on_the_block =
        super::points::fold_deviation_from_mm(&lags, q_prev, tu, Vec3::ZERO, (1.0, Vec3::ZERO));
    let short = tu - sol_start;
    let left_at_corner = on_the_block.max((short - u * short.dot(u)).norm());
    let on_the_way = super::points::fold_deviation_mm(&lags, q_prev, q, u * d);
    Ok((on_the_way < left_at_corner + LEAST_STEP_MM).then_some(q))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compensate::test_support::um;
    use crate::model::Direction;

    #[test]
    fn a_step_against_an_axis_motion_is_caught_up_along_the_line() {
        // bench/eval set c's chords20_cw on the coarse map at X's reversal
        // (X 263.9467, Y 198.7798, judge.py's map): X reverses (band
        // 12.31 µm) and so does Z (11.49 µm); Z's switch moves X's
        // correction by +3.00 µm, against X's new motion (−X). By hand:
        // X's command must travel 12.31 µm but the new state's solution at
        // the corner lies 9.31 µm back, 3.00 µm short; the next chord runs
        // at u = (−0.2419, −0.9703), so X catches 3.00 µm up after
        // (3.00 + 0.01) / 0.2419 = 12.44 µm of path. Y keeps its direction
        // (−Y) and its solution does not move; Z crosses 14.49 µm.
        let s = [Direction::Reverse, Direction::Reverse, Direction::Reverse];
        let q_prev = um(0.0, 0.0, 0.0);
        let sol = um(-9.31, 0.0, -14.49);
        let u = Vec3::new(-0.2419, -0.9703, 0.0);
        let bands = [12.31e-3, 0.0, 11.49e-3];
        let d = advance_needed_mm(q_prev, sol, u, s, bands).unwrap();
        assert!((d - 3.01e-3 / 0.2419).abs() < 1e-12, "{d}");
        // Y short by 4 µm (the switch of X alone, Z kept): caught up after
        // (4 + 0.01) / 0.9703 µm, X then short by nothing.
        let sol_y = um(-12.31, 4.0, -14.49);
        let d_y = advance_needed_mm(q_prev, sol_y, u, s, bands).unwrap();
        assert!((d_y - 4.01e-3 / 0.9703).abs() < 1e-12, "{d_y}");
        // Every axis where it must be: no advance.
        assert_eq!(
            advance_needed_mm(q_prev, um(-12.31, -1.0, -11.49), u, s, bands),
            Some(0.0)
        );
        // Short by less than the contour tolerance: none either.
        assert_eq!(
            advance_needed_mm(q_prev, um(-12.27, 0.0, -11.49), u, s, bands),
            Some(0.0)
        );
        // Z short (a static axis: no motion along the line): none possible.
        assert_eq!(
            advance_needed_mm(q_prev, um(-12.31, 0.0, -11.0), u, s, bands),
            None
        );
        // X short but the line runs +X while X reverses to −X: none.
        let back = Vec3::new(0.2419, -0.9703, 0.0);
        assert_eq!(advance_needed_mm(q_prev, sol, back, s, bands), None);
    }
}
