//! Canned cycles written as explicit, compensated moves: G73, G81–G86 and
//! G89, with the dwells and spindle stops/restarts LinuxCNC 2.9 makes in
//! them (src/emc/rs274ngc/interp_cycles.cc); G84's tapping strokes are
//! written unaltered (see `write_tap_stroke`). G87 and G88 are refused:
//! see `refusal`.

use super::lines::{blank_before, OutMode};
use super::walk::{Line, Place};
use super::State;
use crate::error::CompensationError;
use crate::simulate::next_state;
use volcomp_gcode::edit::{apply_edits, Edit};
use volcomp_gcode::lexer::Word;
use volcomp_gcode::number::{format_number, NumberStyle};
use volcomp_gcode::{FeedMode, MotionKind};

impl State<'_> {
    /// Writes a canned-cycle block as explicit moves: the block itself keeps
    /// its other words with the cycle code turned into G80 and its cycle
    /// words (X Y Z R P Q L) removed; each move of the expanded cycle
    /// follows, compensated like any other, with the dwell of G82/G86/G89 as
    /// G4 and G86's spindle stop (M5) and restart (M3/M4) where LinuxCNC
    /// makes them.
    pub(super) fn write_cycle(&mut self, line: &Line) -> Result<(), CompensationError> {
        let (interp, file, number) = (line.ev.interp, self.walk.file, line.number());
        let (bytes, words, motions) = (
            line.ev.bytes,
            line.words().collect::<Vec<&Word>>(),
            line.ev.motions,
        );
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
        let content = line.content();
        let ending = line.ending;
        let mut edits = Vec::new();
        for w in &words {
            match w.letter {
                b'G' if [73.0, 74.0, 81.0, 82.0, 83.0, 84.0, 85.0, 86.0, 89.0]
                    .contains(&w.value) =>
                {
                    edits.push(Edit::replace(w.value_span.clone(), "80"));
                }
                b'X' | b'Y' | b'Z' | b'R' | b'P' | b'Q' | b'L' | b'@' | b'^' => {
                    edits.push(Edit::delete(
                        blank_before(content, w.span.start)..w.span.end,
                    ));
                }
                _ => {}
            }
        }
        apply_edits(bytes, &mut edits, &mut self.buf)
            .map_err(|e| super::edit_error(file, number, e))?;
        if !self.buf.ends_with(b"\n") {
            self.buf.extend_from_slice(ending);
        }
        self.summary.lines_out += 1;
        self.mode = Some(OutMode::Other);
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
            let from = self.q_out;
            let commands = self.solve_motion(line.model(), &frame, m, feed_like, number)?;
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
                self.write_inserted(&at, pos, q, mode, "cycle");
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
                        self.write_word_line(&text, ending);
                    }
                    if code == 86 {
                        self.write_word_line("M5", ending);
                        restart_due = true;
                    }
                }
            }
        }
        Ok(())
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
            format_number(
                dwell.unwrap_or(0.0),
                NumberStyle {
                    decimals: 3,
                    leading_zero: true,
                    trim_trailing_zeros: true,
                    trailing_dot: false,
                },
                &mut text,
            );
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
