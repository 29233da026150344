//! What LinuxCNC's reader refuses in a line that volcomp's lexer reads:
//! the bytes it sees differently (`Interp::read_text`, interp_read.cc,
//! reads a line with `fgets` and handles it as a C string;
//! `close_and_downcase`, interp_internal.cc; `read_one_item`,
//! interp_read.cc).
//!
//! * A NUL byte ends the C string: the rest of the line is not read. Inside
//!   a `( )` comment that leaves the comment open ("Unclosed comment
//!   found"). (A NUL outside comments the lexer already refuses as binary;
//!   inside a `;` comment it cuts only the comment, as in LinuxCNC.)
//! * A UTF-8 byte-order mark is three bytes of the line, the first of which
//!   is no G-code character ("Bad character '\357' used").

use super::invalid;
use crate::error::GcodeError;
use crate::lexer::{Lexed, Token, UTF8_BOM};

/// Checks the line `content` (without its line ending, 1-based `line`)
/// that the lexer read into `lexed` for what LinuxCNC's reader refuses.
pub fn check_line(line: u64, content: &[u8], lexed: &Lexed) -> Result<(), GcodeError> {
    if content.starts_with(UTF8_BOM) {
        return Err(invalid(
            line,
            0,
            "the line starts with a UTF-8 byte-order mark, which LinuxCNC reads as a character of the line and refuses (\"Bad character '\\357' used\")",
            "save the program without a byte-order mark (as ASCII, or UTF-8 without BOM)",
        ));
    }
    for t in &lexed.tokens {
        if let Token::Comment(r) = t {
            if let Some(k) = content[r.clone()].iter().position(|&b| b == 0) {
                return Err(invalid(
                    line,
                    r.start + k,
                    "NUL byte in a comment: LinuxCNC reads the line only up to it, so the comment is not closed (\"Unclosed comment found\")",
                    "remove the NUL byte; the file may be damaged",
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::check_line;
    use crate::lexer::{lex_block, Lexed};

    fn check(content: &[u8]) -> Result<(), String> {
        let mut lexed = Lexed::default();
        lex_block(content, &mut lexed).map_err(|e| format!("lex: {e:?}"))?;
        check_line(1, content, &lexed).map_err(|e| e.to_string())
    }

    #[test]
    fn nul_in_a_comment_is_refused_as_linuxcnc_reads_it() {
        let e = check(b"G0 X1 (a\0b)").unwrap_err();
        assert!(e.contains("Unclosed comment found"), "{e}");
        assert!(e.contains(":1:9:"), "column of the NUL: {e}");
        // In a `;` comment the NUL cuts only the comment.
        check(b"G0 X1 ;a\0b").unwrap();
        check(b"G0 X1 (ab)").unwrap();
    }

    #[test]
    fn byte_order_mark_is_refused() {
        let e = check(b"\xEF\xBB\xBFG0 X1").unwrap_err();
        assert!(e.contains("Bad character '\\357' used"), "{e}");
    }
}
