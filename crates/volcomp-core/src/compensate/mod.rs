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

pub mod solve;

use crate::error::{CompensationError, ModelError};
use crate::model::{Directions, ErrorModel, WithTool, ALL_FORWARD};
use crate::simulate::next_state;
use crate::compensate::solve::{solve_consistent, solve_fixed, Method};
use std::io::{BufRead, Write};
use volcomp_gcode::edit::{apply_edits, Edit};
use volcomp_gcode::lexer::{LineKind, Word};
use volcomp_gcode::number::{format_number, NumberStyle, StyleSurvey};
use volcomp_gcode::{FeedMode, MotionKind, MotionSource, Units, Vec3, Walker};

/// How feed moves are split into target points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Segmentation {
    /// One target per move (arcs are still linearised).
    Off,
    /// This many segments per block (as the papers do).
    Count(u32),
    /// Segments no longer than this (mm).
    MaxLength(f64),
    /// As many segments as the map needs: a segment is halved while the
    /// error's departure from a straight line between its ends (which is what
    /// compensating only the ends leaves on the path) exceeds the tolerance
    /// at its quarter points, down to `min_length_mm`.
    Adaptive {
        /// Contour tolerance (mm).
        tolerance_mm: f64,
        /// Shortest segment (mm).
        min_length_mm: f64,
    },
}

/// Which direction state chooses the error tables.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DirectionPolicy {
    /// The direction of the command actually sent (docs/design.md, "Direction state and backlash"; default).
    Commanded,
    /// The direction of the nominal move, as the papers do (for comparison).
    Nominal,
}

/// Options of [`compensate_program`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompensateOptions {
    /// Point solver.
    pub method: Method,
    /// Splitting of feed moves.
    pub segmentation: Segmentation,
    /// Chord tolerance for arcs (mm).
    pub chord_tolerance_mm: f64,
    /// Written decimals; `None`: 4 in mm, 5 in inch, or more where the
    /// program writes more. A rewritten word never has fewer decimals than
    /// the word it replaces.
    pub decimals: Option<u8>,
    /// Largest accepted correction (mm).
    pub max_correction_mm: f64,
    /// Table choice.
    pub directions: DirectionPolicy,
    /// Insert take-up moves at reversals on feed moves.
    pub take_up: bool,
    /// Tag inserted lines with `(volcomp Ln)`.
    pub trace_comments: bool,
    /// Largest model residual `‖t − (q + e(q))‖` accepted at a point (µm),
    /// for the solvers that aim at the target (exact, ILC; direct and pitch
    /// are checked for finiteness only); `None` checks only finiteness. A point past it is an error at its
    /// line: a program whose points do not reach their targets is never
    /// written as a success. Points with a held axis are exempt (their
    /// residual is the reversal value the take-up cannot cover,
    /// docs/compensation.md).
    pub max_residual_um: Option<f64>,
}

impl Default for CompensateOptions {
    fn default() -> Self {
        Self {
            method: Method::Exact,
            segmentation: Segmentation::MaxLength(1.0),
            chord_tolerance_mm: 1e-4,
            decimals: None,
            max_correction_mm: 0.1,
            directions: DirectionPolicy::Commanded,
            take_up: true,
            trace_comments: true,
            max_residual_um: Some(DEFAULT_MAX_RESIDUAL_UM),
        }
    }
}

/// Default of [`CompensateOptions::max_residual_um`]: 1 µm, ten times the
/// solver's own tolerance plus the rounding of a written coordinate (half a
/// step of 0.1 µm in mm, 0.254 µm in inch, on three axes), so a converged
/// point always passes and an unconverged one (ILC stopped early, a map the
/// solver cannot invert) never does.
pub const DEFAULT_MAX_RESIDUAL_UM: f64 = 1.0;

/// One compensated target point, for the per-point report.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointRecord {
    /// Source line.
    pub line: u64,
    /// Nominal target (axis frame, mm).
    pub target_mm: Vec3,
    /// Command written (axis frame, mm).
    pub command_mm: Vec3,
    /// Solver iterations.
    pub iterations: u32,
    /// Model residual at the command (µm).
    pub residual_um: f64,
    /// Axes reversed on this move.
    pub reversed: [bool; 3],
    /// Axes held (no consistent reversal).
    pub held: [bool; 3],
    /// A take-up move was written before this point.
    pub take_up: bool,
    /// The point ends a rapid (measured by no metric: rapids do not cut).
    pub rapid: bool,
}

/// What a compensation run did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CompensateSummary {
    /// Lines read.
    pub lines_in: u64,
    /// Lines written.
    pub lines_out: u64,
    /// Target points compensated.
    pub points: u64,
    /// Largest model residual (µm).
    pub max_residual_um: f64,
    /// Largest correction `‖q − t‖` (µm).
    pub max_correction_um: f64,
    /// Take-up moves written.
    pub take_ups: u64,
    /// Lines where an axis was held, with the axis letter (first 100).
    pub held: Vec<(u64, char)>,
    /// Total number of holds.
    pub held_count: u64,
}

/// How a program writes its numbers and separates its words.
#[derive(Debug, Clone, Default)]
pub struct ProgramStyle {
    /// Evidence of the number style.
    pub survey: StyleSurvey,
    /// Words are separated by blanks (`G1 X1`), not written together (`G1X1`).
    pub spaced: bool,
}

/// Infers the program's number style and word spacing from its first bytes.
pub fn survey_style(head: &[u8]) -> ProgramStyle {
    let mut survey = StyleSurvey::default();
    let mut lexed = volcomp_gcode::lexer::Lexed::default();
    let (mut spaced, mut compact) = (0u32, 0u32);
    for line in head.split(|b| *b == b'\n') {
        let content = &line[..volcomp_gcode::lexer::content_len(line)];
        if volcomp_gcode::lexer::classify(content) != LineKind::Block
            || volcomp_gcode::lexer::lex_block(content, &mut lexed).is_err()
        {
            continue;
        }
        let mut prev_end = None;
        for w in lexed.words() {
            if matches!(w.letter, b'X' | b'Y' | b'Z' | b'I' | b'J' | b'K' | b'R') {
                survey.record(&content[w.value_span.clone()]);
            }
            if let Some(e) = prev_end {
                if e == w.span.start {
                    compact += 1;
                } else {
                    spaced += 1;
                }
            }
            prev_end = Some(w.span.end);
        }
    }
    ProgramStyle {
        survey,
        spaced: spaced >= compact,
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum OutMode {
    Rapid,
    Feed,
    Other,
}

/// Streams `walker`'s program to `out` with every program motion compensated.
pub fn compensate_program<R: BufRead>(
    walker: &mut Walker<R>,
    file: &str,
    model: &dyn ErrorModel,
    program_style: &ProgramStyle,
    options: &CompensateOptions,
    out: &mut dyn Write,
    mut on_point: impl FnMut(&PointRecord),
) -> Result<CompensateSummary, CompensationError> {
    let mut st = State {
        q_out: walker.interpreter().position(),
        s: ALL_FORWARD,
        s_nominal: ALL_FORWARD,
        mode: None,
        feed_known: false,
        frame_before: None,
        known: [false; 3],
        summary: CompensateSummary::default(),
        buf: Vec::with_capacity(1024),
        text: String::with_capacity(128),
    };
    let sep = if program_style.spaced { " " } else { "" };
    let survey = &program_style.survey;
    while let Some(ev) = walker.next_line()? {
        // Models with Abbe terms see the tool that is active on this line.
        let tool_model = WithTool {
            model,
            tool_length_offset_mm: ev.interp.tool_length_offset_mm(),
        };
        let model: &dyn ErrorModel = &tool_model;
        st.summary.lines_in += 1;
        st.buf.clear();
        let program_motion = ev.motions.iter().any(|m| m.source == MotionSource::Program);
        let cycle = ev.motions.iter().any(|m| m.source == MotionSource::Cycle);
        if !ev.motions.is_empty() {
            mark_axes_set(ev.lexed, &mut st.known);
        }
        if ev
            .motions
            .iter()
            .any(|m| m.source == MotionSource::Reference)
        {
            st.known = [true; 3];
        }
        let all_known = st.known.iter().all(|k| *k);
        if cycle && all_known && !ev.after_end {
            st.write_cycle(
                ev.number,
                ev.bytes,
                ev.lexed.words().collect(),
                ev.motions,
                ev.interp,
                model,
                options,
                survey,
                sep,
                file,
                &mut on_point,
            )?;
            out.write_all(&st.buf)?;
            st.frame_before = Some(Frame::of(ev.interp, options, survey));
            continue;
        }
        if ev.after_end || ev.kind != LineKind::Block || !program_motion || !all_known {
            out.write_all(ev.bytes)?;
            st.summary.lines_out += 1;
            for m in ev.motions {
                // G53 and G28/G30 moves are sent as written: they are set-up
                // moves in machine coordinates, not part geometry.
                st.s = next_state(st.s, m.end - st.q_out);
                st.s_nominal = st.s;
                st.q_out = m.end;
            }
            if let Some(mode) = explicit_mode(ev.lexed.words()) {
                st.mode = Some(mode);
            }
            st.feed_known |=
                ev.interp.feed_mode() != FeedMode::InverseTime && has_feed(ev.lexed.words());
            st.frame_before = Some(Frame::of(ev.interp, options, survey));
            continue;
        }
        let motion = ev.motions[0];
        let interp = ev.interp;
        let (frame, style) = Frame::of(interp, options, survey);
        // The line's words are quantised and written with at least their own
        // decimals, so an unchanged word is written back as it was.
        let (frame, style) = frame.with_line_decimals(ev.lexed.words(), ev.bytes, style);
        let (frame0, style0) = st.frame_before.unwrap_or((frame, style));
        let feed_known_before = st.feed_known;
        let feed_known_in_line = st.feed_known || has_feed(ev.lexed.words());
        check_target_count(&motion, options, file, ev.number)?;
        let targets = targets_of(&motion, options, model, st.s)
            .map_err(|source| model_error(file, ev.number, source))?;
        let feed_like = !matches!(motion.kind, MotionKind::Rapid);
        if targets.len() > 1 && interp.feed_mode() == FeedMode::InverseTime {
            return Err(CompensationError::AtLine {
                file: file.into(),
                line: ev.number,
                message: "splitting a block under inverse-time feed (G93) would change its duration".into(),
                help: "pass --no-split for straight moves, or post the program in G94 (units per minute)".into(),
            });
        }
        let line_ending: &[u8] = line_ending(ev.bytes);
        let content_len = volcomp_gcode::lexer::content_len(ev.bytes);
        let content = &ev.bytes[..content_len];
        // Solve every target first (the original line carries the first).
        let q_line_start = st.q_out;
        let commands = st.solve_targets(
            model,
            options,
            &frame,
            &frame0,
            &targets,
            motion.start,
            feed_like,
            file,
            ev.number,
            &mut on_point,
        )?;
        // Write: the commands were solved from the position before the line.
        let mut pos = q_line_start;
        let stop_word = if commands.len() > 1 {
            stop_m_word(ev.lexed.words())
        } else {
            None
        };
        let needed = if feed_like {
            OutMode::Feed
        } else {
            OutMode::Rapid
        };
        for (i, (q, take_up)) in commands.iter().enumerate() {
            if let Some(tu) = take_up {
                // The first take-up runs before the line's own words: in the
                // previous line's frame, distance mode, units and feed.
                let (tu_frame, tu_style, tu_feed) = if i == 0 {
                    (&frame0, style0, feed_known_before)
                } else {
                    (&frame, style, feed_known_in_line)
                };
                let tu_mode = if tu_feed {
                    OutMode::Feed
                } else {
                    OutMode::Rapid
                };
                st.write_inserted(
                    tu_frame,
                    tu_style,
                    sep,
                    pos,
                    *tu,
                    tu_mode,
                    ev.number,
                    options.trace_comments,
                    line_ending,
                    "take-up",
                );
                pos = *tu;
            }
            if i == 0 {
                let edits = st.original_line_edits(
                    ev.lexed.words().collect(),
                    content,
                    &frame,
                    style,
                    sep,
                    pos,
                    *q,
                    &motion.kind,
                    needed,
                    stop_word,
                    targets[0],
                    motion.start,
                );
                let mut edits = edits;
                apply_edits(ev.bytes, &mut edits, &mut st.buf).map_err(|e| {
                    CompensationError::AtLine {
                        file: file.into(),
                        line: ev.number,
                        message: format!("internal edit error: {e}"),
                        help: "please report this with the program line".into(),
                    }
                })?;
                if content_len == ev.bytes.len() && commands.len() > 1 {
                    st.buf.extend_from_slice(b"\n");
                }
                st.mode = Some(needed);
                st.summary.lines_out += 1;
            } else {
                st.write_inserted(
                    &frame,
                    style,
                    sep,
                    pos,
                    *q,
                    needed,
                    ev.number,
                    options.trace_comments,
                    if i + 1 == commands.len()
                        && content_len == ev.bytes.len()
                        && stop_word.is_none()
                    {
                        b""
                    } else {
                        line_ending
                    },
                    "",
                );
            }
            pos = *q;
        }
        if let Some(w) = stop_word {
            st.buf.extend_from_slice(&content[w.span.clone()]);
            st.buf.extend_from_slice(line_ending);
            st.summary.lines_out += 1;
        }
        st.feed_known = feed_known_in_line;
        st.frame_before = Some((frame, style));
        out.write_all(&st.buf)?;
    }
    Ok(st.summary)
}

fn model_error(file: &str, line: u64, source: ModelError) -> CompensationError {
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

struct State {
    /// Axes whose position the program has set; until all three are known,
    /// motions are written unchanged (the start position is not the program's).
    known: [bool; 3],
    q_out: Vec3,
    s: Directions,
    s_nominal: Directions,
    mode: Option<OutMode>,
    feed_known: bool,
    /// Frame and number style in effect before the current line (after the
    /// previous one): what a move written before the line's own words uses.
    frame_before: Option<(Frame, NumberStyle)>,
    summary: CompensateSummary,
    buf: Vec<u8>,
    text: String,
}

/// The program frame of a line and how its numbers are written.
#[derive(Debug, Clone, Copy)]
struct Frame {
    offset_mm: Vec3,
    mm_per_unit: f64,
    decimals: u8,
    absolute: bool,
}

impl Frame {
    /// The frame and number style of the line just interpreted: its offsets,
    /// units and distance mode; 4 decimals in mm, 5 in inch unless overridden.
    fn of(
        interp: &volcomp_gcode::Interpreter,
        options: &CompensateOptions,
        survey: &StyleSurvey,
    ) -> (Frame, NumberStyle) {
        let units = interp.units();
        let decimals = options.decimals.unwrap_or(
            match units {
                Units::Mm => 4,
                Units::Inch => 5,
            }
            .max(survey.max_decimals()),
        );
        let frame = Frame {
            offset_mm: interp.frame_offset_mm(),
            mm_per_unit: units.mm_per_unit(),
            decimals,
            absolute: interp.absolute(),
        };
        (frame, survey.style(decimals))
    }

    /// This frame with at least as many decimals as any X, Y or Z word of
    /// the line (up to [`volcomp_gcode::number::MAX_DECIMALS`]).
    fn with_line_decimals<'a>(
        mut self,
        words: impl Iterator<Item = &'a Word>,
        bytes: &[u8],
        style: NumberStyle,
    ) -> (Frame, NumberStyle) {
        let most = words
            .filter(|w| matches!(w.letter, b'X' | b'Y' | b'Z'))
            .map(|w| volcomp_gcode::number::decimals_of(&bytes[w.value_span.clone()]))
            .max()
            .unwrap_or(0)
            .min(volcomp_gcode::number::MAX_DECIMALS);
        if most > self.decimals {
            self.decimals = most;
            return (self, style.with_decimals(most));
        }
        (self, style)
    }

    fn round(&self, v: f64) -> f64 {
        let k = 10f64.powi(i32::from(self.decimals));
        (v * k).round() / k
    }

    /// Program-frame value (program units) of axis-frame `q`.
    fn program(&self, q: Vec3) -> Vec3 {
        (q - self.offset_mm) * (1.0 / self.mm_per_unit)
    }

    /// The word value to write for axis `a` when moving from `from` to `q`.
    fn word_value(&self, q: Vec3, from: Vec3, a: usize) -> f64 {
        if self.absolute {
            self.round(self.program(q)[a])
        } else {
            self.round(self.program(q)[a] - self.program(from)[a])
        }
    }

    /// The command the controller really executes for a wish `q` from `from`.
    fn quantize(&self, q: Vec3, from: Vec3) -> Vec3 {
        let mut out = q;
        for a in 0..3 {
            let v = self.word_value(q, from, a);
            out[a] = if self.absolute {
                v * self.mm_per_unit + self.offset_mm[a]
            } else {
                from[a] + v * self.mm_per_unit
            };
            // An axis whose written value would not change stays exactly put.
            if (out[a] - from[a]).abs()
                < 0.5 * 10f64.powi(-i32::from(self.decimals)) * self.mm_per_unit * 1e-3
            {
                out[a] = from[a];
            }
        }
        out
    }
}

/// The command that takes up the reversing axes' backlash at `q_prev`
/// without moving the tool: for each reversing axis `a`, the position where
/// the new direction's image along `a` equals the old one's.
fn take_up_command(
    model: &dyn ErrorModel,
    q_prev: Vec3,
    s_old: Directions,
    s_new: Directions,
    reversed: [bool; 3],
    frame: &Frame,
) -> Result<Vec3, ModelError> {
    use crate::model::{actual_mm, Components};
    let held = actual_mm(model, q_prev, s_old, Components::All)?;
    let mut q = q_prev;
    // Only the reversing axes move; their new state applies during the move.
    let mut s = s_old;
    for a in 0..3 {
        if reversed[a] {
            s[a] = s_new[a];
        }
    }
    for _ in 0..8 {
        let img = actual_mm(model, q, s, Components::All)?;
        for a in 0..3 {
            if reversed[a] {
                q[a] += held[a] - img[a];
            }
        }
    }
    let mut out = frame.quantize(q, q_prev);
    for a in 0..3 {
        if !reversed[a] {
            out[a] = q_prev[a];
        } else if (out[a] - q_prev[a]) * s_new[a].sign() <= 0.0 {
            // A negative reversal value needs no take-up: the axis engages at once.
            out[a] = q_prev[a];
        }
    }
    Ok(out)
}

impl State {
    /// Writes a canned-cycle block as explicit moves: the block itself keeps
    /// its other words with the cycle code turned into G80 and its cycle
    /// words (X Y Z R P L) removed; each move of the expanded cycle follows,
    /// compensated like any other, with the dwell of G82/G89 as G4.
    #[allow(clippy::too_many_arguments)]
    fn write_cycle(
        &mut self,
        line: u64,
        bytes: &[u8],
        words: Vec<&Word>,
        motions: &[volcomp_gcode::Motion],
        interp: &volcomp_gcode::Interpreter,
        model: &dyn ErrorModel,
        options: &CompensateOptions,
        survey: &StyleSurvey,
        sep: &str,
        file: &str,
        on_point: &mut dyn FnMut(&PointRecord),
    ) -> Result<(), CompensationError> {
        if interp.feed_mode() == FeedMode::InverseTime {
            return Err(CompensationError::AtLine {
                file: file.into(),
                line,
                message: "a canned cycle under inverse-time feed (G93) cannot be expanded with the same timing".into(),
                help: "post the program in G94 (units per minute)".into(),
            });
        }
        let content = &bytes[..volcomp_gcode::lexer::content_len(bytes)];
        let ending = line_ending(bytes);
        let mut edits = Vec::new();
        for w in &words {
            match w.letter {
                b'G' if [81.0, 82.0, 85.0, 89.0].contains(&w.value) => {
                    edits.push(Edit::replace(w.value_span.clone(), "80"));
                }
                b'X' | b'Y' | b'Z' | b'R' | b'P' | b'L' => {
                    edits.push(Edit::delete(
                        blank_before(content, w.span.start)..w.span.end,
                    ));
                }
                _ => {}
            }
        }
        apply_edits(bytes, &mut edits, &mut self.buf).map_err(|e| CompensationError::AtLine {
            file: file.into(),
            line,
            message: format!("internal edit error: {e}"),
            help: "please report this with the program line".into(),
        })?;
        if !self.buf.ends_with(b"\n") {
            self.buf.extend_from_slice(ending);
        }
        self.summary.lines_out += 1;
        self.mode = Some(OutMode::Other);
        let (frame, style) = Frame::of(interp, options, survey);
        let dwell = interp.canned_cycle().and_then(|(_, d)| d);
        let mut dwell_written = false;
        for m in motions {
            let feed_like = matches!(m.kind, MotionKind::Feed);
            check_target_count(m, options, file, line)?;
            let targets = targets_of(m, options, model, self.s)
                .map_err(|source| model_error(file, line, source))?;
            let from = self.q_out;
            let commands = self.solve_targets(
                model, options, &frame, &frame, &targets, m.start, feed_like, file, line, on_point,
            )?;
            let mode = if feed_like {
                OutMode::Feed
            } else {
                OutMode::Rapid
            };
            let mut pos = from;
            for (q, take_up) in commands {
                if let Some(tu) = take_up {
                    self.write_inserted(
                        &frame,
                        style,
                        sep,
                        pos,
                        tu,
                        OutMode::Feed,
                        line,
                        options.trace_comments,
                        ending,
                        "take-up",
                    );
                    pos = tu;
                }
                if q == pos {
                    // A zero-length move of the cycle: keep the modal state
                    // the same as the controller would, but write nothing.
                    continue;
                }
                self.write_inserted(
                    &frame,
                    style,
                    sep,
                    pos,
                    q,
                    mode,
                    line,
                    options.trace_comments,
                    ending,
                    "cycle",
                );
                pos = q;
            }
            if feed_like && !dwell_written {
                if let Some(p) = dwell {
                    let mut text = String::from("G4");
                    text.push_str(sep);
                    text.push('P');
                    format_number(
                        p,
                        NumberStyle {
                            decimals: 3,
                            leading_zero: true,
                            trim_trailing_zeros: true,
                            trailing_dot: false,
                        },
                        &mut text,
                    );
                    self.buf.extend_from_slice(text.as_bytes());
                    self.buf.extend_from_slice(ending);
                    self.summary.lines_out += 1;
                }
                dwell_written = true;
            }
        }
        Ok(())
    }

    /// Solves the targets of one motion in order; returns each command and
    /// the take-up move written before it, if any.
    #[allow(clippy::too_many_arguments)]
    fn solve_targets(
        &mut self,
        model: &dyn ErrorModel,
        options: &CompensateOptions,
        frame: &Frame,
        first_take_up_frame: &Frame,
        targets: &[Vec3],
        start: Vec3,
        feed_like: bool,
        file: &str,
        line: u64,
        on_point: &mut dyn FnMut(&PointRecord),
    ) -> Result<Vec<(Vec3, Option<Vec3>)>, CompensationError> {
        let mut commands: Vec<(Vec3, Option<Vec3>)> = Vec::with_capacity(targets.len());
        let mut t_prev = start;
        for t in targets {
            let q_from = self.q_out;
            let quantize = |q: Vec3| frame.quantize(q, q_from);
            let point = match options.directions {
                DirectionPolicy::Commanded => {
                    solve_consistent(model, options.method, *t, self.q_out, self.s, &quantize)
                }
                DirectionPolicy::Nominal => {
                    let s_nom = next_state(self.s_nominal, *t - t_prev);
                    solve_fixed(model, options.method, *t, s_nom, [false; 3], Vec3::ZERO).map(
                        |sol| {
                            let q = quantize(sol.q_mm);
                            crate::compensate::solve::PointSolution {
                                q_mm: q,
                                s: s_nom,
                                iterations: sol.iterations,
                                residual_um: sol.residual_um,
                                reversed: [false; 3],
                                held: [false; 3],
                            }
                        },
                    )
                }
            }
            .map_err(|source| command_error(model, file, line, *t, source))?;
            check_converged(&point, options, *t, file, line)?;
            let correction = (point.q_mm - *t).norm();
            if correction > options.max_correction_mm {
                return Err(CompensationError::AtLine {
                    file: file.into(),
                    line,
                    message: format!("the correction here would be {:.1} µm, above the limit of {:.1} µm", correction * 1e3, options.max_correction_mm * 1e3),
                    help: "check that the map is in µm (not mm) and belongs to this machine; raise --max-correction only if the machine really is this far off".into(),
                });
            }
            let mut take_up = None;
            if options.take_up
                && feed_like
                && options.directions == DirectionPolicy::Commanded
                && point.reversed.iter().any(|r| *r)
            {
                take_up = Some(
                    take_up_command(
                        model,
                        self.q_out,
                        self.s,
                        point.s,
                        point.reversed,
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
            if let Some(tu) = take_up.as_mut() {
                for a in 0..3 {
                    if point.reversed[a] && (tu[a] - point.q_mm[a]) * point.s[a].sign() > 0.0 {
                        tu[a] = point.q_mm[a];
                    }
                }
            }
            // A take-up that does not move (negative reversal value, or one
            // the segment itself covers) is not written and not counted.
            if take_up == Some(self.q_out) {
                take_up = None;
            }
            if let Some(tu) = take_up {
                self.q_out = tu;
            }
            self.summary.points += 1;
            self.summary.max_residual_um = self.summary.max_residual_um.max(point.residual_um);
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
            on_point(&PointRecord {
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
            commands.push((point.q_mm, take_up));
            self.q_out = point.q_mm;
            self.s = point.s;
            self.s_nominal = next_state(self.s_nominal, *t - t_prev);
            t_prev = *t;
        }
        Ok(commands)
    }

    #[allow(clippy::too_many_arguments)]
    fn write_inserted(
        &mut self,
        frame: &Frame,
        style: NumberStyle,
        sep: &str,
        from: Vec3,
        q: Vec3,
        mode: OutMode,
        line: u64,
        trace: bool,
        ending: &[u8],
        note: &str,
    ) {
        self.text.clear();
        if self.mode != Some(mode) {
            self.text
                .push_str(if mode == OutMode::Rapid { "G0" } else { "G1" });
            self.mode = Some(mode);
        }
        for (a, letter) in ['X', 'Y', 'Z'].into_iter().enumerate() {
            if q[a] != from[a] {
                if !self.text.is_empty() {
                    self.text.push_str(sep);
                }
                self.text.push(letter);
                format_number(frame.word_value(q, from, a), style, &mut self.text);
            }
        }
        if self.text.is_empty() {
            return;
        }
        if trace {
            self.text.push_str(sep);
            if note.is_empty() {
                self.text.push_str(&format!("(volcomp L{line})"));
            } else {
                self.text.push_str(&format!("(volcomp L{line} {note})"));
            }
        }
        if !self.buf.is_empty() && !self.buf.ends_with(b"\n") {
            self.buf.extend_from_slice(b"\n");
        }
        self.buf.extend_from_slice(self.text.as_bytes());
        self.buf
            .extend_from_slice(if ending.is_empty() { b"\n" } else { ending });
        self.summary.lines_out += 1;
    }

    #[allow(clippy::too_many_arguments)]
    fn original_line_edits(
        &mut self,
        words: Vec<&Word>,
        content: &[u8],
        frame: &Frame,
        style: NumberStyle,
        sep: &str,
        from: Vec3,
        q: Vec3,
        kind: &MotionKind,
        needed: OutMode,
        stop_word: Option<&Word>,
        polar_nominal: Vec3,
        polar_start: Vec3,
    ) -> Vec<Edit> {
        let mut edits = Vec::new();
        let is_arc = matches!(kind, MotionKind::Arc(_));
        let mut has_motion_word = false;
        let mut last_axis_end = None;
        let mut first_axis_start = None;
        let mut present = [false; 3];
        // A polar end point (LinuxCNC `@` radius, `^` angle) is kept as
        // written while its X and Y round to the command's; otherwise the
        // polar words are replaced by the command's X and Y.
        let polar: Vec<&&Word> = words
            .iter()
            .filter(|w| matches!(w.letter, b'@' | b'^'))
            .collect();
        if let Some(first) = polar.first() {
            present[0] = true;
            present[1] = true;
            // In G91, or with only one of `@`/`^` in G90, the polar end point
            // depends on the start: the words can only stay when the command
            // starts where the nominal move did (to the written resolution).
            let both = polar.len() == 2;
            let half_lsb_mm = 0.5 * 10f64.powi(-i32::from(frame.decimals)) * frame.mm_per_unit;
            let start_kept = (frame.absolute && both)
                || (0..2).all(|a| (from[a] - polar_start[a]).abs() <= half_lsb_mm);
            let same = start_kept
                && (0..2).all(|a| {
                    (frame.word_value(q, from, a) - frame.word_value(polar_nominal, from, a)).abs()
                        < 0.5 * 10f64.powi(-i32::from(frame.decimals))
                });
            if !same {
                self.text.clear();
                self.text.push('X');
                format_number(frame.word_value(q, from, 0), style, &mut self.text);
                self.text.push_str(sep);
                self.text.push('Y');
                format_number(frame.word_value(q, from, 1), style, &mut self.text);
                edits.push(Edit::replace(first.span.clone(), self.text.clone()));
                for w in &polar[1..] {
                    edits.push(Edit::delete(
                        blank_before(content, w.span.start)..w.span.end,
                    ));
                }
            }
            first_axis_start = Some(first.span.start);
            last_axis_end = Some(first.span.end);
        }
        for w in &words {
            match w.letter {
                b'G' if [0.0, 1.0, 2.0, 3.0].contains(&w.value) => {
                    has_motion_word = true;
                    if is_arc {
                        let text = &content[w.value_span.clone()];
                        let new = if text.len() >= 2 && text[0] == b'0' {
                            "01"
                        } else {
                            "1"
                        };
                        edits.push(Edit::replace(w.value_span.clone(), new));
                    }
                }
                b'X' | b'Y' | b'Z' => {
                    let a = usize::from(w.letter - b'X');
                    present[a] = true;
                    first_axis_start.get_or_insert(w.span.start);
                    last_axis_end = Some(w.span.end);
                    let v = frame.word_value(q, from, a);
                    let lsb = 0.5 * 10f64.powi(-i32::from(frame.decimals));
                    if (v - w.value).abs() >= lsb * 0.999 {
                        self.text.clear();
                        // Never fewer decimals than the word replaced, even
                        // past the grid's MAX_DECIMALS.
                        let own =
                            volcomp_gcode::number::decimals_of(&content[w.value_span.clone()]);
                        let style = style.with_decimals(style.decimals.max(own.min(15)));
                        format_number(v, style, &mut self.text);
                        edits.push(Edit::replace(w.value_span.clone(), self.text.clone()));
                    }
                }
                b'I' | b'J' | b'K' | b'R' | b'P' if is_arc => {
                    edits.push(Edit::delete(
                        blank_before(content, w.span.start)..w.span.end,
                    ));
                }
                _ => {}
            }
        }
        if let Some(w) = stop_word {
            edits.push(Edit::delete(
                blank_before(content, w.span.start)..w.span.end,
            ));
        }
        let at = last_axis_end.unwrap_or(content.len());
        for (a, letter) in ['X', 'Y', 'Z'].into_iter().enumerate() {
            if !present[a] && q[a] != from[a] {
                self.text.clear();
                self.text.push_str(sep);
                self.text.push(letter);
                format_number(frame.word_value(q, from, a), style, &mut self.text);
                edits.push(Edit::insert(at, self.text.clone()));
            }
        }
        if !has_motion_word && (self.mode != Some(needed) || is_arc) {
            let code = if needed == OutMode::Rapid { "G0" } else { "G1" };
            let at = first_axis_start.unwrap_or(0);
            edits.push(Edit::insert(
                at,
                format!("{code}{}", if sep.is_empty() { "" } else { " " }),
            ));
        }
        edits
    }
}

/// Start of the blanks that precede byte `at` (so a deleted word takes its
/// separating blank with it).
fn blank_before(content: &[u8], at: usize) -> usize {
    let mut i = at;
    while i > 0 && (content[i - 1] == b' ' || content[i - 1] == b'\t') {
        i -= 1;
    }
    i
}

fn line_ending(bytes: &[u8]) -> &[u8] {
    let n = volcomp_gcode::lexer::content_len(bytes);
    let e = &bytes[n..];
    if e.is_empty() {
        b"\n"
    } else {
        e
    }
}

fn explicit_mode<'a>(words: impl Iterator<Item = &'a Word>) -> Option<OutMode> {
    let mut mode = None;
    for w in words {
        if w.letter == b'G' {
            mode = match w.value {
                0.0 => Some(OutMode::Rapid),
                1.0 => Some(OutMode::Feed),
                v if v == 2.0 || v == 3.0 || (80.0..=89.0).contains(&v) => Some(OutMode::Other),
                _ => mode,
            };
        }
    }
    mode
}

fn has_feed<'a>(mut words: impl Iterator<Item = &'a Word>) -> bool {
    words.any(|w| w.letter == b'F' && w.value > 0.0)
}

fn stop_m_word<'a>(mut words: impl Iterator<Item = &'a Word>) -> Option<&'a Word> {
    words.find(|w| w.letter == b'M' && [0.0, 1.0, 2.0, 30.0, 60.0].contains(&w.value))
}

/// An upper bound of the number of targets [`targets_of`] makes of
/// `motion`, computed in O(1) so that a block asking for unbounded work is
/// refused before any point is generated.
pub fn target_count_bound(motion: &volcomp_gcode::Motion, options: &CompensateOptions) -> f64 {
    let per = |len_mm: f64| -> f64 {
        match options.segmentation {
            Segmentation::Off => 1.0,
            Segmentation::Count(n) => f64::from(n.max(1)),
            Segmentation::MaxLength(l) => (len_mm / l).ceil().max(1.0),
            // `bisect` halves only segments longer than twice the minimum,
            // at most 40 levels deep.
            Segmentation::Adaptive { min_length_mm, .. } => {
                (len_mm / min_length_mm).floor().min(2f64.powi(40)) + 1.0
            }
        }
    };
    match motion.kind {
        MotionKind::Rapid => 1.0,
        MotionKind::Feed => per((motion.end - motion.start).norm()),
        MotionKind::Arc(arc) => {
            let chords = arc.chord_count(options.chord_tolerance_mm) as f64;
            match options.segmentation {
                Segmentation::Count(n) => chords.max(f64::from(n)),
                _ => chords * per(arc.length() / chords),
            }
        }
    }
}

/// Refuses a motion whose targets would pass
/// [`crate::limits::MAX_POINTS_PER_BLOCK`].
fn check_target_count(
    motion: &volcomp_gcode::Motion,
    options: &CompensateOptions,
    file: &str,
    line: u64,
) -> Result<(), CompensationError> {
    crate::limits::check_points(target_count_bound(motion, options)).map_err(|message| {
        CompensationError::AtLine {
            file: file.into(),
            line,
            message,
            help: "split the move in the program, or pass a coarser --segment-length, --segments, --chord-tolerance or --min-segment-length".into(),
        }
    })
}

/// Target points of a program motion (axis frame), the last one exactly the
/// motion's end. `model` and `s` (the direction state before the motion)
/// are only used by adaptive segmentation.
pub fn targets_of(
    motion: &volcomp_gcode::Motion,
    options: &CompensateOptions,
    model: &dyn ErrorModel,
    s: Directions,
) -> Result<Vec<Vec3>, ModelError> {
    let mut out = Vec::new();
    let seg = options.segmentation;
    match motion.kind {
        MotionKind::Rapid => out.push(motion.end),
        MotionKind::Feed => split(motion.start, motion.end, seg, model, s, &mut out)?,
        MotionKind::Arc(arc) => {
            let chords = arc.chord_count(options.chord_tolerance_mm);
            if let Segmentation::Count(n) = seg {
                let n = chords.max(n as usize);
                for k in 1..n {
                    out.push(arc.point_at(k as f64 / n as f64));
                }
                out.push(arc.end);
            } else {
                let mut prev = arc.start;
                let mut result = Ok(());
                arc.for_each_chord_end(options.chord_tolerance_mm, |p| {
                    if result.is_ok() {
                        result = split(prev, p, seg, model, s, &mut out);
                    }
                    prev = p;
                });
                result?;
            }
        }
    }
    Ok(out)
}

fn split(
    a: Vec3,
    b: Vec3,
    seg: Segmentation,
    model: &dyn ErrorModel,
    s: Directions,
    out: &mut Vec<Vec3>,
) -> Result<(), ModelError> {
    let n = match seg {
        Segmentation::Off => 1,
        Segmentation::Count(n) => n.max(1) as usize,
        Segmentation::MaxLength(l) => (((b - a).norm() / l).ceil() as usize).max(1),
        Segmentation::Adaptive {
            tolerance_mm,
            min_length_mm,
        } => {
            let s = next_state(s, b - a);
            let e = |p: Vec3| -> Result<Vec3, ModelError> {
                Ok(model.deviation_um(p, s, crate::model::Components::All)? * 1e-3)
            };
            let (ea, eb) = (e(a)?, e(b)?);
            return bisect(a, b, ea, eb, tolerance_mm, min_length_mm, &e, 0, out);
        }
    };
    for k in 1..n {
        out.push(a.lerp(b, k as f64 / n as f64));
    }
    out.push(b);
    Ok(())
}

/// Adaptive splitting of `a`–`b` (errors `ea`, `eb` at the ends, mm).
#[allow(clippy::too_many_arguments)]
fn bisect(
    a: Vec3,
    b: Vec3,
    ea: Vec3,
    eb: Vec3,
    tol: f64,
    min_len: f64,
    e: &dyn Fn(Vec3) -> Result<Vec3, ModelError>,
    depth: u32,
    out: &mut Vec<Vec3>,
) -> Result<(), ModelError> {
    let mid = a.lerp(b, 0.5);
    let em = e(mid)?;
    let mut worst = (em - ea.lerp(eb, 0.5)).norm();
    if worst <= tol {
        for t in [0.25, 0.75] {
            worst = worst.max((e(a.lerp(b, t))? - ea.lerp(eb, t)).norm());
        }
    }
    if worst > tol && (b - a).norm() > 2.0 * min_len && depth < 40 {
        bisect(a, mid, ea, em, tol, min_len, e, depth + 1, out)?;
        bisect(mid, b, em, eb, tol, min_len, e, depth + 1, out)
    } else {
        out.push(b);
        Ok(())
    }
}

/// Marks the axes whose position a moving line states: its X, Y and Z words,
/// and X and Y for a polar end point (`@` radius, `^` angle; LinuxCNC reads
/// polar words in the XY plane only). Until a program has stated every axis,
/// the machine is where the program does not say, and neither compensation
/// nor simulation evaluates the map there.
pub(crate) fn mark_axes_set(line: &volcomp_gcode::lexer::Lexed, known: &mut [bool; 3]) {
    for w in line.words() {
        match w.letter {
            b'X' | b'Y' | b'Z' => known[usize::from(w.letter - b'X')] = true,
            b'@' | b'^' => {
                known[0] = true;
                known[1] = true;
            }
            _ => {}
        }
    }
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
        help: "with ILC raise the iteration limit or the gain; check that the map is smooth and in µm; the residual limit is an option (--max-residual-um)".into(),
    })
}
