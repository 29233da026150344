//! Canned cycles (G81, G82, G85, G89) written as explicit, compensated moves.

use super::frame::Frame;
use super::lines::{blank_before, line_ending, OutMode};
use super::targets::{check_target_count, targets_of};
use super::{model_error, CompensateOptions, PointRecord, State};
use crate::error::CompensationError;
use crate::model::ErrorModel;
use volcomp_gcode::edit::{apply_edits, Edit};
use volcomp_gcode::lexer::Word;
use volcomp_gcode::number::{format_number, NumberStyle, StyleSurvey};
use volcomp_gcode::{FeedMode, MotionKind};

impl State {
    /// Writes a canned-cycle block as explicit moves: the block itself keeps
    /// its other words with the cycle code turned into G80 and its cycle
    /// words (X Y Z R P L) removed; each move of the expanded cycle follows,
    /// compensated like any other, with the dwell of G82/G89 as G4.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn write_cycle(
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
}
