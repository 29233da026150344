//! Writing lines: inserted moves, byte-range edits of an original line, and
//! the small lexical helpers they need.

// `1.0 / pow10(d)` is `10f64.powi(-d)` to the bit (frame.rs, `pow10_is_powi`).
use super::frame::{pow10, Frame};
use super::walk::{Line, Place};
use super::State;
use std::ops::Range;
use volcomp_gcode::edit::{Edit, EditError};
use volcomp_gcode::lexer::Word;
use volcomp_gcode::number::{
    format_number_bytes, format_scaled_bytes, format_uint_bytes, NumberStyle,
};
use volcomp_gcode::{FeedMode, MotionKind, Vec3};

/// The edits of one line (each an [`Edit`]: a byte range of the line and
/// the text that replaces it) with their texts in one buffer, kept from
/// line to line: no `String` per edit and, once the buffers have grown, no
/// allocation per line. [`LineEdits::apply`] writes them as
/// [`volcomp_gcode::edit::apply_edits`] writes a list of [`Edit`]s: the
/// same bytes, the same errors.
#[derive(Debug, Default)]
pub(super) struct LineEdits {
    /// Each edit: its range in the line, and its text's range in `text`.
    list: Vec<(Range<usize>, Range<usize>)>,
    text: Vec<u8>,
}

impl LineEdits {
    /// No edits (the buffers kept).
    pub(super) fn clear(&mut self) {
        self.list.clear();
        self.text.clear();
    }

    /// Replaces `range` of the line with `content` (inserts where the
    /// range is empty).
    pub(super) fn replace(&mut self, range: Range<usize>, content: &[u8]) {
        let start = self.text.len();
        self.text.extend_from_slice(content);
        self.list.push((range, start..self.text.len()));
    }

    /// Inserts `content` before byte `at`.
    pub(super) fn insert(&mut self, at: usize, content: &[u8]) {
        self.replace(at..at, content);
    }

    /// Deletes `range`.
    pub(super) fn delete(&mut self, range: Range<usize>) {
        self.replace(range, b"");
    }

    /// Replaces `range` with the text written into the buffer from `start`
    /// ([`LineEdits::text_start`]) on.
    fn replace_written(&mut self, range: Range<usize>, start: usize) {
        self.list.push((range, start..self.text.len()));
    }

    /// Where the next text written into the buffer starts.
    fn text_start(&self) -> usize {
        self.text.len()
    }

    /// Appends edits made elsewhere, in their order.
    pub(super) fn extend(&mut self, edits: impl IntoIterator<Item = Edit>) {
        for e in edits {
            self.replace(e.range, e.content.as_bytes());
        }
    }

    /// Appends `line` with the edits applied to `out`, in the order of
    /// their ranges (edits at the same place in the order they were made;
    /// the sort is stable), as [`volcomp_gcode::edit::apply_edits`] does.
    pub(super) fn apply(&mut self, line: &[u8], out: &mut Vec<u8>) -> Result<(), EditError> {
        // Most lines' edits are made in the order of the line (its words
        // in turn): a list already in order is left as it is (a stable
        // sort would leave it so too).
        let key = |(r, _): &(Range<usize>, Range<usize>)| (r.start, r.end);
        if !self.list.windows(2).all(|p| key(&p[0]) <= key(&p[1])) {
            self.list.sort_by_key(key);
        }
        // The result is at most the line and every edit's text: room for
        // it is made once, not by each of the copies below.
        out.reserve(line.len() + self.text.len());
        let mut cursor = 0;
        for (r, t) in &self.list {
            if r.end > line.len() || r.start > r.end {
                return Err(EditError::OutOfRange {
                    end: r.end,
                    len: line.len(),
                });
            }
            if r.start < cursor {
                return Err(EditError::Overlap(r.start));
            }
            out.extend_from_slice(&line[cursor..r.start]);
            out.extend_from_slice(&self.text[t.clone()]);
            cursor = r.end;
        }
        out.extend_from_slice(&line[cursor..]);
        Ok(())
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum OutMode {
    Rapid,
    Feed,
    /// G2.
    Cw,
    /// G3.
    Ccw,
    Other,
}

impl OutMode {
    /// The motion word of the mode.
    pub(super) fn code(self) -> &'static str {
        match self {
            OutMode::Rapid => "G0",
            OutMode::Cw => "G2",
            OutMode::Ccw => "G3",
            _ => "G1",
        }
    }
}

/// How a compensated arc piece is written: its centre (axis frame), or as
/// a chord when no circle fits (three collinear points).
#[derive(Debug, Clone, Copy)]
pub(super) struct ArcWords {
    pub(super) center: Option<Vec3>,
    pub(super) plane: volcomp_gcode::Plane,
    pub(super) clockwise: bool,
    /// The program gives radii (R) rather than centres.
    pub(super) radius_style: bool,
    /// Centres are absolute (G90.1).
    pub(super) absolute_centers: bool,
    /// A piece written as two arcs (an S-curve take-up, compensate/scurve.rs):
    /// the first ends at `joint`, the second runs from there about its own
    /// centre, each turning its own way.
    pub(super) second: Option<SecondArc>,
}

/// The second arc of a piece written as two: where the first ends (axis
/// frame), and the second's centre and direction.
#[derive(Debug, Clone, Copy)]
pub(super) struct SecondArc {
    pub(super) joint: Vec3,
    pub(super) center: Option<Vec3>,
    pub(super) clockwise: bool,
}

impl ArcWords {
    pub(super) fn mode(&self) -> OutMode {
        match (self.center, self.clockwise) {
            (None, _) => OutMode::Feed,
            (Some(_), true) => OutMode::Cw,
            (Some(_), false) => OutMode::Ccw,
        }
    }

    /// Whether LinuxCNC reads the piece written from `from` to `q` (axis
    /// points on the written grid) with these words as the intended arc of
    /// at most half a turn. The centre is taken as the controller reads it
    /// from the rounded I/J/K words (for R, the circle through the ends:
    /// only the radius and the chord are checked); refused, as
    /// `arc_data_ijk` (src/emc/rs274ngc/interp_arc.cc) refuses them:
    /// a radius below `RADIUS_TOLERANCE_INCH` (0.00005 in, also in mm), or
    /// start and end radii that differ by more than 100 × the spiral
    /// tolerance, or by more than 0.1 % and the spiral tolerance
    /// (`CENTER_ARC_RADIUS_TOLERANCE_*`, interp_internal.hh: 2·0.01·√2 mm,
    /// 2·0.001·√2 in). Also refused here: a chord shorter than two steps of
    /// the written resolution, and a sweep as read of half a turn or more
    /// (pieces turn at most a quarter: the rounded ends crossed over, and
    /// the controller would run the long way round, a full circle when
    /// they coincide).
    pub(super) fn readable(&self, frame: &Frame, style: NumberStyle, from: Vec3, q: Vec3) -> bool {
        let Some(c) = self.center else {
            return true;
        };
        let (u, v, _) = self.plane.axes();
        let k = frame.mm_per_unit;
        let step_mm = (1.0 / pow10(style.decimals)) * k;
        let chord_mm = (q[u] - from[u]).hypot(q[v] - from[v]);
        let inch = (k - 1.0).abs() > 1e-9;
        let radius_tolerance_mm = 0.00005 * 25.4;
        let spiral_mm = if inch { 0.002 } else { 0.02 } * std::f64::consts::SQRT_2 * k;
        if chord_mm < 2.0 * step_mm {
            return false;
        }
        let mut read = c;
        if !self.radius_style {
            let round = |x: f64| (x / step_mm).round() * step_mm;
            for a in [u, v] {
                read[a] = if self.absolute_centers {
                    frame.offset_mm[a] + round(c[a] - frame.offset_mm[a])
                } else {
                    from[a] + round(c[a] - from[a])
                };
            }
        }
        let r1 = (from[u] - read[u]).hypot(from[v] - read[v]);
        let r2 = (q[u] - read[u]).hypot(q[v] - read[v]);
        if r1.min(r2) < radius_tolerance_mm {
            return false;
        }
        let abs_err = (r1 - r2).abs();
        if abs_err > 100.0 * spiral_mm || (abs_err / r1.max(r2) > 0.001 && abs_err > spiral_mm) {
            return false;
        }
        let angle = |p: Vec3| (p[v] - read[v]).atan2(p[u] - read[u]);
        let sweep = volcomp_gcode::arc::sweep_angle(angle(from), angle(q), self.clockwise, 1);
        sweep.abs() < std::f64::consts::PI
    }

    /// The centre words (` I… J…`, or ` R…`) of the piece from `from`, in
    /// the frame's units; empty for a chord.
    pub(super) fn text(&self, frame: &Frame, style: NumberStyle, sep: &str, from: Vec3) -> String {
        let mut t = Vec::new();
        self.push_text(frame, style, sep, from, &mut t);
        // Letters, digits, points, signs and the separator: ASCII.
        String::from_utf8(t).unwrap_or_default()
    }

    /// [`ArcWords::text`] appended to the bytes of a line being written.
    pub(super) fn push_text(
        &self,
        frame: &Frame,
        style: NumberStyle,
        sep: &str,
        from: Vec3,
        t: &mut Vec<u8>,
    ) {
        let Some(c) = self.center else {
            return;
        };
        let (u, v, _) = self.plane.axes();
        if self.radius_style {
            t.extend_from_slice(sep.as_bytes());
            t.push(b'R');
            let r = (from[u] - c[u]).hypot(from[v] - c[v]) / frame.mm_per_unit;
            format_number_bytes(r, style, t);
            return;
        }
        let mut axes = [u, v];
        axes.sort_unstable();
        for a in axes {
            t.extend_from_slice(sep.as_bytes());
            t.push([b'I', b'J', b'K'][a]);
            let value = if self.absolute_centers {
                frame.program(c)[a]
            } else {
                (c[a] - from[a]) / frame.mm_per_unit
            };
            format_number_bytes(value, style, t);
        }
    }
}

/// The first command of a line, written into the original line: from
/// where and to which command, the motion it was, the motion mode it
/// needs, the stop word that moves to a line after the last segment, and
/// for a polar end point the nominal end and start.
pub(super) struct FirstCommand<'a> {
    pub(super) from: Vec3,
    pub(super) q: Vec3,
    pub(super) kind: &'a MotionKind,
    pub(super) needed: OutMode,
    pub(super) stop_word: Option<&'a Word>,
    pub(super) polar_nominal: Vec3,
    pub(super) polar_start: Vec3,
}

impl State<'_> {
    /// The approach before the first cut (compensate/approach.rs): a
    /// rapid from `from` to `away` and back, tagged `approach`.
    pub(super) fn write_approach(&mut self, at: &Place, from: Vec3, away: Vec3) {
        self.write_inserted(at, from, away, OutMode::Rapid, "approach");
        self.write_inserted(at, away, from, OutMode::Rapid, "approach");
        self.summary.approach_lines += 2;
    }

    /// Writes the move from `from` to `q` as an inserted line at `at` (the
    /// motion word where the output's modal motion differs, the words of
    /// the coordinates that change, the extra-axis words waiting in
    /// `extra_text`); `note` follows the line number in the trace comment.
    /// Nothing where nothing would be written.
    pub(super) fn write_inserted(
        &mut self,
        at: &Place,
        from: Vec3,
        q: Vec3,
        mode: OutMode,
        note: &str,
    ) {
        let (frame, style, sep) = (at.frame, at.style, self.walk.sep);
        let code: &[u8] = if mode == OutMode::Rapid { b"G0" } else { b"G1" };
        self.text.clear();
        if self.mode != Some(mode) {
            self.text.extend_from_slice(code);
            self.mode = Some(mode);
        }
        for (a, letter) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
            if frame.changes(q, from, a) {
                if !self.text.is_empty() {
                    self.text.extend_from_slice(sep.as_bytes());
                }
                self.text.push(letter);
                push_word_value(frame, q, from, a, style, &mut self.text);
            }
        }
        if !self.extra_text.is_empty() {
            if self.text.is_empty() {
                self.text.extend_from_slice(code);
                self.mode = Some(mode);
            }
            self.text.extend_from_slice(self.extra_text.as_bytes());
            self.extra_text.clear();
        }
        if self.text.is_empty() {
            return;
        }
        self.push_inserted(at, note);
    }

    /// Writes path-control `words` on a line of their own before a block
    /// (an arc cannot carry P), tagged `(volcomp Ln path mode)`.
    pub(super) fn push_path_mode_line(&mut self, words: &str, at: &Place) {
        self.text.clear();
        self.text.extend_from_slice(words.as_bytes());
        self.push_inserted(at, "path mode");
        self.summary.path_mode_lines += 1;
    }

    /// Writes a plane selection `word` (G17, G18, G19) on a line of its
    /// own, tagged `(volcomp Ln plane)` (compensate/still_s.rs).
    pub(super) fn push_plane_line(&mut self, word: &str, at: &Place) {
        self.text.clear();
        self.text.extend_from_slice(word.as_bytes());
        self.push_inserted(at, "plane");
    }

    /// Ends the inserted line in `self.text` (its trace comment, `(volcomp
    /// Ln note)`, when asked for) and appends it to the buffer on a line of
    /// its own.
    pub(super) fn push_inserted(&mut self, at: &Place, note: &str) {
        let line = at.line;
        // Path-control words waiting for this line (the mode restored on a
        // block's last piece, `piece_mode_words`).
        if !self.line_words.is_empty() {
            self.text.extend_from_slice(self.walk.sep.as_bytes());
            self.text.extend_from_slice(self.line_words.as_bytes());
            self.line_words.clear();
        }
        if self.walk.options.trace_comments {
            // `(volcomp Ln)`, or `(volcomp Ln note)`.
            self.text.extend_from_slice(self.walk.sep.as_bytes());
            self.text.extend_from_slice(b"(volcomp L");
            format_uint_bytes(line, &mut self.text);
            if !note.is_empty() {
                self.text.push(b' ');
                self.text.extend_from_slice(note.as_bytes());
            }
            self.text.push(b')');
        }
        if !self.buf.is_empty() && !self.buf.ends_with(b"\n") {
            self.buf.extend_from_slice(b"\n");
        }
        self.buf.extend_from_slice(&self.text);
        self.buf.extend_from_slice(if at.ending.is_empty() {
            b"\n"
        } else {
            at.ending
        });
        self.summary.lines_out += 1;
    }

    /// Writes one compensated arc piece from `from` to `q` as an inserted
    /// line (`G2`/`G3` always written, both axes of the plane, the helix
    /// axis where it moves, the centre words), or as a G1 chord; `note`
    /// follows the line number in the trace comment.
    pub(super) fn write_inserted_arc(
        &mut self,
        at: &Place,
        from: Vec3,
        q: Vec3,
        arc: &ArcWords,
        note: &str,
    ) {
        if let Some(second) = arc.second {
            let first = ArcWords {
                second: None,
                ..*arc
            };
            let next = ArcWords {
                center: second.center,
                clockwise: second.clockwise,
                second: None,
                ..*arc
            };
            // Words for the piece's line go on its second arc's.
            let words = std::mem::take(&mut self.line_words);
            self.write_inserted_arc(at, from, second.joint, &first, note);
            self.line_words = words;
            self.write_inserted_arc(at, second.joint, q, &next, note);
            return;
        }
        if arc.center.is_none() {
            self.write_inserted(at, from, q, OutMode::Feed, note);
            return;
        }
        let (frame, style, sep) = (at.frame, at.style, self.walk.sep);
        let mode = arc.mode();
        let (u, v, _) = arc.plane.axes();
        self.text.clear();
        self.text.extend_from_slice(mode.code().as_bytes());
        self.mode = Some(mode);
        for (a, letter) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
            if a == u || a == v || frame.changes(q, from, a) {
                self.text.extend_from_slice(sep.as_bytes());
                self.text.push(letter);
                push_word_value(frame, q, from, a, style, &mut self.text);
            }
        }
        arc.push_text(frame, style, sep, from, &mut self.text);
        self.push_inserted(at, note);
    }

    /// The edits that write the first command `c` into the original line
    /// `line`, in the frame and style of `at`, appended to `edits`.
    pub(super) fn original_line_edits(
        &mut self,
        edits: &mut LineEdits,
        line: &Line,
        at: &Place,
        c: FirstCommand,
    ) {
        let (frame, style, sep) = (at.frame, at.style, self.walk.sep);
        let FirstCommand {
            from,
            q,
            kind,
            needed,
            stop_word,
            polar_nominal,
            polar_start,
        } = c;
        let content = line.content();
        let is_arc = matches!(kind, MotionKind::Arc(_));
        let mut has_motion_word = false;
        let mut last_axis_end = None;
        let mut first_axis_start = None;
        let mut present = [false; 3];
        // A polar end point (LinuxCNC `@` radius, `^` angle) is kept as
        // written while its X and Y round to the command's; otherwise the
        // polar words are replaced by the command's X and Y.
        let polar = || line.words().filter(|w| matches!(w.letter, b'@' | b'^'));
        // The lexer noted the line's letters: most lines have no polar
        // word and are not searched for one.
        let first_polar = if line.ev.lexed.has_polar() {
            polar().next()
        } else {
            None
        };
        if let Some(first) = first_polar {
            present[0] = true;
            present[1] = true;
            // In G91, or with only one of `@`/`^` in G90, the polar end point
            // depends on the start: the words can only stay when the command
            // starts where the nominal move did (to the written resolution).
            let both = polar().count() == 2;
            let half_lsb_mm = 0.5 * (1.0 / pow10(frame.decimals)) * frame.mm_per_unit;
            let start_kept = (frame.absolute && both)
                || (0..2).all(|a| (from[a] - polar_start[a]).abs() <= half_lsb_mm);
            let same = start_kept
                && (0..2).all(|a| {
                    (frame.word_value(q, from, a) - frame.word_value(polar_nominal, from, a)).abs()
                        < 0.5 * (1.0 / pow10(frame.decimals))
                });
            if !same {
                let start = edits.text_start();
                edits.text.push(b'X');
                format_number_bytes(frame.word_value(q, from, 0), style, &mut edits.text);
                edits.text.extend_from_slice(sep.as_bytes());
                edits.text.push(b'Y');
                format_number_bytes(frame.word_value(q, from, 1), style, &mut edits.text);
                edits.replace_written(first.span.clone(), start);
                for w in polar().skip(1) {
                    edits.delete(blank_before(content, w.span.start)..w.span.end);
                }
            }
            first_axis_start = Some(first.span.start);
            last_axis_end = Some(first.span.end);
        }
        for w in line.words() {
            match w.letter {
                b'G' if [0.0, 1.0, 2.0, 3.0].contains(&w.value) => {
                    has_motion_word = true;
                    if is_arc {
                        let text = &content[w.value_span.clone()];
                        let new: &[u8] = if text.len() >= 2 && text[0] == b'0' {
                            b"01"
                        } else {
                            b"1"
                        };
                        edits.replace(w.value_span.clone(), new);
                    }
                }
                b'X' | b'Y' | b'Z' => {
                    let a = usize::from(w.letter - b'X');
                    present[a] = true;
                    first_axis_start.get_or_insert(w.span.start);
                    last_axis_end = Some(w.span.end);
                    let scaled = frame.word_scaled(q, from, a);
                    // `frame.word_value`, the same operations.
                    let v = scaled / pow10(frame.decimals);
                    let lsb = 0.5 * (1.0 / pow10(frame.decimals));
                    if (v - w.value).abs() >= lsb * 0.999 {
                        // Never fewer decimals than the word replaced, even
                        // past the grid's MAX_DECIMALS.
                        let own = w.decimals;
                        let style = style.with_decimals(style.decimals.max(own.min(15)));
                        let start = edits.text_start();
                        if style.decimals == frame.decimals {
                            format_scaled_bytes(scaled, style, &mut edits.text);
                        } else {
                            format_number_bytes(v, style, &mut edits.text);
                        }
                        edits.replace_written(w.value_span.clone(), start);
                    }
                }
                b'I' | b'J' | b'K' | b'R' | b'P' if is_arc => {
                    edits.delete(blank_before(content, w.span.start)..w.span.end);
                }
                _ => {}
            }
        }
        if let Some(w) = stop_word {
            edits.delete(blank_before(content, w.span.start)..w.span.end);
        }
        let at = last_axis_end.unwrap_or(content.len());
        for (a, letter) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
            if !present[a] && frame.changes(q, from, a) {
                let start = edits.text_start();
                edits.text.extend_from_slice(sep.as_bytes());
                edits.text.push(letter);
                push_word_value(frame, q, from, a, style, &mut edits.text);
                edits.replace_written(at..at, start);
            }
        }
        if !has_motion_word && (self.mode != Some(needed) || is_arc) {
            let at = first_axis_start.unwrap_or(0);
            let start = edits.text_start();
            edits.text.extend_from_slice(needed.code().as_bytes());
            if !sep.is_empty() {
                edits.text.push(b' ');
            }
            edits.replace_written(at..at, start);
        }
    }
}

/// Appends the word of axis `a` moving from `from` to `q`
/// ([`Frame::word_value`]) in `style`: from the integer count of steps it
/// was rounded to where the style writes the frame's decimals (the same
/// text, [`format_scaled_bytes`]), else from the value.
fn push_word_value(
    frame: &Frame,
    q: Vec3,
    from: Vec3,
    a: usize,
    style: NumberStyle,
    out: &mut Vec<u8>,
) {
    if style.decimals == frame.decimals {
        format_scaled_bytes(frame.word_scaled(q, from, a), style, out);
    } else {
        format_number_bytes(frame.word_value(q, from, a), style, out);
    }
}

/// Edits that replace an arc line's centre words: every I, J, K, R and P
/// word is deleted (a piece never turns more than a quarter, so it needs no
/// P) and `centre` is inserted after the last axis word (or at the end).
pub(super) fn arc_line_edits<'a>(
    words: impl Iterator<Item = &'a Word>,
    content: &[u8],
    centre: String,
) -> Vec<Edit> {
    let mut edits = Vec::new();
    let mut at = None;
    for w in words {
        match w.letter {
            b'I' | b'J' | b'K' | b'R' | b'P' => {
                edits.push(Edit::delete(
                    blank_before(content, w.span.start)..w.span.end,
                ));
            }
            b'X' | b'Y' | b'Z' => at = Some(w.span.end),
            _ => {}
        }
    }
    // No axis word (the end is the start: a full circle): at the end.
    let at = at.unwrap_or(content.len());
    edits.push(Edit::insert(at, centre));
    edits
}

/// Start of the blanks that precede byte `at` (so a deleted word takes its
/// separating blank with it).
pub(super) fn blank_before(content: &[u8], at: usize) -> usize {
    let mut i = at;
    while i > 0 && (content[i - 1] == b' ' || content[i - 1] == b'\t') {
        i -= 1;
    }
    i
}

pub(super) fn line_ending(bytes: &[u8]) -> &[u8] {
    let n = volcomp_gcode::lexer::content_len(bytes);
    let e = &bytes[n..];
    if e.is_empty() {
        b"\n"
    } else {
        e
    }
}

pub(super) fn explicit_mode<'a>(words: impl Iterator<Item = &'a Word>) -> Option<OutMode> {
    let mut mode = None;
    for w in words {
        if w.letter == b'G' {
            mode = match w.value {
                0.0 => Some(OutMode::Rapid),
                1.0 => Some(OutMode::Feed),
                2.0 => Some(OutMode::Cw),
                3.0 => Some(OutMode::Ccw),
                v if (80.0..=89.0).contains(&v) => Some(OutMode::Other),
                _ => mode,
            };
        }
    }
    mode
}

/// The feed mode and rate in force at a point of the program: the
/// interpreter's after a line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct FeedInForce {
    pub mode: FeedMode,
    /// The last F in the units of `mode`; 0 until an F sets it and again
    /// after a G94 or G95 (LinuxCNC, src/emc/rs274ngc/interp_convert.cc,
    /// `Interp::convert_feed_mode`: "settings->feed_rate = 0.0" for G_94
    /// and G_95, not for G_93).
    pub rate: f64,
}

impl Default for FeedInForce {
    /// LinuxCNC's start: G94, no feed rate.
    fn default() -> Self {
        FeedInForce {
            mode: FeedMode::PerMinute,
            rate: 0.0,
        }
    }
}

/// How a feed move the compensation inserts (a take-up) is written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum InsertedFeed {
    /// `G1` without F: a positive rate is in force.
    InForce,
    /// `G0`: no feed rate in force (none set yet, or reset to 0 by G94 or
    /// G95: a feed move would be refused, "Cannot do g1 with zero feed
    /// rate"); and under inverse time (G93), where every feed move needs
    /// its own F (LinuxCNC: "F word missing with inverse time g1 move") and
    /// the line's F would make a take-up of micrometres last as long as the
    /// line. A G1 at the line's own F would be valid where the line keeps
    /// the feed mode, but it runs slower than the rapid and counts as
    /// cutting time (+0.5 point on a G61 circle at F6000).
    Rapid,
}

impl FeedInForce {
    /// The feed state the interpreter leaves after a line.
    pub fn after(interp: &volcomp_gcode::Interpreter) -> Self {
        FeedInForce {
            mode: interp.feed_mode(),
            rate: interp.feed_rate(),
        }
    }

    /// How a feed move inserted where `self` is in force is written.
    pub fn inserted_feed(self) -> InsertedFeed {
        match self.mode {
            FeedMode::InverseTime => InsertedFeed::Rapid,
            _ if self.rate > 0.0 => InsertedFeed::InForce,
            _ => InsertedFeed::Rapid,
        }
    }
}

pub(super) fn stop_m_word<'a>(mut words: impl Iterator<Item = &'a Word>) -> Option<&'a Word> {
    words.find(|w| w.letter == b'M' && [0.0, 1.0, 2.0, 30.0, 60.0].contains(&w.value))
}

/// The mode words that let the planner run through the joins between the
/// pieces of one block under G61 or G61.1 (docs/compensation.md, "Pieces
/// of a block under G61"): `G64 P p Q0` for the block's first piece and
/// the program's own word (`G61`, `G61.1`) for its last.
///
/// LinuxCNC 2.9 takes a segment's end condition from the mode in effect
/// when the segment was queued (tp.c `tpSetupTangent`, `tpChooseBestBlend`
/// look at the earlier segment's `term_cond`): under G61
/// (TC_TERM_COND_EXACT) it stops at every join that is not tangent within
/// its tolerance, under G61.1 (TC_TERM_COND_STOP) at every join, while the
/// program asked to be exact only at its own block ends. Under `G64 P p`
/// a join is blended by an arc that stays within `p` of the corner
/// (blendmath.c `blendComputeParameters`); the corner is a solved target,
/// so with `p` at most the contour tolerance the tool stays within it.
/// `Q0` keeps the canonical layer from merging the pieces into one line or
/// turning an arc piece into two lines (emccanon.cc `linkable`, `ARC_FEED`:
/// both need a naive-CAM tolerance above 0; without Q, G64 takes P for it).
///
/// `None` where the block is not in G61/G61.1, or its line already has a
/// P or Q word or a path-control word (one block may not carry two; a
/// line is left as the program wrote it), or `p` rounds to 0 in the
/// program's units. `p_units` is `p` in the program's units; `arc`: the
/// block is an arc, whose P (its turn count) the written pieces drop.
pub(super) fn piece_mode_words<'a>(
    mode: volcomp_gcode::PathMode,
    mut words: impl Iterator<Item = &'a Word>,
    p_units: f64,
    arc: bool,
    sep: &str,
) -> Option<(String, &'static str)> {
    let restore = match mode {
        volcomp_gcode::PathMode::ExactPath => "G61",
        volcomp_gcode::PathMode::ExactStop => "G61.1",
        volcomp_gcode::PathMode::Blend { .. } => return None,
    };
    if words.any(|w| {
        (w.letter == b'P' && !arc)
            || w.letter == b'Q'
            || (w.letter == b'G'
                && [61.0, 61.1, 64.0]
                    .iter()
                    .any(|g| (w.value - g).abs() < 1e-9))
    }) {
        return None;
    }
    let p = tolerance_text(p_units)?;
    Some((format!("G64{sep}P{p}{sep}Q0"), restore))
}

/// `v` (> 0) rounded down to two significant digits, as a decimal without
/// exponent and without trailing zeros (`1e-4` → `0.0001`, `3.937e-6` →
/// `0.0000039`): a tolerance that is never larger than asked. `None` for
/// what is not a positive finite number, or below 1e-12.
fn tolerance_text(v: f64) -> Option<String> {
    if !(v.is_finite() && v >= 1e-12) {
        return None;
    }
    let decimals = (1.0 - v.log10().floor()).max(0.0) as usize;
    let scale = 10f64.powi(decimals as i32);
    let kept = ((v * scale) * (1.0 + 1e-12)).floor() / scale;
    let text = format!("{kept:.decimals$}");
    let text = if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        text
    };
    Some(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The edits kept in one buffer write what `apply_edits` writes from
    /// the same edits (the second method), errors included: replacements,
    /// deletions, insertions at one place (kept in their order), at the
    /// line's end; overlapping edits and one past the end. By hand: the
    /// first case gives `G1 X10.5 Y2 Z1 F100`.
    #[test]
    fn line_edits_apply_as_apply_edits() {
        use volcomp_gcode::edit::apply_edits;
        let line = b"G1 X10 Y2 I5 F100\r\n";
        let cases: Vec<Vec<Edit>> = vec![
            vec![
                Edit::replace(4..6, "10.5"),
                Edit::delete(9..12),
                Edit::insert(9, " Z1"),
            ],
            vec![
                Edit::insert(3, "A"),
                Edit::insert(0, "N1 "),
                Edit::insert(3, "B"),
                Edit::replace(0..2, "G01"),
                Edit::insert(17, " (end)"),
            ],
            vec![Edit::replace(3..6, "X1"), Edit::replace(5..9, "Y3")],
            vec![Edit::replace(18..20, "")],
            vec![Edit::insert(20, "!")],
            vec![],
        ];
        let mut edits = LineEdits::default();
        let mut outs = Vec::new();
        for case in cases {
            let (mut want, mut got) = (Vec::new(), Vec::new());
            let expected = apply_edits(line, &mut case.clone(), &mut want);
            edits.clear();
            edits.extend(case);
            assert_eq!(edits.apply(line, &mut got), expected);
            if expected.is_ok() {
                assert_eq!(got, want);
            }
            outs.push(got);
        }
        assert_eq!(outs[0], b"G1 X10.5 Y2 Z1 F100\r\n");
        assert_eq!(outs[1], b"N1 G01 ABX10 Y2 I5 F100 (end)\r\n");
    }

    #[test]
    fn a_tolerance_is_written_rounded_down_to_two_digits() {
        // 0.1 µm in mm, in inch (0.1 / 25 400 = 3.937e-6 in), 0.5 mm, 2.
        assert_eq!(tolerance_text(1e-4).as_deref(), Some("0.0001"));
        assert_eq!(tolerance_text(1e-4 / 25.4).as_deref(), Some("0.0000039"));
        assert_eq!(tolerance_text(0.5).as_deref(), Some("0.5"));
        assert_eq!(tolerance_text(2.0).as_deref(), Some("2"));
        assert_eq!(tolerance_text(0.0), None);
        assert_eq!(tolerance_text(f64::NAN), None);
    }
    use volcomp_gcode::Plane;

    fn frame(mm_per_unit: f64) -> Frame {
        Frame {
            offset_mm: Vec3::ZERO,
            mm_per_unit,
            decimals: 4,
            absolute: true,
            rotation_deg: 0.0,
            before_mm: Vec3::ZERO,
            after_mm: Vec3::ZERO,
            x_word_scale: 1.0,
            arc_absolute: false,
        }
    }

    /// Whether the G3 from `a` to `b` about `c` (mm, XY) is read as meant,
    /// written in mm (`k` = 1) or inch (`k` = 25.4) with 4 decimals.
    fn readable(a: [f64; 2], b: [f64; 2], c: [f64; 2], k: f64) -> bool {
        let w = ArcWords {
            center: Some(Vec3::new(c[0], c[1], 0.0)),
            plane: Plane::Xy,
            clockwise: false,
            radius_style: false,
            absolute_centers: false,
            second: None,
        };
        let p = |v: [f64; 2]| Vec3::new(v[0], v[1], 0.0);
        w.readable(&frame(k), NumberStyle::fixed(4), p(a), p(b))
    }

    #[test]
    fn pieces_linuxcnc_would_misread_are_not_readable() {
        // A quarter of radius 1 about the origin.
        assert!(readable([1.0, 0.0], [0.0, 1.0], [0.0, 0.0], 1.0));
        // Rounded ends 0.5 µm apart that crossed over: counter-clockwise
        // from 0.0005 rad to 0 is almost a full turn as read.
        assert!(!readable([1.0, 0.0005], [1.0, 0.0], [0.0, 0.0], 1.0));
        // A chord of one step (0.1 µm).
        assert!(!readable([1.0, 0.0], [1.0, 0.0001], [0.0, 0.0], 1.0));
        // Radius 0.5 µm, below RADIUS_TOLERANCE (1.27 µm).
        assert!(!readable([0.0, 0.0], [0.0005, 0.0005], [0.0005, 0.0], 1.0));
        // End radius 1.05 against 1 at the start: 0.05 mm and 5 % apart,
        // past the spiral tolerance in mm (0.028 mm) — refused; in inch
        // (0.0028 in = 0.072 mm) accepted (both must be exceeded).
        assert!(!readable([1.0, 0.0], [0.0, 1.05], [0.0, 0.0], 1.0));
        assert!(readable([25.4, 0.0], [0.0, 25.4 + 0.05], [0.0, 0.0], 25.4));
        // The centre is read from the rounded I: meant 1.26 µm from the
        // start (below the 1.27 µm), written I0.0013, read 1.3 µm from the
        // start and from the end (0.0013, −0.0013), a quarter turn.
        assert!(readable([0.0, 0.0], [0.0013, -0.0013], [0.00126, 0.0], 1.0));
    }
}
