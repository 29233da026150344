//! Canned cycles written as explicit, compensated moves: G73, G81–G86 and
//! G89, with the dwells and spindle stops/restarts LinuxCNC 2.9 makes in
//! them (src/emc/rs274ngc/interp_cycles.cc); G84's tapping strokes are
//! written unaltered (see `write_tap_stroke`). G87 and G88 are refused:
//! see `refusal`.

use super::cycle_keep::Hole;
use super::lines::{blank_before, OutMode};
use super::walk::{Line, Place};
use super::State;
use crate::error::CompensationError;
use crate::model::next_state;
use volcomp_gcode::edit::{apply_edits, Edit};
use volcomp_gcode::number::{format_number, NumberStyle};
use volcomp_gcode::{FeedMode, MotionKind, PathMode};

/// How a dwell's seconds are written (`P0.5`, `P1.25`).
const SECONDS: NumberStyle = NumberStyle {
    decimals: 3,
    leading_zero: true,
    trim_trailing_zeros: true,
    trailing_dot: false,
};

impl State<'_> {
    /// Writes a canned-cycle block: each hole as a compensated cycle block
    /// where the map allows (compensate/cycle_keep.rs), as its moves
    /// elsewhere ([`State::write_cycle_moves`]), one hole after the other.
    pub(super) fn write_cycle(&mut self, line: &Line) -> Result<(), CompensationError> {
        let (interp, file, number) = (line.ev.interp, self.walk.file, line.number());
        if interp.feed_mode() == FeedMode::InverseTime {
            return Err(CompensationError::AtLine {
                file: file.into(),
                line: number,
                message: "a canned cycle under inverse-time feed (G93) cannot be expanded with the same timing".into(),
                help: "post the program in G94 (units per minute)".into(),
            });
        }
        let code = interp.canned_cycle().map(|(c, _)| c).unwrap_or(0);
        if let Some((message, help)) = refusal(code) {
            return Err(CompensationError::AtLine {
                file: file.into(),
                line: number,
                message: message.into(),
                help: help.into(),
            });
        }
        let holes = match (code, self.cycle_tolerance_mm()) {
            (74 | 84, _) | (_, None) => None,
            (_, Some(_)) => self.cycle_holes(line),
        };
        let Some(holes) = holes else {
            self.write_cycle_line_as_g80(line)?;
            self.write_cycle_moves(line, line.ev.motions, "cycle", (true, true))?;
            self.summary.cycle_holes_expanded +=
                interp.last_cycle().map_or(1, |b| b.holes.len() as u64);
            self.note_feed(line);
            return Ok(());
        };
        let tolerance_mm = self.hole_tolerance_mm(code).unwrap_or(0.0);
        let mut line_written = false;
        // Holes written as moves since the last kept one: under the G61
        // written before the first of them.
        let mut in_exact = false;
        for (k, range) in holes.ranges.iter().enumerate() {
            let nominal = &holes.nominal[range.clone()];
            match self.plan_hole(line, &holes.block, k, nominal, tolerance_mm)? {
                Hole::Keep(kept) => {
                    if in_exact {
                        self.exact_path(line, false);
                        in_exact = false;
                    }
                    // The controller runs the hole's moves: the bands still
                    // unsettled approach before it, from where the machine
                    // stands (compensate/approach.rs).
                    let (at_mm, s_at) = (self.q_out, self.s);
                    self.write_approach_before(line, &line.place(), true, (at_mm, s_at), at_mm)?;
                    if line_written {
                        self.write_kept_inserted(line, code, &kept.words);
                    } else {
                        self.write_kept_line(line, code, &kept.words)?;
                        line_written = true;
                    }
                    self.follow_kept(line, &kept);
                    self.mode = Some(OutMode::Other);
                }
                Hole::Expand(why) => {
                    if line_written {
                        if self.cycles.active() {
                            self.write_word_line("G80", line.ending);
                        }
                    } else {
                        self.write_cycle_line_as_g80(line)?;
                        line_written = true;
                    }
                    self.cycles.end();
                    let note = self.expand_note(&why, code);
                    let motions = &line.ev.motions[range.clone()];
                    self.write_cycle_moves(line, motions, &note, (!in_exact, false))?;
                    in_exact = true;
                    self.summary.cycle_holes_expanded += 1;
                }
            }
        }
        if in_exact {
            self.exact_path(line, false);
        }
        self.note_feed(line);
        Ok(())
    }

    /// The dwell word of a kept G82, G86 or G89 hole (`P` seconds, as
    /// LinuxCNC requires it on a block that starts a cycle).
    fn dwell_word(&self, line: &Line, code: u16) -> String {
        let mut text = String::new();
        if let (82 | 86 | 89, Some((_, Some(p)))) = (code, line.ev.interp.canned_cycle()) {
            text.push_str(self.walk.sep);
            text.push('P');
            format_number(p, SECONDS, &mut text);
        }
        text
    }

    /// The cycle line itself written for its first hole kept as a cycle:
    /// its words but the cycle's (X Y Z R P Q L, polar words) kept as they
    /// are, the cycle code written if the line had none (the written
    /// program may have left the cycle for a hole written as moves), and
    /// the hole's compensated words appended.
    fn write_kept_line(
        &mut self,
        line: &Line,
        code: u16,
        words: &str,
    ) -> Result<(), CompensationError> {
        let content = line.content();
        let mut edits = cycle_word_deletions(line, content);
        let has_code = line
            .words()
            .any(|w| w.letter == b'G' && is_cycle_code(w.value));
        let mut text = String::new();
        if !has_code {
            text.push_str(self.walk.sep);
            text.push_str(&format!("G{code}"));
        }
        text.push_str(words);
        text.push_str(&self.dwell_word(line, code));
        edits.push(Edit::insert(content.len(), text));
        self.write_edited_line(line, edits)
    }

    /// The cycle line with `edits` applied, as one line of the output. A
    /// line that was only the hole's words (`X20`) would start with the
    /// separator of the words written after them: it is not written.
    fn write_edited_line(
        &mut self,
        line: &Line,
        mut edits: Vec<Edit>,
    ) -> Result<(), CompensationError> {
        let content = line.content();
        let start = self.buf.len();
        apply_edits(line.ev.bytes, &mut edits, &mut self.buf)
            .map_err(|e| super::edit_error(self.walk.file, line.number(), e))?;
        let blanks = self.buf[start..]
            .iter()
            .take_while(|b| **b == b' ' || **b == b'\t')
            .count();
        if blanks > 0 && !content.starts_with(b" ") && !content.starts_with(b"\t") {
            self.buf.drain(start..start + blanks);
        }
        if !self.buf.ends_with(b"\n") {
            self.buf.extend_from_slice(line.ending);
        }
        self.summary.lines_out += 1;
        Ok(())
    }

    /// A hole after the first of a cycle line (an L repeat) kept as a
    /// cycle: a block of its own, traced to the line.
    fn write_kept_inserted(&mut self, line: &Line, code: u16, words: &str) {
        let mut text = format!("G{code}{words}{}", self.dwell_word(line, code));
        if self.walk.options.trace_comments {
            text.push_str(self.walk.sep);
            text.push_str(&format!("(volcomp L{} cycle)", line.number()));
        }
        if !self.buf.is_empty() && !self.buf.ends_with(b"\n") {
            self.buf.extend_from_slice(b"\n");
        }
        self.write_word_line(&text, line.ending);
    }

    /// The cycle line written for its moves: its other words with the
    /// cycle code turned into G80 (or G80 added where the written program
    /// is in a cycle the line does not name) and the cycle words (X Y Z R
    /// P Q L, polar words) removed.
    fn write_cycle_line_as_g80(&mut self, line: &Line) -> Result<(), CompensationError> {
        let content = line.content();
        let mut edits = cycle_word_deletions(line, content);
        let mut has_code = false;
        for w in line.words() {
            if w.letter == b'G' && is_cycle_code(w.value) {
                edits.push(Edit::replace(w.value_span.clone(), "80"));
                has_code = true;
            }
        }
        if !has_code && self.cycles.active() {
            edits.push(Edit::insert(content.len(), format!("{}G80", self.walk.sep)));
        }
        self.cycles.end();
        self.write_edited_line(line, edits)?;
        self.mode = Some(OutMode::Other);
        Ok(())
    }

    /// Writes `motions` of a cycle line (all of them, or one hole's) as
    /// explicit moves, compensated like any other, with the dwell of
    /// G82/G86/G89 as G4 and G86's spindle stop (M5) and restart (M3/M4)
    /// where LinuxCNC makes them; `note` follows the line number in the
    /// trace comment of the first move. `open` and `close`: whether the
    /// G61 LinuxCNC runs a cycle's moves in is written before them and
    /// the program's mode after them (consecutive holes written as moves
    /// share one).
    fn write_cycle_moves(
        &mut self,
        line: &Line,
        motions: &[volcomp_gcode::Motion],
        note: &str,
        (open, close): (bool, bool),
    ) -> Result<(), CompensationError> {
        let (interp, number) = (line.ev.interp, line.number());
        let code = interp.canned_cycle().map(|(c, _)| c).unwrap_or(0);
        let ending = line.ending;
        let mut note = note;
        // LinuxCNC runs a cycle's moves in exact path (G61) whatever the
        // program's mode, and restores the mode after them
        // (`convert_cycle_xy`, interp_cycles.cc): written as moves they say
        // so, or a G64 program would blend the rapid into the hole. (Under
        // G61.1 LinuxCNC keeps exact stop for the rapid up to R from below
        // it; here that rapid is written under G61 too: it ends at a corner
        // either way.)
        if open {
            self.exact_path(line, true);
        }
        let frame = line.frame;
        let at = line.place();
        let sep = self.walk.sep;
        let dwell = interp.canned_cycle().and_then(|(_, d)| d);
        let restart = if interp.spindle_direction() < 0 {
            "M4"
        } else {
            "M3"
        };
        // Feed moves of the block so far: G89 dwells after its feed down
        // (even) but not after its feed out (odd).
        let mut feeds = 0usize;
        // G86 restarts the spindle after the rapid out of the hole.
        let mut restart_due = false;
        for m in motions {
            let feed_like = matches!(m.kind, MotionKind::Feed);
            if matches!(code, 74 | 84) && feed_like {
                let left_hand = code == 74;
                self.write_tap_stroke(m, &at, feeds, dwell, left_hand);
                feeds += 1;
                continue;
            }
            let (from, s_from) = (self.q_out, self.s);
            let commands = self.solve_motion(line.model(), &frame, m, feed_like, number)?;
            let end = commands.last().map_or(from, |c| c.0);
            self.write_approach_before(line, &at, feed_like, (from, s_from), end)?;
            let mode = if feed_like {
                OutMode::Feed
            } else {
                OutMode::Rapid
            };
            let mut pos = from;
            for (q, take_up) in commands {
                if let Some(tu) = take_up {
                    self.write_inserted(&at, pos, tu, OutMode::Feed, "take-up");
                    pos = tu;
                }
                if q == pos {
                    // A zero-length move of the cycle: keep the modal state
                    // the same as the controller would, but write nothing.
                    continue;
                }
                self.write_inserted(&at, pos, q, mode, note);
                note = "cycle";
                pos = q;
            }
            if restart_due && !feed_like {
                self.write_word_line(restart, ending);
                restart_due = false;
            }
            if feed_like {
                let at_bottom = match code {
                    82 | 86 => true,
                    89 => feeds.is_multiple_of(2),
                    _ => false,
                };
                feeds += 1;
                if at_bottom {
                    if let Some(p) = dwell {
                        let mut text = String::from("G4");
                        text.push_str(sep);
                        text.push('P');
                        format_number(p, SECONDS, &mut text);
                        self.write_word_line(&text, ending);
                    }
                    if code == 86 {
                        self.write_word_line("M5", ending);
                        restart_due = true;
                    }
                }
            }
        }
        if close {
            self.exact_path(line, false);
        }
        Ok(())
    }

    /// The G61 written before a cycle's moves (`on`), or the program's own
    /// mode written after them, where the program is not in G61 itself.
    fn exact_path(&mut self, line: &Line, on: bool) {
        let interp = line.ev.interp;
        let program_mode = interp.path_mode();
        if program_mode == PathMode::ExactPath {
            return;
        }
        let text = if on {
            "G61".to_string()
        } else {
            mode_code(program_mode, interp.units().mm_per_unit(), self.walk.sep)
        };
        self.write_word_line(&text, line.ending);
    }

    /// One feed stroke of G84 or G74 (even `feeds`: down, odd: up; G74 turns
    /// the spindle the other way), written so the
    /// tapping stroke is not altered: it is the nominal stroke translated
    /// rigidly to where the compensated positioning left the tool, so its
    /// direction and length are exactly the controller's. Around it, what
    /// LinuxCNC 2.9's `convert_cycle_g74_g84` does with canon calls, as
    /// M-codes: overrides disabled (M49) for the stroke, at the bottom the
    /// spindle stopped and reversed (M5 M4) and the dwell, at the top the
    /// spindle stopped and restarted clockwise (M5 M3) and the overrides
    /// enabled again (M48).
    fn write_tap_stroke(
        &mut self,
        m: &volcomp_gcode::Motion,
        at: &Place,
        feeds: usize,
        dwell: Option<f64>,
        left_hand: bool,
    ) {
        let (ending, sep) = (at.ending, self.walk.sep);
        let (reverse, forward) = if left_hand {
            ("M3", "M4")
        } else {
            ("M4", "M3")
        };
        let down = feeds.is_multiple_of(2);
        if down {
            self.write_word_line("M49", ending);
        }
        let from = self.q_out;
        let q = from + (m.end - m.start);
        if q != from {
            self.write_inserted(at, from, q, OutMode::Feed, "tap");
        }
        self.s = next_state(self.s, q - from);
        self.s_nominal = self.s;
        self.q_out = q;
        if down {
            self.write_word_line("M5", ending);
            self.write_word_line(reverse, ending);
            let mut text = format!("G4{sep}P");
            format_number(dwell.unwrap_or(0.0), SECONDS, &mut text);
            self.write_word_line(&text, ending);
        } else {
            self.write_word_line("M5", ending);
            self.write_word_line(forward, ending);
            self.write_word_line("M48", ending);
        }
    }

    fn write_word_line(&mut self, text: &str, ending: &[u8]) {
        self.buf.extend_from_slice(text.as_bytes());
        self.buf.extend_from_slice(ending);
        self.summary.lines_out += 1;
    }
}

/// The G code that sets `mode`, its tolerances in program units
/// (`mm_per_unit` mm each): `G61`, `G61.1`, `G64`, `G64 P0.01`,
/// `G64 P0.01 Q0.005` (Q written only where it is not P, LinuxCNC's
/// default for it), words apart by `sep` as the program writes them.
fn mode_code(mode: PathMode, mm_per_unit: f64, sep: &str) -> String {
    let style = NumberStyle {
        decimals: 6,
        leading_zero: true,
        trim_trailing_zeros: true,
        trailing_dot: false,
    };
    match mode {
        PathMode::ExactPath => "G61".into(),
        PathMode::ExactStop => "G61.1".into(),
        PathMode::Blend {
            tolerance_mm,
            naive_cam_mm,
        } => {
            let mut text = String::from("G64");
            if tolerance_mm > 0.0 {
                text.push_str(sep);
                text.push('P');
                format_number(tolerance_mm / mm_per_unit, style, &mut text);
            }
            if naive_cam_mm != tolerance_mm {
                text.push_str(sep);
                text.push('Q');
                format_number(naive_cam_mm / mm_per_unit, style, &mut text);
            }
            text
        }
    }
}

/// Why a canned cycle cannot be written back as explicit moves.
fn refusal(code: u16) -> Option<(&'static str, &'static str)> {
    match code {
        87 => Some((
            "G87 back boring cannot be written as explicit moves that run the same: it stops the spindle in an orientation (ORIENT_SPINDLE) that only the cycle makes, to pass the boring bar through the hole",
            "run the back-boring operation in a separate program that is not compensated",
        )),
        88 => Some((
            "G88 cannot be written as explicit moves that run the same: the operator retracts the spindle by hand at its program stop, and LinuxCNC then takes the tool to be at the clearance plane, which explicit moves cannot state",
            "run the G88 holes in a separate program that is not compensated, or use G86 or G85",
        )),
        _ => None,
    }
}

/// Whether G-code `value` is a canned cycle's (G73, G74, G81–G89).
fn is_cycle_code(value: f64) -> bool {
    [
        73.0, 74.0, 81.0, 82.0, 83.0, 84.0, 85.0, 86.0, 87.0, 88.0, 89.0,
    ]
    .contains(&value)
}

/// Edits that delete a cycle line's cycle words: X Y Z R P Q L and the
/// polar words, each with the blank before it.
fn cycle_word_deletions(line: &Line, content: &[u8]) -> Vec<Edit> {
    line.words()
        .filter(|w| {
            matches!(
                w.letter,
                b'X' | b'Y' | b'Z' | b'R' | b'P' | b'Q' | b'L' | b'@' | b'^'
            )
        })
        .map(|w| Edit::delete(blank_before(content, w.span.start)..w.span.end))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mode_is_written_in_program_units() {
        let blend = |p: f64, q: f64| PathMode::Blend {
            tolerance_mm: p,
            naive_cam_mm: q,
        };
        assert_eq!(mode_code(blend(0.0, 0.0), 1.0, " "), "G64");
        assert_eq!(mode_code(blend(0.01, 0.01), 1.0, " "), "G64 P0.01");
        assert_eq!(
            mode_code(blend(0.0254, 0.0127), 25.4, ""),
            "G64P0.001Q0.0005"
        );
        assert_eq!(mode_code(PathMode::ExactStop, 1.0, " "), "G61.1");
        assert_eq!(mode_code(PathMode::ExactPath, 25.4, " "), "G61");
    }
}
