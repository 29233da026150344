//! The end zone of a line under G64 without P, kept whole from the real
//! corner at its end (docs/compensation.md, "No split inside the reach of a
//! corner's blend (G64)").
//!
//! When a line is read the next motion is not known yet, yet the blend
//! LinuxCNC puts at the line's end takes a length that depends on it:
//! `d = min(L₁/2, L₂/2, d_tol, R/tan θ)` of each line
//! (`blendComputeParameters`, src/emc/tp/blendmath.c). A split nearer the
//! corner than `2d` cuts that blend short and slows it; a split kept out of
//! a longer zone than `2d` leaves the map's error there uncorrected. So a
//! line with splits waits whole ([`HeldLine`]: its event, its interpreter
//! state and its targets; one line, the memory it holds) until the next
//! line is read ([`NextCorner`]); it is then solved and written whole, with
//! `2d` of the real corner before its end kept whole.
//!
//! Under G64 with or without P a line that leaves some axis still waits
//! too, one piece or more: where the next motion is an arc of a plane the
//! line lies in, its last piece is written in that plane
//! (compensate/line_arc.rs).

use super::frame::Frame;
use super::points::{self, Run};
use super::walk::Line;
use super::{PlannerLimits, Segmentation, State};
use crate::error::CompensationError;
use crate::model::{Directions, ErrorModel};
use std::io::Write;
use volcomp_gcode::lexer::{Lexed, LineKind};
use volcomp_gcode::number::NumberStyle;
use volcomp_gcode::{
    FeedMode, Interpreter, LineEvent, Motion, MotionKind, MotionSource, PathMode, Vec3,
};

/// Whether a line run as `run` waits for the real corner at its end: under
/// G64 without P at a feed per minute, where the block may hold its end at
/// all (`may_hold_end`: no stop word, no inverse time, no extra axes,
/// adaptive segmentation).
pub(super) fn holds_end(run: &Run, may_hold_end: bool) -> bool {
    may_hold_end
        && run.feed_mm_min.is_some()
        && matches!(run.mode, PathMode::Blend { tolerance_mm, .. } if tolerance_mm <= 0.0)
}

/// The distance `d` (mm) LinuxCNC's blend takes of each of two lines, of
/// lengths `l1_mm` and `l2_mm` and unit tangents `t1`, `t2` at the corner,
/// run at `v_mm_s` (the faster of the two: `v_goal` of
/// `blendParamKinematics`, blendmath.c):
/// `d = min(L₁/2, L₂/2, d_tol, R/tan θ)` (`blendComputeParameters`), with
/// `d_tol = T cos θ / (1 − sin θ)` for the blend tolerance `T`, the
/// smallest of the segments' G64 P (`p2_mm` for the second, none for the
/// first) and a quarter of either line (`tcFindBlendTolerance`, tc.c), and
/// `R = v²/a_n` ([`PlannerLimits::blend_distance_at_mm`]). 0 where the
/// planner does not blend: a join it takes as tangent (`kink`: below 1,
/// [`PlannerLimits::kink_ratio`]) or a reversal, whose tangents are
/// anti-parallel within 2° (`tpSetupTangent`, tp.c), where it stops.
pub(super) fn corner_reach_mm(
    planner: &PlannerLimits,
    (t1, t2): (Vec3, Vec3),
    (l1_mm, l2_mm): (f64, f64),
    v_mm_s: f64,
    p2_mm: f64,
    kink: f64,
) -> f64 {
    let phi = super::joins::deflection_rad(t1, t2);
    let theta = 0.5 * (std::f64::consts::PI - phi);
    if kink < 1.0 || theta < super::joins::REVERSAL_HALF_ANGLE_RAD {
        return 0.0;
    }
    let quarter = 0.25 * l1_mm.min(l2_mm);
    let tolerance_mm = if p2_mm > 0.0 {
        p2_mm.min(quarter)
    } else {
        quarter
    };
    let speed_mm = if v_mm_s.is_finite() {
        planner.blend_distance_at_mm(phi, v_mm_s)
    } else {
        f64::INFINITY
    };
    speed_mm
        .min(planner.blend_distance_within_at_mm(phi, tolerance_mm))
        .min(0.5 * l1_mm)
        .min(0.5 * l2_mm)
}

/// The speed (mm/s) at which LinuxCNC runs the blend arc that takes
/// `d_mm` of each side of a corner: its radius is `d·tan θ` (`θ` half the
/// angle between the lines), run at `√(a_n R)` (`blendComputeParameters`,
/// src/emc/tp/blendmath.c). At `v_mm_s` the blend would take `speed_mm`
/// ([`PlannerLimits::blend_distance_at_mm`], `v²/(a_n tan θ)`), and the
/// distance grows with `v²`, so `d` is taken at `v·√(d/speed_mm)`.
/// Infinite where the lines are collinear.
pub(super) fn blend_speed_mm_s(v_mm_s: f64, speed_mm: f64, d_mm: f64) -> f64 {
    if speed_mm > 0.0 {
        v_mm_s * (d_mm / speed_mm).sqrt()
    } else {
        f64::INFINITY
    }
}

/// Under G64 P, whether a take-up at the start of a move (`index` 0) after
/// a corner is written as a block rather than on a lead piece or folded
/// into the move: where the corner's blend, kept within P, runs no faster
/// than the block itself may (`|delta|` per servo period: LinuxCNC caps a
/// segment's speed at its length per period, `tcClampVelocityByLength`,
/// src/emc/tp/tc.c). The machine all but stops at such a corner (5.29 mm/s
/// at a hexagon's 60° at P0.005), so the stop the block makes costs about
/// what the corner costs already, and the tool takes the reversal up at
/// the corner, on the path. A lead piece there turns the path by the
/// take-up over a few tenths of a millimetre (28 mrad for 7 µm over
/// 0.24 mm), a second corner the planner slows for.
pub(super) fn block_at_slow_corner(
    rule: super::TakeUpRule,
    run: &Run,
    index: usize,
    delta_mm: Vec3,
    planner: &PlannerLimits,
) -> bool {
    matches!(rule, super::TakeUpRule::Within(_))
        && index == 0
        && run.corner_before
        && run.blend_speed_before_mm_s <= delta_mm.norm() / planner.servo_period_s
}

/// The motion after a held line, as far as the blend at the line's end
/// depends on it.
#[derive(Clone, Copy)]
pub(super) enum NextCorner {
    /// The planner does not blend into it: the program's end, a line that
    /// stops the machine (M0, M1, M2, M30, M60), a rapid (a feed move into
    /// a rapid ends in a stop, `handleModeChange`, src/emc/tp/tp.c).
    Stop,
    /// A line the corner cannot be read from (a line without motion, a
    /// canned cycle, cutter compensation, an axis not known yet): the zone
    /// is the one taken alike at the start (`Run::split_end_mm`).
    Unknown,
    /// A feed motion: its unit tangent at its start, its length (mm), its
    /// feed (mm/min; infinite where not per minute), whether it is an arc,
    /// and its G64 P (mm; 0 where none).
    Motion {
        t2: Vec3,
        l2_mm: f64,
        feed_mm_min: f64,
        arc: bool,
        p2_mm: f64,
        /// The normal axis of an arc of a plane without a rise of its own
        /// run under G64 (LinuxCNC's blend arc into it needs the line in
        /// that plane: compensate/line_arc.rs); `None` for anything else.
        arc_normal: Option<usize>,
    },
}

impl NextCorner {
    /// The corner into the line `ev`, after which the axes `known` are set.
    pub(super) fn of(ev: &LineEvent<'_>, known: [bool; 3]) -> Self {
        if ev.after_end || super::lines::stop_m_word(ev.lexed.words()).is_some() {
            return NextCorner::Stop;
        }
        let m = match ev.motions {
            [m, ..] if m.source == MotionSource::Program => *m,
            _ => return NextCorner::Unknown,
        };
        if ev.kind != LineKind::Block || !known.iter().all(|k| *k) || ev.interp.cutter_comp_on() {
            return NextCorner::Unknown;
        }
        if m.kind == MotionKind::Rapid {
            return NextCorner::Stop;
        }
        NextCorner::Motion {
            t2: points::tangents(&m).0,
            l2_mm: points::length_mm(&m),
            // A feed not per minute runs at a speed not known here: the
            // blend is taken as fast as the lengths and the tolerance let
            // it be.
            feed_mm_min: match m.feed_mode {
                FeedMode::PerMinute if m.feed > 0.0 => m.feed,
                _ => f64::INFINITY,
            },
            arc: matches!(m.kind, MotionKind::Arc(_)),
            p2_mm: match m.path_mode {
                PathMode::Blend { tolerance_mm, .. } => tolerance_mm,
                _ => 0.0,
            },
            arc_normal: super::line_arc::planar_arc_normal(&m),
        }
    }

    /// The length (mm) before the end of the line `(a, b)` run as `run`
    /// that its pieces leave whole for this corner: twice
    /// [`corner_reach_mm`]; nothing before a stop.
    pub(super) fn end_zone_mm(
        &self,
        planner: &PlannerLimits,
        run: &Run,
        (a, b): (Vec3, Vec3),
    ) -> f64 {
        let (t2, l2_mm, feed_mm_min, arc, p2_mm) = match *self {
            NextCorner::Stop => return 0.0,
            NextCorner::Unknown => return run.split_end_mm,
            NextCorner::Motion {
                t2,
                l2_mm,
                feed_mm_min,
                arc,
                p2_mm,
                ..
            } => (t2, l2_mm, feed_mm_min, arc, p2_mm),
        };
        let l1_mm = (b - a).norm();
        let t1 = (b - a) * (1.0 / l1_mm);
        let v1_mm_s = run.feed_mm_min.unwrap_or(f64::INFINITY) / 60.0;
        let v2_mm_s = feed_mm_min / 60.0;
        let v_mm_s = v1_mm_s.max(v2_mm_s);
        let kink = planner.kink_ratio(t1, t2, v1_mm_s.min(v2_mm_s), arc);
        2.0 * corner_reach_mm(planner, (t1, t2), (l1_mm, l2_mm), v_mm_s, p2_mm, kink)
    }
}

/// A line waiting for the corner at its end: what its [`Line`] is built
/// from (the event's parts owned, the interpreter after it), and its
/// targets. One line: its bytes, tokens, motions, the interpreter's modal
/// state and at most the target count a line may have
/// (`check_target_count`).
pub(super) struct HeldLine {
    pub(super) number: u64,
    file: Option<String>,
    bytes: Vec<u8>,
    rendered: bool,
    kind: LineKind,
    lexed: Lexed,
    motions: Vec<Motion>,
    interp: Interpreter,
    after_end: bool,
    frame: Frame,
    style: NumberStyle,
    before: Option<(Frame, NumberStyle)>,
    all_known: bool,
    targets: Vec<Vec3>,
}

impl HeldLine {
    /// The line `line`, held with its `targets`.
    pub(super) fn of(line: &Line<'_>, targets: Vec<Vec3>) -> Self {
        let ev = line.ev;
        HeldLine {
            number: ev.number,
            file: ev.file.map(str::to_owned),
            bytes: ev.bytes.to_vec(),
            rendered: ev.rendered,
            kind: ev.kind.clone(),
            lexed: ev.lexed.clone(),
            motions: ev.motions.to_vec(),
            interp: ev.interp.clone(),
            after_end: ev.after_end,
            frame: line.frame,
            style: line.style,
            before: line.before,
            all_known: line.all_known,
            targets,
        }
    }
}

/// The command a target `p_mm` needs with every axis in the state `s`
/// (`p − e(p, s)`, the error taken at the target: it changes by a
/// negligible share of itself over the few micrometres between target and
/// command) and each axis' band there (`|e_a(p, s with a flipped) −
/// e_a(p, s)|`, the reversal value the dead-band model gives; mm).
fn command_and_band_mm(
    model: &dyn crate::model::ErrorModel,
    cells: &mut crate::model::AxisCells,
    p_mm: Vec3,
    s: Directions,
) -> Result<(Vec3, Vec3), crate::error::ModelError> {
    let e_um = cells.deviation_again_um(model, p_mm, s)?;
    let mut band_mm = Vec3::ZERO;
    for a in 0..3 {
        let mut flipped = s;
        flipped[a] = flipped[a].flipped();
        band_mm[a] = (cells.deviation_again_um(model, p_mm, flipped)?[a] - e_um[a]).abs() * 1e-3;
    }
    Ok((p_mm - e_um * 1e-3, band_mm))
}

/// The turns along the commands `c` (the first the tail's start), axis by
/// axis from the state `s`, of the axes with a band at the point they turn
/// at (`bands_mm`): each step of such an axis against its direction is a
/// reversal of its carriage that the straight pieces between the points do
/// not ask for, which the solver either holds (solve.rs
/// `hold_small_reversals`, leaving the turn as an error) or takes up
/// (leaving up to the band under G64); steps below a nanometre turn
/// nothing. An axis without a band turns at no cost and is not counted.
fn turns(c: &[Vec3], bands_mm: &[Vec3], s: Directions) -> usize {
    let mut turns = 0;
    for a in 0..3 {
        let mut dir = s[a].sign();
        for i in 1..c.len() {
            let d = c[i][a] - c[i - 1][a];
            if d.abs() <= 1e-6 {
                continue;
            }
            if d * dir < 0.0 {
                if bands_mm[i - 1][a] > 0.0 {
                    turns += 1;
                }
                dir = -dir;
            }
        }
    }
    turns
}

/// Drops a split nearer a zone's edge than `shortest_mm`, where
/// [`points::protect_blends`] put a point at that edge: the split just
/// after the start zone's edge (`start_mm` along the line from `start`)
/// and the one just before the end zone's (`edge_mm`). The edge points
/// stay. `shortest_mm` is the longer of the adaptive segmentation's
/// shortest piece (targets.rs `split`), which it makes none shorter than,
/// and the shortest piece the planner runs at the feed
/// ([`PlannerLimits::shortest_at_feed_mm`]: `tcClampVelocityByLength`,
/// src/emc/tp/tc.c, caps a segment's speed at its length per servo period).
fn drop_short_at_edges(
    targets: &mut Vec<Vec3>,
    start: Vec3,
    (start_mm, edge_mm): (f64, f64),
    shortest_mm: f64,
) {
    let along = |p: &Vec3| (*p - start).norm();
    let at = |p: &Vec3, mm: f64| (along(p) - mm).abs() <= 1e-9;
    if targets.len() >= 3
        && start_mm > 0.0
        && at(&targets[0], start_mm)
        && !at(&targets[1], edge_mm)
        && along(&targets[1]) - start_mm < shortest_mm
    {
        targets.remove(1);
    }
    let n = targets.len();
    if n >= 3
        && at(&targets[n - 2], edge_mm)
        && !(start_mm > 0.0 && at(&targets[n - 3], start_mm))
        && edge_mm - along(&targets[n - 3]) < shortest_mm
    {
        targets.remove(n - 3);
    }
}

impl State<'_> {
    /// Keeps the split points of the line `(start, end)` run as `run` out
    /// of its blend zones ([`points::protect_blends`]): the start zone,
    /// and at the end the zone of the real corner (`real_end_mm`, a held
    /// line's, [`NextCorner::end_zone_mm`]) or else the one taken alike at
    /// the start (`Run::split_end_mm`). Of a held line, no split is kept
    /// nearer a zone's edge than the shortest piece
    /// ([`drop_short_at_edges`]), and the cuts the real zone keeps that
    /// the zone taken at the start dropped are made only where they turn
    /// no axis' command back more often than the pieces of that zone do
    /// ([`turns`]): a cut is made to bring the tool onto the map's curve
    /// between its neighbours, and a turn it adds costs a reversal (a hold
    /// or a take-up) where the other pieces had none. What the pieces kept
    /// whole leave is added to the estimate. `model` is the line's, the
    /// direction state the one the line starts in.
    pub(super) fn protect_line(
        &mut self,
        model: &dyn ErrorModel,
        targets: &mut Vec<Vec3>,
        start: Vec3,
        run: &Run,
        real_end_mm: Option<f64>,
        line: u64,
    ) -> Result<(), CompensationError> {
        // A line whose zones drop no split is left as it is, without a copy
        // of its targets (the common case: most lines are one piece).
        let Some((_, splits)) = targets.split_last() else {
            return Ok(());
        };
        let end_mm = real_end_mm.unwrap_or(run.split_end_mm);
        let along = |p: &Vec3| (*p - start).norm();
        let drops_end = |zone_mm: f64| {
            zone_mm > 0.0 && splits.iter().any(|p| along(p) >= run.length_mm - zone_mm)
        };
        let start_drops = run.protect_mm > 0.0 && splits.iter().any(|p| along(p) <= run.protect_mm);
        if !start_drops && !drops_end(end_mm) && !drops_end(run.split_end_mm) {
            return Ok(());
        }
        let split = targets.clone();
        points::protect_blends(targets, start, (run.protect_mm, end_mm));
        if let (Some(_), Segmentation::Adaptive { min_length_mm, .. }) =
            (real_end_mm, self.walk.options.segmentation)
        {
            let edges_mm = (run.protect_mm, run.length_mm - end_mm);
            let planner = &self.walk.options.planner;
            let at_feed_mm = run
                .feed_mm_min
                .map_or(0.0, |f| planner.shortest_at_feed_mm(f));
            drop_short_at_edges(targets, start, edges_mm, min_length_mm.max(at_feed_mm));
        }
        if real_end_mm.is_some() && end_mm < run.split_end_mm && targets.len() > 1 {
            let mut proxy = split.clone();
            points::protect_blends(&mut proxy, start, (run.protect_mm, run.split_end_mm));
            if proxy != *targets
                && self.turns_of(model, start, targets, line)?
                    > self.turns_of(model, start, &proxy, line)?
            {
                *targets = proxy;
            }
        }
        if split != *targets {
            self.estimate_whole_pieces(start, &split, targets, line)?;
        }
        Ok(())
    }

    /// The turns ([`turns`]) of the commands of the pieces from `start`
    /// through `targets`: from the command the machine stands at, each
    /// target's taken at it ([`command_and_band_mm`]) in the state the
    /// line's motion puts the axes in (each axis that moves along the line
    /// runs its way, `next_state`; the others keep theirs): an axis'
    /// error depends on the other axes' states (a map's straightness
    /// tables), and the line turns them at its start.
    fn turns_of(
        &mut self,
        model: &dyn ErrorModel,
        start: Vec3,
        targets: &[Vec3],
        line: u64,
    ) -> Result<usize, CompensationError> {
        let Some(&end) = targets.last() else {
            return Ok(0);
        };
        let s = self.s;
        let along = crate::model::next_state(s, end - start);
        let (q_mm, file) = (self.q_out, self.walk.file);
        let cells = self.cells.get_or_insert_with(Box::default);
        let mut commands = Vec::with_capacity(targets.len() + 1);
        let mut bands_mm = Vec::with_capacity(targets.len() + 1);
        let (_, band) = command_and_band_mm(model, cells, start, s)
            .map_err(|source| super::model_error(file, line, source))?;
        commands.push(q_mm);
        bands_mm.push(band);
        for p in targets {
            let (c, band) = command_and_band_mm(model, cells, *p, along)
                .map_err(|source| super::model_error(file, line, source))?;
            commands.push(c);
            bands_mm.push(band);
        }
        Ok(turns(&commands, &bands_mm, s))
    }

    /// Writes the held line `held` now that the corner at its end (`next`)
    /// is known: solved and written whole as any line is
    /// ([`State::write_line`]), its targets kept out of that corner's zone.
    pub(super) fn write_held_line(
        &mut self,
        held: HeldLine,
        next: NextCorner,
        out: &mut dyn Write,
    ) -> Result<(), CompensationError> {
        let ev = LineEvent {
            number: held.number,
            file: held.file.as_deref(),
            bytes: &held.bytes,
            rendered: held.rendered,
            kind: held.kind,
            lexed: &held.lexed,
            motions: &held.motions,
            interp: &held.interp,
            after_end: held.after_end,
            // The next line is read by now: `next_corner` says what it is.
            next: volcomp_gcode::NextLine::unknown(),
        };
        let line = Line {
            ev: &ev,
            model: crate::model::WithTool {
                model: self.walk.model,
                tool_length_offset_mm: held.interp.tool_length_offset_mm(),
            },
            frame: held.frame,
            style: held.style,
            before: held.before,
            ending: super::lines::line_ending(&held.bytes),
            all_known: held.all_known,
        };
        self.buf.clear();
        self.targets = held.targets;
        self.next_corner = Some(next);
        let after = self.write_line(&line, out);
        self.next_corner = None;
        let after = after?;
        out.write_all(&self.buf)?;
        self.buf.clear();
        self.frame_before = Some(after);
        Ok(())
    }

    /// Raises the estimate of the contour error left by what the pieces
    /// of a line from `start` through `kept` leave where they are longer
    /// than the adaptive segmentation's (`split`: its points, of which
    /// [`points::protect_blends`] kept `kept`): the map's departure from
    /// the chord across the move on each piece that dropped a point
    /// ([`super::targets::whole_piece_departure_mm`]).
    pub(super) fn estimate_whole_pieces(
        &mut self,
        start: Vec3,
        split: &[Vec3],
        kept: &[Vec3],
        line: u64,
    ) -> Result<(), CompensationError> {
        let Some(&end) = kept.last() else {
            return Ok(());
        };
        let length = (end - start).norm();
        if length <= 0.0 {
            return Ok(());
        }
        let u = (end - start) * (1.0 / length);
        let along = |p: &Vec3| (*p - start).dot(u);
        let mut from = start;
        for to in kept {
            let (lo, hi) = (along(&from), along(to));
            let dropped = split
                .iter()
                .any(|p| along(p) > lo + 1e-9 && along(p) < hi - 1e-9);
            if dropped {
                let d_mm = super::targets::whole_piece_departure_mm(
                    (from, *to),
                    self.walk.options,
                    self.walk.model,
                    self.s,
                    self.cells.get_or_insert_with(Box::default),
                )
                .map_err(|source| super::model_error(self.walk.file, line, source))?;
                self.estimate_mm = self.estimate_mm.max(d_mm);
            }
            from = *to;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 30 mm X line, then a 2.5 mm Y line, both at F6000 under G64:
    /// blendmath.c's `d = min(L₁/2, L₂/2, d_tol, R/tan θ)` at this right
    /// angle (`θ = 45°`) is `min(15, 1.25, T·cos 45°/(1 − sin 45°) with
    /// T = 2.5/4 = 0.625 → 1.5089, R/tan 45° = R)`, `R = v²/a_n` =
    /// 100²/(1000·√(1 − 0.5²)) = 11.547 mm: 1.25 mm, the half of the short
    /// line.
    #[test]
    fn a_right_angle_into_a_short_step_takes_half_the_step() {
        let p = PlannerLimits::default();
        let (x, y) = (Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0));
        let kink = p.kink_ratio(x, y, 100.0, false);
        let d = corner_reach_mm(&p, (x, y), (30.0, 2.5), 100.0, 0.0, kink);
        assert!((d - 1.25).abs() < 1e-12, "{d}");
        // Into a 10 mm step the tolerance rule binds: T = 2.5 mm,
        // d_tol = 2.5 · 0.70711/(1 − 0.70711) = 6.0355 mm; R = 11.547 mm;
        // half the step 5 mm: 5 mm.
        let d = corner_reach_mm(&p, (x, y), (30.0, 10.0), 100.0, 0.0, kink);
        assert!((d - 5.0).abs() < 1e-12, "{d}");
        // At F3000 (R = 2.8868 mm) the speed binds: R/tan 45° = 2.8868.
        let kink = p.kink_ratio(x, y, 50.0, false);
        let d = corner_reach_mm(&p, (x, y), (30.0, 10.0), 50.0, 0.0, kink);
        let r = 50.0 * 50.0 / (1000.0 * 0.75f64.sqrt());
        assert!((d - r).abs() < 1e-9, "{d} {r}");
    }

    /// A hexagon's corner (60° deflection, `θ = 60°`) under G64 P0.005 at
    /// F6000: the blend keeps within 5 µm, `d = 0.005·cos 60°/(1 − sin 60°)`
    /// = 0.018660 mm, its arc of radius `d·tan 60°` = 0.032321 mm run at
    /// `√(a_n R)` = √(866.03 · 0.032321) = 5.2906 mm/s (`a_n` = 1000 ·
    /// √(1 − 0.5²); by hand). A take-up block of 6 µm may run at 6 mm/s
    /// (6 µm per 1 ms servo period): written as a block there. One of 4 µm
    /// (4 mm/s), the move's second target, G64 without P, or a join with
    /// no corner: not.
    #[test]
    fn a_take_up_at_a_corner_the_blend_all_but_stops_at_is_a_block_under_g64_p() {
        let p = PlannerLimits::default();
        let th = 60f64.to_radians();
        let d = 0.005 * th.cos() / (1.0 - th.sin());
        assert!((d - 0.018_660).abs() < 1e-6, "{d}");
        let v = blend_speed_mm_s(100.0, p.blend_distance_at_mm(60f64.to_radians(), 100.0), d);
        assert!((v - 5.2906).abs() < 1e-3, "{v}");
        // The hexagon's edge from (14.4889, 3.8823) to (3.8823, 14.4889)
        // after the edge from (10.6066, −10.6066) to it.
        let (a, b, c) = (
            Vec3::new(10.6066, -10.6066, 0.0),
            Vec3::new(14.4889, 3.8823, 0.0),
            Vec3::new(3.8823, 14.4889, 0.0),
        );
        let edge = |path_mode| Motion {
            kind: volcomp_gcode::MotionKind::Feed,
            start: b,
            end: c,
            line: 1,
            column: 1,
            feed: 6000.0,
            source: MotionSource::Program,
            extra: Default::default(),
            feed_mode: FeedMode::PerMinute,
            path_mode,
        };
        let t1 = (b - a) * (1.0 / (b - a).norm());
        let within = PathMode::Blend {
            tolerance_mm: 0.005,
            naive_cam_mm: 0.005,
        };
        let run = Run::of(&edge(within), Some((t1, (b - a).norm())), &p);
        assert!(
            (run.blend_speed_before_mm_s - 5.2906).abs() < 2e-3,
            "{}",
            run.blend_speed_before_mm_s
        );
        let rule = super::super::TakeUpRule::Within(0.005);
        let z6 = Vec3::new(0.0, 0.0, 0.006);
        assert!(block_at_slow_corner(rule, &run, 0, z6, &p));
        assert!(!block_at_slow_corner(rule, &run, 0, z6 * (4.0 / 6.0), &p));
        assert!(!block_at_slow_corner(rule, &run, 1, z6, &p));
        let always = super::super::TakeUpRule::Always;
        assert!(!block_at_slow_corner(always, &run, 0, z6, &p));
        // No corner before (the edge runs on along its own tangent).
        let straight = Run::of(
            &edge(within),
            Some(((c - b) * (1.0 / (c - b).norm()), 5.0)),
            &p,
        );
        assert!(!block_at_slow_corner(rule, &straight, 0, z6, &p));
    }

    /// A sharp corner (150° deflection, `θ = 15°`) is limited by the
    /// tolerance rule: `d_tol = T cos 15°/(1 − sin 15°)` = 1.30323 T, with
    /// `T` a quarter of the shorter line (8 mm → 2 mm): 2.6065 mm, below
    /// half of either line and below `R/tan 15°` = 43.09 mm.
    #[test]
    fn a_sharp_corner_is_limited_by_a_quarter_of_the_shorter_line() {
        let p = PlannerLimits::default();
        let phi = 150f64.to_radians();
        let (t1, t2) = (
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(phi.cos(), phi.sin(), 0.0),
        );
        let kink = p.kink_ratio(t1, t2, 100.0, false);
        let d = corner_reach_mm(&p, (t1, t2), (30.0, 8.0), 100.0, 0.0, kink);
        let th = 15f64.to_radians();
        let expected = 2.0 * th.cos() / (1.0 - th.sin());
        assert!((d - expected).abs() < 1e-9, "{d} {expected}");
        assert!((expected - 2.606_46).abs() < 1e-4);
    }

    /// Commands along X with Z's turning: up 1 µm, back 0.5 µm, up
    /// 0.7 µm against a 3 µm band: two turns (by hand); without the middle
    /// point (up 1 µm, up 0.2 µm) none. Z without a band (the ripple
    /// map's tables, `both`) turns at no cost: none counted.
    #[test]
    fn turns_are_counted_on_the_axes_with_a_band() {
        use crate::model::Direction::{Forward, Reverse};
        let s = [Forward; 3];
        let c = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(10.0, 0.0, 0.001),
            Vec3::new(20.0, 0.0, 0.0005),
            Vec3::new(30.0, 0.0, 0.0012),
        ];
        let band = [Vec3::new(0.0, 0.0, 0.003); 4];
        assert_eq!(turns(&c, &band, s), 2);
        assert_eq!(turns(&[c[0], c[1], c[3]], &band, s), 0);
        // From Z's reverse state the first step up is a turn too.
        assert_eq!(turns(&c, &band, [Forward, Forward, Reverse]), 3);
        assert_eq!(turns(&c, &[Vec3::ZERO; 4], s), 0);
    }

    /// A 20 mm X line with a 5 mm start zone and an 8 mm end zone (edge
    /// at 12 mm), the shortest piece 0.5 mm: the split 0.025 mm after the
    /// start zone's edge and the one 0.2 mm before the end zone's edge go
    /// (by hand: 0.025 and 0.2 < 0.5); the edges, and a split 2 mm from
    /// each, stay.
    #[test]
    fn no_split_nearer_a_zone_edge_than_the_shortest_piece() {
        let x = |v: f64| Vec3::new(v, 0.0, 0.0);
        let mut t: Vec<Vec3> = [5.0, 5.025, 10.0, 11.8, 12.0, 20.0].map(x).to_vec();
        drop_short_at_edges(&mut t, x(0.0), (5.0, 12.0), 0.5);
        assert_eq!(t, [5.0, 10.0, 12.0, 20.0].map(x).to_vec());
        let mut t: Vec<Vec3> = [5.0, 7.0, 10.0, 12.0, 20.0].map(x).to_vec();
        drop_short_at_edges(&mut t, x(0.0), (5.0, 12.0), 0.5);
        assert_eq!(t, [5.0, 7.0, 10.0, 12.0, 20.0].map(x).to_vec());
        // No start zone: the first split is no edge point and stays.
        let mut t: Vec<Vec3> = [0.2, 11.9, 12.0, 20.0].map(x).to_vec();
        drop_short_at_edges(&mut t, x(0.0), (0.0, 12.0), 0.5);
        assert_eq!(t, [0.2, 12.0, 20.0].map(x).to_vec());
    }

    /// No blend, no zone: a join the planner takes as tangent, and a
    /// reversal within 2°, where it stops.
    #[test]
    fn tangent_joins_and_reversals_have_no_zone() {
        let p = PlannerLimits::default();
        let x = Vec3::new(1.0, 0.0, 0.0);
        let back = Vec3::new(-1.0, 0.001, 0.0);
        let back = back * (1.0 / back.norm());
        let d = corner_reach_mm(&p, (x, back), (30.0, 30.0), 100.0, 0.0, 10.0);
        assert_eq!(d, 0.0);
        let d = corner_reach_mm(&p, (x, x), (30.0, 30.0), 100.0, 0.0, 0.0);
        assert_eq!(d, 0.0);
    }
}
