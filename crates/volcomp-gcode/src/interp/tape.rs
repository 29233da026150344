//! The start and end of a program, as LinuxCNC reads them
//! (`Interp::open`, rs274ngc_pre.cc; `Interp::read_text`, interp_read.cc).
//!
//! A program "uses percents" when its first non-blank line holds only `%`
//! (blanks around it allowed); it then ends at the next line that is only
//! `%`. Any other `%` line is not G-code: LinuxCNC stops there with "Bad
//! character '%' used", after running every line before it. M2 or M30 end
//! any program; a program that reaches the end of its file without either
//! (or without its closing `%`) is run to its last line, then LinuxCNC
//! reports "File ended with no percent sign or program end" ("File ended
//! with no percent sign" when it opened with `%`).
//!
//! volcomp follows the motion: a program without an end, or whose last
//! non-blank line is a stray `%`, is read to that point and processed, with
//! a warning that says what LinuxCNC will report (grbl-oriented posts write
//! no M2, some posts a trailing `%`). What LinuxCNC refuses before it moves
//! is refused: a first line that is `%` with something else on it (`%
//! hello`), and any G-code after a stray `%` (LinuxCNC would stop at the `%`
//! and never run it).

use super::{invalid, Interpreter, Warning};
use crate::error::GcodeError;

/// What to do about a program without an end, with the option that stops
/// the warning (front ends say `{allow_no_program_end}` their own way).
pub const PROGRAM_END_HELP: &str = "add M2 (or M30) at the end of the program, or accept a program without one ({allow_no_program_end}) if the controller runs such programs";

/// UTF-8 byte-order mark: LinuxCNC reads its first byte as a character of
/// the line ("Bad character '\357' used").
const BOM: &[u8] = b"\xEF\xBB\xBF";

/// Whether `content` (a line without its ending) is what LinuxCNC takes for
/// a `%` line: at the top of the file, `%` with only white space around it
/// (`Interp::open` skips `isspace` on both sides); later, after trailing
/// white space is cut and blanks and tabs are removed outside comments
/// (`read_text`, `close_and_downcase`), exactly `%`. Both reduce to: `%`
/// and white space only.
fn is_percent_only(content: &[u8]) -> bool {
    let mut rest = content
        .iter()
        .filter(|b| !matches!(b, b' ' | b'\t' | b'\r' | b'\x0b' | b'\x0c'));
    rest.next() == Some(&b'%') && rest.next().is_none()
}

/// LinuxCNC's message for a `%` line it does not take as the tape's start
/// or end.
fn bad_character(content: &[u8]) -> &'static str {
    if content.starts_with(BOM) {
        "Bad character '\\357' used"
    } else {
        "Bad character '%' used"
    }
}

impl Interpreter {
    /// Notes a `%` line (1-based `line`, `content` without its line
    /// ending): the first non-blank line starts a program that uses
    /// percents when it is only `%`, the next such line ends it. Any other
    /// `%` line is a stray one: refused when it is the first non-blank line
    /// (LinuxCNC refuses the program before it moves), else remembered, so
    /// that G-code after it is refused and the end of the file warns.
    pub fn percent_line(&mut self, line: u64, content: &[u8]) -> Result<(), GcodeError> {
        if self.finished {
            return Ok(());
        }
        let first = !self.nonblank_seen;
        self.nonblank_seen = true;
        let pure = is_percent_only(content);
        if first && pure {
            self.uses_percents = true;
            return Ok(());
        }
        if self.uses_percents && pure {
            self.finished = true;
            return Ok(());
        }
        if first {
            return Err(invalid(
                line,
                0,
                format!(
                    "the first line starts with `%` but holds more than `%`: LinuxCNC refuses the program before it runs (\"{}\")",
                    bad_character(content)
                ),
                "make the first line `%` alone (the program then ends at the next `%` line), or remove the `%`",
            ));
        }
        if let Some(first_stray) = self.stray_percent {
            return Err(self.after_stray_percent(line, first_stray));
        }
        self.stray_percent = Some((line, bad_character(content)));
        Ok(())
    }

    /// The refusal of G-code after a stray `%` line.
    fn after_stray_percent(&self, line: u64, (at, message): (u64, &'static str)) -> GcodeError {
        invalid(
            line,
            0,
            format!(
                "line {at} is a `%` line that does not close a program opened by `%`: LinuxCNC stops there (\"{message}\") and never runs this line"
            ),
            format!("remove the `%` of line {at} if the program goes on, or end the program before it"),
        )
    }

    /// Refuses a block with words after a stray `%` line (comments and
    /// blank lines may follow it).
    #[inline]
    pub(super) fn check_after_stray_percent(
        &self,
        line: u64,
        lexed: &crate::lexer::Lexed,
    ) -> Result<(), GcodeError> {
        // The words are looked at only after a stray `%` (rare).
        match self.stray_percent {
            Some(at) if lexed.words().next().is_some() => Err(self.after_stray_percent(line, at)),
            _ => Ok(()),
        }
    }

    /// Ends the program where LinuxCNC runs nothing more up to the end of
    /// the file (`what` says why, at `line`, `column`), which it then
    /// reports: a warning says both.
    pub(crate) fn end_of_file_reached(&mut self, line: u64, column: usize, what: &str) {
        self.finished = true;
        let reported = if self.uses_percents {
            "File ended with no percent sign"
        } else {
            "File ended with no percent sign or program end"
        };
        self.warnings.push(Warning {
            line,
            column,
            message: format!(
                "{what}, then reports \"{reported}\"; volcomp copies the rest of the file as it is"
            ),
        });
    }

    /// Notes a non-blank line that is not executed as a block (an `O`
    /// program number), so that a later `%` is not taken as the first line.
    pub fn note_nonblank_line(&mut self) {
        self.nonblank_seen = true;
    }

    /// Checks the end of the input after `last_line` lines. A program run
    /// to the end of its file without M2, M30 or its closing `%`, or up to a
    /// stray `%` line, is LinuxCNC's too, which reports it only then: a
    /// warning says what LinuxCNC reports (for a missing end only when
    /// [`super::InterpOptions::require_program_end`] asks for LinuxCNC's
    /// rule). The one refusal: a move still waiting in the cutter
    /// compensation queue, which LinuxCNC never makes.
    pub fn end_of_input(&mut self, last_line: u64) -> Result<(), GcodeError> {
        if !self.finished && self.comp_pending() {
            return Err(invalid(
                last_line.max(1),
                0,
                "the file ends with cutter radius compensation on and its last move still waiting for the next block (LinuxCNC gives it out only at G40 or the program end)",
                "turn compensation off with G40 and end the program with M2",
            ));
        }
        if self.finished {
            return Ok(());
        }
        if let Some((at, message)) = self.stray_percent {
            self.warnings.push(Warning {
                line: at,
                column: 1,
                message: format!(
                    "a `%` line that does not close a program opened by `%`: LinuxCNC runs every line before it, then stops here with \"{message}\"; volcomp reads the program up to it (remove the line to run the program without that error)"
                ),
            });
            return Ok(());
        }
        if !self.options.require_program_end {
            return Ok(());
        }
        let (reported, help) = if self.uses_percents {
            (
                "File ended with no percent sign",
                "add a `%` line (or M2) at the end of the program",
            )
        } else {
            (
                "File ended with no percent sign or program end",
                "add M2 (or M30) at the end of the program",
            )
        };
        self.warnings.push(Warning {
            line: last_line.max(1),
            column: 1,
            message: format!(
                "the file ends without M2 or M30{}: LinuxCNC runs every line, then reports \"{reported}\"; volcomp reads the program to its last line (if the file was cut short, get it whole again; else {help})",
                if self.uses_percents { " or the `%` line that closes the program" } else { "" }
            ),
        });
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::is_percent_only;

    #[test]
    fn percent_only_lines() {
        assert!(is_percent_only(b"%"));
        assert!(is_percent_only(b"  %\t\r"));
        assert!(!is_percent_only(b"% hello"));
        assert!(!is_percent_only(b"%(end)"));
        assert!(!is_percent_only(b"%%"));
        assert!(!is_percent_only(b"\xEF\xBB\xBF%"));
        assert!(!is_percent_only(b""));
    }
}
