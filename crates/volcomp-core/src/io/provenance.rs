//! The header of a compensated program: what it was compensated for.
//!
//! A compensated program is valid for one machine state only: the map it
//! was made with, the set-up (work offsets, tool lengths) and the options.
//! Its first lines — after a leading `%` line and an O-number line, where
//! present — say so in comments, so that an operator can tell which map a
//! program on the controller belongs to, and volcomp can refuse to
//! compensate a compensated program a second time (that would apply every
//! correction twice).
//!
//! The comments are written so that every common controller accepts them:
//! parenthesised (RS274/NGC, NIST IR 6556 §3.3.4; Fanuc, Haas, Siemens in
//! ISO mode), no nested parentheses, printable ASCII only, and lines of at
//! most [`MAX_LINE`] characters.
//!
//! The header is the block of lines from [`FIRST_LINE`] to [`LAST_LINE`];
//! [`strip_header`] removes it, which gives back the program body that a
//! byte-for-byte round trip compares.

use std::io::{self, Write};

use volcomp_gcode::Setup;

/// The header's first line; its presence marks a compensated program.
pub const FIRST_LINE: &str = "(volcomp compensated program - do not compensate again)";
/// The header's first line instead of [`FIRST_LINE`] when feed moves were
/// written without compensation (an axis never set): the program is never
/// called compensated then; it still marks the program, whose other moves
/// are compensated.
pub const FIRST_LINE_PARTIAL: &str =
    "(volcomp program NOT fully compensated - do not compensate again)";
/// The header's last line: the program body starts after it.
pub const LAST_LINE: &str = "(volcomp header end)";
/// The longest header line, parentheses included: 80 columns, the width
/// of a classic terminal (a SHA-256 line takes 77); controllers accept far
/// longer blocks (LinuxCNC 256 characters, `LINELEN` in rs274ngc.hh).
pub const MAX_LINE: usize = 80;

/// What a compensated program was made for.
#[derive(Debug, Clone)]
pub struct ProgramHeader {
    /// volcomp's version.
    pub version: String,
    /// Each file the compensation depends on: a short label (`map`,
    /// `surf`, `probes`; at most 6 characters so that the SHA-256 line fits
    /// in [`MAX_LINE`]), the file name and its SHA-256 in hex.
    pub files: Vec<(String, String, String)>,
    /// The set-up file's name, if one was given.
    pub setup_file: Option<String>,
    /// Where a work offset came from when not from the set-up file
    /// (e.g. a command-line flag).
    pub work_offset_note: Option<String>,
    /// The set-up used.
    pub setup: Setup,
    /// The method, in words.
    pub method: String,
    /// The options, in words.
    pub options: String,
    /// When, as ISO 8601 UTC (see [`iso8601_utc`]).
    pub date_utc: String,
}

/// The SHA-256 of `bytes` in lower-case hex (FIPS 180-4).
pub fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::Digest as _;
    let digest = sha2::Sha256::digest(bytes);
    digest.iter().map(|b| format!("{b:02x}")).collect()
}

/// Now as ISO 8601 UTC, or `SOURCE_DATE_EPOCH` when set (the
/// reproducible-builds convention), so a run can be repeated byte for byte.
pub fn now_utc() -> String {
    let secs = std::env::var("SOURCE_DATE_EPOCH")
        .ok()
        .and_then(|s| s.trim().parse::<i64>().ok())
        .unwrap_or_else(|| {
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map(|d| d.as_secs() as i64)
                .unwrap_or(0)
        });
    iso8601_utc(secs)
}

/// Seconds since 1970-01-01T00:00:00Z as ISO 8601 (`2024-02-29T12:00:00Z`),
/// by the days-to-civil algorithm of H. Hinnant, "chrono-Compatible
/// Low-Level Date Algorithms" (proleptic Gregorian calendar).
pub fn iso8601_utc(unix_seconds: i64) -> String {
    let days = unix_seconds.div_euclid(86_400);
    let secs = unix_seconds.rem_euclid(86_400);
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        secs / 3600,
        secs % 3600 / 60,
        secs % 60
    )
}

/// Text safe inside a comment: printable ASCII, parentheses turned into
/// brackets (a `)` would end the comment, a `(` would nest one).
pub fn comment_text(s: &str) -> String {
    s.chars()
        .map(|c| match c {
            '(' => '[',
            ')' => ']',
            c if c.is_ascii_graphic() || c == ' ' => c,
            _ => '?',
        })
        .collect()
}

/// `(label text)` lines of at most [`MAX_LINE`] characters, broken at
/// `, ` where possible; continuation lines repeat the label.
fn wrapped(label: &str, text: &str) -> Vec<String> {
    let text = comment_text(text);
    let room = MAX_LINE - label.len() - 3;
    let mut lines = Vec::new();
    let mut rest = text.as_str();
    while !rest.is_empty() {
        let (take, skip) = if rest.len() <= room {
            (rest.len(), 0)
        } else {
            match rest[..room].rfind(", ") {
                Some(k) if k > 0 => (k, 2),
                _ => (room, 0),
            }
        };
        let (head, tail) = rest.split_at(take);
        lines.push(format!("({label} {})", head.trim()));
        rest = tail[skip..].trim_start();
    }
    if lines.is_empty() {
        lines.push(format!("({label})"));
    }
    lines
}

/// `text` as comment lines of at most [`MAX_LINE`] characters, each
/// starting with `label`, broken between words.
pub(crate) fn wrapped_at_words(label: &str, text: &str) -> Vec<String> {
    let room = MAX_LINE - label.len() - 3;
    let mut lines = Vec::new();
    let mut line = String::new();
    for word in comment_text(text).split_whitespace() {
        if !line.is_empty() && line.len() + 1 + word.len() > room {
            lines.push(format!("({label} {line})"));
            line.clear();
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(word);
    }
    if !line.is_empty() {
        lines.push(format!("({label} {line})"));
    }
    lines
}

pub(crate) fn num(v: f64) -> String {
    // Display never uses an exponent; trim float noise to 6 decimals.
    let s = format!("{:.6}", v);
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.into()
    }
}

const WORK_OFFSETS: [&str; 9] = [
    "G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3",
];

impl ProgramHeader {
    /// The header's lines, without line endings.
    pub fn lines(&self) -> Vec<String> {
        let mut out = vec![FIRST_LINE.to_string()];
        out.extend(wrapped("volcomp", &self.version));
        for (label, name, sha) in &self.files {
            let label = comment_text(label);
            out.extend(wrapped(&label, name));
            out.push(format!("({label} sha256 {})", comment_text(sha)));
        }
        let mut setup = self
            .setup_file
            .clone()
            .unwrap_or_else(|| "none given".into());
        if let Some(note) = &self.work_offset_note {
            setup.push_str(", ");
            setup.push_str(note);
        }
        out.extend(wrapped("setup", &setup));
        let mut any = false;
        for (name, w) in WORK_OFFSETS.iter().zip(&self.setup.work_offsets_mm) {
            if w.x != 0.0 || w.y != 0.0 || w.z != 0.0 || *name == "G54" {
                any = true;
                out.push(format!(
                    "({name} X{} Y{} Z{} mm)",
                    num(w.x),
                    num(w.y),
                    num(w.z)
                ));
            }
        }
        debug_assert!(any);
        if self.setup.tool_lengths_mm.is_empty() {
            out.push("(tool lengths none)".into());
        }
        for (t, l) in &self.setup.tool_lengths_mm {
            out.push(format!("(tool {t} length {} mm)", num(*l)));
        }
        out.extend(wrapped("method", &self.method));
        out.extend(wrapped("options", &self.options));
        out.extend(wrapped("date", &self.date_utc));
        out.push(LAST_LINE.to_string());
        out
    }
}

/// How a program shows that volcomp compensated it already.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Compensated {
    /// It carries a header, starting on this line (1-based).
    Header(u64),
    /// It carries `(volcomp L…)` trace comments (written by versions
    /// without a header), the first on this line.
    Trace(u64),
}

/// Looks for signs of an earlier compensation in the start of a program.
pub fn find_compensation(head: &[u8]) -> Option<Compensated> {
    let mut trace = None;
    for (k, line) in head.split(|&b| b == b'\n').enumerate() {
        let line = String::from_utf8_lossy(line);
        let t = line.trim();
        if t.starts_with("(volcomp compensated program") || t == FIRST_LINE_PARTIAL {
            return Some(Compensated::Header(k as u64 + 1));
        }
        if trace.is_none() && t.contains("(volcomp L") {
            trace = Some(Compensated::Trace(k as u64 + 1));
        }
    }
    trace
}

/// The program without its header (unchanged when it has none).
pub fn strip_header(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut inside = false;
    let mut done = false;
    for line in text.split_inclusive('\n') {
        let t = line.trim();
        if !done && !inside && (t == FIRST_LINE || t == FIRST_LINE_PARTIAL) {
            inside = true;
            continue;
        }
        if inside {
            if t == LAST_LINE {
                inside = false;
                done = true;
            }
            continue;
        }
        out.push_str(line);
    }
    out
}

/// Is this line a program-number line (`O1234`, optionally with a comment)?
fn is_program_number(t: &str) -> bool {
    let b = t.as_bytes();
    if b.len() < 2 || !(b[0] == b'O' || b[0] == b'o') || !b[1].is_ascii_digit() {
        return false;
    }
    let rest = t[1..]
        .trim_start_matches(|c: char| c.is_ascii_digit())
        .trim();
    rest.is_empty() || rest.starts_with('(')
}

/// Where a header went into a program: after its first `body_lines_before`
/// lines (blank lines, `%`, an O-number), `lines` lines long. The default
/// is no header: every line where it was.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct HeaderPlace {
    /// Lines of the program before the header.
    pub body_lines_before: u64,
    /// Lines of the header.
    pub lines: u64,
}

impl HeaderPlace {
    /// The line of the written file (1-based) that holds line `body_line`
    /// of the program without its header (0, no line, stays 0).
    pub fn written_line(&self, body_line: u64) -> u64 {
        if body_line > self.body_lines_before {
            body_line + self.lines
        } else {
            body_line
        }
    }

    /// `e`, an error found reading the program without its header (the
    /// machining-time estimate of the copy made while it was written),
    /// located at the line of the written file instead.
    pub fn locate_in_written(&self, e: crate::Error) -> crate::Error {
        match e {
            crate::Error::Gcode(mut g) => {
                g.diagnostic.line = self.written_line(g.diagnostic.line);
                crate::Error::Gcode(g)
            }
            e => e,
        }
    }
}

/// A writer that inserts the header after a leading `%` line and an
/// O-number line (where present), before the first other line.
pub struct HeaderWriter<W: Write> {
    inner: W,
    header: Option<Vec<String>>,
    /// Where the header goes: the lines passed before it so far.
    place: HeaderPlace,
    pending: Vec<u8>,
    seen_percent: bool,
    seen_number: bool,
}

impl<W: Write> HeaderWriter<W> {
    /// Wraps `inner`; `lines` are the header's lines.
    pub fn new(inner: W, lines: Vec<String>) -> Self {
        Self {
            inner,
            place: HeaderPlace {
                body_lines_before: 0,
                lines: lines.len() as u64,
            },
            header: Some(lines),
            pending: Vec::new(),
            seen_percent: false,
            seen_number: false,
        }
    }

    fn emit_header(&mut self, eol: &str) -> io::Result<()> {
        if let Some(lines) = self.header.take() {
            for l in lines {
                self.inner.write_all(l.as_bytes())?;
                self.inner.write_all(eol.as_bytes())?;
            }
        }
        Ok(())
    }

    /// Writes the header if the program ended before its first block.
    pub fn finish(self) -> io::Result<W> {
        self.finish_placed().map(|(w, _)| w)
    }

    /// [`HeaderWriter::finish`], and where the header went.
    pub fn finish_placed(mut self) -> io::Result<(W, HeaderPlace)> {
        if self.header.is_some() {
            let pending = std::mem::take(&mut self.pending);
            if !pending.is_empty() {
                // A last line without a line ending.
                self.inner.write_all(&pending)?;
                self.inner.write_all(b"\n")?;
                self.place.body_lines_before += 1;
            }
            self.emit_header("\n")?;
        }
        self.inner.flush()?;
        Ok((self.inner, self.place))
    }
}

impl<W: Write> Write for HeaderWriter<W> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        if self.header.is_none() {
            return self.inner.write(buf);
        }
        self.pending.extend_from_slice(buf);
        while self.header.is_some() {
            let Some(end) = self.pending.iter().position(|&b| b == b'\n') else {
                break;
            };
            let line: Vec<u8> = self.pending.drain(..=end).collect();
            let text = String::from_utf8_lossy(&line);
            let t = text.trim();
            let eol = if line.ends_with(b"\r\n") {
                "\r\n"
            } else {
                "\n"
            };
            if !self.seen_percent && !self.seen_number && t.is_empty() {
                // Blank lines before the opening `%` stay
                // before it (LinuxCNC looks for `%` at the first non-blank
                // line; a header there would make the `%` a stray one).
            } else if !self.seen_percent && !self.seen_number && t.starts_with('%') {
                self.seen_percent = true;
            } else if !self.seen_number && is_program_number(t) {
                self.seen_number = true;
            } else {
                self.emit_header(eol)?;
            }
            if self.header.is_some() {
                self.place.body_lines_before += 1;
            }
            self.inner.write_all(&line)?;
        }
        if self.header.is_none() && !self.pending.is_empty() {
            let rest = std::mem::take(&mut self.pending);
            self.inner.write_all(&rest)?;
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compensate::CompensateOptions;

    #[test]
    fn dates_against_known_days() {
        // Hand-checked: the epoch, a leap day, the last second of 1999.
        assert_eq!(iso8601_utc(0), "1970-01-01T00:00:00Z");
        assert_eq!(iso8601_utc(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(iso8601_utc(946_684_799), "1999-12-31T23:59:59Z");
        assert_eq!(iso8601_utc(-1), "1969-12-31T23:59:59Z");
    }

    #[test]
    fn sha256_of_abc() {
        // FIPS 180-2, appendix B.1.
        assert_eq!(
            sha256_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }

    #[test]
    fn comment_text_is_plain_ascii_without_parentheses() {
        assert_eq!(comment_text("a(b)ü\t"), "a[b]??");
    }

    fn header() -> ProgramHeader {
        let mut setup = Setup::default();
        setup.work_offsets_mm[0] = volcomp_gcode::Vec3::new(150.0, 150.0, 100.0);
        setup.tool_lengths_mm.insert(1, 75.0);
        ProgramHeader::for_compensation(
            vec![("very (odd) name.csv".into(), sha256_hex(b"abc"))],
            Some("machine.toml".into()),
            setup,
            &CompensateOptions::default(),
            iso8601_utc(0),
        )
    }

    #[test]
    fn header_lines_are_plain_short_comments() {
        let lines = header().lines();
        assert_eq!(lines[0], FIRST_LINE);
        assert_eq!(lines.last().unwrap(), LAST_LINE);
        for l in &lines {
            assert!(l.len() <= MAX_LINE, "{l}");
            assert!(l.starts_with('(') && l.ends_with(')'), "{l}");
            assert_eq!(l.matches('(').count(), 1, "{l}");
            assert_eq!(l.matches(')').count(), 1, "{l}");
            assert!(l.is_ascii());
        }
        let all = lines.join("\n");
        assert!(all.contains("(map very [odd] name.csv)"));
        assert!(all.contains("(map sha256 ba7816bf"));
        assert!(all.contains("(G54 X150 Y150 Z100 mm)"));
        assert!(all.contains("(tool 1 length 75 mm)"));
        assert!(all.contains("(method exact)"));
        assert!(all.contains("(date 1970-01-01T00:00:00Z)"));
    }

    fn insert(program: &str) -> String {
        let mut w = HeaderWriter::new(Vec::new(), vec!["(H1)".into(), "(H2)".into()]);
        // Byte by byte: the position must not depend on how writes are cut.
        for b in program.as_bytes() {
            w.write_all(std::slice::from_ref(b)).unwrap();
        }
        String::from_utf8(w.finish().unwrap()).unwrap()
    }

    #[test]
    fn header_position() {
        assert_eq!(insert("G0 X1\nM2\n"), "(H1)\n(H2)\nG0 X1\nM2\n");
        assert_eq!(insert("%\nG0 X1\n%\n"), "%\n(H1)\n(H2)\nG0 X1\n%\n");
        assert_eq!(
            insert("%\r\nO1234 (PART)\r\nG0 X1\r\n"),
            "%\r\nO1234 (PART)\r\n(H1)\r\n(H2)\r\nG0 X1\r\n"
        );
        assert_eq!(insert("O0001\nG0 X1\n"), "O0001\n(H1)\n(H2)\nG0 X1\n");
        // A LinuxCNC subroutine is not a program number.
        assert_eq!(insert("o100 sub\nM2\n"), "(H1)\n(H2)\no100 sub\nM2\n");
        assert_eq!(insert("%\n"), "%\n(H1)\n(H2)\n");
        assert_eq!(insert(""), "(H1)\n(H2)\n");
    }

    #[test]
    fn header_place_counts_the_lines_before_and_of_the_header() {
        // Counted by hand in the written texts of `header_position`.
        let place = |program: &str| {
            let mut w = HeaderWriter::new(Vec::new(), vec!["(H1)".into(), "(H2)".into()]);
            w.write_all(program.as_bytes()).unwrap();
            w.finish_placed().unwrap().1
        };
        let at = |before, lines| HeaderPlace {
            body_lines_before: before,
            lines,
        };
        assert_eq!(place("G0 X1\nM2\n"), at(0, 2));
        assert_eq!(place("%\r\nO1234 (PART)\r\nG0 X1\r\n"), at(2, 2));
        assert_eq!(place("\n%\nG0 X1\n"), at(2, 2));
        // A last line without an ending goes before the header: written
        // "%\nG0 X1\n(H1)\n(H2)\n".
        assert_eq!(place("%\nG0 X1"), at(2, 2));
        assert_eq!(place("%\nO12"), at(2, 2));
        // "%\nO1234 (PART)\n(H1)\n(H2)\nG0 X1\nM2": M2, line 4 without
        // the header, is line 6 of the written file; the `%` stays line 1.
        let p = at(2, 2);
        assert_eq!(p.written_line(4), 6);
        assert_eq!(p.written_line(3), 5);
        assert_eq!(p.written_line(1), 1);
        assert_eq!(p.written_line(0), 0);
        assert_eq!(HeaderPlace::default().written_line(7), 7);
    }

    #[test]
    fn strip_and_find() {
        let program = "%\nO12\nG0 X1\nM2\n%\n";
        let mut w = HeaderWriter::new(Vec::new(), header().lines());
        w.write_all(program.as_bytes()).unwrap();
        let with = String::from_utf8(w.finish().unwrap()).unwrap();
        assert_eq!(
            find_compensation(with.as_bytes()),
            Some(Compensated::Header(3))
        );
        assert_eq!(strip_header(&with), program);
        assert_eq!(find_compensation(program.as_bytes()), None);
        assert_eq!(
            find_compensation(b"G0 X1\nG1 X2 (volcomp L2)\n"),
            Some(Compensated::Trace(2))
        );
    }
}
