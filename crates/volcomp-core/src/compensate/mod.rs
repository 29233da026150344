//! Compensation of a part program (docs/design.md, "Compensation"): every target point of every
//! program motion is replaced by the command that, with the machine's error,
//! lands the tool on it; the program is written back losslessly.
//!
//! Flow per line: the interpreter gives the line's motions in the axis frame;
//! feed moves and arcs are split into target points (arcs linearised first,
//! rapids only at their end); each target is solved by [`solve_consistent`]
//! against the command the written program will really send (quantised to
//! the written decimals); the line is rewritten by byte-range edits and the
//! extra segments are inserted right after it, tagged with their source line.
//!
//! Reversals: when an axis must reverse on a feed move, a take-up move that
//! moves only the reversing axes (and, by the backlash model, not the tool) is
//! written before the segment, so the tool does not leave the path while the
//! axis takes up its reversal value. Axes for which no consistent reversal
//! exists (negative reversal value) are held and reported.

mod approach;
mod arc_fold;
mod arc_zone;
mod arcs;
mod cutter;
mod cycle;
mod cycle_keep;
mod end_zone;
mod exact_hold;
mod extra;
mod frame;
mod front;
pub mod header;
mod hold_fold;
mod idle;
mod joins;
mod line_arc;
mod line_limit;
mod lines;
mod options;
mod planar;
mod points;
mod ramp_band;
mod ramp_centre;
mod ramp_cross;
mod ramp_stage;
mod scurve;
mod size;
pub mod solve;
mod spline;
mod still_s;
mod style;
mod tail;
mod tail_hold;
mod take_up_across;
mod take_up_advance;
mod take_up_before;
mod take_up_order;
mod take_up_stand;
mod tangent_join;
mod targets;
mod transition_hold;
mod turn_back;
mod walk;

/// Helpers shared by the take-up modules' unit tests.
#[cfg(test)]
pub(crate) mod test_support {
    use volcomp_gcode::Vec3;

    /// A vector given in µm, in mm (the map's and the tests' hand values).
    pub(crate) fn um(x: f64, y: f64, z: f64) -> Vec3 {
        Vec3::new(x * 1e-3, y * 1e-3, z * 1e-3)
    }
}

pub use front::{
    file_name, header_for_map, refuse_if_compensated, Compensator, MachineSetup, HEAD_BYTES,
};
pub use joins::PlannerLimits;
pub use options::{
    unset_axes_text, CompensateOptions, CompensateSummary, DirectionPolicy, PointRecord,
    Segmentation, TakeUpRule, DEFAULT_CONTOUR_TOLERANCE_UM, DEFAULT_DECIMALS_INCH,
    DEFAULT_DECIMALS_MM, DEFAULT_DRILL_TOLERANCE_UM, DEFAULT_EXACT_CONTOUR_TOLERANCE_UM,
    DEFAULT_MAX_RESIDUAL_UM, DEFAULT_MIN_SEGMENT_LENGTH_MM,
};
pub use scurve::{least_cost_s, least_speed_mm_s};
pub use style::{survey_style, ProgramStyle};
pub(crate) use targets::mark_axes_set;
pub use targets::{target_count_bound, targets_of};

use crate::error::{CompensationError, ModelError};
use crate::model::next_state;
use crate::model::{Direction, Directions, ErrorModel, ALL_FORWARD};
use frame::Frame;
use lines::{
    arc_line_edits, explicit_mode, line_ending, stop_m_word, ArcWords, FeedInForce, InsertedFeed,
    OutMode,
};
use std::io::{BufRead, Write};
use targets::check_target_count;
use volcomp_gcode::edit::apply_edits;
use volcomp_gcode::lexer::LineKind;
use volcomp_gcode::number::NumberStyle;
use volcomp_gcode::{FeedMode, LineEvent, MotionKind, MotionSource, Vec3, Walker};
use walk::{Line, Place, Walk};

/// Streams `walker`'s program to `out` with every program motion compensated.
pub fn compensate_program<R: BufRead>(
    walker: &mut Walker<R>,
    file: &str,
    model: &dyn ErrorModel,
    program_style: &ProgramStyle,
    options: &CompensateOptions,
    out: &mut dyn Write,
    on_point: impl FnMut(&PointRecord),
) -> Result<CompensateSummary, CompensationError> {
    let on_line = &mut |_: &LineEvent<'_>| {};
    compensate_program_seen(
        walker,
        file,
        model,
        program_style,
        options,
        out,
        on_point,
        on_line,
    )
}

/// [`compensate_program`], every line `walker` reads also given to
/// `on_line` as it is read (a machining-time estimate of the original
/// plans its moves: `crate::plan::compare_while_writing_fed`).
#[allow(clippy::too_many_arguments)]
pub fn compensate_program_seen<R: BufRead>(
    walker: &mut Walker<R>,
    file: &str,
    model: &dyn ErrorModel,
    program_style: &ProgramStyle,
    options: &CompensateOptions,
    out: &mut dyn Write,
    mut on_point: impl FnMut(&PointRecord),
    on_line: &mut dyn FnMut(&LineEvent<'_>),
) -> Result<CompensateSummary, CompensationError> {
    let walk = Walk {
        model,
        options,
        survey: &program_style.survey,
        sep: if program_style.spaced { " " } else { "" },
        file,
    };
    let mut st = State::new(walk, walker.interpreter().position(), &mut on_point);
    // The set-up's `start` gives every axis a known position before the
    // program sets any; without it an axis is unknown until set.
    st.known = [walker.interpreter().start_given(); 3];
    st.feed_before = FeedInForce::after(walker.interpreter());
    // Every written line within LinuxCNC's 252 characters
    // (compensate/line_limit.rs), which counts what reaches `out`.
    let mut out = line_limit::LineLimit::new(out);
    out.file = file;
    while let Some(ev) = walker.next_line()? {
        if let Some(held) = st.held_line.take() {
            // The line held for the corner at its end is written now that
            // the next line is known (compensate/end_zone.rs).
            let next = end_zone::NextCorner::of(&ev, walk::known_after(st.known, &ev));
            out.source_line = held.number;
            if let Err(e) = st.write_held_line(held, next, &mut out) {
                return Err(out.error(e));
            }
        }
        on_line(&ev);
        let line = st.begin_line(&ev);
        if st.idle.is_some() {
            // A line held back for a take-up ahead (compensate/idle.rs)
            // goes out before this one, as this line's motion asks.
            let mut held = std::mem::take(&mut st.buf);
            out.source_line = st
                .release_idle(idle::next_motion(&line), &mut held)
                .unwrap_or(0);
            if let Err(e) = out.write_all(&held) {
                return Err(out.error(e.into()));
            }
            held.clear();
            st.buf = held;
        }
        out.source_line = ev.number;
        if st.tail.is_some() && !may_take_tail(&line) {
            // A held tail the line cannot start an S-curve from is
            // written before it.
            if let Err(e) = st.flush_tail(idle::next_motion(&line), tail::After::of(&line)) {
                return Err(out.error(e));
            }
            if let Err(e) = out.write_all(&st.buf) {
                return Err(out.error(e.into()));
            }
            st.buf.clear();
        }
        let after = match st.write_line(&line, &mut out) {
            Ok(after) => after,
            Err(e) => return Err(out.error(e)),
        };
        if let Some(p) = st.planar_pending.take() {
            // The arc before, its end planar only where this arc's start
            // is (compensate/planar.rs).
            let text = st.resolve_planar_end(p);
            if let Err(e) = out.write_all(&text) {
                return Err(out.error(e.into()));
            }
        }
        if let Err(e) = out.write_all(&st.buf) {
            return Err(out.error(e.into()));
        }
        if let Some(targets) = st.hold_line.take() {
            st.held_line = Some(end_zone::HeldLine::of(&line, targets));
        }
        st.frame_before = Some(after);
    }
    if let Some(held) = st.held_line.take() {
        // After the program's last line the planner stops: no blend.
        out.source_line = held.number;
        if let Err(e) = st.write_held_line(held, end_zone::NextCorner::Stop, &mut out) {
            return Err(out.error(e));
        }
    }
    if st.idle.is_some() {
        let mut held = Vec::new();
        out.source_line = st.release_idle(None, &mut held).unwrap_or(0);
        if let Err(e) = out.write_all(&held) {
            return Err(out.error(e.into()));
        }
    }
    if st.tail.is_some() {
        st.buf.clear();
        if let Err(e) = st.flush_tail(None, tail::After::CutEnds) {
            return Err(out.error(e));
        }
        if let Err(e) = out.write_all(&st.buf) {
            return Err(out.error(e.into()));
        }
    }
    st.summary.blocks_in = st.blocks_in.finish();
    if let Err(e) = out.end() {
        return Err(out.error(e.into()));
    }
    (st.summary.bytes_out, st.summary.blocks_out) = out.counts();
    st.summary.max_estimated_contour_um =
        matches!(options.segmentation, Segmentation::Adaptive { .. })
            .then_some(st.estimate_mm * 1e3);
    Ok(st.summary)
}

impl<'w> State<'w> {
    fn new(walk: Walk<'w>, q_start: Vec3, on_point: &'w mut dyn FnMut(&PointRecord)) -> Self {
        State {
            walk,
            on_point,
            q_out: q_start,
            s: ALL_FORWARD,
            s_nominal: ALL_FORWARD,
            mode: None,
            feed_before: FeedInForce::default(),
            last_tangent: None,
            normal_slope_out: None,
            frame_before: None,
            g93_before: false,
            g93_last: false,
            known: [false; 3],
            summary: CompensateSummary::default(),
            buf: Vec::with_capacity(1024),
            text: Vec::with_capacity(128),
            extra_text: String::new(),
            line_words: String::new(),
            states: Vec::new(),
            ramp_mids: Vec::new(),
            take_up_blocks: Vec::new(),
            s_line: None,
            s_pieces: Vec::new(),
            records: Vec::new(),
            targets: Vec::new(),
            commands: Vec::new(),
            line_edits: lines::LineEdits::default(),
            cells: Some(Box::default()),
            transitions: Vec::new(),
            transitions_written: Vec::new(),
            estimate_mm: 0.0,
            blocks_in: size::Blocks::default(),
            // The run of canned cycles in the written program.
            cycles: cycle_keep::Series::default(),
            tail: None,
            hold_line: None,
            held_line: None,
            next_corner: None,
            idle: None,
            defer_points: false,
            planar_before: false,
            arc_starts_planar: false,
            planar_pending: None,
            planar_start_kept: false,
            planar_line_normal: None,
            planar_corner_normal: None,
            ramp_end_zone_mm: 0.0,
            planar_corner_blends: false,
            plunge_held: [false; 3],
            next_dir: None,
            next_text: Vec::new(),
            program_dirs: [None; 3],
            arc_end_written: None,
            arc_end_before: None,
            approach_pending: None,
        }
    }

    /// Writes one line (into the buffer, or straight to `out` where it
    /// stays as it is) by the writer its kind calls for; returns the frame
    /// and number style in effect after it.
    fn write_line(
        &mut self,
        line: &Line,
        out: &mut dyn Write,
    ) -> Result<(Frame, NumberStyle), CompensationError> {
        let ev = line.ev;
        let own = (line.frame, line.style);
        let before = self.last_tangent.take();
        // The arc's written end reaches only the motion right after it
        // (compensate/tangent_join.rs).
        self.arc_end_before = if ev.motions.is_empty() {
            self.arc_end_written
        } else {
            self.arc_end_written.take()
        };
        let has = |source| ev.motions.iter().any(|m| m.source == source);
        let program_motion = has(MotionSource::Program);
        let runs = line.all_known && !ev.after_end;
        if has(MotionSource::Cycle) && runs {
            self.write_cycle(line)?;
            return Ok(own);
        }
        // A line that leaves the canned cycle ends the run.
        self.cycles.follow(ev.interp);
        if (ev.interp.cutter_comp_on() || has(MotionSource::CutterComp))
            && !ev.after_end
            && ev.kind == LineKind::Block
        {
            // Cutter compensation becomes the compensated tool-centre path
            // under G40: G0/G1 segments and G2/G3 arc pieces
            // (compensate/cutter.rs). Its cut starts from the side each band
            // is assumed on: no approach is written before or after it
            // (compensate/approach.rs).
            self.approach_pending = Some([false; 3]);
            self.write_cutter(line)?;
            self.mode = Some(OutMode::Other);
            self.known = [true; 3];
            self.note_feed(line);
            return Ok(own);
        }
        let spline = has(MotionSource::Spline);
        if (spline || ev.interp.in_nurbs_block()) && runs {
            // Splines become compensated G1 segments (compensate/spline.rs);
            // a G5.2 control-point line loses its spline words.
            if spline {
                self.write_spline(line)?;
            } else {
                let words: Vec<_> = line.words().collect();
                self.write_spline_block(line, &words, None)?;
            }
            self.note_feed(line);
            return Ok(own);
        }
        if !line.all_known && !ev.after_end && ev.kind == LineKind::Block {
            self.note_uncompensated(line)?;
        }
        if ev.after_end || ev.kind != LineKind::Block || !program_motion || !line.all_known {
            self.pass_through(line, out)?;
            if ev.motions.is_empty() {
                // No motion between: the next one follows the last.
                self.last_tangent = before;
            }
            return Ok(own);
        }
        self.last_tangent = before;
        self.write_motion_line(line)
    }

    /// A line whose moves run while an axis has never been set: its feed
    /// moves (not rapids, G53, G28/G30, nor a feed move of length zero)
    /// cannot be compensated, the map
    /// having no position on that axis. The program is refused at the first
    /// such move (its line and the column of its first axis word), or, with
    /// [`CompensateOptions::allow_uncompensated_axes`], the move is written
    /// as it is and counted.
    fn note_uncompensated(&mut self, line: &Line) -> Result<(), CompensationError> {
        // A feed move that goes nowhere (`G1 F10`) has nothing to compensate.
        let cuts = line.ev.motions.iter().any(|m| {
            m.kind != MotionKind::Rapid
                && !matches!(m.source, MotionSource::Machine | MotionSource::Reference)
                && (matches!(m.kind, MotionKind::Arc(_)) || m.end != m.start)
        });
        if !cuts {
            return Ok(());
        }
        let unset = self.known.map(|k| !k);
        let content = line.content();
        let at = line
            .words()
            .find(|w| matches!(w.letter, b'X' | b'Y' | b'Z' | b'@' | b'^'))
            .or_else(|| line.words().next())
            .map_or(0, |w| w.span.start.min(content.len()));
        let column = String::from_utf8_lossy(&content[..at]).chars().count() + 1;
        if !self.walk.options.allow_uncompensated_axes {
            let axes = options::unset_axes_text(unset);
            let one = unset.iter().filter(|u| **u).count() == 1;
            return Err(volcomp_gcode::GcodeError::new(
                volcomp_gcode::ErrorClass::Unsupported,
                line.number(),
                column,
                format!(
                    "this move cannot be compensated: the program has not set {axes} before it and the set-up gives no start, so the machine's {axes} {} unknown",
                    if one { "position is" } else { "positions are" }
                ),
                format!(
                    "give the machine's position when the program starts as `start = [X, Y, Z]` in the set-up file ({{setup}}), or add a move of {axes} to the program before this line; {{allow_uncompensated_axes}} writes such moves without compensation"
                ),
            )
            .with_source_line(content)
            .with_file(self.walk.file)
            .into());
        }
        let s = &mut self.summary;
        s.uncompensated_moves += 1;
        if s.first_uncompensated.is_none() {
            s.first_uncompensated = Some((line.number(), column));
            s.unset_axes = unset;
        }
        Ok(())
    }

    /// The feed state after a line that is not a compensated motion line
    /// (the interpreter's: an F sets the rate, G94 and G95 reset it to 0).
    fn note_feed(&mut self, line: &Line) {
        self.feed_before = FeedInForce::after(line.ev.interp);
    }

    /// A line without a compensated motion: written as it is (to `out`),
    /// or with the words a G92/G10 L20 or a G53 move needs where the
    /// machine is not at the nominal point; its motions followed.
    fn pass_through(&mut self, line: &Line, out: &mut dyn Write) -> Result<(), CompensationError> {
        let ev = line.ev;
        let (options, survey) = (self.walk.options, self.walk.survey);
        let added = g53_words_to_add(ev, line.all_known, options, survey);
        let mut offset_edits = if line.all_known && !ev.after_end {
            offset_setting_edits(ev, self.q_out, options, survey)
        } else {
            Vec::new()
        };
        if !offset_edits.is_empty() {
            // The machine is not at the nominal point (the last command
            // carried its correction): a G92 or G10 L20 written as it
            // was would take the correction into the offset it sets.
            self.buf.clear();
            apply_edits(ev.bytes, &mut offset_edits, &mut self.buf)
                .map_err(|e| edit_error(self.walk.file, ev.number, e))?;
            out.write_all(&self.buf)?;
            self.buf.clear();
        } else if added.is_empty() {
            out.write_all(ev.bytes)?;
        } else {
            // The machine is not where the interpreter's G53 move starts
            // (the tool-centre point a cutter-compensated move left it
            // at, while LinuxCNC's G53 keeps the programmed point of the
            // axes the line does not name): those axes are written.
            let ending = line_ending(ev.bytes);
            out.write_all(&ev.bytes[..ev.bytes.len() - ending.len()])?;
            out.write_all(added.as_bytes())?;
            out.write_all(ending)?;
        }
        self.summary.lines_out += 1;
        for m in ev.motions {
            // G53 and G28/G30 moves are sent as written: they are set-up
            // moves in machine coordinates, not part geometry. So are
            // spindle-synchronised moves (G33, G33.1), whose pitch ties
            // the feed axis to the spindle: written as they are, in G91
            // they move by their increment from where the last command
            // left the machine.
            let end = if m.source == MotionSource::SpindleSynced && !ev.interp.absolute() {
                self.q_out + (m.end - m.start)
            } else {
                m.end
            };
            self.s = next_state(self.s, end - self.q_out);
            self.s_nominal = self.s;
            self.q_out = end;
        }
        if let Some(mode) = explicit_mode(line.words()) {
            self.mode = Some(mode);
        }
        self.note_feed(line);
        Ok(())
    }

    /// A line with one program motion: its targets solved, the line
    /// rewritten with the first command and the other commands (with their
    /// take-ups) inserted after it. Returns the line's frame and style
    /// (with at least the line's own decimals).
    fn write_motion_line(
        &mut self,
        line: &Line,
    ) -> Result<(Frame, NumberStyle), CompensationError> {
        let ev = line.ev;
        let (file, sep) = (self.walk.file, self.walk.sep);
        // By reference: the motion is a few hundred bytes.
        let motion = &ev.motions[0];
        // Asked for several times below; each is a walk or a dozen
        // comparisons.
        let extra_moves = motion.extra.moves();
        let stop_any = stop_m_word(line.words());
        let interp = ev.interp;
        let model = line.model();
        // The line's words are quantised and written with at least their own
        // decimals, so an unchanged word is written back as it was.
        let (frame, style) = line.frame.with_line_decimals(line.words(), line.style);
        let (frame0, style0) = line.before_or((frame, style));
        let feed_before = self.feed_before;
        let feed_after = FeedInForce::after(interp);
        let options = self.walk.options;
        // Arcs are written as arcs unless the line needs what that path
        // does not write: a rotated frame, polar words or extra axes. Centres
        // read as absolute by option are written absolute too: the program's
        // own controller reads I/J/K so (docs/gcode.md, "Absolute arc
        // centres without G90.1").
        let arc_nominal = match motion.kind {
            MotionKind::Arc(arc)
                if options.arcs_as_arcs
                    && frame.rotation_deg == 0.0
                    && !extra_moves
                    && !line.ev.lexed.has_polar() =>
            {
                Some(arc)
            }
            _ => None,
        };
        // `arcs_as_arcs` is read only for an arc motion (targets.rs): the
        // options are copied with it changed only where it changes.
        let line_options_arc;
        let line_options = if matches!(motion.kind, MotionKind::Arc(_))
            && options.arcs_as_arcs != arc_nominal.is_some()
        {
            line_options_arc = CompensateOptions {
                arcs_as_arcs: arc_nominal.is_some(),
                ..*options
            };
            &line_options_arc
        } else {
            options
        };
        check_target_count(motion, line_options, file, ev.number)?;
        let run = points::Run::of(motion, self.last_tangent, &options.planner);
        self.next_dir = None;
        // An axis this line does not move keeps the direction it had.
        let end_tangent = points::tangents(motion).1;
        for (a, d) in self.program_dirs.iter_mut().enumerate() {
            if end_tangent[a].abs() > idle::STILL_COSINE {
                *d = Direction::of_delta(end_tangent[a]);
            }
        }
        let planar_before = std::mem::take(&mut self.planar_before);
        self.arc_starts_planar = planar_before;
        let planar_line_normal = self.planar_line_normal.take();
        self.planar_start_kept = false;
        // The tail the block before held back (arcs.rs, `HeldEnd`): the
        // S-curve at this arc's start begins there where the original runs
        // on through the join; else it is written first.
        // A tail whose block left the program's mode to restore is taken
        // only by a line that restores it on its own last piece.
        let restores = || {
            lines::piece_mode_words(
                motion.path_mode,
                line.words(),
                piece_blend_tolerance_mm(options) / frame.mm_per_unit,
                true,
                sep,
            )
            .is_some()
        };
        // A line's tail before an arc that reverses the axis it was held
        // for crosses that axis' band on the line (`Tail::line_s_curve`).
        let line_s = match (&self.tail, &arc_nominal) {
            (Some(t), Some(arc)) if t.may_start(arc, &run) => t
                .line_s_curve(arc, self.s, self.walk.model)
                .map_err(|source| model_error(file, t.line, source))?,
            _ => None,
        };
        if let (Some(t), Some(ls)) = (self.tail.as_mut(), line_s) {
            t.s_curve = Some(ls);
        }
        let held = match (&self.tail, &arc_nominal) {
            (Some(t), Some(arc))
                if line_s.is_none()
                    && t.may_start(arc, &run)
                    && (t.restore.is_none() || restores()) =>
            {
                Some((t.held.before_mm, t.held.radius_mm))
            }
            _ => None,
        };
        let next = Some(motion).filter(|m| m.kind != MotionKind::Rapid);
        if held.is_none() {
            self.flush_tail(next, tail::After::Arc)?;
        }
        // An arc may hold back its own tail for the block after where the
        // block ends as a plain compensated motion (no stop word, no
        // inverse time, no extra axes, adaptive segmentation).
        let joins = arcs::JoinTails {
            held_before: held,
            hold_end: stop_any.is_none()
                && interp.feed_mode() != FeedMode::InverseTime
                && !extra_moves
                && matches!(options.segmentation, Segmentation::Adaptive { .. }),
        };
        let mut held_end = None;
        // A line's own targets beyond the tail it holds back.
        let mut tail_targets = Vec::new();
        let mut start_tangent = None;
        let mut restore_pending = false;
        // The tail this arc's first S-curve starts from.
        let mut taken: Option<Tail> = None;
        let mut pieces: Vec<f64> = match arc_nominal {
            Some(arc) => {
                let mut planned = self.pieces_of_arc(&arc, model, ev.number, &run, joins)?;
                if held.is_some() && !planned.absorbed {
                    // No S-curve fits from the tail: it is written first.
                    self.flush_tail(next, tail::After::Arc)?;
                    let joins = arcs::JoinTails {
                        held_before: None,
                        ..joins
                    };
                    planned = self.pieces_of_arc(&arc, model, ev.number, &run, joins)?;
                }
                if let Some(mut t) = self.tail.take() {
                    start_tangent = Some(t.end_tangent(arc.plane));
                    restore_pending = t.restore.is_some();
                    if let Some(k) = t.kept.take() {
                        self.put_back(k);
                    }
                    taken = Some(t);
                }
                held_end = planned.held_end;
                planned.pieces
            }
            None => Vec::new(),
        };
        let mut targets = match arc_nominal {
            // A held line's targets were found when it was first read
            // (`State::write_held_line` puts them back).
            None if self.next_corner.is_some() => std::mem::take(&mut self.targets),
            Some(arc) => pieces
                .iter()
                .map(|l| if *l >= 1.0 { arc.end } else { arc.point_at(*l) })
                .collect(),
            // The map's cells the solves keep (the line's model is the
            // walk's map with the line's tool, as for them): the
            // segmentation's evaluations also leave them where the solves
            // along the move look next.
            None => targets::targets_in(
                motion,
                line_options,
                model,
                self.s,
                &mut self.estimate_mm,
                (
                    self.cells.get_or_insert_with(Box::default),
                    std::mem::take(&mut self.targets),
                ),
            )
            .map_err(|source| model_error(file, ev.number, source))?,
        };
        let feed_like = !matches!(motion.kind, MotionKind::Rapid);
        if arc_nominal.is_none() && matches!(motion.kind, MotionKind::Feed) {
            // Under G64 without P a line with splits waits for the next
            // line, which the blend at its end depends on
            // (compensate/end_zone.rs): it is written whole then.
            let holds = end_zone::holds_end(&run, joins.hold_end) && targets.len() > 1;
            // Under G64 (with or without P) a line that may lie in the
            // plane of an arc after it waits for the next line too: its
            // last piece may be written in that plane (compensate/line_arc.rs).
            // Only where the next line may be such an arc (a peek at its
            // text, `LineEvent::next_may_start_arc`): before any other line
            // the held line is written as it is now (`plan_planar_line_end`
            // plans before an arc only), so it is written now, without the
            // copy of the line and the interpreter a hold takes.
            let waits = line_arc::waits_for_arc(motion, &run, joins.hold_end)
                && self.planar_pending.is_none()
                && ev.next_may_start_arc();
            if (holds || waits) && self.next_corner.is_none() {
                self.hold_line = Some(targets);
                // The arc's end waits with the line (it is written again
                // from `write_held_line`).
                self.arc_end_written = self.arc_end_before.take();
                return Ok((frame, style));
            }
            // Under G61: where the next line goes, from its text
            // (compensate/tail_hold.rs).
            // Only the text is kept here (a copy into a buffer kept from
            // line to line); it is read where a still axis reverses at
            // the line's end, a few times a program.
            if matches!(options.take_up_rule(run.mode), TakeUpRule::Exact { .. }) {
                self.next_dir = tail_hold::keep_next_line(ev, &mut self.next_text)
                    .map(|from| (motion.end, tail_hold::NextDir::Text(from)));
            }
            let real_end_mm = self
                .next_corner
                .filter(|_| holds)
                .map(|next| next.end_zone_mm(&options.planner, &run, (motion.start, motion.end)));
            self.protect_line(
                model,
                &mut targets,
                motion.start,
                &run,
                real_end_mm,
                ev.number,
            )?;
            self.ramp_end_zone_mm = real_end_mm.unwrap_or(0.0);
            // Under G61 a line holds back its tail for an S-curve into an
            // arc that may run on from it (arcs.rs, `line_tail`): its
            // targets end short of its end.
            let smooth = options.take_up
                && options.fold_take_ups
                && options.directions == DirectionPolicy::Commanded
                && options.take_up_rule(run.mode) == TakeUpRule::Exact { smooth: true };
            if let (true, true, Some(f)) = (smooth, joins.hold_end, run.feed_mm_min) {
                let min_mm = options.arc_tolerances_mm(run.mode).1;
                held_end = arcs::line_tail(
                    (motion.start, motion.end),
                    interp.plane(),
                    model,
                    self.s,
                    f / 60.0,
                    &options.planner,
                    min_mm,
                )
                .map_err(|source| model_error(file, ev.number, source))?;
                if let Some(h) = held_end {
                    // The targets beyond the tail's start go with the tail
                    // (the end among them), those before it stay.
                    let length = (motion.end - motion.start).norm();
                    let tail_mm = length * h.at;
                    let along = |t: &Vec3| (*t - motion.start).norm();
                    tail_targets = targets
                        .iter()
                        .filter(|t| along(t) > tail_mm + min_mm)
                        .copied()
                        .collect();
                    if tail_targets.last() != Some(&motion.end) {
                        tail_targets.push(motion.end);
                    }
                    targets.retain(|t| along(t) < tail_mm - min_mm);
                    targets.push(motion.start + (motion.end - motion.start) * h.at);
                }
            }
        }
        if targets.len() > 1 && interp.feed_mode() == FeedMode::InverseTime {
            return Err(CompensationError::AtLine {
                file: file.into(),
                line: ev.number,
                message:
                    "splitting a block under inverse-time feed (G93) would change its duration"
                        .into(),
                help: crate::error::help::SPLIT_UNDER_INVERSE_TIME.into(),
            });
        }
        let line_ending = line.ending;
        let content_len = volcomp_gcode::lexer::content_len(ev.bytes);
        let content = line.content();
        // Solve every target first (the original line carries the first).
        let q_line_start = self.q_out;
        let s_line_start = self.s;
        // Where this arc takes the tail of the block before, that block's
        // end is written with the first S-curve: its point goes out first.
        // A feed line that leaves still an axis the motion before moved
        // may take that axis up ahead for the next motion: it is held back
        // with its points (compensate/idle.rs).
        let idle_axes = match (&arc_nominal, &held_end, &taken) {
            (None, None, None)
                if matches!(motion.kind, MotionKind::Feed)
                    && options.take_up
                    && options.fold_take_ups
                    && options.directions == DirectionPolicy::Commanded
                    && matches!(options.segmentation, Segmentation::Adaptive { .. })
                    && !extra_moves
                    && interp.feed_mode() != FeedMode::InverseTime
                    && stop_any.is_none()
                    && !line.ev.lexed.has_polar() =>
            {
                let mut axes =
                    idle::candidate_axes(motion.start, motion.end, self.last_tangent.map(|t| t.0));
                // Under G61 also a still axis in a state against the
                // program's, which the next line moves the program's way
                // (compensate/idle.rs `State::turned_back_axes`).
                if matches!(options.take_up_rule(run.mode), TakeUpRule::Exact { .. }) {
                    let back = self.turned_back_axes(motion.start, motion.end);
                    for (a, b) in axes.iter_mut().zip(back) {
                        *a |= b;
                    }
                }
                axes
            }
            _ => [false; 3],
        };
        let idle_any = idle_axes.iter().any(|a| *a);
        self.defer_points = taken.is_some() || idle_any;
        // A take-up may get a lead piece of a line or an arc piece
        // (compensate/points.rs) where the segmentation adapts to the path
        // anyway; not on moves that carry extra axes, or under inverse time.
        let may_lead = feed_like
            && !extra_moves
            && interp.feed_mode() != FeedMode::InverseTime
            && matches!(options.segmentation, Segmentation::Adaptive { .. });
        let leads = match (&arc_nominal, may_lead) {
            (_, false) => points::Leads::Nowhere,
            (Some(arc), true) => points::Leads::Arc {
                arc,
                pieces: &mut pieces,
            },
            (None, true) => points::Leads::Lines,
        };
        // A line into an arc of its plane: its last piece planar
        // (compensate/line_arc.rs).
        let planar_line_end = match arc_nominal {
            None if taken.is_none() && held_end.is_none() && !extra_moves => {
                self.plan_planar_line_end(model, &frame, (motion, &run), &mut targets, ev.number)?
            }
            _ => None,
        };
        // An arc after a planar G64 corner: its normal axis' reversal at
        // the corner may be held to keep it planar (compensate/turn_back.rs).
        self.planar_corner_normal = arc_nominal
            .filter(|a| {
                planar_before
                    && run.corner_before
                    && run.protect_mm > 0.0
                    && run.feed_mm_min.is_some()
                    && held_end.is_none()
                    && taken.is_none()
                    && matches!(motion.path_mode, volcomp_gcode::PathMode::Blend { .. })
                    && planar::planar_arc(motion, a.plane).is_some()
            })
            .map(|a| a.plane.axes().2);
        // Its normal axis' reversal held over its first piece only where
        // the corner is blended, not a reversal the planner stops at
        // (compensate/planar.rs `normal_held_at_start`).
        self.planar_corner_blends = self.planar_corner_normal.is_some()
            && self
                .last_tangent
                .is_some_and(|(t1, _)| !planar::stops_at(t1, points::tangents(motion).0));
        // Under G61 a still axis' take-up inside a line may go on an S
        // (compensate/still_s.rs): not under cutter radius compensation,
        // where the plane cannot change.
        self.s_line =
            (arc_nominal.is_none() && taken.is_none() && may_lead && !interp.cutter_comp_on())
                .then_some(still_s::LineContext {
                    plane: interp.plane(),
                    style,
                });
        let commands = self.solve_targets(
            model,
            (&frame, &frame0),
            points::Targets {
                points: &mut targets,
                leads,
                start: motion.start,
                feed_like,
                run,
            },
            ev.number,
        );
        self.s_line = None;
        self.defer_points = false;
        self.planar_corner_normal = None;
        self.planar_corner_blends = false;
        self.ramp_end_zone_mm = 0.0;
        let mut commands = commands?;
        let planar_line_split = planar_line_end.is_some_and(|p| {
            self.apply_planar_line_end(p, (&mut targets, &mut commands), q_line_start)
        });
        // A line after an arc it joins tangent in the original: its first
        // piece begins along the arc's written end tangent
        // (compensate/tangent_join.rs).
        let arc_end = self.arc_end_before.take();
        let s_at_first = commands
            .first()
            .is_some_and(|c| self.s_pieces.iter().any(|p| p.from == c.0));
        if let (Some(end), None, None, None, false, false) = (
            arc_end,
            &arc_nominal,
            &taken,
            &held_end,
            extra_moves,
            s_at_first,
        ) {
            self.tangent_lead(
                end,
                model,
                (motion, &run),
                (&mut targets, &mut commands),
                (&frame, q_line_start, s_line_start),
            );
        }
        // Each axis' dead band brought to a known side before the program
        // cuts (compensate/approach.rs).
        let approach = self
            .approach_before(
                model,
                feed_like,
                (q_line_start, s_line_start),
                commands.last().map_or(q_line_start, |c| c.0),
                options.take_up,
            )
            .map_err(|source| model_error(file, ev.number, source))?;
        let mut idle_flips = Vec::new();
        let n = commands.len();
        let last_record = self.records.last();
        let plain_end = last_record.is_some_and(|r| {
            !r.take_up && !r.reversed.iter().any(|r| *r) && !r.held.iter().any(|h| *h)
        });
        if let (true, true, true, Segmentation::Adaptive { min_length_mm, .. }) = (
            idle_any && plain_end,
            targets.len() == n && n > 0,
            commands.last().is_some_and(|c| c.1.is_none()),
            options.segmentation,
        ) {
            let (q_prev, t_prev) = match n {
                1 => (q_line_start, motion.start),
                _ => (commands[n - 2].0, targets[n - 2]),
            };
            if (targets[n - 1] - t_prev).norm() >= min_length_mm {
                let piece = idle::LastPiece {
                    model,
                    frame: &frame,
                    q_prev,
                    t_prev,
                    t_end: targets[n - 1],
                    rule: options.take_up_rule(run.mode),
                    line: ev.number,
                };
                idle_flips = self.idle_flips(&piece, idle_axes)?;
            }
        }
        let mut idle_last = 0..0;
        // Where the last piece's text begins, and the mode before it.
        let mut last_piece_at = (0, None);
        let place = Place {
            frame: &frame,
            style,
            line: ev.number,
            ending: line_ending,
        };
        // Arc pieces: the centre of each, through its compensated start,
        // middle and end (compensate/arcs.rs).
        // The program's plane to select again after each piece written as
        // an S in another plane (compensate/still_s.rs).
        let mut s_planes: Vec<Option<volcomp_gcode::Plane>> = Vec::new();
        let mut arc_words: Vec<ArcWords> = match arc_nominal {
            Some(arc) => self.arc_piece_words(
                model,
                &place,
                arcs::Piecewise {
                    arc: &arc,
                    pieces: &pieces,
                    radius_style: line.words().any(|w| w.letter == b'R'),
                    turn_tolerance: points::piece_turn_tolerance(options, &run, &arc),
                    chord_turn_tolerance: planar::chord_turn_tolerance(options, &run, &arc),
                    start_tangent,
                },
                &commands,
                q_line_start,
            )?,
            None if !self.s_pieces.is_empty() => {
                let (words, found) = still_s::piece_words(&self.s_pieces, &commands, q_line_start);
                if found != self.s_pieces.len() {
                    return Err(CompensationError::AtLine {
                        file: file.into(),
                        line: ev.number,
                        message: "internal error: an S-curve take-up lost its place in the line"
                            .into(),
                        help: "please report this with the program line".into(),
                    });
                }
                s_planes = words.iter().map(|w| w.1).collect();
                words.into_iter().map(|w| w.0).collect()
            }
            None => Vec::new(),
        };
        // The first piece after a G64 corner with the arc before written
        // planar there (compensate/planar.rs).
        let blend = matches!(motion.path_mode, volcomp_gcode::PathMode::Blend { .. });
        let planar_arc = arc_nominal.filter(|a| {
            blend
                && run.feed_mm_min.is_some()
                && held_end.is_none()
                && taken.is_none()
                && planar::planar_arc(motion, a.plane).is_some()
        });
        if let (Some(arc), true, true, None) = (
            planar_arc,
            planar_before && run.corner_before && run.protect_mm > 0.0,
            pieces.len() == commands.len(),
            approach,
        ) {
            self.planar_start(
                model,
                (&frame, style, ev.number),
                &arc,
                (
                    arc_zone::planar_reach_mm(
                        options.take_up_rule(run.mode),
                        &run,
                        planar::Side::Start,
                    ),
                    0.5 * run.protect_mm,
                ),
                q_line_start,
                (&mut pieces, &mut targets),
                (&mut commands, &mut arc_words),
                (
                    planar::planar_tolerance_mm(options, run.mode),
                    line.words().any(|w| w.letter == b'R'),
                    points::piece_turn_tolerance(options, &run, &arc),
                ),
            )?;
        }
        // A line after a G64 corner whose arc before may end planar: its
        // first piece planar keeps LinuxCNC's blend arc (planar.rs).
        if let (Some(w), None, true) = (
            planar_line_normal,
            &arc_nominal,
            planar_before && run.corner_before && run.protect_mm > 0.0 && approach.is_none(),
        ) {
            self.planar_start_kept = planar::line_starts_planar(&commands, q_line_start, w);
        }
        // The pieces as written: a planar start split after a corner
        // (`planar_start`) added one since the count above, and the last
        // piece (the one a planar end or a tail takes) is the last of them.
        let n = commands.len();
        // Extra axes (A … W) of a split motion: each segment carries its share.
        let mut extra_plan = extra::ExtraPlan::new(
            motion.extra,
            interp.extra_offset(),
            motion.start,
            &targets,
            &frame,
        );
        // Write: the commands were solved from the position before the line.
        let mut pos = q_line_start;
        let mode_before = self.mode;
        if let (Some(t), Some(arc)) = (&taken, &arc_nominal) {
            pos = self.write_join_split(
                t,
                (arc, &mut arc_words),
                (q_line_start, &commands),
                model,
                s_line_start,
            )?;
        }
        let stop_word = if commands.len() > 1 { stop_any } else { None };
        let needed = if feed_like {
            OutMode::Feed
        } else {
            OutMode::Rapid
        };
        // A first piece written as two arcs (an S-curve from the join with
        // the block before, compensate/arcs.rs): the line carries the first
        // to the joint, the second is inserted after it.
        let first_split = arc_words.first().and_then(|w| {
            w.second.map(|s| {
                let second = ArcWords {
                    center: s.center,
                    clockwise: s.clockwise,
                    second: None,
                    ..*w
                };
                (s.joint, second)
            })
        });
        let first_arc = arc_words.first().filter(|w| w.center.is_some());
        let needed_first = first_arc.map_or(needed, |w| w.mode());
        // Under G61/G61.1 a block written as several lines runs its pieces
        // under `G64 P p Q0` and restores the program's mode on its last
        // (lines.rs, `piece_mode_words`). A take-up between its pieces
        // stays a stop under the program's mode: the pieces before it end
        // under that mode, those after it run under `G64 P p Q0` again.
        // A piece that is an arc cannot carry P (its turn count): the words
        // go on a line of their own before it, read in the units in effect
        // there.
        // A tail held back (arcs.rs, `HeldEnd`) is a line of the block,
        // written later: the block's last run of pieces ends on it, so the
        // program's mode is restored there, not on the last piece written
        // now. A tail taken from the block before with its mode not yet
        // restored begins the first run.
        let n_pieces = commands.len();
        let holds = held_end.is_some();
        let lines_of_block = n_pieces
            + usize::from(first_split.is_some())
            + usize::from(holds)
            + usize::from(restore_pending);
        let p_mm = piece_blend_tolerance_mm(options);
        let piece_words = |mm_per_unit: f64| {
            let arc = matches!(motion.kind, MotionKind::Arc(_));
            lines::piece_mode_words(motion.path_mode, line.words(), p_mm / mm_per_unit, arc, sep)
        };
        let piece_modes = if lines_of_block > 1 {
            piece_words(frame.mm_per_unit)
                .zip(piece_words(frame0.mm_per_unit))
                .map(|((own, restore), (before, _))| (own, before, restore))
        } else {
            None
        };
        // Where each run of pieces between take-ups begins and ends (runs
        // of one line are left alone).
        // (Read only where `piece_modes` is set: allocated only then.)
        let runs = if piece_modes.is_some() { n_pieces } else { 0 };
        let mut tail_restore = None;
        let mut run_starts = vec![false; runs];
        let mut run_ends = vec![false; runs];
        if piece_modes.is_some() {
            let mut k = 0;
            while k < n_pieces {
                let end = (k + 1..n_pieces)
                    .find(|j| commands[*j].1.is_some())
                    .unwrap_or(n_pieces);
                let last = end == n_pieces && holds;
                let lines = end - k
                    + usize::from(k == 0 && (first_split.is_some() || restore_pending))
                    + usize::from(last);
                if lines > 1 {
                    run_starts[k] = true;
                    if last {
                        tail_restore = piece_modes.as_ref().map(|(_, _, r)| *r);
                    } else {
                        run_ends[end - 1] = true;
                    }
                }
                k = end;
            }
        }
        // Under G64 P p Q q an arc written as several arc pieces runs them
        // under `G64 P p Q0` (on a line before the block) and the program's
        // words come back on a line after it (joins.rs, `naive_cam_words`).
        let naive_cam = if lines_of_block > 1
            && piece_modes.is_none()
            && (arc_words.iter().any(|w| w.center.is_some()) || planar_line_split)
        {
            joins::naive_cam_words(
                motion.path_mode,
                line.words(),
                (frame0.mm_per_unit, frame.mm_per_unit),
                matches!(motion.kind, MotionKind::Arc(_)),
                sep,
            )
        } else {
            None
        };
        if let Some((before, _)) = &naive_cam {
            let at = Place {
                frame: &frame0,
                style: style0,
                ..place
            };
            self.push_path_mode_line(before, &at);
            self.summary.naive_cam_off_blocks += 1;
        }
        if run_starts.iter().any(|s| *s) {
            self.summary.pieces_blended_blocks += 1;
            self.summary.piece_blend_tolerance_um =
                self.summary.piece_blend_tolerance_um.max(p_mm * 1e3);
        }
        // The last inserted line ends as the original did (without an
        // ending where it had none and no stop word follows).
        let last_ending: &[u8] = if content_len == ev.bytes.len() && stop_word.is_none() {
            b""
        } else {
            line_ending
        };
        if let Some(p) = approach {
            let at = Place {
                frame: &frame0,
                style: style0,
                ..place
            };
            self.write_approach(&at, pos, p);
        }
        for (i, (q, take_up)) in commands.iter().enumerate() {
            let piece_at = (self.buf.len(), self.mode);
            if i + 1 == n {
                last_piece_at = piece_at;
            }
            if let Some(tu) = take_up {
                // The first take-up runs before the line's own words: in the
                // previous line's frame, distance mode, units and feed; later
                // ones in the line's.
                let (tu_frame, tu_style, tu_feed) = if i == 0 {
                    (&frame0, style0, feed_before.inserted_feed())
                } else {
                    (&frame, style, feed_after.inserted_feed())
                };
                let tu_mode = match tu_feed {
                    InsertedFeed::InForce => OutMode::Feed,
                    InsertedFeed::Rapid => OutMode::Rapid,
                };
                let at = Place {
                    frame: tu_frame,
                    style: tu_style,
                    ..place
                };
                pos = self.write_take_up_blocks(&at, pos, i, tu_mode);
                self.write_inserted(&at, pos, *tu, tu_mode, "take-up");
                pos = *tu;
            }
            let ending = if i + 1 == commands.len() {
                last_ending
            } else {
                line_ending
            };
            let restore_here = piece_modes
                .as_ref()
                .filter(|_| run_ends[i])
                .map(|(_, _, restore)| *restore);
            let start_here = piece_modes.as_ref().filter(|_| run_starts[i]);
            if let (Some((own, _, _)), true) = (start_here, i > 0) {
                // A run that begins after a take-up: an arc piece gets the
                // words on a line of their own, a line piece on its line.
                if arc_words.get(i).is_some_and(|w| w.center.is_some()) {
                    self.text.clear();
                    self.text.extend_from_slice(own.as_bytes());
                    self.push_inserted(&place.with_ending(line_ending), "path mode");
                    self.summary.path_mode_lines += 1;
                } else {
                    self.line_words = own.clone();
                }
            }
            if i == 0 {
                if let (Some((_, words, _)), true) = (start_here, first_arc.is_some()) {
                    let at = Place {
                        frame: &frame0,
                        style: style0,
                        ..place
                    };
                    self.push_path_mode_line(words, &at);
                }
                // A line of one piece held for a take-up ahead: the line's
                // edits with each variant's end (compensate/idle.rs).
                let mut flips = std::mem::take(&mut idle_flips);
                for f in flips.iter_mut().filter(|_| n == 1) {
                    let mut edits = lines::LineEdits::default();
                    self.original_line_edits(
                        &mut edits,
                        line,
                        &place,
                        lines::FirstCommand {
                            from: pos,
                            q: f.q_mm,
                            kind: &motion.kind,
                            needed: needed_first,
                            stop_word,
                            polar_nominal: targets[0],
                            polar_start: motion.start,
                        },
                    );
                    edits
                        .apply(ev.bytes, &mut f.text)
                        .map_err(|e| edit_error(file, ev.number, e))?;
                }
                idle_flips = flips;
                // The line's edits, in a buffer kept between lines.
                let mut edits = std::mem::take(&mut self.line_edits);
                edits.clear();
                self.original_line_edits(
                    &mut edits,
                    line,
                    &place,
                    lines::FirstCommand {
                        from: pos,
                        q: first_split.map_or(*q, |(joint, _)| joint),
                        kind: if first_arc.is_some() {
                            &MotionKind::Feed
                        } else {
                            &motion.kind
                        },
                        needed: needed_first,
                        stop_word,
                        polar_nominal: targets[0],
                        polar_start: motion.start,
                    },
                );
                if let Some(w) = first_arc {
                    // The line's own G2/G3 turns the way its first arc does
                    // (the part of an S-curve after the cut at a block join,
                    // `write_join_split`, may turn the other way).
                    for g in line
                        .words()
                        .filter(|g| g.letter == b'G' && (g.value == 2.0 || g.value == 3.0))
                    {
                        if (g.value == 2.0) != w.clockwise {
                            let zero = content[g.value_span.clone()].starts_with(b"0");
                            let code: &[u8] = match (w.clockwise, zero) {
                                (true, false) => b"2",
                                (true, true) => b"02",
                                (false, false) => b"3",
                                (false, true) => b"03",
                            };
                            edits.replace(g.value_span.clone(), code);
                        }
                    }
                    edits.extend(arc_line_edits(
                        line.words(),
                        content,
                        w.text(&frame, style, sep, pos),
                    ));
                }
                if let Some(plan) = extra_plan.as_mut() {
                    let words: Vec<_> = line.words().collect();
                    for (span, text) in plan.first_edits(&words, style) {
                        edits.replace(span, text.as_bytes());
                    }
                }
                if let (Some((words, _, _)), None) = (start_here, first_arc) {
                    // After the line's last word (and after every other
                    // edit there).
                    let end = line.words().map(|w| w.span.end).max();
                    let space = if sep.is_empty() { "" } else { " " };
                    edits.insert(
                        end.unwrap_or(content.len()),
                        format!("{space}{words}").as_bytes(),
                    );
                }
                let applied = edits.apply(ev.bytes, &mut self.buf);
                self.line_edits = edits;
                applied.map_err(|e| edit_error(file, ev.number, e))?;
                if content_len == ev.bytes.len() && commands.len() > 1 {
                    self.buf.extend_from_slice(b"\n");
                }
                self.mode = Some(needed_first);
                self.summary.lines_out += 1;
                if let Some((joint, second)) = first_split {
                    if let Some(restore) = restore_here {
                        self.line_words = restore.to_string();
                    }
                    self.write_inserted_arc(&place.with_ending(ending), joint, *q, &second, "");
                }
            } else if let Some(w) = arc_words.get(i) {
                let back = s_planes.get(i).copied().flatten();
                if back.is_some() {
                    self.push_plane_line(
                        still_s::plane_word(w.plane),
                        &place.with_ending(line_ending),
                    );
                }
                if let Some(restore) = restore_here {
                    self.line_words = restore.to_string();
                }
                self.write_inserted_arc(&place.with_ending(ending), pos, *q, w, "");
                if let Some(p) = back {
                    self.push_plane_line(still_s::plane_word(p), &place.with_ending(line_ending));
                }
            } else {
                if let Some(plan) = extra_plan.as_mut() {
                    self.extra_text = plan.words_for(i, style, sep);
                }
                if let Some(restore) = restore_here {
                    self.line_words = restore.to_string();
                }
                self.write_inserted(&place.with_ending(ending), pos, *q, needed, "");
            }
            if !self.line_words.is_empty() {
                // The piece rounded to nothing and was not written: the
                // mode is restored on a line of its own; words that would
                // have begun a run are dropped (the run stays under the
                // program's mode).
                self.line_words.clear();
                if let Some(restore) = restore_here {
                    self.text.clear();
                    self.text.extend_from_slice(restore.as_bytes());
                    self.push_inserted(&place.with_ending(ending), "path mode");
                    self.summary.path_mode_lines += 1;
                }
            }
            if i + 1 == n && !idle_flips.is_empty() {
                idle_last = piece_at.0..self.buf.len();
                if i > 0 {
                    self.idle_piece_texts(
                        &mut idle_flips,
                        (&place.with_ending(ending), pos, needed, piece_at.1),
                        restore_here,
                    );
                }
            }
            pos = *q;
        }
        let last_piece = last_piece_at.0..self.buf.len();
        if let Some((_, after)) = &naive_cam {
            self.text.clear();
            self.text.extend_from_slice(after.as_bytes());
            self.push_inserted(&place.with_ending(line_ending), "path mode");
            self.summary.path_mode_lines += 1;
        }
        if let Some(w) = stop_word {
            self.buf.extend_from_slice(&content[w.span.clone()]);
            self.buf.extend_from_slice(line_ending);
            self.summary.lines_out += 1;
        }
        self.feed_before = feed_after;
        self.last_tangent =
            feed_like.then(|| (points::tangents(motion).1, points::length_mm(motion)));
        if let Some(held) = held_end {
            self.tail = Some(Tail {
                path: match arc_nominal {
                    Some(arc) => TailPath::Arc(arc),
                    None => TailPath::Line(motion.start, motion.end),
                },
                targets: tail_targets,
                held,
                frame,
                style,
                line: ev.number,
                ending: line_ending.to_vec(),
                run,
                tool_length_offset_mm: interp.tool_length_offset_mm(),
                radius_style: line.words().any(|w| w.letter == b'R'),
                turn_tolerance: arc_nominal
                    .and_then(|arc| points::piece_turn_tolerance(options, &run, &arc)),
                restore: tail_restore,
                kept: None,
                s_curve: None,
            });
            self.keep_tail_piece((&targets, &pieces, &arc_words, &commands), last_piece_at);
        }
        if idle_any {
            self.hold_idle(ev.number, idle_last, idle_flips);
        }
        // An arc's line held back with its last piece's planar variant, for
        // a G64 corner with the next arc (compensate/planar.rs).
        if let (Some(arc), true) = (
            planar_arc,
            n >= 1
                && pieces.len() == n
                && stop_word.is_none()
                && interp.feed_mode() != FeedMode::InverseTime
                && matches!(options.segmentation, Segmentation::Adaptive { .. })
                && piece_modes.is_none()
                && self.idle.is_none()
                && commands[n - 1].1.is_none()
                && self.states.len() == n
                && arc_words
                    .get(n - 1)
                    .is_some_and(|w| w.center.is_some() && w.second.is_none())
                && (self.buf[..last_piece.start].ends_with(b"\n")
                    || (n == 1 && last_piece.start == 0))
                // Last: it reads the line's text.
                && (n >= 2
                    || (planar_arc.is_some() && planar::plain_arc_line(line.words(), content))),
        ) {
            let planar = planar::PlanarEnd {
                arc,
                piece_from: if n >= 2 { pieces[n - 2] } else { 0.0 },
                from_mm: if n >= 2 {
                    commands[n - 2].0
                } else {
                    q_line_start
                },
                mode_before: if n >= 2 { None } else { Some(mode_before) },
                to_mm: commands[n - 1].0,
                state: self.states[n - 1],
                frame,
                style,
                line: ev.number,
                ending: last_ending.to_vec(),
                line_ending: line_ending.to_vec(),
                tool_length_offset_mm: interp.tool_length_offset_mm(),
                radius_style: line.words().any(|w| w.letter == b'R'),
                turn_tolerance: points::piece_turn_tolerance(options, &run, &arc),
                mode: motion.path_mode,
            };
            self.hold_planar(ev.number, last_piece, planar);
        }
        // An arc written whole, its last piece not held back: its end for
        // a line after it (compensate/tangent_join.rs).
        let arc_end = match (&arc_nominal, arc_words.last(), commands.last()) {
            (Some(_), Some(w), Some((q, _))) if held_end.is_none() => {
                let k = commands.len() - 1;
                let before = if k == 0 {
                    q_line_start
                } else {
                    commands[k - 1].0
                };
                let from = commands[k].1.unwrap_or(before);
                tangent_join::end_tangent(w, from, *q)
                    .map(|tangent| tangent_join::WrittenArcEnd { q_mm: *q, tangent })
            }
            _ => None,
        };
        // Held back (compensate/idle.rs): it counts where the text goes out
        // as solved.
        match self.idle.as_mut() {
            Some(h) if h.line == ev.number => h.arc_end = arc_end,
            _ => self.arc_end_written = arc_end,
        }
        // The buffers back for the next motion line.
        (self.targets, self.commands) = (targets, commands);
        Ok((frame, style))
    }

    /// Writes the part of an arc's first S-curve that lies before the block
    /// join, from the tail `t` the block before held back: the S-curve cut
    /// where it crosses the normal through the join
    /// ([`arcs::split_at_normal`]; the normal through the join's command
    /// solved in the state the block arrives in, so the tool reaches the
    /// join's normal where the block before ends), written in that block's
    /// frame and traced to its line, with a point record for its end ahead
    /// of this block's (deferred by `defer_points`). The first words of
    /// `arc_words` become the part after the cut. Returns where this
    /// block's own line starts (the tail's start where no cut is found).
    fn write_join_split(
        &mut self,
        t: &Tail,
        (arc, arc_words): (&volcomp_gcode::Arc, &mut [ArcWords]),
        (from, commands): (Vec3, &[(Vec3, Option<Vec3>)]),
        model: &dyn ErrorModel,
        s_arrived: Directions,
    ) -> Result<Vec3, CompensationError> {
        let join = arc.start;
        let split = match (arc_words.first(), commands.first()) {
            (Some(words), Some((q, None))) => {
                let q_join = solve::solve_fixed(
                    model,
                    self.walk.options.method,
                    join,
                    s_arrived,
                    [false; 3],
                    Vec3::ZERO,
                )
                .map_err(|source| command_error(model, self.walk.file, t.line, join, source))?
                .q_mm;
                arcs::split_at_normal(
                    words,
                    (from, *q),
                    (q_join, arcs::plane_tangent(arc, 0.0)),
                    &t.frame,
                    t.style,
                )
            }
            _ => None,
        };
        let mut start = from;
        if let Some(split) = split {
            let place = Place {
                frame: &t.frame,
                style: t.style,
                line: t.line,
                ending: &t.ending,
            };
            self.write_inserted_arc(&place, from, split.at, &split.before, "");
            arc_words[0] = split.after;
            start = split.at;
            let residual_um = (crate::model::actual_mm(
                model,
                split.at,
                s_arrived,
                crate::model::Components::All,
            )
            .map_err(|source| model_error(self.walk.file, t.line, source))?
                - join)
                .norm()
                * 1e3;
            self.summary.points += 1;
            (self.on_point)(&PointRecord {
                line: t.line,
                target_mm: join,
                command_mm: split.at,
                iterations: 0,
                residual_um,
                reversed: [false; 3],
                held: [false; 3],
                take_up: false,
                rapid: false,
            });
        }
        for r in &self.records {
            (self.on_point)(r);
        }
        Ok(start)
    }

    /// Writes the held tail, if any, into the buffer: the last piece of
    /// its arc, from the command its block ended at to the compensated end,
    /// traced to its block's line. A line's tail takes up ahead an axis
    /// the motion `next` reverses, where it can (compensate/idle.rs).
    /// Where the block's last piece was kept back with it, the two are
    /// written as one piece where that changes no reversal and writes no
    /// take-up block (compensate/tail.rs), else the piece as it was first.
    fn flush_tail(
        &mut self,
        next: Option<&volcomp_gcode::Motion>,
        after: tail::After,
    ) -> Result<(), CompensationError> {
        let Some(mut t) = self.tail.take() else {
            return Ok(());
        };
        if let Some(k) = t.kept.take() {
            if self.merge_tail(&t, &k, (next, after))? {
                return Ok(());
            }
            self.write_kept(k);
        }
        let solved = self.solve_tail(&t, None, next)?;
        self.write_tail(&t, solved)
    }

    /// Solves a held tail (see [`State::flush_tail`]): from the command its
    /// block ended at, or, with the block's last piece `kept`, from the
    /// command before that piece over both (lead pieces and ramps on it
    /// where a take-up asks for them).
    fn solve_tail(
        &mut self,
        t: &Tail,
        kept: Option<&tail::KeptPiece>,
        next: Option<&volcomp_gcode::Motion>,
    ) -> Result<tail::SolvedTail, CompensationError> {
        let model = crate::model::WithTool {
            model: self.walk.model,
            tool_length_offset_mm: t.tool_length_offset_mm,
        };
        let at_from = kept.map_or(t.held.at, |k| k.at_prev);
        let piece = match t.path {
            TailPath::Arc(arc) => Some(arcs::sub_arc(&arc, at_from, 1.0)),
            TailPath::Line(..) => None,
        };
        let (start, end) = match (t.path, &piece) {
            (_, Some(p)) => (p.start, p.end),
            (TailPath::Line(a, b), None) => (kept.map_or(a + (b - a) * t.held.at, |k| k.t_prev), b),
            (TailPath::Arc(_), None) => unreachable!("an arc's tail is an arc piece"),
        };
        if let Some(k) = kept {
            self.q_out = k.q_prev;
        }
        let mut piece_ends = vec![1.0];
        let mut targets = match t.path {
            TailPath::Line(..) => t.targets.clone(),
            TailPath::Arc(_) => vec![end],
        };
        let from = self.q_out;
        self.transitions.clear();
        let ahead = match (t.path, next, targets.as_slice()) {
            (TailPath::Line(..), Some(_), [_]) if t.s_curve.is_some() => {
                t.s_curve.map(|ls| arcs::Transition {
                    index: 0,
                    axis: ls.axis,
                    direction: ls.direction,
                    deviation_mm: 0.0,
                    spread: None,
                    widest: true,
                })
            }
            (TailPath::Line(a, b), Some(m), [_]) => {
                let piece = idle::LastPiece {
                    model: &model,
                    frame: &t.frame,
                    q_prev: from,
                    t_prev: start,
                    t_end: end,
                    rule: self.walk.options.take_up_rule(t.run.mode),
                    line: t.line,
                };
                self.tail_take_up(&piece, (a, b), m)?
            }
            _ => None,
        };
        self.transitions.extend(ahead);
        let folded = self.summary.take_ups_folded;
        // Under G61 a line's end held where the next motion turns its
        // reversal back (compensate/tail_hold.rs).
        self.next_dir = match (t.path, next) {
            (TailPath::Line(_, b), Some(m))
                if matches!(
                    self.walk.options.take_up_rule(t.run.mode),
                    TakeUpRule::Exact { .. }
                ) =>
            {
                let u = points::tangents(m).0;
                (u.norm() > 0.0).then_some((b, tail_hold::NextDir::Known(u)))
            }
            _ => None,
        };
        let commands = self.solve_targets(
            &model,
            (&t.frame, &t.frame),
            points::Targets {
                points: &mut targets,
                leads: match (&piece, kept) {
                    (Some(arc), Some(_)) => points::Leads::Arc {
                        arc,
                        pieces: &mut piece_ends,
                    },
                    (None, Some(_)) => points::Leads::Lines,
                    (_, None) => points::Leads::Nowhere,
                },
                start,
                feed_like: true,
                run: points::tail_run(
                    t.run,
                    matches!(t.path, TailPath::Line(..)),
                    self.walk.options.take_up_rule(t.run.mode),
                ),
            },
            t.line,
        );
        self.next_dir = None;
        let commands = commands?;
        if ahead.is_some() && self.summary.take_ups_folded > folded {
            // Counted as taken up ahead, not as a fold.
            self.summary.take_ups_folded -= 1;
            self.summary.take_ups_idle += 1;
        }
        Ok(tail::SolvedTail {
            piece,
            piece_ends,
            commands,
            from,
        })
    }

    /// Writes a solved tail ([`State::solve_tail`]) into the buffer.
    fn write_tail(&mut self, t: &Tail, solved: tail::SolvedTail) -> Result<(), CompensationError> {
        let model = crate::model::WithTool {
            model: self.walk.model,
            tool_length_offset_mm: t.tool_length_offset_mm,
        };
        let tail::SolvedTail {
            piece,
            piece_ends,
            commands,
            from,
        } = solved;
        let place = Place {
            frame: &t.frame,
            style: t.style,
            line: t.line,
            ending: &t.ending,
        };
        let words = match &piece {
            Some(piece) => self.arc_piece_words(
                &model,
                &place,
                arcs::Piecewise {
                    arc: piece,
                    pieces: &piece_ends,
                    radius_style: t.radius_style,
                    turn_tolerance: t.turn_tolerance,
                    chord_turn_tolerance: None,
                    start_tangent: None,
                },
                &commands,
                from,
            )?,
            None => Vec::new(),
        };
        let mut pos = from;
        for (i, (q, take_up)) in commands.iter().enumerate() {
            if let Some(tu) = take_up {
                pos = self.write_take_up_blocks(&place, pos, i, OutMode::Feed);
                self.write_inserted(&place, pos, *tu, OutMode::Feed, "take-up");
                pos = *tu;
            }
            let s_words = match (t.s_curve, commands.len(), take_up) {
                (Some(ls), 1, None) => tail::line_s_words(&ls, &t.frame, t.style, (pos, *q)),
                _ => None,
            };
            let restore = t.restore.filter(|_| i + 1 == commands.len());
            match (words.get(i), s_words) {
                (None, Some(w)) => {
                    // The block's mode comes back on a line of its own
                    // after the S-curve (below), which so ends under the
                    // pieces' blending: under G61 (exact path) its join with
                    // the arc would be a stop wherever the plane's normal
                    // axis turns there by more than the planner's kink
                    // tolerance (tp.c `tpSetupTangent`: 0.8 mrad at 60 mm/s),
                    // and the share of that axis' switch the S carries
                    // turns it by up to ~1 mrad.
                    self.write_inserted_arc(&place, pos, *q, &w, "");
                    if let Some(restore) = restore {
                        self.line_words = restore.to_string();
                    }
                }
                (w, _) => {
                    // The block's mode comes back on its last line.
                    if let Some(restore) = restore {
                        self.line_words = restore.to_string();
                    }
                    match w {
                        Some(w) => self.write_inserted_arc(&place, pos, *q, w, ""),
                        None => self.write_inserted(&place, pos, *q, OutMode::Feed, ""),
                    }
                }
            }
            pos = *q;
        }
        if !self.line_words.is_empty() {
            // The piece rounded to nothing: the mode on a line of its own.
            self.text.clear();
            self.text
                .extend_from_slice(std::mem::take(&mut self.line_words).as_bytes());
            self.push_inserted(&place, "path mode");
            self.summary.path_mode_lines += 1;
        }
        Ok(())
    }
}

/// The tail of an arc under G61 held back for an S-curve across its end
/// ([`arcs::HeldEnd`]), with what writing it as it is takes: its block's
/// nominal arc, frame, style, line and line ending, run, tool and arc
/// words.
struct Tail {
    path: TailPath,
    /// A line's targets from the tail's start on (its end the last): the
    /// points its segmentation put there.
    targets: Vec<Vec3>,
    held: arcs::HeldEnd,
    frame: Frame,
    style: NumberStyle,
    line: u64,
    ending: Vec<u8>,
    run: points::Run,
    tool_length_offset_mm: Vec3,
    radius_style: bool,
    turn_tolerance: Option<f64>,
    /// The program's path-control word its block's last run of pieces
    /// restores on the tail (lines.rs, `piece_mode_words`), if any.
    restore: Option<&'static str>,
    /// The block's last piece before the tail, kept back with it
    /// (compensate/tail.rs): merged with the tail where no S-curve takes it.
    kept: Option<tail::KeptPiece>,
    /// A line's tail that crosses the band of the axis the arc after it
    /// reverses ([`Tail::line_s_curve`]), written as an S-curve on the line.
    s_curve: Option<tail::LineS>,
}

/// The nominal path of a held tail's block.
#[derive(Clone, Copy)]
enum TailPath {
    Arc(volcomp_gcode::Arc),
    /// A line from its start to its end.
    Line(Vec3, Vec3),
}

impl Tail {
    /// Whether an arc that runs `run` may start its S-curve from this tail:
    /// it starts where the tail's block ends (an arc: in the same plane),
    /// without a corner, at the same feed and path mode (whether the
    /// reversing axis turns there and a window fits,
    /// [`arcs::plan_transitions`] decides).
    fn may_start(&self, arc: &volcomp_gcode::Arc, run: &points::Run) -> bool {
        let (same_plane, end) = match self.path {
            TailPath::Arc(a) => (a.plane == arc.plane, a.end),
            TailPath::Line(_, end) => (true, end),
        };
        !run.corner_before
            && run.feed_mm_min == self.run.feed_mm_min
            && run.mode == self.run.mode
            && same_plane
            && (arc.start - end).norm() <= 1e-9
    }

    /// The unit tangent of the tail's block where the tail starts, in the
    /// axes of `plane`.
    fn end_tangent(&self, plane: volcomp_gcode::Plane) -> [f64; 2] {
        match self.path {
            TailPath::Arc(a) => arcs::plane_tangent(&a, self.held.at),
            TailPath::Line(a, b) => {
                let (u, v, _) = plane.axes();
                let (du, dv) = (b[u] - a[u], b[v] - a[v]);
                let n = du.hypot(dv);
                [du / n, dv / n]
            }
        }
    }
}

/// Whether `line` may start an S-curve from a held tail: one program arc,
/// compensated (every axis known, before the program end, outside cutter
/// compensation); the writer decides the rest ([`Tail::may_start`]).
fn may_take_tail(line: &Line) -> bool {
    let ev = line.ev;
    ev.kind == LineKind::Block
        && !ev.after_end
        && line.all_known
        && !ev.interp.cutter_comp_on()
        && matches!(ev.motions, [m] if m.source == MotionSource::Program
            && matches!(m.kind, MotionKind::Arc(_)))
}

/// The tolerance (mm) within which the planner may blend the joins between
/// a G61 block's pieces (lines.rs, `piece_mode_words`): the contour
/// tolerance of the adaptive segmentation, else its default.
fn piece_blend_tolerance_mm(options: &CompensateOptions) -> f64 {
    match options.segmentation {
        Segmentation::Adaptive { tolerance_mm, .. } => tolerance_mm,
        _ => DEFAULT_CONTOUR_TOLERANCE_UM * 1e-3,
    }
}

/// An edit of a line that did not apply (overlapping spans): a bug of
/// ours, reported at the line.
fn edit_error(file: &str, line: u64, e: impl std::fmt::Display) -> CompensationError {
    CompensationError::AtLine {
        file: file.into(),
        line,
        message: format!("internal edit error: {e}"),
        help: "please report this with the program line".into(),
    }
}

pub(super) fn model_error(file: &str, line: u64, source: ModelError) -> CompensationError {
    CompensationError::Model {
        file: file.into(),
        line,
        target_mm: None,
        source,
    }
}

/// A model error at the command that compensates target `t`: reported with
/// the target when the target itself lies inside the map's range.
fn command_error(
    model: &dyn ErrorModel,
    file: &str,
    line: u64,
    t: Vec3,
    source: ModelError,
) -> CompensationError {
    let r = model.range_mm();
    let inside = (0..3).all(|a| t[a] >= r[a][0] && t[a] <= r[a][1]);
    CompensationError::Model {
        file: file.into(),
        line,
        target_mm: inside.then_some(t),
        source,
    }
}

/// The walk's own state: what has been sent so far and what is being
/// written (module documentation of `walk.rs`).
struct State<'w> {
    /// The walk's inputs.
    walk: Walk<'w>,
    /// Called with every solved point.
    on_point: &'w mut dyn FnMut(&PointRecord),
    /// Axes whose position the program has set; until all three are known,
    /// motions are written unchanged (the start position is not the program's).
    known: [bool; 3],
    q_out: Vec3,
    s: Directions,
    s_nominal: Directions,
    mode: Option<OutMode>,
    /// The feed mode and rate in force after the previous line.
    feed_before: FeedInForce,
    /// The end tangent and the length of the last motion, where it was a
    /// compensated feed motion of the program (for the corner test of the
    /// next, and its blend).
    last_tangent: Option<(Vec3, f64)>,
    /// The slope over the last written piece of the last motion solved (an
    /// arc's normal axis, a line's direction), for an arc that follows it
    /// tangent ([`arcs::NormalSlopeOut`]).
    normal_slope_out: Option<arcs::NormalSlopeOut>,
    /// Frame and number style in effect before the current line (after the
    /// previous one): what a move written before the line's own words uses.
    frame_before: Option<(Frame, NumberStyle)>,
    /// Whether inverse time (G93) was in effect before the current line,
    /// and after it.
    g93_before: bool,
    g93_last: bool,
    summary: CompensateSummary,
    buf: Vec<u8>,
    /// The inserted line being written (ASCII but for the words of
    /// path-control and extra axes, copied from the program's own).
    text: Vec<u8>,
    /// Extra-axis words (A … W) for the next inserted command.
    extra_text: String,
    /// Path-control words for the next inserted line (the program's mode
    /// restored on a block's last piece, lines.rs `piece_mode_words`).
    line_words: String,
    /// Direction state of each command of the last [`State::solve_targets`].
    states: Vec<Directions>,
    /// The offset a take-up ramp puts on the middle of the piece that
    /// ends at each target (zero off a ramp), for the arc written through it.
    ramp_mids: Vec<Vec3>,
    /// Take-up blocks written before a command's own take-up (its index
    /// in the last [`State::solve_targets`]' commands), in order
    /// (compensate/take_up_order.rs).
    take_up_blocks: Vec<(usize, Vec3)>,
    /// Under G61, for the line being solved: what an S taking up an axis
    /// it keeps still needs of the writer (compensate/still_s.rs); `None`
    /// where no S is tried.
    s_line: Option<still_s::LineContext>,
    /// The S pieces of the last [`State::solve_targets`] (still_s.rs).
    s_pieces: Vec<still_s::SPiece>,
    /// The per-point records of the motion being solved (a buffer kept
    /// between motions, compensate/points.rs).
    records: Vec<PointRecord>,
    /// The targets and the solved commands of the motion line being
    /// written (buffers kept between motion lines).
    targets: Vec<Vec3>,
    commands: Vec<(Vec3, Option<Vec3>)>,
    /// The edits of the line being written (a buffer kept between lines).
    line_edits: lines::LineEdits,
    /// The map's table cells last used ([`crate::model::AxisCells`]),
    /// kept between points and lines: the cells of the walk's map
    /// ([`Walk::model`]), which every line's model is with the line's tool.
    /// Boxed, so [`State::solve_targets`] takes them for its motion and
    /// puts them back without copying them.
    cells: Option<Box<crate::model::AxisCells>>,
    /// S-curve take-ups of the arc the next [`State::solve_targets`] solves
    /// ([`arcs::plan_transitions`]); it takes them.
    transitions: Vec<arcs::Transition>,
    /// The transitions the last [`State::solve_targets`] took, for the
    /// writer.
    transitions_written: Vec<arcs::Transition>,
    /// Largest contour error the segmentation estimates it leaves (mm).
    estimate_mm: f64,
    /// Block counting of the input and the output ([`size::Blocks`]).
    blocks_in: size::Blocks,
    /// The run of canned cycles in the written program
    /// (compensate/cycle_keep.rs).
    cycles: cycle_keep::Series,
    /// The tail of the last arc, held back for an S-curve across its end
    /// ([`Tail`]).
    tail: Option<Tail>,
    /// Set by [`State::write_motion_line`] where the line waits for the
    /// corner at its end (compensate/end_zone.rs): its targets.
    hold_line: Option<Vec<Vec3>>,
    /// The line waiting for the corner at its end: written when the next
    /// line is read ([`State::write_held_line`]).
    held_line: Option<end_zone::HeldLine>,
    /// While a held line is written: the corner at its end.
    next_corner: Option<end_zone::NextCorner>,
    /// The last line, held back for a take-up ahead in it
    /// (compensate/idle.rs): it never holds a [`Tail`] too.
    idle: Option<idle::IdleHold>,
    /// The point records of the motion being solved are kept in `records`
    /// rather than passed on (the block before's end, written with this
    /// motion's first S-curve, goes first: `write_join_split`).
    defer_points: bool,
    /// The axes whose dead band's side is not known yet
    /// (compensate/approach.rs); `None` before the first compensated motion.
    approach_pending: Option<[bool; 3]>,
    /// The arc before ended planar at a G64 corner (compensate/planar.rs):
    /// the next arc's first piece is written planar at the corner too.
    planar_before: bool,
    /// The motion being compensated starts after a corner the arc before
    /// ended planar at (`planar_before` as it was taken for it): no zone at
    /// its start (compensate/arc_zone.rs).
    arc_starts_planar: bool,
    /// The arc before's line with and without its planar end, written once
    /// the next arc's first piece is solved (compensate/planar.rs).
    planar_pending: Option<planar::PendingEnd>,
    /// The last arc's first piece is planar at the corner before it.
    planar_start_kept: bool,
    /// The arc before may end planar at a G64 corner with a line
    /// (compensate/planar.rs): the normal axis of its plane.
    planar_line_normal: Option<usize>,
    /// While an arc after a planar G64 corner is solved: its plane's
    /// normal axis (compensate/turn_back.rs).
    planar_corner_normal: Option<usize>,
    /// While a line held for the corner at its end is solved under G64
    /// without P: the zone before its end kept whole for that corner's
    /// blend (mm; compensate/end_zone.rs), where a ramp does not end
    /// (points.rs `plan_ramp`); 0 elsewhere.
    ramp_end_zone_mm: f64,
    /// While an arc after a planar G64 corner is solved: whether that
    /// corner is blended (not a reversal LinuxCNC stops at).
    planar_corner_blends: bool,
    /// The axes the last motion, a plunge, held through its end instead of
    /// a take-up (compensate/points.rs `hold_to_plunge_end`): the next
    /// line's start may hold them on.
    plunge_held: [bool; 3],
    /// While a G61 line (or a line's tail) is solved: its end and the unit
    /// direction the next motion starts in, where known, or the next line's
    /// text to read it from (compensate/tail_hold.rs).
    next_dir: Option<(Vec3, tail_hold::NextDir)>,
    /// The next line's text for `next_dir` (one buffer, reused).
    next_text: Vec<u8>,
    /// The direction the program's nominal path last moved each axis in
    /// (its motions' end tangents), `None` before any: an axis a line
    /// does not move whose state is against it may be taken up ahead
    /// (compensate/idle.rs `State::turned_back_axes`).
    program_dirs: [Option<Direction>; 3],
    /// The last motion, an arc, as written: its end command and tangent
    /// (compensate/tangent_join.rs); `None` after anything else, or where
    /// its last piece is held back.
    arc_end_written: Option<tangent_join::WrittenArcEnd>,
    /// While a motion line is written: `arc_end_written` as the line
    /// before left it.
    arc_end_before: Option<tangent_join::WrittenArcEnd>,
}

/// Edits of a line that sets an offset from the current point (G92, or
/// G10 L20: "the current point has these coordinates"), so that the offset
/// it sets in the written program is the original's: the written program
/// stands at the last command `q_out`, not at the nominal point, and
/// LinuxCNC (`convert_axis_offsets`, `convert_setup`, interp_convert.cc)
/// makes the offset the difference between the current point and the words.
/// Each X, Y, Z word gains the difference of the two points (program frame
/// and units; in G7 an X word is a diameter). G10 L20 in a rotated system
/// is left as it is.
fn offset_setting_edits(
    ev: &volcomp_gcode::LineEvent<'_>,
    q_out: Vec3,
    options: &CompensateOptions,
    survey: &volcomp_gcode::number::StyleSurvey,
) -> Vec<volcomp_gcode::edit::Edit> {
    let mut edits = Vec::new();
    if ev.kind != LineKind::Block || !ev.motions.is_empty() {
        return edits;
    }
    let g = |v: f64| ev.lexed.words().any(|w| w.letter == b'G' && w.value == v);
    let l20 = g(10.0)
        && ev
            .lexed
            .words()
            .any(|w| w.letter == b'L' && w.value == 20.0);
    let (frame, style) = Frame::of(ev.interp, options, survey);
    if !(g(92.0) || (l20 && frame.rotation_deg == 0.0)) {
        return edits;
    }
    let d = frame.program(q_out) - frame.program(ev.interp.position());
    for w in ev.lexed.words() {
        if !matches!(w.letter, b'X' | b'Y' | b'Z') {
            continue;
        }
        let a = usize::from(w.letter - b'X');
        let k = if a == 0 { frame.x_word_scale } else { 1.0 };
        let own = w.decimals;
        // Less than half a step of the written resolution: the word stays.
        if (d[a] * k).abs() < 0.5 * 10f64.powi(-i32::from(style.decimals.max(own))) {
            continue;
        }
        let style = style.with_decimals(style.decimals.max(own.min(15)));
        let mut text = String::new();
        volcomp_gcode::number::format_number(w.value + d[a] * k, style, &mut text);
        edits.push(volcomp_gcode::edit::Edit::replace(
            w.value_span.clone(),
            text,
        ));
    }
    edits
}

/// The axis words a G53 line written as it is must gain so that the machine
/// ends where the interpreter's G53 move ends: the axes the line does not
/// name but the move changes (after cutter radius compensation the move
/// starts at the tool-centre point and LinuxCNC's G53 keeps the programmed
/// point of the other axes). G53 words are machine coordinates in program
/// units.
fn g53_words_to_add(
    ev: &volcomp_gcode::LineEvent<'_>,
    all_known: bool,
    options: &CompensateOptions,
    survey: &volcomp_gcode::number::StyleSurvey,
) -> String {
    let mut text = String::new();
    let [m] = ev.motions else {
        return text;
    };
    if ev.after_end || !all_known || m.source != MotionSource::Machine {
        return text;
    }
    let (frame, style) = Frame::of(ev.interp, options, survey);
    let named = |letter: u8| ev.lexed.words().any(|w| w.letter == letter);
    for (a, letter) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
        if !named(letter) && (m.end[a] - m.start[a]).abs() > 1e-9 {
            text.push(' ');
            text.push(letter as char);
            volcomp_gcode::number::format_number(m.end[a] / frame.mm_per_unit, style, &mut text);
        }
    }
    text
}
