//! One line that is not plain literal G-code: its words with expression
//! values, its parameter settings, or its o-word statement (LinuxCNC's
//! `read_items`, `read_parameter_setting`, `read_o`, interp_read.cc), and
//! its rendering as a literal line.

use super::expr::{eval, to_integer, Expr, ExprError, Lookup, Param, Parser};
use super::norm::Norm;
use std::ops::Range;

/// A word whose value is an expression (`X[#1+2]`, `Z#<safe>`).
#[derive(Debug, Clone)]
pub struct ExprWord {
    /// The letter, lower case.
    pub letter: u8,
    /// Its value.
    pub value: Expr,
    /// Original bytes of the value (after the letter).
    pub span: Range<usize>,
    /// Original column of the letter.
    pub col: usize,
}

/// `#… = value`.
#[derive(Debug, Clone)]
pub struct Setting {
    /// The parameter set.
    pub target: Param,
    /// The value.
    pub value: Expr,
    /// Original bytes of the whole setting.
    pub span: Range<usize>,
    /// Original column of the `#`.
    pub col: usize,
}

/// The keyword of an o-word line.
#[derive(Debug, Clone, PartialEq)]
pub enum OKind {
    /// `sub`
    Sub,
    /// `endsub [value]`
    Endsub(Option<Expr>),
    /// `return [value]`
    Return(Option<Expr>),
    /// `call [a] [b] …`
    Call(Vec<Expr>),
    /// `do`
    Do,
    /// `while [cond]`
    While(Expr),
    /// `endwhile`
    Endwhile,
    /// `repeat [n]`
    Repeat(Expr),
    /// `endrepeat`
    Endrepeat,
    /// `if [cond]`
    If(Expr),
    /// `elseif [cond]`
    Elseif(Expr),
    /// `else`
    Else,
    /// `endif`
    Endif,
    /// `break`
    Break,
    /// `continue`
    Continue,
    /// A bare `O<name>` or `O<n>` line: the start of a Fanuc-style program,
    /// which runs on.
    Program,
}

impl OKind {
    /// The keyword as written in programs.
    pub fn keyword(&self) -> &'static str {
        match self {
            OKind::Sub => "sub",
            OKind::Endsub(_) => "endsub",
            OKind::Return(_) => "return",
            OKind::Call(_) => "call",
            OKind::Do => "do",
            OKind::While(_) => "while",
            OKind::Endwhile => "endwhile",
            OKind::Repeat(_) => "repeat",
            OKind::Endrepeat => "endrepeat",
            OKind::If(_) => "if",
            OKind::Elseif(_) => "elseif",
            OKind::Else => "else",
            OKind::Endif => "endif",
            OKind::Break => "break",
            OKind::Continue => "continue",
            OKind::Program => "",
        }
    }
}

/// An o-word line.
#[derive(Debug, Clone)]
pub struct OWord {
    /// The label: a number (as its decimal integer) or a `<name>` (lower case).
    pub label: String,
    /// A number label given as an expression (`o[#2 * 10]`, `o#1`), which
    /// LinuxCNC evaluates when it reads the line: the flow
    /// evaluates it and sets `label`.
    pub label_expr: Option<(Expr, usize)>,
    /// The statement.
    pub kind: OKind,
    /// Original column of the `o`.
    pub col: usize,
}

/// What a non-literal line holds.
#[derive(Debug, Clone)]
pub enum Statement {
    /// Words (some with expressions) and parameter settings.
    Block {
        /// Words whose values are expressions, in order.
        words: Vec<ExprWord>,
        /// Parameter settings, in order.
        settings: Vec<Setting>,
    },
    /// An o-word statement.
    OWord(OWord),
}

fn skip_comments(p: &mut Parser, n: &Norm) {
    loop {
        match n.byte(p.pos) {
            b'(' => {
                while p.pos < n.text.len() && n.byte(p.pos) != b')' {
                    p.pos += 1;
                }
                p.pos += 1;
            }
            b';' => p.pos = n.text.len(),
            _ => return,
        }
    }
}

/// Whether `content` may need the expression layer: a `#` or `[`, or an
/// o-word statement (a cheap test; [`parse`] decides).
pub fn needs_ngc(content: &[u8]) -> bool {
    if content.iter().any(|&b| b == b'#' || b == b'[') {
        return true;
    }
    let mut i = 0;
    while i < content.len() && matches!(content[i], b' ' | b'\t' | b'/') {
        i += 1;
    }
    i < content.len()
        && matches!(content[i], b'o' | b'O')
        && content[i + 1..]
            .iter()
            .find(|b| !matches!(b, b' ' | b'\t'))
            .is_some_and(|b| *b == b'<' || b.is_ascii_digit() || *b == b'#' || *b == b'[')
        && !is_program_number(&content[i + 1..])
}

/// Whether normalised `text` is a number the lexer reads: an optional
/// sign, then digits and at most one point.
fn is_plain_number(text: &[u8]) -> bool {
    let digits = match text.first() {
        Some(b'+' | b'-') => &text[1..],
        _ => text,
    };
    !digits.is_empty()
        && digits.iter().all(|b| b.is_ascii_digit() || *b == b'.')
        && digits.iter().filter(|b| **b == b'.').count() <= 1
}

/// `O0001` or `O1001 (NAME)`: a Fanuc program number, not an o-word statement.
fn is_program_number(rest: &[u8]) -> bool {
    let mut j = 0;
    let mut digits = false;
    while j < rest.len() && (rest[j].is_ascii_digit() || matches!(rest[j], b' ' | b'\t')) {
        digits |= rest[j].is_ascii_digit();
        j += 1;
    }
    digits && (j == rest.len() || rest[j] == b'(' || rest[j] == b';' || rest[j] == b'\r')
}

fn expect_bracket(p: &mut Parser, what: &str) -> Result<Expr, ExprError> {
    p.bracketed().map_err(|mut e| {
        if e.message == "`[` expected here" {
            e.message = format!("`{what}` needs a condition or value in brackets");
            e.help = format!("write e.g. `o100 {what} [#1 LT 10]`");
        }
        e
    })
}

/// Parses a normalised line.
pub fn parse(n: &Norm) -> Result<Statement, ExprError> {
    let mut p = Parser::new(n, 0);
    if n.byte(0) == b'/' {
        p.pos = 1;
    }
    if n.byte(p.pos) == b'o' {
        return parse_oword(n, p).map(Statement::OWord);
    }
    let mut words = Vec::new();
    let mut settings = Vec::new();
    while p.pos < n.text.len() {
        let c = n.byte(p.pos);
        match c {
            b'(' | b';' => skip_comments(&mut p, n),
            b'#' => {
                let start = p.pos;
                let (target, col) = p.param_ref()?;
                if n.byte(p.pos) != b'=' {
                    return Err(ExprError::new(
                        p.col(),
                        "`=` is missing in this parameter setting",
                        "write #1 = value (a parameter can only be read as a word's value)",
                    ));
                }
                p.pos += 1;
                let value = p.value()?;
                settings.push(Setting {
                    target,
                    value,
                    span: n.span(start, p.pos),
                    col,
                });
            }
            b'a'..=b'z' | b'@' | b'^' => {
                let col = n.col(p.pos);
                p.pos += 1;
                let vstart = p.pos;
                let value = p.value()?;
                // A plain number (`X10`, `Y-.5`) stays as written; anything
                // else is rendered, including `X[1]`, `X[-1]` and `X+-1`,
                // which parse to a number too but are not literal G-code.
                if !is_plain_number(&n.text[vstart..p.pos.min(n.text.len())]) {
                    words.push(ExprWord {
                        letter: c,
                        value,
                        span: n.span(vstart, p.pos),
                        col,
                    });
                }
            }
            _ => {
                return Err(ExprError::new(
                    p.col(),
                    format!("unexpected character {:?}", char::from(c)),
                    "remove it or put it inside a comment",
                ))
            }
        }
    }
    Ok(Statement::Block { words, settings })
}

fn parse_oword(n: &Norm, mut p: Parser) -> Result<OWord, ExprError> {
    let col = p.col();
    p.pos += 1;
    let mut label_expr = None;
    let label = if n.byte(p.pos) == b'<' {
        p.name()?
    } else {
        let lcol = p.col();
        match p.value()? {
            Expr::Num(v) => to_integer(v, lcol)?.to_string(),
            // `read_o` reads the number with `read_integer_value`, which
            // takes any value: evaluated when the line runs.
            e => {
                label_expr = Some((e, lcol));
                String::new()
            }
        }
    };
    let rest = &n.text[p.pos.min(n.text.len())..];
    let keywords: [&str; 15] = [
        "sub",
        "endsub",
        "call",
        "do",
        "while",
        "repeat",
        "if",
        "elseif",
        "else",
        "endif",
        "break",
        "continue",
        "endwhile",
        "endrepeat",
        "return",
    ];
    let Some(kw) = keywords.iter().find(|k| rest.starts_with(k.as_bytes())) else {
        // A bare o-word (only comments after it) starts a Fanuc-style
        // program (`read_o`: O_).
        let at = p.pos;
        skip_comments(&mut p, n);
        if p.pos >= n.text.len() {
            return Ok(OWord {
                label,
                label_expr,
                kind: OKind::Program,
                col,
            });
        }
        p.pos = at;
        return Err(ExprError::new(
            p.col(),
            "unknown o-word statement",
            "o-words are sub, endsub, return, call, if, elseif, else, endif, while, endwhile, do, repeat, endrepeat, break, continue",
        ));
    };
    p.pos += kw.len();
    let optional = |p: &mut Parser| -> Result<Option<Expr>, ExprError> {
        if n.byte(p.pos) == b'[' {
            Ok(Some(p.bracketed()?))
        } else {
            Ok(None)
        }
    };
    let kind = match *kw {
        "sub" => OKind::Sub,
        "endsub" => OKind::Endsub(optional(&mut p)?),
        "return" => OKind::Return(optional(&mut p)?),
        "call" => {
            let mut args = Vec::new();
            loop {
                skip_comments(&mut p, n);
                if n.byte(p.pos) != b'[' {
                    break;
                }
                if args.len() >= 30 {
                    return Err(ExprError::new(
                        p.col(),
                        "more than 30 arguments in a call",
                        "a subroutine takes at most 30 arguments (#1 to #30)",
                    ));
                }
                args.push(p.bracketed()?);
            }
            OKind::Call(args)
        }
        "do" => OKind::Do,
        "while" => OKind::While(expect_bracket(&mut p, "while")?),
        "repeat" => OKind::Repeat(expect_bracket(&mut p, "repeat")?),
        "if" => OKind::If(expect_bracket(&mut p, "if")?),
        "elseif" => OKind::Elseif(expect_bracket(&mut p, "elseif")?),
        "else" => OKind::Else,
        "endif" => OKind::Endif,
        "break" => OKind::Break,
        "continue" => OKind::Continue,
        "endwhile" => OKind::Endwhile,
        _ => OKind::Endrepeat,
    };
    skip_comments(&mut p, n);
    if p.pos < n.text.len() {
        return Err(ExprError::new(
            p.col(),
            format!("unexpected text after `{kw}`"),
            "an o-word line holds only its statement (and comments)",
        ));
    }
    Ok(OWord {
        label,
        label_expr,
        kind,
        col,
    })
}

/// Formats a value so that the lexer reads back the same number: the
/// shortest representation that round-trips, never with an exponent.
pub fn format_value(v: f64, out: &mut Vec<u8>) {
    let v = if v == 0.0 { 0.0 } else { v };
    if shortest_positional(v, out) {
        return;
    }
    let mut text = ShortText::default();
    if std::fmt::Write::write_fmt(&mut text, format_args!("{v}")).is_ok() {
        out.extend_from_slice(&text.bytes[..text.len]);
    } else {
        // Only for magnitudes below 1e-20 or above 1e39, far outside any
        // machine: 15 decimals keep every position to 1e-15 mm.
        let t = format!("{v:.15}");
        let t = t.trim_end_matches('0').trim_end_matches('.');
        out.extend_from_slice(t.as_bytes());
    }
}

/// Most characters [`format_value`] writes positionally (what its stack
/// buffer holds); longer values take the 15-decimal path.
const SHORT_TEXT_BYTES: usize = 40;

/// `v` as `{v}` writes it (the shortest digits that read back the same,
/// laid out without an exponent) when that fits [`SHORT_TEXT_BYTES`]:
/// the digits from `ryu` (the same shortest, closest digits as the
/// standard library's Grisu/Dragon, several times faster), placed here.
/// `false`, having written nothing, for non-finite or longer values and
/// where the two could differ: when two shortest candidates are equally
/// close, `ryu` takes the even one and `{}` the larger.
fn shortest_positional(v: f64, out: &mut Vec<u8>) -> bool {
    if !v.is_finite() || may_tie(v) {
        return false;
    }
    let mut buf = ryu::Buffer::new();
    let text = buf.format_finite(v).as_bytes();
    let (negative, text) = match text.split_first() {
        Some((b'-', rest)) => (true, rest),
        _ => (false, text),
    };
    // `d.ddde±x`, `ddd.ddd` or `0.000ddd`: at most 17 significant digits
    // and 5 leading zeros.
    let mut digits = [0u8; 32];
    let mut n = 0;
    let mut point = None;
    let mut exponent: i32 = 0;
    for (i, &b) in text.iter().enumerate() {
        match b {
            b'0'..=b'9' if n < digits.len() => {
                digits[n] = b;
                n += 1;
            }
            b'.' => point = Some(n),
            b'e' => {
                let Some(e) = std::str::from_utf8(&text[i + 1..])
                    .ok()
                    .and_then(|t| t.parse().ok())
                else {
                    return false;
                };
                exponent = e;
                break;
            }
            _ => return false,
        }
    }
    // The decimal point stands `at` digits after the first digit.
    let mut at = point.unwrap_or(n) as i32 + exponent;
    let mut first = 0;
    while first < n && digits[first] == b'0' {
        first += 1;
        at -= 1;
    }
    let mut last = n;
    while last > first && digits[last - 1] == b'0' {
        last -= 1;
    }
    if first == last {
        out.push(b'0');
        return true;
    }
    let d = &digits[first..last];
    let count = d.len() as i32;
    let len = i32::from(negative)
        + if at <= 0 {
            2 - at + count
        } else if at >= count {
            at
        } else {
            count + 1
        };
    if len > SHORT_TEXT_BYTES as i32 {
        return false;
    }
    if negative {
        out.push(b'-');
    }
    if at <= 0 {
        out.extend_from_slice(b"0.");
        out.resize(out.len() + (-at) as usize, b'0');
        out.extend_from_slice(d);
    } else if at >= count {
        out.extend_from_slice(d);
        out.resize(out.len() + (at - count) as usize, b'0');
    } else {
        out.extend_from_slice(&d[..at as usize]);
        out.push(b'.');
        out.extend_from_slice(&d[at as usize..]);
    }
    true
}

/// Whether two shortest decimal candidates of `v` can be equally close:
/// only when `v`'s exact decimal expansion ends in a 5 one digit after
/// the shortest (at most 17 significant digits), so when that expansion
/// has at most 18 significant digits. `v = m·2^e` (m odd): for `e < 0` it
/// has the significant digits of `m·5^−e`; integers below 2^53 need all
/// their digits (no shorter candidate), larger ones are left to `{}`.
fn may_tie(v: f64) -> bool {
    let bits = v.to_bits();
    let biased = ((bits >> 52) & 0x7ff) as i32;
    let fraction = bits & ((1u64 << 52) - 1);
    let (mut m, mut e) = if biased == 0 {
        (fraction, -1074)
    } else {
        (fraction | (1u64 << 52), biased - 1075)
    };
    if m == 0 {
        return true;
    }
    let zeros = m.trailing_zeros();
    m >>= zeros;
    e += zeros as i32;
    if e >= 0 {
        return v.abs() >= 9_007_199_254_740_992.0;
    }
    let k = e.unsigned_abs();
    // 5^27 > 10^18: more than 18 digits whatever `m`.
    k <= 26 && u128::from(m) * 5u128.pow(k) < 10u128.pow(18)
}

/// Up to 40 bytes of text on the stack; writing more fails.
struct ShortText {
    bytes: [u8; SHORT_TEXT_BYTES],
    len: usize,
}

impl Default for ShortText {
    fn default() -> Self {
        Self {
            bytes: [0; SHORT_TEXT_BYTES],
            len: 0,
        }
    }
}

impl std::fmt::Write for ShortText {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        let end = self.len + s.len();
        if end > self.bytes.len() {
            return Err(std::fmt::Error);
        }
        self.bytes[self.len..end].copy_from_slice(s.as_bytes());
        self.len = end;
        Ok(())
    }
}

/// Formats `v` with at most `decimals` decimals (rounded, trailing zeros
/// cut, no `-0`): a computed value written like the program's numbers
/// (`InterpOptions::computed_decimals`). Written on the stack (no
/// allocation) unless the text is longer than 40 bytes.
pub fn format_value_decimals(v: f64, decimals: u8, out: &mut Vec<u8>) {
    let mut text = ShortText::default();
    let long;
    let s: &[u8] =
        if std::fmt::Write::write_fmt(&mut text, format_args!("{v:.*}", usize::from(decimals)))
            .is_ok()
        {
            &text.bytes[..text.len]
        } else {
            long = format!("{v:.*}", usize::from(decimals));
            long.as_bytes()
        };
    let t = if s.contains(&b'.') {
        let end = s.iter().rposition(|&b| b != b'0').map_or(0, |i| i + 1);
        let t = &s[..end];
        t.strip_suffix(b".").unwrap_or(t)
    } else {
        s
    };
    let t: &[u8] = if t == b"-0" { b"0" } else { t };
    out.extend_from_slice(t);
}

/// Evaluates the words of a block statement and writes the literal line:
/// the original bytes with every expression value replaced by its number
/// (with at most `decimals` decimals when given, else the shortest number
/// that reads back the same) and every parameter setting removed. Returns
/// the values of the settings (to apply after the line, as LinuxCNC does).
pub fn render(
    content: &[u8],
    words: &[ExprWord],
    settings: &[Setting],
    lk: &dyn Lookup,
    decimals: Option<u8>,
    out: &mut Vec<u8>,
) -> Result<Vec<f64>, ExprError> {
    let mut edits: Vec<(Range<usize>, Option<f64>)> =
        Vec::with_capacity(words.len() + settings.len());
    for w in words {
        let lk = Declared::new(lk, settings, w.col);
        edits.push((w.span.clone(), Some(eval(&w.value, &lk)?)));
    }
    let mut values = Vec::with_capacity(settings.len());
    for s in settings {
        // The setting's own name is declared before its value is read.
        let lk = Declared::new(lk, settings, s.col + 1);
        values.push(eval(&s.value, &lk)?);
        edits.push((s.span.clone(), None));
    }
    edits.sort_by_key(|e| e.0.start);
    let mut at = 0;
    for (span, value) in edits {
        out.extend_from_slice(&content[at..span.start]);
        match (value, decimals) {
            (Some(v), Some(d)) => format_value_decimals(v, d, out),
            (Some(v), None) => format_value(v, out),
            (None, _) => {}
        }
        at = span.end;
    }
    out.extend_from_slice(&content[at..]);
    Ok(values)
}

/// LinuxCNC declares a named parameter when it reads the name of a setting
/// (`read_named_parameter_setting` calls `add_named_param`, value 0, before
/// the line's settings are applied): a read further along the same line of
/// a name that did not exist before finds it, with the value 0, and
/// `EXISTS` gives 1. `#<n> = [#<n> + 1]` on a first use sets 1.
struct Declared<'a> {
    inner: &'a dyn Lookup,
    settings: &'a [Setting],
    /// Settings whose `#` stands before this column are read already.
    before: usize,
}

impl<'a> Declared<'a> {
    fn new(inner: &'a dyn Lookup, settings: &'a [Setting], before: usize) -> Self {
        Self {
            inner,
            settings,
            before,
        }
    }

    fn declared(&self, name: &str) -> bool {
        self.settings
            .iter()
            .any(|s| s.col < self.before && matches!(&s.target, Param::Named(n) if n == name))
    }
}

impl Lookup for Declared<'_> {
    fn numbered(&self, n: usize, col: usize) -> Result<f64, ExprError> {
        self.inner.numbered(n, col)
    }

    fn named(&self, name: &str, col: usize) -> Result<f64, ExprError> {
        // One lookup: a name that reads is one that exists.
        match self.inner.named(name, col) {
            Err(_) if self.declared(name) => Ok(0.0),
            r => r,
        }
    }

    fn exists(&self, name: &str) -> bool {
        self.inner.exists(name) || self.declared(name)
    }
}
