//! Compensated arcs written as arcs (docs/compensation.md, "Arcs as arcs").
//!
//! A G2/G3 is cut into pieces of the original arc: at the quarter points of
//! the circle (where an axis of the plane reverses, so each piece has one
//! direction state and a take-up can go between pieces), where it crosses a
//! point of the map's tables (where a linearly interpolated map bends), and
//! then by bisection while the estimated contour error of a piece exceeds
//! the contour tolerance. Each piece's end is compensated exactly by the
//! point solver; its centre is that of the circle through the compensated
//! start, the compensated middle and the compensated end, so the actual path
//! lands on the nominal arc at three points of every piece.

use super::frame::{pow10, Frame};
use super::lines::{ArcWords, SecondArc};
use super::walk::Place;
use super::{command_error, model_error, solve, State};
use crate::error::{CompensationError, ModelError};
use crate::geometry::arc_distance_mm;
use crate::model::next_state;
use crate::model::{Components, Direction, Directions, ErrorModel};
use std::f64::consts::{FRAC_PI_2, TAU};
use volcomp_gcode::number::NumberStyle;
use volcomp_gcode::{Arc, Vec3};

/// Pieces (and table crossings) generated at most for one arc: past
/// [`crate::limits::MAX_POINTS_PER_BLOCK`] the generation stops and the
/// caller refuses the block, so the work stays bounded.
const LIMIT: u64 = crate::limits::MAX_POINTS_PER_BLOCK;

/// Table points of one piece at which its departure is sampled at most
/// (bounded work on dense maps). A piece that crosses more is
/// sampled at this many of them, evenly by index: on a table that dense
/// (points closer than the shortest piece) the map is smooth at the scale
/// of a piece, and every level of bisection samples again.
const KNOTS_PER_PIECE: usize = 32;

/// The sorted knots of `knots` within `[lo, hi]` (a window
/// by binary search, so an arc looks only at the table points it can
/// cross, not at every point of a dense table).
fn window(knots: &[f64], lo: f64, hi: f64) -> &[f64] {
    let first = knots.partition_point(|k| *k < lo);
    let last = knots.partition_point(|k| *k <= hi);
    &knots[first..last.max(first)]
}

/// Centre `(u, v)` of the circle through three points of a plane, or `None`
/// when they are collinear to within 1e-12 of the squared chord.
pub(super) fn circle_through(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> Option<[f64; 2]> {
    let (bx, by) = (b[0] - a[0], b[1] - a[1]);
    let (cx, cy) = (c[0] - a[0], c[1] - a[1]);
    let (b2, c2) = (bx * bx + by * by, cx * cx + cy * cy);
    let d = 2.0 * (bx * cy - by * cx);
    if d.abs() <= 1e-12 * b2.max(c2) || !d.is_finite() {
        return None;
    }
    Some([
        a[0] + (cy * b2 - by * c2) / d,
        a[1] + (bx * c2 - cx * b2) / d,
    ])
}

/// The arc the controller runs from `start` to `end` in `arc`'s plane and
/// turning direction, about the centre of the circle through `start`, `mid`
/// and `end` (the helix axis linear from start to end, as LinuxCNC
/// interpolates it). `None` when the three points are collinear or the
/// circle does not pass `mid` between `start` and `end` in that direction.
pub(super) fn commanded_arc(nominal: &Arc, start: Vec3, mid: Vec3, end: Vec3) -> Option<Arc> {
    let (u, v, w) = nominal.plane.axes();
    let c = circle_through([start[u], start[v]], [mid[u], mid[v]], [end[u], end[v]])?;
    let mut center = start;
    center[u] = c[0];
    center[v] = c[1];
    center[w] = start[w];
    let angle = |p: Vec3| (p[v] - c[1]).atan2(p[u] - c[0]);
    let cw = nominal.clockwise();
    let sweep = volcomp_gcode::arc::sweep_angle(angle(start), angle(end), cw, 1);
    let to_mid = volcomp_gcode::arc::sweep_angle(angle(start), angle(mid), cw, 1);
    if to_mid.abs() >= sweep.abs() || !sweep.is_finite() {
        return None;
    }
    Some(Arc {
        start,
        end,
        center,
        plane: nominal.plane,
        sweep_rad: sweep,
    })
}

/// The largest change of a correction's slope per millimetre of path
/// (1/mm) that a map can make: a sagitta `Δs` over a chord `c` is such a
/// bend of `8·Δs/c²`. A correction of micrometres that changes its slope
/// by 10 µm/mm within a millimetre is ten times beyond a ripple of 2 µm
/// over 10 mm (`A·(2π/λ)²` = 0.8·10⁻³/mm).
const MAX_CORRECTION_BEND_PER_MM: f64 = 1e-2;

/// The centre to write for a compensated piece of the nominal arc `piece`
/// (commanded `start`, `mid`, `end`), or `None` to write the piece as a G1
/// chord when the piece departs from its own chord by no more than
/// `chord_tolerance_mm` (its sagitta `r(1 − cos(Δ/2))`). The centre is
/// that of the circle through the three points, unless that circle is not
/// the nominal one moved by a correction (its sagitta off by more than
/// half: the rounding of the written ends, up to 0.09 µm, then dominates
/// a sagitta of a few tenths of a µm, or the points are collinear): then
/// the nominal centre moved by the mean correction of the two ends.
///
/// With `turn_tolerance` (G61, where the planner must join the pieces
/// without a stop) the circle through the three points is also refused
/// where its sagitta differs from the nominal one by more than would turn
/// the piece's end tangents by that much (`4·Δs/c` for a chord `c`): on a
/// short piece (a ramp's, 0.2 mm) a few hundredths of a micrometre at the
/// middle (a take-up's share across the plane, the rounding of the
/// written ends) bend it by milliradians, far more than the compensation
/// itself turns the path over so short a piece. Only where the nominal
/// circle so moved stays within the chord tolerance of the three points,
/// or where the bend the three points make is one no map makes
/// ([`MAX_CORRECTION_BEND_PER_MM`]): on a long piece the compensated path
/// itself bends by more.
pub(super) fn piece_center(
    piece: &Arc,
    (start, mid, end): (Vec3, Vec3, Vec3),
    chord_tolerance_mm: f64,
    turn_tolerance: Option<f64>,
) -> Option<Vec3> {
    let sagitta = sagitta_mm(piece);
    // Under G61 a chord that turns from the arc's tangent at its ends (by
    // half the piece's sweep) by more than the turn allowed stays an arc:
    // the planner would stop at both its ends.
    let chord_turns = turn_tolerance.is_some_and(|k| 0.5 * piece.sweep_rad.abs() > k);
    if sagitta <= chord_tolerance_mm && !chord_turns {
        return None;
    }
    if let Some(cmd) = commanded_arc(piece, start, mid, end) {
        let fitted = cmd.start_radius() * (1.0 - (0.5 * cmd.sweep_rad.abs()).min(FRAC_PI_2).cos());
        let chord = (end - start).norm();
        let off = (fitted - sagitta).abs();
        let bends = turn_tolerance.is_some_and(|k| {
            4.0 * off > k * chord
                && (off <= chord_tolerance_mm
                    || 8.0 * off / (chord * chord) > MAX_CORRECTION_BEND_PER_MM)
        });
        if (fitted - sagitta).abs() <= 0.5 * sagitta && !bends {
            return Some(cmd.center);
        }
    }
    // The nominal circle moved by the mean correction of the ends: its
    // radius to the written ends differs by half the difference of their
    // corrections (µm), far inside LinuxCNC's radius tolerance.
    let (u, v, _) = piece.plane.axes();
    let shift = ((start - piece.start) + (end - piece.end)) * 0.5;
    let mut center = piece.center;
    center[u] += shift[u];
    center[v] += shift[v];
    Some(center)
}

/// The parameter of `arc` ([`Arc::point_at`]'s angle share) at the angle
/// of `p` about the centre in the arc's plane, counted from the point at
/// `l_from` (within half a turn of it): a command a few micrometres off
/// the arc, across it or along its normal axis, reads as the nominal point
/// it stands for.
pub(super) fn param_near(arc: &Arc, l_from: f64, p: Vec3) -> f64 {
    let (u, v, _) = arc.plane.axes();
    let c = arc.center;
    let a = arc.point_at(l_from);
    let (ax, ay) = (a[u] - c[u], a[v] - c[v]);
    let (px, py) = (p[u] - c[u], p[v] - c[v]);
    let turn = (ax * py - ay * px).atan2(ax * px + ay * py);
    let l = l_from + turn / arc.sweep_rad;
    if l.is_finite() {
        l
    } else {
        l_from
    }
}

/// The centre of the circle of `piece`'s start radius through the written
/// ends `from` and `to`, on the side of the chord the piece's own centre
/// lies (its helix-axis component `from`'s, as [`sub_arc`] keeps it);
/// `None` where the chord is longer than the diameter or has no length.
pub(super) fn ends_center(piece: &Arc, from: Vec3, to: Vec3) -> Option<Vec3> {
    let (u, v, w) = piece.plane.axes();
    let r = piece.start_radius();
    let (du, dv) = (to[u] - from[u], to[v] - from[v]);
    let chord = du.hypot(dv);
    let half = 0.5 * chord;
    if !(chord > 0.0 && half < r) {
        return None;
    }
    let d = (r * r - half * half).sqrt();
    let (nu, nv) = (-dv / chord, du / chord);
    let (mu, mv) = (from[u] + 0.5 * du, from[v] + 0.5 * dv);
    // The side of the nominal centre.
    let side = (piece.center[u] - mu) * nu + (piece.center[v] - mv) * nv;
    let d = if side < 0.0 { -d } else { d };
    let mut c = Vec3::ZERO;
    c[u] = mu + d * nu;
    c[v] = mv + d * nv;
    c[w] = from[w];
    Some(c)
}

/// How far an arc departs from its chord: `r(1 − cos(Δ/2))` (mm).
pub(super) fn sagitta_mm(arc: &Arc) -> f64 {
    let r = arc.start_radius().max(arc.end_radius());
    r * (1.0 - (0.5 * arc.sweep_rad.abs()).min(FRAC_PI_2).cos())
}

/// The sub-arc of `arc` between parameters `a` and `b`.
pub(super) fn sub_arc(arc: &Arc, a: f64, b: f64) -> Arc {
    let (_, _, w) = arc.plane.axes();
    let start = arc.point_at(a);
    let mut center = arc.center;
    center[w] = start[w];
    Arc {
        start,
        end: arc.point_at(b),
        center,
        plane: arc.plane,
        sweep_rad: arc.sweep_rad * (b - a),
    }
}

/// The command `q` with `q + e(q, s) = t` by fixed-point iteration (the
/// map's slope is of the order of 10⁻⁵, so a few steps reach 1e-12 mm); for
/// estimates only — written points come from the program's own solver.
fn solve_quick(model: &dyn ErrorModel, t: Vec3, s: Directions) -> Result<Vec3, ModelError> {
    let mut q = t;
    for _ in 0..6 {
        q = t - model.deviation_um(q, s, Components::All)? * 1e-3;
    }
    Ok(q)
}

/// The largest distance (mm) from the nominal arc of the actual path of the
/// piece `[a, b]` of `arc`, compensated at its ends and middle, with the
/// direction state `s` during the piece: sampled at a quarter, half and
/// three quarters of the commanded piece. Infinite when no circle fits.
#[cfg(test)]
pub(super) fn piece_departure_mm(
    arc: &Arc,
    a: f64,
    b: f64,
    model: &dyn ErrorModel,
    s: Directions,
) -> Result<f64, ModelError> {
    Ok(piece_departure_at_mm(arc, a, b, model, s, &[])?.0)
}

/// The departure along the plane's normal axis a G61 arc piece may keep,
/// as a share of the contour tolerance. The controller runs a piece's
/// normal axis linearly from end to end (a helix), while the correction
/// along it follows the map's tables across the plane and bends: its
/// departure is one-sided over the whole piece, a bump `κL²/8` at the
/// middle of a piece of length `L` (zero only at the ends), where the
/// plane's own departure, on the circle through the piece's ends and
/// middle, changes sign at the middle and grows with `L³`. So the pieces
/// are sized by the bump; at the tolerance the bump leaves
/// `√(8/15) ≈ 0.73` of it as RMS over the whole piece. Half the tolerance
/// costs `√2` as many pieces where the bump decides and nothing where it
/// does not.
pub(super) const NORMAL_DEPARTURE_SHARE: f64 = 0.5;

/// The bound on a piece's departure along the plane's normal axis
/// ([`NORMAL_DEPARTURE_SHARE`]) for the contour tolerance `tolerance_mm`
/// in path-control mode `mode`: under G61/G61.1 its share, elsewhere the
/// tolerance itself (no separate bound).
pub(super) fn normal_tolerance_mm(tolerance_mm: f64, mode: volcomp_gcode::PathMode) -> f64 {
    match mode {
        volcomp_gcode::PathMode::ExactPath | volcomp_gcode::PathMode::ExactStop => {
            NORMAL_DEPARTURE_SHARE * tolerance_mm
        }
        _ => tolerance_mm,
    }
}

/// [`piece_departure_mm`], sampled also at the parameters `extra` of `arc`
/// (inside `[a, b]`); with the one of them that departs most and its
/// departure, and the departure along the plane's normal axis at the
/// middle of the piece (where the bump of that axis' linear run peaks,
/// [`NORMAL_DEPARTURE_SHARE`]); 0 where that axis' command turns back
/// inside the piece.
#[allow(clippy::type_complexity)]
fn piece_departure_at_mm(
    arc: &Arc,
    a: f64,
    b: f64,
    model: &dyn ErrorModel,
    s: Directions,
    extra: &[f64],
) -> Result<(f64, Option<(f64, f64)>, f64), ModelError> {
    let nominal = sub_arc(arc, a, b);
    let s = next_state(s, nominal.end - nominal.start);
    let qa = solve_quick(model, nominal.start, s)?;
    let qm = solve_quick(model, nominal.point_at(0.5), s)?;
    let qb = solve_quick(model, nominal.end, s)?;
    let Some(cmd) = commanded_arc(&nominal, qa, qm, qb) else {
        return Ok((f64::INFINITY, None, f64::INFINITY));
    };
    let (_, _, w) = arc.plane.axes();
    // Where the normal axis' command turns back inside the piece the
    // bump is a reversal the controller never makes (it runs the axis
    // linearly), not an interpolation error to be cut smaller.
    let monotone = (qm[w] - qa[w]) * (qb[w] - qm[w]) > 0.0;
    let mut worst: f64 = 0.0;
    let mut normal: f64 = 0.0;
    let mut hint = 0.0;
    let mut at = |f: f64| -> Result<f64, ModelError> {
        let p = cmd.point_at(f);
        let actual = p + model.deviation_um(p, s, Components::All)? * 1e-3;
        if f == 0.5 && monotone {
            normal = (actual[w] - nominal.point_at(0.5)[w]).abs();
        }
        Ok(arc_distance_mm(actual, &nominal, &mut hint))
    };
    for f in [0.25, 0.5, 0.75] {
        worst = worst.max(at(f)?);
    }
    let mut cut: Option<(f64, f64)> = None;
    for &t in extra {
        let d = at((t - a) / (b - a))?;
        worst = worst.max(d);
        if cut.is_none_or(|(_, dc)| d > dc) {
            cut = Some((t, d));
        }
    }
    Ok((worst, cut, normal))
}

/// Parameters in `(0, 1)` (unsorted) where `arc` reaches a quarter point of
/// its circle (an axis of the plane reverses there), and those where it
/// crosses a point of the model's tables on an axis of the plane or, on a
/// helix, its axis.
fn arc_cuts(arc: &Arc, model: &dyn ErrorModel) -> (Vec<f64>, Vec<f64>) {
    let (u, v, w) = arc.plane.axes();
    let sweep = arc.sweep_rad;
    let mut cuts = Vec::new();
    if sweep == 0.0 || !sweep.is_finite() {
        return (cuts, Vec::new());
    }
    let a0 = (arc.start[v] - arc.center[v]).atan2(arc.start[u] - arc.center[u]);
    let r = 0.5 * (arc.start_radius() + arc.end_radius());
    // Every angle θ + 2πm (any m) that lies inside the sweep.
    let at_angle = |theta: f64, cuts: &mut Vec<f64>| {
        let first = ((theta - a0) / sweep).rem_euclid(TAU / sweep.abs());
        let mut t = first;
        while t < 1.0 && cuts.len() as u64 <= LIMIT {
            if t > 0.0 {
                cuts.push(t);
            }
            t += TAU / sweep.abs();
        }
    };
    for k in 0..4 {
        at_angle(f64::from(k) * FRAC_PI_2, &mut cuts);
    }
    let quarters = std::mem::take(&mut cuts);
    let both = |axis: usize, lo: f64, hi: f64| -> Vec<f64> {
        let mut k: Vec<f64> = window(model.knots_mm(axis, Direction::Forward), lo, hi).to_vec();
        k.extend_from_slice(window(model.knots_mm(axis, Direction::Reverse), lo, hi));
        k.sort_by(f64::total_cmp);
        k.dedup();
        k
    };
    for knot in both(u, arc.center[u] - r, arc.center[u] + r) {
        let c = (knot - arc.center[u]) / r;
        if c.abs() < 1.0 {
            let alpha = c.acos();
            at_angle(alpha, &mut cuts);
            at_angle(-alpha, &mut cuts);
        }
    }
    for knot in both(v, arc.center[v] - r, arc.center[v] + r) {
        let s = (knot - arc.center[v]) / r;
        if s.abs() < 1.0 {
            let beta = s.asin();
            at_angle(beta, &mut cuts);
            at_angle(std::f64::consts::PI - beta, &mut cuts);
        }
    }
    let (w0, w1) = (arc.start[w], arc.end[w]);
    if w1 != w0 {
        let (lo, hi) = (w0.min(w1), w0.max(w1));
        for knot in both(w, lo, hi) {
            if knot > lo && knot < hi && cuts.len() as u64 <= LIMIT {
                cuts.push((knot - w0) / (w1 - w0));
            }
        }
    }
    (quarters, cuts)
}

/// The end parameters of the pieces of `arc` (increasing, the last 1.0):
/// cut at quarter points and table points, then halved while a piece's
/// estimated departure ([`piece_departure_mm`]) exceeds `tolerance_mm`;
/// no piece shorter than `min_length_mm` along the arc except where a
/// quarter point needs it, so at most `length / min + 4·turns + 4` pieces.
pub(super) fn arc_pieces(
    arc: &Arc,
    model: &dyn ErrorModel,
    s: Directions,
    tolerances_mm: (f64, f64),
    min_length_mm: f64,
    worst_mm: &mut f64,
) -> Result<Vec<f64>, ModelError> {
    arc_pieces_zoned(
        arc,
        model,
        s,
        tolerances_mm,
        min_length_mm,
        ((0.0, 0.0), tolerances_mm),
        worst_mm,
    )
}

/// [`arc_pieces`] with zones at its ends (`start_mm`, `end_mm` of the arc
/// from its start and from its end) whose pieces are halved only past
/// `zone_tolerances_mm` (compensate/arc_zone.rs); where the zones leave
/// room between them, a cut at each zone's edge. Zones of 0 leave
/// [`arc_pieces`] as it is.
pub(super) fn arc_pieces_zoned(
    arc: &Arc,
    model: &dyn ErrorModel,
    s: Directions,
    (tolerance_mm, normal_mm): (f64, f64),
    min_length_mm: f64,
    ((start_mm, end_mm), zone_tolerances_mm): ((f64, f64), (f64, f64)),
    worst_mm: &mut f64,
) -> Result<Vec<f64>, ModelError> {
    let length = arc.length();
    let (mut cuts, mut knots) = arc_cuts(arc, model);
    cuts.sort_by(f64::total_cmp);
    knots.sort_by(f64::total_cmp);
    knots.dedup();
    let min_step = if length > 0.0 {
        min_length_mm / length
    } else {
        1.0
    };
    let mut kept = Vec::with_capacity(cuts.len() + 3);
    let mut last = 0.0;
    for c in cuts {
        if c - last >= min_step && 1.0 - c >= min_step {
            kept.push(c);
            last = c;
        }
    }
    let (lo, hi) = if length > 0.0 {
        (start_mm / length, 1.0 - end_mm / length)
    } else {
        (0.0, 1.0)
    };
    let whole_zone = lo >= hi;
    if !whole_zone {
        for edge in [lo, hi] {
            if edge >= min_step
                && 1.0 - edge >= min_step
                && kept.iter().all(|k: &f64| (k - edge).abs() >= min_step)
            {
                kept.push(edge);
            }
        }
        kept.sort_by(f64::total_cmp);
    }
    kept.push(1.0);
    let mut out = Vec::with_capacity(kept.len());
    let mut from = 0.0;
    for to in kept {
        let in_zone = whole_zone || to <= lo || from >= hi;
        bisect_arc(
            arc,
            from,
            to,
            model,
            s,
            if in_zone {
                zone_tolerances_mm
            } else {
                (tolerance_mm, normal_mm)
            },
            min_step,
            &knots,
            0,
            &mut out,
            worst_mm,
        )?;
        from = to;
    }
    Ok(out)
}

/// A take-up at a quarter point written as an S-curve (compensate/scurve.rs):
/// the piece that ends at target `index` runs across the quarter point,
/// where `axis` turns to `direction`; the tool stays within `deviation_mm`
/// of the path (the local model's bound).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Transition {
    pub(super) index: usize,
    pub(super) axis: usize,
    pub(super) direction: Direction,
    pub(super) deviation_mm: f64,
    /// Where the step the S-curve makes in the plane's normal axis is to
    /// be spread as a smooth step (the arc parameters of its start and
    /// end, both cuts of the pieces; [`normal_step_span`]), if anywhere.
    pub(super) spread: Option<(f64, f64)>,
    /// The S-curve is the biarc whose tighter arc is the widest of the two
    /// kinds ([`super::scurve::widest_biarc`]) or the equal-distance biarc,
    /// as its window was found (`super::scurve::Window::widest`; under
    /// G61 either, elsewhere the equal-distance one).
    pub(super) widest: bool,
}

/// The span (arc parameters) over which the step `step_mm` that an
/// S-curve from `lo` to `hi` makes in the plane's normal axis is spread
/// as a smooth step `3u² − 2u³` whose joins the planner takes as tangent,
/// on an arc of `length_mm` cut into pieces of about `piece_mm`: a smooth
/// step over `L` turns the path by at most `6|Δ|ℓ/L²` at a join between
/// pieces of `ℓ`, so it needs `L = √(6|Δ|ℓ/κ)` (`κ` the share of the
/// planner's tangency tolerance, tp.c `tpSetupTangent`), centred on the
/// S-curve; `None` where the S-curve's own length keeps the step's turn
/// within `κ` at its joins (then nothing is spread).
pub(super) fn normal_step_span(
    (lo, hi): (f64, f64),
    length_mm: f64,
    step_mm: f64,
    (piece_mm, kappa): (f64, f64),
) -> Option<(f64, f64)> {
    let s_mm = (hi - lo) * length_mm;
    if !(s_mm > 0.0 && kappa > 0.0 && piece_mm > 0.0) || step_mm.abs() <= kappa * s_mm {
        return None;
    }
    let need_mm = (6.0 * step_mm.abs() * piece_mm / kappa).sqrt();
    if need_mm <= s_mm {
        return None;
    }
    let d = 0.5 * (need_mm - s_mm) / length_mm;
    Some((lo - d, hi + d))
}

/// [`smooth_normal_turns`] on an arc's solved commands at the feed
/// `v_mm_s`, under the rule of the program's path-control mode:
///
/// * [`Smoothing::Exact`] (G61): the joins whose turn of the normal axis is
///   above the planner's tangency tolerance there
///   (`PlannerLimits::tangent_tolerance`, on an arc) are smoothed to within
///   that tolerance, each command moved by no more than a ramp's tolerance
///   ([`super::ramp_centre::TOLERANCE_MM`]) nor more than the run-through
///   tolerance leaves beside the deviation of an S-curve (`transitions`)
///   between the anchors, `√(tol² − dev²)` (the two lie across each other).
/// * [`Smoothing::Folded`] (G64 without P), a helix included: to within
///   [`super::points::RAMP_SHARE`] of the tolerance. Where an axis of the
///   plane reverses on an S-curve, its straightness in `w` switches
///   tables, and the normal command steps by that difference over the
///   S-curve's two short arcs (about 3 µm over 1.5–3 mm on bench/eval's
///   coarse map: a turn of about 1 mrad at both ends). Such a join between
///   helical pieces is no tangent for LinuxCNC 2.9 (the turn counts the
///   rise, tp.c `tpSetupTangent`), nor can it be blended by an arc (a
///   helix is not in the corner's plane, `tpCreateArcArcBlend`): the
///   planner blends it parabolically, at half the acceleration, at every
///   quarter point of a helical bore. A program in G64 without P asks for
///   speed and lets the tool leave the path at a reversal, so the step is
///   spread over the pieces around it, a command moving by no more than
///   the step it spreads ([`normal_steps_mm`]) of an S-curve between the
///   anchors, and by the run-through tolerance
///   ([`super::points::RUN_THROUGH_TOLERANCE_MM`]) where none lies between
///   them.
///
/// `slope_in` is the normal axis' slope (`dw/ds`, along the path's
/// length) of the written piece the arc starts tangent to, where known
/// ([`NormalSlopeOut`]): then the join at the arc's start counts as well,
/// and a window may start there.
///
/// Returns the largest distance a command moved and the largest distance
/// from the path it may leave there (mm; zeros where nothing moved).
pub(super) fn smooth_normal_kinks(
    (commands, states): (&mut [(Vec3, Option<Vec3>)], &[Directions]),
    (arc, pieces, q_in, slope_in): (&Arc, &[f64], Vec3, Option<f64>),
    (transitions, options, v_mm_s): (&[Transition], &super::CompensateOptions, f64),
    quantize: &dyn Fn(Vec3, Vec3) -> Vec3,
    smoothing: Smoothing,
) -> (f64, f64) {
    // Under G64 without P only the steps S-curves make are spread.
    let nothing_folded = smoothing == Smoothing::Folded && transitions.is_empty();
    if v_mm_s.is_nan() || v_mm_s <= 0.0 || nothing_folded {
        return (0.0, 0.0);
    }
    let w = arc.plane.axes().2;
    let limit = options.planner.tangent_tolerance(v_mm_s, true)[w];
    let run_through = super::points::RUN_THROUGH_TOLERANCE_MM;
    let steps = match smoothing {
        Smoothing::Exact => Vec::new(),
        Smoothing::Folded => normal_steps_mm(commands, (arc, pieces, q_in, slope_in), transitions),
    };
    let bound = |a: usize, b: usize| match smoothing {
        Smoothing::Exact => {
            let dev = deviation_between_mm(transitions, a, b);
            let beside = (run_through * run_through - dev * dev).max(0.0).sqrt();
            super::ramp_centre::TOLERANCE_MM.min(beside)
        }
        Smoothing::Folded => transitions
            .iter()
            .zip(&steps)
            .filter(|(t, _)| t.index < b && t.index + 1 > a)
            .map(|(_, s)| *s)
            .fold(run_through, f64::max),
    };
    let target = match smoothing {
        Smoothing::Exact => limit,
        Smoothing::Folded => super::points::RAMP_SHARE * limit,
    };
    let moved = smooth_normal_turns(
        (commands, states),
        (arc, pieces, q_in, slope_in),
        (limit, target),
        &bound,
        quantize,
        smoothing,
    );
    if moved > 0.0 {
        let dev = deviation_between_mm(transitions, 0, usize::MAX);
        (moved, moved.hypot(dev))
    } else {
        (0.0, 0.0)
    }
}

/// The slope over the last written piece of a motion, for an arc that
/// follows it tangent ([`smooth_normal_kinks`]' `slope_in`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct NormalSlopeOut {
    /// Where the piece ends: the next motion starts there or the slope is
    /// not its own.
    pub(super) end_mm: Vec3,
    /// For an arc, its plane's normal axis: the only axis whose slope is
    /// kept (across the plane the slope turns along the arc). `None` for a
    /// line: every axis'.
    pub(super) arc_normal: Option<usize>,
    /// The slope `dq/ds` of each axis over the piece (per length along
    /// the path).
    pub(super) slope: Vec3,
}

impl NormalSlopeOut {
    /// The slope over the last of an arc's solved `commands` (pieces
    /// ending at the arc parameters `pieces`, the first starting at
    /// `q_in`); `None` where the last piece carries a take-up block or has
    /// no length.
    pub(super) fn of(
        commands: &[(Vec3, Option<Vec3>)],
        (arc, pieces, q_in): (&Arc, &[f64], Vec3),
    ) -> Option<Self> {
        let n = commands.len().min(pieces.len());
        let (end, take_up) = *commands.get(n.checked_sub(1)?)?;
        if take_up.is_some() {
            return None;
        }
        let (t0, start) = if n >= 2 {
            (pieces[n - 2], commands[n - 2].0)
        } else {
            (0.0, q_in)
        };
        let w = arc.plane.axes().2;
        let ds = (pieces[n - 1] - t0) * arc.length();
        (ds > 0.0).then(|| {
            let mut slope = Vec3::ZERO;
            slope[w] = (end[w] - start[w]) / ds;
            Self {
                end_mm: end,
                arc_normal: Some(w),
                slope,
            }
        })
    }

    /// The slope over the last of a straight motion's solved `commands`
    /// (the first starting at `q_in`): the written piece's own direction,
    /// its length the path's to within the compensation (micrometres on
    /// millimetres). `None` where the last piece carries a take-up block
    /// or has no length.
    pub(super) fn of_line(commands: &[(Vec3, Option<Vec3>)], q_in: Vec3) -> Option<Self> {
        let n = commands.len();
        let (end, take_up) = *commands.get(n.checked_sub(1)?)?;
        if take_up.is_some() {
            return None;
        }
        let start = if n >= 2 { commands[n - 2].0 } else { q_in };
        let ds = (end - start).norm();
        (ds > 0.0).then(|| Self {
            end_mm: end,
            arc_normal: None,
            slope: (end - start) / ds,
        })
    }

    /// The slope of axis `w` the path comes in with, where this piece
    /// gives one.
    pub(super) fn along(&self, w: usize) -> Option<f64> {
        self.arc_normal
            .is_none_or(|a| a == w)
            .then_some(self.slope[w])
    }
}

/// The largest deviation (mm) of the S-curves among `transitions` that lie
/// between the anchors `a < b` (point `k` ends piece `k`; transition `t`'s
/// S-curve is the piece from point `t.index` to `t.index + 1`).
fn deviation_between_mm(transitions: &[Transition], a: usize, b: usize) -> f64 {
    transitions
        .iter()
        .filter(|t| t.index < b && t.index + 1 > a)
        .map(|t| t.deviation_mm)
        .fold(0.0f64, f64::max)
}

/// The step (mm) each S-curve among `transitions` makes in the plane's
/// normal axis `w` beyond the arc's own progress: the S-curve's piece (from
/// point `t.index` to `t.index + 1`; point 0 is `q_in`, point `k` the end
/// of piece `k`) moves along `w` by that much more than the mean slope of
/// the pieces on either side carries over its length (before the first
/// piece: the slope the path comes in with, `slope_in`, where known). 0
/// where it has no piece on either side.
fn normal_steps_mm(
    commands: &[(Vec3, Option<Vec3>)],
    (arc, pieces, q_in, slope_in): (&Arc, &[f64], Vec3, Option<f64>),
    transitions: &[Transition],
) -> Vec<f64> {
    let w = arc.plane.axes().2;
    let len = arc.length();
    let n = commands.len().min(pieces.len());
    let x = |k: usize| if k == 0 { 0.0 } else { pieces[k - 1] * len };
    let point = |k: usize| {
        if k == 0 {
            q_in[w]
        } else {
            commands[k - 1].0[w]
        }
    };
    // The slope of piece k (from point k − 1 to k), where it has a length;
    // piece 0 is the one the path comes in along.
    let slope = |k: usize| {
        if k == 0 {
            return slope_in;
        }
        if k > n {
            return None;
        }
        let dx = x(k) - x(k - 1);
        (dx > 0.0).then(|| (point(k) - point(k - 1)) / dx)
    };
    transitions
        .iter()
        .map(|t| {
            let i = t.index;
            let Some(own) = slope(i + 1) else { return 0.0 };
            let beside: Vec<f64> = [i, i + 2].into_iter().filter_map(slope).collect();
            if beside.is_empty() {
                return 0.0;
            }
            let mean = beside.iter().sum::<f64>() / beside.len() as f64;
            ((own - mean) * (x(i + 1) - x(i))).abs()
        })
        .collect()
}

/// Pieces on each side of a kink the smoothing of the normal axis may
/// reach ([`smooth_normal_turns`]).
const SMOOTH_REACH: usize = 8;

/// How [`smooth_normal_turns`] treats a helix and which of the windows that
/// bring every turn within the target it takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Smoothing {
    /// Under G61: a helix is left alone (its own progress along the normal
    /// decides the joins); the window of the fewest pieces, then of the
    /// least largest move.
    Exact,
    /// Under G64 without P: a helix too (its nominal rise is linear in the
    /// arc's length, so the slopes compared differ by the compensation's
    /// alone); the window whose moves leave the least squared error along
    /// the path (`Σ Δw²` weighted by the length each command stands for),
    /// whatever its size (on bench/eval's bores it is the window of the
    /// fewest pieces as well).
    Folded,
}

/// The turns of the plane's normal axis `w` at the joins of an arc's
/// pieces that the planner would not take as tangent, smoothed within an
/// error bound (under G61 and G64 without P: [`smooth_normal_kinks`]).
///
/// Where the normal axis' command steps by tenths of a micrometre over a
/// piece of a few tenths of a millimetre (its straightness switching
/// tables when an axis of the plane reverses, next to a ramp that takes up
/// the normal axis' own reversal), its slope turns by about 1 mrad at a
/// join, above the planner's tangency tolerance (tp.c `tpSetupTangent`:
/// `|Δt_w|·(v/T + A)/A_w / BLEND_ACC_RATIO_TANGENTIAL` against the kink
/// ratio), and the planner slows to the kink's speed, about
/// `0.05·A_w·T/|Δt_w|` (25–50 mm/s). Such a join `j` (a turn above
/// `turn_limit`) is smoothed over the fewest pieces around it, up to
/// [`SMOOTH_REACH`] on each side: the commands between two anchors `A < j
/// < B` move along `w` onto the cubic Hermite curve through the anchors
/// with the slopes of the pieces outside them (so the anchors' joins turn
/// by little), quantized by `quantize`. Taken where every turn from `A` to
/// `B` is then within `target` (below `turn_limit`, room for the
/// rounding), no piece between the anchors carries a take-up block, every
/// piece moves `w` in its direction state's way or not at all (so no
/// reversal is made or moved), and no command moves by more than
/// `bound_mm(A, B)` (commands `A`, `B` counted from the arc's start, 0).
/// Where the slope the path comes in with is known (`slope_in`, along
/// `w` per length), the join at the start is one of them and a window may
/// start there (`A = 0`, the start held, its slope that one).
/// [`Smoothing`] says whether a helix is smoothed and which window is
/// taken. Returns the largest distance moved (mm; 0 where nothing was).
#[allow(clippy::too_many_arguments)]
pub(super) fn smooth_normal_turns(
    (commands, states): (&mut [(Vec3, Option<Vec3>)], &[Directions]),
    (arc, pieces, q_in, slope_in): (&Arc, &[f64], Vec3, Option<f64>),
    (turn_limit, target): (f64, f64),
    bound_mm: &dyn Fn(usize, usize) -> f64,
    quantize: &dyn Fn(Vec3, Vec3) -> Vec3,
    smoothing: Smoothing,
) -> f64 {
    let w = arc.plane.axes().2;
    let n = commands.len().min(pieces.len()).min(states.len());
    let len = arc.length();
    let helix_left = smoothing == Smoothing::Exact && arc.start[w] != arc.end[w];
    if helix_left || n < 3 || !(len > 0.0 && target > 0.0) {
        return 0.0;
    }
    // Point k: 0 the start, k the end of piece k (commands[k − 1]).
    let x: Vec<f64> = std::iter::once(0.0)
        .chain(pieces[..n].iter().map(|p| p * len))
        .collect();
    let point = |c: &[(Vec3, Option<Vec3>)], k: usize| if k == 0 { q_in } else { c[k - 1].0 };
    // Piece k runs from point k − 1 to k; piece 0 is the one the path
    // comes in along (asked for only where `slope_in` is known).
    let slope = |c: &[(Vec3, Option<Vec3>)], k: usize| {
        if k == 0 {
            return slope_in.unwrap_or(0.0);
        }
        let dx = x[k] - x[k - 1];
        if dx > 0.0 {
            (point(c, k)[w] - point(c, k - 1)[w]) / dx
        } else {
            0.0
        }
    };
    let turn = |c: &[(Vec3, Option<Vec3>)], j: usize| (slope(c, j + 1) - slope(c, j)).abs();
    let first = if slope_in.is_some() { 0 } else { 1 };
    let mut moved: f64 = 0.0;
    for j in first..n {
        if turn(commands, j) <= turn_limit {
            continue;
        }
        // The best window: the fewest pieces that bring every turn within
        // `target` (then the least error), or under `Smoothing::Folded`
        // the least squared error of all; where none does, the one that
        // leaves the least turn, if below the worst it had.
        let mut within: Option<(f64, f64, Vec<Vec3>, usize)> = None;
        let mut least: Option<(f64, f64, Vec<Vec3>, usize)> = None;
        for total in 1..=2 * SMOOTH_REACH {
            if within.is_some() && smoothing == Smoothing::Exact {
                break;
            }
            for ma in 0..=total {
                let mb = total - ma;
                if ma > SMOOTH_REACH || mb > SMOOTH_REACH || ma + first > j || j + mb >= n {
                    continue;
                }
                let (a, b) = (j - ma, j + mb);
                if b < a + 2 || (a + 1..=b).any(|k| commands[k - 1].1.is_some()) {
                    continue;
                }
                let (wa, wb) = (point(commands, a)[w], point(commands, b)[w]);
                let (sa, sb) = (slope(commands, a), slope(commands, b + 1));
                let h = x[b] - x[a];
                let mut trial: Vec<(Vec3, Option<Vec3>)> = commands[..n].to_vec();
                let mut err: f64 = 0.0;
                let mut area: f64 = 0.0;
                for k in a + 1..b {
                    let u = (x[k] - x[a]) / h;
                    let (u2, u3) = (u * u, u * u * u);
                    let value = (2.0 * u3 - 3.0 * u2 + 1.0) * wa
                        + (u3 - 2.0 * u2 + u) * h * sa
                        + (-2.0 * u3 + 3.0 * u2) * wb
                        + (u3 - u2) * h * sb;
                    let mut q = trial[k - 1].0;
                    q[w] = value;
                    let q = quantize(q, point(&trial, k - 1));
                    let dw = q[w] - commands[k - 1].0[w];
                    err = err.max(dw.abs());
                    area += dw * dw * 0.5 * (x[k + 1] - x[k - 1]);
                    trial[k - 1].0 = q;
                }
                if err > bound_mm(a, b) {
                    continue;
                }
                let against = (a + 1..=b).any(|k| {
                    let d = point(&trial, k)[w] - point(&trial, k - 1)[w];
                    d * states[k - 1][w].sign() < 0.0
                });
                if against {
                    continue;
                }
                let worst =
                    |c: &[(Vec3, Option<Vec3>)]| (a..=b).map(|k| turn(c, k)).fold(0.0f64, f64::max);
                let (was, now) = (worst(commands), worst(&trial));
                let qs: Vec<Vec3> = trial[a..b].iter().map(|c| c.0).collect();
                if now <= target {
                    let key = match smoothing {
                        Smoothing::Exact => err,
                        Smoothing::Folded => area,
                    };
                    if within.as_ref().is_none_or(|(k, _, _, _)| key < *k) {
                        within = Some((key, err, qs, a));
                    }
                } else if now < was && least.as_ref().is_none_or(|(t, _, _, _)| now < *t) {
                    least = Some((now, err, qs, a));
                }
            }
        }
        let best = within.or(least);
        if let Some((_, err, qs, a)) = best {
            for (i, q) in qs.into_iter().enumerate() {
                commands[a + i].0 = q;
            }
            moved = moved.max(err);
        }
    }
    moved
}

/// The plane axis whose coordinate is extreme at parameter `t` of `arc`
/// (the tangent has no component along it), if `t` is a quarter point.
fn extreme_axis(arc: &Arc, t: f64) -> Option<usize> {
    let (u, v, _) = arc.plane.axes();
    let p = arc.point_at(t);
    let (du, dv) = (p[u] - arc.center[u], p[v] - arc.center[v]);
    let rad = du.hypot(dv);
    if rad == 0.0 {
        None
    } else if du.abs() <= 1e-9 * rad {
        Some(v)
    } else if dv.abs() <= 1e-9 * rad {
        Some(u)
    } else {
        None
    }
}

/// S-curve take-ups at the quarter points inside `arc` (pieces ending at
/// `pieces`): where the reversing axis has a positive reversal value
/// there and `tolerance_mm(b)` (the tolerance the rule gives for a band
/// `b`, `None`: no S-curve) asks for one, the quarter-point cut becomes the
/// two ends of the window [`scurve::best_window`] finds for the feed
/// `v_mm_s`, cuts inside it are dropped, and the piece between is the
/// transition. A window that does not fit between the neighbouring cuts
/// (kept at least `min_step` apart) is not used: the take-up is then
/// decided as any other.
#[allow(clippy::too_many_arguments)]
pub(super) fn plan_transitions(
    arc: &Arc,
    pieces: &[f64],
    model: &dyn ErrorModel,
    s_before: Directions,
    tolerance_mm: &dyn Fn(f64) -> Option<f64>,
    v_mm_s: f64,
    planner: &super::PlannerLimits,
    min_length_mm: f64,
    smooth_start: bool,
    spread: Option<(f64, f64)>,
    joins: JoinTails,
) -> Result<Planned, ModelError> {
    let length = arc.length();
    let r = 0.5 * (arc.start_radius() + arc.end_radius());
    let mut out: Vec<f64> = pieces.to_vec();
    let mut found: Vec<(f64, f64, usize, Direction, f64, f64, bool)> = Vec::new();
    let mut planned = Planned::default();
    if !(length > 0.0 && r > 0.0 && v_mm_s > 0.0) {
        planned.pieces = out;
        return Ok(planned);
    }
    let min_step = min_length_mm / length;
    // 10 µm along the arc: the axis moves by 5·10⁻⁵ µm/mm of radius there,
    // far above the rounding of the point's angle.
    let step = 0.01 / length.max(1e-9);
    let w = arc.plane.axes().2;
    // Under G61 (where the step is spread) the S-curve is the widest
    // biarc: the planner runs its tighter arc faster.
    let widest = spread.is_some();
    // The band of the quarter point at `to` where the direction state is
    // `s` and the reversing axis turns to `new`, and the tolerance the
    // rule gives it.
    let band_at = |to: f64, s: Directions, a: usize, new: Direction| -> Result<_, ModelError> {
        let p0 = arc.point_at(to);
        let mut s_old = s;
        s_old[a] = new.flipped();
        let mut s_new = s;
        s_new[a] = new;
        let e_old = model.deviation_um(p0, s_old, Components::All)?;
        let e_new = model.deviation_um(p0, s_new, Components::All)?;
        let band_mm = (e_old[a] - e_new[a]) * new.sign() * 1e-3;
        if band_mm <= 0.0 {
            return Ok(None);
        }
        Ok(tolerance_mm(band_mm).map(|tol| (band_mm, tol)))
    };
    // The window of the quarter point at `to` where the direction state
    // is `s`: the reversing axis, its new direction and the window, if the
    // rule asks for an S-curve there and one fits.
    let window_at = |to: f64, s: Directions, after_only: bool| -> Result<_, ModelError> {
        let Some(a) = extreme_axis(arc, to) else {
            return Ok(None);
        };
        let (p0, p1) = (arc.point_at(to), arc.point_at(to + step));
        let Some(new) = Direction::of_delta(p1[a] - p0[a]) else {
            return Ok(None);
        };
        if let Some((before_mm, r_before)) = joins.held_before.filter(|_| to == 0.0) {
            // The block before held back its tail for this S-curve.
            return Ok(band_at(0.0, s, a, new)?.and_then(|(band_mm, tol)| {
                super::scurve::join_window(
                    (r_before, r),
                    band_mm,
                    0.85 * tol,
                    v_mm_s,
                    planner,
                    before_mm,
                    widest,
                )
                .map(|win| (a, new, win, 0.0))
            }));
        }
        let mut s_old = s;
        s_old[a] = new.flipped();
        let mut s_new = s;
        s_new[a] = new;
        let e_old = model.deviation_um(p0, s_old, Components::All)?;
        let e_new = model.deviation_um(p0, s_new, Components::All)?;
        let band_mm = (e_old[a] - e_new[a]) * new.sign() * 1e-3;
        // The step the S-curve makes in the plane's normal axis (its
        // straightness across the plane switching tables).
        let step_w_mm = (e_old[w] - e_new[w]) * 1e-3;
        if band_mm <= 0.0 {
            return Ok(None);
        }
        let Some(tol) = tolerance_mm(band_mm) else {
            return Ok(None);
        };
        // What the local model leaves out (the map's change over the
        // window, the rounding of the written words) takes a little of the
        // tolerance.
        Ok(
            super::scurve::best_window(r, band_mm, 0.85 * tol, v_mm_s, planner, after_only, widest)
                .map(|win| (a, new, win, step_w_mm)),
        )
    };
    // A reversal at the start, where the block before ends and the
    // original runs on without a corner: the S-curve on this block alone,
    // from the join along the tangent both share (the block before is
    // written already).
    if smooth_start {
        if let Some(a) = extreme_axis(arc, 0.0) {
            let moves = Direction::of_delta(arc.point_at(step)[a] - arc.start[a]);
            if moves.is_some_and(|d| s_before[a] == d.flipped()) {
                if let Some((a, new, win, _)) = window_at(0.0, s_before, true)? {
                    found.push((
                        0.0,
                        win.after_mm / length,
                        a,
                        new,
                        win.deviation_mm,
                        0.0,
                        win.widest,
                    ));
                    // Where the window fits (below), the held tail is its
                    // start.
                    planned.absorbed = joins.held_before.is_some();
                }
            }
        }
    }
    let mut s = s_before;
    let mut from = 0.0;
    for &to in pieces {
        s = next_state(s, arc.point_at(to) - arc.point_at(from));
        from = to;
        if to >= 1.0 {
            break;
        }
        if let Some((a, new, win, step_w)) = window_at(to, s, false)? {
            let (lo, hi) = (to - win.before_mm / length, to + win.after_mm / length);
            found.push((lo, hi, a, new, win.deviation_mm, step_w, win.widest));
        }
    }
    let mut transitions = Vec::new();
    // The windows taken (their ends, for the spans below).
    let mut taken: Vec<(f64, f64, f64)> = Vec::new();
    for (lo, hi, a, new, dev, step_w, family) in found {
        if lo <= 0.0 {
            // The window from the start: its end is the first cut.
            let after = out.iter().find(|c| **c > hi).copied().unwrap_or(1.0);
            if after - hi < min_step {
                planned.absorbed = false;
                continue;
            }
            out.retain(|c| *c > hi);
            out.insert(0, hi);
            transitions.push(Transition {
                index: 0,
                axis: a,
                direction: new,
                deviation_mm: dev,
                spread: None,
                widest: family,
            });
            taken.push((0.0, hi, 0.0));
            continue;
        }
        let before = out.iter().rev().find(|c| **c < lo).copied().unwrap_or(0.0);
        let after = out.iter().find(|c| **c > hi).copied().unwrap_or(1.0);
        if lo - before < min_step || after - hi < min_step {
            continue;
        }
        out.retain(|c| *c < lo || *c > hi);
        let at = out.partition_point(|c| *c < lo);
        out.insert(at, lo);
        out.insert(at + 1, hi);
        transitions.push(Transition {
            index: at + 1,
            axis: a,
            direction: new,
            deviation_mm: dev,
            spread: None,
            widest: family,
        });
        taken.push((lo, hi, step_w));
    }
    // Under G61, the normal axis' step spread as a smooth step around each
    // S-curve: cuts about `piece_mm` apart over its span, none inside a
    // window nor nearer than `min_step` to another cut; a span that leaves
    // the block is not used.
    if let Some((piece_mm, kappa)) = spread {
        for (k, &(lo, hi, step_w)) in taken.iter().enumerate() {
            let Some((a, b)) = (lo > 0.0)
                .then(|| normal_step_span((lo, hi), length, step_w, (piece_mm, kappa)))
                .flatten()
            else {
                continue;
            };
            let clear = |x: f64| taken.iter().all(|t| x < t.0 || x > t.1);
            if a <= min_step || b >= 1.0 - min_step || !clear(a) || !clear(b) {
                continue;
            }
            let cuts_on = |from: f64, to: f64| -> Vec<f64> {
                let n = ((to - from).abs() * length / piece_mm).round().max(1.0) as usize;
                (1..=n)
                    .map(|j| from + (to - from) * j as f64 / n as f64)
                    .collect()
            };
            for c in cuts_on(lo, a).into_iter().chain(cuts_on(hi, b)) {
                let free = out.iter().all(|x| (x - c).abs() >= min_step);
                if free && clear(c) {
                    let at = out.partition_point(|x| *x < c);
                    out.insert(at, c);
                }
            }
            // The span ends at the cuts nearest its ends.
            let nearest = |e: f64| {
                out.iter()
                    .copied()
                    .filter(|x| (x - e).abs() < min_step.max(0.5 * piece_mm / length))
                    .min_by(|x, y| (x - e).abs().total_cmp(&(y - e).abs()))
            };
            if let (Some(a), Some(b)) = (nearest(a), nearest(b)) {
                transitions[k].spread = Some((a, b));
            }
        }
        for (k, t) in taken.iter().enumerate() {
            transitions[k].index = out.partition_point(|x| *x < t.1 - 1e-15);
        }
    }
    // A quarter point at the end: the block after may run on through it
    // tangentially (not known yet), the reversing axis turning there. The
    // part of the window the best S-curve takes before the point
    // ([`super::scurve::best_window`], on this arc's radius) is held back
    // (the block ends short of it), for the block after to start its
    // S-curve there, or to write it as it is.
    if joins.hold_end {
        if let Some(a) = extreme_axis(arc, 1.0) {
            let moves = Direction::of_delta(arc.end[a] - arc.point_at(1.0 - step)[a]);
            let window = match moves {
                Some(d) => band_at(1.0, s, a, d.flipped())?.and_then(|(band_mm, tol)| {
                    super::scurve::best_window(
                        r,
                        band_mm,
                        0.85 * tol,
                        v_mm_s,
                        planner,
                        false,
                        widest,
                    )
                }),
                None => None,
            };
            // The held tail lies beyond every cut of a take-up window or
            // of a spread step, at least `min_step` from the last cut kept.
            let busy = transitions
                .iter()
                .map(|t| {
                    let hi = out.get(t.index).copied().unwrap_or(1.0);
                    t.spread.map_or(hi, |(_, b)| b.max(hi))
                })
                .fold(0.0, f64::max);
            if let Some(win) = window.filter(|w| w.before_mm > 0.0) {
                let lo = 1.0 - win.before_mm / length;
                if lo - busy >= min_step {
                    let prev = out.iter().copied().filter(|c| *c < lo).fold(0.0, f64::max);
                    if lo - prev >= min_step {
                        out.retain(|c| *c < lo);
                        out.push(lo);
                        planned.held_end = Some(HeldEnd {
                            at: lo,
                            axis: a,
                            before_mm: win.before_mm,
                            radius_mm: r,
                        });
                    }
                }
            }
        }
    }
    planned.pieces = out;
    planned.transitions = transitions;
    Ok(planned)
}

/// The tail a line from `start` to `end` in `plane` (the plane in effect:
/// an arc that follows runs in it) holds back under G61 for an S-curve
/// across its end ([`HeldEnd`], parameter along the line): an arc that
/// runs on from it tangentially turns an axis of the plane the line does
/// not move (the line's tangent has no component along it), to the
/// direction opposite its state `s`; a line that leaves the plane has no
/// such arc after it. On the line the nominal path stays flat, so
/// while that axis crosses its band `b` (the map's, at the end) the tool
/// stays on the path, and an S-curve of two arcs of radius `ρ` over a
/// length `w` drops by `b` where `w²/(4ρ) = b`: with `w = 2·v·√(b/a_n)`
/// its arcs have `ρ = v²/a_n`, which LinuxCNC runs at the feed `v`
/// (`pmCircleActualMaxVel`, blendmath.c, `a_n = √0.75·A`). The largest
/// such `w` over the axes the line does not move, if a band is positive
/// and the line is at least twice as long (plus `min_length_mm`).
pub(super) fn line_tail(
    (start, end): (Vec3, Vec3),
    plane: volcomp_gcode::Plane,
    model: &dyn ErrorModel,
    s: Directions,
    v_mm_s: f64,
    planner: &super::PlannerLimits,
    min_length_mm: f64,
) -> Result<Option<HeldEnd>, ModelError> {
    let d = end - start;
    let length = d.norm();
    let (u, v, w) = plane.axes();
    if !(length > 0.0 && v_mm_s > 0.0) || d[w].abs() > 1e-12 * length {
        return Ok(None);
    }
    let a_min = planner
        .max_acceleration_mm_s2
        .iter()
        .fold(f64::INFINITY, |m, x| m.min(*x));
    let a_n = a_min * 0.75f64.sqrt();
    let e_now = model.deviation_um(end, s, Components::All)?;
    let mut best: Option<HeldEnd> = None;
    for a in [u, v] {
        if d[a].abs() > 1e-12 * length {
            continue;
        }
        let new = s[a].flipped();
        let mut s_new = s;
        s_new[a] = new;
        let e_new = model.deviation_um(end, s_new, Components::All)?;
        let band_mm = (e_now[a] - e_new[a]) * new.sign() * 1e-3;
        if band_mm <= 0.0 {
            continue;
        }
        let w = 2.0 * v_mm_s * (band_mm / a_n).sqrt();
        if 2.0 * w + min_length_mm > length || best.is_some_and(|b| b.before_mm >= w) {
            continue;
        }
        best = Some(HeldEnd {
            at: 1.0 - w / length,
            axis: a,
            before_mm: w,
            radius_mm: f64::INFINITY,
        });
    }
    Ok(best)
}

/// What a block join lends or borrows ([`plan_transitions`]).
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct JoinTails {
    /// The tail the block before held back for an S-curve at this arc's
    /// start: its length (mm) and the block before's radius (mm).
    pub(super) held_before: Option<(f64, f64)>,
    /// Whether this arc may hold back its own tail ([`HeldEnd`]).
    pub(super) hold_end: bool,
}

/// The tail of an arc held back for an S-curve across its end: the
/// block's written part ends at parameter `at`; the reversing axis;
/// the window's length before the join (mm) and the arc's radius (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct HeldEnd {
    pub(super) at: f64,
    pub(super) axis: usize,
    pub(super) before_mm: f64,
    pub(super) radius_mm: f64,
}

/// The pieces and S-curves [`plan_transitions`] plans: the end parameters
/// of the pieces, the transitions, whether the tail the block before held
/// back starts the first S-curve, and the tail this arc holds back.
#[derive(Debug, Default)]
pub(super) struct Planned {
    pub(super) pieces: Vec<f64>,
    pub(super) transitions: Vec<Transition>,
    pub(super) absorbed: bool,
    pub(super) held_end: Option<HeldEnd>,
}

/// An S-curve across a block join cut where it crosses the normal through
/// the join ([`split_at_normal`]): the words from its start to `at`
/// (traced to the block before), the point `at`, and the words from `at`
/// to its end (traced to the block after).
#[derive(Debug, Clone, Copy)]
pub(super) struct JoinSplit {
    pub(super) before: ArcWords,
    pub(super) at: Vec3,
    pub(super) after: ArcWords,
}

/// Cuts the piece written with `words` from `a` to `b` (one arc, or two
/// where it is an S-curve: `words.second`) where it crosses the line of
/// the plane through `q_join` normal to the unit tangent `t_join` (the
/// plane's axes), the helix axis shared in proportion to the length as
/// [`State::arc_piece_words`] shares it. Each part keeps its arc's centre,
/// so the path and its tangent are unchanged; the cut is put on the
/// written grid of `frame`, and a part whose words LinuxCNC would not read
/// as that arc ([`ArcWords::readable`]) is written as its chord. `None`
/// where the piece does not cross from behind the normal to beyond it, or
/// a part would be shorter than two written steps.
pub(super) fn split_at_normal(
    words: &ArcWords,
    (a, b): (Vec3, Vec3),
    (q_join, t_join): (Vec3, [f64; 2]),
    frame: &Frame,
    style: NumberStyle,
) -> Option<JoinSplit> {
    let min_mm = 2.0 * frame.mm_per_unit / pow10(style.decimals);
    let (u, v, w) = words.plane.axes();
    let ahead = |p: Vec3| (p[u] - q_join[u]) * t_join[0] + (p[v] - q_join[v]) * t_join[1];
    let first = ArcWords {
        second: None,
        ..*words
    };
    // The arcs of the piece: (start, end, words).
    let mut arcs = vec![(a, b, first)];
    if let Some(s) = words.second {
        arcs[0].1 = s.joint;
        arcs.push((
            s.joint,
            b,
            ArcWords {
                center: s.center,
                clockwise: s.clockwise,
                ..first
            },
        ));
    }
    if !(ahead(a) < 0.0 && ahead(b) > 0.0) {
        return None;
    }
    let k = arcs.iter().position(|(_, e, _)| ahead(*e) >= 0.0)?;
    let (s, e, aw) = arcs[k];
    let point = arc_point(&aw, s, e);
    // Bisection on the arc's parameter: `ahead` grows along it (the piece
    // runs along the tangent within the S-curve's turn).
    let (mut lo, mut hi) = (0.0, 1.0);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if ahead(point(mid)) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let mut at = point(hi);
    at[w] = s[w] + (e[w] - s[w]) * hi;
    let at = frame.quantize(at, s);
    let far = |p: Vec3, q: Vec3| (q[u] - p[u]).hypot(q[v] - p[v]) >= min_mm;
    if !(far(s, at) && far(at, e)) {
        return None;
    }
    // The arc cut in two: each part read as that arc, or its chord.
    let (mut head, mut rest) = (aw, aw);
    if !head.readable(frame, style, s, at) {
        head.center = None;
    }
    if !rest.readable(frame, style, at, e) {
        rest.center = None;
    }
    let (before, after) = match words.second {
        Some(second) if k == 0 => (
            head,
            ArcWords {
                second: Some(second),
                ..rest
            },
        ),
        Some(second) => (
            ArcWords {
                second: Some(SecondArc {
                    center: head.center,
                    ..second
                }),
                ..*words
            },
            rest,
        ),
        None => (head, rest),
    };
    Some(JoinSplit { before, at, after })
}

/// The point at parameter `l` (0…1) of the arc written with `words` from
/// `s` to `e` in its plane (the radius taken linearly from the start's to
/// the end's, as rounded ends leave them), or of the chord where it has no
/// centre; the other axis as at `s`.
fn arc_point(words: &ArcWords, s: Vec3, e: Vec3) -> impl Fn(f64) -> Vec3 {
    let (u, v, _) = words.plane.axes();
    let clockwise = words.clockwise;
    let center = words.center;
    move |l: f64| match center {
        None => s + (e - s) * l,
        Some(c) => {
            let (rs, re) = (
                (s[u] - c[u]).hypot(s[v] - c[v]),
                (e[u] - c[u]).hypot(e[v] - c[v]),
            );
            let (ts, te) = (
                (s[v] - c[v]).atan2(s[u] - c[u]),
                (e[v] - c[v]).atan2(e[u] - c[u]),
            );
            let sweep = if clockwise {
                -(ts - te).rem_euclid(TAU)
            } else {
                (te - ts).rem_euclid(TAU)
            };
            let (r, t) = (rs + (re - rs) * l, ts + sweep * l);
            let mut p = s;
            p[u] = c[u] + r * t.cos();
            p[v] = c[v] + r * t.sin();
            p
        }
    }
}

/// Splits the piece `[a, b]` of `arc` while its estimated departure — at
/// ¼, ½, ¾ and at the table points it crosses (`knots`, sorted) — exceeds
/// `tol`: at the table point that departs most when that one is past the
/// tolerance (a kink of the map), else in the middle; never into pieces
/// shorter than `min_step` (of the parameter).
#[allow(clippy::too_many_arguments)]
fn bisect_arc(
    arc: &Arc,
    a: f64,
    b: f64,
    model: &dyn ErrorModel,
    s: Directions,
    (tol, normal_tol): (f64, f64),
    min_step: f64,
    knots: &[f64],
    depth: u32,
    out: &mut Vec<f64>,
    worst_mm: &mut f64,
) -> Result<(), ModelError> {
    let lo = knots.partition_point(|k| *k < a + min_step);
    let hi = knots.partition_point(|k| *k <= b - min_step);
    let inside = &knots[lo..hi.max(lo)];
    let sampled: Vec<f64>;
    let inside = if inside.len() > KNOTS_PER_PIECE {
        sampled = (0..KNOTS_PER_PIECE)
            .map(|k| inside[k * inside.len() / KNOTS_PER_PIECE])
            .collect();
        &sampled
    } else {
        inside
    };
    let (d, cut, d_normal) = piece_departure_at_mm(arc, a, b, model, s, inside)?;
    if b - a > 2.0 * min_step
        && depth < 64
        && (d > tol || d_normal > normal_tol)
        && (out.len() as u64) <= LIMIT
    {
        let m = match cut {
            Some((t, dc)) if dc > tol => t,
            _ => 0.5 * (a + b),
        };
        bisect_arc(
            arc,
            a,
            m,
            model,
            s,
            (tol, normal_tol),
            min_step,
            knots,
            depth + 1,
            out,
            worst_mm,
        )?;
        return bisect_arc(
            arc,
            m,
            b,
            model,
            s,
            (tol, normal_tol),
            min_step,
            knots,
            depth + 1,
            out,
            worst_mm,
        );
    }
    // A piece with no fitting circle is written as its chord.
    *worst_mm = worst_mm.max(if d.is_finite() {
        d
    } else {
        sagitta_mm(&sub_arc(arc, a, b))
    });
    out.push(b);
    Ok(())
}

/// Where a ramp around a reversal in an arc starts
/// ([`centred_start_on_arc`]): the target solved again from, the point
/// inserted before it with its arc parameter, and the ramp's length (mm).
pub(super) type ArcRampStart = (usize, Option<(Vec3, f64)>, f64);

/// Where a take-up ramp of `length_mm` around a reversal inside an arc
/// begins: the reversal at the start of target `index`'s piece, the
/// targets at the arc parameters `pieces` (the motion from parameter 0),
/// the ramp starting `lead_mm` before the reversal along the arc. As on a
/// line (compensate/ramp_centre.rs `centred_start`): moved to the nearer
/// end of its piece where that is closer than `shortest_mm`, and to the
/// arc's start where the arc is shorter before the reversal; `None` where
/// the ramp would begin less than `shortest_mm` before the reversal. The
/// target solved again from, the point inserted before it with its arc
/// parameter (`None`: the ramp starts at a piece's start), and the
/// ramp's length to its end `length_mm − lead_mm` after the reversal.
pub(super) fn centred_start_on_arc(
    arc: &Arc,
    pieces: &[f64],
    index: usize,
    (lead_mm, length_mm): (f64, f64),
    shortest_mm: f64,
) -> Option<ArcRampStart> {
    let len = arc.length();
    if index == 0
        || index >= pieces.len()
        || !(length_mm > 0.0 && length_mm.is_finite() && len > 0.0)
        || !(0.0..=length_mm).contains(&lead_mm)
    {
        return None;
    }
    // The arc's length is linear in its parameter (a helix too).
    let along = |j: usize| pieces[j] * len;
    let s0 = along(index - 1);
    let s_start = (s0 - lead_mm).max(0.0);
    let p = (0..index).find(|j| along(*j) > s_start + 1e-9)?;
    let piece_start = if p == 0 { 0.0 } else { along(p - 1) };
    let (from, insert, s_ramp) = if s_start - piece_start < shortest_mm {
        (p, None, piece_start)
    } else if along(p) - s_start < shortest_mm {
        (p + 1, None, along(p))
    } else {
        let l = s_start / len;
        (p, Some((arc.point_at(l), l)), s_start)
    };
    if s0 - s_ramp < shortest_mm || from >= index {
        return None;
    }
    let after_mm = length_mm - lead_mm;
    Some((from, insert, (s0 + after_mm - s_ramp).max(length_mm)))
}

/// The share of a ramp of length `L` to put before a reversal where the
/// target of the reversing axis drifts at `s1_um_mm` on its old way
/// before it and at `s2_um_mm` on its new way after it (both ≥ 0): the
/// tool, held at the level of the ramp's start while the motor crosses
/// its band, is off by `s₁·a` at the reversal (`a` before it) and by
/// `|s₂(L − a) − s₁a|` at the ramp's end; the larger of the two is least,
/// `s₁s₂L/(2s₁ + s₂)`, at `a = s₂L/(2s₁ + s₂)`. A half where both are 0
/// (or not finite).
pub(super) fn ramp_lead_share(s1_um_mm: f64, s2_um_mm: f64) -> f64 {
    let d = 2.0 * s1_um_mm + s2_um_mm;
    if s1_um_mm >= 0.0 && s2_um_mm >= 0.0 && d > 0.0 && d.is_finite() {
        s2_um_mm / d
    } else {
        0.5
    }
}

/// An arc written as pieces of itself: the end parameters of the pieces
/// ([`arc_pieces`]), and whether the program gives radii (R) rather than
/// centres.
pub(super) struct Piecewise<'a> {
    pub(super) arc: &'a Arc,
    pub(super) pieces: &'a [f64],
    pub(super) radius_style: bool,
    /// Under G61, how far a piece's end tangents may turn from the
    /// nominal arc's ([`piece_center`]): half the planner's tangency
    /// tolerance in the plane at the feed; `None` elsewhere.
    pub(super) turn_tolerance: Option<f64>,
    /// Under G64 and G64 P, how far a chord written for a piece may turn
    /// from the arc's tangents before the piece stays an arc
    /// (compensate/planar.rs, `chord_turn_center`); `None` elsewhere.
    pub(super) chord_turn_tolerance: Option<f64>,
    /// The unit tangent (in the plane's axes) the path leaves the start
    /// along where it is not the arc's own: the end of the tail the block
    /// before held back for an S-curve across the join ([`HeldEnd`]).
    pub(super) start_tangent: Option<[f64; 2]>,
}

/// The unit tangent of `arc` at parameter `t`, in its plane's axes (the
/// radial direction turned a quarter turn the way the arc runs).
pub(super) fn plane_tangent(arc: &Arc, t: f64) -> [f64; 2] {
    let (u, v, _) = arc.plane.axes();
    let p = arc.point_at(t);
    let (du, dv) = (p[u] - arc.center[u], p[v] - arc.center[v]);
    let n = du.hypot(dv);
    if arc.clockwise() {
        [dv / n, -du / n]
    } else {
        [-dv / n, du / n]
    }
}

impl State<'_> {
    /// The end parameters of the pieces of `arc` ([`arc_pieces`]) from the
    /// current direction state, with the options' contour tolerance and
    /// shortest piece; refused past [`crate::limits::MAX_POINTS_PER_BLOCK`].
    /// Raises the estimate of the contour error left.
    pub(super) fn pieces_of_arc(
        &mut self,
        arc: &Arc,
        model: &dyn ErrorModel,
        line: u64,
        run: &super::points::Run,
        joins: JoinTails,
    ) -> Result<Planned, CompensationError> {
        let (options, file) = (self.walk.options, self.walk.file);
        let (tolerance_mm, min_length_mm) = options.arc_tolerances_mm(run.mode);
        let tolerances_mm = (tolerance_mm, normal_tolerance_mm(tolerance_mm, run.mode));
        // Under G64 without P, the pieces at a corner's blend are split
        // only past a looser tolerance (compensate/arc_zone.rs).
        let pieces = arc_pieces_zoned(
            arc,
            model,
            self.s,
            tolerances_mm,
            min_length_mm,
            super::arc_zone::zones(
                options.take_up_rule(run.mode),
                run,
                self.arc_starts_planar,
                tolerances_mm,
            ),
            &mut self.estimate_mm,
        )
        .map_err(|source| model_error(file, line, source))?;
        crate::limits::check_points(pieces.len() as f64).map_err(|message| {
            CompensationError::AtLine {
                file: file.into(),
                line,
                message,
                help: crate::error::help::TOO_MANY_POINTS.into(),
            }
        })?;
        // Quarter points where the rule asks for a take-up the planner runs
        // through: S-curves ([`plan_transitions`]); the next solve takes
        // them.
        self.transitions.clear();
        if !(options.take_up
            && options.fold_take_ups
            && options.directions == super::DirectionPolicy::Commanded)
        {
            return Ok(Planned {
                pieces,
                ..Planned::default()
            });
        }
        let rule = options.take_up_rule(run.mode);
        let contour = options.fold_tolerance_mm();
        // G64 without P lets the tool leave the path by the reversal
        // value at a reversal (the fold's bound): an S-curve within it
        // runs at the feed where a fold into one short piece makes a
        // corner the planner blends.
        let tolerance = |band_mm: f64| match rule {
            super::TakeUpRule::Exact { smooth: true } => {
                Some(super::points::RUN_THROUGH_TOLERANCE_MM.max(contour))
            }
            super::TakeUpRule::Within(t) => Some(t.min(band_mm)),
            super::TakeUpRule::Always => Some(band_mm),
            super::TakeUpRule::Exact { smooth: false } => None,
        };
        // Under G61 the step an S-curve makes in the plane's normal axis
        // is spread as a smooth step over pieces the planner runs at the
        // feed, within the share of its tangency tolerance a ramp may use.
        let v_mm_s = run.feed_mm_min.unwrap_or(0.0) / 60.0;
        let spread = (matches!(rule, super::TakeUpRule::Exact { smooth: true }) && v_mm_s > 0.0)
            .then(|| {
                let w = arc.plane.axes().2;
                (
                    super::points::shortest_ramp_piece_mm(options, v_mm_s),
                    super::points::RAMP_SHARE * options.planner.tangent_tolerance(v_mm_s, true)[w],
                )
            });
        // Tails are held back and taken across a block join under G61 only
        // (where the normal step is spread).
        let joins = if spread.is_some() {
            joins
        } else {
            JoinTails::default()
        };
        let mut planned = plan_transitions(
            arc,
            &pieces,
            model,
            self.s,
            &tolerance,
            run.feed_mm_min.unwrap_or(0.0) / 60.0,
            &options.planner,
            min_length_mm,
            !run.corner_before,
            spread,
            joins,
        )
        .map_err(|source| model_error(file, line, source))?;
        self.transitions = std::mem::take(&mut planned.transitions);
        Ok(planned)
    }

    /// How each solved piece of an arc is written (module documentation):
    /// `commands` are the solved ends of the pieces of `p` (each with the
    /// take-up written before it), the first starting at `from`; the
    /// direction state of each is that of the last [`State::solve_targets`];
    /// `at` gives the frame and style the words are checked in and the line
    /// errors are reported at. A piece
    /// is written as a G1 to its compensated end (no centre) when its
    /// sagitta is within the chord tolerance ([`piece_center`]), or when
    /// the controller would not read the written words as that piece
    /// ([`ArcWords::readable`]: a zero radius, start and end radii that
    /// LinuxCNC refuses as different, a chord shorter than two steps of the
    /// written resolution, or rounded ends that turn the piece into (nearly)
    /// a full circle). The chord error of such a line is the piece's
    /// sagitta: within the chord tolerance in the first case; in the
    /// second it is added to the estimate of the contour error left (for a
    /// chord of two steps, 0.2 µm in mm, on LinuxCNC's smallest radius
    /// 1.27 µm it is at most `c²/(8r)` ≈ 0.004 µm).
    pub(super) fn arc_piece_words(
        &mut self,
        model: &dyn ErrorModel,
        at: &Place,
        p: Piecewise,
        commands: &[(Vec3, Option<Vec3>)],
        from: Vec3,
    ) -> Result<Vec<ArcWords>, CompensationError> {
        let (options, file) = (self.walk.options, self.walk.file);
        let (frame, style, line) = (at.frame, at.style, at.line);
        let Piecewise {
            arc,
            pieces,
            radius_style,
            turn_tolerance,
            chord_turn_tolerance,
            start_tangent,
        } = p;
        let start0 = from;
        let (mut from, mut l_from) = (from, 0.0);
        let mut words = Vec::with_capacity(commands.len());
        for (i, (q, take_up)) in commands.iter().enumerate() {
            let start = take_up.unwrap_or(from);
            // A take-up block may end a little along the piece (a chord
            // of the arc, compensate/take_up_before.rs): the piece runs
            // from there.
            // (`max`/`min` rather than `clamp`, which panics on an empty
            // interval.)
            let l_start = take_up.map_or(l_from, |tu| {
                param_near(arc, l_from, tu).min(pieces[i]).max(l_from)
            });
            let piece = sub_arc(arc, l_start, pieces[i]);
            let t_mid = piece.point_at(0.5);
            let q_mid = solve::solve_fixed(
                model,
                options.method,
                t_mid,
                self.states[i],
                [false; 3],
                Vec3::ZERO,
            )
            .map_err(|source| command_error(model, file, line, t_mid, source))?
            .q_mm
                + self.ramp_mids.get(i).copied().unwrap_or(Vec3::ZERO);
            let mut w = ArcWords {
                center: piece_center(
                    &piece,
                    (start, q_mid, *q),
                    options.chord_tolerance_mm,
                    turn_tolerance,
                )
                .or_else(|| {
                    super::planar::chord_turn_center(
                        &piece,
                        (start, q_mid, *q),
                        chord_turn_tolerance,
                    )
                }),
                plane: arc.plane,
                clockwise: arc.clockwise(),
                radius_style,
                absolute_centers: frame.arc_absolute,
                second: None,
            };
            if w.center.is_some() && !w.readable(frame, style, start, *q) {
                // The circle of the piece's radius through its written
                // ends, where LinuxCNC reads it, before a chord.
                w.center = ends_center(&piece, start, *q);
                match w.center {
                    Some(c) if w.readable(frame, style, start, *q) => {
                        let (u, v, _) = arc.plane.axes();
                        let off = (q_mid[u] - c[u]).hypot(q_mid[v] - c[v]) - piece.start_radius();
                        self.estimate_mm = self.estimate_mm.max(off.abs());
                    }
                    _ => {
                        w.center = None;
                        self.estimate_mm = self.estimate_mm.max(sagitta_mm(&piece));
                    }
                }
            }
            words.push(w);
            from = *q;
            l_from = pieces[i];
        }
        let transitions = std::mem::take(&mut self.transitions_written);
        for t in transitions {
            let i = t.index;
            if i + 1 >= words.len() {
                continue;
            }
            let start_of = |k: usize| -> Vec3 {
                commands[k]
                    .1
                    .unwrap_or(if k == 0 { start0 } else { commands[k - 1].0 })
            };
            let (u, v, w) = arc.plane.axes();
            let p2 = |p: Vec3| [p[u], p[v]];
            let tangent = |words: &ArcWords, from: Vec3, to: Vec3, at_end: bool| -> [f64; 2] {
                let at = if at_end { to } else { from };
                match words.center {
                    Some(c) => {
                        let (du, dv) = (at[u] - c[u], at[v] - c[v]);
                        let n = du.hypot(dv);
                        let t = [-dv / n, du / n];
                        if words.clockwise {
                            [-t[0], -t[1]]
                        } else {
                            t
                        }
                    }
                    None => {
                        let (du, dv) = (to[u] - from[u], to[v] - from[v]);
                        let n = du.hypot(dv);
                        [du / n, dv / n]
                    }
                }
            };
            let (s_next, e_next) = (start_of(i + 1), commands[i + 1].0);
            let t1 = if i == 0 {
                // The block before ends along the arc's own start tangent
                // (the join is tangent in the original; the compensation
                // turns it by the map's slope, micro-radians), or, where it
                // held back its tail, along its own tangent there.
                start_tangent.unwrap_or_else(|| plane_tangent(arc, 0.0))
            } else {
                let (s_prev, e_prev) = (start_of(i - 1), commands[i - 1].0);
                tangent(&words[i - 1], s_prev, e_prev, true)
            };
            let t2 = tangent(&words[i + 1], s_next, e_next, false);
            let (a, b) = (start_of(i), commands[i].0);
            let s_curve = if t.widest {
                super::scurve::widest_biarc
            } else {
                super::scurve::biarc
            };
            let Some([arc1, arc2]) = s_curve(p2(a), t1, p2(b), t2) else {
                continue;
            };
            let joint = frame.quantize(
                super::scurve::biarc_joint(&[arc1, arc2], (a, b), (u, v, w)),
                a,
            );
            let center = |arc: &super::scurve::BiarcArc, at_w: f64| {
                arc.center().map(|c| {
                    let mut p = a;
                    p[u] = c[0];
                    p[v] = c[1];
                    p[w] = at_w;
                    p
                })
            };
            let mut first = ArcWords {
                center: center(&arc1, a[w]),
                clockwise: arc1.radius < 0.0,
                second: None,
                ..words[i]
            };
            let mut second = ArcWords {
                center: center(&arc2, joint[w]),
                clockwise: arc2.radius < 0.0,
                second: None,
                ..words[i]
            };
            if first.center.is_some() && !first.readable(frame, style, a, joint) {
                first.center = None;
            }
            if second.center.is_some() && !second.readable(frame, style, joint, b) {
                second.center = None;
            }
            words[i] = ArcWords {
                second: Some(super::lines::SecondArc {
                    joint,
                    center: second.center,
                    clockwise: second.clockwise,
                }),
                ..first
            };
        }
        Ok(words)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ALL_FORWARD;
    use volcomp_gcode::Plane;

    #[test]
    fn the_circle_through_the_written_ends_keeps_the_pieces_radius_and_side() {
        // A counter-clockwise quarter of R5 about the origin from (5, 0) to
        // (0, 5); its ends written 3 µm apart from the nominal (both moved
        // by (0.003, 0)): the circle of radius 5 through them is centred
        // at (0.003, 0), on the origin's side of the chord, not at its
        // mirror (5.003, 5).
        let piece = Arc {
            start: Vec3::new(5.0, 0.0, 0.0),
            end: Vec3::new(0.0, 5.0, 0.0),
            center: Vec3::ZERO,
            plane: Plane::Xy,
            sweep_rad: std::f64::consts::FRAC_PI_2,
        };
        let c = ends_center(
            &piece,
            Vec3::new(5.003, 0.0, 0.0),
            Vec3::new(0.003, 5.0, 0.0),
        )
        .expect("a centre");
        assert!((c - Vec3::new(0.003, 0.0, 0.0)).norm() < 1e-12, "{c:?}");
        // A chord longer than the diameter has none.
        assert!(ends_center(&piece, Vec3::new(5.0, 0.0, 0.0), Vec3::new(-5.1, 0.0, 0.0)).is_none());
    }

    #[test]
    fn a_point_off_the_arc_reads_as_the_parameter_of_its_angle() {
        // A clockwise quarter circle R2 about (1, 1, 0) from (3, 1) to
        // (1, −1), rising 1 mm in Z. The point at 45° (parameter 1/2) is
        // (1 + √2, 1 − √2); moved 3 µm outward and 5 µm along Z it still
        // reads 1/2, counted from 0 or from 0.4; 30° on from the start
        // (the point at 1/3) moved inward by 2 µm reads 1/3.
        let arc = Arc {
            start: Vec3::new(3.0, 1.0, 0.0),
            end: Vec3::new(1.0, -1.0, 1.0),
            center: Vec3::new(1.0, 1.0, 0.0),
            plane: Plane::Xy,
            sweep_rad: -std::f64::consts::FRAC_PI_2,
        };
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let at_45 = Vec3::new(1.0 + 2.003 * h, 1.0 - 2.003 * h, 0.505);
        assert!((param_near(&arc, 0.0, at_45) - 0.5).abs() < 1e-12);
        assert!((param_near(&arc, 0.4, at_45) - 0.5).abs() < 1e-12);
        let (s, c) = (-std::f64::consts::FRAC_PI_6).sin_cos();
        let at_30 = Vec3::new(1.0 + 1.998 * c, 1.0 + 1.998 * s, 0.0);
        assert!((param_near(&arc, 0.0, at_30) - 1.0 / 3.0).abs() < 1e-12);
    }

    /// An R15 arc in XY cut into pieces of 0.2 mm (plus a first piece of
    /// 3 mm), its commands on the arc with Z 0 up to point `at` and Z
    /// `step_um` from the point after it on: one piece climbs the step.
    /// Solved piece ends, each with the take-up written before it.
    type Commands = Vec<(Vec3, Option<Vec3>)>;

    fn stepped_arc(at: usize, step_um: f64) -> (Arc, Vec<f64>, Commands) {
        let r = 15.0;
        let ends_mm: Vec<f64> = std::iter::once(3.0)
            .chain((1..=30).map(|k| 3.0 + 0.2 * k as f64))
            .collect();
        let length = *ends_mm.last().unwrap();
        let arc = Arc {
            start: Vec3::new(r, 0.0, 0.0),
            end: Vec3::new(r * (length / r).cos(), r * (length / r).sin(), 0.0),
            center: Vec3::ZERO,
            plane: Plane::Xy,
            sweep_rad: length / r,
        };
        let pieces: Vec<f64> = ends_mm.iter().map(|e| e / length).collect();
        let commands = pieces
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let mut q = arc.point_at(*p);
                q.z = if i + 1 > at { step_um * 1e-3 } else { 0.0 };
                (q, None)
            })
            .collect();
        (arc, pieces, commands)
    }

    fn z_turns(arc: &Arc, pieces: &[f64], c: &[(Vec3, Option<Vec3>)]) -> Vec<f64> {
        let len = arc.length();
        let mut x = vec![0.0];
        x.extend(pieces.iter().map(|p| p * len));
        let z = |k: usize| if k == 0 { 0.0 } else { c[k - 1].0.z };
        let slope = |k: usize| (z(k) - z(k - 1)) / (x[k] - x[k - 1]);
        (1..c.len())
            .map(|j| (slope(j + 1) - slope(j)).abs())
            .collect()
    }

    /// A helix of R7 about the origin falling 1.5 mm a turn, from (7, 0, 0)
    /// over 20 mm of arc: pieces of 4, 4.5, 1.5 (the S-curve's, ending at
    /// point 3), 5 and 5 mm of arc, its commands on the helix but for the
    /// S-curve's end and what follows, lowered by `step_um`.
    fn stepped_helix(step_um: f64) -> (Arc, Vec<f64>, Commands) {
        let r = 7.0;
        let (arc_mm, pitch) = (20.0, 1.5);
        let sweep = arc_mm / r;
        let fall = pitch * sweep / TAU;
        let arc = Arc {
            start: Vec3::new(r, 0.0, 0.0),
            end: Vec3::new(r * sweep.cos(), r * sweep.sin(), -fall),
            center: Vec3::ZERO,
            plane: Plane::Xy,
            sweep_rad: sweep,
        };
        let pieces: Vec<f64> = [4.0, 8.5, 10.0, 15.0, 20.0]
            .iter()
            .map(|e| e / arc_mm)
            .collect();
        let commands = pieces
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let mut q = arc.point_at(*p);
                if i >= 2 {
                    q.z -= step_um * 1e-3;
                }
                (q, None)
            })
            .collect();
        (arc, pieces, commands)
    }

    /// [`stepped_helix`] with the S-curve's piece first: pieces of 1.5
    /// (the S-curve's), 5, 5, 5 and 3.5 mm of arc, every command lowered
    /// by `step_um`.
    fn helix_stepped_at_its_start(step_um: f64) -> (Arc, Vec<f64>, Commands) {
        let (arc, _, _) = stepped_helix(0.0);
        let pieces: Vec<f64> = [1.5, 6.5, 11.5, 16.5, 20.0]
            .iter()
            .map(|e| e / 20.0)
            .collect();
        let commands = pieces
            .iter()
            .map(|p| (arc.point_at(*p) - Vec3::new(0.0, 0.0, step_um * 1e-3), None))
            .collect();
        (arc, pieces, commands)
    }

    /// `before` (the commands of a helix' pieces, Z falling along it in its
    /// reverse state) smoothed under G64 without P at F6000 with the
    /// S-curve `s_curve`, Z written to 0.01 µm: the commands, the largest
    /// move and the bound ([`smooth_normal_kinks`]).
    fn folded_on_helix(
        before: &[(Vec3, Option<Vec3>)],
        (arc, pieces, slope_in): (&Arc, &[f64], Option<f64>),
        s_curve: Transition,
    ) -> (Vec<(Vec3, Option<Vec3>)>, f64, f64) {
        let quantize = |q: Vec3, _from: Vec3| Vec3::new(q.x, q.y, (q.z * 1e5).round() / 1e5);
        let mut down = ALL_FORWARD;
        down[2] = Direction::Reverse;
        let states = vec![down; before.len()];
        let options = super::super::CompensateOptions::default();
        let mut c = before.to_vec();
        let (moved, bound) = smooth_normal_kinks(
            (&mut c, &states),
            (arc, pieces, arc.start, slope_in),
            (&[s_curve], &options, 100.0),
            &quantize,
            Smoothing::Folded,
        );
        (c, moved, bound)
    }

    #[test]
    fn an_arcs_last_piece_gives_its_normal_slope_along_its_length() {
        // On the helix the slope is its fall over its length, by hand:
        // 1.5 mm a turn of 2π·7 mm in the plane, dw/ds = −1.5 / √((2π·7)² + 1.5²).
        let (arc, pieces, commands) = stepped_helix(0.0);
        let out = NormalSlopeOut::of(&commands, (&arc, &pieces, arc.start)).unwrap();
        let by_hand = -1.5 / (TAU * 7.0).hypot(1.5);
        let along = out.along(2).unwrap();
        assert!((along - by_hand).abs() < 1e-12, "{along} {by_hand}");
        assert_eq!(out.end_mm, commands[4].0);
        // Across the plane an arc gives none (its slope turns along it).
        assert_eq!((out.along(0), out.along(1)), (None, None));
        // One piece: from the arc's start; a take-up block after the last
        // piece: none (the path leaves along the take-up).
        let one = NormalSlopeOut::of(&commands[..1], (&arc, &pieces, arc.start)).unwrap();
        assert!((one.along(2).unwrap() - by_hand).abs() < 1e-12);
        let mut taken = commands.clone();
        taken[4].1 = Some(taken[4].0);
        assert_eq!(NormalSlopeOut::of(&taken, (&arc, &pieces, arc.start)), None);
    }

    #[test]
    fn a_lines_last_piece_gives_every_axis_slope() {
        // The last piece from (0, 10, −1) to (0, 22, −1.003): 12 mm in Y
        // with Z 3 µm lower, by hand dz/ds = −0.003 / √(12² + 0.003²),
        // dy/ds = 12 / √(12² + 0.003²).
        let commands = [
            (Vec3::new(0.0, 10.0, -1.0), None),
            (Vec3::new(0.0, 22.0, -1.003), None),
        ];
        let q_in = Vec3::new(0.0, 0.0, -1.0);
        let out = NormalSlopeOut::of_line(&commands, q_in).unwrap();
        let ds = 12f64.hypot(0.003);
        assert!((out.along(2).unwrap() + 0.003 / ds).abs() < 1e-15);
        assert!((out.along(1).unwrap() - 12.0 / ds).abs() < 1e-15);
        assert_eq!(out.along(0), Some(0.0));
        // One piece: from where the motion starts.
        let one = NormalSlopeOut::of_line(&commands[..1], q_in).unwrap();
        assert_eq!(one.along(2), Some(0.0));
        // No length, or a take-up block last: none.
        assert_eq!(NormalSlopeOut::of_line(&commands[..1], commands[0].0), None);
        let taken = [commands[0], (commands[1].0, Some(commands[1].0))];
        assert_eq!(NormalSlopeOut::of_line(&taken, q_in), None);
    }

    #[test]
    fn under_g64_an_s_curve_at_an_arcs_start_is_spread_from_the_slope_it_comes_in_with() {
        // The arc's first piece is the S-curve, falling 2.9 µm more than
        // the helix: against the helix it comes in along (the last turn's
        // last piece) and the piece after it, its slope differs by
        // 2.9e-3 / 1.5 = 1.93e-3 rad at both ends.
        let (arc, pieces, before) = helix_stepped_at_its_start(2.9);
        let helix = -1.5 / (TAU * 7.0).hypot(1.5);
        let len = arc.length();
        let z = |c: &Commands, k: usize| if k == 0 { arc.start.z } else { c[k - 1].0.z };
        let first_turn = |c: &Commands| ((z(c, 1) - z(c, 0)) / (pieces[0] * len) - helix).abs();
        let by_hand = 2.9e-3 / (1.5 * len / 20.0);
        assert!((first_turn(&before) - by_hand).abs() < 1e-9);
        assert!((z_turns(&arc, &pieces, &before)[0] - by_hand).abs() < 1e-9);
        let s_curve = Transition {
            index: 0,
            axis: 1,
            direction: Direction::Forward,
            deviation_mm: 12e-3,
            spread: None,
            widest: false,
        };
        let steps = normal_steps_mm(&before, (&arc, &pieces, arc.start, Some(helix)), &[s_curve]);
        assert!((steps[0] - 2.9e-3).abs() < 1e-9, "{steps:?}");
        let smooth = |slope_in: Option<f64>| {
            let (c, moved, _) = folded_on_helix(&before, (&arc, &pieces, slope_in), s_curve);
            (c, moved)
        };
        // Not knowing the slope the path comes in with, the join at the
        // start keeps its turn whatever is done after it.
        let (blind, _) = smooth(None);
        assert!((first_turn(&blind) - by_hand).abs() < 1e-9);
        // Knowing it, every join from the start on is within 0.6 of the
        // tolerance (2.970e-4 rad at F6000), no command moved by more than
        // the step, the start and the end kept, Z never rising.
        let (c, moved) = smooth(Some(helix));
        let limit = 0.6 * 4.950e-4 + 1e-9;
        assert!(first_turn(&c) <= limit, "{}", first_turn(&c));
        let turns = z_turns(&arc, &pieces, &c);
        assert!(turns.iter().all(|t| *t <= limit), "{turns:?}");
        assert!(moved > 0.0 && moved <= 2.9e-3 + 1e-12, "{moved}");
        assert_eq!(c.last().unwrap().0, before.last().unwrap().0);
        assert!((1..=c.len()).all(|k| z(&c, k) <= z(&c, k - 1)), "{c:?}");
    }

    #[test]
    fn under_g64_a_helix_spreads_the_step_of_its_s_curve_within_the_step() {
        // The S-curve's piece falls by its share of the helix plus 2.9 µm:
        // against the pieces on either side its slope differs by
        // 2.9e-3 / 1.5 = 1.93e-3 rad, above the planner's tangency
        // tolerance on an arc at F6000 (4.950e-4 rad, by hand in the test
        // above), a join LinuxCNC blends parabolically.
        let (arc, pieces, before) = stepped_helix(2.9);
        let turns = z_turns(&arc, &pieces, &before);
        let len = arc.length();
        let by_hand = 2.9e-3 / (1.5 * len / arc.sweep_rad / 7.0);
        assert!((turns[1] - by_hand).abs() < 1e-9, "{turns:?} {by_hand}");
        assert!((turns[2] - by_hand).abs() < 1e-9, "{turns:?} {by_hand}");
        let s_curve = Transition {
            index: 2,
            axis: 1,
            direction: Direction::Forward,
            deviation_mm: 12e-3,
            spread: None,
            widest: false,
        };
        // The step the S-curve makes beyond the helix' own fall, by hand.
        let steps = normal_steps_mm(&before, (&arc, &pieces, arc.start, None), &[s_curve]);
        assert!((steps[0] - 2.9e-3).abs() < 1e-9, "{steps:?}");
        let (c, moved, bound) = folded_on_helix(&before, (&arc, &pieces, None), s_curve);
        // Every join now within 0.6 of the tolerance (2.970e-4 rad), no
        // command moved by more than the step, the helix' ends kept, Z
        // never rising.
        let turns = z_turns(&arc, &pieces, &c);
        assert!(
            turns.iter().all(|t| *t <= 0.6 * 4.950e-4 + 1e-9),
            "{turns:?}"
        );
        assert!(moved > 0.0 && moved <= 2.9e-3 + 1e-12, "{moved}");
        assert!((bound - moved.hypot(12e-3)).abs() < 1e-15);
        assert_eq!(c.last().unwrap().0, before.last().unwrap().0);
        let z = |k: usize| if k == 0 { arc.start.z } else { c[k - 1].0.z };
        assert!((1..=c.len()).all(|k| z(k) <= z(k - 1)), "{c:?}");
        // Under G61 a helix is left alone.
        let mut g61 = before.clone();
        let states = vec![ALL_FORWARD; before.len()];
        let moved = smooth_normal_turns(
            (&mut g61, &states),
            (&arc, &pieces, arc.start, None),
            (4.950e-4, 4.950e-4),
            &|_, _| 1.0,
            &|q, _| q,
            Smoothing::Exact,
        );
        assert_eq!((moved, &g61), (0.0, &before));
    }

    #[test]
    fn a_step_of_the_normal_axis_is_smoothed_within_the_planners_tangency_tolerance() {
        // At F6000 the planner takes a join on an arc as tangent where
        // |Δt_z|·(v/T + A)/A / ½ stays below the kink ratio 0.1 (tp.c
        // `tpSetupTangent`): |Δt_z| < 0.05·1000/(100/0.001 + 1000) =
        // 4.950e-4 rad (by hand). A step of 0.3 µm over the piece ending
        // at point 16 (0.2 mm) turns Z by 0.3e-3/0.2 = 1.5e-3 rad at both
        // its joins, and the planner slows to about 0.05/1.5e-3 = 33 mm/s.
        let limit = 0.05 * 1000.0 / (100.0 / 0.001 + 1000.0);
        let planner = super::super::PlannerLimits::default();
        assert!((planner.tangent_tolerance(100.0, true)[2] - limit).abs() < 1e-12);
        let (arc, pieces, before) = stepped_arc(15, 0.3);
        assert!((z_turns(&arc, &pieces, &before)[14] - 1.5e-3).abs() < 1e-9);
        let quantize = |q: Vec3, _from: Vec3| Vec3::new(q.x, q.y, (q.z * 1e5).round() / 1e5);
        let bound = |_: usize, _: usize| 0.2e-3;
        // Z moves up in every state: the step may spread both ways.
        let states = vec![ALL_FORWARD; before.len()];
        let mut c = before.clone();
        let moved = smooth_normal_turns(
            (&mut c, &states),
            (&arc, &pieces, arc.start, None),
            (limit, limit),
            &bound,
            &quantize,
            Smoothing::Exact,
        );
        let turns = z_turns(&arc, &pieces, &c);
        let worst = turns.iter().fold(0.0f64, |m, t| m.max(*t));
        assert!(worst <= limit, "{turns:?}");
        assert!(moved > 0.0 && moved <= 0.2e-3, "{moved}");
        for (k, (q, p)) in c.iter().zip(&before).enumerate() {
            // Only Z moves, by no more than reported, never downward.
            assert_eq!((q.0.x, q.0.y), (p.0.x, p.0.y));
            assert!((q.0.z - p.0.z).abs() <= moved + 1e-15, "{k}");
            let prev = if k == 0 { 0.0 } else { c[k - 1].0.z };
            assert!(q.0.z >= prev, "{k}: {} < {prev}", q.0.z);
        }
        // The ends of the block stay.
        assert_eq!(c.last().unwrap().0.z, 0.3e-3);
        assert_eq!(c[0].0.z, 0.0);

        // Z reverse before the step (its state down: no command may rise
        // there), forward from the step's piece on: only the pieces after
        // it may take it, and those before keep their Z.
        let mut states = vec![ALL_FORWARD; before.len()];
        for s in states.iter_mut().take(15) {
            s[2] = Direction::Reverse;
        }
        let mut c = before.clone();
        smooth_normal_turns(
            (&mut c, &states),
            (&arc, &pieces, arc.start, None),
            (limit, limit),
            &bound,
            &quantize,
            Smoothing::Exact,
        );
        assert!(c[..15].iter().all(|q| q.0.z == 0.0));
        assert!(c != before);
        // Within 0.05 µm: no command moves by more.
        let mut c = before.clone();
        let tight = |_: usize, _: usize| 0.05e-3;
        let moved = smooth_normal_turns(
            (&mut c, &vec![ALL_FORWARD; before.len()]),
            (&arc, &pieces, arc.start, None),
            (limit, limit),
            &tight,
            &quantize,
            Smoothing::Exact,
        );
        assert!(moved <= 0.05e-3 + 1e-15, "{moved}");
        assert!(c
            .iter()
            .zip(&before)
            .all(|(q, p)| (q.0.z - p.0.z).abs() <= 0.05e-3 + 1e-15));
    }

    #[test]
    fn under_g61_a_short_piece_bent_by_its_middle_keeps_the_nominal_circle() {
        // A piece of 0.2 mm of a circle of R15 about the origin (sweep
        // 0.2/15 rad), every point moved by the same correction (1, −2) µm,
        // its middle 0.09 µm further out: the circle through the three
        // points has a sagitta of 0.333 + 0.09 µm, R ≈ 15·0.333/0.423 =
        // 11.8 mm, its end tangents turned by 4·0.09 µm / 0.2 mm = 1.8 mrad
        // from the nominal circle's. Under G61 (half the tangency tolerance
        // at F6000 with an arc: 0.2475 mrad) the nominal centre moved by
        // the correction (0.001, −0.002) is written; elsewhere the three
        // points' circle, as before. An 8 mm piece bent by 0.5 µm at its
        // middle (a bend of 8·0.5 µm/(8 mm)² = 6·10⁻⁵/mm, which a map
        // makes) keeps its three points' circle in both.
        let r = 15.0;
        let arc_of = |length: f64| Arc {
            start: Vec3::new(r, 0.0, 0.0),
            end: Vec3::new(r * (length / r).cos(), r * (length / r).sin(), 0.0),
            center: Vec3::ZERO,
            plane: Plane::Xy,
            sweep_rad: length / r,
        };
        let shift = Vec3::new(0.001, -0.002, 0.0);
        let ends = |piece: &Arc, out_um: f64| {
            let mid = piece.point_at(0.5);
            let radial = mid * (1.0 / mid.norm());
            (
                piece.start + shift,
                mid + shift + radial * (out_um * 1e-3),
                piece.end + shift,
            )
        };
        let short = arc_of(0.2);
        let tol = Some(0.5 * 0.1 * 1000.0 / (100.0 / 0.001 + 1000.0));
        let g61 = piece_center(&short, ends(&short, 0.09), 1e-7, tol).unwrap();
        assert!((g61 - shift).norm() < 1e-12, "{g61:?}");
        let other = piece_center(&short, ends(&short, 0.09), 1e-7, None).unwrap();
        let (s, _, _) = ends(&short, 0.09);
        let fitted_r = (s - other).norm();
        assert!((fitted_r - 11.8).abs() < 0.1, "{other:?} R {fitted_r}");
        let long = arc_of(8.0);
        for t in [tol, None] {
            let c = piece_center(&long, ends(&long, 0.5), 1e-7, t).unwrap();
            assert!((c - shift).norm() > 1e-3, "{t:?}: {c:?}");
        }
    }

    #[test]
    fn an_s_curve_is_cut_on_the_normal_through_the_join_about_its_own_centres() {
        // An S-curve of two arcs in XY: the first clockwise about (0, −2),
        // R 2, from 0.05 rad before its top (0, 0) to 0.03 rad past it (the
        // joint J); the second counter-clockwise, R 3, about the point 3 mm
        // from J away from the first centre, on for 0.04 rad. Cut on the
        // normal x = 0 (the tangent (1, 0) through the origin) it is cut at
        // the first arc's top, (0, 0); on x = 0.1, past J, on the second
        // arc's lower half at y = c₂y − √(9 − (0.1 − c₂x)²) (closed form),
        // each on the 4-decimal grid (half a step, 0.05 µm). Each part
        // keeps its arc's centre; the part of the first arc after the cut
        // carries the second arc on. A normal beyond the end cuts nothing.
        let frame = Frame {
            offset_mm: Vec3::ZERO,
            mm_per_unit: 1.0,
            decimals: 4,
            absolute: true,
            rotation_deg: 0.0,
            before_mm: Vec3::ZERO,
            after_mm: Vec3::ZERO,
            x_word_scale: 1.0,
            arc_absolute: false,
        };
        let style = NumberStyle::fixed(4);
        let c1 = Vec3::new(0.0, -2.0, 0.0);
        let on1 = |t: f64| c1 + Vec3::new(2.0 * t.sin(), 2.0 * t.cos(), 0.0);
        let (a, joint) = (on1(-0.05), on1(0.03));
        let c2 = joint + (joint - c1) * (3.0 / 2.0);
        let back = c1 - c2;
        let phi = back.y.atan2(back.x);
        let b = c2 + Vec3::new(3.0 * (phi + 0.04).cos(), 3.0 * (phi + 0.04).sin(), 0.0);
        let words = ArcWords {
            center: Some(c1),
            plane: Plane::Xy,
            clockwise: true,
            radius_style: false,
            absolute_centers: false,
            second: Some(SecondArc {
                joint,
                center: Some(c2),
                clockwise: false,
            }),
        };
        let cut = |x: f64| {
            split_at_normal(
                &words,
                (a, b),
                (Vec3::new(x, 0.0, 0.0), [1.0, 0.0]),
                &frame,
                style,
            )
        };
        let first = cut(0.0).unwrap();
        assert!(first.at.norm() < 5.1e-5, "{:?}", first.at);
        assert_eq!(first.before.center, Some(c1));
        assert!(first.before.second.is_none() && first.before.clockwise);
        assert_eq!(first.after.center, Some(c1));
        assert_eq!(first.after.second.map(|s| s.center), Some(Some(c2)));
        let second = cut(0.1).unwrap();
        let y = c2.y - (9.0 - (0.1 - c2.x).powi(2)).sqrt();
        assert!(
            (second.at - Vec3::new(0.1, y, 0.0)).norm() < 7.1e-5,
            "{:?} {y}",
            second.at
        );
        assert_eq!(second.before.center, Some(c1));
        assert_eq!(
            second.before.second.map(|s| (s.joint, s.center)),
            Some((joint, Some(c2)))
        );
        assert_eq!(second.after.center, Some(c2));
        assert!(second.after.second.is_none() && !second.after.clockwise);
        assert!(cut(b.x + 0.01).is_none() && cut(a.x - 0.01).is_none());
    }

    #[test]
    fn a_ramp_around_a_reversal_in_an_arc_starts_its_lead_before_it_along_the_arc() {
        // A full G3 circle of R10 from (10, 0): 62.832 mm, targets at the
        // quarters (15.708 mm apart); the reversal at the start of target
        // 2's piece, 31.416 mm along. A 6 mm ramp with 4 mm before it
        // starts 27.416 mm along, inside piece 1: a point inserted there
        // (on the circle, at the angle 27.416/10 rad), solved again from
        // target 1, and the ramp runs 4 + 2 = 6 mm.
        let arc = Arc {
            start: Vec3::new(10.0, 0.0, 0.0),
            end: Vec3::new(10.0, 0.0, 0.0),
            center: Vec3::ZERO,
            plane: Plane::Xy,
            sweep_rad: TAU,
        };
        let pieces = [0.25, 0.5, 0.75, 1.0];
        let half = 10.0 * std::f64::consts::PI;
        let (from, insert, ramp_mm) =
            centred_start_on_arc(&arc, &pieces, 2, (4.0, 6.0), 0.2).unwrap();
        assert_eq!(from, 1);
        let (p, l) = insert.unwrap();
        let angle = (half - 4.0) / 10.0;
        assert!((l - (half - 4.0) / (2.0 * half)).abs() < 1e-12, "{l}");
        assert!((p.x - 10.0 * angle.cos()).abs() < 1e-9, "{p:?}");
        assert!((p.y - 10.0 * angle.sin()).abs() < 1e-9, "{p:?}");
        assert!((ramp_mm - 6.0).abs() < 1e-9, "{ramp_mm}");
        // A start 0.1 mm after target 1 (15.708 mm along) moves back to it:
        // no point inserted, the ramp 15.708 + 2 mm long.
        let lead = half - 0.5 * half - 0.1;
        let (from, insert, ramp_mm) =
            centred_start_on_arc(&arc, &pieces, 2, (lead, lead + 2.0), 0.2).unwrap();
        assert_eq!((from, insert), (1, None));
        assert!((ramp_mm - (0.5 * half + 2.0)).abs() < 1e-9, "{ramp_mm}");
        // No room: a lead shorter than the shortest piece, a lead longer
        // than the ramp, no reversal before the first target.
        assert_eq!(
            centred_start_on_arc(&arc, &pieces, 2, (0.1, 6.0), 0.2),
            None
        );
        assert_eq!(
            centred_start_on_arc(&arc, &pieces, 2, (7.0, 6.0), 0.2),
            None
        );
        assert_eq!(
            centred_start_on_arc(&arc, &pieces, 0, (3.0, 6.0), 0.2),
            None
        );
    }

    #[test]
    fn the_ramps_lead_leaves_the_least_of_the_largest_drift_a_scan_finds() {
        // Second method: scan the ramp's start a over [0, L] in steps of
        // L/100 000 for the least max(s₁a, |s₂(L − a) − s₁a|), the tool
        // held at the start's level while the target drifts s₁ before
        // the reversal and s₂ after it.
        let l = 5.0;
        for (s1, s2) in [
            (1.0, 1.0),
            (0.235, 0.08),
            (0.032, 0.101),
            (0.0, 0.3),
            (0.4, 0.0),
        ] {
            let worst = |a: f64| (s1 * a).max((s2 * (l - a) - s1 * a).abs());
            let n = 100_000;
            let (best_a, best) = (0..=n)
                .map(|k| l * k as f64 / n as f64)
                .map(|a| (a, worst(a)))
                .min_by(|x, y| x.1.total_cmp(&y.1))
                .unwrap();
            let share = ramp_lead_share(s1, s2);
            assert!(
                worst(share * l) <= best + 1e-9,
                "{s1} {s2}: {share} vs {best_a}"
            );
            // And the closed form of that least drift, s₁s₂L/(2s₁ + s₂).
            assert!((worst(share * l) - s1 * s2 * l / (2.0 * s1 + s2)).abs() < 1e-12);
        }
        // Equal drifts: a third of the ramp before the reversal.
        assert!((ramp_lead_share(1.0, 1.0) - 1.0 / 3.0).abs() < 1e-15);
        // No drift on either side: centred.
        assert_eq!(ramp_lead_share(0.0, 0.0), 0.5);
    }

    #[test]
    fn circle_through_three_points_of_a_known_circle() {
        // Centre (3, −2), radius 5: points at 0°, 90° and 210°.
        let p = |deg: f64| {
            let a = deg.to_radians();
            [3.0 + 5.0 * a.cos(), -2.0 + 5.0 * a.sin()]
        };
        let c = circle_through(p(0.0), p(90.0), p(210.0)).unwrap();
        assert!((c[0] - 3.0).abs() < 1e-12 && (c[1] + 2.0).abs() < 1e-12);
        assert!(circle_through([0.0, 0.0], [1.0, 1.0], [2.0, 2.0]).is_none());
    }

    /// A quarter of a circle of radius 20 about the origin, G3 in XY.
    fn quarter_r20() -> Arc {
        Arc {
            start: Vec3::new(20.0, 0.0, 0.0),
            end: Vec3::new(0.0, 20.0, 0.0),
            center: Vec3::ZERO,
            plane: Plane::Xy,
            sweep_rad: FRAC_PI_2,
        }
    }

    /// A map given by one formula of the point (µm), the same in every
    /// direction, over ±1 m.
    struct Smooth(fn(Vec3) -> Vec3);
    impl ErrorModel for Smooth {
        fn deviation_um(&self, q: Vec3, _: Directions, _: Components) -> Result<Vec3, ModelError> {
            Ok((self.0)(q))
        }
        fn range_mm(&self) -> [[f64; 2]; 3] {
            [[-1e3, 1e3]; 3]
        }
    }

    /// A map with a smooth bend along X in Z (`e_z = k·x²`) and in-plane
    /// terms: on an XY arc the helix axis is matched at the two ends only,
    /// so the error left in a piece is the departure of
    /// `g(θ) = e_z(R cos θ) = k R² cos² θ` from its chord in θ, which at
    /// the middle is `−g''·Δ²/8 = k R² cos(2θ_m) Δ²/4`: second order in the
    /// piece, so halving it divides the error by 4. The in-plane part,
    /// matched at three points, is of higher order.
    #[test]
    fn the_error_of_a_piece_is_second_order() {
        let bend = Smooth(|q| Vec3::new(0.02 * q.x * q.y, -0.03 * q.x * q.x, 0.05 * q.x * q.x));
        let arc = quarter_r20();
        // Pieces from 0° of 8°, 4° and 2°.
        let d_um =
            |deg: f64| piece_departure_mm(&arc, 0.0, deg / 90.0, &bend, ALL_FORWARD).unwrap() * 1e3;
        let hand_um = |deg: f64| {
            let delta = f64::to_radians(deg);
            0.05 * 400.0 * delta.cos() * delta * delta / 4.0
        };
        for deg in [8.0, 4.0, 2.0] {
            // 4°: 0.05 · 400 · cos 4° · 0.0698² / 4 = 0.02431 µm.
            let (d, h) = (d_um(deg), hand_um(deg));
            assert!((d - h).abs() < 0.02 * h, "{deg}°: {d} µm, by hand {h} µm");
        }
        assert!((d_um(8.0) / d_um(4.0) - 4.0).abs() < 0.1);
        assert!((d_um(4.0) / d_um(2.0) - 4.0).abs() < 0.1);
    }

    #[test]
    fn pieces_end_at_quarter_points() {
        struct Zero;
        impl ErrorModel for Zero {
            fn deviation_um(
                &self,
                _: Vec3,
                _: Directions,
                _: Components,
            ) -> Result<Vec3, ModelError> {
                Ok(Vec3::ZERO)
            }
            fn range_mm(&self) -> [[f64; 2]; 3] {
                [[-1e3, 1e3]; 3]
            }
        }
        // A full G2 circle from 45°: quarter points at 0°, −90°, −180°, −270°.
        let s = 10.0 * std::f64::consts::FRAC_1_SQRT_2;
        let p = Vec3::new(s, s, 0.0);
        let arc = Arc {
            start: p,
            end: p,
            center: Vec3::ZERO,
            plane: Plane::Xy,
            sweep_rad: -TAU,
        };
        let mut worst = 0.0;
        let t = arc_pieces(&arc, &Zero, ALL_FORWARD, (1e-4, 1e-4), 0.01, &mut worst).unwrap();
        assert!(worst < 1e-12, "{worst}");
        let expected = [0.125, 0.375, 0.625, 0.875, 1.0];
        assert_eq!(t.len(), 5);
        for (a, b) in t.iter().zip(expected) {
            assert!((a - b).abs() < 1e-12, "{t:?}");
        }
    }

    #[test]
    fn under_g61_a_piece_keeps_its_normal_axis_bump_within_half_the_tolerance() {
        // Z's correction 0.05·x² µm (nothing across the plane): on the
        // circle of radius 20 about the origin it is 20·cos²θ =
        // 10 + 10·cos 2θ µm, which the controller runs linearly over a
        // piece. A piece of sweep φ about θ₀ is off at its middle by
        // 10·|cos 2θ₀|·(1 − cos φ) µm by hand (the mean of cos 2θ at its
        // ends is cos 2θ₀·cos φ); in the plane nothing departs.
        let bowl = Smooth(|q| Vec3::new(0.0, 0.0, 0.05 * q.x * q.x));
        let arc = quarter_r20();
        let bump_um = |a: f64, b: f64| {
            let (t0, phi) = (0.5 * (a + b) * FRAC_PI_2, (b - a) * FRAC_PI_2);
            10.0 * (2.0 * t0).cos().abs() * (1.0 - phi.cos())
        };
        // 11.25° pieces are off by 0.188 µm (θ₀ = 5.6°), 5.6° ones by
        // 0.047 µm, 2.8° ones by 0.012 µm (by the formula).
        let tol_mm = 0.08e-3;
        let worst_bump_um = |normal_mm: f64| {
            let mut worst = 0.0;
            let t = arc_pieces(
                &arc,
                &bowl,
                ALL_FORWARD,
                (tol_mm, normal_mm),
                0.01,
                &mut worst,
            )
            .unwrap();
            let mut from = 0.0;
            let mut most: f64 = 0.0;
            for to in &t {
                most = most.max(bump_um(from, *to));
                from = *to;
            }
            (most, t.len())
        };
        // With the tolerance alone (G64, and G61 before), a piece keeps a
        // bump of more than half of it.
        let (alone_um, alone_n) = worst_bump_um(tol_mm);
        assert!(alone_um > 0.04 && alone_um <= 0.08, "{alone_um} µm");
        // Under G61, within half (0.04 µm), the pieces halved once more
        // (the bump grows with the square of the sweep: a quarter).
        let g61_mm = normal_tolerance_mm(tol_mm, volcomp_gcode::PathMode::ExactPath);
        assert!((g61_mm - 0.04e-3).abs() < 1e-15, "{g61_mm}");
        let (half_um, half_n) = worst_bump_um(g61_mm);
        assert!(half_um <= 0.04 && half_um > 0.01, "{half_um} µm");
        assert!(
            half_n > alone_n && half_n <= 2 * alone_n,
            "{alone_n} → {half_n}"
        );
        // Elsewhere the tolerance alone.
        let g64 = volcomp_gcode::PathMode::Blend {
            tolerance_mm: 0.0,
            naive_cam_mm: 0.0,
        };
        assert_eq!(normal_tolerance_mm(tol_mm, g64), tol_mm);
    }

    #[test]
    fn a_pieces_normal_bump_counts_only_where_the_normal_command_runs_one_way() {
        // Z's correction 0.05·(x − y)² µm: on the circle of radius 20 it
        // is 20·(1 − sin 2θ) µm, least at 45°.
        let valley = Smooth(|q| Vec3::new(0.0, 0.0, 0.05 * (q.x - q.y) * (q.x - q.y)));
        let arc = quarter_r20();
        // 0° to 22.5°: Z's command runs one way; the bump at 11.25° by
        // hand is 20·|sin 22.5° − sin 45°/2| = 0.5826 µm.
        let (d, _, n) = piece_departure_at_mm(&arc, 0.0, 0.25, &valley, ALL_FORWARD, &[]).unwrap();
        let hand_um = 20.0 * (f64::to_radians(22.5).sin() - 0.5 * f64::to_radians(45.0).sin());
        assert!(
            (n * 1e3 - hand_um).abs() < 1e-3 * hand_um,
            "{n} mm, by hand {hand_um} µm"
        );
        assert!(d >= n, "{d} {n}");
        // 22.5° to 67.5°: Z's command turns back at 45°: no normal bump
        // counted (the reversal is not an interpolation error), while the
        // departure itself, 20·(1 − sin 45°) = 5.858 µm at the middle,
        // still splits the piece.
        let (d, _, n) = piece_departure_at_mm(&arc, 0.25, 0.75, &valley, ALL_FORWARD, &[]).unwrap();
        assert_eq!(n, 0.0);
        let hand_um = 20.0 * (1.0 - f64::to_radians(45.0).sin());
        assert!(
            (d * 1e3 - hand_um).abs() < 1e-3 * hand_um,
            "{d} mm, by hand {hand_um} µm"
        );
    }
}
