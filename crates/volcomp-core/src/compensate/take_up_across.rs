//! Under G61, a take-up of the arc plane's normal axis right after a
//! quarter-point S-curve (or on the piece right before it), spread as a
//! smooth ramp across the S-curve instead of written as a block (docs/compensation.md, "A normal-axis
//! take-up across the S-curve").
//!
//! At a quarter point the S-curve axis' straightness across the plane
//! switches with its direction (tenths of a micrometre), and where the
//! normal axis' target runs one way before the point and the other way
//! after it, that axis reverses right where the S-curve ends. A take-up
//! block there is a stop (tp.c `tpSetupTangent` sees a corner), about
//! 0.1 s at 100 mm/s. Near the quarter point the S-curve axis barely
//! moves, so the normal axis' target stays within a few tenths of a
//! micrometre over a few millimetres: the carriage may cross its band
//! while the tool stands still along it, as on any ramp
//! (`points::RampPlan`). The ramp `3u² − 2u³` over `L = √(6|Δ|ℓ/κ)`
//! (`ℓ` the ramp's piece, `κ` the share `RAMP_SHARE` of the planner's
//! tangency tolerance) is the shortest whose joins the planner takes as
//! tangent; it starts before the S-curve so the standing tool sits
//! between the target's levels before and after it, where the ramp
//! after the S-curve alone leaves the target's whole fall over `L`.
//!
//! The tool's offset along the normal axis is read from the written
//! commands in the dead-band reading (docs/design.md, "Direction state
//! and backlash"; bench/eval/judge.py `band`): the carriage follows the
//! command its old way up to the command's turn, stands until the command
//! has travelled the band `|Δ|` back, then follows it its new way. The
//! offset is across the plane, the S-curve's own deviation in it: the two
//! add as the hypotenuse, which must stay within the run-through
//! tolerance (`points::RUN_THROUGH_TOLERANCE_MM`).
//!
//! The take-up block may also move an axis of the plane that does not
//! reverse, by its share of the normal axis' band (the normal axis' tables
//! move the tool across the plane too: 0.33 µm of X for Z's 6.84 µm on
//! bench/shop_map.py's map). That axis' command takes the same ramp, and
//! its lag fades as the normal axis crosses its band, which the offset
//! counts beside the normal axis' own.
//!
//! A take-up of the normal axis away from the S-curves (its command
//! turning inside the arc where the map's straightness across the plane
//! turns, or a plane axis' table switching) is spread the same way, the
//! ramp standing alone on the arc, within what a ramp centred on a
//! reversal may leave ([`ALONE_TOLERANCE_MM`]): only where the walk left a
//! take-up block (no fold, ramp or hold took it), so the ramp replaces a
//! stop.
//!
//! Where that lone ramp is refused and an S-curve lies within the ramp's
//! length of the take-up (Z's command turning half a millimetre before a
//! quarter point, as on the spirals' half circles), the ramp crosses that
//! S-curve as it crosses the one next to a take-up, within the same
//! bound. Where the S-curve's span and the take-up lie farther apart than
//! the shortest ramp can span with a piece to spare, the ramp is made
//! longer (flatter, its joins turn by less; its offset is checked all the
//! same).

use super::arcs::Transition;
use super::solve::solve_fixed_in;
use super::PointRecord;
use crate::error::ModelError;
use crate::model::{AxisCells, Directions, ErrorModel};
use volcomp_gcode::Vec3;

/// The motion `points::State::solve_targets` solved, kept in step: the
/// commands (each with the take-up written before it), the nominal
/// targets, the arc parameters of the pieces' ends, the direction state
/// and the ramp offset at the middle of each piece, the per-point records
/// and the S-curves.
pub(super) struct Solved<'a> {
    pub(super) commands: &'a mut Vec<(Vec3, Option<Vec3>)>,
    pub(super) targets: &'a mut Vec<Vec3>,
    pub(super) pieces: &'a mut Vec<f64>,
    pub(super) states: &'a mut Vec<Directions>,
    pub(super) ramp_mids: &'a mut Vec<Vec3>,
    pub(super) records: &'a mut Vec<PointRecord>,
    pub(super) transitions: &'a mut [Transition],
}

/// What the ramp is built from: the map, the solver method, the arc, the
/// first command's start, the quantizer of the written words, and the
/// limits (`piece_mm` the ramp's pieces, `kappa` the share of the
/// tangency tolerance its joins may turn by, `tangent` the planner's
/// whole tolerance for the normal axis, `tolerance_mm` the tool's bound).
pub(super) struct Setting<'a> {
    pub(super) model: &'a dyn ErrorModel,
    pub(super) method: super::solve::Method,
    pub(super) arc: &'a volcomp_gcode::Arc,
    pub(super) q_in: Vec3,
    pub(super) quantize: &'a dyn Fn(Vec3, Vec3) -> Vec3,
    pub(super) piece_mm: f64,
    pub(super) kappa: f64,
    pub(super) tangent: f64,
    pub(super) tolerance_mm: f64,
}

/// A take-up replaced by a ramp: the largest distance the ramp leaves the
/// tool from the path (mm, the S-curve's deviation included).
pub(super) struct Spread {
    pub(super) bound_mm: f64,
}

/// The largest share of the other axes' command a take-up spread here may
/// move (mm): their rounding, no take-up of their own.
const OTHER_AXES_MM: f64 = 0.02e-3;

/// The largest share of the normal axis' take-up its reversal may move
/// the other axes by (their part of its band: the normal axis' tables
/// move the tool across the plane too, 0.33 µm in X for Z's 6.84 µm on
/// the shop map), where those axes do not reverse: their command then
/// takes the same ramp, and the lag it carries fades as the normal axis
/// crosses its band (bench/eval/judge.py's band reading).
const CROSS_SHARE: f64 = 0.1;

/// How far the ramp may leave the tool from the path (mm), its offset
/// along the normal axis and the S-curve's own deviation across it added
/// as the hypotenuse: the product's 0.5 µm (docs/compensation.md,
/// "Reversals by path-control mode") less a tenth. Both errors are read
/// at the same place (the S-curve's end), where bench/eval/judge.py's
/// independent dead-band reading agrees with this one within 0.01 µm
/// (g2_d40, shop map, F6000); `points::RUN_THROUGH_TOLERANCE_MM` keeps a
/// fifth for a local model that leaves a lag out.
pub(super) const ACROSS_TOLERANCE_MM: f64 = 0.45e-3;

/// How far a ramp of a take-up away from the S-curves (a turn of the
/// normal axis' command inside the arc, the map's straightness across the
/// plane turning there) may leave the tool from the path (mm): what a ramp
/// centred on a reversal may leave (compensate/ramp_centre.rs
/// `TOLERANCE_MM`, 0.2 µm), whose place it takes where that ramp was
/// refused and a take-up block, a stop, would be written instead.
const ALONE_TOLERANCE_MM: f64 = super::ramp_centre::TOLERANCE_MM;

/// The smooth step `3u² − 2u³`, 0 before `u = 0` and 1 after `u = 1`.
fn smooth(u: f64) -> f64 {
    let u = u.clamp(0.0, 1.0);
    u * u * (3.0 - 2.0 * u)
}

/// Spreads every take-up block of the normal axis written right after an
/// S-curve (or before the piece right before one), or away from the
/// S-curves (module documentation), where its ramp keeps the tool within
/// the tolerance and the planner's tangency; returns one [`Spread`] per
/// take-up replaced. The motion's vectors grow by the ramp's inner points.
pub(super) fn spread_take_ups(
    cells: &mut AxisCells,
    m: &mut Solved<'_>,
    set: &Setting<'_>,
) -> Result<Vec<Spread>, ModelError> {
    let mut done = Vec::new();
    // From the last, so the indices of those before do not move.
    let order: Vec<usize> = (1..m.commands.len())
        .filter(|&k| m.commands[k].1.is_some())
        .collect();
    for &k in order.iter().rev() {
        if let Some(s) = spread_one(cells, m, set, k)? {
            done.push(s);
        }
    }
    Ok(done)
}

/// A point of the ramp: its arc parameter, the index of the command it
/// is (or, inserted, goes before), and whether it is inserted.
type RampPoint = (f64, usize, bool);

/// [`spread_take_ups`] for the take-up written before command `k`.
fn spread_one(
    cells: &mut AxisCells,
    m: &mut Solved<'_>,
    set: &Setting<'_>,
    k: usize,
) -> Result<Option<Spread>, ModelError> {
    let w = set.arc.plane.axes().2;
    let n = m.commands.len();
    if k < 1 || k >= n || m.pieces.len() != n || m.states.len() != n || m.ramp_mids.len() != n {
        return Ok(None);
    }
    // The S-curve's piece right before the take-up, or right after the
    // piece the take-up starts; none for a take-up away from the
    // S-curves (the ramp then stands alone on the arc, [`ALONE_TOLERANCE_MM`]).
    let tr = m
        .transitions
        .iter()
        .find(|tr| tr.index + 1 == k || tr.index == k + 1)
        .copied();
    if tr.is_none() && m.transitions.iter().any(|o| o.index.abs_diff(k) <= 1) {
        return Ok(None);
    }
    let Some(tu) = m.commands[k].1 else {
        return Ok(None);
    };
    let before = m.commands[k - 1].0;
    let delta = tu[w] - before[w];
    // The take-up's part across the plane (none within the rounding).
    let mut cross = Vec3::ZERO;
    for a in (0..3).filter(|a| *a != w) {
        let d = tu[a] - before[a];
        if d.abs() <= OTHER_AXES_MM {
            continue;
        }
        if m.states[k][a] != m.states[k - 1][a] || d.abs() > CROSS_SHARE * delta.abs() {
            return Ok(None);
        }
        cross[a] = d;
    }
    let (s_old, s_new) = (m.states[k - 1][w], m.states[k][w]);
    // A reversal of the normal axis, its take-up its new way.
    if s_old == s_new || delta == 0.0 || delta * s_new.sign() <= 0.0 {
        return Ok(None);
    }
    let len = set.arc.length();
    if !(len > 0.0 && set.kappa > 0.0 && set.piece_mm > 0.0) {
        return Ok(None);
    }
    let ramp_mm = (6.0 * delta.abs() * set.piece_mm / set.kappa).sqrt();
    let at = |j: usize| if j == 0 { 0.0 } else { m.pieces[j - 1] };
    let l_take = at(k);
    // A take-up away from the S-curves that no ramp of its own can
    // spread, where its ramp would reach an S-curve: the ramp then crosses
    // that S-curve as it crosses the one next to a take-up ([`near_scurve`]).
    let near = match tr {
        Some(_) => None,
        None => near_scurve(m, (l_take, len), ramp_mm),
    };
    let mut found = None;
    for tr in std::iter::once(tr).chain(near.map(Some)) {
        // (The S-curve's piece, its deviation, the ramp's tolerance.)
        let (scurve, deviation_mm, tolerance_mm) = match &tr {
            Some(tr) => (tr.index, tr.deviation_mm, set.tolerance_mm),
            None => (usize::MAX, 0.0, ALONE_TOLERANCE_MM),
        };
        // The S-curve's step along the normal axis is spread over its span as
        // a smooth step within the ramp (as `points::spread_normal_step` does
        // where no take-up follows): the ramp starts no later than the span.
        let (l_first, l_last) = match &tr {
            Some(tr) => {
                let (l_scurve, l_scurve_end) = (at(tr.index), m.pieces[tr.index]);
                let first = tr.spread.map_or(l_scurve, |(a, _)| a.min(l_scurve));
                (first.min(l_take), l_take.max(l_scurve_end))
            }
            None => (l_take, l_take),
        };
        let span = tr.as_ref().and_then(|tr| step_span(m, set, tr));
        // Starts tried: the earliest of the S-curve's start (its span's) and
        // the take-up, and back from it by pieces while the ramp still ends a
        // piece past both; the one leaving the tool nearest the path is kept.
        let mut best: Option<(f64, Vec<RampPoint>, Vec<Vec3>)> = None;
        // Where the S-curve's span and the take-up lie farther apart than
        // the shortest ramp leaves a piece past them, the ramp spans them
        // with a piece and a half to spare: a longer ramp turns its joins
        // by less, and its offset is bounded below all the same.
        let reach_mm = (l_last - l_first) * len + set.piece_mm;
        let ramp_mm = if reach_mm > ramp_mm {
            reach_mm + 0.5 * set.piece_mm
        } else {
            ramp_mm
        };
        let steps = (ramp_mm / set.piece_mm).floor() as usize;
        for step in 0..steps {
            let l0 = l_first - (step as f64) * set.piece_mm / len;
            let l1 = l0 + ramp_mm / len;
            if l0 < 0.0 || l1 >= 1.0 || (l1 - l_last) * len < set.piece_mm {
                break;
            }
            let Some(plan) = ramp_points(m, set, (l0, l1), (scurve, k)) else {
                continue;
            };
            let Some((cmds, news)) =
                ramp_commands(cells, m, set, (&plan, span), (l0, l1), (k, delta, cross))?
            else {
                continue;
            };
            let start = piece_start(m, set, plan[0].1);
            let Some(off) = standing_offset((&cmds, &news), start[w], (delta, w), cross) else {
                continue;
            };
            let bound = off.hypot(deviation_mm);
            if bound > tolerance_mm || !joins_tangent(m, set, &plan, &cmds, start) {
                continue;
            }
            if best.as_ref().is_none_or(|b| bound < b.0) {
                best = Some((bound, plan, cmds));
            }
        }
        if let Some((bound, plan, cmds)) = best {
            found = Some((bound, plan, cmds, span));
            break;
        }
    }
    let Some((bound, plan, cmds, span)) = found else {
        return Ok(None);
    };
    apply(m, set, (&plan, &cmds, span), (k, delta, s_new, cross));
    Ok(Some(Spread { bound_mm: bound }))
}

/// The S-curve nearest a take-up at arc parameter `l_take` (the arc `len`
/// mm long) whose piece lies within the ramp's length `ramp_mm` of it, if
/// any: a ramp standing alone there would run into it, which
/// [`ramp_points`] refuses.
fn near_scurve(m: &Solved<'_>, (l_take, len): (f64, f64), ramp_mm: f64) -> Option<Transition> {
    let gap_mm = |tr: &Transition| {
        let lo = if tr.index == 0 {
            0.0
        } else {
            m.pieces[tr.index - 1]
        };
        let hi = m.pieces[tr.index];
        (lo - l_take).max(l_take - hi).max(0.0) * len
    };
    m.transitions
        .iter()
        .filter(|tr| tr.index < m.pieces.len() && gap_mm(tr) < ramp_mm)
        .min_by(|a, b| gap_mm(a).total_cmp(&gap_mm(b)))
        .copied()
}

/// Where piece `j` starts as written: its take-up where one is written
/// before it, else the command before it (the motion's start for the
/// first).
fn piece_start(m: &Solved<'_>, set: &Setting<'_>, j: usize) -> Vec3 {
    match (m.commands[j].1, j) {
        (Some(tu), _) => tu,
        (None, 0) => set.q_in,
        (None, _) => m.commands[j - 1].0,
    }
}

/// The S-curve's step along the normal axis spread over its span: the
/// span's ends `a`, `b` and the S-curve's `lo`, `hi` (arc parameters), and
/// the step its commands make beyond the arc's own progress (mm).
#[derive(Clone, Copy)]
struct StepSpan {
    a: f64,
    b: f64,
    lo: f64,
    hi: f64,
    step_mm: f64,
}

impl StepSpan {
    /// The offset at `l` that turns the step as written (linear across
    /// the S-curve) into the smooth step over the span.
    fn offset(&self, l: f64) -> f64 {
        if l <= self.a || l >= self.b {
            return 0.0;
        }
        let h = ((l - self.lo) / (self.hi - self.lo)).clamp(0.0, 1.0);
        self.step_mm * (smooth((l - self.a) / (self.b - self.a)) - h)
    }
}

/// The span of the S-curve `tr` ([`StepSpan`]), where it has one.
fn step_span(m: &Solved<'_>, set: &Setting<'_>, tr: &Transition) -> Option<StepSpan> {
    let w = set.arc.plane.axes().2;
    let (a, b) = tr.spread?;
    let lo = if tr.index == 0 {
        0.0
    } else {
        m.pieces[tr.index - 1]
    };
    let hi = m.pieces[tr.index];
    if !(a < lo && hi < b && hi > lo) {
        return None;
    }
    let own = set.arc.point_at(hi)[w] - set.arc.point_at(lo)[w];
    let from = if tr.index == 0 {
        set.q_in
    } else {
        m.commands[tr.index - 1].0
    };
    let step_mm = m.commands[tr.index].0[w] - from[w] - own;
    Some(StepSpan {
        a,
        b,
        lo,
        hi,
        step_mm,
    })
}

/// The ramp's points from `l0` to `l1` (arc parameters): the commands
/// there, and points inserted about a piece apart where no command is
/// within half a piece; none inside the S-curve (its piece ends at
/// command `scurve`; `usize::MAX` for a ramp with no S-curve), which the
/// writer writes whole. `None` where another
/// S-curve, take-up or ramp lies on it.
fn ramp_points(
    m: &Solved<'_>,
    set: &Setting<'_>,
    (l0, l1): (f64, f64),
    (scurve, k): (usize, usize),
) -> Option<Vec<RampPoint>> {
    let len = set.arc.length();
    let n = m.pieces.len();
    let half = 0.5 * set.piece_mm / len;
    // The pieces the ramp runs on: from the one holding `l0` to the one
    // holding `l1`.
    let first = m.pieces.partition_point(|p| *p < l0 - 1e-12);
    let last = m.pieces.partition_point(|p| *p < l1 - 1e-12);
    if last + 1 >= n {
        return None;
    }
    if (first..=last + 1).any(|j| m.ramp_mids[j] != Vec3::ZERO)
        || (first + 1..=last + 1).any(|j| j != k && m.commands[j].1.is_some())
        || m.transitions
            .iter()
            .any(|tr| tr.index != scurve && tr.index >= first && tr.index <= last + 1)
    {
        return None;
    }
    let mut pts: Vec<RampPoint> = (first..=last)
        .filter(|&j| m.pieces[j] >= l0 - 1e-12 && m.pieces[j] <= l1 + 1e-12)
        .map(|j| (m.pieces[j], j, false))
        .collect();
    let steps = (((l1 - l0) * len / set.piece_mm).round() as usize).max(1);
    for i in 0..=steps {
        let l = l0 + (l1 - l0) * i as f64 / steps as f64;
        let j = m.pieces.partition_point(|p| *p < l - 1e-12);
        let lo = if j == 0 { 0.0 } else { m.pieces[j - 1] };
        if j >= n || j == scurve || l - lo < half || m.pieces[j] - l < half {
            continue;
        }
        if pts.iter().any(|p| (p.0 - l).abs() < half) {
            continue;
        }
        pts.push((l, j, true));
    }
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    (!pts.is_empty()).then_some(pts)
}

/// The ramp's written commands at its points and the new state's solutions
/// there.
type RampCommands = (Vec<Vec3>, Vec<Vec3>);

/// The commands the ramp writes at its points and the new state's
/// solution there (the command the normal axis would have engaged in its
/// new direction): a kept command is moved by the ramp's offset, an
/// inserted one solved first in the state of the piece it splits.
fn ramp_commands(
    cells: &mut AxisCells,
    m: &Solved<'_>,
    set: &Setting<'_>,
    (plan, span): (&[RampPoint], Option<StepSpan>),
    (l0, l1): (f64, f64),
    (k, delta, cross): (usize, f64, Vec3),
) -> Result<Option<RampCommands>, ModelError> {
    let w = set.arc.plane.axes().2;
    let mut cmds = Vec::with_capacity(plan.len());
    let mut news = Vec::with_capacity(plan.len());
    let mut prev = piece_start(m, set, plan[0].1);
    // Once the command has turned its new way, a step back its old way
    // of the written resolution stands instead (the rounding of a nearly
    // flat command; a second reversal the carriage would take up).
    let new_sign = delta.signum();
    let mut turned = false;
    for &(l, j, inserted) in plan {
        let solved = if inserted {
            let t = set.arc.point_at(l);
            solve_fixed_in(
                cells,
                set.model,
                set.method,
                t,
                m.states[j],
                [false; 3],
                prev,
            )?
            .q_mm
        } else {
            m.commands[j].0
        };
        if !(0..3).all(|a| solved[a].is_finite()) {
            return Ok(None);
        }
        let mut new = solved;
        if j < k {
            new[w] += delta;
            new += cross;
        }
        let rest = 1.0 - smooth((l - l0) / (l1 - l0));
        let mut q = new - cross * rest;
        q[w] -= delta * rest;
        if let Some(sp) = span {
            q[w] += sp.offset(l);
        }
        let mut q = (set.quantize)(q, prev);
        // An axis of the plane carrying the take-up's part keeps its way.
        if (0..3).any(|a| cross[a] != 0.0 && (q[a] - prev[a]) * m.states[j][a].sign() < 0.0) {
            return Ok(None);
        }
        let step = (q[w] - prev[w]) * new_sign;
        if step > 0.0 {
            turned = true;
        } else if turned && step < 0.0 {
            q[w] = prev[w];
        }
        cmds.push(q);
        news.push(new);
        prev = q;
    }
    Ok(Some((cmds, news)))
}

/// The tool's largest offset along the normal axis `w` on the ramp (mm),
/// in the dead-band reading (module documentation): `cmds` the written
/// commands, `news` the new state's solutions, `start` the normal axis'
/// command before the ramp, `delta` the take-up (the band, its new way).
/// In the new state's terms the tool is at the command `+ Δ` while the
/// carriage follows its old way, at the turning command `+ Δ` while it
/// stands, at the command once the command has travelled `|Δ|` back; the
/// offset is that less the new state's solution. `None` where the
/// command turns its old way again after its turn, or the band is not
/// crossed by the ramp's end.
fn standing_offset(
    (cmds, news): (&[Vec3], &[Vec3]),
    start: f64,
    (delta, w): (f64, usize),
    cross: Vec3,
) -> Option<f64> {
    let old = -delta.signum();
    let (mut peak, mut last) = (start, start);
    let (mut turned, mut engaged) = (false, false);
    let mut worst = 0.0f64;
    // The other axes' offset: the command's from the new state's solution
    // and the take-up's part across the plane not yet faded, in the share
    // of the band the normal axis has still to cross.
    let across = |q: &Vec3, new: &Vec3, left: f64| -> f64 {
        if cross == Vec3::ZERO {
            return 0.0;
        }
        (0..3)
            .filter(|a| *a != w)
            .map(|a| {
                let e = q[a] - new[a] + cross[a] * left;
                e * e
            })
            .sum::<f64>()
    };
    for (q, new) in cmds.iter().zip(news) {
        let c = q[w];
        if !turned {
            if (c - peak) * old >= 0.0 {
                peak = c;
                last = c;
                let e = c + delta - new[w];
                worst = worst.max((e * e + across(q, new, 1.0)).sqrt());
                continue;
            }
            turned = true;
        }
        if (c - last) * old > 1e-12 {
            return None;
        }
        last = c;
        let travel = (peak - c) * old;
        engaged = engaged || travel >= delta.abs() * (1.0 - 1e-9);
        let tool = if engaged { c } else { peak + delta };
        let left = if engaged {
            0.0
        } else {
            1.0 - travel / delta.abs()
        };
        let e = tool - new[w];
        worst = worst.max((e * e + across(q, new, left)).sqrt());
    }
    engaged.then_some(worst)
}

/// Whether every join on the ramp, from the command before its first
/// point to the one after its last, turns the normal axis' slope by no
/// more than the planner's tangency tolerance (tp.c `tpSetupTangent`),
/// read on the written commands (the compensation's own turn included):
/// the ramp's own joins take the share `kappa` by its length, the
/// S-curve's ends, a piece the ramp cannot split, take more.
fn joins_tangent(
    m: &Solved<'_>,
    set: &Setting<'_>,
    plan: &[RampPoint],
    cmds: &[Vec3],
    start: Vec3,
) -> bool {
    let w = set.arc.plane.axes().2;
    let len = set.arc.length();
    let first = plan[0].1;
    let (last_l, last_j, last_inserted) = plan[plan.len() - 1];
    let after = if last_inserted { last_j } else { last_j + 1 };
    let l_start = if first == 0 { 0.0 } else { m.pieces[first - 1] };
    let mut pts: Vec<(f64, f64)> = vec![(l_start, start[w])];
    pts.extend(plan.iter().zip(cmds).map(|(p, q)| (p.0, q[w])));
    if after < m.pieces.len() && m.pieces[after] > last_l {
        pts.push((m.pieces[after], m.commands[after].0[w]));
    }
    let slope = |a: (f64, f64), b: (f64, f64)| (b.1 - a.1) / ((b.0 - a.0) * len);
    pts.windows(3)
        .all(|p| (slope(p[1], p[2]) - slope(p[0], p[1])).abs() <= set.tangent)
}

/// Writes the ramp into the motion: kept commands moved, inserted ones
/// added (with their state, record and parameter), the take-up block
/// gone, the S-curves after shifted, and on each piece the ramp's offset
/// at its middle, where the writer reads its third point.
fn apply(
    m: &mut Solved<'_>,
    set: &Setting<'_>,
    (plan, cmds, span): (&[RampPoint], &[Vec3], Option<StepSpan>),
    (k, delta, s_new, cross): (usize, f64, crate::model::Direction, Vec3),
) {
    let w = set.arc.plane.axes().2;
    let (l0, l1) = (plan[0].0, plan[plan.len() - 1].0);
    m.commands[k].1 = None;
    if let Some(r) = m.records.get_mut(k) {
        r.take_up = false;
    }
    for (&(l, j, inserted), q) in plan.iter().zip(cmds).rev() {
        if inserted {
            let mut rec = m.records[j];
            rec.target_mm = set.arc.point_at(l);
            rec.command_mm = *q;
            rec.take_up = false;
            rec.reversed = [false; 3];
            let state = m.states[j];
            // A take-up written before the piece stays at its start.
            let tu = m.commands[j].1.take();
            rec.take_up = tu.is_some();
            if let Some(r) = m.records.get_mut(j) {
                r.take_up = false;
            }
            m.commands.insert(j, (*q, tu));
            m.targets.insert(j, rec.target_mm);
            m.pieces.insert(j, l);
            m.states.insert(j, state);
            m.ramp_mids.insert(j, Vec3::ZERO);
            m.records.insert(j, rec);
            for tr in m.transitions.iter_mut().filter(|tr| tr.index >= j) {
                tr.index += 1;
            }
        } else {
            m.commands[j].0 = *q;
            m.records[j].command_mm = *q;
        }
    }
    let first = m.pieces.partition_point(|p| *p < l0 - 1e-12);
    let last = m.pieces.partition_point(|p| *p < l1 - 1e-12);
    for j in first..=last.min(m.pieces.len() - 1) {
        let lo = if j == 0 { 0.0 } else { m.pieces[j - 1] };
        let mid = 0.5 * (lo + m.pieces[j]);
        let u = (mid - l0) / (l1 - l0);
        let share = if m.states[j][w] == s_new {
            -(1.0 - smooth(u))
        } else {
            smooth(u)
        };
        m.ramp_mids[j] += cross * share;
        m.ramp_mids[j][w] += delta * share + span.map_or(0.0, |sp| sp.offset(mid));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn z(v: &[f64]) -> Vec<Vec3> {
        v.iter().map(|&z| Vec3::new(0.0, 0.0, z)).collect()
    }

    #[test]
    fn the_carriage_stands_across_the_ramp_and_leaves_the_targets_step() {
        // Z turns from up to down, its band 1 (the take-up −1), the ramp
        // 3u² − 2u³ at u = 0, ¼, ½, ¾, 1 (σ = 0, 0.15625, 0.5, 0.84375,
        // 1) over a new-state target that steps up 0.3 at the middle and
        // falls after: the command is the target + (1 − σ). By hand the
        // carriage follows up to the first point (command 1, the peak),
        // stands at 1 − 1 = 0 while the command falls by less than 1
        // (0.15625, 0.2, 0.74375), and is engaged at the last (1.1): off
        // by 0, 0, 0.3, 0.1, 0.
        let news = z(&[0.0, 0.0, 0.3, 0.1, -0.1]);
        let cmds = z(&[1.0, 0.84375, 0.8, 0.25625, -0.1]);
        let off = standing_offset((&cmds, &news), 1.0, (-1.0, 2), Vec3::ZERO).unwrap();
        assert!((off - 0.3).abs() < 1e-12, "{off}");
        // The target ending 0.1 above where the carriage stands: the
        // command has travelled 0.9 of the band by the ramp's end.
        let news = z(&[0.0, 0.0, 0.3, 0.2, 0.1]);
        let cmds = z(&[1.0, 0.84375, 0.8, 0.35625, 0.1]);
        assert_eq!(
            standing_offset((&cmds, &news), 1.0, (-1.0, 2), Vec3::ZERO),
            None
        );
        // A command that turns back up after its turn: a second reversal.
        let cmds = z(&[1.0, 0.8, 0.9, 0.2, -0.1]);
        assert_eq!(
            standing_offset((&cmds, &z(&[0.0; 5])), 1.0, (-1.0, 2), Vec3::ZERO),
            None
        );
    }

    #[test]
    fn the_s_curves_step_is_spread_over_its_span_as_a_smooth_step() {
        // A step of 0.3 across the S-curve from 0.4 to 0.6, spread over
        // 0.2 to 0.8: the offset is 0.3·(σ − H), by hand 0 at the span's
        // ends, 0.3·σ(1/3) = 0.3·7/27 before the S-curve at 0.4, and
        // 0.3·(0.5 − 0.5) = 0 at its middle.
        let sp = StepSpan {
            a: 0.2,
            b: 0.8,
            lo: 0.4,
            hi: 0.6,
            step_mm: 0.3,
        };
        assert_eq!(sp.offset(0.2), 0.0);
        assert_eq!(sp.offset(0.8), 0.0);
        assert!((sp.offset(0.4) - 0.3 * 7.0 / 27.0).abs() < 1e-12);
        assert!(sp.offset(0.5).abs() < 1e-12);
        assert!((sp.offset(0.6) + 0.3 * 7.0 / 27.0).abs() < 1e-12);
    }
}
