//! Under G61, the take-up of an axis a line keeps still, where that
//! axis' command turns back inside the line, written as an S of two arcs
//! in the plane of the line and the axis (docs/compensation.md, "A still
//! axis' take-up inside a line: an S of two arcs").
//!
//! An axis a line does not move (a zigzag's X and Z along Y) still has its
//! command follow the map, and on a map interpolated between table points
//! that command turns back at a table point (its slope jumps from `s₁` to
//! `−s₂`). Crossing its dead band there costs the tool nothing in
//! principle: the motor moves inside the band while the table stands, and
//! the line runs on (bench/eval/least.py counts such a reversal as free).
//! Written as a take-up block it is a stop under G61 (two corners the
//! planner does not take as tangent, tp.c `tpSetupTangent`), about `v/a`
//! each: the shop map's zigzag along Y at F6000 ran 32 % longer for them.
//! A linear ramp must keep its kinks within the planner's tangency
//! tolerance and so runs over millimetres (`points::ramp_length_mm`,
//! 3.8 mm for a 7 µm band at F6000), along which the target drifts away
//! from the standing tool by tenths of a micrometre.
//!
//! An S of two arcs of one radius `R`, tangent to the pieces before and
//! after it, has no kink at all: the planner runs it at `√(a_n R)`
//! (`pmCircleActualMaxVel`, blendmath.c; `a_n = A·√(1 − 0.5²)`), so
//! `R = v²/a_n` keeps the feed, and an offset `h` (the band) needs only
//! `L = √(4Rh − h²)` of line: 0.6 mm for 7 µm at F6000 and 1,000 mm/s².
//! The tool stands in the reversing axis while the motor crosses the band
//! along the S; started `ℓ = L·s₂/(s₁ + s₂)` before the reversal, the
//! target comes back to where the tool stands at the S's end, and the
//! tool is off by at most `L·s₁s₂/(s₁ + s₂)` at the reversal (0.06 µm
//! for slopes of 0.2 µm/mm).
//!
//! The S is checked against the dead band itself (docs/design.md): along
//! it the tool is the image of the command in the new direction plus what
//! each reversing carriage still lags, fading with that carriage's own
//! travel across its band ([`super::points::switch_lags_mm`]); it is kept
//! where that stays within [`TOLERANCE_MM`] of the line, where the joins
//! are tangent for the planner, and where every axis' command runs its
//! direction's way on the S and the pieces next to it. The third axis
//! runs as a helix along the S, shared out by length.
//!
//! Where two axes reverse together (the shop map's axes share their table
//! points), each gets a leg of its own, one after the other, in either
//! order and meeting at one of a few places around the reversal
//! ([`JOINT_SHARES`]); the plan leaving the least is taken. Every plan must
//! also leave the span from the S's start to the next target no worse, in
//! the mean square, than the take-up block does, or within the 99 % goal
//! of what the machine leaves there uncompensated ([`GOAL_SHARE`]).
//!
//! Only on a line along one machine axis (the plane of the line and a
//! reversing axis must be G17, G18 or G19), one or two axes reversing, and
//! not under cutter radius compensation (a plane cannot change there). Where
//! the S's plane is not the program's, the plane is selected on a line of
//! its own before the S and the program's is selected again after it
//! (SELECT_PLANE moves nothing: emccanon.cc only records it).

use super::frame::Frame;
use super::lines::{ArcWords, SecondArc};
use super::options::PointRecord;
use super::scurve::{self, BiarcArc};
use super::State;
use crate::error::ModelError;
use crate::model::{AxisCells, Direction, Directions, ErrorModel};
use volcomp_gcode::number::NumberStyle;
use volcomp_gcode::{Plane, Vec3};

/// How far the S may leave the tool from the line (mm): that of a ramp
/// centred on the reversal (compensate/ramp_centre.rs), which the S
/// replaces where both fit.
pub(super) const TOLERANCE_MM: f64 = super::ramp_centre::TOLERANCE_MM;

/// How far the S may leave the tool from the line (mm) where an axis
/// stands across it by `stand_mm` ([`State::still_axis_s_curves`]): the
/// take-up block it replaces leaves that much too, so the S may leave it
/// and a twentieth of a micrometre more, within the run-through tolerance
/// of any G61 take-up ([`super::points::RUN_THROUGH_TOLERANCE_MM`]);
/// [`TOLERANCE_MM`] where none stands.
fn tolerance_mm(stand_mm: f64) -> f64 {
    if stand_mm > 0.0 {
        TOLERANCE_MM
            .max(stand_mm + 0.05e-3)
            .min(super::points::RUN_THROUGH_TOLERANCE_MM)
    } else {
        TOLERANCE_MM
    }
}

/// The S's radius over the least the planner runs at the feed (`v²/a_n`):
/// a margin for the helix and the rounding of the written centres.
const RADIUS_MARGIN: f64 = 1.2;

/// The share of the planner's tangency tolerance (tp.c `tpSetupTangent`,
/// [`super::PlannerLimits::tangent_tolerance`], an arc taking part) the
/// S's joins may use, measured on the commands as written (no share is
/// left for a turn still to come, as a ramp must leave one).
const JOIN_SHARE: f64 = 0.9;

/// The share of that tolerance by which the slope of the last leg's
/// third axis may differ from the piece after's: the rest of JOIN_SHARE is
/// for the leg's own turn in its plane and the rounding of the written
/// numbers.
const HELIX_SHARE: f64 = 0.75;

/// How much of what the machine leaves uncompensated an S may leave, in
/// the root mean square over its span (from its start to the next
/// target), where the take-up block it replaces leaves less: the accuracy
/// goal of G61 (docs/compensation.md, "Reversals by path-control mode":
/// 99 % of the contour's RMS removed), so every span an S touches keeps
/// the goal.
const GOAL_SHARE: f64 = 0.01;

/// Where two legs meet, as a share of the second leg's length before the
/// reversal (negative: after it, by that share of the second leg): the
/// first leg's axis is held while its target still drifts before the
/// reversal, the second's while its target drifts after it, so the
/// best place depends on the four slopes; a few are tried.
const JOINT_SHARES: [f64; 6] = [-0.5, -0.25, 0.0, 0.25, 0.5, 0.75];

/// Samples of the S checked against the dead band.
const SAMPLES: u32 = 32;

/// A piece of a line written as an S: from the command `from` to `to`,
/// its words (two arcs), and the plane the program is in where the S's
/// is another (selected again after it).
#[derive(Debug, Clone, Copy)]
pub(super) struct SPiece {
    pub(super) from: Vec3,
    pub(super) to: Vec3,
    pub(super) words: ArcWords,
    pub(super) program_plane: Option<Plane>,
}

/// What the S pass needs of the writer: the program's plane and the
/// line's number style.
#[derive(Debug, Clone, Copy)]
pub(super) struct LineContext {
    pub(super) plane: Plane,
    pub(super) style: NumberStyle,
}

/// The plane of G17/G18/G19 holding axes `m` and `a`.
pub(super) fn plane_of(m: usize, a: usize) -> Option<Plane> {
    match (m.min(a), m.max(a)) {
        (0, 1) => Some(Plane::Xy),
        (0, 2) => Some(Plane::Zx),
        (1, 2) => Some(Plane::Yz),
        _ => None,
    }
}

/// The G-code word selecting `plane`.
pub(super) fn plane_word(plane: Plane) -> &'static str {
    match plane {
        Plane::Xy => "G17",
        Plane::Zx => "G18",
        Plane::Yz => "G19",
    }
}

/// The length along the line (mm) of an S of two arcs of radius `r_mm`
/// that offsets the path by `h_mm`: `(L/2)² + (R − h/2)² = R²`.
pub(super) fn s_length_mm(h_mm: f64, r_mm: f64) -> f64 {
    (4.0 * r_mm * h_mm - h_mm * h_mm).max(0.0).sqrt()
}

/// How far before the reversal the S starts (mm), for an S of `length_mm`
/// where the command's slope is `s1` before and `s2` after (each taken
/// the way its direction runs, per mm): `L·s₂/(s₁ + s₂)`, where the target
/// at the S's end is back where it was at its start; half the S where
/// the slopes say nothing.
pub(super) fn lead_mm(length_mm: f64, s1: f64, s2: f64) -> f64 {
    let (s1, s2) = (s1.max(0.0), s2.max(0.0));
    if s1 + s2 > 0.0 {
        length_mm * s2 / (s1 + s2)
    } else {
        0.5 * length_mm
    }
}

/// Whether a command's travel `d` along an axis in state `s` keeps to
/// that axis' direction (no travel does).
fn keeps(d: f64, s: Direction) -> bool {
    Direction::of_delta(d).is_none_or(|x| x == s)
}

/// `x > 0` (false for NaN).
fn positive(x: f64) -> bool {
    x > 0.0
}

/// `x ≥ y` (false where either is NaN).
fn at_least(x: f64, y: f64) -> bool {
    x >= y
}

fn unit2(a: f64, b: f64) -> Option<[f64; 2]> {
    let n = a.hypot(b);
    (n > 0.0 && n.is_finite()).then(|| [a / n, b / n])
}

/// The command on the S at the fraction `f` of its length: the biarc's
/// point in its plane, the third axis shared out by length.
fn on_s(
    arcs: &[BiarcArc; 2],
    (from, to): (Vec3, Vec3),
    (u, v, w): (usize, usize, usize),
    f: f64,
) -> Vec3 {
    let (l1, l2) = (arcs[0].length(), arcs[1].length());
    let at = f * (l1 + l2);
    let p = if at <= l1 && l1 > 0.0 {
        (arcs[0].sampler())(at / l1)
    } else if l2 > 0.0 {
        (arcs[1].sampler())(((at - l1) / l2).clamp(0.0, 1.0))
    } else {
        arcs[1].end
    };
    let mut q = from;
    q[u] = p[0];
    q[v] = p[1];
    q[w] = from[w] + (to[w] - from[w]) * f;
    q
}

/// A reversal's switch along the S: the command it starts from and the
/// lags it leaves ([`super::points::switch_lags_mm`] there), each fading
/// with its own carriage's travel from that command in the new direction.
#[derive(Debug, Clone, Copy)]
struct Switch {
    from: Vec3,
    lags: [Vec3; 3],
}

/// The largest distance (mm) of the tool from the line through `origin`
/// along `dir` while the commands run `path(λ)` for `λ` in `[0, 1]`
/// (sampled at `samples + 1` fractions): the image of the command in the
/// state `s` plus what each of `switches` still lags (docs/design.md, the
/// dead band: an axis' lag fades with its own travel across its band;
/// one with no reversal value of its own loses it at once). Also the
/// largest lag left at the end, and the mean square distance (mm²) over
/// the samples (the ends weighted half).
fn dead_band_deviation_mm(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    (origin, dir): (Vec3, Vec3),
    (s, s_new, switches): (Directions, Directions, &[Switch]),
    path: &dyn Fn(f64) -> Vec3,
    samples: u32,
) -> Result<(f64, f64, f64), ModelError> {
    let mut worst = 0.0f64;
    let mut left_end = 0.0f64;
    let mut square = 0.0f64;
    for k in 0..=samples {
        let q = path(f64::from(k) / f64::from(samples));
        let mut tool = cells.actual_again_mm(model, q, s)?;
        let mut left_any = 0.0f64;
        for sw in switches {
            for (a, lag) in sw.lags.iter().enumerate() {
                if *lag == Vec3::ZERO {
                    continue;
                }
                let own = lag[a].abs();
                let left = if own > 0.0 {
                    let travel = (q[a] - sw.from[a]) * s_new[a].sign();
                    (1.0 - travel.max(0.0) / own).max(0.0)
                } else {
                    0.0
                };
                tool += *lag * left;
                left_any = left_any.max(left * lag.norm());
            }
        }
        let off = tool - origin;
        let across = (off - dir * off.dot(dir)).norm();
        worst = worst.max(across);
        let weight = if k == 0 || k == samples { 0.5 } else { 1.0 };
        square += weight * across * across;
        left_end = left_any;
    }
    Ok((worst, left_end, square / f64::from(samples)))
}

/// One S of a plan: its plane, the commands it runs between, its arcs and
/// its unit tangents (3-D, the helix' slope in) at both ends.
#[derive(Debug, Clone, Copy)]
struct Leg {
    plane: Plane,
    from: Vec3,
    to: Vec3,
    arcs: [BiarcArc; 2],
    t_start: Vec3,
    t_end: Vec3,
}

/// The S from `from` to `to` in `plane`, tangent to `dir_in` and `dir_out`
/// (3-D, taken in the plane) at its ends; `None` where no biarc fits or
/// its tighter arc is narrower than `r_need` (mm).
fn leg(
    plane: Plane,
    (from, to): (Vec3, Vec3),
    (dir_in, dir_out): (Vec3, Vec3),
    r_need: f64,
) -> Option<Leg> {
    let (u, v, w) = plane.axes();
    let t1 = unit2(dir_in[u], dir_in[v])?;
    let t2 = unit2(dir_out[u], dir_out[v])?;
    let arcs = scurve::widest_biarc([from[u], from[v]], t1, [to[u], to[v]], t2)?;
    if !at_least(scurve::least_radius(&arcs), r_need) {
        return None;
    }
    let total = arcs[0].length() + arcs[1].length();
    if !positive(total) {
        return None;
    }
    let slope_w = (to[w] - from[w]) / total;
    let tangent3 = |t: [f64; 2]| {
        let mut x = Vec3::ZERO;
        x[u] = t[0];
        x[v] = t[1];
        x[w] = slope_w;
        x * (1.0 / x.norm())
    };
    Some(Leg {
        plane,
        from,
        to,
        arcs,
        t_start: tangent3(t1),
        t_end: tangent3(arcs[1].end_tangent()),
    })
}

/// A plan for the take-up at one reversal: the points it writes (nominal,
/// command, state after, solver iterations and residual), the first in
/// place of the reversal's target, the S legs between them, and the
/// tool's largest distance from the line (mm).
struct Plan {
    points: Vec<PlanPoint>,
    legs: Vec<Leg>,
    bound_mm: f64,
    /// The root mean square distance over the span (mm).
    rms_mm: f64,
}

/// The line and its reversal as [`State::still_s_at`] found them.
struct At {
    start: Vec3,
    dir: Vec3,
    m: usize,
    /// The reversal's target, the command the piece before starts from,
    /// the reversal's own command, the take-up's end, and the next
    /// target's command.
    t_rev: Vec3,
    t_next: Vec3,
    q_piece: Vec3,
    q_rev: Vec3,
    tu: Vec3,
    q_next: Vec3,
    len_before: f64,
    len_after: f64,
    s_old: Directions,
    s_new: Directions,
    reversed: [bool; 3],
}

/// The command for `t` in state `s`, rounded to the output from `from`;
/// with the solver's iterations and residual.
fn solve_at(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    (options, frame): (&super::CompensateOptions, &Frame),
    (t, s, from): (Vec3, Directions, Vec3),
) -> Result<Option<(Vec3, u32, f64)>, ModelError> {
    let sol =
        super::solve::solve_fixed_in(cells, model, options.method, t, s, [false; 3], Vec3::ZERO)?;
    let limit_um = options.max_residual_um.unwrap_or(f64::INFINITY);
    Ok(
        (sol.residual_um <= limit_um && (0..3).all(|a| sol.q_mm[a].is_finite())).then(|| {
            (
                frame.quantize(sol.q_mm, from),
                sol.iterations,
                sol.residual_um,
            )
        }),
    )
}

/// The points of a plan with legs of `lengths` (see [`plan`]): the S's
/// start (in place of the reversal's target) and each leg's end, with
/// their commands and states; and how far before the reversal the S
/// starts. `None` where the legs do not fit between the targets around
/// the reversal, or a command cannot be solved.
fn plan_points(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    (options, frame): (&super::CompensateOptions, &Frame),
    at: &At,
    order: &[usize],
    (lengths, shortest, share): (&[f64], f64, f64),
) -> Result<Option<(Vec<PlanPoint>, f64)>, ModelError> {
    let lead = match (order, lengths) {
        ([a], _) => {
            let s1 = (at.q_rev[*a] - at.q_piece[*a]) * at.s_old[*a].sign() / at.len_before;
            let s2 = (at.q_next[*a] - at.tu[*a]) * at.s_new[*a].sign() / at.len_after;
            lead_mm(lengths[0], s1, s2)
        }
        (_, [l0, l1, ..]) => l0 + share * l1,
        _ => return Ok(None),
    };
    if !at_least(lead, 0.0) {
        return Ok(None);
    }
    let total: f64 = lengths.iter().sum();
    if at.len_before < lead + shortest || at.len_after < total - lead + shortest {
        return Ok(None);
    }
    let mut points = Vec::new();
    let mut state = at.s_old;
    let mut along = -lead;
    let t0 = at.t_rev + at.dir * along;
    let Some((mut q0, it0, res0)) =
        solve_at(cells, model, (options, frame), (t0, state, at.q_piece))?
    else {
        return Ok(None);
    };
    // An axis whose command turns back already inside the piece before
    // (between its table points, by hundredths of a micrometre) stands
    // from there to the S instead.
    for j in (0..3).filter(|j| *j != at.m) {
        if !keeps(q0[j] - at.q_piece[j], state[j]) {
            if (q0[j] - at.q_piece[j]).abs() > TOLERANCE_MM {
                return Ok(None);
            }
            q0[j] = at.q_piece[j];
        }
    }
    points.push((t0, q0, state, it0, res0));
    for (k, a) in order.iter().enumerate() {
        state[*a] = at.s_new[*a];
        along += lengths[k];
        let t = at.t_rev + at.dir * along;
        let from = points[k].1;
        let Some((mut q, it, res)) = solve_at(cells, model, (options, frame), (t, state, from))?
        else {
            return Ok(None);
        };
        // An axis the switch moves against its own direction stands until
        // its command catches the step up (as after a take-up block,
        // compensate/take_up_stand.rs): the tool is off by that step
        // meanwhile.
        for j in (0..3).filter(|j| *j != *a && *j != at.m) {
            if !keeps(q[j] - from[j], state[j]) {
                q[j] = from[j];
            }
        }
        points.push((t, q, state, it, res));
    }
    Ok(Some((points, lead)))
}

/// A line's targets, commands (each with its take-up) and point records.
type LineBuffers<'a> = (
    &'a mut Vec<Vec3>,
    &'a mut Vec<(Vec3, Option<Vec3>)>,
    &'a mut Vec<PointRecord>,
);

/// A point of a plan: nominal, command, state after it, solver iterations
/// and residual.
type PlanPoint = (Vec3, Vec3, Directions, u32, f64);

/// The integral of the squared distance from the line (mm³) that the
/// take-up block at `at` leaves over the span an S starting `lead_mm`
/// before the reversal takes: the piece before from there to the
/// reversal (old state), the block where the tool stands (no path), the
/// piece after it (new state, the switches' lags fading from the
/// reversal's command).
fn block_square(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    at: &At,
    lead_mm: f64,
) -> Result<f64, ModelError> {
    let lambda0 = 1.0 - lead_mm / at.len_before;
    let before = |f: f64| at.q_piece + (at.q_rev - at.q_piece) * (lambda0 + (1.0 - lambda0) * f);
    let lags =
        super::points::switch_lags_mm(cells, model, at.q_rev, at.s_old, at.s_new, at.reversed)?;
    let switch = [Switch {
        from: at.q_rev,
        lags,
    }];
    let after = |f: f64| at.tu + (at.q_next - at.tu) * f;
    let line = (at.start, at.dir);
    let (_, _, ms_before) = dead_band_deviation_mm(
        cells,
        model,
        line,
        (at.s_old, at.s_old, &[]),
        &before,
        SAMPLES,
    )?;
    let (_, _, ms_after) = dead_band_deviation_mm(
        cells,
        model,
        line,
        (at.s_new, at.s_new, &switch),
        &after,
        SAMPLES,
    )?;
    Ok(ms_before * lead_mm + ms_after * at.len_after)
}

/// The S legs for the reversing axes `order` at `at`, one after the other
/// (module documentation): one axis' S starts `ℓ` before the reversal
/// ([`lead_mm`]); of two, the first ends at the reversal and the second
/// starts there. Each leg is as long as its band needs at the radius
/// `r_mm`, or as its third axis' travel needs for its slope to stay within
/// [`HELIX_SHARE`] of the planner's tangency tolerance, whichever is
/// longer. `None` where a leg does not fit.
#[allow(clippy::too_many_arguments)]
fn plan(
    cells: &mut AxisCells,
    model: &dyn ErrorModel,
    (options, frame): (&super::CompensateOptions, &Frame),
    at: &At,
    (order, share): (&[usize], f64),
    (v_mm_s, r_need, r_mm, shortest): (f64, f64, f64, f64),
) -> Result<Option<Plan>, ModelError> {
    let mut lengths: Vec<f64> = order
        .iter()
        .map(|a| s_length_mm((at.tu[*a] - at.q_rev[*a]).abs(), r_mm))
        .collect();
    if lengths.iter().any(|l| !positive(*l)) {
        return Ok(None);
    }
    let tolerance = options.planner.tangent_tolerance(v_mm_s, true);
    let mut solved = None;
    for _ in 0..3 {
        let Some((points, lead)) = plan_points(
            cells,
            model,
            (options, frame),
            at,
            order,
            (&lengths, shortest, share),
        )?
        else {
            return Ok(None);
        };
        // A leg whose third axis travels too far for its length is
        // lengthened to the travel over the slope allowed, and the points
        // are solved again.
        let mut longer = false;
        for (k, a) in order.iter().enumerate() {
            let Some(plane) = plane_of(at.m, *a) else {
                return Ok(None);
            };
            let w = plane.axes().2;
            let need = (points[k + 1].1[w] - points[k].1[w]).abs() / (HELIX_SHARE * tolerance[w]);
            if need > lengths[k] * (1.0 + 1e-9) {
                lengths[k] = 1.05 * need;
                longer = true;
            }
        }
        solved = Some((points, lead));
        if !longer {
            break;
        }
    }
    let Some((mut points, lead)) = solved else {
        return Ok(None);
    };
    let total: f64 = lengths.iter().sum();
    let last = points.len() - 1;
    // An axis whose command would turn back on the piece after the S (its
    // target drifts its old way again, by hundredths of a micrometre over
    // millimetres) stops at the next command instead: it stands in its
    // band meanwhile, as the dead band would leave it.
    for j in (0..3).filter(|j| *j != at.m) {
        let q = &mut points[last].1;
        if !keeps(at.q_next[j] - q[j], at.s_new[j]) && (at.q_next[j] - q[j]).abs() <= TOLERANCE_MM {
            q[j] = at.q_next[j];
        }
    }
    // The last leg's third axis runs as a helix: a step the switches make
    // in it (the reversing axis' straightness across it, tenths of a
    // micrometre) would turn the path at the leg's end by more than the
    // planner takes as tangent. Its slope is kept within a share of that
    // tolerance of the piece after's, which carries the rest of the step
    // (the tool off by it meanwhile, as after a take-up block).
    if let Some(plane) = plane_of(at.m, order[order.len() - 1]) {
        let w = plane.axes().2;
        let kappa = HELIX_SHARE * options.planner.tangent_tolerance(v_mm_s, true)[w];
        let from = points[last - 1].1;
        let to = points[last].1;
        let (chord, after) = ((to - from).norm(), (at.q_next - to).norm());
        if chord > 0.0 && after > 0.0 {
            let slope_leg = (to[w] - from[w]) / chord;
            let slope_after = (at.q_next[w] - to[w]) / after;
            if (slope_leg - slope_after).abs() > kappa {
                let mut q = to;
                q[w] = from[w] + (slope_after + kappa.copysign(slope_leg - slope_after)) * chord;
                points[last].1 = frame.quantize(q, from);
            }
        }
    }
    // Every axis runs its direction's way before, on and after the S; the
    // reversing axis of each leg its new way.
    let q_first = points[0].1;
    let q_last = points[last].1;
    // (Where the solve's own piece before already ran an axis against its
    // direction, by a hold's few hundredths of a micrometre, that is no
    // concern of the S.)
    // (An axis that does not reverse here may run back by a step of the
    // written grid: the rounding of two commands a hair apart.)
    let step_mm = 1.5 * frame.mm_per_unit / super::frame::pow10(frame.decimals);
    let keeps_near =
        |j: usize, d: f64, s: Direction| keeps(d, s) || (!order.contains(&j) && d.abs() <= step_mm);
    let mut runs = (0..3).all(|j| {
        keeps_near(j, q_first[j] - at.q_piece[j], at.s_old[j])
            || !keeps(at.q_rev[j] - at.q_piece[j], at.s_old[j])
    }) && (0..3).all(|j| keeps_near(j, at.q_next[j] - q_last[j], at.s_new[j]));
    for (k, a) in order.iter().enumerate() {
        let (from, to, s) = (points[k].1, points[k + 1].1, points[k + 1].2);
        runs &= (0..3).all(|j| keeps_near(j, to[j] - from[j], s[j]))
            && Direction::of_delta(to[*a] - from[*a]) == Some(s[*a]);
    }
    if !runs {
        return Ok(None);
    }
    // The legs, tangent to the pieces around them and to the line between
    // two of them.
    // Where two legs meet, both run along one tangent: the line's, turned
    // by each leg's helix slope (its third axis' travel over its chord),
    // which is the other leg's in-plane turn there.
    let mut joint = at.dir;
    if let [_, _] = order {
        for (k, a) in order.iter().enumerate() {
            let Some(plane) = plane_of(at.m, *a) else {
                return Ok(None);
            };
            let w = plane.axes().2;
            let (from, to) = (points[k].1, points[k + 1].1);
            joint[w] = (to[w] - from[w]) / (to - from).norm();
        }
    }
    let mut legs = Vec::new();
    for (k, a) in order.iter().enumerate() {
        let Some(plane) = plane_of(at.m, *a) else {
            return Ok(None);
        };
        let (from, to) = (points[k].1, points[k + 1].1);
        let dir_in = if k == 0 { from - at.q_piece } else { joint };
        let dir_out = if k + 1 == order.len() {
            at.q_next - to
        } else {
            joint
        };
        let Some(l) = leg(plane, (from, to), (dir_in, dir_out), r_need) else {
            return Ok(None);
        };
        legs.push(l);
    }
    // Tangent joins for the planner (tp.c `tpSetupTangent`, with an arc).
    let unit = |x: Vec3| x * (1.0 / x.norm());
    let mut joins = vec![(unit(q_first - at.q_piece), legs[0].t_start)];
    for w in legs.windows(2) {
        joins.push((w[0].t_end, w[1].t_start));
    }
    joins.push((legs[legs.len() - 1].t_end, unit(at.q_next - q_last)));
    if joins.iter().any(|(t1, t2)| {
        !at_least(
            JOIN_SHARE,
            options.planner.kink_ratio(*t1, *t2, v_mm_s, true),
        )
    }) {
        return Ok(None);
    }
    // The tool under the dead band along each leg and the piece after.
    let mut switches = Vec::new();
    let mut bound = 0.0f64;
    // The integral of the squared distance over the span from the S's
    // start to the next target (mm³), against the take-up block's.
    let mut square = 0.0f64;
    let mut stand = 0.0f64;
    let mut s_before = at.s_old;
    for (k, a) in order.iter().enumerate() {
        let (from, s) = (points[k].1, points[k + 1].2);
        let mut reversed = [false; 3];
        reversed[*a] = true;
        let lags = super::points::switch_lags_mm(cells, model, from, s_before, s, reversed)?;
        switches.push(Switch { from, lags });
        let l = legs[k];
        let (u, v, w) = l.plane.axes();
        let on = |f: f64| on_s(&l.arcs, (l.from, l.to), (u, v, w), f);
        let (dev, _, ms) = dead_band_deviation_mm(
            cells,
            model,
            (at.start, at.dir),
            (s, at.s_new, &switches),
            &on,
            SAMPLES,
        )?;
        bound = bound.max(dev);
        square += ms * (l.arcs[0].length() + l.arcs[1].length());
        s_before = s;
    }
    // How far the standing axes leave the tool at the legs' ends (what a
    // take-up block would leave too).
    for p in &points {
        let image = cells.actual_again_mm(model, p.1, p.2)?;
        let off = image - p.0;
        stand = stand.max((off - at.dir * off.dot(at.dir)).norm());
    }
    let after = |f: f64| q_last + (at.q_next - q_last) * f;
    let (dev_after, _, ms) = dead_band_deviation_mm(
        cells,
        model,
        (at.start, at.dir),
        (at.s_new, at.s_new, &switches),
        &after,
        SAMPLES,
    )?;
    bound = bound.max(dev_after).max(stand);
    square += ms * (at.len_after - (total - lead));
    let square_block = block_square(cells, model, at, lead)?;
    // What the machine leaves across the path over the span uncompensated
    // (at its start, the reversal and the next target).
    let mut raw = 0.0f64;
    for (t, s) in [
        (points[0].0, at.s_old),
        (at.t_rev, at.s_old),
        (at.t_next, at.s_new),
    ] {
        let off = cells.actual_again_mm(model, t, s)? - t;
        raw += (off - at.dir * off.dot(at.dir)).norm_squared() / 3.0;
    }
    let span = lead + at.len_after;
    let rms_s = (square / span).sqrt();
    let rms_block = (square_block / span).sqrt();
    let within = rms_s <= rms_block.max(GOAL_SHARE * raw.sqrt());
    Ok((bound <= tolerance_mm(stand) && within).then_some(Plan {
        points,
        legs,
        bound_mm: bound,
        rms_mm: rms_s,
    }))
}

impl State<'_> {
    /// Under G61, on the solved line from `start` (nominal) whose commands
    /// start at `q_start`: each take-up block of an axis the line keeps
    /// still, inside the line, replaced by an S where one fits (module
    /// documentation). `targets`, `commands` and `records` are the line's
    /// own; the states, ramp offsets and take-up blocks kept for the
    /// writer follow. The S pieces go to `self.s_pieces`.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn still_axis_s_curves(
        &mut self,
        cells: &mut AxisCells,
        model: &dyn ErrorModel,
        frame: &Frame,
        ctx: &LineContext,
        (targets, commands, records): LineBuffers<'_>,
        (start, q_start): (Vec3, Vec3),
        v_mm_s: f64,
    ) -> Result<(), ModelError> {
        let options = self.walk.options;
        let n = commands.len();
        if n < 2
            || targets.len() != n
            || records.len() != n
            || self.states.len() != n
            || self.ramp_mids.len() != n
            || !(v_mm_s > 0.0 && v_mm_s.is_finite())
        {
            return Ok(());
        }
        let Some(&end) = targets.last() else {
            return Ok(());
        };
        let d = end - start;
        let length = d.norm();
        if !positive(length) {
            return Ok(());
        }
        // A line along one machine axis `m`.
        let Some(m) = (0..3).find(|k| d[*k].abs() > 0.0) else {
            return Ok(());
        };
        if (0..3).any(|k| k != m && d[k] != 0.0) {
            return Ok(());
        }
        let dir = d * (1.0 / length);
        // The planner runs an arc at no more than `√(a_n R)`: `R = v²/a_n`
        // keeps the feed (the least axis' limit, as for a blend).
        let a_n = options.planner.blend_normal_acceleration();
        let r_need = v_mm_s * v_mm_s / a_n;
        let r_mm = RADIUS_MARGIN * r_need;
        let shortest = super::points::shortest_ramp_piece_mm(options, v_mm_s);
        let mut i = 1;
        while i < commands.len() {
            let added = self.still_s_at(
                cells,
                model,
                frame,
                ctx,
                (targets, commands, records),
                (start, q_start, dir, m),
                (i, v_mm_s, r_need, r_mm, shortest),
            )?;
            i += 1 + added;
        }
        Ok(())
    }

    /// [`Self::still_axis_s_curves`] at the take-up of command `i`: how
    /// many points an S added there (0: none took it).
    #[allow(clippy::too_many_arguments)]
    fn still_s_at(
        &mut self,
        cells: &mut AxisCells,
        model: &dyn ErrorModel,
        frame: &Frame,
        ctx: &LineContext,
        (targets, commands, records): LineBuffers<'_>,
        (start, q_start, dir, m): (Vec3, Vec3, Vec3, usize),
        (i, v_mm_s, r_need, r_mm, shortest): (usize, f64, f64, f64, f64),
    ) -> Result<usize, ModelError> {
        let options = self.walk.options;
        let Some(tu) = commands[i].1 else {
            return Ok(0);
        };
        let rec = records[i];
        let reversing: Vec<usize> = (0..3).filter(|a| rec.reversed[*a]).collect();
        let (s_old, s_new) = (self.states[i - 1], self.states[i]);
        if reversing.is_empty()
            || reversing.len() > 2
            || reversing.contains(&m)
            || rec.held.iter().any(|h| *h)
            || records[i - 1].held.iter().any(|h| *h)
            // A reversal folded into the piece before (not a block at its
            // start) would fold into a shorter piece.
            || (records[i - 1].reversed.iter().any(|r| *r) && commands[i - 1].1.is_none())
            || self.ramp_mids[i] != Vec3::ZERO
            || self.ramp_mids[i - 1] != Vec3::ZERO
            || (0..3).any(|k| reversing.contains(&k) == (s_old[k] == s_new[k]))
        {
            return Ok(0);
        }
        let t_rev = targets[i - 1];
        let (t_before, q_before) = if i >= 2 {
            (targets[i - 2], commands[i - 2].0)
        } else {
            (start, q_start)
        };
        // The take-up's end: where the reversing axes go (an order of
        // blocks, compensate/take_up_order.rs, ends where the last does).
        let at = At {
            start,
            dir,
            m,
            t_rev,
            t_next: targets[i],
            q_piece: commands[i - 1].1.unwrap_or(q_before),
            q_rev: commands[i - 1].0,
            tu,
            q_next: commands[i].0,
            len_before: (t_rev - t_before).norm(),
            len_after: (targets[i] - t_rev).norm(),
            s_old,
            s_new,
            reversed: rec.reversed,
        };
        if !(at.len_before > 0.0 && at.len_after > 0.0) {
            return Ok(0);
        }
        let orders: Vec<Vec<usize>> = match reversing[..] {
            [a] => vec![vec![a]],
            [a, b] => vec![vec![a, b], vec![b, a]],
            _ => return Ok(0),
        };
        // Of two legs, where they meet is tried at a few places around the
        // reversal ([`JOINT_SHARES`]); the plan that leaves the least
        // (root mean square over the span) is taken.
        let mut best: Option<Plan> = None;
        for order in &orders {
            let shares: &[f64] = if order.len() == 1 {
                &[0.0]
            } else {
                &JOINT_SHARES
            };
            for share in shares {
                if let Some(p) = plan(
                    cells,
                    model,
                    (options, frame),
                    &at,
                    (order, *share),
                    (v_mm_s, r_need, r_mm, shortest),
                )? {
                    if best.as_ref().is_none_or(|b| p.rms_mm < b.rms_mm) {
                        best = Some(p);
                    }
                }
            }
        }
        let Some(best) = best else {
            return Ok(0);
        };
        let mut words = Vec::new();
        for l in &best.legs {
            match s_words(l.plane, &l.arcs, frame, ctx.style, (l.from, l.to)) {
                Some(w) => words.push(w),
                None => return Ok(0),
            }
        }
        // Written: the piece before ends at the S's start, the legs take the
        // take-up blocks' place.
        let (t0, q0, _, it0, res0) = best.points[0];
        targets[i - 1] = t0;
        commands[i - 1].0 = q0;
        records[i - 1].target_mm = t0;
        records[i - 1].command_mm = q0;
        records[i - 1].iterations = it0;
        records[i - 1].residual_um = res0;
        let added = best.points.len() - 1;
        for (k, (t, q, s, it, res)) in best.points.iter().skip(1).enumerate() {
            let mut reversed = [false; 3];
            for a in 0..3 {
                reversed[a] = s[a] != best.points[k].2[a];
            }
            targets.insert(i + k, *t);
            commands.insert(i + k, (*q, None));
            records.insert(
                i + k,
                PointRecord {
                    target_mm: *t,
                    command_mm: *q,
                    iterations: *it,
                    residual_um: *res,
                    reversed,
                    held: [false; 3],
                    take_up: false,
                    ..rec
                },
            );
            self.states.insert(i + k, *s);
            self.ramp_mids.insert(i + k, Vec3::ZERO);
        }
        commands[i + added].1 = None;
        records[i + added].reversed = [false; 3];
        records[i + added].take_up = false;
        let blocks_before = self.take_up_blocks.len();
        self.take_up_blocks.retain(|(k, _)| *k != i);
        let dropped = (blocks_before - self.take_up_blocks.len()) as u64;
        for (k, _) in self.take_up_blocks.iter_mut() {
            if *k >= i {
                *k += added;
            }
        }
        self.summary.points += added as u64;
        self.summary.take_ups -= 1 + dropped;
        self.summary.take_ups_folded += best.legs.len() as u64;
        self.summary.max_fold_excursion_um =
            self.summary.max_fold_excursion_um.max(best.bound_mm * 1e3);
        for (l, w) in best.legs.iter().zip(words) {
            self.s_pieces.push(SPiece {
                from: l.from,
                to: l.to,
                words: w,
                program_plane: (l.plane != ctx.plane).then_some(ctx.plane),
            });
        }
        Ok(added)
    }
}

/// The words of each piece of a line whose solve wrote S pieces
/// (`pieces`): an S's where a piece runs from its start to its end
/// (`commands` from `q_start`), a straight line's elsewhere; with the
/// program's plane to select again after each S in another plane, and how
/// many of `pieces` were found.
pub(super) fn piece_words(
    pieces: &[SPiece],
    commands: &[(Vec3, Option<Vec3>)],
    q_start: Vec3,
) -> (Vec<(ArcWords, Option<Plane>)>, usize) {
    let line = ArcWords {
        center: None,
        plane: Plane::Xy,
        clockwise: false,
        radius_style: false,
        absolute_centers: false,
        second: None,
    };
    let mut found = 0;
    let words = commands
        .iter()
        .enumerate()
        .map(|(k, (q, take_up))| {
            let from = match k {
                0 => q_start,
                _ => commands[k - 1].0,
            };
            match pieces
                .iter()
                .find(|p| k > 0 && take_up.is_none() && p.from == from && p.to == *q)
            {
                Some(p) => {
                    found += 1;
                    (p.words, p.program_plane)
                }
                None => (line, None),
            }
        })
        .collect();
    (words, found)
}

/// The words of the S `arcs` from `from` to `q` in `plane`, the third axis
/// shared out by length ([`scurve::biarc_joint`]); `None` where the arcs
/// do not read as written ([`ArcWords::readable`]).
pub(super) fn s_words(
    plane: Plane,
    arcs: &[BiarcArc; 2],
    frame: &Frame,
    style: NumberStyle,
    (from, q): (Vec3, Vec3),
) -> Option<ArcWords> {
    let (u, v, w) = plane.axes();
    let joint = frame.quantize(scurve::biarc_joint(arcs, (from, q), (u, v, w)), from);
    let center = |c: [f64; 2]| {
        let mut p = from;
        p[u] = c[0];
        p[v] = c[1];
        p
    };
    let first = ArcWords {
        center: Some(center(arcs[0].center()?)),
        plane,
        clockwise: arcs[0].radius < 0.0,
        radius_style: false,
        absolute_centers: frame.arc_absolute,
        second: None,
    };
    let second = ArcWords {
        center: Some(center(arcs[1].center()?)),
        clockwise: arcs[1].radius < 0.0,
        ..first
    };
    (first.readable(frame, style, from, joint) && second.readable(frame, style, joint, q))
        .then_some(ArcWords {
            second: Some(SecondArc {
                joint,
                center: second.center,
                clockwise: second.clockwise,
            }),
            ..first
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_s_of_radius_r_offsets_h_over_the_chord_of_two_arcs() {
        // Two arcs of radius R, each turning by φ: h = 2R(1 − cos φ),
        // L = 2R sin φ.
        let (r, phi) = (11.5f64, 0.0123f64);
        let h = 2.0 * r * (1.0 - phi.cos());
        let l = 2.0 * r * phi.sin();
        assert!((s_length_mm(h, r) - l).abs() < 1e-12);
        // 7 µm at R = 1.2 · 100²/(0.866 · 1000): about 0.62 mm.
        let r = 1.2 * 100.0f64.powi(2) / (1000.0 * 0.75f64.sqrt());
        assert!((s_length_mm(0.007, r) - 0.6224).abs() < 1e-3);
    }

    #[test]
    fn the_lead_brings_the_target_back_to_where_the_tool_stands() {
        // Slopes 0.1 and 0.3 µm/mm: the target rises 0.1·ℓ, then falls
        // 0.3·(L − ℓ); equal where ℓ = 0.75 L.
        let l = 0.8;
        let lead = lead_mm(l, 0.1, 0.3);
        assert!((0.1 * lead - 0.3 * (l - lead)).abs() < 1e-15);
        assert_eq!(lead_mm(l, 0.0, 0.0), 0.4);
        assert_eq!(lead_mm(l, -1.0, 0.0), 0.4);
    }

    #[test]
    fn planes_of_two_axes() {
        assert_eq!(plane_of(1, 0), Some(Plane::Xy));
        assert_eq!(plane_of(0, 2), Some(Plane::Zx));
        assert_eq!(plane_of(2, 1), Some(Plane::Yz));
        assert_eq!(plane_of(1, 1), None);
        assert_eq!(plane_word(Plane::Yz), "G19");
    }
}
