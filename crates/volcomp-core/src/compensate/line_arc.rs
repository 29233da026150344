//! A line into an arc of its plane keeps LinuxCNC's blend arc under G64
//! (docs/compensation.md, "A line into an arc of its plane (G64)").
//!
//! LinuxCNC 2.9 joins a line and the arc after it with a blend arc only
//! where the corner's binormal (`u_line × u_arc`, src/emc/tp/blendmath.c
//! `blendInit3FromLineArc`, `blendGeom3Init`) is colinear with the arc's
//! normal within `TP_ANGLE_EPSILON` = 1e-6 rad (src/emc/tp/tp.c,
//! `tpCreateLineArcBlend`, `pmUnitCartsColinear`). The binormal is normal to
//! both tangents, so both must lie in the arc's plane: the line's direction
//! and the arc's start tangent (whose helix rise counts,
//! `pmCircleTangentVector`). Else the planner blends parabolically and
//! slows (a one-block G18 circle after its plunge, ripple map, planner
//! model: 0.908 s in the original, 1.079 s compensated).
//!
//! A compensated line carries the map's change of the normal axis' correction
//! along it (1.4 µm over a 7.3 mm plunge). So the line's last piece is
//! written planar: where the next motion is such an arc (known once the line
//! waits for it, compensate/end_zone.rs [`super::end_zone::HeldLine`]), the
//! line is split before its end by the zone the corner's blend takes of it
//! ([`super::end_zone::NextCorner::end_zone_mm`]), and the split's command
//! keeps the end's normal coordinate. The tool then leaves the path along
//! the normal by the correction's change over that part, at most at the
//! split; the part is shortened to keep that within the contour tolerance,
//! under G64 without P within 0.4 µm and at most half the piece
//! ([`super::planar::planar_tolerance_mm`], [`super::planar::shortened_mm`]).
//! A one-piece line from rest under G64 without P may stay flat for longer
//! than half of it: its first piece, as short as the tangency to the flat
//! part allows, carries the normal command's whole change
//! ([`flat_from_rest`]).
//! The arc's first piece is then written
//! planar at its start as after an arc ending planar (planar.rs
//! `planar_start`, through `planar_before`).

use super::end_zone::NextCorner;
use super::frame::Frame;
use super::points::Run;
use super::{command_error, Segmentation, State, TakeUpRule};
use crate::error::CompensationError;
use crate::model::ErrorModel;
use volcomp_gcode::{FeedMode, Motion, MotionKind, PathMode, Vec3};

/// How many lengths of the planar part are tried, each shortened from the
/// last in proportion to how far it moved the split (as planar.rs).
const TRIES: usize = 4;

/// What a move along the normal measured between two written numbers may
/// exceed the tolerance by: their rounding in binary (mm).
const QUANTUM_MM: f64 = 1e-9;

/// The normal axis of `m` where it is an arc of a plane without a rise of
/// its own, run under G64 (with or without P) at a feed per minute: the
/// arc a line before it may keep LinuxCNC's blend arc into. `None` for
/// anything else.
pub(super) fn planar_arc_normal(m: &Motion) -> Option<usize> {
    let MotionKind::Arc(a) = m.kind else {
        return None;
    };
    let blended = matches!(m.path_mode, PathMode::Blend { .. });
    let per_minute = m.feed_mode == FeedMode::PerMinute && m.feed > 0.0;
    if !(blended && per_minute) {
        return None;
    }
    super::planar::planar_arc(m, a.plane).map(|a| a.plane.axes().2)
}

/// Whether the feed line `motion`, run as `run`, waits for the next line
/// before it is written: under G64 with or without P at a feed per minute,
/// where the block may hold its end (`may_hold_end`, as
/// [`super::end_zone::holds_end`]), and where the line leaves some axis
/// still (else it lies in no plane an arc after it can have). A property of
/// the line alone: the hold's mechanism (compensate/mod.rs) may also ask
/// whether the next line can be an arc at all before it holds one. Under
/// G64 without P a one-piece line waits too: a plunge into a one-block G18
/// circle (held-out set, F6000) cost +17…+35 % on the planner model
/// without its planar end. Holding every such line by copying its event
/// and interpreter state cost 36 % more instructions on a 20,000-line CAM
/// program without an arc (callgrind, cam20k), hence that peek.
pub(super) fn waits_for_arc(motion: &Motion, run: &Run, may_hold_end: bool) -> bool {
    may_hold_end
        && matches!(motion.kind, MotionKind::Feed)
        && run.feed_mm_min.is_some()
        && matches!(run.mode, PathMode::Blend { .. })
        && motion.start != motion.end
        && (0..3).any(|a| motion.start[a] == motion.end[a])
}

/// How much of the planner's tangency tolerance the join between a line's
/// first piece and its flat part may use ([`flat_from_rest`]): half, so
/// that the written numbers' rounding keeps it tangent (a 0.05 µm rounding
/// over a 0.7 mm piece turns its tangent by 0.07 mrad of the 0.99 mrad at
/// F6000, `PlannerLimits::tangent_tolerance`).
const FIRST_KINK_SHARE: f64 = 0.5;

/// Whether a take-up is written where a line starts: its start solved in
/// the line's direction state (`q_start`) is not the command the tool
/// stands at (`from`). An axis that reverses without a band to take up
/// (a map without backlash) takes nothing up.
fn takes_up_at_start(q_start: Vec3, from: Vec3) -> bool {
    q_start != from
}

/// A one-piece line from rest ([`flat_from_rest`]): its start and end,
/// each as the nominal target and the solved command, the normal axis `w`
/// of the arc after it, the shortest piece the planner runs at the feed,
/// the planar tolerance and the feed.
struct FromRest {
    start: (Vec3, Vec3),
    end: (Vec3, Vec3),
    w: usize,
    floor_mm: f64,
    tolerance_mm: f64,
    feed_mm_min: f64,
}

/// The split of a one-piece line that starts from rest (no compensated
/// feed motion before it, no take-up at its start) into an arc of its
/// plane under G64 without P, where its flat part may be longer than the
/// half [`State::plan_planar_line_end`] otherwise allows: the split as
/// near the start as a piece the planner runs at the feed (`floor_mm`),
/// moved on while the join between the first piece (which carries the
/// whole change of the normal command) and the flat part is no tangent
/// join for the planner within [`FIRST_KINK_SHARE`]
/// (`PlannerLimits::kink_ratio`, tp.c `tpSetupTangent`), the first piece
/// grown in proportion to the kink each time. `None` where the flat part
/// would move along the normal by more than the tolerance, would be no
/// longer than half the line, or no tangent join is found in [`TRIES`].
///
/// The first piece runs from rest, where the tool is slow anyway; the long
/// flat part lets LinuxCNC size its line-arc blend from the line's length
/// (tp.c `tpCreateLineArcBlend`): the held-out set's one-block G18 circle
/// after its plunge, fine map, F6000 on the planner model +4.3 % → +2.3 %
/// against the original.
fn flat_from_rest(
    line: &FromRest,
    planner: &super::joins::PlannerLimits,
    solve: impl Fn(Vec3) -> Result<Vec3, CompensationError>,
) -> Result<Option<Vec3>, CompensationError> {
    let ((start, q_start), (end, q_end), w) = (line.start, line.end, line.w);
    let length_mm = (end - start).norm();
    let u = (end - start) * (1.0 / length_mm);
    let mut s = line.floor_mm;
    for _ in 0..TRIES {
        if !(s.is_finite() && s >= line.floor_mm && length_mm - s > 0.5 * length_mm) {
            return Ok(None);
        }
        let at = start + u * s;
        let mut q_at = solve(at)?;
        if (q_at[w] - q_end[w]).abs() > line.tolerance_mm + QUANTUM_MM {
            return Ok(None);
        }
        q_at[w] = q_end[w];
        let (first, flat) = (q_at - q_start, q_end - q_at);
        let (l1, l2) = (first.norm(), flat.norm());
        if !(l1 > 0.0 && l2 > 0.0) {
            return Ok(None);
        }
        let v = planner.segment_velocity_mm_s(line.feed_mm_min, l1.min(l2));
        let kink = planner.kink_ratio(first * (1.0 / l1), flat * (1.0 / l2), v, false);
        if kink <= FIRST_KINK_SHARE {
            return Ok(Some(at));
        }
        // The kink falls as the first piece grows (its normal change is
        // the line's whole): one step lands near the share, 1 % beyond.
        s *= 1.01 * kink / FIRST_KINK_SHARE;
    }
    Ok(None)
}

/// The planar end planned for a line: the normal axis `w`, the split
/// target inserted before the end (`None` where none is needed), the
/// tolerance (mm) the split's command may move along the normal, and
/// whether an axis may turn at the line's end ([`turn_may_end_planar`]).
#[derive(Debug, Clone, Copy)]
pub(super) struct PlanarLineEnd {
    w: usize,
    split: Option<Vec3>,
    tolerance_mm: f64,
    turn_at_end: bool,
}

/// Whether a line's planar end is kept where an axis turns at the line's
/// end (the end's command solved in the direction state after the turn,
/// the split's in the one before it): under G64 without P
/// ([`TakeUpRule::Always`]) only, where the commands as solved lie within
/// the planar tolerance along the normal all the same (the check in
/// [`State::apply_planar_line_end`] reads the two commands themselves, so a
/// turn of the normal axis whose take-up moves the end's command further is
/// refused by it). The turn's take-up is not moved: the split's command
/// keeps its own in-plane coordinates, the end its own.
///
/// Such a turn is common at a line into an arc of its plane: the map's
/// correction of the normal axis rises along the line and falls along the
/// arc (or the other way), so the compensated normal axis turns at the
/// corner. Without the planar end LinuxCNC blends that corner
/// parabolically (the line's binormal is not colinear with the arc's
/// normal, src/emc/tp/tp.c `tpCreateLineArcBlend`): set c g55_tool, ripple
/// map, planner model 2.007 s against 1.824 s in the original; its planar
/// end restores the blend arc (1.921 s).
pub(super) fn turn_may_end_planar(rule: TakeUpRule) -> bool {
    rule == TakeUpRule::Always
}

impl State<'_> {
    /// Before the line `motion` (run as `run`, its targets `targets`) is
    /// solved: where the next motion (`self.next_corner`) is an arc of a
    /// plane the line lies in and the corner is blended (a zone at the
    /// line's end, not a tangent join or a stop), the split that makes its
    /// last piece planar: `zone` before the end (no longer than the last
    /// piece less the shortest piece), shortened until the split's solved
    /// command lies within the contour tolerance of the end's normal
    /// coordinate. The split is inserted into `targets`. `None` where no
    /// such corner follows or no split keeps within the tolerance.
    pub(super) fn plan_planar_line_end(
        &mut self,
        model: &dyn ErrorModel,
        frame: &Frame,
        (motion, run): (&Motion, &Run),
        targets: &mut Vec<Vec3>,
        line: u64,
    ) -> Result<Option<PlanarLineEnd>, CompensationError> {
        let Some(next) = self.next_corner else {
            return Ok(None);
        };
        let NextCorner::Motion {
            arc_normal: Some(w),
            ..
        } = next
        else {
            return Ok(None);
        };
        let (Some(f), MotionKind::Feed) = (run.feed_mm_min, motion.kind) else {
            return Ok(None);
        };
        if motion.start[w] != motion.end[w] {
            return Ok(None);
        }
        let options = self.walk.options;
        let Segmentation::Adaptive { min_length_mm, .. } = options.segmentation else {
            return Ok(None);
        };
        let zone_mm = next.end_zone_mm(&options.planner, run, (motion.start, motion.end));
        if zone_mm.is_nan() || zone_mm <= 0.0 {
            return Ok(None);
        }
        let Some(&end) = targets.last() else {
            return Ok(None);
        };
        let n = targets.len();
        let before = if n > 1 { targets[n - 2] } else { motion.start };
        let piece_mm = (end - before).norm();
        if piece_mm.is_nan() || piece_mm <= 0.0 {
            return Ok(None);
        }
        let floor_mm = min_length_mm.max(options.planner.shortest_at_feed_mm(f));
        let tolerance_mm = super::planar::planar_tolerance_mm(options, run.mode);
        let state = crate::model::next_state(self.s, motion.end - motion.start);
        let file = self.walk.file;
        let from = self.q_out;
        let solve = |t: Vec3| {
            super::solve::solve_fixed(model, options.method, t, state, [false; 3], Vec3::ZERO)
                .map(|s| frame.quantize(s.q_mm, from))
                .map_err(|source| command_error(model, file, line, t, source))
        };
        let q_end = solve(end)?;
        let q_before = solve(before)?;
        let rule = options.take_up_rule(run.mode);
        if rule == TakeUpRule::Always
            && n == 1
            && q_before[w] != q_end[w]
            && self.last_tangent.is_none()
            && !takes_up_at_start(solve(motion.start)?, from)
        {
            let from_rest = FromRest {
                start: (motion.start, from),
                end: (end, q_end),
                w,
                floor_mm,
                tolerance_mm,
                feed_mm_min: f,
            };
            if let Some(at) = flat_from_rest(&from_rest, &options.planner, solve)? {
                targets.insert(n - 1, at);
                return Ok(Some(PlanarLineEnd {
                    w,
                    split: Some(at),
                    tolerance_mm,
                    turn_at_end: turn_may_end_planar(rule),
                }));
            }
        }
        if q_before[w] == q_end[w] {
            // Planar as solved: no split.
            return Ok(Some(PlanarLineEnd {
                w,
                split: None,
                tolerance_mm,
                turn_at_end: turn_may_end_planar(options.take_up_rule(run.mode)),
            }));
        }
        let u = (end - before) * (1.0 / piece_mm);
        // No shorter than a piece the planner runs at the feed: the blend
        // takes what it needs of it.
        let mut d = zone_mm.max(floor_mm).min(piece_mm - floor_mm);
        if options.take_up_rule(run.mode) == TakeUpRule::Always {
            // Under G64 without P the planar part may reach far (0.4 µm,
            // `planar_tolerance_mm`): it takes at most half the piece, so
            // that a take-up at the line's start still folds into a first
            // piece of at least half of it (a split near the start made
            // the fold steep enough for a lead piece: held-out inch R arcs,
            // fine map, +15.4 → +17.9 % on the planner model).
            d = d.min(0.5 * piece_mm);
        }
        for _ in 0..TRIES {
            if d.is_nan() || d < floor_mm {
                return Ok(None);
            }
            let at = end - u * d;
            let moved = (solve(at)?[w] - q_end[w]).abs();
            if moved <= tolerance_mm + QUANTUM_MM {
                targets.insert(n - 1, at);
                return Ok(Some(PlanarLineEnd {
                    w,
                    split: Some(at),
                    tolerance_mm,
                    turn_at_end: turn_may_end_planar(options.take_up_rule(run.mode)),
                }));
            }
            d = super::planar::shortened_mm(d, moved, tolerance_mm);
        }
        Ok(None)
    }

    /// After the line is solved (`commands` for `targets`, the solve's
    /// lead points among them, from `q_start`): the planned split's command
    /// given the end's normal coordinate where it moves no further than the
    /// tolerance, both commands plain (no take-up) and in one direction
    /// state (no axis turns at the end: the end's command was solved for
    /// the turn; under G64 without P a turn is allowed,
    /// [`turn_may_end_planar`]); else the split is taken out again, and the line is written
    /// as solved without it. Then, where the last piece is planar, the arc
    /// after it starts planar too (`planar_before`, planar.rs
    /// `planar_start`). Whether the split was kept: under G64 P its pieces
    /// then run under Q0 (LinuxCNC's naive-CAM layer would merge them back
    /// into one line, emccanon.cc `linkable`; joins.rs `naive_cam_words`).
    pub(super) fn apply_planar_line_end(
        &mut self,
        p: PlanarLineEnd,
        (targets, commands): (&mut Vec<Vec3>, &mut Vec<(Vec3, Option<Vec3>)>),
        q_start: Vec3,
    ) -> bool {
        let n = commands.len();
        if n == 0 {
            return false;
        }
        let w = p.w;
        let mut kept = false;
        if let Some(at) = p.split {
            // The split is the last piece's start, unless the solve put a
            // point of its own after it.
            let k = n.saturating_sub(2);
            let ours = n >= 2 && targets.len() == n && targets[k] == at;
            let plain = ours
                && commands[k].1.is_none()
                && commands[k + 1].1.is_none()
                && self.states.len() == n
                && (p.turn_at_end || self.states[k] == self.states[k + 1]);
            let moved = if plain {
                (commands[k].0[w] - commands[k + 1].0[w]).abs()
            } else {
                f64::INFINITY
            };
            if moved <= p.tolerance_mm + QUANTUM_MM {
                commands[k].0[w] = commands[k + 1].0[w];
                if let Some(r) = self.records.get_mut(k) {
                    r.command_mm = commands[k].0;
                }
                self.estimate_mm = self.estimate_mm.max(moved);
                kept = true;
            } else if ours && commands[k].1.is_none() && self.states.len() == n {
                targets.remove(k);
                commands.remove(k);
                self.states.remove(k);
                if self.records.len() == n {
                    self.records.remove(k);
                }
                if self.ramp_mids.len() == n {
                    self.ramp_mids.remove(k);
                }
                return false;
            } else {
                return false;
            }
        }
        let n = commands.len();
        let start = if n > 1 { commands[n - 2].0 } else { q_start };
        if commands[n - 1].1.is_none() && start[w] == commands[n - 1].0[w] {
            self.planar_before = true;
        }
        kept
    }
}
