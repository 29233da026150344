//! Solving the targets of one motion: the command of each target, the
//! take-up move before a reversal, and the checks that refuse a point the
//! solver did not reach.

use super::frame::Frame;
use super::{
    command_error, model_error, CompensateOptions, DirectionPolicy, PointRecord, State, TakeUpRule,
};
use crate::compensate::solve::{
    hold_small_reversals_in, solve_consistent_in, solve_fixed_in, solve_keeping_in, Method,
};
use crate::error::{CompensationError, ModelError};
use crate::model::next_state;
use crate::model::{AxisCells, Components, Directions, ErrorModel};
use volcomp_gcode::Vec3;

/// The command that takes up the reversing axes' backlash at `q_prev`
/// without moving the tool: for each reversing axis `a`, the position where
/// the new direction's image along `a` equals the old one's.
///
/// With `up_to_toward` (G61, G61.1: the machine stands still on the
/// take-up block), an axis that follows the switch toward the segment's
/// own command but would pass it goes as far as that command: the tool
/// then starts the segment off by only what is left beyond it, where
/// otherwise it would start off by the whole step the switch made (the
/// reversing axis' straightness across the others, a few tenths of a
/// micrometre), fading over the whole segment.
#[allow(clippy::too_many_arguments)]
fn take_up_command(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    q_prev: Vec3,
    s_old: Directions,
    s_new: Directions,
    reversed: [bool; 3],
    (toward, up_to_toward): (Vec3, bool),
    frame: &Frame,
) -> Result<Vec3, ModelError> {
    // At `q_prev` the old state and the switched one were mostly evaluated
    // already (the hold, an earlier take-up): [`AxisCells::actual_again_mm`].
    let held = cells.actual_again_mm(model, q_prev, s_old)?;
    let mut q = q_prev;
    // The reversing axes move, with their new state during the move. The
    // other axes follow too where the tool would otherwise step (the new
    // direction's straightness differs from the old one's), but only
    // toward the segment's own command `toward` and not past it, so no
    // axis reverses for it.
    let mut s = s_old;
    for a in 0..3 {
        if reversed[a] {
            s[a] = s_new[a];
        }
    }
    let mut moves = reversed;
    // The iteration's points lie micrometres apart: evaluated in the
    // tables' cells ([`AxisCells`]). It stops where the command repeats bit
    // for bit: every later round would compute the same command and the
    // same `moves`.
    for round in 0..8 {
        let img = if round == 0 {
            cells.actual_again_mm(model, q, s)?
        } else {
            cells.actual_mm(model, q, s, Components::All)?
        };
        let before = q;
        for a in 0..3 {
            if reversed[a] {
                q[a] += held[a] - img[a];
            } else {
                let next = q[a] + held[a] - img[a];
                let (d, room) = (next - q_prev[a], toward[a] - q_prev[a]);
                moves[a] = d * room > 0.0 && (up_to_toward || d.abs() <= room.abs());
                q[a] = match (moves[a], d.abs() <= room.abs()) {
                    (false, _) => q_prev[a],
                    (true, true) => next,
                    (true, false) => toward[a],
                };
            }
        }
        if (0..3).all(|a| q[a].to_bits() == before[a].to_bits()) {
            break;
        }
    }
    let mut out = frame.quantize(q, q_prev);
    for a in 0..3 {
        if !reversed[a] {
            if !moves[a] {
                out[a] = q_prev[a];
            }
        } else if (out[a] - q_prev[a]) * s_new[a].sign() <= 0.0 {
            // A negative reversal value needs no take-up: the axis engages at once.
            out[a] = q_prev[a];
        }
    }
    Ok(out)
}

/// The jump of the tool's image at `q_prev` when the `reversed` axes switch
/// from `s_old` to `s_new`, axis by axis (mm): the lag each reversing axis'
/// carriage starts with under the simulator's dead band (simulate/mod.rs),
/// its own component and what its tables change across. They add up to the
/// whole jump. The written take-up is rounded to the output's step, so it
/// is not used here.
pub(super) fn switch_lags_mm(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    q_prev: Vec3,
    s_old: Directions,
    s_new: Directions,
    reversed: [bool; 3],
) -> Result<[Vec3; 3], ModelError> {
    let mut lags = [Vec3::ZERO; 3];
    let mut s = s_old;
    for a in 0..3 {
        if reversed[a] && s_new[a] != s[a] {
            let before = cells.actual_again_mm(model, q_prev, s)?;
            s[a] = s_new[a];
            lags[a] = before - cells.actual_again_mm(model, q_prev, s)?;
        }
    }
    Ok(lags)
}

/// The contour error (mm) left by folding the take-up of `lags` (see
/// [`switch_lags_mm`]) into the move from `q_prev` to the command `q`,
/// whose nominal travel is `nominal_delta`, under the simulator's dead band
/// (docs/compensation.md, "Take-ups folded into the move"; simulate/mod.rs).
///
/// The command is solved for the new direction, so the image of the
/// command runs from `(1 − λ)·ℓ` short of the nominal point at the start
/// (`ℓ = Σ ℓ_a`, the whole jump) onto it at the end, linearly over the
/// move (the map is affine at this scale). The tool is the image plus what
/// each carriage still lags, `ℓ_a·f_a(λ)`: so it is off the nominal point by
/// `Σ_a ℓ_a·(f_a(λ) − 1 + λ)`. For an axis whose command travels
/// `T_a = |q_a − q_prev_a|` toward its own lag `b_a = |ℓ_a[a]|`, the part
/// left is `f_a = max(0, 1 − r_a λ)`, `r_a = T_a / b_a`, so its term peaks at
/// `|r_a − 1| / max(r_a, 1)` of `ℓ_a` (at `λ = 1/r_a` if the command crosses
/// the band, at the end if not: the rest then carries into the next move);
/// an axis that stands still keeps its lag (`f_a = 1`: all of it at the
/// end); one that moves away from it, or has no reversal value of its own,
/// loses it at once (`f_a = 0`: all of it at the start). The offsets are
/// piecewise linear in `λ`, so the largest is at `λ = 0`, `1` or a `1/r_a`.
/// Only the part across the move's direction leaves the path (a lag along
/// it is the tool arriving later). Zero where every reversing axis'
/// command crosses exactly its band.
pub(super) fn fold_deviation_mm(
    lags: &[Vec3; 3],
    q_prev: Vec3,
    q: Vec3,
    nominal_delta: Vec3,
) -> f64 {
    fold_deviation_beyond_mm(lags, q_prev, q, nominal_delta, 0.0)
}

/// [`fold_deviation_mm`] counted from the fraction `from_lambda` of the
/// move on: what a fold leaves beyond that much of its path (mm). Zero
/// where the reversing axes have crossed their bands and the command has
/// caught the path up by then.
fn fold_deviation_beyond_mm(
    lags: &[Vec3; 3],
    q_prev: Vec3,
    q: Vec3,
    nominal_delta: Vec3,
    from_lambda: f64,
) -> f64 {
    fold_deviation_from_mm(lags, q_prev, q, nominal_delta, (from_lambda, Vec3::ZERO))
}

/// [`fold_deviation_beyond_mm`] where the tool starts the move off the
/// nominal point by `start_mm` (a held axis, compensate/turn_back.rs
/// `start_offset_mm`): the command, solved onto the path at the move's
/// end, carries that offset off linearly, `start_mm·(1 − λ)`, on top of
/// the lags' own.
pub(super) fn fold_deviation_from_mm(
    lags: &[Vec3; 3],
    q_prev: Vec3,
    q: Vec3,
    nominal_delta: Vec3,
    (from_lambda, start_mm): (f64, Vec3),
) -> f64 {
    // Along a straight move the direction is the same everywhere; where
    // the move has no length every offset counts.
    let length = nominal_delta.norm();
    let u = if length > 0.0 {
        nominal_delta * (1.0 / length)
    } else {
        Vec3::ZERO
    };
    // With one direction the part across it is convex between
    // the breakpoints, so the ends and the breakpoints give the largest.
    fold_deviation_sampled_mm(
        lags,
        (q_prev, start_mm),
        q,
        &|_| u,
        (from_lambda.clamp(0.0, 1.0), 1),
    )
}

/// Whether a G61 hold of a small reversal may run to the end of a straight
/// move from `start_mm` to `end_mm` (the next move then takes it up from
/// its start, or holds it on: compensate/exact_hold.rs `hold_end`):
/// only on a plunge, a move along the tool axis Z alone with X and Y
/// commanded still, and only for a reversal of X or Y (`reversed`), not
/// of Z, the axis the plunge drives. On a plunge, X and Y turn back where
/// Z crosses a point of its tables (their straightness along Z changes
/// slope there, docs/design.md "Direction state and backlash"), by
/// tenths of a micrometre, so a hold within the run-through tolerance
/// (exact_hold.rs `hold_instead_of_stop_mm`) lasts to the plunge's end;
/// taken up there instead, the X and Y switch moves the Z error where the
/// next line starts, with Z running on its way along the line, which it
/// cannot follow without a reversal of its own: measured on the shop map,
/// pocket_r4's 0.52 µm at the start of the line after a plunge through
/// Z 150 (docs/compensation.md, "A hold to the end of a plunge"). A line
/// with X or Y commanded keeps the rule of exact_hold.rs (no hold to its
/// end).
fn hold_to_plunge_end(start_mm: Vec3, end_mm: Vec3, reversed: [bool; 3]) -> bool {
    let d = end_mm - start_mm;
    d.x == 0.0 && d.y == 0.0 && d.z != 0.0 && !reversed[2] && (reversed[0] || reversed[1])
}

/// Whether a G61 hold on a line's held tail ([`tail_run`]) may last to the
/// line's end, `rest_mm` of it left after the held point: where the rest
/// is shorter than the shortest smooth ramp of the take-up (`ramp_mm`,
/// [`line_ramp_length_mm`]; the reason no ramp took it), as on an arc
/// (compensate/exact_hold.rs). The take-up block the hold replaces would
/// stop the machine inside the line, a stop the original does not make;
/// held on, the reversal is taken up at the corner after the line, where
/// G61 stops anyway (LinuxCNC's tp.c `tpSetupTangent` finds no tangency
/// under G61), or carried on into the next line ([`carries_plunge_hold`]).
/// The hold's error over the rest is bounded as every G61 hold's
/// (exact_hold.rs `hold_instead_of_stop_mm`). Not on a whole line:
/// measured on the shop map (bench/eval set a, F6000), chords12_d36 fell
/// from 99.03 to 98.91 % RMS reduction and chords25_d44 took +2.6 % for
/// +2.3 %, the hold's error over the last millimetre of many chords.
fn hold_to_line_end(rest_mm: f64, ramp_mm: f64) -> bool {
    rest_mm < ramp_mm
}

/// The run a line's tail is solved in (mod.rs `flush_tail`: the last
/// piece of a block, held until the next block is known): under G61 no
/// corner before it, for the tail starts inside its block, where the
/// original runs on. With the block's own run (a corner before the
/// block), a take-up at the tail's start read as one at a corner, where
/// G61 stops anyway, so no hold took it and it became a take-up block: a
/// stop inside the line the original does not make (measured on
/// bench/cycle_time's zigzag_40x30, example map, F6000: 43 ms at each of
/// seven of its fifteen 2 mm stepovers, X and Z reversing on the tail;
/// LinuxCNC's tp.c `tpSetupTangent` finds no tangency at the block's
/// corners, `tcFinalizeLength` stops there). Other modes keep the block's
/// run as it was.
pub(super) fn tail_run(run: Run, line: bool, rule: TakeUpRule) -> Run {
    if line && matches!(rule, TakeUpRule::Exact { smooth: true }) {
        Run {
            corner_before: false,
            ..run
        }
    } else {
        run
    }
}

/// Whether a G61 hold at the first target of a line may carry on the hold
/// of the plunge before it through its end ([`hold_to_plunge_end`]; the
/// axes `held_mm_before`): where only those axes reverse here. The machine
/// stops at the corner between the two moves, but the axis has not
/// switched: held on (within the same tolerance, and only where the hold
/// ends within the line, exact_hold.rs `hold_end`), it never
/// reverses; taken up here, it would reverse twice, here and again where
/// its target turns back inside the line, a stop G61 does not make
/// without it (measured on pocket_r4, shop map: a take-up block at X −10
/// after the plunge through Z 150).
fn carries_plunge_hold(held_before: [bool; 3], reversed: [bool; 3]) -> bool {
    reversed.iter().any(|r| *r) && (0..3).all(|a| !reversed[a] || held_before[a])
}

/// Whether a take-up `delta` folded into a piece of `piece_mm` turns the
/// path by no more than the planner takes as tangent there, less the room
/// left for the compensation's own turn: `|Δ_i| / ℓ ≤ RAMP_SHARE · κ_i`
/// with `κ` the tangency tolerance at the feed
/// ([`super::PlannerLimits::tangent_tolerance`]).
fn fold_is_tangent(delta: Vec3, kink: [f64; 3], piece_mm: f64) -> bool {
    (0..3).all(|i| delta[i].abs() <= RAMP_SHARE * kink[i] * piece_mm)
}

/// A lead piece for a take-up that the whole move cannot fold (see
/// [`fold_deviation_mm`]): the point at a fraction ½, ¼, … of the move from
/// `t_prev`, on its line or arc, on which the reversing axes, running their
/// new way from the start, take up the lags `lags` with the tool within
/// `tolerance_mm` of the path; the longest such piece, and none shorter
/// than `shortest_mm` ([`State::lead_shortest_mm`]). Over a short piece the
/// command's travel beyond the band (the nominal path's or the
/// compensation's own along the reversing axis) is small, so the tool
/// catches the path again sooner.
///
/// `at(f)` is the target at the fraction `f` of the move (of length
/// `length`, mm) from the previous target, on its line or arc; the result
/// is the fraction of the lead piece.
#[allow(clippy::too_many_arguments)]
fn lead_target(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    options: &CompensateOptions,
    quantize: &dyn Fn(Vec3) -> Vec3,
    q_prev: Vec3,
    lags: &[Vec3; 3],
    (shortest_mm, tolerance_mm): (f64, f64),
    t_prev: Vec3,
    (at, length): (&dyn Fn(f64) -> Vec3, f64),
    point: &crate::compensate::solve::PointSolution,
) -> Result<Option<f64>, ModelError> {
    let mut piece = 0.5 * length;
    while piece >= shortest_mm && piece > 0.0 {
        let lead = at(piece / length);
        let sol = solve_fixed_in(
            cells,
            model,
            options.method,
            lead,
            point.s,
            [false; 3],
            q_prev,
        )?;
        let q = quantize(sol.q_mm);
        let consistent = (0..3).all(|a| {
            !point.reversed[a]
                || crate::model::Direction::of_delta(q[a] - q_prev[a]) == Some(point.s[a])
        });
        if consistent && fold_deviation_mm(lags, q_prev, q, lead - t_prev) <= tolerance_mm {
            return Ok(Some(piece / length));
        }
        piece *= 0.5;
    }
    Ok(None)
}

/// [`fold_deviation_mm`] for a fold whose path turns: the offsets of the
/// fold (piecewise linear in the fraction `λ` of the move) are sampled at
/// 33 fractions and at the breakpoints `1/r_a`, and only their part across
/// the path's own tangent there, `tangent(λ)`, is counted.
fn fold_deviation_along_mm(
    lags: &[Vec3; 3],
    q_prev: Vec3,
    q: Vec3,
    tangent: &dyn Fn(f64) -> Vec3,
) -> f64 {
    fold_deviation_sampled_mm(lags, (q_prev, Vec3::ZERO), q, tangent, (0.0, 32))
}

/// [`fold_deviation_along_mm`] sampled at `steps + 1` fractions from
/// `from` to 1 (and at the breakpoints in between).
pub(super) fn fold_deviation_sampled_mm(
    lags: &[Vec3; 3],
    (q_prev, start_mm): (Vec3, Vec3),
    q: Vec3,
    tangent: &dyn Fn(f64) -> Vec3,
    (from, steps): (f64, u32),
) -> f64 {
    let dq = q - q_prev;
    let ratio = |a: usize| -> Option<f64> {
        let own = lags[a][a];
        (own != 0.0 && own * dq[a] >= 0.0).then(|| dq[a].abs() / own.abs())
    };
    let offset = |lambda: f64| -> Vec3 {
        let mut off = start_mm * (1.0 - lambda);
        for (a, lag) in lags.iter().enumerate() {
            if *lag != Vec3::ZERO {
                let left = ratio(a).map_or(0.0, |r| (1.0 - r * lambda).max(0.0));
                off += *lag * (left - 1.0 + lambda);
            }
        }
        off
    };
    let across = |lambda: f64| -> f64 {
        let off = offset(lambda);
        let u = tangent(lambda);
        (off - u * off.dot(u)).norm()
    };
    let mut worst = (0..=steps).fold(0.0f64, |m, k| {
        m.max(across(
            from + (1.0 - from) * f64::from(k) / f64::from(steps),
        ))
    });
    for a in 0..3 {
        if let Some(r) = ratio(a).filter(|r| *r > 1.0 && 1.0 / *r >= from) {
            worst = worst.max(across(1.0 / r));
        }
    }
    worst
}

/// How far a take-up the machine runs through without a stop (a ramp,
/// [`RampPlan`], or an S-curve at a quarter point, compensate/scurve.rs)
/// may leave the tool from the path under G61 and G64 without P (mm), where
/// the contour tolerance is smaller: the accuracy the product states for
/// the whole path, 0.5 µm (docs/compensation.md, "Reversals by path-control
/// mode"), less a fifth for what the local model leaves out. A stop on a
/// smooth contour costs about `v/a` and leaves a dwell mark; a shop that
/// wants the contour tolerance there asks for it with the take-up
/// tolerance (the G64 P rule, which keeps every take-up within it).
pub(super) const RUN_THROUGH_TOLERANCE_MM: f64 = 0.4e-3;

/// Under G64 without P, the path after a reversal within which its take-up
/// is over (mm): beyond it the tool keeps within
/// [`RUN_THROUGH_TOLERANCE_MM`] of the path. G64 lets the tool leave the
/// path at a reversal by up to the axis' reversal value, as the
/// controller's own backlash compensation does when it takes the band up
/// at the reversal at the axis' limits; away from reversals the product's
/// accuracy target holds (docs/compensation.md, "Reversals by
/// path-control mode").
pub(super) const TAKE_UP_REACH_MM: f64 = 1.0;

/// Under G64 without P, the share of its speed a corner's blend keeps
/// where a take-up's lead piece after the corner shortens it. LinuxCNC
/// blends two lines with an arc that takes at most half of the next piece
/// (`blendComputeParameters`, src/emc/tp/blendmath.c; the planner model's
/// `line_line`), of radius `tan θ · d` for the length `d` it takes of each
/// line, run at `√(a_n · tan θ · d)`: a lead piece `ℓ` shorter than twice
/// the blend's own `d` (`Run::protect_mm`) keeps `√(ℓ / 2d)` of its speed.
/// Slowing from `v` to 0.8 `v` and back costs at most about
/// `(0.2 v)² / (a v) = 0.04 v/a` (4 ms at 100 mm/s and 1,000 mm/s²).
const BLEND_SPEED_KEPT: f64 = 0.8;

/// The share of the planner's tangency tolerance a take-up may turn the
/// path by at a join (a fold or the ends of a ramp): the rest is for the
/// compensation's own turn there, which adds to it.
pub(super) const RAMP_SHARE: f64 = 0.6;

/// A take-up spread over the path after the reversal (a ramp): the
/// reversing axes run their new way from the reversal on, and the command
/// catches up the take-up `delta` linearly over the length `L` of path
/// that keeps the turn of the tangent at both ends of the ramp below a
/// share of the planner's tangency tolerance (`|Δ_i| / L ≤ RAMP_SHARE·tol_i`,
/// [`super::PlannerLimits::tangent_tolerance`]). Over `L` the reversing
/// carriage crosses its band while the tool stands still along it, as
/// under a fold into a move of that length ([`fold_deviation_mm`]); the
/// planner runs the ramp's pieces without a corner, where a take-up folded
/// into one short piece turns the path by `|Δ|/ℓ` and makes the planner
/// blend or stop (docs/compensation.md, "Take-ups spread along the path").
pub(super) struct RampPlan {
    /// The share of `delta` still to catch up at each target of the ramp,
    /// from the reversal's target on (the last 0: the ramp's end).
    pub(super) fracs: Vec<f64>,
    /// On a staged ramp ([`super::ramp_stage`]), the take-up still to catch
    /// up at each of those targets, in place of `delta` times the share;
    /// empty on a ramp of one step.
    pub(super) rests: Vec<(Vec3, [bool; 3])>,
    /// The targets to insert (each with the index it goes before, the
    /// point, and on an arc its parameter), in order along the path: where
    /// the ramp ends inside a move, and on a smooth ramp its inner points.
    pub(super) insert: Vec<(usize, Vec3, Option<f64>)>,
    /// The tool's largest distance from the path on the ramp (mm).
    pub(super) bound_mm: f64,
}

/// How many of the motion's targets after a staged ramp's end are read on
/// where its last axis has not crossed its band there
/// (compensate/ramp_stage.rs): a few, the band short by a tenth of a
/// micrometre and the targets a few millimetres apart.
const STAGED_READ_ON_TARGETS: usize = 4;

/// The length [`plan_ramp`] first asks of a ramp for the take-up `delta`
/// (mm): the tangency's, before a given length or the floor.
fn ramp_need_mm(
    leads: &Leads<'_>,
    length_mm: Option<f64>,
    smooth: bool,
    delta: Vec3,
    kink_tolerance: [f64; 3],
    shortest_mm: f64,
) -> f64 {
    let parabolic = smooth && matches!(leads, Leads::Lines) && length_mm.is_some();
    if parabolic {
        line_ramp_length_mm(delta, kink_tolerance, shortest_mm)
    } else {
        ramp_length_mm(delta, kink_tolerance, shortest_mm, smooth)
    }
}

/// Whether [`plan_ramp`] with the floor `floor_mm` can plan otherwise than
/// without it (`judged` false in both): the floor is read nowhere but to
/// lengthen a ramp of no given length whose tangency needs less; where it
/// does not, both calls compute the same (the cells they evaluate in give
/// the map's values to the bit), so a try without the floor after one with
/// it that failed fails again.
fn floor_lengthens_ramp(
    (leads, length_mm, smooth): (&Leads<'_>, Option<f64>, bool),
    delta: Vec3,
    (kink_tolerance, shortest_mm): ([f64; 3], f64),
    floor_mm: f64,
) -> bool {
    let need = ramp_need_mm(leads, length_mm, smooth, delta, kink_tolerance, shortest_mm);
    // A need that is not positive and finite returns before the floor is
    // read (as `floor_mm > NaN` is false).
    length_mm.is_none() && need > 0.0 && need.is_finite() && floor_mm > need
}

/// The ramp of a take-up `delta` at target `index` (see [`RampPlan`]), or
/// `None` where the motion's rest is too short for it, an S-curve or a
/// reversal of any axis lies inside it, or it leaves the tool further
/// than `tolerance_mm` from the path.
#[allow(clippy::too_many_arguments)]
fn plan_ramp(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    options: &CompensateOptions,
    quantize: &dyn Fn(Vec3, Vec3) -> Vec3,
    (targets, leads, transitions): (&[Vec3], &Leads<'_>, &[super::arcs::Transition]),
    (index, t_prev, q_prev): (usize, Vec3, Vec3),
    point: &crate::compensate::solve::PointSolution,
    (delta, lags, hold): (Vec3, &[Vec3; 3], [bool; 3]),
    (kink_tolerance, tolerance_mm, shortest_mm, length_mm, floor_mm): (
        [f64; 3],
        f64,
        f64,
        Option<f64>,
        f64,
    ),
    (smooth, judged, staged): (bool, bool, bool),
    end_zone_mm: f64,
) -> Result<Option<RampPlan>, ModelError> {
    // (Two parabolas on a ramp centred on a reversal along a line, the one
    // ramp of a line given its length: compensate/ramp_centre.rs.)
    let parabolic = smooth && matches!(leads, Leads::Lines) && length_mm.is_some();
    let need = ramp_need_mm(leads, length_mm, smooth, delta, kink_tolerance, shortest_mm);
    if !(need > 0.0 && need.is_finite()) {
        return Ok(None);
    }
    // A ramp of a given length (one taken up ahead of an S-curve, ending
    // where it begins): refused where that is too short.
    let need = match length_mm {
        Some(l) if l < need * (1.0 - 1e-9) => return Ok(None),
        Some(l) => l,
        None => need,
    };
    // Distance along the path from `t_prev` to each target from `index`.
    let (arc, l_prev) = match leads {
        Leads::Arc { arc, pieces } => (
            Some(**arc),
            if index == 0 { 0.0 } else { pieces[index - 1] },
        ),
        Leads::Lines => (None, 0.0),
        Leads::Nowhere => return Ok(None),
    };
    let along = |k: usize| -> f64 {
        match (arc, leads) {
            (Some(a), Leads::Arc { pieces, .. }) => a.length() * (pieces[k] - l_prev),
            _ => (targets[k] - t_prev).norm(),
        }
    };
    // A ramp whose end would fall inside a blend's zone ends at its edge,
    // or at the motion's end where that edge is past it ([`ramp_floor_mm`]).
    let need = match targets.len().checked_sub(1).map(along) {
        Some(rest) if floor_mm > need && length_mm.is_none() => floor_mm.min(rest),
        _ => need,
    };
    let Some(k) = (index..targets.len()).find(|k| along(*k) >= need * (1.0 - 1e-9)) else {
        return Ok(None);
    };
    if transitions
        .iter()
        .any(|tr| tr.index > index && tr.index <= k)
    {
        return Ok(None);
    }
    // The ramp ends at target `k`, or at a point inserted in its piece.
    let s_before = if k == index { 0.0 } else { along(k - 1) };
    let s_k = along(k);
    let mut window: Vec<(Vec3, f64)> = (index..k).map(|j| (targets[j], along(j))).collect();
    // The point `s` along the path from `t_prev`, in the piece that ends
    // at target `j` (and starts `s_from` along).
    let point_at = |j: usize, s_from: f64, s: f64| -> (Vec3, Option<f64>) {
        match (arc, leads) {
            (Some(a), Leads::Arc { .. }) => {
                let l = l_prev + s / a.length();
                (a.point_at(l), Some(l))
            }
            _ => {
                let from = if j == index { t_prev } else { targets[j - 1] };
                let s_to = along(j);
                let f = (s - s_from) / (s_to - s_from);
                (from + (targets[j] - from) * f, None)
            }
        }
    };
    let mut insert: Vec<(usize, Vec3, Option<f64>, f64)> = Vec::new();
    // Under G64 without P, a ramp whose end would fall inside the zone a
    // held line keeps whole for the blend at its end (compensate/end_zone.rs
    // `NextCorner::end_zone_mm`) runs to the line's end: its end would be a
    // split inside the blend's reach, which LinuxCNC then rounds tighter and
    // slower (blendmath.c `blendComputeParameters`: the blend takes at most
    // half of the piece next to the corner).
    let in_end_zone = end_zone_mm > 0.0 && k + 1 == targets.len() && s_k - need < end_zone_mm;
    let end_s = if in_end_zone || (s_k - need <= 0.5 * need && !judged) || s_k - need < shortest_mm
    {
        s_k
    } else {
        let s_new = need.max(s_before + shortest_mm);
        if s_k - s_new < shortest_mm {
            s_k
        } else {
            let (p, param) = point_at(k, s_before, s_new);
            insert.push((k, p, param, s_new));
            window.push((p, s_new));
            s_new
        }
    };
    if insert.is_empty() {
        window.push((targets[k], s_k));
    }
    // A smooth ramp's inner points, about `shortest_mm` apart, where no
    // target is within half of that already.
    if smooth && end_s > 2.0 * shortest_mm {
        let n = (end_s / shortest_mm).floor() as usize;
        let step = end_s / n as f64;
        let mut inner = Vec::new();
        for m in 1..n {
            let s = step * m as f64;
            if window.iter().any(|(_, w)| (w - s).abs() < 0.5 * step) {
                continue;
            }
            let j = (index..=k).find(|j| along(*j) > s).unwrap_or(k);
            let s_from = if j == index { 0.0 } else { along(j - 1) };
            let (p, param) = point_at(j, s_from, s);
            inner.push((j, p, param, s));
        }
        for (j, p, param, s) in inner {
            insert.push((j, p, param, s));
            window.push((p, s));
        }
        insert.sort_by(|a, b| a.3.partial_cmp(&b.3).unwrap_or(std::cmp::Ordering::Equal));
        window.sort_by(|a, b| a.1.partial_cmp(&b.1).unwrap_or(std::cmp::Ordering::Equal));
    }
    // A staged ramp (judged by its commands only): each reversing axis'
    // lag on a step of its own (compensate/ramp_stage.rs).
    let stages = if staged {
        if !(judged && parabolic) {
            return Ok(None);
        }
        let Some(st) = super::ramp_stage::Stages::plan(lags, point.s, point.reversed, |v| {
            line_ramp_length_mm(v, kink_tolerance, shortest_mm)
        }) else {
            return Ok(None);
        };
        Some(st)
    } else {
        None
    };
    let rests: Vec<(Vec3, [bool; 3])> = match stages {
        Some(st) => window
            .iter()
            .map(|(_, s)| {
                let u = (s / end_s).clamp(0.0, 1.0);
                (st.rest(delta, lags, u, parabolic_step), st.waiting(u))
            })
            .collect(),
        None => Vec::new(),
    };
    let fracs: Vec<f64> = window
        .iter()
        .map(|(_, s)| {
            let u = (s / end_s).clamp(0.0, 1.0);
            if parabolic {
                1.0 - parabolic_step(u)
            } else if smooth {
                1.0 - u * u * (3.0 - 2.0 * u)
            } else {
                1.0 - u
            }
        })
        .collect();
    // The commands the ramp writes, estimated in the new state: no axis may
    // turn against its direction on it (an axis in `hold` stands instead,
    // [`hold_on_ramp`]).
    let mut prev = q_prev;
    let mut written = Vec::new();
    for (k, ((t, _), f)) in window.iter().zip(&fracs).enumerate() {
        let sol = solve_fixed_in(cells, model, options.method, *t, point.s, [false; 3], prev)?;
        let (rest, waiting) = rests.get(k).copied().unwrap_or((delta * *f, [false; 3]));
        let mut q = quantize(sol.q_mm - rest, prev);
        hold_on_ramp(
            &mut q,
            prev,
            point.s,
            [0, 1, 2].map(|a| hold[a] && !waiting[a]),
        );
        if judged {
            written.push((*t, q, sol.q_mm));
        }
        for a in (0..3).filter(|a| !waiting[*a]) {
            if (q[a] - prev[a]) * point.s[a].sign() < -1e-9 {
                return Ok(None);
            }
        }
        prev = q;
    }
    // Each reversing axis must cross its band before its command turns
    // back: where the solved commands run against the new way, the
    // command can turn back after less than the band, the dead band keeps
    // the carriage on its old flank, and the targets after the reversal
    // are solved in a state the machine is not in (docs/compensation.md,
    // "Take-ups spread along the path"). Short at the ramp's end, the
    // motion's later targets (solved in the new state) must carry it the
    // rest of the way without turning back. Under G61 and G61.1 (`smooth`)
    // only: under G64 a ramp may leave the tool off by the rule's own
    // tolerance (0.4 µm, or P), and refusing it there folded the take-up
    // instead, which measured worse.
    let tolerance_band_mm = options.fold_tolerance_mm();
    if smooth && !reaches_flank(delta, q_prev, prev, point, tolerance_band_mm) {
        let mut p = prev;
        let mut crossed = false;
        for j in (index..targets.len()).filter(|j| along(*j) > end_s * (1.0 + 1e-9)) {
            let sol = solve_fixed_in(
                cells,
                model,
                options.method,
                targets[j],
                point.s,
                [false; 3],
                p,
            )?;
            let q = quantize(sol.q_mm, p);
            if (0..3).any(|a| point.reversed[a] && (q[a] - p[a]) * point.s[a].sign() < -1e-9) {
                break;
            }
            p = q;
            if reaches_flank(delta, q_prev, p, point, tolerance_band_mm) {
                crossed = true;
                break;
            }
        }
        if !crossed {
            return Ok(None);
        }
    }
    let end_t = window.last().map_or(t_prev, |w| w.0);
    let bound = match arc {
        Some(a) => {
            let l_end = l_prev + end_s / a.length();
            let h = 1e-6;
            fold_deviation_along_mm(lags, q_prev, prev, &|lambda| {
                let l = l_prev + (l_end - l_prev) * lambda;
                let d = a.point_at((l + h).min(1.0)) - a.point_at((l - h).max(0.0));
                let n = d.norm();
                if n > 0.0 {
                    d * (1.0 / n)
                } else {
                    d
                }
            })
        }
        None => fold_deviation_mm(lags, q_prev, prev, end_t - t_prev),
    };
    // A ramp ending where the tangency needs it, judged by its written
    // commands (compensate/ramp_band.rs): its largest distance from the
    // path within the tolerance, its mean square within a quarter of the
    // tolerance's square ([`super::ramp_band::within`]).
    let bound = if judged {
        let mut e = super::ramp_band::excursion(lags, q_prev, point.s, t_prev, &written);
        // A staged ramp whose last axis has not crossed its band by the
        // ramp's end (its target drifted its old way over part of its
        // step): read on over the motion's next targets, solved in the new
        // state, as far as the band is crossed (the tool stands there).
        if staged && e.max_mm.is_infinite() {
            let mut p = prev;
            for j in (index..targets.len())
                .filter(|j| along(*j) > end_s * (1.0 + 1e-9))
                .take(STAGED_READ_ON_TARGETS)
            {
                let sol = solve_fixed_in(
                    cells,
                    model,
                    options.method,
                    targets[j],
                    point.s,
                    [false; 3],
                    p,
                )?;
                let q = quantize(sol.q_mm, p);
                if (0..3).any(|a| (q[a] - p[a]) * point.s[a].sign() < -1e-9) {
                    break;
                }
                written.push((targets[j], q, sol.q_mm));
                p = q;
                e = super::ramp_band::excursion(lags, q_prev, point.s, t_prev, &written);
                if e.max_mm.is_finite() {
                    break;
                }
            }
        }
        if !super::ramp_band::within(e, tolerance_mm) {
            return Ok(None);
        }
        e.max_mm
    } else {
        bound
    };
    if bound > tolerance_mm {
        return Ok(None);
    }
    Ok(Some(RampPlan {
        fracs,
        rests,
        insert: insert.into_iter().map(|(j, p, l, _)| (j, p, l)).collect(),
        bound_mm: bound,
    }))
}

/// Whether every reversing axis' command has travelled its whole take-up
/// (`delta`'s own component) in its new way from the ramp's start
/// `q_prev` to `q_end`, within `tolerance_mm`: the dead band keeps the
/// carriage on its old flank until the command has crossed the band
/// (docs/design.md, "Direction state and backlash").
fn reaches_flank(
    delta: Vec3,
    q_prev: Vec3,
    q_end: Vec3,
    point: &crate::compensate::solve::PointSolution,
    tolerance_mm: f64,
) -> bool {
    (0..3).all(|a| {
        !point.reversed[a]
            || (q_end[a] - q_prev[a]) * point.s[a].sign() >= delta[a].abs() - tolerance_mm
    })
}

/// The shortest a ramp may be (mm; 0: no floor). Under G64 without P, a
/// ramp from a motion's start after a corner the planner blends ends
/// outside that blend's zone: its end is a split, and a split nearer the
/// corner than twice the blend's distance `d` makes the planner round the
/// corner tighter and slower (`Run::protect_mm`; blendmath.c
/// `blendComputeParameters` takes at most half of the piece after the
/// corner). Where the zone of the blend at the motion's end
/// (`Run::split_end_mm`) meets it, the ramp runs to the motion's end: a
/// fold into the whole motion, whose joins are the corners at its ends.
/// The ramp's bound (the tool within the run-through tolerance) is
/// checked as for any ramp; a longer ramp turns the path less.
fn ramp_floor_mm(rule: TakeUpRule, run: &Run, index: usize) -> f64 {
    if !(matches!(rule, TakeUpRule::Always) && index == 0 && run.corner_before) {
        return 0.0;
    }
    if run.protect_mm + run.split_end_mm >= run.length_mm {
        run.length_mm
    } else {
        run.protect_mm
    }
}

/// The shortest ramp (mm) of a take-up `delta` whose joins the planner
/// takes as tangent ([`RampPlan`]): a straight ramp turns the path by
/// `|Δ|/L` at both ends; a `smooth` step `3u² − 2u³` over pieces of `ℓ`
/// (`shortest_mm`) turns it by at most `6|Δ|ℓ/L²` at each join, so it
/// needs only `L = √(6|Δ|ℓ/κ)` (κ the share [`RAMP_SHARE`] of the
/// tangency tolerance `kink_tolerance`).
fn ramp_length_mm(delta: Vec3, kink_tolerance: [f64; 3], shortest_mm: f64, smooth: bool) -> f64 {
    (0..3).fold(0.0f64, |m, i| {
        let kappa = (RAMP_SHARE * kink_tolerance[i]).max(1e-300);
        let straight = delta[i].abs() / kappa;
        m.max(if smooth {
            (6.0 * delta[i].abs() * shortest_mm / kappa)
                .sqrt()
                .min(straight)
        } else {
            straight
        })
    })
}

/// The shortest smooth ramp (mm) of a take-up `delta` on a line under G61
/// ([`parabolic_step`]): its joins turn the path by at most `4|Δ|ℓ/L²`
/// (the step's second derivative is ±4, against the cubic's 6), so
/// `L = √(4|Δ|ℓ/κ)`, `√(2/3)` of [`ramp_length_mm`]'s. The shorter ramp
/// leaves the tool off by less where the band is crossed (the target
/// drifts from the held tool along the whole ramp).
fn line_ramp_length_mm(delta: Vec3, kink_tolerance: [f64; 3], shortest_mm: f64) -> f64 {
    (0..3).fold(0.0f64, |m, i| {
        let kappa = (RAMP_SHARE * kink_tolerance[i]).max(1e-300);
        let straight = delta[i].abs() / kappa;
        m.max(
            (4.0 * delta[i].abs() * shortest_mm / kappa)
                .sqrt()
                .min(straight),
        )
    })
}

/// The smooth step of a line's ramp: two parabolas, `2u²` to the middle
/// and `1 − 2(1 − u)²` after it, the step of least largest curvature
/// (constant `|σ''| = 4`) from rest to rest; at even pieces of `h` its
/// second differences are `4h²` (`2h²` at the ends and at the middle).
pub(super) fn parabolic_step(u: f64) -> f64 {
    let u = u.clamp(0.0, 1.0);
    if u <= 0.5 {
        2.0 * u * u
    } else {
        1.0 - 2.0 * (1.0 - u) * (1.0 - u)
    }
}

/// On a take-up moved ahead ([`Ahead`]), an axis in `hold` whose command
/// `q` would turn against its new direction `s` from `prev` stands
/// instead: its target still drifts the old way there, by far less than
/// the band, and the carriage, crossing its band, could not follow it.
fn hold_on_ramp(q: &mut Vec3, prev: Vec3, s: Directions, hold: [bool; 3]) {
    for a in 0..3 {
        if hold[a] && (q[a] - prev[a]) * s[a].sign() < 0.0 {
            q[a] = prev[a];
        }
    }
}

/// The length of a smooth ramp's pieces (mm): twice the feed per servo
/// period (the planner caps a segment's speed at its length per period,
/// and a blend may take half of it), never below the shortest segment.
pub(super) fn shortest_ramp_piece_mm(options: &CompensateOptions, v_mm_s: f64) -> f64 {
    let min_segment = match options.segmentation {
        super::Segmentation::Adaptive { min_length_mm, .. } => min_length_mm,
        _ => super::DEFAULT_MIN_SEGMENT_LENGTH_MM,
    };
    (2.0 * options.planner.shortest_at_feed_mm(v_mm_s * 60.0)).max(min_segment)
}

/// Under G61 (where the planner stops at a join it does not take as
/// tangent), half its tangency tolerance in the plane of `arc` at the
/// run's feed (tp.c `tpSetupTangent`): how far a piece's end tangents may
/// turn from the nominal arc's ([`super::arcs::piece_center`]); `None`
/// under the other modes.
pub(super) fn piece_turn_tolerance(
    options: &CompensateOptions,
    run: &Run,
    arc: &volcomp_gcode::Arc,
) -> Option<f64> {
    let v_mm_s = run.feed_mm_min? / 60.0;
    if !matches!(
        options.take_up_rule(run.mode),
        TakeUpRule::Exact { smooth: true }
    ) {
        return None;
    }
    let (u, v, _) = arc.plane.axes();
    let tol = options.planner.tangent_tolerance(v_mm_s, true);
    Some(0.5 * tol[u].min(tol[v]))
}

/// Under G61, the step an S-curve makes in the plane's normal axis `w`
/// (its axis' straightness across the plane switching tables with its
/// direction: tenths of a micrometre over the S-curve's few tenths of a
/// millimetre, a turn of about 1 mrad at both its joins, above the
/// planner's tangency tolerance, tp.c `tpSetupTangent`) spread over the
/// span around it (arc parameters, both cuts; [`super::arcs::normal_step_span`])
/// as a smooth step `3u² − 2u³`: each command from the span's start to its
/// end moves along `w` by `Δ·(σ − H)`, with `Δ` the step the S-curve's
/// commands make (on a helix, beyond the arc's own progress along `w`
/// across it), `σ` the smooth step over the span and `H` the step as
/// written (0 before the S-curve, linear across it, 1 after). The commands
/// at the span's ends do not move.
///
/// Taken only where no take-up lies inside the span, `w` keeps one
/// direction over it (on a planar arc, the step's: so no command turns
/// against it; on a helix no command may turn against the helix's), and
/// the largest turn of `w`'s slope at the span's joins
/// (as written, quantized) falls below `kappa` or at least below what it
/// was, and no command moves along `w` by more than `limit_mm` (the tool
/// would leave the path by that: G61 asks for the path first, and where the
/// step is too large to spread within it the planner stops at the
/// S-curve's joins instead). Returns the largest distance it adds to the
/// path along `w` (mm).
fn spread_normal_step(
    (commands, states): (&mut [(Vec3, Option<Vec3>)], &[Directions]),
    (arc, pieces, q_in): (&volcomp_gcode::Arc, &[f64], Vec3),
    (index, (a, b)): (usize, (f64, f64)),
    (kappa, limit_mm): (f64, f64),
    quantize: &dyn Fn(Vec3, Vec3) -> Vec3,
) -> Option<f64> {
    let w = arc.plane.axes().2;
    let n = commands.len().min(pieces.len()).min(states.len());
    let find = |x: f64| pieces.iter().position(|p| (p - x).abs() < 1e-12);
    let (k0, k1) = (find(a)?, find(b)?);
    if !(index >= 1 && k0 < index - 1 && k1 > index && k1 + 1 < n) {
        return None;
    }
    let (lo, hi) = (pieces[index - 1], pieces[index]);
    // On a helix the commands across the S-curve also carry the arc's own
    // progress along w: the step is only what they add to it.
    let helical = arc.start[w] != arc.end[w];
    let own_w = if helical {
        arc.point_at(hi)[w] - arc.point_at(lo)[w]
    } else {
        0.0
    };
    let step = commands[index].0[w] - commands[index - 1].0[w] - own_w;
    let dir = states[index][w].sign();
    if step == 0.0
        || (!helical && step * dir <= 0.0)
        || (k0 + 1..=k1).any(|k| states[k][w] != states[index][w])
        || (k0 + 1..=k1).any(|k| commands[k].1.is_some())
    {
        return None;
    }
    let len = arc.length();
    let at = |k: usize| if k == 0 { 0.0 } else { pieces[k - 1] };
    let start_of = |q: &[Vec3], k: usize| if k == 0 { q_in } else { q[k - 1] };
    // The largest turn of w's slope at the joins from the piece before the
    // span to the one after it.
    let worst_turn = |q: &[Vec3]| {
        let slope = |k: usize| (q[k][w] - start_of(q, k)[w]) / ((pieces[k] - at(k)) * len);
        (k0..=k1)
            .map(|k| (slope(k + 1) - slope(k)).abs())
            .fold(0.0f64, f64::max)
    };
    let before: Vec<Vec3> = commands[..=k1 + 1].iter().map(|c| c.0).collect();
    let mut after = before.clone();
    let mut added: f64 = 0.0;
    for k in k0 + 1..k1 {
        let u = (pieces[k] - a) / (b - a);
        let sigma = u * u * (3.0 - 2.0 * u);
        let h = ((pieces[k] - lo) / (hi - lo)).clamp(0.0, 1.0);
        let mut q = after[k];
        q[w] += step * (sigma - h);
        let q = quantize(q, after[k - 1]);
        added = added.max((q[w] - before[k][w]).abs());
        after[k] = q;
    }
    // No command turns against w's direction, nor leaves the path by more
    // than the limit.
    if added > limit_mm || (k0 + 1..=k1).any(|k| (after[k][w] - after[k - 1][w]) * dir < 0.0) {
        return None;
    }
    let (was, now) = (worst_turn(&before), worst_turn(&after));
    if !(now <= kappa || now < was) {
        return None;
    }
    for k in k0 + 1..k1 {
        commands[k].0 = after[k];
    }
    Some(added)
}

/// What [`State::solve_targets`] had before solving a target: where it
/// goes back to when a take-up is moved ahead of an S-curve
/// ([`Ahead`]).
struct Snapshot {
    q_out: Vec3,
    s: Directions,
    s_nominal: Directions,
    t_prev: Vec3,
    summary: super::CompensateSummary,
    ramp_on: bool,
    last_lead: Option<usize>,
    ramp_inserted: Option<usize>,
}

/// A take-up moved ahead of an S-curve under G61/G61.1: the reversal
/// another axis' S-curve causes (its straightness across this axis
/// changes with its direction, by tenths of a micrometre) would otherwise
/// be taken up on a ramp after it, where this axis' carriage stands in
/// its band and leaves the tool off by that step over the whole ramp. The
/// ramp ends where the S-curve begins instead, so the axis is engaged in
/// its new direction when the step comes; before it, its target drifts
/// the other way by far less.
#[derive(Clone, Copy)]
struct Ahead {
    /// The target the ramp starts with (its axes solved in their new
    /// direction from there).
    index: usize,
    /// The target solved again from (the ramp's start point).
    from: usize,
    /// The new direction of each axis taken up ahead.
    axes: [Option<crate::model::Direction>; 3],
    /// The ramp's length (mm): to the S-curve's start.
    length_mm: f64,
    /// The S-curve's place in the motion's transitions (none for a ramp
    /// centred on a reversal along a line).
    transition: usize,
    /// A ramp centred on a reversal along a line
    /// (compensate/ramp_centre.rs), not one ending at an S-curve.
    centred: bool,
    /// A centred ramp whose reversing axes catch up their take-ups one
    /// after the other (compensate/ramp_stage.rs).
    staged: bool,
}

/// The targets, the arc parameters of their pieces and the transitions of
/// a motion before a take-up was moved ahead ([`Ahead`]).
type AheadSaved = (Vec<Vec3>, Option<Vec<f64>>, Vec<super::arcs::Transition>);

/// A take-up being spread along the path in `solve_targets`: the take-up,
/// the share of it still to catch up at each next target, the share left
/// before the current one, the axes held on the ramp, and (on a staged
/// ramp, [`RampPlan::rests`]) the take-up left at each next target with the
/// axes still waiting there, and the take-up left before the current one.
type RampUnderWay = (
    Vec3,
    std::collections::VecDeque<f64>,
    f64,
    [bool; 3],
    (std::collections::VecDeque<(Vec3, [bool; 3])>, Vec3),
);

/// How a motion runs on the machine, for the take-up decisions
/// ([`super::TakeUpRule`]): its path-control mode, its feed (mm/min; `None`
/// where not per minute), whether it is an arc, and whether the original
/// program has a corner where it begins (a join the planner does not take
/// as tangent: the machine stops there under G61, so a take-up block there
/// costs nothing).
#[derive(Debug, Clone, Copy)]
pub(super) struct Run {
    pub(super) mode: volcomp_gcode::PathMode,
    pub(super) feed_mm_min: Option<f64>,
    pub(super) arc: bool,
    pub(super) corner_before: bool,
    /// Under G64, how far from the corner before it (and, taken alike, from
    /// its end) a piece must reach so the planner's blend there is not cut
    /// short: twice the blend distance the feed needs, at most the length
    /// a blend may take of either neighbour (half of it); 0 elsewhere
    /// ([`protect_blends`]).
    pub(super) protect_mm: f64,
    /// Under G64, how far from its end a piece must reach: twice the
    /// farthest a blend at a corner of any angle reaches into the motion
    /// (the next motion is not known yet;
    /// [`super::PlannerLimits::blend_reach_any_corner_mm`]); 0 elsewhere.
    pub(super) protect_end_mm: f64,
    /// How far from its end no split point is put (mm; [`protect_blends`],
    /// [`ramp_floor_mm`]): under G64 without P, after a corner, twice the
    /// reach of the blend at its end taken as the one at its start
    /// ([`end_blend_reach_at_mm`]); else `protect_end_mm`.
    pub(super) split_end_mm: f64,
    /// The motion's length (mm).
    pub(super) length_mm: f64,
    /// Under G64, the corner before it is one LinuxCNC blends parabolically
    /// ([`super::planar::parabolic_into`]).
    pub(super) parabolic_before: bool,
    /// Under G64 P, the speed (mm/s) of the blend at the corner before it,
    /// from the distance `d` it takes of each side (`protect_mm / 2`): its
    /// arc of radius `d·tan θ` run at `√(a_n · d · tan θ)`
    /// ([`super::end_zone::blend_speed_mm_s`]); infinite where there is
    /// no corner blended within a P.
    pub(super) blend_speed_before_mm_s: f64,
}

impl Run {
    /// The run of `m`, which follows a motion whose end tangent and length
    /// were `before` (`None`: not a feed motion, or unknown — taken as a
    /// corner).
    pub(super) fn of(
        m: &volcomp_gcode::Motion,
        before: Option<(Vec3, f64)>,
        planner: &super::PlannerLimits,
    ) -> Run {
        let feed_mm_min =
            (m.feed_mode == volcomp_gcode::FeedMode::PerMinute && m.feed > 0.0).then_some(m.feed);
        let arc = matches!(m.kind, volcomp_gcode::MotionKind::Arc(_));
        let (t2, _) = tangents(m);
        // A G64 corner's deflection and the blend distance its feed needs,
        // computed once for the blend before and the one taken alike at
        // the end (`split_end_mm`).
        let mut blended_corner: Option<(f64, f64)> = None;
        let mut parabolic_before = false;
        let mut blend_speed_before_mm_s = f64::INFINITY;
        let (corner_before, protect_mm) = match (before, feed_mm_min) {
            (Some((t1, prev_len)), Some(f)) => {
                let corner = planner.kink_ratio(t1, t2, f / 60.0, arc) >= 1.0;
                let blend = matches!(m.path_mode, volcomp_gcode::PathMode::Blend { .. });
                let protect = if corner && blend {
                    parabolic_before = super::planar::parabolic_into(t1, m);
                    let phi = super::joins::deflection_rad(t1, t2);
                    let speed_mm = planner.blend_distance_at_mm(phi, f / 60.0);
                    blended_corner = Some((phi, speed_mm));
                    // G64 P p: the blend keeps within p of the corner.
                    let within = match m.path_mode {
                        volcomp_gcode::PathMode::Blend { tolerance_mm, .. }
                            if tolerance_mm > 0.0 =>
                        {
                            planner.blend_distance_within_at_mm(phi, tolerance_mm)
                        }
                        _ => f64::INFINITY,
                    };
                    let d = speed_mm
                        .min(within)
                        .min(0.5 * prev_len)
                        .min(0.5 * length_mm(m));
                    if within.is_finite() {
                        blend_speed_before_mm_s =
                            super::end_zone::blend_speed_mm_s(f / 60.0, speed_mm, d).min(f / 60.0);
                    }
                    2.0 * d
                } else {
                    0.0
                };
                (corner, protect)
            }
            _ => (true, 0.0),
        };
        // Under G64 P p: the reach within p of a corner of any angle is
        // short (0.34 mm at P0.005 and F6000). Without P it is up to half
        // the line at some angle, and the splits the contour tolerance
        // needs there would be lost wherever the corner turns out gentler:
        // the corner at the end is taken as the one at the start
        // ([`end_blend_reach_at_mm`]).
        let protect_end_mm = match (m.path_mode, feed_mm_min) {
            (volcomp_gcode::PathMode::Blend { tolerance_mm, .. }, Some(f))
                if tolerance_mm > 0.0 =>
            {
                2.0 * planner.blend_reach_any_corner_mm(f / 60.0, length_mm(m), Some(tolerance_mm))
            }
            _ => protect_mm,
        };
        let split_end_mm = match (m.path_mode, blended_corner) {
            // Here `corner_before` with a feed per minute, under G64
            // (`blended_corner` is known exactly then).
            (volcomp_gcode::PathMode::Blend { tolerance_mm, .. }, Some((phi, speed_mm)))
                if tolerance_mm <= 0.0 =>
            {
                2.0 * end_blend_reach_at_mm(planner, phi, speed_mm, length_mm(m))
            }
            _ => protect_end_mm,
        };
        Run {
            mode: m.path_mode,
            feed_mm_min,
            arc,
            corner_before,
            protect_mm,
            protect_end_mm,
            split_end_mm,
            length_mm: length_mm(m),
            parabolic_before,
            blend_speed_before_mm_s,
        }
    }
}

/// [`end_blend_reach_at_mm`] of the corner from unit tangent `t1` to `t2`
/// at `v_mm_s`.
#[cfg(test)]
pub(super) fn end_blend_reach_mm(
    planner: &super::PlannerLimits,
    t1: Vec3,
    t2: Vec3,
    v_mm_s: f64,
    length_mm: f64,
) -> f64 {
    let phi = super::joins::deflection_rad(t1, t2);
    end_blend_reach_at_mm(
        planner,
        phi,
        planner.blend_distance_at_mm(phi, v_mm_s),
        length_mm,
    )
}

/// Under G64 without P, how far from its end a motion of `length_mm` run
/// at `v_mm_s` keeps its pieces whole for the blend at its end (mm, half
/// the protected length): the corner there is not known when the motion
/// is compensated (the next block is read after), so it is taken as the
/// corner at its start, of deflection `phi` ([`super::joins::deflection_rad`]),
/// with what the motion itself allows that blend. LinuxCNC's line–line
/// blend takes `d = min(L₁/2, L₂/2, d_tol, R/tan θ)` of each line
/// (`blendComputeParameters`, src/emc/tp/blendmath.c, with `L/2` from
/// `tpCreateLineLineBlend`, tp.c), `d_tol = T cos θ / (1 − sin θ)` for the
/// blend tolerance `T`, a quarter of the shorter line without P
/// (`tcFindBlendTolerance`, tc.c), and `R = v²/a_n` at full speed
/// (`speed_mm`, [`super::PlannerLimits::blend_distance_at_mm`] at
/// `v_mm_s`: the distance `R/tan θ`). Of these the motion's own half and
/// its own quarter for `T` are known; the length of the motion before,
/// which limits the corner at the start, is no limit at the end.
fn end_blend_reach_at_mm(
    planner: &super::PlannerLimits,
    phi: f64,
    speed_mm: f64,
    length_mm: f64,
) -> f64 {
    speed_mm
        .min(planner.blend_distance_within_at_mm(phi, 0.25 * length_mm))
        .min(0.5 * length_mm)
}

/// The length of a motion (mm): of its line, or of its arc (helix).
pub(super) fn length_mm(m: &volcomp_gcode::Motion) -> f64 {
    match m.kind {
        volcomp_gcode::MotionKind::Arc(arc) => arc.length(),
        _ => (m.end - m.start).norm(),
    }
}

/// Keeps the split points of a line from `start` through `targets` out of
/// the blend zones at its ends: none nearer than `protect_mm` to either
/// end (docs/compensation.md, "Pieces the planner runs at full speed").
/// Where points were dropped, one is put at that distance, so the rest of
/// the line keeps its own; the pieces at the ends then run whole, and the
/// planner blends the corners as it blends the original's.
pub(super) fn protect_blends(
    targets: &mut Vec<Vec3>,
    start: Vec3,
    (protect_mm, protect_end_mm): (f64, f64),
) {
    let Some(&end) = targets.last() else { return };
    let length = (end - start).norm();
    if protect_mm.max(protect_end_mm) <= 0.0 || targets.len() < 2 || length <= 0.0 {
        return;
    }
    if length <= protect_mm + protect_end_mm {
        targets.clear();
        targets.push(end);
        return;
    }
    let u = (end - start) * (1.0 / length);
    let along = |p: Vec3| (p - start).dot(u);
    let splits = &targets[..targets.len() - 1];
    let near_start = protect_mm > 0.0 && splits.iter().any(|p| along(*p) <= protect_mm);
    let near_end =
        protect_end_mm > 0.0 && splits.iter().any(|p| along(*p) >= length - protect_end_mm);
    let inner: Vec<Vec3> = splits
        .iter()
        .copied()
        .filter(|p| along(*p) > protect_mm && along(*p) < length - protect_end_mm)
        .collect();
    targets.clear();
    if near_start {
        targets.push(start + u * protect_mm);
    }
    targets.extend(inner);
    if near_end {
        targets.push(start + u * (length - protect_end_mm));
    }
    targets.push(end);
}

/// The unit tangents of a motion at its start and its end.
pub(super) fn tangents(m: &volcomp_gcode::Motion) -> (Vec3, Vec3) {
    let unit = |v: Vec3| {
        let n = v.norm();
        if n > 0.0 {
            v * (1.0 / n)
        } else {
            Vec3::ZERO
        }
    };
    match m.kind {
        volcomp_gcode::MotionKind::Arc(arc) => {
            let h = 1e-6 / arc.sweep_rad.abs().max(1e-9);
            let h = h.min(1e-3);
            (
                unit(arc.point_at(h) - arc.start),
                unit(arc.end - arc.point_at(1.0 - h)),
            )
        }
        _ => {
            let t = unit(m.end - m.start);
            (t, t)
        }
    }
}

/// Where [`State::solve_targets`] may put a lead piece (see [`lead_target`]).
pub(super) enum Leads<'a> {
    /// Nowhere: fixed segmentations, cycles, splines, moves with extra
    /// axes, inverse time.
    Nowhere,
    /// On the straight moves between the targets.
    Lines,
    /// On the pieces of `arc`, whose end parameters `pieces` are kept in
    /// step with the targets.
    Arc {
        arc: &'a volcomp_gcode::Arc,
        pieces: &'a mut Vec<f64>,
    },
}

/// The targets of one motion, in order (the last is the motion's end),
/// and what [`State::solve_targets`] needs to know of the motion: where a
/// lead piece may go, where the motion starts, whether it is a feed move
/// (a rapid gets no take-up).
pub(super) struct Targets<'a> {
    pub(super) points: &'a mut Vec<Vec3>,
    pub(super) leads: Leads<'a>,
    pub(super) start: Vec3,
    pub(super) feed_like: bool,
    pub(super) run: Run,
}

impl State<'_> {
    /// Solves one whole motion of a block written as segments (a canned
    /// cycle's, a spline's): its targets as the segmentation gives them,
    /// without lead pieces ([`State::solve_targets`]).
    pub(super) fn solve_motion(
        &mut self,
        model: &dyn ErrorModel,
        frame: &Frame,
        m: &volcomp_gcode::Motion,
        feed_like: bool,
        line: u64,
    ) -> Result<Vec<(Vec3, Option<Vec3>)>, CompensationError> {
        let (options, file) = (self.walk.options, self.walk.file);
        super::targets::check_target_count(m, options, file, line)?;
        let mut targets =
            super::targets::targets_with_estimate(m, options, model, self.s, &mut self.estimate_mm)
                .map_err(|source| model_error(file, line, source))?;
        let run = Run {
            corner_before: true,
            ..Run::of(m, None, &options.planner)
        };
        self.solve_targets(
            model,
            (frame, frame),
            Targets {
                points: &mut targets,
                leads: Leads::Nowhere,
                start: m.start,
                feed_like,
                run,
            },
            line,
        )
    }

    /// Solves the targets of one motion in order; returns each command and
    /// the take-up move written before it, if any. `frames` are the frame
    /// of the motion and the one a take-up before its first command is
    /// written in (the previous line's, where that take-up runs before the
    /// line's own words).
    pub(super) fn solve_targets(
        &mut self,
        model: &dyn ErrorModel,
        frames: (&Frame, &Frame),
        motion: Targets<'_>,
        line: u64,
    ) -> Result<Vec<(Vec3, Option<Vec3>)>, CompensationError> {
        let (options, file) = (self.walk.options, self.walk.file);
        let (frame, first_take_up_frame) = frames;
        let Targets {
            points: targets,
            mut leads,
            start,
            feed_like,
            run,
        } = motion;
        let rule = options.take_up_rule(run.mode);
        // The buffer kept between motion lines (the writer gives it back).
        let mut commands = std::mem::take(&mut self.commands);
        commands.clear();
        commands.reserve(targets.len());
        let commands_start = self.q_out;
        let state_start = self.s;
        self.states.clear();
        self.ramp_mids.clear();
        self.take_up_blocks.clear();
        let mut t_prev = start;
        let mut forced: Option<Directions> = None;
        let mut transitions = std::mem::take(&mut self.transitions);
        // The index of the last lead piece inserted: neither it nor the
        // target after it gets another (the work stays bounded).
        let mut last_lead: Option<usize> = None;
        // A take-up being spread along the path ([`RampPlan`]): the take-up
        // and the share of it still to catch up at each next target; and
        // the index a ramp's end was last inserted before (one insertion
        // per reversal).
        // (On a staged ramp, the take-up left at each next target and at
        // the last: [`RampPlan::rests`].)
        let mut ramp: Option<RampUnderWay> = None;
        let mut ramp_inserted: Option<usize> = None;
        // Take-ups moved ahead of an S-curve ([`Ahead`]): the state before
        // each target (kept only where one may happen), the one pending,
        // and the transitions already tried.
        // (Also on a line under G61, for a ramp centred on its reversal:
        // compensate/ramp_centre.rs.)
        let line_take_ups = matches!(leads, Leads::Lines)
            && feed_like
            && options.take_up
            && options.fold_take_ups
            && options.directions == DirectionPolicy::Commanded
            && run.feed_mm_min.is_some_and(|f| f > 0.0);
        let centre_lines = matches!(rule, TakeUpRule::Exact { smooth: true }) && line_take_ups;
        // Under G64 P the same on a line: a take-up block there is one
        // (compensate/take_up_advance.rs).
        let adv_lines = matches!(rule, TakeUpRule::Within(_)) && line_take_ups;
        // (And inside an arc: compensate/arcs.rs `centred_start_on_arc`.)
        let centre_arcs = matches!(rule, TakeUpRule::Exact { smooth: true })
            && matches!(leads, Leads::Arc { .. })
            && feed_like
            && options.take_up
            && options.fold_take_ups
            && options.directions == DirectionPolicy::Commanded
            && run.feed_mm_min.is_some_and(|f| f > 0.0);
        let keep_history = (matches!(rule, TakeUpRule::Exact { smooth: true })
            && matches!(leads, Leads::Arc { .. })
            && !transitions.is_empty())
            || centre_lines
            || centre_arcs;
        // The reversals (their points) a centred ramp was tried for, and
        // whether a staged one was too (compensate/ramp_stage.rs).
        let mut centred_tried: Vec<(Vec3, bool)> = Vec::new();
        // Where a target was inserted for an axis a take-up block left
        // ahead of its target (compensate/take_up_stand.rs): once.
        let mut stood: Option<Vec3> = None;
        let mut history: Vec<Snapshot> = Vec::new();
        let mut ahead: Option<Ahead> = None;
        let mut ahead_tried: Vec<usize> = Vec::new();
        // The S-curves (their places in the transitions) whose ramp ahead
        // was refused for the room it leaves, and those where it is taken
        // as before, the ramp after the S-curve needing a block.
        let mut ahead_capped: Vec<usize> = Vec::new();
        let mut ahead_loose: Vec<usize> = Vec::new();
        // The targets (arc parameters) and transitions before one was
        // moved ahead, for going back to them.
        let mut ahead_saved: Option<AheadSaved> = None;
        // The axes taken up ahead, held in their new direction up to the
        // S-curve (its place in the transitions).
        let mut ahead_hold: Option<(usize, [bool; 3])> = None;
        // The per-point records, passed on once the motion is solved (a
        // take-up moved ahead solves some targets again).
        // (One buffer kept between motions: no allocation per line.)
        let mut records = std::mem::take(&mut self.records);
        records.clear();
        // The map's cells kept between points and motions ([`AxisCells`]):
        // every line's model is the walk's map with the line's tool.
        // (Lost on an error return: the next motion starts from none.)
        let mut cells = self.cells.take().unwrap_or_default();
        // The target a hold at an arc's planar start ends at
        // (compensate/turn_back.rs).
        let mut planar_hold_until: Option<usize> = None;
        // Whether the normal axis was held at the first target of an arc
        // after a planar corner (compensate/planar.rs
        // `normal_held_at_start`).
        let mut normal_held = false;
        // The axes a plunge before held through its end, and those this
        // motion holds through its end, a plunge ([`hold_to_plunge_end`]).
        let plunge_held_before = std::mem::take(&mut self.plunge_held);
        let mut plunge_held: Option<([bool; 3], Directions)> = None;
        let mut index = 0;
        while index < targets.len() {
            if keep_history && history.len() == index {
                history.push(Snapshot {
                    q_out: self.q_out,
                    s: self.s,
                    s_nominal: self.s_nominal,
                    t_prev,
                    summary: self.summary.clone(),
                    ramp_on: ramp.is_some(),
                    last_lead,
                    ramp_inserted,
                });
            }
            let t = &targets[index];
            let q_from = self.q_out;
            // On a lead piece the reversing axis runs its new way from the
            // start, across an S-curve it ends so: the solver starts from
            // that state.
            let was_forced = forced.is_some();
            let mut s_from = forced.take().unwrap_or(self.s);
            let transition = transitions.iter().find(|tr| tr.index == index).copied();
            if let Some(tr) = transition {
                s_from[tr.axis] = tr.direction;
            }
            if let Some(ah) = ahead.filter(|ah| ah.index == index) {
                for (a, d) in ah.axes.iter().enumerate() {
                    if let Some(d) = d {
                        s_from[a] = *d;
                    }
                }
            }
            let quantize = |q: Vec3| frame.quantize(q, q_from);
            let point = match options.directions {
                DirectionPolicy::Commanded => solve_consistent_in(
                    &mut cells,
                    model,
                    options.method,
                    *t,
                    (self.q_out, s_from),
                    &quantize,
                )
                .map(|mut p| {
                    p.reversed = [0, 1, 2].map(|a| p.s[a] != self.s[a]);
                    p
                }),
                DirectionPolicy::Nominal => {
                    let s_nom = next_state(self.s_nominal, *t - t_prev);
                    solve_fixed_in(
                        &mut cells,
                        model,
                        options.method,
                        *t,
                        s_nom,
                        [false; 3],
                        Vec3::ZERO,
                    )
                    .map(|sol| {
                        let q = quantize(sol.q_mm);
                        crate::compensate::solve::PointSolution {
                            q_mm: q,
                            s: s_nom,
                            iterations: sol.iterations,
                            residual_um: sol.residual_um,
                            reversed: [false; 3],
                            held: [false; 3],
                        }
                    })
                }
            }
            .map_err(|source| command_error(model, file, line, *t, source))?;
            // A reversal smaller than the axis' band: the axis held instead
            // (compensate/solve.rs), where the mode allows what it leaves
            // and nothing else decided this point's state.
            let hold_bound = options
                .hold_tolerance_mm(rule)
                .filter(|_| feed_like && !was_forced && transition.is_none());
            // Under G64 P, a reversal whose band passes P held within half
            // the bound (compensate/arc_fold.rs).
            let hold_bound = match hold_bound {
                Some(b) => Some(
                    super::arc_fold::hold_bound_for_band_mm(
                        &mut cells,
                        model,
                        (rule, b),
                        (self.q_out, self.s),
                        point.reversed,
                    )
                    .map_err(|source| model_error(file, line, source))?
                        // Under G64 P less what the next S-curve's switch
                        // adds to the hold's offset
                        // (compensate/transition_hold.rs).
                        - if matches!(rule, TakeUpRule::Within(_)) {
                            super::transition_hold::step_ahead_mm(
                                &mut cells,
                                model,
                                (transitions.as_slice(), targets.as_slice(), index),
                                &point,
                                self.s,
                            )
                            .map_err(|source| model_error(file, line, source))?
                        } else {
                            0.0
                        },
                ),
                None => None,
            };
            // Under G64 P inside a line, held only where the take-up would
            // kink the path, as under G64 (compensate/turn_back.rs).
            let (hold_bound, kink_hold_bound) =
                match super::turn_back::holds_at(rule, index, matches!(leads, Leads::Lines)) {
                    true => (hold_bound, None),
                    false => (None, hold_bound),
                };
            // Checked before a hold: a held point is off the target by
            // what the hold allows, on purpose (the free axes no more than
            // here, solve.rs `hold_small_reversals`).
            check_converged(&point, options, *t, file, line)?;
            let solve_residual_um = point.residual_um;
            let point = match hold_bound {
                Some(bound) => hold_small_reversals_in(
                    &mut cells,
                    model,
                    options.method,
                    *t,
                    (self.q_out, self.s),
                    &quantize,
                    (&point, bound),
                )
                .map_err(|source| model_error(file, line, source))?
                .map_or(point, |held| {
                    self.summary.count_hold(held.residual_um);
                    held
                }),
                None => point,
            };
            // G61: a reversal at a line's end of an axis the line does not
            // move and the next motion moves its old way, held through the
            // corner (compensate/tail_hold.rs).
            let point = match (rule, self.next_dir) {
                (TakeUpRule::Exact { .. }, Some((end, next_dir)))
                    if feed_like
                        && *t == end
                        && !was_forced
                        && transition.is_none()
                        && ramp.is_none()
                        && index + 1 == targets.len()
                        && !matches!(leads, Leads::Arc { .. })
                        && super::tail_hold::only_still_axes_reverse(
                            point.reversed,
                            start,
                            targets.as_slice(),
                        )
                        && self.next_direction(next_dir).is_some_and(|u| {
                            super::tail_hold::next_turns_back(point.reversed, self.s, u)
                        }) =>
                {
                    hold_small_reversals_in(
                        &mut cells,
                        model,
                        options.method,
                        *t,
                        (self.q_out, self.s),
                        &quantize,
                        (&point, super::tail_hold::HOLD_MM),
                    )
                    .map_err(|source| model_error(file, line, source))?
                    .map_or(point, |held| {
                        self.summary.count_hold(held.residual_um);
                        held
                    })
                }
                _ => point,
            };
            // G64 without P: a reversal the next target of the move turns
            // back is held instead (compensate/turn_back.rs).
            let point = match rule {
                TakeUpRule::Always
                    if feed_like
                        && !was_forced
                        && transition.is_none()
                        && ramp.is_none()
                        && options.fold_take_ups
                        && point.reversed.iter().any(|r| *r) =>
                {
                    super::turn_back::held_before_turn_back(
                        &mut cells,
                        model,
                        options.method,
                        &quantize,
                        (*t, self.q_out, self.s),
                        &point,
                        (
                            &targets[index + 1..],
                            [0, 1, 2].map(|a| (t[a] - t_prev[a]).abs() > 1e-9),
                        ),
                        (
                            RUN_THROUGH_TOLERANCE_MM,
                            // The normal axis at the start of an arc after
                            // a planar G64 corner (compensate/planar.rs):
                            // the hold keeps the blend arc, and needs only
                            // to end within the move.
                            // (and on to where that hold ends).
                            !(self
                                .planar_corner_normal
                                .is_some_and(|w| point.s[w] != self.s[w])
                                && (index == 0 || planar_hold_until.is_some_and(|u| index < u))),
                        ),
                    )
                    .map_err(|source| model_error(file, line, source))?
                    .map_or(point, |(held, ends)| {
                        if index == 0 && self.planar_corner_normal.is_some() {
                            planar_hold_until = Some(index + 1 + ends);
                        }
                        self.summary.count_hold(held.residual_um);
                        held
                    })
                }
                _ => point,
            };
            // G64 without P: the normal axis' reversal at the start of an
            // arc after a planar corner held over the first piece, which
            // stays planar (compensate/planar.rs `normal_held_at_start`).
            let point = match (rule, self.planar_corner_normal) {
                (TakeUpRule::Always, Some(w))
                    if index == 0
                        && self.planar_corner_blends
                        && targets.get(1).is_some_and(|n| {
                            super::planar::fold_after_hold_is_gentle(
                                &options.planner,
                                run.feed_mm_min,
                                (point.q_mm[w] - self.q_out[w]).abs(),
                                (*n - *t).norm(),
                                w,
                            )
                        })
                        && feed_like
                        && !was_forced
                        && transition.is_none()
                        && ramp.is_none()
                        && options.fold_take_ups
                        && point.reversed[w] =>
                {
                    super::planar::normal_held_at_start(
                        &mut cells,
                        model,
                        (options.method, &quantize),
                        (*t, self.q_out, self.s),
                        &point,
                        w,
                    )
                    .map_err(|source| model_error(file, line, source))?
                    .map_or(point, |held| {
                        normal_held = true;
                        self.summary.count_hold(held.residual_um);
                        held
                    })
                }
                _ => point,
            };
            // Across an S-curve only its own axis reverses: another axis
            // that would (its straightness changing with the S-curve's axis'
            // direction, by tenths of a micrometre) is held for the piece,
            // and reverses on the next one, where the piece is long enough
            // to take its band up gently.
            // G64 without P: an axis whose command turns back by less than
            // its band is held instead of its take-up only where that
            // take-up, folded or on a lead piece, would turn the path by
            // more than the planner takes as tangent (decided below, where
            // its piece is known); a hold that leaves any axis reversing
            // is not taken (its take-up would be lost).
            // The hold is solved only where it is asked for (most take-ups
            // fold tangent): from the point and state as they are here.
            // (Not on the piece after the normal axis' hold at a planar
            // corner: the take-up folds there, whatever its kink.)
            let after_normal_hold = index == 1 && normal_held;
            let mut hold_alt = ((matches!(rule, TakeUpRule::Always) || kink_hold_bound.is_some())
                && !after_normal_hold
                && feed_like
                && !was_forced
                && transition.is_none()
                && point.reversed.iter().any(|r| *r))
            .then_some((*t, self.q_out, self.s, point));
            let held_instead = |cells: &mut AxisCells,
                                from: Option<(
                Vec3,
                Vec3,
                Directions,
                crate::compensate::solve::PointSolution,
            )>| {
                let Some((t, q_prev, s_prev, point)) = from else {
                    return Ok(None);
                };
                hold_small_reversals_in(
                    cells,
                    model,
                    options.method,
                    t,
                    (q_prev, s_prev),
                    &quantize,
                    (&point, kink_hold_bound.unwrap_or(f64::INFINITY)),
                )
                .map(|held| held.filter(|h| !h.reversed.iter().any(|r| *r)))
                .map_err(|source| model_error(file, line, source))
            };
            let mut point = point;
            // On a take-up moved ahead, its axes keep their new direction
            // to the S-curve ([`Ahead`]).
            let mut hold = ramp.as_ref().map_or([false; 3], |r| r.3);
            if let Some((k, axes)) = ahead_hold {
                if transitions.get(k).is_some_and(|tr| index <= tr.index) {
                    for a in 0..3 {
                        hold[a] |= axes[a];
                    }
                } else {
                    ahead_hold = None;
                }
            }
            for (a, held) in hold.iter().enumerate() {
                if *held && point.reversed[a] {
                    point.q_mm[a] = self.q_out[a];
                    point.s[a] = self.s[a];
                    point.reversed[a] = false;
                }
            }
            // Under G64 (with P or without) the free axes solved again with
            // the held ones in their old tables; under G61 not: the take-up
            // after the S-curve is written for the free axes where the new
            // tables put them (compensate/transition_hold.rs).
            if let Some(tr) = transition {
                super::transition_hold::hold_across(
                    &mut cells,
                    model,
                    (options.method, &quantize),
                    (*t, self.q_out, self.s),
                    &mut point,
                    (tr.axis, super::transition_hold::resolves_free_axes(rule)),
                )
                .map_err(|source| model_error(file, line, source))?;
            }
            let correction = (point.q_mm - *t).norm();
            if correction > options.max_correction_mm {
                return Err(CompensationError::AtLine {
                    file: file.into(),
                    line,
                    message: format!(
                        "the correction here would be {:.1} µm, above the limit of {:.1} µm",
                        correction * 1e3,
                        options.max_correction_mm * 1e3
                    ),
                    help: crate::error::help::CORRECTION_LIMIT.into(),
                });
            }
            // A reversal right after another axis' S-curve: taken up ahead
            // of it where the arc before leaves room ([`Ahead`]).
            let mut back_to: Option<(usize, Option<(Vec3, f64)>)> = None;
            if let (true, Leads::Arc { arc, pieces }) = (
                keep_history
                    && ramp.is_none()
                    && feed_like
                    && options.take_up
                    && options.fold_take_ups
                    && options.directions == DirectionPolicy::Commanded,
                &leads,
            ) {
                let found = transitions
                    .iter()
                    .enumerate()
                    .find(|(_, tr)| tr.index >= 1 && tr.index + 1 == index)
                    .map(|(k, tr)| (k, *tr));
                if let Some((k, tr)) = found.filter(|(k, _)| !ahead_tried.contains(k)) {
                    let reversing = [0, 1, 2].map(|a| a != tr.axis && point.reversed[a]);
                    if reversing.iter().any(|r| *r) {
                        ahead_tried.push(k);
                        let mut s_new = self.s;
                        for a in (0..3).filter(|a| reversing[*a]) {
                            s_new[a] = point.s[a];
                        }
                        let tu = take_up_command(
                            &mut cells,
                            model,
                            self.q_out,
                            self.s,
                            s_new,
                            reversing,
                            (point.q_mm, true),
                            frame,
                        )
                        .map_err(|source| model_error(file, line, source))?;
                        // Only a reversal the S-curve makes: the axis'
                        // command, its band aside, went back against its
                        // old direction across the S-curve by more than
                        // the contour tolerance (a target that turns
                        // there by itself drifts far less).
                        let from = commands[tr.index - 1].0;
                        let axes = [0, 1, 2].map(|a| {
                            let back = (point.q_mm[a] - (tu[a] - self.q_out[a]) - from[a])
                                * self.s[a].sign();
                            (reversing[a] && back < -options.fold_tolerance_mm())
                                .then_some(point.s[a])
                        });
                        let v_mm_s = run.feed_mm_min.map_or(0.0, |f| f / 60.0);
                        let shortest = shortest_ramp_piece_mm(options, v_mm_s);
                        let need = ramp_length_mm(
                            tu - self.q_out,
                            options.planner.tangent_tolerance(v_mm_s.max(1e-9), true),
                            shortest,
                            true,
                        );
                        let len = arc.length();
                        let l_end = pieces[tr.index - 1];
                        let l0 = l_end - need / len;
                        if axes.iter().any(Option::is_some)
                            && v_mm_s > 0.0
                            && need > 0.0
                            && need.is_finite()
                            && l0 > 0.0
                        {
                            let p = pieces.partition_point(|x| *x <= l0);
                            let l_ps = if p == 0 { 0.0 } else { pieces[p - 1] };
                            let mut l_start = l0.min(pieces[p] - shortest / len);
                            let insert = (l_start - l_ps) * len >= shortest;
                            if !insert {
                                l_start = l_ps;
                            }
                            // Nothing else happens between the ramp's
                            // start and the S-curve.
                            let quiet = l_start > 0.0
                                && p < tr.index
                                && (p..=tr.index).all(|j| !history[j].ramp_on)
                                && (p..tr.index).all(|j| {
                                    commands[j].1.is_none() && self.states[j] == self.states[p]
                                })
                                && transitions
                                    .iter()
                                    .all(|o| o.index < p || o.index >= tr.index);
                            if quiet {
                                ahead = Some(Ahead {
                                    index: if insert { p + 1 } else { p },
                                    from: p,
                                    axes,
                                    length_mm: (l_end - l_start) * len,
                                    transition: k,
                                    centred: false,
                                    staged: false,
                                });
                                back_to =
                                    Some((p, insert.then(|| (arc.point_at(l_start), l_start))));
                            }
                        }
                    }
                }
            }
            if let Some((p, insert)) = back_to {
                self.go_back(&history[p], p, (&mut commands, &mut records));
                history.truncate(p + 1);
                let h = &history[p];
                (t_prev, last_lead, ramp_inserted) = (h.t_prev, h.last_lead, h.ramp_inserted);
                (ramp, forced, ahead_hold) = (None, None, None);
                ahead_saved = Some((
                    targets.clone(),
                    match &leads {
                        Leads::Arc { pieces, .. } => Some(pieces.to_vec()),
                        _ => None,
                    },
                    transitions.clone(),
                ));
                if let Some((pt, l)) = insert {
                    targets.insert(p, pt);
                    if let Leads::Arc { pieces, .. } = &mut leads {
                        pieces.insert(p, l);
                    }
                    for tr in transitions.iter_mut().filter(|tr| tr.index >= p) {
                        tr.index += 1;
                    }
                }
                index = p;
                continue;
            }
            let pre_length = ahead.filter(|ah| ah.index == index).map(|ah| ah.length_mm);
            let ahead_axes = ahead.filter(|ah| ah.index == index).map(|ah| ah.axes);
            let mut take_up = None;
            if options.take_up
                && feed_like
                && options.directions == DirectionPolicy::Commanded
                && point.reversed.iter().any(|r| *r)
            {
                take_up = Some(
                    take_up_command(
                        &mut cells,
                        model,
                        self.q_out,
                        self.s,
                        point.s,
                        point.reversed,
                        (point.q_mm, matches!(rule, TakeUpRule::Exact { .. })),
                        if commands.is_empty() {
                            first_take_up_frame
                        } else {
                            frame
                        },
                    )
                    .map_err(|source| model_error(file, line, source))?,
                );
            }
            // A take-up never goes past the segment's own command: the segment
            // must continue in the new direction, not reverse once more.
            let mut short_mm = [0.0; 3];
            if let Some(tu) = take_up.as_mut() {
                for a in 0..3 {
                    if point.reversed[a] && (tu[a] - point.q_mm[a]) * point.s[a].sign() > 0.0 {
                        short_mm[a] = (tu[a] - point.q_mm[a]).abs();
                        tu[a] = point.q_mm[a];
                    }
                }
            }
            // Under G61 and G61.1, a reversing axis whose take-up that cut
            // stops short of its new flank by more than the contour
            // tolerance never crosses its band: the command turned back by
            // less than the band, so the dead band keeps the carriage on
            // its old flank (docs/compensation.md, "Take-ups folded into
            // the move") and the state the point was solved in is not the
            // machine's. The point is solved again with those axes in
            // their old direction (the others reversing as they need), if
            // that is consistent and its own take-ups reach their flanks.
            let tolerance_mm = options.fold_tolerance_mm();
            if let (Some(_), TakeUpRule::Exact { .. }, true) = (
                take_up,
                rule,
                feed_like
                    && !was_forced
                    && transition.is_none()
                    && ramp.is_none()
                    && ahead.is_none()
                    && short_mm.iter().any(|s| *s > tolerance_mm),
            ) {
                let keep = short_mm.map(|s| s > tolerance_mm);
                let kept = solve_keeping_in(
                    &mut cells,
                    model,
                    options.method,
                    *t,
                    (self.q_out, self.s),
                    &quantize,
                    keep,
                )
                .map_err(|source| model_error(file, line, source))?;
                if let Some(kept) = kept {
                    let tu = if kept.reversed.iter().any(|r| *r) {
                        let mut tu = take_up_command(
                            &mut cells,
                            model,
                            self.q_out,
                            self.s,
                            kept.s,
                            kept.reversed,
                            (kept.q_mm, true),
                            if commands.is_empty() {
                                first_take_up_frame
                            } else {
                                frame
                            },
                        )
                        .map_err(|source| model_error(file, line, source))?;
                        let mut reaches = true;
                        for a in 0..3 {
                            let past = (tu[a] - kept.q_mm[a]) * kept.s[a].sign();
                            if kept.reversed[a] && past > 0.0 {
                                reaches &= past <= tolerance_mm;
                                tu[a] = kept.q_mm[a];
                            }
                        }
                        reaches.then_some(Some(tu))
                    } else {
                        Some(None)
                    };
                    if let Some(tu) = tu {
                        point = kept;
                        take_up = tu;
                    }
                }
            }
            // A take-up that does not move (negative reversal value, or one
            // the segment itself covers) is not written and not counted.
            if take_up == Some(self.q_out) {
                take_up = None;
            }
            // Where the dead band keeps the tool on the path while the axis
            // takes up its reversal value, the move itself takes it up.
            if let (Some(tr), true) = (transition, take_up.is_some()) {
                // Taken up on the S-curve (compensate/scurve.rs).
                take_up = None;
                self.note_fold(tr.deviation_mm);
            }
            if take_up.is_some() && options.fold_take_ups {
                let lags = switch_lags_mm(
                    &mut cells,
                    model,
                    self.q_out,
                    self.s,
                    point.s,
                    point.reversed,
                )
                .map_err(|source| model_error(file, line, source))?;
                let bound = fold_deviation_mm(&lags, self.q_out, point.q_mm, *t - t_prev);
                // Under G64 P the tool starts where a hold left it
                // (compensate/turn_back.rs).
                let held_off_mm = super::turn_back::start_offset_mm(
                    &mut cells,
                    model,
                    rule,
                    (self.q_out, self.s),
                    t_prev,
                )
                .map_err(|source| model_error(file, line, source))?;
                // On an arc piece the bound above, taken along its chord,
                // may fall short of what the tool leaves beside the arc; the
                // whole lag is an upper bound (the tool is never further
                // from the compensated path than the motor is ahead of it).
                let bound = if matches!(leads, Leads::Arc { .. }) {
                    bound.max(lags.iter().fold(Vec3::ZERO, |s, l| s + *l).norm())
                } else {
                    bound
                };
                // The contour tolerance first (a fold or a lead piece that
                // keeps the tool on the path); what G64 allows beyond it
                // (`allowed` below) only where no such piece exists.
                let tolerance = match rule {
                    TakeUpRule::Within(t) => t.min(options.fold_tolerance_mm()),
                    _ => options.fold_tolerance_mm(),
                };
                // A fold left for a hold to try first (below), kept where
                // the hold fails: its bound.
                let mut deferred_fold: Option<f64> = None;
                // Where the path runs on through the reversal: inside a
                // move, or where the original joins its moves without a
                // corner.
                let smooth = index > 0 || !run.corner_before;
                let plain_shortest = self.lead_shortest_mm(rule, &run, &lags, smooth);
                let parabolic_floor =
                    super::planar::lead_floor_after_parabolic_mm(rule, &run, index);
                let shortest = plain_shortest.map(|s| {
                    if index == 0 {
                        s.max(run.protect_mm).max(parabolic_floor)
                    } else {
                        s
                    }
                });
                // A fold into this piece alone turns the path by the
                // take-up over its length at both ends: where the planner
                // would not take that as tangent, the take-up is spread
                // along the path ([`plan_ramp`]) if the rule allows it.
                let v_mm_s = run.feed_mm_min.map_or(0.0, |f| f / 60.0);
                let kink_tolerance = options
                    .planner
                    .tangent_tolerance(v_mm_s.max(1e-9), run.arc || index == 0);
                let delta = take_up.map_or(Vec3::ZERO, |tu| tu - self.q_out);
                let piece_mm = (*t - t_prev).norm();
                let fold_is_tangent = fold_is_tangent(delta, kink_tolerance, piece_mm);
                // Under G64 P at a corner the machine all but stops at: a
                // block, not a lead piece nor a fold beyond the contour
                // tolerance (compensate/end_zone.rs).
                let slow_block = super::end_zone::block_at_slow_corner(
                    rule,
                    &run,
                    index,
                    delta,
                    &options.planner,
                );
                let ramp_tolerance = match rule {
                    TakeUpRule::Exact { smooth: true } if smooth => {
                        Some(RUN_THROUGH_TOLERANCE_MM.max(tolerance))
                    }
                    TakeUpRule::Exact { .. } => None,
                    // Less what a hold left at the start (the ramp's bound
                    // counts from the path).
                    TakeUpRule::Within(t) => Some(t - held_off_mm.norm()),
                    TakeUpRule::Always => Some(RUN_THROUGH_TOLERANCE_MM.max(tolerance)),
                };
                // A ramp centred on its reversal (compensate/ramp_centre.rs)
                // within its own, tighter tolerance.
                let ramp_tolerance = if ahead.is_some_and(|ah| ah.index == index && ah.centred) {
                    ramp_tolerance.map(|t| t.min(super::ramp_centre::TOLERANCE_MM))
                } else {
                    ramp_tolerance
                };
                let mut planned = None;
                if let (Some(ramp_tol), true) = (
                    ramp_tolerance,
                    !(bound <= tolerance && fold_is_tangent)
                        && feed_like
                        && v_mm_s > 0.0
                        && ramp.is_none(),
                ) {
                    let shortest_piece = shortest_ramp_piece_mm(options, v_mm_s);
                    // Out of the blends' zones where the rule lets the
                    // ramp run longer; as short as tangency allows where
                    // that leaves the tool too far off.
                    let floor = ramp_floor_mm(rule, &run, index);
                    // Under G61 the ramp first tries to spread the whole
                    // step the switch makes across the reversing axis too
                    // (compensate/ramp_cross.rs), within its tolerance:
                    // [`plan_ramp`]'s bound, whose lags carry that step
                    // fading with the reversing axis' band, plus the step
                    // where it would turn another axis back.
                    let across = match (take_up, rule) {
                        (Some(_), TakeUpRule::Exact { .. }) => {
                            let full = super::ramp_cross::full_take_up_mm(
                                &mut cells,
                                model,
                                self.q_out,
                                (self.s, point.s),
                                point.reversed,
                                if commands.is_empty() {
                                    first_take_up_frame
                                } else {
                                    frame
                                },
                            )
                            .map_err(|source| model_error(file, line, source))?;
                            let d = super::ramp_cross::ramp_delta_mm(
                                delta,
                                full,
                                self.q_out,
                                point.reversed,
                            );
                            (d != delta).then_some(d)
                        }
                        _ => None,
                    };
                    let exact = matches!(rule, TakeUpRule::Exact { .. });
                    'floors: for (floor_mm, judged) in super::ramp_band::tries(floor, exact) {
                        for d in [across, Some(delta)].into_iter().flatten() {
                            let back = d != delta
                                && super::ramp_cross::step_turns_back(
                                    d,
                                    delta,
                                    self.s,
                                    point.reversed,
                                );
                            if judged && back {
                                continue;
                            }
                            // The try without the floor repeats, for this
                            // `d`, the one with it that just failed, where
                            // the floor did not lengthen the ramp.
                            if !judged
                                && floor_mm == 0.0
                                && floor > 0.0
                                && !floor_lengthens_ramp(
                                    (&leads, pre_length, exact),
                                    d,
                                    (kink_tolerance, shortest_piece),
                                    floor,
                                )
                            {
                                continue;
                            }
                            let step_mm = if back { (d - delta).norm() } else { 0.0 };
                            // With the end zone of a held line first
                            // ([`plan_ramp`]), then without it where that
                            // ramp leaves too much.
                            for end_zone_mm in [self.ramp_end_zone_mm, 0.0] {
                                planned = plan_ramp(
                                    &mut cells,
                                    model,
                                    options,
                                    &|q, from| frame.quantize(q, from),
                                    (targets.as_slice(), &leads, transitions.as_slice()),
                                    (index, t_prev, self.q_out),
                                    &point,
                                    (
                                        d,
                                        &lags,
                                        ahead_axes
                                            .map_or([false; 3], |axes| axes.map(|d| d.is_some())),
                                    ),
                                    (
                                        kink_tolerance,
                                        ramp_tol,
                                        shortest_piece,
                                        pre_length,
                                        floor_mm,
                                    ),
                                    (
                                        exact,
                                        judged,
                                        ahead.is_some_and(|ah| {
                                            ah.index == index && ah.centred && ah.staged
                                        }),
                                    ),
                                    end_zone_mm,
                                )
                                .map_err(|source| model_error(file, line, source))?
                                .filter(|p| p.insert.is_empty() || ramp_inserted != Some(index))
                                .filter(|p| p.bound_mm + step_mm <= ramp_tol)
                                .map(|p| (p, d));
                                if planned.is_some() || end_zone_mm == 0.0 {
                                    break;
                                }
                            }
                            if planned.is_some() {
                                break 'floors;
                            }
                        }
                    }
                }
                // A ramp moved ahead of an S-curve that leaves more than
                // the S-curve leaves room for: refused while a ramp after
                // the S-curve may take the reversal instead (one that
                // needs a take-up block there comes back to it, below).
                if let Some((k, tr)) = ahead
                    .filter(|ah| ah.index == index && !ah.centred)
                    .and_then(|ah| Some((ah.transition, transitions.get(ah.transition)?)))
                    .filter(|(k, _)| !ahead_loose.contains(k))
                {
                    if planned.as_ref().is_some_and(|(plan, _)| {
                        !super::exact_hold::ahead_ramp_within_room(plan.bound_mm, tr.deviation_mm)
                    }) {
                        planned = None;
                        ahead_capped.push(k);
                    }
                }
                // G64 P on an arc where the path runs on: a take-up no ramp
                // took folded into its piece where the tool stays within P
                // (compensate/arc_fold.rs).
                let arc_fold_bound = match (&leads, rule) {
                    (Leads::Arc { arc, pieces }, TakeUpRule::Within(p))
                        if smooth && feed_like && planned.is_none() && !slow_block =>
                    {
                        let l_prev = if index == 0 { 0.0 } else { pieces[index - 1] };
                        Some(super::arc_fold::fold_bound_on_arc_mm(
                            &lags,
                            (self.q_out, held_off_mm),
                            point.q_mm,
                            (arc, l_prev, pieces[index]),
                        ))
                        .filter(|b| *b <= p)
                    }
                    _ => None,
                };
                if let Some((plan, delta)) = planned {
                    if !plan.insert.is_empty() {
                        // The ramp ends inside a piece (or a smooth ramp
                        // has inner points): they become targets, last
                        // first, and this one is solved again.
                        for &(k, p, param) in plan.insert.iter().rev() {
                            targets.insert(k, p);
                            if let (Leads::Arc { pieces, .. }, Some(l)) = (&mut leads, param) {
                                pieces.insert(k, l);
                            }
                            for tr in transitions.iter_mut().filter(|tr| tr.index >= k) {
                                tr.index += 1;
                            }
                        }
                        ramp_inserted = Some(index);
                        // Solved in the state the reversal turned to.
                        forced = Some(point.s);
                        continue;
                    }
                    take_up = None;
                    self.note_fold(plan.bound_mm);
                    last_lead = Some(index + plan.fracs.len());
                    ramp = Some((
                        delta,
                        plan.fracs.into_iter().collect(),
                        1.0,
                        ahead_axes.map_or([false; 3], |axes| axes.map(|d| d.is_some())),
                        (plan.rests.into_iter().collect(), delta),
                    ));
                } else if let Some(b) = arc_fold_bound.filter(|_| bound > tolerance) {
                    // G64 P inside an arc: folded into the piece within P,
                    // not on a short lead piece nor a block
                    // (compensate/arc_fold.rs).
                    take_up = None;
                    self.note_fold(b);
                } else if bound <= tolerance {
                    let from = hold_alt.take().filter(|_| !fold_is_tangent);
                    match held_instead(&mut cells, from)? {
                        Some(held) => point = self.take_hold(held, &mut take_up),
                        // G61 on an arc's tail (its last piece, where the
                        // path runs on): a fold that kinks is a stop; the
                        // hold to the move's end below is tried first, and
                        // the fold kept where it fails.
                        None if matches!(rule, TakeUpRule::Exact { smooth: true })
                            && smooth
                            && !fold_is_tangent
                            && run.arc
                            && matches!(leads, Leads::Nowhere) =>
                        {
                            deferred_fold = Some(bound);
                        }
                        None => {
                            take_up = None;
                            self.note_fold(bound);
                        }
                    }
                } else if let Some(shortest) = shortest.filter(|_| {
                    feed_like
                        && !slow_block
                        && !after_normal_hold
                        && !matches!(leads, Leads::Nowhere)
                        && last_lead.is_none_or(|l| index > l + 1)
                }) {
                    let t = *t;
                    let (l_prev, l_end) = match &leads {
                        Leads::Arc { pieces, .. } => (
                            if index == 0 { 0.0 } else { pieces[index - 1] },
                            pieces[index],
                        ),
                        _ => (0.0, 1.0),
                    };
                    let (length, at): (f64, Box<dyn Fn(f64) -> Vec3>) = match &leads {
                        Leads::Arc { arc, .. } => {
                            let arc = **arc;
                            (
                                arc.length() * (l_end - l_prev),
                                Box::new(move |f| arc.point_at(l_prev + (l_end - l_prev) * f)),
                            )
                        }
                        _ => (
                            (t - t_prev).norm(),
                            Box::new(move |f| t_prev + (t - t_prev) * f),
                        ),
                    };
                    // Under G64 without P, where the zones of the blends
                    // at both ends of the motion cover it (a polygon's
                    // edge at speed), a lead piece's end would be a split
                    // inside one of them ([`ramp_floor_mm`]): none for the
                    // contour tolerance nor the shortest one; the reach
                    // rule below still ends the take-up within its reach.
                    let zones_cover = index == 0 && ramp_floor_mm(rule, &run, index) >= length;
                    let mut lead = if zones_cover {
                        None
                    } else {
                        lead_target(
                            &mut cells,
                            model,
                            options,
                            &quantize,
                            self.q_out,
                            &lags,
                            (shortest, tolerance),
                            t_prev,
                            (&*at, length),
                            &point,
                        )
                        .map_err(|source| model_error(file, line, source))?
                    };
                    let within_tolerance = lead.is_some();
                    // The command at the end of a lead piece ending at
                    // `f` of the move: solved in the reversal's new
                    // directions and written as it will be read back,
                    // `None` where it does not move each reversing axis
                    // its new way (the take-up would not be over there).
                    let mut lead_command = |f: f64| -> Result<Option<Vec3>, CompensationError> {
                        let q = solve_fixed_in(
                            &mut cells,
                            model,
                            options.method,
                            at(f),
                            point.s,
                            [false; 3],
                            self.q_out,
                        )
                        .map(|sol| quantize(sol.q_mm))
                        .map_err(|source| model_error(file, line, source))?;
                        let consistent = (0..3).all(|a| {
                            !point.reversed[a]
                                || crate::model::Direction::of_delta(q[a] - self.q_out[a])
                                    == Some(point.s[a])
                        });
                        Ok(consistent.then_some(q))
                    };
                    // The excursion of the lead piece taken beyond the
                    // tolerance (µm), counted once it is chosen.
                    let mut lead_excursion_um = 0.0f64;
                    // Under G64 a take-up that no lead piece keeps within
                    // the tolerance still gets the shortest one the planner
                    // runs at speed, where the rule allows what it leaves:
                    // the rest of the move then runs in the new direction,
                    // so the excursion stays at the reversal instead of
                    // fading along the whole move.
                    let allowed = match rule {
                        TakeUpRule::Always => Some(f64::INFINITY),
                        TakeUpRule::Within(t) => Some(t),
                        TakeUpRule::Exact { .. } => None,
                    };
                    if let (None, Some(allowed), false) = (lead, allowed, zones_cover) {
                        if length >= 2.0 * shortest {
                            let f = shortest / length;
                            if let Some(q) = lead_command(f)? {
                                let b = fold_deviation_from_mm(
                                    &lags,
                                    self.q_out,
                                    q,
                                    at(f) - t_prev,
                                    (0.0, held_off_mm),
                                );
                                if b <= allowed {
                                    lead_excursion_um = b * 1e3;
                                    lead = Some(f);
                                }
                            }
                        }
                    }
                    // G64 without P: the take-up over within the reach
                    // after the reversal ([`TAKE_UP_REACH_MM`]), on the
                    // longest lead piece that leaves no more beyond it.
                    let reach = TAKE_UP_REACH_MM;
                    if let (TakeUpRule::Always, Some(plain), true) = (
                        rule,
                        plain_shortest,
                        reach > 0.0 && length > 0.0 && !within_tolerance,
                    ) {
                        let tail = |q: Vec3, piece_mm: f64, nominal: Vec3| {
                            fold_deviation_beyond_mm(
                                &lags,
                                self.q_out,
                                q,
                                nominal,
                                reach / piece_mm.max(1e-12),
                            )
                        };
                        let tail_now = match lead {
                            Some(f) => lead_command(f)?
                                .map_or(f64::INFINITY, |q| tail(q, f * length, at(f) - t_prev)),
                            None => tail(point.q_mm, length, t - t_prev),
                        };
                        if tail_now > RUN_THROUGH_TOLERANCE_MM {
                            let total = lags.iter().fold(Vec3::ZERO, |s, l| s + *l).norm();
                            // Not so short that the corner's blend before it
                            // loses more than its share of speed, and the
                            // rest of the move long enough for the blend at
                            // its end alike.
                            let keep = BLEND_SPEED_KEPT * BLEND_SPEED_KEPT;
                            let floor = if index == 0 {
                                plain.max(keep * run.protect_mm).max(parabolic_floor)
                            } else {
                                plain
                            };
                            let mut piece = if total > RUN_THROUGH_TOLERANCE_MM {
                                reach / (1.0 - RUN_THROUGH_TOLERANCE_MM / total)
                            } else {
                                length
                            }
                            .min(length - plain.max(keep * run.protect_end_mm));
                            while piece >= floor {
                                let f = piece / length;
                                if let Some(q) = lead_command(f)? {
                                    let lead_t = at(f);
                                    if tail(q, piece, lead_t - t_prev) <= RUN_THROUGH_TOLERANCE_MM {
                                        let b = fold_deviation_mm(
                                            &lags,
                                            self.q_out,
                                            q,
                                            lead_t - t_prev,
                                        );
                                        lead_excursion_um = b * 1e3;
                                        lead = Some(f);
                                        break;
                                    }
                                }
                                piece *= 0.8;
                            }
                        }
                    }
                    self.summary.max_fold_excursion_um =
                        self.summary.max_fold_excursion_um.max(lead_excursion_um);
                    let lead_kinks = lead
                        .is_some_and(|f| !self::fold_is_tangent(delta, kink_tolerance, f * length));
                    if let Some(held) = held_instead(&mut cells, hold_alt.take_if(|_| lead_kinks))?
                    {
                        point = self.take_hold(held, &mut take_up);
                    } else if let Some(f) = lead {
                        // Solve the lead piece first (it takes the take-up up),
                        // then this target again from there.
                        targets.insert(index, at(f));
                        if let Leads::Arc { pieces, .. } = &mut leads {
                            pieces.insert(index, l_prev + (l_end - l_prev) * f);
                        }
                        for tr in transitions.iter_mut().filter(|tr| tr.index >= index) {
                            tr.index += 1;
                        }
                        last_lead = Some(index);
                        // The state the point was solved in: its reversing
                        // axes switched, the others as they were.
                        forced = Some(point.s);
                        continue;
                    }
                }
                let allowed = match rule {
                    TakeUpRule::Always => f64::INFINITY,
                    TakeUpRule::Within(t) => t,
                    TakeUpRule::Exact { .. } => 0.0,
                };
                if let Some(held) = held_instead(
                    &mut cells,
                    hold_alt.take_if(|_| take_up.is_some() && !fold_is_tangent),
                )? {
                    point = self.take_hold(held, &mut take_up);
                } else if let Some(held) = (take_up.is_some()
                    && bound > allowed
                    && feed_like
                    && !was_forced
                    && transition.is_none()
                    && ramp.is_none()
                    && ahead.is_none_or(|ah| ah.index != index))
                .then(|| {
                    // G61: a take-up that would be a block (nothing above
                    // took it), outside ramps, S-curves and take-ups moved
                    // ahead: held where the hold ends before the next
                    // S-curve, or, on an arc, with the move where the rest
                    // of it is shorter than the ramp the take-up needs (the
                    // reason no ramp took it): the next move takes the
                    // reversal up from its start (compensate/exact_hold.rs).
                    let end = transitions
                        .iter()
                        .filter(|tr| tr.index > index)
                        .fold(targets.len(), |e, tr| e.min(tr.index));
                    let after = &targets[index + 1..end];
                    let to_move_end = end == targets.len()
                        && match leads {
                            Leads::Arc { .. } => {
                                super::exact_hold::path_mm(*t, after)
                                    <= ramp_length_mm(
                                        delta,
                                        kink_tolerance,
                                        shortest_ramp_piece_mm(options, v_mm_s),
                                        true,
                                    )
                            }
                            Leads::Lines => targets
                                .last()
                                .is_some_and(|e| hold_to_plunge_end(start, *e, point.reversed)),
                            // An arc's tail whose fold kinks (above): to
                            // its end, which is the move's.
                            Leads::Nowhere if deferred_fold.is_some() => !run.corner_before,
                            // A line's tail (mod.rs `flush_tail`,
                            // [`tail_run`]).
                            Leads::Nowhere => {
                                !run.corner_before
                                    && !run.arc
                                    && hold_to_line_end(
                                        super::exact_hold::path_mm(*t, after),
                                        line_ramp_length_mm(
                                            delta,
                                            kink_tolerance,
                                            shortest_ramp_piece_mm(options, v_mm_s),
                                        ),
                                    )
                            }
                        };
                    let on_from_plunge = index == 0
                        && matches!(leads, Leads::Lines)
                        && carries_plunge_hold(plunge_held_before, point.reversed);
                    let held = super::exact_hold::held_instead_of_stop(
                        &mut cells,
                        model,
                        options,
                        (rule, smooth || on_from_plunge),
                        &quantize,
                        (*t, self.q_out, self.s, &point),
                        (after, to_move_end && !on_from_plunge),
                        hold_across(&transitions, targets.as_slice(), end),
                    )?;
                    if let Some(h) = held.as_ref().filter(|_| to_move_end) {
                        if matches!(leads, Leads::Lines) {
                            let axes = [0, 1, 2].map(|a| point.reversed[a] && h.s[a] != point.s[a]);
                            plunge_held = Some((axes, h.s));
                        }
                    }
                    Ok(held)
                })
                .transpose()
                .map_err(|source| model_error(file, line, source))?
                .flatten()
                {
                    point = self.take_hold(held, &mut take_up);
                } else if let Some(excursion) = super::hold_fold::fold_excursion_mm(
                    (bound, allowed),
                    &lags,
                    (self.q_out, held_off_mm),
                    (point.q_mm, *t - t_prev),
                )
                .filter(|_| take_up.is_some() && !slow_block)
                {
                    // G64: folded all the same, the tool leaving the path by
                    // the bound (at most the reversal value; within P,
                    // counted from where a hold left the tool:
                    // compensate/hold_fold.rs).
                    take_up = None;
                    self.note_fold(excursion);
                }
                if let Some(b) = deferred_fold.filter(|_| take_up.is_some()) {
                    take_up = None;
                    self.note_fold(b);
                }
            }
            // G61 on a line: a reversal inside the line whose take-up is
            // still a block (no fold, ramp or hold took it: a stop) taken
            // up on a ramp centred on it instead (compensate/ramp_centre.rs),
            // where the line before it is quiet (no take-up, ramp or other
            // state).
            if (centre_lines || centre_arcs)
                && take_up.is_some()
                && ramp.is_none()
                && ahead.is_none()
                && !was_forced
                && index >= 1
                && point.reversed.iter().any(|r| *r)
                && !centred_tried.contains(&(t_prev, true))
            {
                let tried = centred_tried.iter().position(|(p, _)| *p == t_prev);
                let v_mm_s = run.feed_mm_min.map_or(0.0, |f| f / 60.0);
                let shortest = shortest_ramp_piece_mm(options, v_mm_s);
                // A reversal whose one-step centred ramp was refused: on a
                // line, tried again staged where two axes cross a band
                // (compensate/ramp_stage.rs).
                let stages = match tried {
                    Some(i) => {
                        centred_tried[i].1 = true;
                        if centre_lines {
                            let lags = switch_lags_mm(
                                &mut cells,
                                model,
                                self.q_out,
                                self.s,
                                point.s,
                                point.reversed,
                            )
                            .map_err(|source| model_error(file, line, source))?;
                            let kink = options.planner.tangent_tolerance(v_mm_s, false);
                            super::ramp_stage::Stages::plan(&lags, point.s, point.reversed, |v| {
                                line_ramp_length_mm(v, kink, shortest)
                            })
                        } else {
                            None
                        }
                    }
                    None => {
                        centred_tried.push((t_prev, false));
                        None
                    }
                };
                let staged = stages.is_some();
                let tu = take_up_command(
                    &mut cells,
                    model,
                    self.q_out,
                    self.s,
                    point.s,
                    point.reversed,
                    (point.q_mm, true),
                    frame,
                )
                .map_err(|source| model_error(file, line, source))?;
                // A tenth more than the ramp needs here: the take-up at
                // the ramp's start (solved there) is a little different.
                let need = 1.1
                    * match &leads {
                        Leads::Arc { .. } => ramp_length_mm(
                            tu - self.q_out,
                            options.planner.tangent_tolerance(v_mm_s, true),
                            shortest,
                            true,
                        ),
                        _ => line_ramp_length_mm(
                            tu - self.q_out,
                            options.planner.tangent_tolerance(v_mm_s, false),
                            shortest,
                        ),
                    };
                // (From, the point inserted and on an arc its parameter,
                // the ramp's length.)
                // Staged: each step over its own need, the first centred
                // on the reversal (its target drifts the old way up to it,
                // so its command cannot reach its new flank before).
                let (lead, need) = match stages {
                    Some(st) => {
                        let l = (1.1 * st.need_mm()).max(need);
                        (st.lead_share() * l, l)
                    }
                    None => (0.5 * need, need),
                };
                let found = match &leads {
                    _ if tu == self.q_out => None,
                    _ if tried.is_some() && !staged => None,
                    Leads::Arc { arc, pieces } => {
                        // Before the reversal as much as the drifts on
                        // both sides ask (compensate/arcs.rs
                        // `ramp_lead_share`).
                        let lead = arc_ramp_lead_share(
                            &mut cells,
                            model,
                            options.method,
                            (arc, pieces[index - 1], 0.5 * need),
                            (self.q_out, self.s),
                            (&point, tu - self.q_out),
                        )
                        .map_err(|source| model_error(file, line, source))?;
                        super::arcs::centred_start_on_arc(
                            arc,
                            pieces,
                            index,
                            (lead * need, need),
                            shortest,
                        )
                        .map(|(from, ins, l)| (from, ins.map(|(p, t)| (p, Some(t))), l))
                    }
                    _ => super::ramp_centre::centred_start(
                        start,
                        targets.as_slice(),
                        index,
                        (lead, need),
                        shortest,
                    )
                    .map(|c| (c.from, c.insert.map(|p| (p, None)), c.ramp_mm)),
                };
                if let Some((p, c_insert, c_ramp_mm)) = found {
                    // (A take-up at the start of the piece the ramp's
                    // start is inserted in comes before the ramp: solved
                    // again there as it was.)
                    let first = p + usize::from(c_insert.is_some());
                    let quiet = (p..=index).all(|j| !history[j].ramp_on)
                        && (first..index).all(|j| {
                            commands[j].1.is_none() && self.states[j] == self.states[first]
                        })
                        && transitions.iter().all(|o| o.index < p || o.index > index);
                    if quiet {
                        ahead = Some(Ahead {
                            index: if c_insert.is_some() { p + 1 } else { p },
                            from: p,
                            // (On an arc only the axes the take-up moves: one
                            // with no band that turns at the same point, a
                            // quarter point, runs on along the arc.)
                            axes: [0, 1, 2].map(|a| {
                                (point.reversed[a] && (!centre_arcs || tu[a] != self.q_out[a]))
                                    .then_some(point.s[a])
                            }),
                            length_mm: c_ramp_mm,
                            // No S-curve: the axes are held on the ramp
                            // only (`ahead_hold` finds no transition there
                            // and ends).
                            transition: usize::MAX,
                            centred: true,
                            staged,
                        });
                        // Solved again from the ramp's start (as for a
                        // take-up moved ahead of an S-curve, above).
                        self.go_back(&history[p], p, (&mut commands, &mut records));
                        history.truncate(p + 1);
                        let h = &history[p];
                        (t_prev, last_lead, ramp_inserted) =
                            (h.t_prev, h.last_lead, h.ramp_inserted);
                        (ramp, forced, ahead_hold) = (None, None, None);
                        ahead_saved = Some((
                            targets.clone(),
                            match &leads {
                                Leads::Arc { pieces, .. } => Some(pieces.to_vec()),
                                _ => None,
                            },
                            transitions.clone(),
                        ));
                        if let Some((pt, param)) = c_insert {
                            targets.insert(p, pt);
                            if let (Leads::Arc { pieces, .. }, Some(l)) = (&mut leads, param) {
                                pieces.insert(p, l);
                            }
                            for tr in transitions.iter_mut().filter(|tr| tr.index >= p) {
                                tr.index += 1;
                            }
                        }
                        index = p;
                        continue;
                    }
                }
            }
            // A take-up moved ahead that was not spread over its ramp (or
            // folded): solved as before from the ramp's start.
            if let Some(ah) = ahead.filter(|ah| ah.index == index) {
                ahead = None;
                let saved = ahead_saved.take();
                let taken = (0..3).any(|a| ah.axes[a].is_some() && point.reversed[a]);
                // Or a ramp from the start point itself (the target turned
                // there already) took them to their new direction: held on
                // it as on their own.
                let already =
                    ramp.is_some() && (0..3).all(|a| ah.axes[a].is_none_or(|d| self.s[a] == d));
                if let (true, Some((_, _, _, hold, _))) = (already, ramp.as_mut()) {
                    for (a, d) in ah.axes.iter().enumerate() {
                        hold[a] |= d.is_some();
                    }
                    ahead_hold = Some((ah.transition, ah.axes.map(|d| d.is_some())));
                } else if take_up.is_some() || !taken {
                    let p = ah.from;
                    self.go_back(&history[p], p, (&mut commands, &mut records));
                    history.truncate(p + 1);
                    let h = &history[p];
                    (t_prev, last_lead, ramp_inserted) = (h.t_prev, h.last_lead, h.ramp_inserted);
                    (ramp, forced) = (None, None);
                    // The targets are the motion's own again (the ramp's
                    // start point and what its ramp inserted go).
                    if let Some((saved, saved_pieces, saved_transitions)) = saved {
                        *targets = saved;
                        if let (Leads::Arc { pieces, .. }, Some(sp)) = (&mut leads, saved_pieces) {
                            **pieces = sp;
                        }
                        transitions = saved_transitions;
                    }
                    index = p;
                    continue;
                } else {
                    ahead_hold = Some((ah.transition, ah.axes.map(|d| d.is_some())));
                }
            }
            let mut ramp_mid = Vec3::ZERO;
            if let Some((delta, fracs, f_before, hold, (rests, rest_before))) = ramp.as_mut() {
                if let Some(f) = fracs.pop_front() {
                    let mut hold = *hold;
                    match rests.pop_front() {
                        Some((rest, waiting)) => {
                            point.q_mm = frame.quantize(point.q_mm - rest, self.q_out);
                            ramp_mid = (*rest_before + rest) * -0.5;
                            *rest_before = rest;
                            hold = [0, 1, 2].map(|a| hold[a] && !waiting[a]);
                        }
                        None => {
                            point.q_mm = frame.quantize(point.q_mm - *delta * f, self.q_out);
                            ramp_mid = *delta * (-0.5 * (*f_before + f));
                        }
                    }
                    hold_on_ramp(&mut point.q_mm, self.q_out, point.s, hold);
                    *f_before = f;
                }
                if fracs.is_empty() {
                    ramp = None;
                }
            }
            // G61 (and G64 P) on a line: a take-up whose switches move an
            // axis' correction against its new motion ends along the line,
            // where that motion has caught the step up
            // (compensate/take_up_advance.rs).
            if let (Some(tu), true) = (
                take_up,
                (centre_lines || adv_lines)
                    && ramp.is_none()
                    && ahead.is_none()
                    && transition.is_none(),
            ) {
                take_up = Some(
                    self.advance_take_up(
                        (&mut cells, model, options),
                        (t_prev, *t, run.feed_mm_min),
                        &point,
                        tu,
                        if commands.is_empty() {
                            first_take_up_frame
                        } else {
                            frame
                        },
                    )
                    .map_err(|source| model_error(file, line, source))?,
                );
            }
            // G61 on a line: several axes reverse and the one block leaves
            // the path; one block per axis, in order
            // (compensate/take_up_order.rs).
            let mut ordered = None;
            if let (Some(tu), true) = (
                take_up,
                centre_lines && ramp.is_none() && ahead.is_none() && transition.is_none(),
            ) {
                // The path into the corner: the piece before in this
                // motion, or the last motion's end tangent.
                let u_in = match index {
                    0 => self.last_tangent.map(|(t1, _)| t1),
                    _ => (t_prev - targets[index - 1]).normalized(),
                };
                ordered = self
                    .order_take_up(
                        (&mut cells, model, options),
                        (t_prev, *t, u_in, run.feed_mm_min),
                        &point,
                        tu,
                        if commands.is_empty() {
                            first_take_up_frame
                        } else {
                            frame
                        },
                    )
                    .map_err(|source| model_error(file, line, source))?;
                if let Some(last) = ordered.as_mut().and_then(|o| o.pop()) {
                    take_up = Some(last);
                }
            }
            // G61 on a line: an axis the take-up block leaves ahead of its
            // new target stands until the target catches up, at a target
            // inserted there (compensate/take_up_stand.rs).
            if let (Some(tu), true) = (
                take_up,
                centre_lines
                    && ramp.is_none()
                    && ahead.is_none()
                    && stood != Some(t_prev)
                    && ordered.is_none(),
            ) {
                let t_end = *t;
                let v_mm_s = run.feed_mm_min.map_or(0.0, |f| f / 60.0);
                let share = super::take_up_stand::stand_share_on_piece(
                    (&mut cells, model, options),
                    (t_prev, t_end, v_mm_s),
                    tu,
                    &point,
                )
                .map_err(|source| model_error(file, line, source))?;
                if let Some(f) = share {
                    stood = Some(t_prev);
                    targets.insert(index, t_prev + (t_end - t_prev) * f);
                    for tr in transitions.iter_mut().filter(|tr| tr.index >= index) {
                        tr.index += 1;
                    }
                    if let Some(h) = history.get(index) {
                        self.summary = h.summary.clone();
                    }
                    continue;
                }
            }
            // The reversal right after an S-curve whose ramp ahead of it
            // was refused ([`super::exact_hold::ahead_ramp_within_room`])
            // and that needs a take-up block here after all: the ramp
            // ahead as it was, rather than a stop.
            if let (Some(_), false, Some(k)) = (
                take_up,
                was_forced || history.get(index).is_none_or(|h| h.ramp_on),
                transitions
                    .iter()
                    .position(|tr| tr.index + 1 == index)
                    .filter(|k| ahead_capped.contains(k) && !ahead_loose.contains(k)),
            ) {
                ahead_loose.push(k);
                ahead_tried.retain(|x| *x != k);
                self.go_back(&history[index], index, (&mut commands, &mut records));
                history.truncate(index + 1);
                let h = &history[index];
                (t_prev, last_lead, ramp_inserted) = (h.t_prev, h.last_lead, h.ramp_inserted);
                (ramp, forced, ahead_hold) = (None, None, None);
                continue;
            }
            if let Some(tu) = take_up {
                self.q_out = tu;
            }
            self.summary.points += 1;
            // The solver's residual (a hold's error is counted apart).
            self.summary.max_residual_um = self.summary.max_residual_um.max(solve_residual_um);
            self.summary.max_correction_um = self.summary.max_correction_um.max(correction * 1e3);
            for a in 0..3 {
                if point.held[a] {
                    self.summary.held_count += 1;
                    if self.summary.held.len() < 100 {
                        self.summary.held.push((line, ['X', 'Y', 'Z'][a]));
                    }
                }
            }
            self.summary.take_ups += u64::from(take_up.is_some());
            records.push(PointRecord {
                line,
                target_mm: *t,
                command_mm: point.q_mm,
                iterations: point.iterations,
                residual_um: point.residual_um,
                reversed: point.reversed,
                held: point.held,
                take_up: take_up.is_some(),
                rapid: !feed_like,
            });
            for q in ordered.into_iter().flatten() {
                self.take_up_blocks.push((commands.len(), q));
                self.summary.take_ups += 1;
            }
            commands.push((point.q_mm, take_up));
            self.states.push(point.s);
            self.ramp_mids.push(ramp_mid);
            self.q_out = point.q_mm;
            self.s = point.s;
            self.s_nominal = next_state(self.s_nominal, *t - t_prev);
            t_prev = *t;
            index += 1;
        }
        // Under G61 a take-up block of the plane's normal axis right after
        // an S-curve, spread as a ramp across it instead, or away from the
        // S-curves as a ramp of its own (compensate/take_up_across.rs).
        if let (TakeUpRule::Exact { smooth: true }, Leads::Arc { arc, pieces }) = (rule, &mut leads)
        {
            if commands.iter().any(|c| c.1.is_some()) {
                let v_mm_s = run.feed_mm_min.map_or(0.0, |f| f / 60.0);
                let w = arc.plane.axes().2;
                let tangent = options.planner.tangent_tolerance(v_mm_s.max(1e-9), true)[w];
                let spread = super::take_up_across::spread_take_ups(
                    &mut cells,
                    &mut super::take_up_across::Solved {
                        commands: &mut commands,
                        targets: &mut *targets,
                        pieces,
                        states: &mut self.states,
                        ramp_mids: &mut self.ramp_mids,
                        records: &mut records,
                        transitions: &mut transitions,
                    },
                    &super::take_up_across::Setting {
                        model,
                        method: options.method,
                        arc,
                        q_in: commands_start,
                        quantize: &|q, from| frame.quantize(q, from),
                        piece_mm: shortest_ramp_piece_mm(options, v_mm_s),
                        kappa: RAMP_SHARE * tangent,
                        tangent,
                        tolerance_mm: super::take_up_across::ACROSS_TOLERANCE_MM,
                    },
                )
                .map_err(|source| model_error(file, line, source))?;
                for s in spread {
                    self.summary.take_ups -= 1;
                    self.note_fold(s.bound_mm);
                }
            }
        }
        // Under G61 a take-up block of the plane's normal axis right after
        // an S-curve that the spread above left, moved before it where there
        // every axis steps its own way (compensate/take_up_before.rs).
        if let (TakeUpRule::Exact { smooth: true }, Leads::Arc { arc, pieces }) = (rule, &leads) {
            if commands.iter().any(|c| c.1.is_some()) {
                super::take_up_before::move_take_ups_before(
                    &mut cells,
                    &mut super::take_up_before::Solved {
                        commands: &mut commands,
                        targets: &*targets,
                        states: &mut self.states,
                        records: &mut records,
                        transitions: &mut transitions,
                    },
                    &super::take_up_before::Setting {
                        model,
                        arc,
                        pieces,
                        method: options.method,
                        normal: arc.plane.axes().2,
                        quantize: &|q, from| frame.quantize(q, from),
                        quantize_first: &|q, from| first_take_up_frame.quantize(q, from),
                        // An S-curve that begins in the block before (a
                        // tail taken) has its first part written there.
                        start: (run.corner_before || !self.defer_points).then_some((
                            commands_start,
                            state_start,
                            start,
                        )),
                        tolerance_mm: options.fold_tolerance_mm(),
                    },
                )
                .map_err(|source| model_error(file, line, source))?;
            }
        }
        // Under G61 the step an S-curve makes in the plane's normal axis,
        // spread as a smooth step around it ([`spread_normal_step`]).
        if let (TakeUpRule::Exact { smooth: true }, Leads::Arc { arc, pieces }) = (rule, &leads) {
            let v_mm_s = run.feed_mm_min.map_or(0.0, |f| f / 60.0);
            let w = arc.plane.axes().2;
            let kappa = RAMP_SHARE * options.planner.tangent_tolerance(v_mm_s.max(1e-9), true)[w];
            let q_in = commands_start;
            for tr in &transitions {
                let Some(span) = tr.spread else { continue };
                // The S-curve's deviation and the spread lie across each
                // other; together within the run-through tolerance.
                let limit_mm = (RUN_THROUGH_TOLERANCE_MM.powi(2) - tr.deviation_mm.powi(2))
                    .max(0.0)
                    .sqrt();
                let spread = spread_normal_step(
                    (&mut commands, &self.states),
                    (arc, pieces, q_in),
                    (tr.index, span),
                    (kappa, limit_mm),
                    &|q, from| frame.quantize(q, from),
                );
                if let Some(added_mm) = spread {
                    for (r, c) in records.iter_mut().zip(&commands) {
                        r.command_mm = c.0;
                    }
                    // The S-curve's take-up is counted already: the bound
                    // it may leave grows by the offset across the plane.
                    let bound_um = tr.deviation_mm.hypot(added_mm) * 1e3;
                    self.summary.max_fold_excursion_um =
                        self.summary.max_fold_excursion_um.max(bound_um);
                }
            }
        }
        // Then the normal axis' kinks left at the arc's joins
        // (compensate/arcs.rs): under G61 within the run-through tolerance
        // beside the S-curves, under G64 without P (a helix too) within the
        // step an S-curve makes.
        let smoothing = match rule {
            TakeUpRule::Exact { smooth: true } => Some(super::arcs::Smoothing::Exact),
            TakeUpRule::Always => Some(super::arcs::Smoothing::Folded),
            _ => None,
        };
        let slope_out = self.normal_slope_out.take();
        if let (Some(smoothing), Leads::Arc { arc, pieces }) = (smoothing, &leads) {
            let v_mm_s = run.feed_mm_min.map_or(0.0, |f| f / 60.0);
            // The slope the path comes in with, where the arc starts
            // tangent to the piece written just before (a line's, or an
            // arc's of the same plane) and at its end.
            let w = arc.plane.axes().2;
            let slope_in = slope_out
                .filter(|o| {
                    smoothing == super::arcs::Smoothing::Folded
                        && !run.corner_before
                        && !self.defer_points
                        && o.end_mm == commands_start
                })
                .and_then(|o| o.along(w));
            let (moved_mm, bound_mm) = super::arcs::smooth_normal_kinks(
                (&mut commands, &self.states),
                (arc, pieces, commands_start, slope_in),
                (&transitions, options, v_mm_s),
                &|q, from| frame.quantize(q, from),
                smoothing,
            );
            if moved_mm > 0.0 {
                for (r, c) in records.iter_mut().zip(&commands) {
                    r.command_mm = c.0;
                }
                self.summary.max_fold_excursion_um =
                    self.summary.max_fold_excursion_um.max(bound_mm * 1e3);
            }
        }
        // Under G61, a take-up block inside a line of an axis the line
        // keeps still, written as an S where one fits
        // (compensate/still_s.rs).
        self.s_pieces.clear();
        if let (Some(ctx), true, true) = (
            self.s_line,
            centre_lines,
            commands.iter().skip(1).any(|c| c.1.is_some()),
        ) {
            let v_mm_s = run.feed_mm_min.map_or(0.0, |f| f / 60.0);
            self.still_axis_s_curves(
                &mut cells,
                model,
                frame,
                &ctx,
                (targets, &mut commands, &mut records),
                (start, commands_start),
                v_mm_s,
            )
            .map_err(|source| model_error(file, line, source))?;
        }
        // The motion leaves its last piece's slope for an arc that may
        // follow it tangent. (A line held back for a take-up ahead, idle.rs,
        // keeps its slope only where its end goes out as solved: the arc
        // checks the end. An arc that took the tail of the block before
        // had its start rewritten: none.)
        self.normal_slope_out = match &leads {
            Leads::Arc { arc, pieces } if !self.defer_points => {
                super::arcs::NormalSlopeOut::of(&commands, (arc, pieces, commands_start))
            }
            Leads::Lines => super::arcs::NormalSlopeOut::of_line(&commands, commands_start),
            _ => None,
        };
        self.transitions_written = transitions;
        if let Some((axes, s)) = plunge_held {
            self.plunge_held = [0, 1, 2].map(|a| axes[a] && self.s[a] == s[a]);
        }
        for r in records.iter().filter(|_| !self.defer_points) {
            (self.on_point)(r);
        }
        self.records = records;
        self.cells = Some(cells);
        Ok(commands)
    }

    /// Goes back to the state `h` kept before target `p`: the commands,
    /// states and records from `p` on are dropped ([`Ahead`]).
    fn go_back(
        &mut self,
        h: &Snapshot,
        p: usize,
        (commands, records): (&mut Vec<(Vec3, Option<Vec3>)>, &mut Vec<PointRecord>),
    ) {
        self.q_out = h.q_out;
        self.s = h.s;
        self.s_nominal = h.s_nominal;
        self.summary = h.summary.clone();
        commands.truncate(p);
        records.truncate(p);
        self.states.truncate(p);
        self.ramp_mids.truncate(p);
        self.take_up_blocks.retain(|(i, _)| *i < p);
    }
}

impl State<'_> {
    /// The held point `held` in place of a reversal and its
    /// take-up: no take-up written, the hold counted.
    /// [`super::take_up_advance::advanced_take_up`] from this walk's
    /// command and state: the take-up `tu`, or its end moved along the
    /// piece from `t_prev` to `t_end`.
    fn advance_take_up(
        &self,
        (cells, model, options): (&mut AxisCells, &dyn ErrorModel, &CompensateOptions),
        (t_prev, t_end, feed_mm_min): (Vec3, Vec3, Option<f64>),
        point: &crate::compensate::solve::PointSolution,
        tu: Vec3,
        frame: &Frame,
    ) -> Result<Vec3, ModelError> {
        let shortest = shortest_ramp_piece_mm(options, feed_mm_min.map_or(0.0, |f| f / 60.0));
        Ok(super::take_up_advance::advanced_take_up(
            (cells, model, options.method),
            (self.q_out, self.s),
            (t_prev, t_end),
            point,
            tu,
            shortest,
            frame,
        )?
        .unwrap_or(tu))
    }

    /// [`super::take_up_order::ordered_take_up`] from this walk's command
    /// and state: the blocks in order (the last the take-up the piece
    /// starts from), or `None` to keep the take-up `tu`.
    fn order_take_up(
        &self,
        (cells, model, options): (&mut AxisCells, &dyn ErrorModel, &CompensateOptions),
        (t_prev, t_end, u_in, feed_mm_min): (Vec3, Vec3, Option<Vec3>, Option<f64>),
        point: &crate::compensate::solve::PointSolution,
        tu: Vec3,
        frame: &Frame,
    ) -> Result<Option<Vec<Vec3>>, ModelError> {
        let shortest = shortest_ramp_piece_mm(options, feed_mm_min.map_or(0.0, |f| f / 60.0));
        Ok(super::take_up_order::ordered_take_up(
            (cells, model, options.method),
            (self.q_out, self.s),
            (t_prev, t_end, u_in),
            point,
            tu,
            shortest,
            frame,
        )?
        .map(|o| o.blocks))
    }

    fn take_hold(
        &mut self,
        held: crate::compensate::solve::PointSolution,
        take_up: &mut Option<Vec3>,
    ) -> crate::compensate::solve::PointSolution {
        *take_up = None;
        self.summary.count_hold(held.residual_um);
        held
    }

    /// Counts a folded take-up and the excursion its bound allows.
    fn note_fold(&mut self, bound_mm: f64) {
        self.summary.take_ups_folded += 1;
        self.summary.max_fold_excursion_um = self.summary.max_fold_excursion_um.max(bound_mm * 1e3);
    }

    /// The shortest lead piece (mm) the rule allows on a motion run as
    /// `run` for a take-up of `lags`, or `None` where the rule writes no
    /// lead piece: a block or a fold instead.
    ///
    /// * Exact (G61), where the path is `smooth` through the reversal: a
    ///   piece the planner joins as tangent at both ends, which turns from
    ///   the path by about `b/L` along the reversing axis (`b` its own lag):
    ///   `L ≥ b / (½ tolerance)` with the planner's tangency tolerance at
    ///   the feed ([`super::PlannerLimits::tangent_tolerance`]; half of it,
    ///   so the compensation's own turn fits too). Not at a corner (the
    ///   machine stops there anyway: a block), nor under G61.1 (every block
    ///   end stops).
    /// * G64 (with or without P): a piece the planner blends at full speed:
    ///   at least twice the feed per servo period (it caps a segment's
    ///   speed at its length per period, and a blend may take half), and
    ///   `v·√(b/a_n)`: the blend at either end of a piece of length `L`
    ///   turning by `b/L` has the radius `L²/b` (`R = tan θ · L/2`), run at
    ///   `√(a_n R)`. Never shorter than twenty times the lag.
    ///
    /// Never shorter than the shortest segment.
    fn lead_shortest_mm(
        &self,
        rule: TakeUpRule,
        run: &Run,
        lags: &[Vec3; 3],
        smooth: bool,
    ) -> Option<f64> {
        let options = self.walk.options;
        let planner = &options.planner;
        let min_segment = match options.segmentation {
            super::Segmentation::Adaptive { min_length_mm, .. } => min_length_mm,
            _ => super::DEFAULT_MIN_SEGMENT_LENGTH_MM,
        };
        let v = run.feed_mm_min.map_or(0.0, |f| f / 60.0);
        let own = |a: usize| lags[a][a].abs();
        let shortest = match rule {
            TakeUpRule::Exact { smooth: true } if smooth => {
                let tol = planner.tangent_tolerance(v.max(1e-9), run.arc);
                (0..3).fold(0.0f64, |m, a| m.max(own(a) / (0.5 * tol[a])))
            }
            TakeUpRule::Exact { .. } => return None,
            TakeUpRule::Within(_) | TakeUpRule::Always => {
                let a_n = planner
                    .max_acceleration_mm_s2
                    .iter()
                    .fold(f64::INFINITY, |m, x| m.min(*x))
                    * 0.75f64.sqrt();
                let b = (0..3).fold(0.0f64, |m, a| m.max(own(a)));
                let total = lags.iter().fold(Vec3::ZERO, |s, l| s + *l).norm();
                (2.0 * v * planner.servo_period_s)
                    .max(v * (b / a_n).sqrt())
                    .max(20.0 * total)
            }
        };
        Some(shortest.max(min_segment))
    }
}

/// The S-curve at target `end` of an arc (if one is there) and the targets
/// from it up to the next S-curve or the move's end, for a G61 hold that
/// reaches it (compensate/exact_hold.rs `Across`).
fn hold_across<'a>(
    transitions: &[super::arcs::Transition],
    targets: &'a [Vec3],
    end: usize,
) -> Option<super::exact_hold::Across<'a>> {
    let tr = transitions.iter().find(|tr| tr.index == end)?;
    let next = transitions
        .iter()
        .filter(|o| o.index > end)
        .fold(targets.len(), |e, o| e.min(o.index));
    Some(super::exact_hold::Across {
        targets: targets.get(end..next)?,
        axis: tr.axis,
        direction: tr.direction,
        deviation_mm: tr.deviation_mm,
    })
}

/// The share of a take-up ramp to put before a reversal inside an arc
/// (compensate/arcs.rs `ramp_lead_share`): the drift of the reversing
/// axis' command (its largest take-up) over `probe_mm` before the
/// reversal at parameter `l_rev` in the old state `s_old`, and after it
/// in the point's new state, each against the command at the reversal in
/// that state.
fn arc_ramp_lead_share(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    method: Method,
    (arc, l_rev, probe_mm): (&volcomp_gcode::Arc, f64, f64),
    (q_prev, s_old): (Vec3, Directions),
    (point, delta): (&crate::compensate::solve::PointSolution, Vec3),
) -> Result<f64, ModelError> {
    let len = arc.length();
    let a = (0..3)
        .filter(|a| point.reversed[*a])
        .max_by(|x, y| delta[*x].abs().total_cmp(&delta[*y].abs()));
    let Some(a) = a.filter(|_| len > 0.0 && probe_mm > 0.0) else {
        return Ok(0.5);
    };
    let l_before = (l_rev - probe_mm / len).max(0.0);
    let l_after = (l_rev + probe_mm / len).min(1.0);
    let mut q = |l: f64, s: Directions| -> Result<f64, ModelError> {
        Ok(solve_fixed_in(cells, model, method, arc.point_at(l), s, [false; 3], q_prev)?.q_mm[a])
    };
    let s1 = if l_before < l_rev {
        ((q(l_rev, s_old)? - q(l_before, s_old)?) * s_old[a].sign()).max(0.0)
            / ((l_rev - l_before) * len)
    } else {
        0.0
    };
    let s2 = if l_after > l_rev {
        ((q(l_after, point.s)? - q(l_rev, point.s)?) * point.s[a].sign()).max(0.0)
            / ((l_after - l_rev) * len)
    } else {
        0.0
    };
    Ok(super::arcs::ramp_lead_share(s1 * 1e3, s2 * 1e3))
}

/// Refuses a solved point whose command or residual is not finite, or whose
/// residual passes [`CompensateOptions::max_residual_um`] (no held axis).
fn check_converged(
    point: &crate::compensate::solve::PointSolution,
    options: &CompensateOptions,
    target_mm: Vec3,
    file: &str,
    line: u64,
) -> Result<(), CompensationError> {
    let finite = point.residual_um.is_finite() && (0..3).all(|a| point.q_mm[a].is_finite());
    let held = point.held.iter().any(|h| *h);
    // Direct and pitch do not aim at the full model's target: their
    // residual is the method's own error, checked for finiteness only.
    let aims = matches!(options.method, Method::Exact | Method::Ilc { .. });
    let too_far = options
        .max_residual_um
        .is_some_and(|max| aims && !held && point.residual_um > max);
    if finite && !too_far {
        return Ok(());
    }
    Err(CompensationError::AtLine {
        file: file.into(),
        line,
        message: format!(
            "the point X {:.4} Y {:.4} Z {:.4} mm (machine axes) is not reached: the model residual after {} iteration(s) is {} µm{}",
            target_mm[0],
            target_mm[1],
            target_mm[2],
            point.iterations,
            if point.residual_um.is_finite() { format!("{:.3}", point.residual_um) } else { "not finite".into() },
            options.max_residual_um.map_or(String::new(), |m| format!(", above the {m} µm accepted")),
        ),
        help: crate::error::help::RESIDUAL_LIMIT.into(),
    })
}

#[cfg(test)]
mod tests {
    use super::{
        carries_plunge_hold, fold_deviation_from_mm, fold_deviation_mm, hold_to_plunge_end,
    };
    use volcomp_gcode::Vec3;

    #[test]
    fn only_a_plunge_holds_an_x_or_y_reversal_to_its_end() {
        let (a, down) = (Vec3::new(-25.0, -16.0, 5.0), Vec3::new(-25.0, -16.0, -1.0));
        // Z alone moves: X, Y or both reversing are held to the end.
        assert!(hold_to_plunge_end(a, down, [true, false, false]));
        assert!(hold_to_plunge_end(a, down, [true, true, false]));
        assert!(hold_to_plunge_end(down, a, [false, true, false]));
        // Z, the axis the plunge drives, reversing; nothing reversing.
        assert!(!hold_to_plunge_end(a, down, [true, false, true]));
        assert!(!hold_to_plunge_end(a, down, [false; 3]));
        // A line with X or Y commanded (by 1 µm), or no move at all.
        let slant = Vec3::new(-25.001, -16.0, -1.0);
        assert!(!hold_to_plunge_end(a, slant, [false, true, false]));
        assert!(!hold_to_plunge_end(a, a, [true, false, false]));
        // The next line carries on a held Y, not an X the plunge did not
        // hold.
        assert!(carries_plunge_hold(
            [false, true, false],
            [false, true, false]
        ));
        assert!(!carries_plunge_hold(
            [false, true, false],
            [true, true, false]
        ));
        assert!(!carries_plunge_hold([false, true, false], [false; 3]));
    }

    const UM: f64 = 1e-3;

    /// The lags of one reversing axis `a`.
    fn one(a: usize, lag: Vec3) -> [Vec3; 3] {
        let mut l = [Vec3::ZERO; 3];
        l[a] = lag;
        l
    }

    #[test]
    fn a_lag_along_the_move_leaves_the_path_not_at_all() {
        // X reverses by 4 µm and the move goes on along X for 5 mm: the
        // band is crossed after 0.1 % of it, the tool waits on the line.
        let lags = one(0, Vec3::new(-4.0 * UM, 0.0, 0.0));
        let q0 = Vec3::new(10.0, 0.0, 0.0);
        let q = Vec3::new(5.0 - 0.004, 0.0, 0.0);
        assert!(fold_deviation_mm(&lags, q0, q, Vec3::new(-5.0, 0.0, 0.0)) < 1e-12);
    }

    #[test]
    fn a_still_axis_whose_command_crosses_exactly_its_band_costs_nothing() {
        // Z reverses by 2 µm on a move along X that the nominal path makes
        // at constant Z: the Z command travels exactly the 2 µm.
        let lags = one(2, Vec3::new(0.0, 0.0, 2.0 * UM));
        let q = Vec3::new(4.0, 0.0, 2.0 * UM);
        assert!(fold_deviation_mm(&lags, Vec3::ZERO, q, Vec3::new(4.0, 0.0, 0.0)) < 1e-12);
    }

    #[test]
    fn travel_past_the_band_leaves_its_share_across_the_path() {
        // The Z command travels 2.5 µm for a 2 µm band: crossed after 4/5 of
        // the move, when the image is still 1/5 of the lag short: 0.4 µm,
        // across a move along X.
        let lags = one(2, Vec3::new(0.0, 0.0, 2.0 * UM));
        let q = Vec3::new(4.0, 0.0, 2.5 * UM);
        let d = fold_deviation_mm(&lags, Vec3::ZERO, q, Vec3::new(4.0, 0.0, 0.0));
        assert!((d - 0.4 * UM).abs() < 1e-12, "{d}");
        // Travelling only 1.5 µm, 0.5 µm of the band is left at the end.
        let q = Vec3::new(4.0, 0.0, 1.5 * UM);
        let d = fold_deviation_mm(&lags, Vec3::ZERO, q, Vec3::new(4.0, 0.0, 0.0));
        assert!((d - 0.5 * UM).abs() < 1e-12, "{d}");
    }

    #[test]
    fn a_reversal_at_45_degrees_leaves_the_lag_times_sin_45() {
        // X reverses by 4 µm onto a move of 5 mm at 45°: the X command
        // travels 5 mm + 4 µm, the share is 5/5.004 of the lag, and its part
        // across the move is that times sin 45°.
        let lags = one(0, Vec3::new(-4.0 * UM, 0.0, 0.0));
        let q = Vec3::new(-5.004, 5.0, 0.0);
        let d = fold_deviation_mm(&lags, Vec3::ZERO, q, Vec3::new(-5.0, 5.0, 0.0));
        let expected = 4.0 * UM * (5.0 / 5.004) * std::f64::consts::FRAC_1_SQRT_2;
        assert!((d - expected).abs() < 1e-12, "{d} vs {expected}");
    }

    #[test]
    fn a_transverse_lag_fades_with_its_own_axis_whatever_the_others_do() {
        // On a plunge of 1 mm, Y reverses (its command crosses exactly its
        // 4 µm band) and that shifts X by 0.3 µm (the straightness tables
        // differ by direction). The shift is Y's carriage's: it fades as Y
        // engages, in step with the command, whether the X command moves
        // (1 µm away from it) or not: nothing leaves the path.
        let lags = one(1, Vec3::new(0.3 * UM, 4.0 * UM, 0.0));
        let plunge = Vec3::new(0.0, 0.0, -1.0);
        for x in [-UM, 0.0] {
            let q = Vec3::new(x, 4.0 * UM, -1.0);
            let d = fold_deviation_mm(&lags, Vec3::ZERO, q, plunge);
            assert!(d < 1e-12, "{d}");
        }
        // Where Y's command travels only half its band, half of both
        // components is still there at the end: √(0.15² + 2²) µm across.
        let q = Vec3::new(0.0, 2.0 * UM, -1.0);
        let d = fold_deviation_mm(&lags, Vec3::ZERO, q, plunge);
        assert!((d - 0.15f64.hypot(2.0) * UM).abs() < 1e-12, "{d}");
    }

    /// The reach of the blend at a line's end under G64 without P, the
    /// corner taken as the one at its start (`end_blend_reach_mm`), by
    /// hand: at F6000, `R = v²/a_n = 10 000 / (1000·√0.75)` = 11.547 mm.
    /// A right angle (`θ` = 45°): a 40 mm line keeps `R/tan θ` = 11.547 mm
    /// (`d_tol` = 10·cos θ/(1 − sin θ) = 24.14 mm), a 15 mm line its half,
    /// 7.5 mm (`d_tol` 9.053 mm). A 140° turn (`θ` = 20°) on a 40 mm line:
    /// the tolerance term, `T = 10` mm, 10·cos 20°/(1 − sin 20°) =
    /// 14.281 mm (`R/tan θ` = 31.72 mm).
    #[test]
    fn the_blend_at_a_line_s_end_taken_as_the_one_at_its_start() {
        let p = crate::compensate::PlannerLimits::default();
        let x = Vec3::new(1.0, 0.0, 0.0);
        let y = Vec3::new(0.0, 1.0, 0.0);
        let d = super::end_blend_reach_mm(&p, x, y, 100.0, 40.0);
        assert!((d - 11.547_005).abs() < 1e-5, "{d}");
        let d = super::end_blend_reach_mm(&p, x, y, 100.0, 15.0);
        assert!((d - 7.5).abs() < 1e-12, "{d}");
        let turn = 140f64.to_radians();
        let t2 = Vec3::new(turn.cos(), turn.sin(), 0.0);
        let d = super::end_blend_reach_mm(&p, x, t2, 100.0, 40.0);
        let th = 20f64.to_radians();
        assert!((d - 10.0 * th.cos() / (1.0 - th.sin())).abs() < 1e-9, "{d}");
        assert!((d - 14.281).abs() < 1e-3, "{d}");
    }

    /// The run of a line after a corner, its deflection and blend distance
    /// computed once, is the one of the blend distances taken from the
    /// tangents each time (the second method, [`end_blend_reach_mm`] and
    /// [`crate::compensate::PlannerLimits::blend_distance_mm`] as written out
    /// before): to the bit, on 3,000 random corners under G64 with and
    /// without P and under G61, lines of 0.05–50 mm at F600–F12000.
    #[test]
    fn a_corner_computed_once_gives_the_run_of_its_tangents() {
        let p = crate::compensate::PlannerLimits::default();
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut rnd = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let unit = |v: Vec3| v * (1.0 / v.norm());
        let mut corners = 0;
        for k in 0..3_000 {
            let t1 = unit(Vec3::new(rnd() - 0.5, rnd() - 0.5, 0.2 * (rnd() - 0.5)));
            // Gentle turns too (tangent at high feeds).
            let t2 = if k % 3 == 0 {
                unit(t1 + Vec3::new(rnd() - 0.5, rnd() - 0.5, 0.0) * 2e-3)
            } else {
                unit(Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5))
            };
            let (len, prev_len) = (0.05 + 50.0 * rnd(), 0.05 + 50.0 * rnd());
            let f = 600.0 + 11_400.0 * rnd();
            let path_mode = match k % 3 {
                0 => volcomp_gcode::PathMode::ExactPath,
                1 => volcomp_gcode::PathMode::Blend {
                    tolerance_mm: 0.0,
                    naive_cam_mm: 0.0,
                },
                _ => volcomp_gcode::PathMode::Blend {
                    tolerance_mm: 0.005,
                    naive_cam_mm: 0.005,
                },
            };
            let start = Vec3::new(10.0, 20.0, 30.0);
            let m = volcomp_gcode::Motion {
                kind: volcomp_gcode::MotionKind::Feed,
                start,
                end: start + t2 * len,
                line: 1,
                column: 1,
                feed: f,
                source: volcomp_gcode::MotionSource::Program,
                extra: Default::default(),
                feed_mode: volcomp_gcode::interp::FeedMode::PerMinute,
                path_mode,
            };
            let (_, t2) = super::tangents(&m);
            let run = super::Run::of(&m, Some((t1, prev_len)), &p);
            let len = super::length_mm(&m);
            let v = f / 60.0;
            let corner = p.kink_ratio(t1, t2, v, false) >= 1.0;
            let (protect, end) = match path_mode {
                volcomp_gcode::PathMode::Blend { tolerance_mm, .. } if corner => {
                    let within = if tolerance_mm > 0.0 {
                        p.blend_distance_within_mm(t1, t2, tolerance_mm)
                    } else {
                        f64::INFINITY
                    };
                    let d = p
                        .blend_distance_mm(t1, t2, v)
                        .min(within)
                        .min(0.5 * prev_len)
                        .min(0.5 * len);
                    let end = if tolerance_mm > 0.0 {
                        2.0 * p.blend_reach_any_corner_mm(v, len, Some(tolerance_mm))
                    } else {
                        2.0 * super::end_blend_reach_mm(&p, t1, t2, v, len)
                    };
                    (2.0 * d, end)
                }
                volcomp_gcode::PathMode::Blend { tolerance_mm, .. } if tolerance_mm > 0.0 => (
                    0.0,
                    2.0 * p.blend_reach_any_corner_mm(v, len, Some(tolerance_mm)),
                ),
                _ => (0.0, 0.0),
            };
            corners += usize::from(corner && k % 3 != 0);
            assert_eq!(run.corner_before, corner, "{k}");
            assert_eq!(run.protect_mm.to_bits(), protect.to_bits(), "{k}");
            assert_eq!(run.split_end_mm.to_bits(), end.to_bits(), "{k}");
        }
        assert!(corners > 1_000, "{corners}");
    }

    #[test]
    fn no_split_point_inside_a_blend_zone() {
        // A 10 mm line split at 0.5, 3, 5 and 9.7 mm, blend zones of 1 mm
        // at both ends: 0.5 and 9.7 go, 1 and 9 come in their place.
        let x = |v: f64| Vec3::new(v, 0.0, 0.0);
        let mut t = vec![x(0.5), x(3.0), x(5.0), x(9.7), x(10.0)];
        super::protect_blends(&mut t, x(0.0), (1.0, 1.0));
        assert_eq!(t, vec![x(1.0), x(3.0), x(5.0), x(9.0), x(10.0)]);
        // Nothing near the ends: nothing changes.
        let mut t = vec![x(3.0), x(10.0)];
        super::protect_blends(&mut t, x(0.0), (1.0, 1.0));
        assert_eq!(t, vec![x(3.0), x(10.0)]);
        // A line shorter than both zones runs whole.
        let mut t = vec![x(0.7), x(1.5)];
        super::protect_blends(&mut t, x(0.0), (1.0, 1.0));
        assert_eq!(t, vec![x(1.5)]);
        // Zones of their own: 1 mm at the start, 6 mm at the end (a corner
        // not known yet): 5 and 9.7 go, one point comes at 4.
        let mut t = vec![x(0.5), x(3.0), x(5.0), x(9.7), x(10.0)];
        super::protect_blends(&mut t, x(0.0), (1.0, 6.0));
        assert_eq!(t, vec![x(1.0), x(3.0), x(4.0), x(10.0)]);
        // Together longer than the line: it runs whole.
        let mut t = vec![x(3.0), x(10.0)];
        super::protect_blends(&mut t, x(0.0), (0.0, 10.0));
        assert_eq!(t, vec![x(10.0)]);
    }

    #[test]
    fn a_take_up_is_tangent_over_a_piece_long_enough_for_the_planner() {
        // F6000, 1 ms, 1000 mm/s², at a block's first piece (the tolerance
        // halved): κ = 0.05 · 1000 / 101 000 = 0.495 mrad, 60 % of it for
        // the take-up: a 4 µm take-up needs 4e-3 / (0.6 · 0.495e-3) =
        // 13.47 mm. A 0.217 mm lead piece turns the path by 18 mrad.
        let kink = crate::compensate::PlannerLimits::default().tangent_tolerance(100.0, true);
        let delta = Vec3::new(0.0, 4.0 * UM, 0.0);
        let need: f64 = 4e-3 / (0.6 * 0.05 * 1000.0 / 101_000.0);
        assert!((need - 13.4667).abs() < 1e-3, "{need}");
        assert!(super::fold_is_tangent(delta, kink, need * 1.001));
        assert!(!super::fold_is_tangent(delta, kink, need * 0.999));
        assert!(!super::fold_is_tangent(delta, kink, 0.217));
    }

    #[test]
    fn a_lag_with_no_reversal_value_of_its_own_switches_at_once() {
        // X's tables change Y by 0.5 µm with the direction but X itself has
        // no reversal value there: the carriage engages at once, the tool
        // steps by 0.5 µm across a move along X at the start.
        let lags = one(0, Vec3::new(0.0, 0.5 * UM, 0.0));
        let q = Vec3::new(-3.0, 0.0, 0.0);
        let d = fold_deviation_mm(&lags, Vec3::ZERO, q, Vec3::new(-3.0, 0.0, 0.0));
        assert!((d - 0.5 * UM).abs() < 1e-12, "{d}");
    }

    /// A map with slopes, transverse terms and a reversal value on every
    /// axis (4, 3 and 2 µm): the take-up's rounds move every axis.
    fn sloped_map() -> crate::model::axis_table::AxisTableMap {
        let csv = "axis,direction,position_mm,ex_um,ey_um,ez_um\n\
                   X,forward,0,0,0,0\nX,forward,50,3,1.5,-0.5\nX,forward,100,1,2,0.5\n\
                   X,reverse,0,4,0.3,0\nX,reverse,50,7,1.9,-0.4\nX,reverse,100,5,2.2,0.6\n\
                   Y,forward,0,0,0,0\nY,forward,50,-1,2,0.2\nY,forward,100,0.5,1,0.1\n\
                   Y,reverse,0,0.2,3,0\nY,reverse,50,-0.7,5,0.3\nY,reverse,100,0.6,4,0.2\n\
                   Z,forward,0,0,0,0\nZ,forward,50,0.4,-0.3,1\nZ,forward,100,0.2,0.1,2\n\
                   Z,reverse,0,0.1,0,2\nZ,reverse,50,0.5,-0.2,3\nZ,reverse,100,0.3,0.2,4\n";
        crate::model::axis_table::AxisTableMap::from_csv(csv, "m.csv").unwrap()
    }

    fn frame_mm(decimals: u8) -> super::Frame {
        super::Frame {
            offset_mm: Vec3::ZERO,
            mm_per_unit: 1.0,
            decimals,
            absolute: true,
            rotation_deg: 0.0,
            before_mm: Vec3::ZERO,
            after_mm: Vec3::ZERO,
            x_word_scale: 1.0,
            arc_absolute: false,
        }
    }

    /// The take-up command as it was computed before it stopped early:
    /// eight rounds, each through the whole map lookup.
    fn take_up_eight_rounds(
        model: &dyn crate::model::ErrorModel,
        q_prev: Vec3,
        s_old: crate::model::Directions,
        s_new: crate::model::Directions,
        reversed: [bool; 3],
        (toward, up_to_toward): (Vec3, bool),
        frame: &super::Frame,
    ) -> Vec3 {
        use crate::model::{actual_mm, Components};
        let held = actual_mm(model, q_prev, s_old, Components::All).unwrap();
        let mut q = q_prev;
        let mut s = s_old;
        for a in 0..3 {
            if reversed[a] {
                s[a] = s_new[a];
            }
        }
        let mut moves = reversed;
        for _ in 0..8 {
            let img = actual_mm(model, q, s, Components::All).unwrap();
            for a in 0..3 {
                if reversed[a] {
                    q[a] += held[a] - img[a];
                } else {
                    let next = q[a] + held[a] - img[a];
                    let (d, room) = (next - q_prev[a], toward[a] - q_prev[a]);
                    moves[a] = d * room > 0.0 && (up_to_toward || d.abs() <= room.abs());
                    q[a] = match (moves[a], d.abs() <= room.abs()) {
                        (false, _) => q_prev[a],
                        (true, true) => next,
                        (true, false) => toward[a],
                    };
                }
            }
        }
        let mut out = frame.quantize(q, q_prev);
        for a in 0..3 {
            if !reversed[a] {
                if !moves[a] {
                    out[a] = q_prev[a];
                }
            } else if (out[a] - q_prev[a]) * s_new[a].sign() <= 0.0 {
                out[a] = q_prev[a];
            }
        }
        out
    }

    /// The take-up that stops where its command repeats, in the tables'
    /// cells kept from case to case, is the eight rounds' command to the bit: on 3,000 points,
    /// states, reversing axes and segment commands (toward or past the
    /// take-up, up to it or not), at 4 and 6 decimals. By hand: X alone
    /// reverses at 10 mm on a map whose X reverse table lies 4 µm above the
    /// forward one (no slope): the command goes 4 µm back, to 9.996.
    #[test]
    fn the_take_up_that_stops_early_is_the_eight_rounds_one() {
        use crate::model::Direction::{Forward as F, Reverse as R};
        let flat = crate::model::axis_table::AxisTableMap::from_csv(
            "axis,direction,position_mm,ex_um,ey_um,ez_um\n\
             X,forward,0,0,0,0\nX,forward,100,0,0,0\nX,reverse,0,4,0,0\nX,reverse,100,4,0,0\n\
             Y,both,0,0,0,0\nY,both,100,0,0,0\nZ,both,0,0,0,0\nZ,both,100,0,0,0\n",
            "flat.csv",
        )
        .unwrap();
        let q0 = Vec3::new(10.0, 20.0, 30.0);
        let tu = super::take_up_command(
            &mut crate::model::AxisCells::default(),
            &flat,
            q0,
            [F; 3],
            [R, F, F],
            [true, false, false],
            (Vec3::new(5.0, 20.0, 30.0), false),
            &frame_mm(4),
        )
        .unwrap();
        assert_eq!(tu, Vec3::new(9.996, 20.0, 30.0));
        let map = sloped_map();
        let mut rnd = crate::compensate::solve::tests::uniform(0x9e37_79b9_7f4a_7c15);
        let dir = |x: f64| if x < 0.5 { F } else { R };
        // One cache for every case, as the walk keeps it between points.
        let mut cells = crate::model::AxisCells::default();
        for k in 0..3000 {
            let q_prev = Vec3::new(1.0 + 98.0 * rnd(), 1.0 + 98.0 * rnd(), 1.0 + 98.0 * rnd());
            let s_old = [dir(rnd()), dir(rnd()), dir(rnd())];
            let mut reversed = [rnd() < 0.5, rnd() < 0.5, rnd() < 0.5];
            reversed[k % 3] = true;
            let s_new = [0, 1, 2].map(|a| {
                if reversed[a] {
                    s_old[a].flipped()
                } else {
                    s_old[a]
                }
            });
            let step = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * (0.02 * rnd());
            let toward = (q_prev + step, k % 2 == 0);
            let frame = frame_mm(if k % 4 == 0 { 6 } else { 4 });
            let fast = super::take_up_command(
                &mut cells, &map, q_prev, s_old, s_new, reversed, toward, &frame,
            )
            .unwrap();
            let slow = take_up_eight_rounds(&map, q_prev, s_old, s_new, reversed, toward, &frame);
            let bits = |v: Vec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
            assert_eq!(bits(fast), bits(slow), "{q_prev:?} {s_old:?} {reversed:?}");
        }
    }

    /// Under G64 without P a ramp whose end would fall inside the zone a
    /// held line keeps whole for the blend at its end runs to the line's
    /// end ([`super::plan_ramp`]'s `end_zone_mm`). Z's band is 2 µm (its
    /// reverse table 2 µm up, nothing else moves the tool), so the take-up
    /// is 2 µm of Z; at 100 mm/s the tangency tolerance between lines is
    /// 0.1 · 1,000 / (100 / 0.001 + 1,000) = 0.990 mrad (tp.c
    /// `tpSetupTangent`), so the ramp needs 2e-3 · 101,000 / 60 = 3.367 mm
    /// by hand. From the reversal 0.5 mm into an 8 mm line, it ends 3.367 mm
    /// in: a point inserted there, 4.633 mm before the line's end. Inside a
    /// 6.5 mm end zone none is inserted and the ramp ends at the line's end;
    /// a 4 mm zone does not reach it, nor a zone where the line goes on.
    #[test]
    fn a_ramp_ending_inside_a_held_line_s_end_zone_runs_to_the_line_s_end() {
        use crate::model::AxisCells;
        use crate::model::Direction::{Forward as F, Reverse as R};
        let map = crate::model::axis_table::AxisTableMap::from_csv(
            "axis,direction,position_mm,ex_um,ey_um,ez_um\n\
             X,both,0,0,0,0\nX,both,100,0,0,0\n\
             Y,both,0,0,0,0\nY,both,100,0,0,0\n\
             Z,forward,0,0,0,0\nZ,forward,100,0,0,0\n\
             Z,reverse,0,0,0,2\nZ,reverse,100,0,0,2\n",
            "z.csv",
        )
        .unwrap();
        let options = super::CompensateOptions::default();
        let frame = frame_mm(5);
        let quantize = |q: Vec3, from: Vec3| frame.quantize(q, from);
        let mut cells = AxisCells::default();
        let t_prev = Vec3::new(10.0, 10.0, 10.0);
        let (s_old, s_new) = ([F, F, F], [F, F, R]);
        let reversed = [false, false, true];
        let solve = |t: Vec3, s| {
            crate::compensate::solve::solve_fixed(
                &map,
                options.method,
                t,
                s,
                [false; 3],
                Vec3::ZERO,
            )
            .unwrap()
            .q_mm
        };
        let q_prev = solve(t_prev, s_old);
        let at = |x: f64| t_prev + Vec3::new(x, 0.0, 0.0);
        let plan = |cells: &mut AxisCells, ends: &[f64], zone_mm: f64| {
            let targets: Vec<Vec3> = ends.iter().map(|x| at(*x)).collect();
            let point = crate::compensate::solve::PointSolution {
                q_mm: frame.quantize(solve(targets[0], s_new), q_prev),
                s: s_new,
                iterations: 1,
                residual_um: 0.0,
                reversed,
                held: [false; 3],
            };
            let lags = super::switch_lags_mm(cells, &map, q_prev, s_old, s_new, reversed).unwrap();
            let tu = super::take_up_command(
                cells,
                &map,
                q_prev,
                s_old,
                s_new,
                reversed,
                (point.q_mm, false),
                &frame,
            )
            .unwrap();
            let delta = tu - q_prev;
            assert!((delta.z.abs() - 2e-3).abs() < 1e-6, "{delta:?}");
            let kink = options.planner.tangent_tolerance(100.0, false);
            let shortest = super::shortest_ramp_piece_mm(&options, 100.0);
            super::plan_ramp(
                cells,
                &map,
                &options,
                &quantize,
                (targets.as_slice(), &super::Leads::Lines, &[]),
                (0, t_prev, q_prev),
                &point,
                (delta, &lags, [false; 3]),
                (kink, 5e-3, shortest, None, 0.0),
                (false, false, false),
                zone_mm,
            )
            .unwrap()
            .expect("a ramp")
        };
        let need_mm = 2e-3 * 101_000.0 / 60.0;
        // No zone, and a 4 mm one: the ramp's end inserted 3.367 mm in.
        for zone_mm in [0.0, 4.0] {
            let p = plan(&mut cells, &[0.5, 8.0], zone_mm);
            assert_eq!(p.insert.len(), 1, "{zone_mm}");
            let (k, x, _) = p.insert[0];
            assert_eq!(k, 1);
            assert!(((x - t_prev).x - need_mm).abs() < 1e-6, "{x:?}");
        }
        // A 6.5 mm zone: none inserted, the ramp runs to the line's end.
        let p = plan(&mut cells, &[0.5, 8.0], 6.5);
        assert!(p.insert.is_empty(), "{:?}", p.insert);
        assert_eq!(p.fracs.last().copied(), Some(0.0));
        // 1 − 0.5 / 8 of the take-up left at the reversal's target.
        assert_eq!(p.fracs.len(), 2, "{:?}", p.fracs);
        assert!((p.fracs[0] - 0.9375).abs() < 1e-12, "{:?}", p.fracs);
        // The line goes on past the ramp's piece: the zone is not there.
        let p = plan(&mut cells, &[0.5, 8.0, 20.0], 6.5);
        assert_eq!(p.insert.len(), 1);
    }

    /// The try without the floor is skipped where [`super::floor_lengthens_ramp`]
    /// says the floor changed nothing: there [`super::plan_ramp`] with the
    /// floor plans to the bit what it plans without (the second method: both
    /// calls made), on 6,000 take-ups of one to three reversing axes along
    /// lines of 80 targets 0.05–0.5 mm apart on the sloped map, G64 and G61
    /// alike, floors from none to twice the tangency's length. Asserts that
    /// both kinds of floor occurred and that plans were found. By hand: a
    /// floor of 2 mm lengthens a ramp whose tangency needs 1 mm, one of
    /// 0.5 mm does not, nor any floor where the ramp's length is given.
    #[test]
    fn a_floor_that_lengthens_no_ramp_plans_as_no_floor() {
        use crate::model::Direction::{Forward as F, Reverse as R};
        use crate::model::{AxisCells, Directions};
        // The tangency's length by hand: |Δ| / (RAMP_SHARE · κ) with
        // κ = 1e-3 / 0.6 on every axis and a take-up of 1 µm: 1 mm.
        let kink = [1e-3 / super::RAMP_SHARE; 3];
        let unit = Vec3::new(1e-3, 0.0, 0.0);
        assert!(super::floor_lengthens_ramp(
            (&super::Leads::Lines, None, false),
            unit,
            (kink, 0.01),
            2.0
        ));
        assert!(!super::floor_lengthens_ramp(
            (&super::Leads::Lines, None, false),
            unit,
            (kink, 0.01),
            0.5
        ));
        assert!(!super::floor_lengthens_ramp(
            (&super::Leads::Lines, Some(1.5), false),
            unit,
            (kink, 0.01),
            2.0
        ));
        let map = sloped_map();
        let options = super::CompensateOptions::default();
        let frame = frame_mm(4);
        let quantize = |q: Vec3, from: Vec3| frame.quantize(q, from);
        let mut rnd = crate::compensate::solve::tests::uniform(0x2545_f491_4f6c_dd1d);
        let mut cells = AxisCells::default();
        let (mut same_floor, mut longer, mut planned) = (0, 0, 0);
        for k in 0..6000 {
            let smooth = k % 2 == 0;
            let t_prev = Vec3::new(
                10.0 + 80.0 * rnd(),
                10.0 + 80.0 * rnd(),
                10.0 + 80.0 * rnd(),
            );
            let dir = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5);
            let dir = dir * (1.0 / dir.norm());
            let spacing = 0.05 + 0.45 * rnd();
            let targets: Vec<Vec3> = (1..=80)
                .map(|j| t_prev + dir * (spacing * j as f64))
                .collect();
            let s_old: Directions = [F, F, F];
            let mut reversed = [rnd() < 0.4, rnd() < 0.4, rnd() < 0.4];
            reversed[k % 3] = true;
            let s_new: Directions = [0, 1, 2].map(|a| if reversed[a] { R } else { F });
            let q_prev = crate::compensate::solve::solve_fixed(
                &map,
                options.method,
                t_prev,
                s_old,
                [false; 3],
                Vec3::ZERO,
            )
            .unwrap()
            .q_mm;
            let q = crate::compensate::solve::solve_fixed(
                &map,
                options.method,
                targets[0],
                s_new,
                [false; 3],
                Vec3::ZERO,
            )
            .unwrap()
            .q_mm;
            let point = crate::compensate::solve::PointSolution {
                q_mm: frame.quantize(q, q_prev),
                s: s_new,
                iterations: 1,
                residual_um: 0.0,
                reversed,
                held: [false; 3],
            };
            let lags =
                super::switch_lags_mm(&mut cells, &map, q_prev, s_old, s_new, reversed).unwrap();
            // The take-up toward the point, as the solve finds it.
            let tu = super::take_up_command(
                &mut cells,
                &map,
                q_prev,
                s_old,
                s_new,
                reversed,
                (point.q_mm, smooth),
                &frame,
            )
            .unwrap();
            let delta = tu - q_prev;
            let v_mm_s = 20.0 + 80.0 * rnd();
            let kink = options.planner.tangent_tolerance(v_mm_s, false);
            let shortest = super::shortest_ramp_piece_mm(&options, v_mm_s);
            let leads = super::Leads::Lines;
            let need = super::ramp_need_mm(&leads, None, smooth, delta, kink, shortest);
            let floor = if k % 5 == 0 { 0.0 } else { 2.0 * need * rnd() };
            if floor <= 0.0
                || super::floor_lengthens_ramp(
                    (&leads, None, smooth),
                    delta,
                    (kink, shortest),
                    floor,
                )
            {
                longer += usize::from(floor > 0.0);
                continue;
            }
            same_floor += 1;
            let mut plan = |floor_mm: f64| {
                super::plan_ramp(
                    &mut cells,
                    &map,
                    &options,
                    &quantize,
                    (targets.as_slice(), &leads, &[]),
                    (0, t_prev, q_prev),
                    &point,
                    (delta, &lags, [false; 3]),
                    (kink, 2e-3, shortest, None, floor_mm),
                    (smooth, false, false),
                    0.0,
                )
                .unwrap()
                .map(|p| {
                    let bits = |v: Vec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
                    (
                        p.fracs.iter().map(|f| f.to_bits()).collect::<Vec<_>>(),
                        p.insert
                            .iter()
                            .map(|(i, v, l)| (*i, bits(*v), l.map(f64::to_bits)))
                            .collect::<Vec<_>>(),
                        p.bound_mm.to_bits(),
                    )
                })
            };
            let with_floor = plan(floor);
            let without = plan(0.0);
            planned += usize::from(with_floor.is_some());
            assert_eq!(with_floor, without, "case {k}: floor {floor} need {need}");
        }
        assert!(
            same_floor > 1000 && longer > 1000 && planned > 40,
            "{same_floor} {longer} {planned}"
        );
    }

    /// A fold along X of a Z take-up: Z's lag 4 µm, its command 8 µm up
    /// over the move (it crosses its band at half the move, `r = 2`). The
    /// tool is off `4·λ` µm below the path up to `λ = ½` and back onto it
    /// at the end: 2 µm (docs/compensation.md, "Take-ups folded into the
    /// move"). Started 1 µm below the path (where a hold left it), the
    /// offset `1·(1 − λ)` adds: 2.5 µm at `λ = ½`; started 1 µm above, it
    /// takes away: 1.5 µm there, 1 µm at the start (by hand).
    #[test]
    fn a_fold_from_where_a_hold_left_the_tool_counts_that_offset_fading() {
        let lags = [Vec3::ZERO, Vec3::ZERO, Vec3::new(0.0, 0.0, 0.004)];
        let q = Vec3::new(3.0, 0.0, 0.008);
        let along = Vec3::new(3.0, 0.0, 0.0);
        let d = fold_deviation_mm(&lags, Vec3::ZERO, q, along);
        assert!((d - 0.002).abs() < 1e-12, "{d}");
        let below = Vec3::new(0.0, 0.0, -0.001);
        let d = fold_deviation_from_mm(&lags, Vec3::ZERO, q, along, (0.0, below));
        assert!((d - 0.0025).abs() < 1e-12, "{d}");
        let d = fold_deviation_from_mm(&lags, Vec3::ZERO, q, along, (0.0, -below));
        assert!((d - 0.0015).abs() < 1e-12, "{d}");
        // An offset along the move is the tool arriving later: none.
        let behind = Vec3::new(-0.001, 0.0, 0.0);
        let d = fold_deviation_from_mm(&lags, Vec3::ZERO, q, along, (0.0, behind));
        assert!((d - 0.002).abs() < 1e-12, "{d}");
    }
}
