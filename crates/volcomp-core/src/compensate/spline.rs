//! Splines (G5, G5.1, G5.2 … G5.3) written as compensated G1 segments.
//!
//! A compensated spline is not a spline of the nominal control points: the
//! machine's error bends the path differently along it, and the control
//! points of a spline that would follow the corrected path are not those of
//! the program (nor is the corrected path a cubic or a NURBS at all). So the
//! interpreter's chords (within the spline tolerance of the exact curve) are
//! compensated like any feed move and written as G1 segments, and the spline
//! words are removed: the block keeps its other words (F, S, M, comments)
//! with its spline code, X, Y, I, J, P, Q, L, `@`, `^` removed, and the
//! segments follow it. The control-point lines of a G5.2 block are written
//! the same way, without their spline words, so that the controller runs the
//! segments only. The segments change the modal motion mode to G1; the
//! rewrite of later lines restates G0/G1 where the program relied on the
//! mode from before the spline (LinuxCNC's G5/G5.1 leave it unchanged).

use super::frame::Frame;
use super::lines::{blank_before, line_ending, stop_m_word, OutMode};
use super::{CompensateOptions, PointRecord, State};
use crate::error::CompensationError;
use crate::model::ErrorModel;
use volcomp_gcode::edit::{apply_edits, Edit};
use volcomp_gcode::lexer::Word;
use volcomp_gcode::number::StyleSurvey;
use volcomp_gcode::FeedMode;

impl State {
    /// Writes `bytes` with its spline words (and `stop`, a program stop
    /// that must come after the segments) removed; nothing when only blanks
    /// remain.
    pub(super) fn write_spline_block(
        &mut self,
        line: u64,
        bytes: &[u8],
        words: &[&Word],
        stop: Option<&Word>,
        file: &str,
    ) -> Result<(), CompensationError> {
        let content = &bytes[..volcomp_gcode::lexer::content_len(bytes)];
        let mut edits = Vec::new();
        for w in words {
            let spline_code = w.letter == b'G' && [5.0, 5.1, 5.2, 5.3].contains(&w.value);
            let is_stop = stop.is_some_and(|s| s.span == w.span);
            if spline_code || is_stop || b"XYIJPQL@^".contains(&w.letter) {
                edits.push(Edit::delete(
                    blank_before(content, w.span.start)..w.span.end,
                ));
            }
        }
        let mut out = Vec::new();
        apply_edits(bytes, &mut edits, &mut out).map_err(|e| super::edit_error(file, line, e))?;
        if out.iter().all(|b| b.is_ascii_whitespace()) {
            return Ok(());
        }
        self.buf.extend_from_slice(&out);
        if !self.buf.ends_with(b"\n") {
            self.buf.extend_from_slice(line_ending(bytes));
        }
        self.summary.lines_out += 1;
        Ok(())
    }

    /// Writes a spline block as its compensated chords (see the module
    /// documentation).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn write_spline(
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
                message: "a spline under inverse-time feed (G93) cannot be written as segments with the same duration".into(),
                help: "post the program in G94 (units per minute)".into(),
            });
        }
        // A program stop on the block (M0, M1, M2, M30, M60) runs after the
        // segments, as it ran after the spline.
        let stop = stop_m_word(words.iter().copied());
        self.write_spline_block(line, bytes, &words, stop, file)?;
        let ending = line_ending(bytes);
        let (frame, style) = Frame::of(interp, options, survey);
        self.mode = Some(OutMode::Other);
        for m in motions {
            let from = self.q_out;
            let commands =
                self.solve_motion(model, options, &frame, m, true, file, line, on_point)?;
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
                self.write_inserted(
                    &frame,
                    style,
                    sep,
                    pos,
                    q,
                    OutMode::Feed,
                    line,
                    options.trace_comments,
                    ending,
                    "spline",
                );
                pos = q;
            }
        }
        if let Some(w) = stop {
            let content = &bytes[..volcomp_gcode::lexer::content_len(bytes)];
            self.buf.extend_from_slice(&content[w.span.clone()]);
            self.buf.extend_from_slice(ending);
            self.summary.lines_out += 1;
        }
        Ok(())
    }
}
