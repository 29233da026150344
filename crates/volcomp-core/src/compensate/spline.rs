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

use super::lines::{blank_before, stop_m_word, OutMode};
use super::walk::Line;
use super::State;
use crate::error::CompensationError;
use volcomp_gcode::edit::{apply_edits, Edit};
use volcomp_gcode::lexer::Word;
use volcomp_gcode::FeedMode;

impl State<'_> {
    /// Writes `line` with its spline words (and `stop`, a program stop
    /// that must come after the segments) removed; nothing when only blanks
    /// remain.
    pub(super) fn write_spline_block(
        &mut self,
        line: &Line,
        words: &[&Word],
        stop: Option<&Word>,
    ) -> Result<(), CompensationError> {
        let content = line.content();
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
        apply_edits(line.ev.bytes, &mut edits, &mut out)
            .map_err(|e| super::edit_error(self.walk.file, line.number(), e))?;
        if out.iter().all(|b| b.is_ascii_whitespace()) {
            return Ok(());
        }
        self.buf.extend_from_slice(&out);
        if !self.buf.ends_with(b"\n") {
            self.buf.extend_from_slice(line.ending);
        }
        self.summary.lines_out += 1;
        Ok(())
    }

    /// Writes a spline block as its compensated chords (see the module
    /// documentation).
    pub(super) fn write_spline(&mut self, line: &Line) -> Result<(), CompensationError> {
        let number = line.number();
        if line.ev.interp.feed_mode() == FeedMode::InverseTime {
            return Err(CompensationError::AtLine {
                file: self.walk.file.into(),
                line: number,
                message: "a spline under inverse-time feed (G93) cannot be written as segments with the same duration".into(),
                help: "post the program in G94 (units per minute)".into(),
            });
        }
        // A program stop on the block (M0, M1, M2, M30, M60) runs after the
        // segments, as it ran after the spline.
        let words: Vec<&Word> = line.words().collect();
        let stop = stop_m_word(words.iter().copied());
        self.write_spline_block(line, &words, stop)?;
        let at = line.place();
        self.mode = Some(OutMode::Other);
        for m in line.ev.motions {
            let (from, s_from) = (self.q_out, self.s);
            let commands = self.solve_motion(line.model(), &line.frame, m, true, number)?;
            let end = commands.last().map_or(from, |c| c.0);
            self.write_approach_before(line, &at, true, (from, s_from), end)?;
            let mut pos = from;
            for (q, take_up) in commands {
                if let Some(tu) = take_up {
                    self.write_inserted(&at, pos, tu, OutMode::Feed, "take-up");
                    pos = tu;
                }
                self.write_inserted(&at, pos, q, OutMode::Feed, "spline");
                pos = q;
            }
        }
        if let Some(w) = stop {
            self.buf.extend_from_slice(&line.content()[w.span.clone()]);
            self.buf.extend_from_slice(line.ending);
            self.summary.lines_out += 1;
        }
        Ok(())
    }
}
