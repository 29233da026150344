//! Cutter radius compensation (G41/G42) written back as the compensated
//! tool-centre path under G40.
//!
//! The interpreter computes the tool-centre path as LinuxCNC does
//! (volcomp-gcode, `interp/comp.rs`). A compensated tool-centre path cannot
//! be handed back to G41/G42: the controller would offset it again, by a
//! radius measured along a different path. So every block run while
//! compensation is on is written without its G40/G41/G42 (G41.1, G42.1), D,
//! motion code and coordinate words, and its moves follow, compensated, as
//! G0/G1 segments and G2/G3 arc pieces, which the controller runs with
//! compensation off.
//!
//! A tool-centre arc (an offset arc of a program arc, radius ± the tool
//! radius about the same centre, or a corner arc LinuxCNC inserts at a
//! convex corner, radius = the tool radius about the programmed corner) is
//! written as program arcs are (docs/compensation.md, "Arcs as arcs"; the
//! shared [`State::pieces_of_arc`] and [`State::arc_piece_words`]): cut at
//! quarter points, table points and by bisection against the contour
//! tolerance, each piece's end compensated exactly, its centre that of the
//! circle through the compensated start, middle and end, with take-ups
//! between pieces. The pieces are inserted G2/G3 lines in the plane of the
//! compensation (G17 or G18: LinuxCNC refuses a plane change while it is
//! on), with I/J/K from the piece's start (G91.1) or absolute (G90.1) in
//! the program's units and number style, X/Y/Z in the distance mode in
//! effect where the line is written, as the inserted G0/G1 lines are. A
//! piece whose sagitta is within the chord tolerance, or that LinuxCNC
//! would not read as that arc (a tiny corner arc whose rounded ends cross),
//! is written as a G1 to its compensated end. With `--arcs-as-lines`, or in
//! a rotated frame, or with centres absolute only by option, tool-centre
//! arcs are linearised within the chord tolerance.
//!
//! LinuxCNC gives a compensated move out one block late (it waits for the
//! next move to know the corner): moves that come from an earlier block are
//! written before the block that released them, the block's own moves (a
//! corner arc, the exit move after G40) after it. The non-motion words of
//! a block (F, S, M, comments) thus stay between the moves they were
//! between in LinuxCNC's queue. The segments are tagged `(volcomp Ln)` with
//! the line of the block that released them: that block's motions are
//! what `volcomp simulate --reference` pairs them with.

use super::arcs::Piecewise;
use super::lines::{blank_before, stop_m_word, OutMode};
use super::points::{Leads, Run, Targets};
use super::targets::{check_target_count, targets_of};
use super::walk::{Line, Place};
use super::{model_error, CompensateOptions, State};
use crate::error::CompensationError;
use volcomp_gcode::edit::{apply_edits, Edit};
use volcomp_gcode::lexer::Word;
use volcomp_gcode::number::format_number;
use volcomp_gcode::{FeedMode, Motion, MotionKind, MotionSource};

/// G codes removed from a block under compensation (×10): cutter
/// compensation and motion codes.
const REMOVED_G: [f64; 9] = [40.0, 41.0, 41.1, 42.0, 42.1, 0.0, 1.0, 2.0, 3.0];

/// The rate (mm/min) LinuxCNC runs a G93 move at: a compensated move has
/// it already (the interpreter's `comp_feed_mm`); any other move's is its
/// length times its inverse time, at least 0.1 units/min
/// (`inverse_time_rate_straight`/`_arc`, interp_inverse.cc).
fn rate_mm_per_min(m: &Motion, units: volcomp_gcode::Units) -> f64 {
    if m.source == MotionSource::CutterComp {
        return m.feed;
    }
    let length_mm = match m.kind {
        MotionKind::Arc(a) => {
            let (_, _, w) = a.plane.axes();
            (a.start_radius() * a.sweep_rad.abs()).hypot(a.end[w] - a.start[w])
        }
        _ => (m.end - m.start).norm(),
    };
    // `feed` holds the block's F (min⁻¹) times mm per program unit.
    let k = units.mm_per_unit();
    let inverse_per_min = m.feed / k;
    ((length_mm / k) * inverse_per_min).max(0.1) * k
}

impl State<'_> {
    /// Writes a block run while cutter compensation is on (or that turned
    /// it on or off) and its moves (see the module documentation).
    pub(super) fn write_cutter(&mut self, line: &Line) -> Result<(), CompensationError> {
        let (ev, file, number) = (line.ev, self.walk.file, line.number());
        let motions = ev.motions;
        if motions.iter().any(|m| m.extra.moves()) {
            return Err(CompensationError::AtLine {
                file: file.into(),
                line: number,
                message: "a cutter-compensated move that also moves A, B, C, U, V or W is not written back".into(),
                help: "move the extra axes outside the compensated (G41/G42) part".into(),
            });
        }
        let (frame, style) = (line.frame, line.style);
        // Moves released by this block are written before it, so in the
        // modes (G90/G91, G20/G21) in effect before it.
        let (frame0, style0) = line.before_or((frame, style));
        let ending = line.ending;
        let (earlier, own): (Vec<&Motion>, Vec<&Motion>) =
            motions.iter().partition(|m| m.line != number);
        let g93_before = self.g93_before;
        let before = Place {
            frame: &frame0,
            style: style0,
            ..line.place()
        };
        self.write_cutter_moves(line, &earlier, &before, g93_before)?;
        let words: Vec<&Word> = line.words().collect();
        let arc = motions
            .iter()
            .any(|m| m.line == number && matches!(m.kind, MotionKind::Arc(_)));
        let comp_code = words
            .iter()
            .any(|w| w.letter == b'G' && [41.0, 41.1, 42.0, 42.1].contains(&w.value));
        let stop = stop_m_word(words.iter().copied());
        let content = line.content();
        let mut edits = Vec::new();
        for w in &words {
            let remove = match w.letter {
                b'G' => REMOVED_G.contains(&w.value),
                b'X' | b'Y' | b'Z' | b'I' | b'J' | b'K' | b'R' | b'@' | b'^' => true,
                b'P' => arc,
                b'D' | b'L' => comp_code,
                _ => stop.is_some_and(|s| s.span == w.span),
            };
            if remove {
                edits.push(Edit::delete(
                    blank_before(content, w.span.start)..w.span.end,
                ));
            }
        }
        let mut out = Vec::new();
        apply_edits(ev.bytes, &mut edits, &mut out)
            .map_err(|e| super::edit_error(file, number, e))?;
        if !out.iter().all(|b| b.is_ascii_whitespace()) {
            self.buf.extend_from_slice(&out);
            if !self.buf.ends_with(b"\n") {
                self.buf.extend_from_slice(ending);
            }
            self.summary.lines_out += 1;
        }
        let g93_after = ev.interp.feed_mode() == FeedMode::InverseTime;
        self.write_cutter_moves(line, &own, &line.place(), g93_after)?;
        if let Some(w) = stop {
            self.buf.extend_from_slice(&content[w.span.clone()]);
            self.buf.extend_from_slice(ending);
            self.summary.lines_out += 1;
        }
        Ok(())
    }

    /// Writes `motions` at `at` (tagged with its line: the block that
    /// released them, the line `volcomp simulate --reference` pairs them
    /// with); `program_in_g93` says whether the program is in inverse time
    /// where they are written (G93 is then restored after them).
    fn write_cutter_moves(
        &mut self,
        block: &Line,
        motions: &[&Motion],
        at: &Place,
        program_in_g93: bool,
    ) -> Result<(), CompensationError> {
        let (options, file, sep) = (self.walk.options, self.walk.file, self.walk.sep);
        let (frame, style) = (at.frame, at.style);
        let model = block.model();
        let units = block.ev.interp.units();
        // A move computed under inverse time (G93) runs, in LinuxCNC, at the
        // rate its programmed length gives (units/min): written as G94 with
        // that F, and G93 restored after the moves for the program's later
        // blocks.
        let mut forced_g94 = false;
        for m in motions {
            let line = m.line;
            if m.feed_mode == FeedMode::InverseTime && !matches!(m.kind, MotionKind::Rapid) {
                let mut text = String::new();
                if !forced_g94 {
                    text.push_str("G94");
                    text.push_str(sep);
                    forced_g94 = true;
                }
                text.push('F');
                format_number(
                    rate_mm_per_min(m, units) / units.mm_per_unit(),
                    style,
                    &mut text,
                );
                self.buf.extend_from_slice(text.as_bytes());
                self.buf.extend_from_slice(at.ending);
                self.summary.lines_out += 1;
            }
            // A tool-centre arc (an offset arc of a program arc, or a corner
            // arc) is written as compensated pieces of itself, as program
            // arcs are (compensate/arcs.rs), unless arcs are linearised by
            // option or the frame needs what that path does not write (a
            // rotation).
            let arc = match m.kind {
                MotionKind::Arc(a) if options.arcs_as_arcs && frame.rotation_deg == 0.0 => Some(a),
                _ => None,
            };
            let options = &CompensateOptions {
                arcs_as_arcs: arc.is_some(),
                ..*options
            };
            check_target_count(m, options, file, line)?;
            let run = Run {
                corner_before: true,
                ..Run::of(m, None, &options.planner)
            };
            let (mut targets, pieces) = match arc {
                Some(a) => {
                    let pieces = self
                        .pieces_of_arc(&a, model, line, &run, super::arcs::JoinTails::default())?
                        .pieces;
                    let targets = pieces
                        .iter()
                        .map(|l| if *l >= 1.0 { a.end } else { a.point_at(*l) })
                        .collect();
                    (targets, pieces)
                }
                None => (
                    targets_of(m, options, model, self.s)
                        .map_err(|source| model_error(file, line, source))?,
                    Vec::new(),
                ),
            };
            let rapid = matches!(m.kind, MotionKind::Rapid);
            let mode = if rapid { OutMode::Rapid } else { OutMode::Feed };
            let from = self.q_out;
            let commands = self.solve_targets(
                model,
                (frame, frame),
                Targets {
                    points: &mut targets,
                    leads: Leads::Nowhere,
                    start: m.start,
                    feed_like: !rapid,
                    run,
                },
                line,
            )?;
            let words = match arc {
                Some(a) => self.arc_piece_words(
                    model,
                    &Place { line, ..*at },
                    Piecewise {
                        arc: &a,
                        pieces: &pieces,
                        radius_style: false,
                        turn_tolerance: None,
                        chord_turn_tolerance: None,
                        start_tangent: None,
                    },
                    &commands,
                    from,
                )?,
                None => Vec::new(),
            };
            let mut pos = from;
            for (i, (q, take_up)) in commands.into_iter().enumerate() {
                if let Some(tu) = take_up {
                    self.write_inserted(at, pos, tu, OutMode::Feed, "take-up");
                    pos = tu;
                }
                if let Some(w) = words.get(i) {
                    self.write_inserted_arc(at, pos, q, w, "cutter comp");
                } else {
                    self.write_inserted(at, pos, q, mode, "cutter comp");
                }
                pos = q;
            }
        }
        if forced_g94 && program_in_g93 {
            self.buf.extend_from_slice(b"G93");
            self.buf.extend_from_slice(at.ending);
            self.summary.lines_out += 1;
        }
        Ok(())
    }
}
