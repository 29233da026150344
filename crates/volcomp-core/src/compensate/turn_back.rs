//! G64 without P: a reversal that the next target turns back is held
//! (docs/compensation.md, "A reversal the next point turns back is held
//! (G64)").
//!
//! Under G64 without P a reversal is folded into the move (the tool may
//! leave the path by the axis' reversal value at the reversal) and held
//! only where the fold would kink the path (solve.rs
//! `hold_small_reversals`, points.rs). A reversal forced by a change
//! smaller than the axis' band, whose command the very next target of the
//! same move asks to turn back, crosses the band twice for nothing: the
//! carriage moves across the band and back while the target barely moved.
//! Worse, the second turn is often held (its change is again smaller than
//! the band), and the hold then leaves the tool off by the straightness
//! accumulated since the first, and on a straight pass that grows with the
//! pass (a zigzag's pass after a plunge on a map whose straightness jumps
//! with another axis' direction).
//!
//! Under the dead band of docs/design.md ("Simulation and metrics") an axis
//! whose command stays put keeps its carriage where it is: holding the
//! axis at its command, in its old direction, leaves the tool off the
//! target by the change alone. So the point is solved with those axes held
//! and the other axes in the consistent state with the fewest reversals
//! (a transverse table depends on the held axis' direction: holding one
//! axis may take away another's reversal), where the tool stays within
//! `bound_mm` of the target and each held axis within its band.
//!
//! At a G64 corner between two arcs this also keeps the arc after the
//! corner planar at its start where the normal axis' reversal was such a
//! turn (compensate/planar.rs): LinuxCNC keeps its blend arc only where both
//! arcs' normals are colinear with the corner's binormal (src/emc/tp/tp.c,
//! `tpCreateArcArcBlend`).

use super::options::TakeUpRule;
use super::solve::{bands_um, flipped_where, held_solve, solve_fixed_in, Method, PointSolution};
use crate::error::ModelError;
use crate::model::{AxisCells, Components, Directions, ErrorModel};
use volcomp_gcode::Vec3;

/// Whether a small reversal at the target `index` of a move is held
/// whenever the hold's bound allows (solve.rs `hold_small_reversals`,
/// within `CompensateOptions::hold_tolerance_mm`): not under G64 P inside
/// a line (`on_line`, a target after its first). A held axis' command
/// stays put, so at the line's next target the same axis reverses again
/// by as little and is held again, and the tool stays off by up to p less
/// the contour tolerance for as long. Inside a line the take-up is taken
/// where it keeps the path tangent (a ramp, a fold or a lead piece whose
/// turn LinuxCNC's planner takes as tangent, src/emc/tp/tp.c
/// `tpSetupTangent`), and held, as under G64 without P, only where it
/// would kink the path (points.rs `solve_targets`). At a move's start
/// (a corner) and inside an arc the hold stays as it was.
pub(super) fn holds_at(rule: TakeUpRule, index: usize, on_line: bool) -> bool {
    !(matches!(rule, TakeUpRule::Within(_)) && on_line && index > 0)
}

/// Under G64 P p, where the tool stands off the nominal point `t_prev_mm`
/// when a take-up starts (mm): the image of the command `q_prev_mm` in the
/// direction state `s_prev` it was written in, less that point. A held
/// axis (solve.rs `hold_small_reversals`) leaves the tool off its target
/// by up to p less the contour tolerance, and its command stays put, so
/// the next take-up starts from there: the offset fades only as the command,
/// solved onto the path at the piece's end, carries the image back
/// (points.rs `fold_deviation_from_mm`). Counted under G64 P alone, where
/// the program bounds every excursion by p; zero under the other rules.
pub(super) fn start_offset_mm(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    rule: TakeUpRule,
    (q_prev_mm, s_prev): (Vec3, Directions),
    t_prev_mm: Vec3,
) -> Result<Vec3, ModelError> {
    match rule {
        TakeUpRule::Within(_) => Ok(cells.actual_again_mm(model, q_prev_mm, s_prev)? - t_prev_mm),
        TakeUpRule::Exact { .. } | TakeUpRule::Always => Ok(Vec3::ZERO),
    }
}

/// A step of a command smaller than this (mm) turns nothing: the written
/// resolution's order (five decimals of a millimetre are 10 nm).
const TURN_MM: f64 = 1e-6;

/// The point `point` (solved for the target `t_mm` from the command `q_prev`
/// in the state `s_prev`) with its reversing axes that the next target
/// (the first of `after`, the move's targets after this one) turns back
/// held at their commands in their old direction, or `None` where none
/// turns back, or the hold leaves the tool further than `bound_mm` from
/// the target, a held axis beyond its band, or the free axes further than
/// the point did (a solve that did not converge is never hidden behind a
/// hold), or an axis the piece does not move (`moving`: the axes its
/// nominal move changes) still reverses, or the hold does not end within the move without a reversal and
/// within `bound_mm` (as compensate/exact_hold.rs `hold_end`; with
/// `whole_move`, the held axes then run their old way to the move's end:
/// [`hold_runs_on`]). An axis turns back
/// where the next target, solved in the state the point turns to, moves
/// its command against its new direction.
#[allow(clippy::too_many_arguments)]
pub(super) fn held_before_turn_back(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    method: Method,
    quantize: &dyn Fn(Vec3) -> Vec3,
    (t_mm, q_prev, s_prev): (Vec3, Vec3, Directions),
    point: &PointSolution,
    (after, moving): (&[Vec3], [bool; 3]),
    (bound_mm, whole_move): (f64, bool),
) -> Result<Option<(PointSolution, usize)>, ModelError> {
    let reversed = [0, 1, 2].map(|a| point.s[a] != s_prev[a] && !point.held[a]);
    let Some(&next_mm) = after.first() else {
        return Ok(None);
    };
    // The hold must take away more reversals than the axes it holds (one
    // at least), so two reversing axes at least; the looser rule at an
    // arc's planar start (`!whole_move`) needs one.
    let reversing = reversed.iter().filter(|r| **r).count();
    if reversing < if whole_move { 2 } else { 1 } || bound_mm <= 0.0 {
        return Ok(None);
    }
    let next = solve_fixed_in(
        cells,
        model,
        method,
        next_mm,
        point.s,
        [false; 3],
        Vec3::ZERO,
    )?;
    let turns = turning_back(&reversed, point, next.q_mm);
    if !turns.iter().any(|t| *t) {
        return Ok(None);
    }
    let band_um = bands_um(cells, model, (q_prev, s_prev), turns)?;
    // The free axes: every state, fewest reversals from `s_prev` first
    // (the smallest residual among equals), as solve.rs `search_states`.
    let mut best: Option<(u32, f64, PointSolution)> = None;
    for bits in 0..8u8 {
        if (0..3).any(|a| turns[a] && bits & (1 << a) != 0) {
            continue;
        }
        let flips = bits.count_ones();
        if best.as_ref().is_some_and(|b| b.0 < flips) {
            continue;
        }
        let s = flipped_where(s_prev, bits);
        let Some(sol) = held_solve(
            cells,
            model,
            (method, quantize),
            (t_mm, s, turns),
            (q_prev, s_prev),
            (bound_mm, band_um, point.residual_um),
        )?
        else {
            continue;
        };
        if best
            .as_ref()
            .is_some_and(|b| b.0 == flips && b.1 <= sol.residual_um)
        {
            continue;
        }
        best = Some((flips, sol.residual_um, sol));
    }
    let Some((_, _, held)) = best else {
        return Ok(None);
    };
    let taken_away = (0..3)
        .filter(|a| point.reversed[*a] && !held.reversed[*a])
        .count();
    let holds = turns.iter().filter(|t| **t).count();
    if whole_move && taken_away <= holds {
        // The hold saves no more reversals than the axes it holds: each
        // held axis keeps the error of its hold and meets its turn in a
        // later move instead (set b chords Ø50 and zigzag along Y on the
        // shop map lost 0.6–1.0 point of RMS so); only where it takes
        // another axis' reversal away too (a transverse table that
        // depends on the held axis' direction) does it pay.
        return Ok(None);
    }
    if (0..3).any(|a| held.reversed[a] && !moving[a]) {
        // An axis the piece does not move still reverses: the map's own
        // reversal is left to the rules that decide it (a fold, a lead
        // piece, or the hold of every reversing axis where the fold would
        // kink the path); holding part of it would change their choice.
        return Ok(None);
    }
    let ends = hold_runs_on(
        cells,
        model,
        method,
        (held.q_mm, held.s, turns),
        after,
        (bound_mm, whole_move),
    )?;
    Ok(ends.map(|k| (held, k)))
}

/// Whether a hold of the axes `held` at the command `q_mm` in the state
/// `s` ends within the move without a reversal: at some target of `after`
/// (the move's targets after the held point, in order) every held axis'
/// command, solved freely in `s`, runs its old way again (or stands), and
/// up to that target the hold (the axes kept at their command, the others
/// solved again) leaves the tool within `bound_mm` of each target. With
/// `whole_move`, the held axes must then run their old way to the move's
/// end: a hold that ends only to meet the reversal further along the move
/// carries the reversal to a place where it may need a lead piece or kink
/// the path (under G64 a fold there is no cheaper than here). A step back
/// smaller than [`TURN_MM`] turns nothing. Returns the place in `after`
/// of the target the hold ends at, or `None`.
fn hold_runs_on(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    method: Method,
    (q_mm, s, held): (Vec3, Directions, [bool; 3]),
    after: &[Vec3],
    (bound_mm, whole_move): (f64, bool),
) -> Result<Option<usize>, ModelError> {
    let mut q = q_mm;
    let mut ended = None;
    for (k, t) in after.iter().enumerate() {
        let free = solve_fixed_in(cells, model, method, *t, s, [false; 3], q)?;
        let runs_on = (0..3).all(|a| !held[a] || (free.q_mm[a] - q[a]) * s[a].sign() >= -TURN_MM);
        if runs_on {
            if !whole_move {
                return Ok(Some(k));
            }
            ended = ended.or(Some(k));
            q = free.q_mm;
            continue;
        }
        if ended.is_some() {
            return Ok(None);
        }
        let kept = solve_fixed_in(cells, model, method, *t, s, held, q)?;
        let off_mm = *t - cells.actual_mm(model, kept.q_mm, s, Components::All)?;
        if off_mm.norm() > bound_mm {
            return Ok(None);
        }
        q = kept.q_mm;
    }
    Ok(ended)
}

/// The axes of `reversed` whose command the next one, `q_next_mm`, moves
/// back against the direction `point` turned them to (by more than
/// [`TURN_MM`]).
fn turning_back(reversed: &[bool; 3], point: &PointSolution, q_next_mm: Vec3) -> [bool; 3] {
    [0, 1, 2].map(|a| reversed[a] && (q_next_mm[a] - point.q_mm[a]) * point.s[a].sign() < -TURN_MM)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Direction::{Forward, Reverse};

    fn point(q_mm: Vec3, s: Directions) -> PointSolution {
        PointSolution {
            q_mm,
            s,
            iterations: 1,
            residual_um: 0.0,
            reversed: [false; 3],
            held: [false; 3],
        }
    }

    /// Z turned to forward at 0.29 µm; the next target wants it at
    /// 0.06 µm (down 0.23 µm, against forward): it turns back. X turned
    /// forward at −4.64 µm and the next wants −4.27 µm (on its way): it
    /// does not. A step of half a nanometre back turns nothing.
    #[test]
    fn an_axis_turns_back_where_the_next_command_runs_against_its_new_way() {
        let p = point(
            Vec3::new(-0.00464, 190.0, 0.00029),
            [Forward, Forward, Forward],
        );
        let next = Vec3::new(-0.00427, 202.0, 0.00006);
        assert_eq!(
            turning_back(&[true, false, true], &p, next),
            [false, false, true]
        );
        let barely = Vec3::new(-0.00427, 202.0, 0.000_289_5);
        assert_eq!(turning_back(&[true, false, true], &p, barely), [false; 3]);
        // Reverse: a step up is against it.
        let r = point(Vec3::new(0.0, 0.0, -0.002), [Forward, Forward, Reverse]);
        let up = Vec3::new(0.0, 0.0, -0.0015);
        assert_eq!(
            turning_back(&[false, false, true], &r, up),
            [false, false, true]
        );
    }
}
