//! Byte-based, zero-copy lexer for one block (line) of RS274/NGC G-code.
//!
//! The lexer never copies the line: every token is a byte range into it, so a
//! writer can splice edits into the original bytes and leave everything else
//! (spacing, case, comments, number style, line ending) untouched.
//!
//! Rules follow LinuxCNC's reader: spaces and tabs are insignificant outside
//! comments (so `X 1 0 . 5` is the word `X10.5`), letters are case-insensitive,
//! `( … )` and `; …` are comments, a line holding only `%` is a tape marker and
//! a leading `/` is the block-delete character, `@` and `^` are LinuxCNC's
//! polar words (radius and angle) and a UTF-8 byte-order mark at the start of
//! a line is skipped as a blank. Constructs that volcomp refuses
//! to interpret (`#` parameters, `[ ]` expressions, o-word control flow) are
//! reported as [`LexErrorKind`]s with their column, never skipped silently.

use crate::error::{ErrorClass, GcodeError};
use std::ops::Range;

/// One token of a line; all ranges are byte offsets into that line.
#[derive(Debug, Clone, PartialEq)]
pub enum Token {
    /// A letter (or LinuxCNC's polar `@`, `^`) followed by a number, e.g.
    /// `X-.5`, `g 1` or `@12.5`.
    Word(Word),
    /// A parenthesised comment, range includes both parentheses.
    Comment(Range<usize>),
    /// A `;` comment, range runs to the end of the line content.
    LineComment(Range<usize>),
    /// The block-delete character `/` at the start of a block.
    BlockDelete(usize),
}

/// A word: a letter and its numeric value, with where each part sits.
#[derive(Debug, Clone, PartialEq)]
pub struct Word {
    /// The letter, upper-cased (`b'X'`), or `b'@'` / `b'^'` for polar words.
    pub letter: u8,
    /// The numeric value as written (program units, not converted).
    pub value: f64,
    /// Range of the whole word, from the letter to the last byte of the number.
    pub span: Range<usize>,
    /// Range of the number only (may contain spaces, e.g. `1 0 . 5`).
    pub value_span: Range<usize>,
    /// Digits after the decimal point as written: what
    /// [`crate::number::decimals_of`] counts in the number's text, kept
    /// from the lexing (a rewritten word needs it, and the text is not
    /// read twice).
    pub decimals: u8,
}

/// Why a line could not be lexed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LexErrorKind {
    /// A `(` comment without its `)`.
    UnclosedComment,
    /// A `(` inside a comment: LinuxCNC refuses nested comments.
    NestedComment,
    /// A letter not followed by a number.
    MissingNumber(char),
    /// `#` parameters are not interpreted by volcomp.
    Parameter,
    /// `[ ]` expressions are not interpreted by volcomp.
    Expression,
    /// o-word subroutines and control flow are not interpreted by volcomp.
    OWord,
    /// A byte that has no meaning in G-code.
    UnexpectedByte(u8),
    /// A number too long to be a coordinate.
    NumberTooLong,
}

/// A lexing error at a byte column of the line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LexError {
    /// What went wrong.
    pub kind: LexErrorKind,
    /// Byte offset in the line (0-based).
    pub column: usize,
}

impl LexError {
    /// The [`GcodeError`] this is on 1-based `line` (column made 1-based,
    /// no file or excerpt yet: [`crate::Walker`] adds them): what is wrong
    /// and what to do, [`ErrorClass::Unsupported`] for the constructs
    /// volcomp does not interpret (parameters, expressions, o-words).
    pub fn at_line(&self, line: u64) -> GcodeError {
        let (message, help) = lex_message(&self.kind);
        let class = match self.kind {
            LexErrorKind::Parameter | LexErrorKind::Expression | LexErrorKind::OWord => {
                ErrorClass::Unsupported
            }
            _ => ErrorClass::Invalid,
        };
        GcodeError::new(class, line, self.column + 1, message, help)
    }
}

fn lex_message(kind: &LexErrorKind) -> (String, String) {
    match kind {
        LexErrorKind::UnclosedComment => {
            ("comment is not closed".into(), "add the closing `)`".into())
        }
        LexErrorKind::NestedComment => (
            "nested comment".into(),
            "comments cannot contain `(`".into(),
        ),
        LexErrorKind::MissingNumber(c) => (
            format!("{c} word without a number"),
            "every letter needs a number, e.g. X10".into(),
        ),
        LexErrorKind::Parameter => (
            "`#` parameters are not interpreted by volcomp".into(),
            "post the program with numeric values (no variables)".into(),
        ),
        LexErrorKind::Expression => (
            "`[ ]` expressions are not interpreted by volcomp".into(),
            "post the program with numeric values (no expressions)".into(),
        ),
        LexErrorKind::OWord => (
            "o-word subroutines and control flow are not interpreted by volcomp".into(),
            "post the program with subroutines and loops expanded".into(),
        ),
        LexErrorKind::UnexpectedByte(0) => (
            "NUL byte in the program: this is a binary file, or text in UTF-16".into(),
            "save the program as plain text (ASCII or UTF-8)".into(),
        ),
        LexErrorKind::UnexpectedByte(b) if !b.is_ascii() => (
            format!("byte 0x{b:02X} is not ASCII: outside comments G-code is ASCII (the file may be in another encoding, such as Latin-1 or UTF-16)"),
            "remove the character or put it inside a comment; save the file as ASCII or UTF-8".into(),
        ),
        LexErrorKind::UnexpectedByte(b) if b.is_ascii_control() => (
            format!("control character 0x{b:02X} is not G-code"),
            "remove it; it may be a sign that the file is damaged or binary".into(),
        ),
        LexErrorKind::UnexpectedByte(b) => (
            format!("unexpected character {:?}", char::from(*b)),
            "remove it or put it inside a comment".into(),
        ),
        LexErrorKind::NumberTooLong => ("number too long".into(), "write at most 40 digits".into()),
    }
}

/// What kind of line this is, before its words are interpreted.
#[derive(Debug, Clone, PartialEq)]
pub enum LineKind {
    /// A line with only `%` (and white space): start or end of a tape.
    Percent,
    /// An `O` program number such as `O0001` or `O1001 (NAME)`.
    ProgramNumber,
    /// Anything else: a block of words and comments (possibly empty).
    Block,
}

/// The tokens of one line. Tokens borrow nothing; ranges index the line.
#[derive(Debug, Clone, Default)]
pub struct Lexed {
    /// Tokens in source order.
    pub tokens: Vec<Token>,
    /// A `( … )` comment is among the tokens.
    pub(crate) has_comment: bool,
    /// A comment holds a `#` or `[`: the expression layer reads the line
    /// as a whole (its comments are not literal text to it).
    pub(crate) ngc_in_comment: bool,
    /// The word letters of the line, bit `letter & 31`.
    letters: u32,
}

impl Lexed {
    /// The words of the line in source order.
    pub fn words(&self) -> impl Iterator<Item = &Word> {
        self.tokens.iter().filter_map(|t| match t {
            Token::Word(w) => Some(w),
            _ => None,
        })
    }

    /// Whether the line has a word with `letter` (upper case).
    pub(crate) fn has_letter(&self, letter: u8) -> bool {
        self.letters & (1 << (letter & 31)) != 0
    }

    /// Whether the line has a polar word (`@` radius or `^` angle): the
    /// letters noted as the words were lexed, no walk over the tokens.
    pub fn has_polar(&self) -> bool {
        self.has_letter(b'@') || self.has_letter(b'^')
    }

    /// Whether the block starts with the block-delete character.
    pub fn block_delete(&self) -> bool {
        matches!(self.tokens.first(), Some(Token::BlockDelete(_)))
    }
}

/// Blanks are insignificant outside comments. A stray `\r` (some files end
/// lines with `\r\r\n`) counts as a blank, as it does for LinuxCNC.
fn is_blank(b: u8) -> bool {
    b == b' ' || b == b'\t' || b == b'\r'
}

/// The UTF-8 byte-order mark some editors write at the start of a file.
pub const UTF8_BOM: &[u8] = b"\xEF\xBB\xBF";

/// Length of a UTF-8 byte-order mark at the start of `content` (0 or 3).
fn bom_len(content: &[u8]) -> usize {
    if content.starts_with(UTF8_BOM) {
        UTF8_BOM.len()
    } else {
        0
    }
}

/// Strips a trailing `\n`, `\r\n` or `\r` and returns the content length.
/// One match on the last two bytes: `\r\n` is two, a lone `\n` or `\r`
/// one (as stripping `\n` and then `\r` does; `\r\r\n` keeps one `\r`).
#[inline]
pub fn content_len(line: &[u8]) -> usize {
    let n = line.len();
    match line {
        [.., b'\r', b'\n'] => n - 2,
        [.., b'\n' | b'\r'] => n - 1,
        _ => n,
    }
}

/// Classifies a line (without its line ending).
pub fn classify(content: &[u8]) -> LineKind {
    let mut i = bom_len(content);
    while i < content.len() && is_blank(content[i]) {
        i += 1;
    }
    if i < content.len() && content[i] == b'%' {
        return LineKind::Percent;
    }
    if i < content.len() && (content[i] == b'O' || content[i] == b'o') {
        // `O0001`, `O1001 (NAME)` is a Fanuc program number; `o100 sub` is an o-word.
        let mut j = i + 1;
        while j < content.len() && (content[j].is_ascii_digit() || is_blank(content[j])) {
            j += 1;
        }
        let has_digits = content[i + 1..j].iter().any(|b| b.is_ascii_digit());
        let rest_is_comment = j == content.len() || content[j] == b'(' || content[j] == b';';
        if has_digits && rest_is_comment {
            return LineKind::ProgramNumber;
        }
    }
    LineKind::Block
}

/// Lexes one line's content (without line ending) into `out`, reusing its
/// allocation. The caller should first check [`classify`].
pub fn lex_block(content: &[u8], out: &mut Lexed) -> Result<(), LexError> {
    out.tokens.clear();
    out.has_comment = false;
    out.ngc_in_comment = false;
    out.letters = 0;
    let n = content.len();
    let mut i = bom_len(content);
    while i < n && is_blank(content[i]) {
        i += 1;
    }
    if i < n && content[i] == b'/' {
        out.tokens.push(Token::BlockDelete(i));
        i += 1;
    }
    while i < n {
        let b = content[i];
        // Words first: most of a line is words.
        if b.is_ascii_alphabetic() || b == b'@' || b == b'^' {
            let letter = b.to_ascii_uppercase();
            let start = i;
            i += 1;
            let (value, value_span, decimals) = match lex_plain_number(content, i) {
                // The blanks after the number are skipped here (the loop
                // would skip them one by one).
                Some((value, end, next, decimals)) => {
                    i = next;
                    (value, start + 1..end, decimals)
                }
                None => {
                    let (value, span, decimals) = lex_number(content, i, letter)?;
                    i = span.end.max(i);
                    (value, span, decimals)
                }
            };
            if letter == b'O' {
                return Err(LexError {
                    kind: LexErrorKind::OWord,
                    column: start,
                });
            }
            out.letters |= 1 << (letter & 31);
            out.tokens.push(Token::Word(Word {
                letter,
                value,
                span: start..value_span.end,
                value_span,
                decimals,
            }));
            continue;
        }
        match b {
            _ if is_blank(b) => i += 1,
            b'(' => {
                let start = i;
                let rest = &content[i + 1..];
                let close = memchr::memchr(b')', rest);
                let inside = &rest[..close.unwrap_or(rest.len())];
                if let Some(k) = memchr::memchr(b'(', inside) {
                    return Err(LexError {
                        kind: LexErrorKind::NestedComment,
                        column: i + 1 + k,
                    });
                }
                let Some(close) = close else {
                    return Err(LexError {
                        kind: LexErrorKind::UnclosedComment,
                        column: start,
                    });
                };
                out.ngc_in_comment |= memchr::memchr2(b'#', b'[', inside).is_some();
                i += close + 2;
                out.has_comment = true;
                out.tokens.push(Token::Comment(start..i));
            }
            b';' => {
                out.ngc_in_comment |= memchr::memchr2(b'#', b'[', &content[i..n]).is_some();
                out.tokens.push(Token::LineComment(i..n));
                i = n;
            }
            b'#' => {
                return Err(LexError {
                    kind: LexErrorKind::Parameter,
                    column: i,
                })
            }
            b'[' => {
                return Err(LexError {
                    kind: LexErrorKind::Expression,
                    column: i,
                })
            }
            _ => {
                return Err(LexError {
                    kind: LexErrorKind::UnexpectedByte(b),
                    column: i,
                })
            }
        }
    }
    Ok(())
}

/// Reads a number after a word letter, skipping blanks inside it.
/// The general path of the lexer's numbers (blanks inside, more than 15
/// significant digits); `i` is just after the letter. The number ends at
/// the returned span's end, or, when it is empty, at `i`; its digits after
/// the point come last.
#[cold]
fn lex_number(content: &[u8], i: usize, letter: u8) -> Result<(f64, Range<usize>, u8), LexError> {
    let mut i = i;
    let i = &mut i;
    let n = content.len();
    let mut buf = [0u8; 48];
    let mut len = 0;
    let mut start = None;
    let mut end = *i;
    let mut seen_digit = false;
    let mut seen_dot = false;
    let mut j = *i;
    while j < n {
        let c = content[j];
        let accept = match c {
            _ if is_blank(c) => {
                j += 1;
                continue;
            }
            b'+' | b'-' => len == 0,
            b'.' => !seen_dot,
            b'0'..=b'9' => true,
            _ => false,
        };
        if !accept {
            break;
        }
        if c == b'.' {
            seen_dot = true;
        }
        if c.is_ascii_digit() {
            seen_digit = true;
        }
        if len == buf.len() {
            return Err(LexError {
                kind: LexErrorKind::NumberTooLong,
                column: j,
            });
        }
        buf[len] = c;
        len += 1;
        start.get_or_insert(j);
        j += 1;
        end = j;
    }
    if !seen_digit {
        let column = start.unwrap_or(*i);
        let next = content
            .get(*i..)
            .and_then(|r| r.iter().position(|b| !is_blank(*b)))
            .map(|k| *i + k);
        if let Some(at) =
            next.filter(|&at| !content[at].is_ascii() || content[at].is_ascii_control())
        {
            return Err(LexError {
                kind: LexErrorKind::UnexpectedByte(content[at]),
                column: at,
            });
        }
        let kind = match next.map(|at| &content[at]) {
            Some(b'#') => LexErrorKind::Parameter,
            Some(b'[') => LexErrorKind::Expression,
            Some(b'<') if letter == b'O' => LexErrorKind::OWord,
            _ => LexErrorKind::MissingNumber(letter as char),
        };
        return Err(LexError { kind, column });
    }
    let value = parse_decimal(&buf[..len]).ok_or(LexError {
        kind: LexErrorKind::MissingNumber(letter as char),
        column: *i,
    })?;
    *i = end;
    // The blanks are not in `buf`: the digits after its point.
    let decimals = crate::number::decimals_of(&buf[..len]);
    Ok((value, start.unwrap_or(end)..end, decimals))
}

/// The common case in one pass: a number written without blanks inside
/// (`X-12.5`, `Z.25`, `F1200`) and at most 15 significant digits, starting
/// at `start`: its value, where it ends, where the blanks after it end and
/// its digits after the point. Returns `None` for anything else, which
/// [`lex_number`]'s general path handles.
#[inline]
fn lex_plain_number(content: &[u8], start: usize) -> Option<(f64, usize, usize, u8)> {
    let n = content.len();
    let mut j = start;
    let mut negative = false;
    if j < n {
        match content[j] {
            b'-' => {
                negative = true;
                j += 1;
            }
            b'+' => j += 1,
            _ => {}
        }
    }
    // Leading zeros add nothing to the mantissa, so every digit goes in;
    // the count of significant digits is needed only past 15 digits.
    let mut mantissa = 0u64;
    let int_start = j;
    while j < n {
        let Some(d) = digit(content[j]) else { break };
        mantissa = mantissa.wrapping_mul(10).wrapping_add(d);
        j += 1;
    }
    let int_digits = j - int_start;
    let seen_dot = j < n && content[j] == b'.';
    let mut frac_digits = 0;
    if seen_dot {
        j += 1;
        let frac_start = j;
        while j < n {
            let Some(d) = digit(content[j]) else { break };
            mantissa = mantissa.wrapping_mul(10).wrapping_add(d);
            j += 1;
        }
        frac_digits = j - frac_start;
    }
    if int_digits + frac_digits == 0 {
        return None;
    }
    if int_digits + frac_digits > 15 {
        // Significant digits: the integer part from its first non-zero
        // digit, and every digit after the point.
        let int = &content[int_start..int_start + int_digits];
        let leading_zeros = int.iter().take_while(|c| **c == b'0').count();
        if int_digits - leading_zeros + frac_digits > 15 {
            return None;
        }
    }
    // Blanks followed by more of the number (`X 1 0 . 5`) need the general path.
    let mut k = j;
    while k < n && is_blank(content[k]) {
        k += 1;
    }
    if k > j && k < n && (content[k].is_ascii_digit() || (content[k] == b'.' && !seen_dot)) {
        return None;
    }
    // At most 15 significant digits: the mantissa is below 2^63 and exact
    // as a signed integer, whose conversion is one instruction (an
    // unsigned one takes several on x86-64).
    let value = mantissa as i64 as f64 / crate::number::pow10(frac_digits as u32);
    // At most 15 digits: the count fits in a u8.
    Some((
        if negative { -value } else { value },
        j,
        k,
        frac_digits as u8,
    ))
}

/// The value of an ASCII digit.
#[inline(always)]
fn digit(c: u8) -> Option<u64> {
    let d = c.wrapping_sub(b'0');
    (d < 10).then_some(u64::from(d))
}

/// Parses `[+-]digits[.digits]`, also `10.` and `.5`, to the nearest `f64`.
///
/// Fast path: with at most 15 significant digits the digits form an exact
/// integer `m` and `m / 10^k` (both exact doubles) is one correctly rounded
/// division, i.e. exactly what a full decimal parser returns. Longer numbers
/// go through the standard library's parser.
fn parse_decimal(text: &[u8]) -> Option<f64> {
    let (negative, body) = match text.first() {
        Some(b'-') => (true, &text[1..]),
        Some(b'+') => (false, &text[1..]),
        _ => (false, text),
    };
    let mut mantissa: u64 = 0;
    let mut digits = 0u32;
    let mut frac_digits = 0i32;
    let mut seen_dot = false;
    for &c in body {
        match c {
            b'.' => seen_dot = true,
            b'0'..=b'9' => {
                if mantissa == 0 && c == b'0' && !seen_dot {
                    continue;
                }
                mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(c - b'0'));
                digits += 1;
                if seen_dot {
                    frac_digits += 1;
                }
            }
            _ => return None,
        }
    }
    if !body.iter().any(u8::is_ascii_digit) {
        return None;
    }
    let value = if digits <= 15 && frac_digits <= 22 {
        mantissa as f64 / crate::number::pow10(frac_digits as u32)
    } else {
        std::str::from_utf8(body).ok()?.parse::<f64>().ok()?
    };
    Some(if negative { -value } else { value })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn words(line: &str) -> Vec<(char, f64, String)> {
        let mut out = Lexed::default();
        lex_block(line.as_bytes(), &mut out).unwrap();
        out.words()
            .map(|w| {
                (
                    w.letter as char,
                    w.value,
                    line[w.value_span.clone()].to_string(),
                )
            })
            .collect()
    }

    #[test]
    fn lexes_no_space_programs() {
        let w = words("G1X10Y-5.5z.25");
        assert_eq!(
            w,
            vec![
                ('G', 1.0, "1".into()),
                ('X', 10.0, "10".into()),
                ('Y', -5.5, "-5.5".into()),
                ('Z', 0.25, ".25".into()),
            ]
        );
    }

    #[test]
    fn spaces_inside_words_are_insignificant() {
        let w = words("X 1 0 . 5 G0Z  0.1000");
        assert_eq!(w[0], ('X', 10.5, "1 0 . 5".into()));
        assert_eq!(w[2], ('Z', 0.1, "0.1000".into()));
    }

    #[test]
    fn comments_are_tokens_with_exact_ranges() {
        let line = "N10 G0 (move) X1 ; done";
        let mut out = Lexed::default();
        lex_block(line.as_bytes(), &mut out).unwrap();
        let comments: Vec<&str> = out
            .tokens
            .iter()
            .filter_map(|t| match t {
                Token::Comment(r) | Token::LineComment(r) => Some(&line[r.clone()]),
                _ => None,
            })
            .collect();
        assert_eq!(comments, vec!["(move)", "; done"]);
    }

    #[test]
    fn refuses_parameters_expressions_and_owords() {
        let mut out = Lexed::default();
        let e = lex_block(b"G1 X#1", &mut out).unwrap_err();
        assert_eq!((e.kind, e.column), (LexErrorKind::Parameter, 4));
        let e = lex_block(b"G1 X[1+2]", &mut out).unwrap_err();
        assert_eq!(e.kind, LexErrorKind::Expression);
        let e = lex_block(b"o100 sub", &mut out).unwrap_err();
        assert_eq!(e.kind, LexErrorKind::OWord);
        let e = lex_block(b"o<probe> call", &mut out).unwrap_err();
        assert_eq!(e.kind, LexErrorKind::OWord);
        let e = lex_block(b"#1 = 5", &mut out).unwrap_err();
        assert_eq!((e.kind, e.column), (LexErrorKind::Parameter, 0));
        let e = lex_block(b"G1 X1 (open", &mut out).unwrap_err();
        assert_eq!((e.kind, e.column), (LexErrorKind::UnclosedComment, 6));
    }

    #[test]
    fn classifies_percent_and_program_numbers() {
        assert_eq!(classify(b"%"), LineKind::Percent);
        assert_eq!(classify(b"  % "), LineKind::Percent);
        assert_eq!(classify(b"O0001"), LineKind::ProgramNumber);
        assert_eq!(classify(b"O1001 (PARALLEL)"), LineKind::ProgramNumber);
        assert_eq!(classify(b"o100 sub"), LineKind::Block);
        assert_eq!(classify(b"G1 X1"), LineKind::Block);
    }

    #[test]
    fn fast_decimal_parse_matches_the_standard_parser() {
        for t in [
            "0",
            "10.",
            ".5",
            "-.53",
            "+1.25",
            "123.4567",
            "-0.0001",
            "0.1",
            "0.3",
            "99999.99999",
            "1.2345678901234567",
            "00012.5000",
        ] {
            let expected: f64 = t.trim_start_matches('+').parse().unwrap();
            assert_eq!(parse_decimal(t.as_bytes()), Some(expected), "{t}");
        }
        assert_eq!(parse_decimal(b"."), None);
        assert_eq!(parse_decimal(b"-"), None);
    }

    #[test]
    fn numbers_read_as_the_standard_parser_reads_them() {
        // Both paths of the lexer: plain numbers up to 15 significant
        // digits, and longer ones, leading zeros on either side.
        for t in [
            "0",
            "007.5",
            "-0.0001",
            "+3",
            "10.",
            "123456789012345",
            "1234567890123456",
            "0000000000000000000001.25",
            "0.000000000000001",
            "0.0000000000000001",
            "99999.9999999999",
            "-99999.99999999999",
            "12345678901234567890123",
            "0.1",
            "-.53",
        ] {
            let expected: f64 = t.trim_start_matches('+').parse().unwrap();
            let w = words(&format!("X{t} Y1"));
            assert_eq!(w[0], ('X', expected, t.to_string()), "{t}");
            assert_eq!(w[1].1, 1.0, "{t}");
        }
    }

    /// The digits after the point, counted by hand: blanks inside the
    /// number (the general path) and a point without digits count nothing.
    #[test]
    fn a_word_keeps_the_digits_after_its_point() {
        let mut out = Lexed::default();
        lex_block(
            b"X1. Y-.25 Z 1 0 . 2 5 0 F1200 I0.000100 J12345678901234567.5",
            &mut out,
        )
        .unwrap();
        let got: Vec<(u8, u8)> = out.words().map(|w| (w.letter, w.decimals)).collect();
        let want = [
            (b'X', 0),
            (b'Y', 2),
            (b'Z', 3),
            (b'F', 0),
            (b'I', 6),
            (b'J', 1),
        ];
        assert_eq!(got, want);
    }

    #[test]
    fn digit_runs_of_every_length_read_as_the_standard_parser_reads_them() {
        // Runs of 0 to 17 digits before and after the point (the plain path
        // up to 15 significant digits, the general one past them), every
        // digit in every place, followed by the bytes just below and above
        // '0'..='9', which end a run.
        let digits = b"9081726354";
        for int_len in 0..=17usize {
            for frac_len in 0..=17usize {
                if int_len + frac_len == 0 {
                    continue;
                }
                for shift in 0..digits.len() {
                    let run = |len: usize| -> String {
                        (0..len)
                            .map(|k| char::from(digits[(k + shift) % digits.len()]))
                            .collect()
                    };
                    let t = format!("{}.{}", run(int_len), run(frac_len));
                    let expected: f64 = t.parse().unwrap();
                    for after in ["", "/", ":", " Y1", "X1"] {
                        let mut out = Lexed::default();
                        let line = format!("X{t}{after}");
                        match lex_block(line.as_bytes(), &mut out) {
                            Ok(()) => {
                                let Token::Word(w) = &out.tokens[0] else {
                                    panic!("{line}: no word")
                                };
                                assert_eq!(w.value.to_bits(), expected.to_bits(), "{line}");
                                assert_eq!(w.value_span, 1..1 + t.len(), "{line}");
                                assert_eq!(usize::from(w.decimals), frac_len, "{line}");
                            }
                            Err(e) => assert!(
                                matches!(e.kind, LexErrorKind::UnexpectedByte(b'/' | b':')),
                                "{line}: {e:?}"
                            ),
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn comment_errors_name_the_first_offending_parenthesis() {
        let mut out = Lexed::default();
        let e = lex_block(b"G1 (a (b) c)", &mut out).unwrap_err();
        assert_eq!((e.kind, e.column), (LexErrorKind::NestedComment, 6));
        let e = lex_block(b"G1 (a) (b", &mut out).unwrap_err();
        assert_eq!((e.kind, e.column), (LexErrorKind::UnclosedComment, 7));
        let e = lex_block(b"G1 (a (b", &mut out).unwrap_err();
        assert_eq!((e.kind, e.column), (LexErrorKind::NestedComment, 6));
        lex_block(b"G1 (#1 [x]) X1", &mut out).unwrap();
        assert!(out.has_comment && out.ngc_in_comment);
        lex_block(b"G1 (note) X1 ; #2", &mut out).unwrap();
        assert!(out.has_comment && out.ngc_in_comment);
        lex_block(b"G1 (note) X1 ; end", &mut out).unwrap();
        assert!(out.has_comment && !out.ngc_in_comment);
    }

    #[test]
    fn polar_words_and_a_leading_bom_are_read() {
        let w = words("\u{feff}G1 @12.5 ^-30");
        assert_eq!(w[1], ('@', 12.5, "12.5".into()));
        assert_eq!(w[2], ('^', -30.0, "-30".into()));
        assert_eq!(classify("\u{feff}%".as_bytes()), LineKind::Percent);
    }

    #[test]
    fn scientific_notation_lexes_as_an_e_word_like_linuxcnc() {
        // LinuxCNC's reader does the same; the interpreter then refuses the E word.
        let w = words("G1 X1e-05");
        assert_eq!(w[1], ('X', 1.0, "1".into()));
        assert_eq!(w[2], ('E', -5.0, "-05".into()));
    }

    #[test]
    fn non_ascii_bytes_outside_comments_are_located() {
        let mut out = Lexed::default();
        let e = lex_block(b"G1 X1 (caf\xe9) Y\xe92", &mut out).unwrap_err();
        assert_eq!((e.kind, e.column), (LexErrorKind::UnexpectedByte(0xe9), 14));
        let e = lex_block(b"G1 \xe9X1", &mut out).unwrap_err();
        assert_eq!((e.kind, e.column), (LexErrorKind::UnexpectedByte(0xe9), 3));
    }

    #[test]
    fn a_line_the_lexer_reads_is_a_block() {
        // The walker lexes a line first and classifies it only when the
        // lexer stops: every line the lexer reads must be a block. All
        // lines of up to five symbols that matter to either (a `%`, an O
        // word, blanks, a byte-order mark, comments, block delete).
        let symbols: [&[u8]; 15] = [
            b"%", b"O", b"o", b"/", b" ", b"\t", b"0", b"1", b".", b"(", b")", b";", b"G", b"-",
            UTF8_BOM,
        ];
        let mut lexed = Lexed::default();
        let mut line = Vec::new();
        let mut counts = vec![0usize];
        while counts.len() <= 5 {
            line.clear();
            for &k in &counts {
                line.extend_from_slice(symbols[k]);
            }
            if lex_block(&line, &mut lexed).is_ok() {
                assert_eq!(
                    classify(&line),
                    LineKind::Block,
                    "{:?}",
                    String::from_utf8_lossy(&line)
                );
            }
            // The next combination (an odometer over the symbols).
            let mut at = 0;
            loop {
                if at == counts.len() {
                    counts.push(0);
                    break;
                }
                counts[at] += 1;
                if counts[at] < symbols.len() {
                    break;
                }
                counts[at] = 0;
                at += 1;
            }
        }
    }

    #[test]
    fn content_len_strips_any_line_ending() {
        assert_eq!(content_len(b"G1\r\n"), 2);
        assert_eq!(content_len(b"G1\n"), 2);
        assert_eq!(content_len(b"G1"), 2);
        // By hand: a lone CR ends a line; of CR CR LF one CR stays (a
        // stray CR is a blank to the lexer); LF CR is CR's alone.
        assert_eq!(content_len(b"G1\r"), 2);
        assert_eq!(content_len(b"G1\r\r\n"), 3);
        assert_eq!(content_len(b"G1\n\r"), 3);
        assert_eq!(content_len(b""), 0);
        assert_eq!(content_len(b"\n"), 0);
        assert_eq!(content_len(b"\r\n"), 0);
        // Second method: strip LF, then CR, on every line of up to five
        // bytes from `x`, CR and LF.
        let strip = |l: &[u8]| {
            let l = l.strip_suffix(b"\n").unwrap_or(l);
            l.strip_suffix(b"\r").unwrap_or(l).len()
        };
        let alphabet = [b'x', b'\r', b'\n'];
        for len in 0..=5u32 {
            for k in 0..3usize.pow(len) {
                let line: Vec<u8> = (0..len).map(|d| alphabet[k / 3usize.pow(d) % 3]).collect();
                assert_eq!(content_len(&line), strip(&line), "{line:?}");
            }
        }
    }
}
