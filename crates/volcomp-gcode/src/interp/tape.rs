//! The start and end of a program, as LinuxCNC reads them
//! (`Interp::open` and `Interp::read`, src/emc/rs274ngc/rs274ngc_pre.cc).
//!
//! A program "uses percents" when its first non-blank line holds only `%`;
//! it then ends at the next `%` line. A `%` line anywhere else is not
//! G-code (LinuxCNC: "Bad character '%' used"). M2 or M30 end any program;
//! a program that reaches the end of its file without either (or without
//! its closing `%`) is refused by LinuxCNC, after it has executed every
//! line: volcomp refuses it too unless the caller says the controller does
//! not need an end ([`super::InterpOptions::require_program_end`]).

use super::{invalid, Interpreter};

/// The help of the refusal of a program without an end (the command line
/// adds its option to it).
pub const PROGRAM_END_HELP: &str = "add M2 (or M30) at the end of the program, or accept a program without one ({allow_no_program_end}) if the controller runs such programs";
use crate::error::GcodeError;

impl Interpreter {
    /// Notes a `%` line (1-based `line`): the first non-blank line starts a
    /// program that uses percents, the next `%` line ends it; any other `%`
    /// line is refused as LinuxCNC refuses it.
    pub fn percent_line(&mut self, line: u64) -> Result<(), GcodeError> {
        if self.finished {
            return Ok(());
        }
        if !self.nonblank_seen {
            self.nonblank_seen = true;
            self.uses_percents = true;
            return Ok(());
        }
        if self.uses_percents {
            self.finished = true;
            return Ok(());
        }
        Err(invalid(
            line,
            0,
            "a `%` line that does not close a program opened by `%`: LinuxCNC refuses it (\"Bad character '%' used\")",
            "remove the `%` line, or put a `%` line first in the file as well",
        ))
    }

    /// Notes a non-blank line that is not executed as a block (an `O`
    /// program number), so that a later `%` is not taken as the first line.
    pub fn note_nonblank_line(&mut self) {
        self.nonblank_seen = true;
    }

    /// Checks the end of the input after `last_line` lines: the program
    /// must have ended (M2, M30, closing `%`) unless the options say
    /// otherwise.
    pub fn end_of_input(&self, last_line: u64) -> Result<(), GcodeError> {
        if !self.finished && self.comp_pending() {
            return Err(invalid(
                last_line.max(1),
                0,
                "the file ends with cutter radius compensation on and its last move still waiting for the next block (LinuxCNC gives it out only at G40 or the program end)",
                "turn compensation off with G40 and end the program with M2",
            ));
        }
        if self.finished || !self.options.require_program_end {
            return Ok(());
        }
        let (message, help) = if self.uses_percents {
            (
                "the file ends without the `%` line that closes a program opened by `%` (and without M2 or M30): LinuxCNC refuses it (\"File ended with no percent sign\")",
                "add a `%` line (or M2) at the end of the program",
            )
        } else {
            (
                "the file ends without M2 or M30: LinuxCNC refuses a program without a program end (\"File ended with no percent sign or program end\")",
                PROGRAM_END_HELP,
            )
        };
        Err(invalid(last_line.max(1), 0, message, help))
    }
}
