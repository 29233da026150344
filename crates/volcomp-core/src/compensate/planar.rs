//! Corners next to an arc stay planar under G64 (docs/compensation.md,
//! "Corners next to an arc stay planar (G64)").
//!
//! LinuxCNC 2.9 joins two moves at a G64 corner with a blend arc only where
//! the corner's binormal (`u_tan1 × u_tan2`, src/emc/tp/blendmath.c,
//! `blendInit3FromArcArc`) is colinear with each arc's normal within
//! `TP_ANGLE_EPSILON` = 1e-6 rad (src/emc/tp/tp.c, `tpCreateArcArcBlend`,
//! `pmUnitCartsColinear`); elsewhere it falls back to the slower parabolic
//! blend. A compensated arc piece carries a normal-axis word (the map's
//! correction changes along it): a helix whose tangent leaves the plane by
//! about 1e-4 rad, so the blend arc is lost.
//!
//! At a corner between two arcs of one plane (neither a helix of its own),
//! the part of each side within the blend's reach is written planar: the
//! piece next to the corner is split at the reach's edge, the part at the
//! corner keeps the corner's normal coordinate, and the rest of the piece
//! carries the normal axis' change. The tool then leaves the path along the
//! normal by the correction's change over the planar part, at most at the
//! split; that is bounded by the contour tolerance (the planar part is
//! shortened to keep within it, or the piece is kept as solved).
//!
//! A corner from an arc to a line in its plane is alike (tp.c
//! `tpCreateArcLineBlend`: the binormal colinear with the arc's normal): the
//! arc's end is written planar where the line's first piece is planar as
//! solved and the planar part covers the blend's reach.
//!
//! The arc after the corner knows the corner when it is written (its
//! start side). The arc before it does not: its line is held back
//! (compensate/idle.rs, `IdleHold`) with what its last piece's planar
//! variant needs ([`PlanarEnd`]), and the variant is written where the next
//! motion makes such a corner.
//!
//! A line before an arc of its plane ends planar in compensate/line_arc.rs
//! and sets `planar_before` for the arc's start as an arc ending planar
//! does.

use super::arcs::{piece_center, sub_arc};
use super::frame::Frame;
use super::lines::{ArcWords, OutMode};
use super::walk::Place;
use super::{command_error, State};
use crate::error::CompensationError;
use crate::model::{Directions, ErrorModel};
use volcomp_gcode::number::NumberStyle;
use volcomp_gcode::{Arc, Motion, MotionKind, PathMode, Vec3};

/// How many lengths of the planar part are tried, each shortened from the
/// last in proportion to how far it moved the split ([`shortened_mm`]).
const TRIES: usize = 4;

/// What a move along the normal measured between two written numbers may
/// exceed the tolerance by: their rounding in binary (mm).
const QUANTUM_MM: f64 = 1e-9;

/// Which end of a piece is written planar.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Side {
    /// The piece's start (the corner is before the arc).
    Start,
    /// The piece's end (the corner is after the arc).
    End,
}

/// A piece of an arc split in two, one part planar ([`State::planar_split`]).
#[derive(Debug, Clone, Copy)]
pub(super) struct Split {
    /// Arc parameter of the split.
    pub(super) at: f64,
    /// The split's nominal point.
    pub(super) target_mm: Vec3,
    /// The split's command: solved, with the normal coordinate of the
    /// piece's planar end.
    pub(super) q_mm: Vec3,
    /// The words of the part before the split and of the part after it.
    pub(super) words: [ArcWords; 2],
    /// How far the split's command was moved along the normal from where
    /// it was solved (mm): the tool's largest distance from the path there.
    pub(super) moved_mm: f64,
}

/// What writing the last piece of an arc planar at its end takes, kept with
/// its held line until the next motion is known.
#[derive(Debug, Clone)]
pub(super) struct PlanarEnd {
    /// The block's nominal arc and the arc parameter its last piece starts at.
    pub(super) arc: Arc,
    pub(super) piece_from: f64,
    /// The last piece's commanded start and end.
    pub(super) from_mm: Vec3,
    pub(super) to_mm: Vec3,
    /// The direction state the last piece was solved in.
    pub(super) state: Directions,
    pub(super) frame: Frame,
    pub(super) style: NumberStyle,
    pub(super) line: u64,
    /// The ending of the piece's line, and of a line inserted before it.
    pub(super) ending: Vec<u8>,
    pub(super) line_ending: Vec<u8>,
    pub(super) tool_length_offset_mm: Vec3,
    pub(super) radius_style: bool,
    pub(super) turn_tolerance: Option<f64>,
    pub(super) mode: PathMode,
    /// `Some(m)` where the last piece is the arc's whole line (an arc of one
    /// piece, [`plain_arc_line`]): its planar variant is written as two
    /// inserted arcs after output motion mode `m`.
    pub(super) mode_before: Option<Option<OutMode>>,
}

/// Whether an arc line of one piece may be written as two inserted arcs
/// (its planar variant, [`State::planar_end_text`]) without losing
/// anything: its words are G2/G3 and the end and centre words only, and it
/// carries no comment and no block delete.
pub(super) fn plain_arc_line<'a>(
    mut words: impl Iterator<Item = &'a volcomp_gcode::lexer::Word>,
    content: &[u8],
) -> bool {
    !content.iter().any(|b| matches!(b, b'(' | b';' | b'/'))
        && words.all(|w| match w.letter {
            b'G' => w.value == 2.0 || w.value == 3.0,
            b'X' | b'Y' | b'Z' | b'I' | b'J' | b'K' | b'R' => true,
            _ => false,
        })
}

/// Whether LinuxCNC joins a G64 corner from unit tangent `t1` into the arc
/// `m` with a parabolic blend, having no blend arc for it: a blend arc into
/// an arc needs the corner's binormal `t1 × t2` colinear with the arc's
/// normal within `TP_ANGLE_EPSILON` = 1e-6 rad (src/emc/tp/tp.c,
/// `tpCreateLineArcBlend` and `tpCreateArcArcBlend`, `pmUnitCartsColinear`;
/// the planner model: crates/volcomp-core/src/plan/blend.rs). A corner out
/// of a helix into a flat turn (the last turn of a helical bore) or out of
/// a plunge into an arc is such a corner; so is any corner into a nominal
/// helix. `false` for a line after the corner (the arc before it, whose
/// normal decides there, is not known here) and where the tangents are
/// parallel (no corner).
pub(super) fn parabolic_into(t1: Vec3, m: &Motion) -> bool {
    let MotionKind::Arc(arc) = m.kind else {
        return false;
    };
    let (t2, _) = super::points::tangents(m);
    let b = t1.cross(t2);
    let len = b.norm();
    // No corner (parallel tangents), or a tangent that is not a number.
    if len.is_nan() || len <= 1e-12 {
        return false;
    }
    let b = b * (1.0 / len);
    let mut n = Vec3::ZERO;
    n[arc.plane.axes().2] = 1.0;
    let tol = 1e-6 * 1e-6;
    !((b - n).norm_squared() < tol || (b + n).norm_squared() < tol)
}

/// Whether LinuxCNC stops at the join from unit tangent `t1` to `t2`: a
/// reversal within 2° (src/emc/tp/tp.c `tpSetupTangent`: `|t1 + t2|²`
/// under `(2π/180)²` ends the move in a stop). No blend is kept there by a
/// planar start.
pub(super) fn stops_at(t1: Vec3, t2: Vec3) -> bool {
    (t1 + t2).norm_squared() < (std::f64::consts::PI * (2.0 / 180.0)).powi(2)
}

/// Whether the take-up of the normal axis `w` held at an arc's first
/// target ([`normal_held_at_start`]), a step of `step_mm` of its command,
/// folds gently enough into the next piece, `piece_mm` long, at the feed
/// (mm/min): its turn of the path there, `step / piece`, within the
/// planner's tangency tolerance of a join of lines on that axis (tp.c
/// `tpSetupTangent`, [`super::PlannerLimits::tangent_tolerance`]; the
/// arc's tangential share, which halves it, left out). Measured on the
/// planner model (set a's R arcs in G91, shop map, F6000): an 8.6 µm step
/// over the 11.9 mm piece (0.72 mrad) cost 1 ms, 12 µm (1.0 mrad) 25 ms,
/// 20 µm (1.7 mrad) 127 ms; over a 2.6 mm piece (set b's mixed R arcs,
/// 3.5 mrad) +8.8 % of the cutting time. Without a feed per minute, no.
pub(super) fn fold_after_hold_is_gentle(
    planner: &super::PlannerLimits,
    feed_mm_min: Option<f64>,
    step_mm: f64,
    piece_mm: f64,
    w: usize,
) -> bool {
    let Some(f) = feed_mm_min.filter(|f| *f > 0.0) else {
        return false;
    };
    piece_mm > 0.0 && step_mm / piece_mm <= planner.tangent_tolerance(f / 60.0, false)[w]
}

/// Under G64 without P, the first target of an arc after a planar corner
/// (`State::planar_corner_normal`, the plane's normal axis `w`) with the
/// normal axis' reversal held: `point` (solved for `t_mm` from the command
/// `q_prev` in the state `s_prev`) solved again with `w` at its command in
/// its old direction, the other axes as `point` turned them (their own
/// take-ups, in the plane, stay); `None` where `w` does not reverse there or
/// the hold leaves the tool further from the target than `w`'s band (its
/// reversal value, what G64's fold may leave at a reversal), `w` beyond its
/// band, or the free axes further than the point did (solve.rs
/// `held_solve`).
///
/// Folded into the first piece, the take-up moves the normal axis there:
/// the piece is a helix, the corner's binormal leaves the arcs' normal and
/// LinuxCNC 2.9 joins the corner with a parabolic blend instead of a blend
/// arc (src/emc/tp/tp.c `tpCreateArcArcBlend`, `pmUnitCartsColinear`).
/// Held, the first piece stays planar and the take-up folds into the next
/// piece, past the blend's reach, whose join inside the arc LinuxCNC takes
/// as tangent where the fold's slope is as gentle as the piece is long
/// (`tpSetupTangent`).
pub(super) fn normal_held_at_start(
    cells: &mut crate::model::AxisCells,
    model: &dyn ErrorModel,
    (method, quantize): (super::solve::Method, &dyn Fn(Vec3) -> Vec3),
    (t_mm, q_prev, s_prev): (Vec3, Vec3, Directions),
    point: &super::solve::PointSolution,
    w: usize,
) -> Result<Option<super::solve::PointSolution>, crate::error::ModelError> {
    if point.s[w] == s_prev[w] || point.held[w] {
        return Ok(None);
    }
    let hold = [0, 1, 2].map(|a| a == w);
    let band_um = super::solve::bands_um(cells, model, (q_prev, s_prev), hold)?;
    let mut s = point.s;
    s[w] = s_prev[w];
    super::solve::held_solve(
        cells,
        model,
        (method, quantize),
        (t_mm, s, hold),
        (q_prev, s_prev),
        (band_um[w] * 1e-3, band_um, point.residual_um),
    )
}

/// Under G64 without P, the shortest lead piece (mm) for a take-up at the
/// start of a move after a corner LinuxCNC blends parabolically
/// ([`parabolic_into`]): as long as the take-up's reach allows
/// ([`super::points::TAKE_UP_REACH_MM`], at most half the move), since the
/// parabolic blend slows with the piece after it. It overlaps both pieces
/// at once and runs into the next at no more than `√(a_t · ℓ / 2)` for a
/// piece of `ℓ` (`tpComputeBlendVelocity`, src/emc/tp/tp.c: the triangle
/// speed over half a piece not yet finalized; the planner model's
/// `parabolic_velocity`): 6.8 mm/s after a 0.184 mm piece on an arc
/// (`a_t` = 500 mm/s²), 15.8 mm/s after 1 mm, where the original's whole
/// move gave the programmed feed. 0 elsewhere (the blend-arc rule,
/// `Run::protect_mm`, applies there).
pub(super) fn lead_floor_after_parabolic_mm(
    rule: super::TakeUpRule,
    run: &super::points::Run,
    index: usize,
) -> f64 {
    if index == 0 && run.parabolic_before && rule == super::TakeUpRule::Always {
        super::points::TAKE_UP_REACH_MM.min(0.5 * run.length_mm)
    } else {
        0.0
    }
}

/// How far the planar part of a line before an arc of its plane, or of the
/// arc's start after it, may leave the path along the normal (mm): the
/// correction's change over it, at most at its split. Under G64 without
/// P ([`super::TakeUpRule::Always`]) the 0.4 µm a ramp may leave there too
/// ([`super::points::RUN_THROUGH_TOLERANCE_MM`]: the product's 0.5 µm away
/// from reversals less a fifth): the planar part then reaches four times
/// as far along a steady change, and the blend arc LinuxCNC puts at the
/// corner takes at most a third of it (blendmath.c
/// `blendInit3FromLineArc`, `phi2_max`). Elsewhere the mode's contour
/// tolerance (the program asked for the path).
pub(super) fn planar_tolerance_mm(options: &super::CompensateOptions, mode: PathMode) -> f64 {
    let contour_mm = options.arc_tolerances_mm(mode).0;
    match options.take_up_rule(mode) {
        super::TakeUpRule::Always => contour_mm.max(super::points::RUN_THROUGH_TOLERANCE_MM),
        _ => contour_mm,
    }
}

/// Under G64 and G64 P, half the planner's tangency tolerance in the plane
/// of `arc` at the run's feed (tp.c `tpSetupTangent`, as
/// [`super::points::piece_turn_tolerance`] under G61): how far a chord
/// written for a piece of `arc` may turn from the arc's tangents at its
/// ends before it is kept an arc ([`chord_turn_center`]); `None` under G61
/// and G61.1 (their rule is `piece_turn_tolerance`'s) and without a feed.
pub(super) fn chord_turn_tolerance(
    options: &super::CompensateOptions,
    run: &super::points::Run,
    arc: &Arc,
) -> Option<f64> {
    let v_mm_s = run.feed_mm_min? / 60.0;
    if matches!(
        options.take_up_rule(run.mode),
        super::TakeUpRule::Exact { .. }
    ) {
        return None;
    }
    let (u, v, _) = arc.plane.axes();
    let tol = options.planner.tangent_tolerance(v_mm_s, true);
    Some(0.5 * tol[u].min(tol[v]))
}

/// The centre to write for an arc piece that [`piece_center`] would write
/// as a G1 chord (its sagitta within the chord tolerance), where that
/// chord turns from the arc's tangent at its ends (by half the piece's
/// sweep) by more than `turn` ([`chord_turn_tolerance`]): LinuxCNC takes
/// such a join as a corner (tp.c `tpSetupTangent`) and blends it, under
/// G64 at a speed the piece's length caps (a piece of 0.07 mm on a
/// spiral's half circle is two corners of 3 mrad). Kept an arc, the piece
/// joins its neighbours tangent. The centre is `piece_center`'s with no
/// chord tolerance (the circle through the three commanded points, or the
/// nominal one moved by the mean correction of the ends). `None` where the
/// chord turns less, or without `turn`.
pub(super) fn chord_turn_center(
    piece: &Arc,
    ends: (Vec3, Vec3, Vec3),
    turn: Option<f64>,
) -> Option<Vec3> {
    let k = turn?;
    if 0.5 * piece.sweep_rad.abs() > k {
        piece_center(piece, ends, 0.0, None)
    } else {
        None
    }
}

/// Whether a line's first piece, commanded from `from`, keeps the normal
/// coordinate (axis `w`) of its start: LinuxCNC's blend arc between an arc
/// and a line needs the line in the arc's plane (tp.c
/// `tpCreateArcLineBlend`: the corner's binormal colinear with the arc's
/// normal).
pub(super) fn line_starts_planar(commands: &[(Vec3, Option<Vec3>)], from: Vec3, w: usize) -> bool {
    matches!(commands.first(), Some((q, None)) if q[w] == from[w])
}

/// Whether `m` is a line of feed that does not move `plane`'s normal axis
/// (nominally in the plane).
fn planar_line(m: &Motion, plane: volcomp_gcode::Plane) -> bool {
    let (u, v, w) = plane.axes();
    matches!(m.kind, MotionKind::Feed)
        && m.start[w] == m.end[w]
        && (m.start[u] != m.end[u] || m.start[v] != m.end[v])
}

/// Whether a motion is an arc of `plane` without a rise of its own (a
/// nominal helix is not planar in the original either).
pub(super) fn planar_arc(m: &Motion, plane: volcomp_gcode::Plane) -> Option<Arc> {
    match m.kind {
        MotionKind::Arc(a)
            if a.plane == plane && a.start[plane.axes().2] == a.end[plane.axes().2] =>
        {
            Some(a)
        }
        _ => None,
    }
}

/// The shortest part of `arc` (mm) written as an arc: its sagitta
/// `r (1 − cos(θ/2))` over `chord_tolerance_mm` (as `arcs::sagitta_mm`
/// measures it), with a hundredth to spare; a shorter part is written as a
/// chord, whose ends turn from the arc's tangent by half its sweep.
/// Infinite where no part of the arc is that deep.
pub(super) fn shortest_arc_mm(arc: &Arc, chord_tolerance_mm: f64) -> f64 {
    let r = arc.start_radius().max(arc.end_radius());
    let sweep = arc.sweep_rad.abs();
    if !(r > chord_tolerance_mm && sweep > 0.0) {
        return f64::INFINITY;
    }
    let sweep_min = 2.0 * (1.0 - chord_tolerance_mm / r).acos();
    1.01 * sweep_min / sweep * arc.length()
}

/// Whether the normal coordinate `split` lies between the piece's ends `a`
/// and `b` (inclusive): the planar part then moves the normal axis in the
/// direction the piece was solved in, or not at all.
pub(super) fn between(a: f64, split: f64, b: f64) -> bool {
    (split - a) * (b - split) >= 0.0
}

/// The length (mm) of the planar part that keeps the tool within
/// `tolerance_mm` of the path along the normal, from a first try of
/// `length_mm` that moved the split's command by `moved_mm`: the
/// correction's change taken as linear along the piece, shortened by a
/// further tenth for its curvature.
pub(super) fn shortened_mm(length_mm: f64, moved_mm: f64, tolerance_mm: f64) -> f64 {
    if moved_mm <= tolerance_mm {
        return length_mm;
    }
    0.9 * length_mm * tolerance_mm / moved_mm
}

impl State<'_> {
    /// The piece of `arc` from parameter `l_a` to `l_b`, commanded from
    /// `from` to `to` in direction state `state`, split `reach_mm` from its
    /// `side` with the part there planar (its normal coordinate that of
    /// the piece's end on that side). `None` where the planar part would be
    /// shorter than the shortest piece, where the split's command moves
    /// along the normal by more than `tolerance_mm` even on a shortened
    /// part, where the normal axis would turn back at the split, or where
    /// either part is not written as an arc the controller reads.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn planar_split(
        &mut self,
        model: &dyn ErrorModel,
        at: (&Frame, NumberStyle, u64),
        arc: &Arc,
        (l_a, l_b): (f64, f64),
        (from, to): (Vec3, Vec3),
        state: Directions,
        (side, reach_mm, tolerance_mm): (Side, f64, f64),
        (radius_style, turn_tolerance): (bool, Option<f64>),
    ) -> Result<Option<Split>, CompensationError> {
        let (frame, style, line) = at;
        let options = self.walk.options;
        let file = self.walk.file;
        let min_mm = options.arc_tolerances_mm(PathMode::ExactPath).1.max(1e-6);
        let w = arc.plane.axes().2;
        let length_mm = arc.length();
        let piece_mm = (l_b - l_a) * length_mm;
        let keep = match side {
            Side::Start => from[w],
            Side::End => to[w],
        };
        let solve = |t: Vec3| {
            super::solve::solve_fixed(model, options.method, t, state, [false; 3], Vec3::ZERO)
                .map(|s| s.q_mm)
                .map_err(|source| command_error(model, file, line, t, source))
        };
        // Each part stays an arc: no shorter than the shortest piece nor
        // than the shortest part whose sagitta exceeds the chord tolerance
        // (shorter, it would be written as a chord: `piece_center`). A
        // reach shorter than that is lengthened to it: LinuxCNC's blend
        // takes what it needs of the planar part and runs on along it.
        let floor_mm = min_mm.max(shortest_arc_mm(arc, options.chord_tolerance_mm));
        // At most half the piece: both parts stay arcs.
        let mut d = reach_mm.min(0.5 * piece_mm).max(floor_mm);
        if piece_mm - d < floor_mm {
            return Ok(None);
        }
        let mut found = None;
        for _ in 0..TRIES {
            if d.is_nan() || d < floor_mm {
                return Ok(None);
            }
            let at = match side {
                Side::Start => l_a + d / length_mm,
                Side::End => l_b - d / length_mm,
            };
            let target = arc.point_at(at);
            let q = frame.quantize(solve(target)?, from);
            let moved = (q[w] - keep).abs();
            if moved <= tolerance_mm + QUANTUM_MM {
                found = Some((at, target, q, moved));
                break;
            }
            d = shortened_mm(d, moved, tolerance_mm);
        }
        let Some((at, target, q, moved)) = found else {
            return Ok(None);
        };
        if !between(from[w], q[w], to[w]) {
            return Ok(None);
        }
        let mut q_p = q;
        q_p[w] = keep;
        let mut words = [None, None];
        let parts = [
            (sub_arc(arc, l_a, at), from, q_p, side == Side::Start),
            (sub_arc(arc, at, l_b), q_p, to, side == Side::End),
        ];
        for (k, (piece, s, e, planar)) in parts.into_iter().enumerate() {
            let mut mid = solve(piece.point_at(0.5))?;
            if planar {
                mid[w] = keep;
            }
            let word = ArcWords {
                center: piece_center(
                    &piece,
                    (s, mid, e),
                    options.chord_tolerance_mm,
                    turn_tolerance,
                ),
                plane: arc.plane,
                clockwise: arc.clockwise(),
                radius_style,
                absolute_centers: frame.arc_absolute,
                second: None,
            };
            if word.center.is_none() || !word.readable(frame, style, s, e) {
                return Ok(None);
            }
            words[k] = Some(word);
        }
        let [Some(a), Some(b)] = words else {
            return Ok(None);
        };
        Ok(Some(Split {
            at,
            target_mm: target,
            q_mm: q_p,
            words: [a, b],
            moved_mm: moved,
        }))
    }

    /// The arc's first piece after a G64 corner whose arc before it ended
    /// planar (`self.planar_before`): split at `reach_mm` from the corner
    /// ([`super::arc_zone::planar_reach_mm`]), else at `fallback_mm` (the
    /// corner's blend reach, [`super::points::Run::protect_mm`]'s half), the
    /// part at the corner planar. `pieces`, `targets`, `commands` and `words` are
    /// the block's, solved from `from` (no take-up before the first piece).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn planar_start(
        &mut self,
        model: &dyn ErrorModel,
        at: (&Frame, NumberStyle, u64),
        arc: &Arc,
        (reach_mm, fallback_mm): (f64, f64),
        from: Vec3,
        (pieces, targets): (&mut Vec<f64>, &mut Vec<Vec3>),
        (commands, words): (&mut Vec<(Vec3, Option<Vec3>)>, &mut Vec<ArcWords>),
        (tolerance_mm, radius_style, turn_tolerance): (f64, bool, Option<f64>),
    ) -> Result<(), CompensationError> {
        let (Some(first), Some(w0), Some(state)) =
            (commands.first(), words.first(), self.states.first())
        else {
            return Ok(());
        };
        if first.1.is_some() || w0.center.is_none() || w0.second.is_some() {
            return Ok(());
        }
        let (to, state) = (first.0, *state);
        if to[arc.plane.axes().2] == from[arc.plane.axes().2] {
            // Planar as solved.
            self.planar_start_kept = true;
            return Ok(());
        }
        // The longer reach first (G64 without P, compensate/arc_zone.rs);
        // where its planar part cannot be kept within the tolerance, the
        // blend's own distance.
        let mut split = None;
        for reach_mm in [reach_mm, fallback_mm] {
            if split.is_some() || reach_mm.is_nan() || reach_mm <= 0.0 {
                continue;
            }
            split = self.planar_split(
                model,
                at,
                arc,
                (0.0, pieces[0]),
                (from, to),
                state,
                (Side::Start, reach_mm, tolerance_mm),
                (radius_style, turn_tolerance),
            )?;
        }
        let Some(split) = split else {
            return Ok(());
        };
        pieces.insert(0, split.at);
        targets.insert(0, split.target_mm);
        commands.insert(0, (split.q_mm, None));
        words[0] = split.words[1];
        words.insert(0, split.words[0]);
        self.states.insert(0, state);
        self.estimate_mm = self.estimate_mm.max(split.moved_mm);
        self.planar_start_kept = true;
        Ok(())
    }

    /// The text of the held arc's last piece written planar at its end,
    /// where the motion `next` makes a corner LinuxCNC blends with an arc
    /// once both sides are planar (an arc of the same plane without a rise
    /// of its own, under G64 with a feed per minute, not tangent to the
    /// arc's end: [`super::points::Run::of`]), and how far its split moved
    /// along the normal (mm); `None` to write it as solved. Sets
    /// `planar_before` for the next arc's start. The text is a candidate:
    /// it is taken only where the next arc's start is planar too
    /// ([`PendingEnd`]).
    pub(super) fn planar_end_text(
        &mut self,
        p: &PlanarEnd,
        next: Option<&Motion>,
    ) -> Option<(Vec<u8>, f64)> {
        let next = next?;
        // The next motion: an arc of the plane (`tpCreateArcArcBlend`) or a
        // line in it (`tpCreateArcLineBlend`, src/emc/tp/tp.c).
        let to_line = planar_line(next, p.arc.plane);
        if !to_line {
            planar_arc(next, p.arc.plane)?;
        }
        if !matches!(next.path_mode, PathMode::Blend { .. })
            || !matches!(p.mode, PathMode::Blend { .. })
        {
            return None;
        }
        let end_tangent = {
            let [tu, tv] = super::arcs::plane_tangent(&p.arc, 1.0);
            let (u, v, _) = p.arc.plane.axes();
            let mut t = Vec3::ZERO;
            t[u] = tu;
            t[v] = tv;
            t
        };
        let run = super::points::Run::of(
            next,
            Some((end_tangent, p.arc.length())),
            &self.walk.options.planner,
        );
        if !run.corner_before || run.protect_mm.is_nan() || run.protect_mm <= 0.0 {
            return None;
        }
        let w = p.arc.plane.axes().2;
        if to_line {
            self.planar_line_normal = Some(w);
        }
        if p.from_mm[w] == p.to_mm[w] {
            // Planar as solved: written as it is.
            self.planar_before = true;
            return None;
        }
        let model = crate::model::WithTool {
            model: self.walk.model,
            tool_length_offset_mm: p.tool_length_offset_mm,
        };
        // An arc's end before a line keeps the contour tolerance: a planar
        // part longer than that allows may still fall short of what the
        // blend wants
        // (`under_g64_an_arc_end_is_not_split_planar_shorter_than_the_blend_reach_before_a_line`:
        // 0.808 s split, 0.796 s as solved on the planner model). Before
        // an arc it takes the planar tolerance, as the next arc's start
        // does (`planar_tolerance_mm`: 0.4 µm under G64 without P), and
        // the blend arc takes a share of the longer part
        // (`under_g64_an_arc_into_an_arc_ends_planar_within_the_planar_tolerance`:
        // 0.854 → 0.816 s).
        let tolerance_mm = if to_line {
            self.walk.options.arc_tolerances_mm(p.mode).0
        } else {
            planar_tolerance_mm(self.walk.options, p.mode)
        };
        let reach_mm = 0.5 * run.protect_mm;
        if to_line && 0.5 * (1.0 - p.piece_from) * p.arc.length() < reach_mm * (1.0 - 1e-9) {
            // Half the piece (the longest planar part) is shorter than the
            // reach: refused below; known before the split is solved.
            return None;
        }
        // Into an arc, the planar part reaches as far as that corner's
        // blend arc takes of it (compensate/arc_zone.rs); into a line, the
        // blend's distance.
        let part_mm = if to_line {
            reach_mm
        } else {
            super::arc_zone::planar_reach_mm(
                self.walk.options.take_up_rule(p.mode),
                &run,
                Side::End,
            )
        };
        let mut split = None;
        for part_mm in [part_mm, reach_mm] {
            if split.is_some() {
                break;
            }
            split = self
                .planar_split(
                    &model,
                    (&p.frame, p.style, p.line),
                    &p.arc,
                    (p.piece_from, 1.0),
                    (p.from_mm, p.to_mm),
                    p.state,
                    (Side::End, part_mm, tolerance_mm),
                    (p.radius_style, p.turn_tolerance),
                )
                .ok()?;
        }
        let split = split?;
        if to_line && (1.0 - split.at) * p.arc.length() < reach_mm * (1.0 - 1e-9) {
            // A planar part shorter than the blend's reach shortens the
            // segment the blend arc may take (blendmath.c
            // `blendInit3FromArcLine`: the arc's length bounds it); at an arc
            // to a line, measured on the planner model, that runs slower
            // than the parabolic blend of the corner as solved.
            return None;
        }
        let place = Place {
            frame: &p.frame,
            style: p.style,
            line: p.line,
            ending: &p.line_ending,
        };
        let (mode, lines_out) = (self.mode, self.summary.lines_out);
        if let Some(before) = p.mode_before {
            // The whole line is replaced: written after the mode before it.
            self.mode = before;
        }
        let start = self.buf.len();
        self.write_inserted_arc(&place, p.from_mm, split.q_mm, &split.words[0], "");
        if p.mode_before.is_some() && self.walk.options.trace_comments {
            // The first part stands for the program's own line: without a
            // trace comment, as the line's first piece is written (a tagged
            // line continues the untagged one before it).
            let mut tag = self.walk.sep.as_bytes().to_vec();
            tag.extend_from_slice(b"(volcomp L");
            volcomp_gcode::number::format_uint_bytes(p.line, &mut tag);
            tag.push(b')');
            let ending: &[u8] = if p.line_ending.is_empty() {
                b"\n"
            } else {
                &p.line_ending
            };
            let body_end = self.buf.len().saturating_sub(ending.len());
            if self.buf[start..body_end].ends_with(&tag) {
                self.buf.drain(body_end - tag.len()..body_end);
            }
        }
        self.write_inserted_arc(
            &place.with_ending(&p.ending),
            split.q_mm,
            p.to_mm,
            &split.words[1],
            "",
        );
        let text = self.buf[start..].to_vec();
        self.buf.truncate(start);
        self.mode = mode;
        self.summary.lines_out = lines_out;
        self.planar_before = true;
        Some((text, split.moved_mm))
    }

    /// The held arc's text as the next arc's start decided it: the planar
    /// end where that start is planar too (`planar_start_kept`), else the
    /// line as solved. A corner with one side planar keeps no blend arc
    /// either (both normals must be colinear with the binormal:
    /// `tpCreateArcArcBlend`, src/emc/tp/tp.c) and runs slower than with
    /// none: the split adds a piece and the planar side's tangent differs
    /// from the solved one.
    pub(super) fn resolve_planar_end(&mut self, p: PendingEnd) -> Vec<u8> {
        if std::mem::take(&mut self.planar_start_kept) {
            self.summary.lines_out += 1;
            self.estimate_mm = self.estimate_mm.max(p.moved_mm);
            p.planar
        } else {
            p.solved
        }
    }
}

/// A held arc's line whose last piece may be written planar at its end,
/// waiting for the next arc's first piece to be solved: both sides of the
/// corner are decided together ([`State::resolve_planar_end`]).
pub(super) struct PendingEnd {
    /// The line with its last piece as solved.
    pub(super) solved: Vec<u8>,
    /// The line with its last piece split, the part at the corner planar.
    pub(super) planar: Vec<u8>,
    /// How far the split's command moved along the normal (mm).
    pub(super) moved_mm: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The planner stops at a reversal within 2° (tp.c `tpSetupTangent`):
    /// a semicircle retraced (tangents opposite) and a 1° kink back stop;
    /// 3° back and a right angle do not.
    #[test]
    fn a_reversal_within_two_degrees_is_a_stop() {
        let t1 = Vec3::new(1.0, 0.0, 0.0);
        let back = |deg: f64| {
            let r = deg.to_radians();
            Vec3::new(-r.cos(), r.sin(), 0.0)
        };
        assert!(stops_at(t1, back(0.0)));
        assert!(stops_at(t1, back(1.0)));
        assert!(!stops_at(t1, back(3.0)));
        assert!(!stops_at(t1, Vec3::new(0.0, 1.0, 0.0)));
    }

    /// The fold into the piece after a held normal axis is gentle within
    /// the planner's tangency tolerance of a join of lines: at F6000 with
    /// 1,000 mm/s² and 1 ms, 0.1 · 1,000 / (100 / 0.001 + 1,000) =
    /// 0.990 mrad by hand. 8.6 µm over 11.9 mm (0.72 mrad) is; 12 µm over
    /// 11.9 mm (1.01 mrad) and 9 µm over 2.6 mm (3.5 mrad) are not; at
    /// F3000 (1.96 mrad) 20 µm over 11.9 mm (1.68 mrad) is. Never without
    /// a feed per minute.
    #[test]
    fn the_fold_after_a_held_normal_axis_is_gentle_within_the_line_tangency() {
        let planner = crate::compensate::PlannerLimits::default();
        let tol = 0.1 * 1000.0 / (100.0 / 0.001 + 1000.0);
        assert!((planner.tangent_tolerance(100.0, false)[2] - tol).abs() < 1e-12);
        let z = 2;
        assert!(fold_after_hold_is_gentle(
            &planner,
            Some(6000.0),
            8.6e-3,
            11.9,
            z
        ));
        assert!(!fold_after_hold_is_gentle(
            &planner,
            Some(6000.0),
            12e-3,
            11.9,
            z
        ));
        assert!(!fold_after_hold_is_gentle(
            &planner,
            Some(6000.0),
            9e-3,
            2.6,
            z
        ));
        assert!(fold_after_hold_is_gentle(
            &planner,
            Some(3000.0),
            20e-3,
            11.9,
            z
        ));
        assert!(!fold_after_hold_is_gentle(&planner, None, 1e-6, 11.9, z));
    }

    #[test]
    fn a_split_between_the_ends_keeps_the_direction() {
        assert!(between(0.0, 0.5, 1.0));
        assert!(between(1.0, 0.5, 0.0));
        assert!(between(0.0, 0.0, 1.0));
        assert!(between(0.0, 1.0, 1.0));
        assert!(!between(0.0, 1.5, 1.0));
        assert!(!between(0.0, -0.1, 1.0));
    }

    #[test]
    fn the_shortest_arc_part_has_a_sagitta_over_the_chord_tolerance() {
        let quarter = Arc {
            start: Vec3::new(0.0, 0.0, 0.0),
            end: Vec3::new(10.0, 10.0, 0.0),
            center: Vec3::new(0.0, 10.0, 0.0),
            plane: volcomp_gcode::Plane::Xy,
            sweep_rad: std::f64::consts::FRAC_PI_2,
        };
        // R10, 0.1 µm: sweep 2·acos(1 − 1e-5) ≈ 2·√(2e-5) = 8.9443e-3 rad,
        // 0.089443 mm of arc, and a hundredth more (by hand).
        let d = shortest_arc_mm(&quarter, 1e-4);
        assert!((d - 1.01 * 0.089443).abs() < 1e-6, "{d}");
        // Its sagitta, r (1 − cos(θ/2)), is over the tolerance.
        let theta = d / 10.0;
        assert!(10.0 * (1.0 - (0.5 * theta).cos()) > 1e-4);
        // No part of a radius under the tolerance is an arc.
        let tiny = Arc {
            end: Vec3::new(5e-5, 5e-5, 0.0),
            center: Vec3::new(0.0, 5e-5, 0.0),
            ..quarter
        };
        assert_eq!(shortest_arc_mm(&tiny, 1e-4), f64::INFINITY);
    }

    /// A motion of `kind` from `start` to `end` at F3000 under G64.
    fn motion(kind: MotionKind, start: Vec3, end: Vec3) -> Motion {
        Motion {
            kind,
            start,
            end,
            line: 1,
            column: 1,
            feed: 3000.0,
            source: volcomp_gcode::MotionSource::Program,
            extra: Default::default(),
            feed_mode: volcomp_gcode::interp::FeedMode::PerMinute,
            path_mode: PathMode::Blend {
                tolerance_mm: 0.0,
                naive_cam_mm: 0.0,
            },
        }
    }

    #[test]
    fn a_corner_into_an_arc_out_of_its_plane_is_blended_parabolically() {
        // Half a flat turn of R5 clockwise from (−5, 0): its tangent there is
        // +Y, its normal Z.
        let (start, end) = (Vec3::new(-5.0, 0.0, -1.0), Vec3::new(5.0, 0.0, -1.0));
        let flat = motion(
            MotionKind::Arc(Arc {
                start,
                end,
                center: Vec3::new(0.0, 0.0, -1.0),
                plane: volcomp_gcode::Plane::Xy,
                sweep_rad: -std::f64::consts::PI,
            }),
            start,
            end,
        );
        // Out of a helix falling 64 mrad: the binormal +Y × (0, 1, −0.064)
        // lies along X, not Z (by hand).
        let helix = Vec3::new(0.0, 1.0, -0.064) * (1.0 / 1.002_046f64);
        assert!(parabolic_into(helix, &flat));
        // Out of a plunge along −Z: the binormal lies along X too.
        assert!(parabolic_into(Vec3::new(0.0, 0.0, -1.0), &flat));
        // Out of a line in the plane at 90°: the binormal is Z, a blend arc.
        assert!(!parabolic_into(Vec3::new(1.0, 0.0, 0.0), &flat));
        // Tangent (no corner), and a line after the corner: not parabolic.
        assert!(!parabolic_into(Vec3::new(0.0, 1.0, 0.0), &flat));
        let line = motion(MotionKind::Feed, start, Vec3::new(-5.0, 10.0, -1.0));
        assert!(!parabolic_into(helix, &line));
    }

    /// A piece 0.073 mm long of an R12.25 arc (a spiral's half circle):
    /// sweep 5.959 mrad, sagitta `r(1 − cos(Δ/2))` = 0.0544 µm, under the
    /// 0.1 µm chord tolerance, so `piece_center` writes a chord; the chord
    /// turns from the arc's tangents by half the sweep, 2.98 mrad, over
    /// the G64 limit at F6000 (half of LinuxCNC's arc tangency tolerance
    /// `0.1·0.5·1000/(100/0.001 + 1000)` = 0.495 mrad: 0.2475 mrad; tp.c
    /// `tpSetupTangent`; by hand): the piece stays an arc, about the
    /// nominal centre (the ends are the nominal ones here). A piece whose
    /// half sweep is under the limit stays a chord, and G61 has no such
    /// limit here (its rule is `piece_turn_tolerance`'s).
    #[test]
    fn a_chord_that_turns_from_the_arc_by_more_than_the_tangency_stays_an_arc_under_g64() {
        let r = 12.25;
        let sweep = 0.073 / r;
        let center = Vec3::new(0.75, 0.0, 0.0);
        let at = |a: f64| center + Vec3::new(r * a.cos(), r * a.sin(), 0.0);
        let (a0, a1) = (
            std::f64::consts::FRAC_PI_2 + 0.5 * sweep,
            std::f64::consts::FRAC_PI_2 - 0.5 * sweep,
        );
        let piece = Arc {
            start: at(a0),
            end: at(a1),
            center,
            plane: volcomp_gcode::Plane::Xy,
            sweep_rad: -sweep,
        };
        let ends = (piece.start, at(0.5 * (a0 + a1)), piece.end);
        assert!((super::super::arcs::sagitta_mm(&piece) - 0.0544e-3).abs() < 0.001e-3);
        assert_eq!(piece_center(&piece, ends, 1e-4, None), None);
        let mut options = super::super::CompensateOptions::default();
        let m = motion(MotionKind::Arc(piece), piece.start, piece.end);
        let run =
            super::super::points::Run::of(&Motion { feed: 6000.0, ..m }, None, &options.planner);
        let k = chord_turn_tolerance(&options, &run, &piece).unwrap();
        assert!((k - 0.2475e-3).abs() < 1e-6, "{k}");
        let c = chord_turn_center(&piece, ends, Some(k)).unwrap();
        assert!((c - center).norm() < 1e-6, "{c:?}");
        // Half the sweep under the limit: a chord.
        assert_eq!(
            chord_turn_center(&piece, ends, Some(0.5 * sweep + 1e-6)),
            None
        );
        // G61: none of this rule.
        let g61 = Motion {
            path_mode: PathMode::ExactPath,
            feed: 6000.0,
            ..m
        };
        let run = super::super::points::Run::of(&g61, None, &options.planner);
        assert_eq!(chord_turn_tolerance(&options, &run, &piece), None);
        // The take-up tolerance sets G64 P's rule for every mode: kept.
        options.take_up_tolerance_mm = Some(0.005);
        assert!(chord_turn_tolerance(&options, &run, &piece).is_some());
    }

    #[test]
    fn a_part_within_tolerance_is_kept_and_one_over_it_shortened_in_proportion() {
        assert_eq!(shortened_mm(2.0, 0.5e-4, 1e-4), 2.0);
        assert_eq!(shortened_mm(2.0, 1e-4, 1e-4), 2.0);
        // 2 mm moved 0.4 µm against 0.1 µm: a quarter, less a tenth.
        assert!((shortened_mm(2.0, 4e-4, 1e-4) - 0.45).abs() < 1e-12);
    }
}
