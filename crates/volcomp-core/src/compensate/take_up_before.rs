//! Under G61, a take-up block of the arc plane's normal axis that the
//! solve put right after a quarter-point S-curve, moved to right before
//! it where there every axis it moves goes its own way
//! (docs/compensation.md, "A normal-axis take-up before the S-curve").
//!
//! At a quarter point the S-curve axis `A` reverses, and its switch moves
//! the normal axis' target by the jump of `A`'s straightness across the
//! plane (bench/coarse_map.py: 3 µm of Z at X's reversal). Where that step
//! runs against the side the normal axis' carriage rests on, the normal
//! axis must reverse too; the solve writes that take-up block after the
//! S-curve. But the normal axis' own switch moves `A`'s target by its
//! straightness in turn, and after the quarter point `A` runs its new
//! way: a step of `A` along its old way cannot be followed there, and the
//! tool stands off by it until `A`'s motion along the arc catches up
//! (3.3–3.7 µm on the coarse map). Before the quarter point `A` still
//! runs its old way: the same block written there moves every axis its
//! own way, and through the S-curve the normal axis, on its new side
//! already, follows the step `A`'s switch makes while `A` crosses its
//! band (the dead-band reading of docs/design.md, "Direction state and
//! backlash"; bench/eval/judge.py `band`: a lag fades as the reversing
//! axis' command crosses its band). The block stays a block: a stop under
//! G61 either way (tp.c `tpSetupTangent` sees a corner).

use super::arcs::Transition;
use super::solve::solve_fixed_in;
use super::PointRecord;
use crate::error::ModelError;
use crate::model::{AxisCells, Directions, ErrorModel};
use volcomp_gcode::Vec3;

/// The motion `points::State::solve_targets` solved, kept in step: the
/// commands (each with the take-up written before it), the nominal
/// targets, the direction state of each piece, the per-point records and
/// the S-curves.
pub(super) struct Solved<'a> {
    pub(super) commands: &'a mut Vec<(Vec3, Option<Vec3>)>,
    pub(super) targets: &'a [Vec3],
    pub(super) states: &'a mut Vec<Directions>,
    pub(super) records: &'a mut Vec<PointRecord>,
    pub(super) transitions: &'a mut [Transition],
}

/// What the moved take-up is solved with: the map, the solver method, the
/// plane's normal axis and the quantizer of the written words.
pub(super) struct Setting<'a> {
    pub(super) model: &'a dyn ErrorModel,
    pub(super) arc: &'a volcomp_gcode::Arc,
    pub(super) pieces: &'a [f64],
    pub(super) method: super::solve::Method,
    pub(super) normal: usize,
    pub(super) quantize: &'a dyn Fn(Vec3, Vec3) -> Vec3,
    /// The quantizer of a take-up block written before the motion's first
    /// piece (the frame the walk writes that block in).
    pub(super) quantize_first: &'a dyn Fn(Vec3, Vec3) -> Vec3,
    /// Where the motion starts: the command, the direction state and the
    /// nominal target (the arc's start): the "piece before" of an S-curve
    /// that ends the motion's first piece. `None` where the motion may
    /// continue an S-curve that begins in the block before (no block may
    /// go between its parts).
    pub(super) start: Option<(Vec3, Directions, Vec3)>,
    /// The contour tolerance (mm): a take-up block's chord ending along
    /// the first piece departs from the arc by no more.
    pub(super) tolerance_mm: f64,
}

/// How far a written step may run against an axis' side and still count
/// as along it (mm): one step of the written words' last digit (0.01 µm),
/// with room for the difference's own rounding; no take-up.
const AGAINST_MM: f64 = 0.015e-3;

/// Moves every take-up block of the normal axis written right after an
/// S-curve to right before it where every step then runs its axis' way
/// (module documentation); returns how many were moved.
pub(super) fn move_take_ups_before(
    cells: &mut AxisCells,
    m: &mut Solved<'_>,
    set: &Setting<'_>,
) -> Result<usize, ModelError> {
    let mut moved = 0;
    for t in 0..m.transitions.len() {
        if move_one(cells, m, set, t)? {
            moved += 1;
        }
    }
    // A corner block before an arc's first piece (no S-curve there) is
    // not advanced along the piece: an advance of 73 µm there left a
    // random G61 program (tests/random_programs.rs, a plunge into a G3
    // that starts at X's quarter point, example map) 1.09 µm off the
    // path against 0.31 µm without it, the cause not derived.
    Ok(moved)
}

/// Whether every axis' step from `from` to `to` runs along its side in
/// `s` (within [`AGAINST_MM`]).
fn along(from: Vec3, to: Vec3, s: Directions) -> bool {
    (0..3).all(|a| (to[a] - from[a]) * s[a].sign() >= -AGAINST_MM)
}

/// [`move_take_ups_before`] for the S-curve `t`.
fn move_one(
    cells: &mut AxisCells,
    m: &mut Solved<'_>,
    set: &Setting<'_>,
    t: usize,
) -> Result<bool, ModelError> {
    let w = set.normal;
    let n = m.commands.len();
    let i = m.transitions[t].index;
    let k = i + 1;
    // The S-curve ends piece i; the take-up is written before piece k. The
    // piece before the S-curve (i − 1) gives the side every axis rests on
    // as the S-curve begins; for the motion's first piece, the motion's
    // start does (an arc that begins at a quarter point).
    if k >= n || m.states.len() != n || m.targets.len() != n || m.records.len() != n {
        return Ok(false);
    }
    let (start, s_before, t_before) = match (i, set.start) {
        (0, None) => return Ok(false),
        (0, Some(start)) => start,
        _ => (m.commands[i - 1].0, m.states[i - 1], m.targets[i - 1]),
    };
    let quantize_take = if i == 0 {
        set.quantize_first
    } else {
        set.quantize
    };
    if m.commands[k].1.is_none() {
        return Ok(false);
    }
    if m.commands[i].1.is_some() {
        return Ok(false);
    }
    let (s_scurve, s_after) = (m.states[i], m.states[k]);
    // Only the normal axis switches at the take-up.
    if (0..3).any(|a| (s_after[a] != s_scurve[a]) != (a == w)) {
        return Ok(false);
    }
    // The S-curve reverses its own axis and no other, and not the normal.
    let a_axis = m.transitions[t].axis;
    if a_axis == w || (0..3).any(|a| (s_scurve[a] != s_before[a]) != (a == a_axis)) {
        return Ok(false);
    }
    let free = [false; 3];
    // The take-up before the S-curve: its start in the old state but the
    // normal axis'.
    let mut s_take = s_before;
    s_take[w] = s_after[w];
    let q_take = solve_fixed_in(cells, set.model, set.method, t_before, s_take, free, start)?;
    let q_take = quantize_take(q_take.q_mm, start);
    // The S-curve's end in the new state.
    let q_end = solve_fixed_in(
        cells,
        set.model,
        set.method,
        m.targets[i],
        s_after,
        free,
        q_take,
    )?;
    let q_end = (set.quantize)(q_end.q_mm, q_take);
    let next = m.commands[k].0;
    // The S-curve's end in its own state, where the block after it starts.
    let q_scurve_end = solve_fixed_in(
        cells,
        set.model,
        set.method,
        m.targets[i],
        s_scurve,
        free,
        start,
    )?;
    let q_scurve_end = (set.quantize)(q_scurve_end.q_mm, start);
    // Moved before the S-curve where every step goes its axis' way: the
    // block in the old state (the normal axis its new way), the S-curve and
    // the piece after it in the new; and only where a block right after
    // the S-curve would not (the reversing axis' step against its new way).
    // Else the block stays after it, ending along the next piece.
    if along(q_scurve_end, q_end, s_after)
        || !along(start, q_take, s_take)
        || !along(q_take, q_end, s_after)
        || !along(q_end, next, s_after)
    {
        return advance_after(cells, m, set, (start, i, k), (s_scurve, s_after));
    }
    m.commands[i] = (q_end, Some(q_take));
    m.commands[k].1 = None;
    m.states[i] = s_after;
    m.records[i].command_mm = q_end;
    m.records[i].take_up = true;
    m.records[k].take_up = false;
    // The S-curve's normal step is written within it now, on the side the
    // take-up set: no smooth step around it across the take-up.
    m.transitions[t].spread = None;
    Ok(true)
}

/// The take-up after the S-curve kept there, where the S-curve's end in
/// its own state moves every axis its new way into the new state, but
/// written so: the S-curve ends in its own state (the normal axis held
/// where it stands), and the block ends a little along the next piece
/// where every other axis' step the normal axis' switch makes is along
/// its motion there (a step against an axis' motion is caught up by the
/// motion along the path, as on a line: compensate/take_up_advance.rs).
/// Over the block the tool moves linearly while the normal axis crosses
/// its band, and its lag across the plane fades in step (bench/eval/judge.py
/// `band`).
fn advance_after(
    cells: &mut AxisCells,
    m: &mut Solved<'_>,
    set: &Setting<'_>,
    (start, i, k): (Vec3, usize, usize),
    (s_scurve, s_after): (Directions, Directions),
) -> Result<bool, ModelError> {
    let w = set.normal;
    let n = m.commands.len();
    if set.pieces.len() != n || k + 1 > n {
        return Ok(false);
    }
    let mut hold = [false; 3];
    hold[w] = true;
    // The S-curve's end in its own state, the normal axis where it stands.
    let own = solve_fixed_in(
        cells,
        set.model,
        set.method,
        m.targets[i],
        s_scurve,
        hold,
        m.commands[i].0,
    )?;
    let own = (set.quantize)(own.q_mm, start);
    if !along(start, own, s_scurve) {
        return Ok(false);
    }
    // The arc in the targets' frame: the same shift at both ends.
    let shift = m.targets[i] - set.arc.point_at(set.pieces[i]);
    let next = m.commands[k].0;
    let (l0, l1) = (set.pieces[i], set.pieces[k]);
    let length_mm = set.arc.length() * (l1 - l0);
    let q = if i == 0 {
        // After an S-curve at the arc's start (no piece before it in this
        // motion): the least advance ([`least_advance`]).
        let most = most_advance_mm(set, length_mm);
        let at = |d_mm: f64, cells: &mut AxisCells| -> Result<Option<Vec3>, ModelError> {
            let t = set.arc.point_at(l0 + (l1 - l0) * d_mm / length_mm) + shift;
            let q = solve_fixed_in(cells, set.model, set.method, t, s_after, [false; 3], own)?;
            let q = hold_small_steps((set.quantize)(q.q_mm, own), next, s_after, set.tolerance_mm);
            Ok((along(own, q, s_after) && along(q, next, s_after)).then_some(q))
        };
        least_advance(cells, most, at)?
    } else {
        let mut found = None;
        for f in ADVANCE_SHARES {
            let t = set.arc.point_at(l0 + (l1 - l0) * f) + shift;
            let q = solve_fixed_in(cells, set.model, set.method, t, s_after, [false; 3], own)?;
            let q = (set.quantize)(q.q_mm, own);
            if along(own, q, s_after) && along(q, next, s_after) {
                found = Some(q);
                break;
            }
        }
        found
    };
    let Some(q) = q else {
        return Ok(false);
    };
    m.commands[i].0 = own;
    m.records[i].command_mm = own;
    m.commands[k].1 = Some(q);
    Ok(true)
}

/// The shares of the piece after an S-curve inside the arc tried for the
/// take-up's end along it ([`advance_after`]), from the least.
const ADVANCE_SHARES: [f64; 10] = [0.02, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.7, 0.9];

/// A block's end `q` with every axis that would step back against its side
/// `s` on the way to the next command `next` by no more than `tol_mm`
/// (the contour tolerance) put at `next` instead: the axis stands there,
/// off its target by that step at most, rather than reversing for it.
fn hold_small_steps(mut q: Vec3, next: Vec3, s: Directions, tol_mm: f64) -> Vec3 {
    for a in 0..3 {
        let back = (q[a] - next[a]) * s[a].sign();
        if back > 0.0 && back <= tol_mm {
            q[a] = next[a];
        }
    }
    q
}

/// The least advance along the arc tried first by [`least_advance`] (mm),
/// doubled up to the first piece's length, then halved between the last
/// that failed and the first that worked ([`BISECTIONS`] times).
const FIRST_ADVANCE_MM: f64 = 0.005;

/// The largest share of a piece a take-up block may end along: the
/// piece after keeps three quarters of its sweep, its fitted sagitta
/// within half of the arc's (compensate/arcs.rs `piece_center`: `(3/4)²`).
const MOST_SHARE: f64 = 0.25;

/// The farthest a take-up block may end along a piece of `length_mm`
/// (mm): the chord the block runs along departs from the arc by `d²/8R`,
/// within the contour tolerance; and the piece after it keeps most of its
/// sweep ([`MOST_SHARE`]), so its words fit the arc through its ends and
/// middle (compensate/arcs.rs `piece_center`).
fn most_advance_mm(set: &Setting<'_>, length_mm: f64) -> f64 {
    let radius_mm = set.arc.start_radius().min(set.arc.end_radius());
    (8.0 * radius_mm * set.tolerance_mm)
        .sqrt()
        .min(MOST_SHARE * length_mm)
}

/// How often [`least_advance`] halves the interval of its advance.
const BISECTIONS: usize = 6;

/// The least advance `d ≤ most_mm` (mm) along a piece at which `at(d)`
/// gives a block's end, found by doubling from [`FIRST_ADVANCE_MM`] and
/// then halving between the last that failed and the first that worked
/// ([`BISECTIONS`] times); `None` where none up to `most_mm` works.
fn least_advance(
    cells: &mut AxisCells,
    most_mm: f64,
    at: impl Fn(f64, &mut AxisCells) -> Result<Option<Vec3>, ModelError>,
) -> Result<Option<Vec3>, ModelError> {
    let (mut lo, mut hi) = (0.0, FIRST_ADVANCE_MM);
    let mut found = None;
    while hi <= most_mm {
        if let Some(q) = at(hi, cells)? {
            found = Some(q);
            break;
        }
        (lo, hi) = (hi, 2.0 * hi);
    }
    let Some(mut q) = found else {
        return Ok(None);
    };
    for _ in 0..BISECTIONS {
        let mid = 0.5 * (lo + hi);
        match at(mid, cells)? {
            Some(qm) => (hi, q) = (mid, qm),
            None => lo = mid,
        }
    }
    Ok(Some(q))
}
