//! Expressions of RS274/NGC as LinuxCNC reads and evaluates them
//! (src/emc/rs274ngc/interp_read.cc: `read_real_value`,
//! `read_real_expression`, `read_operation`, `read_unary`, `read_atan`,
//! `read_parameter`; interp_execute.cc: `execute_binary1/2`,
//! `execute_unary`; interp_internal.cc: `precedence`).
//!
//! Parsing works on a [`Norm`]alised line (lower case, blanks removed
//! outside comments), as LinuxCNC's reader does; every node keeps the byte
//! column of the original line for errors.
//!
//! Semantics kept exactly: operators of equal precedence associate to the
//! left (`2**3**2` is 64), precedence `**` > `* / MOD` > `+ -` >
//! `EQ NE GT GE LT LE` > `AND OR XOR`; comparisons and logic give 1 or 0
//! (EQ/NE within 0.0001, as the Debian LinuxCNC 2.9.0~pre1 `rs274` does); `MOD` is never negative; trigonometry in
//! degrees; `ROUND` rounds half away from zero; `FIX`/`FUP` are floor/ceil.

use super::norm::Norm;

/// A binary operator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Op {
    /// `**`
    Power,
    /// `*`
    Times,
    /// `/`
    Divide,
    /// `MOD`
    Mod,
    /// `+`
    Plus,
    /// `-`
    Minus,
    /// `EQ`
    Eq,
    /// `NE`
    Ne,
    /// `GT`
    Gt,
    /// `GE`
    Ge,
    /// `LT`
    Lt,
    /// `LE`
    Le,
    /// `AND`
    And,
    /// `OR`
    Or,
    /// `XOR`
    Xor,
}

impl Op {
    fn precedence(self) -> u8 {
        match self {
            Op::And | Op::Or | Op::Xor => 2,
            Op::Eq | Op::Ne | Op::Gt | Op::Ge | Op::Lt | Op::Le => 3,
            Op::Plus | Op::Minus => 4,
            Op::Times | Op::Divide | Op::Mod => 5,
            Op::Power => 6,
        }
    }
}

/// A unary function.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Func {
    /// `ABS`
    Abs,
    /// `ACOS` (degrees)
    Acos,
    /// `ASIN` (degrees)
    Asin,
    /// `COS` (degrees)
    Cos,
    /// `EXP`
    Exp,
    /// `FIX` (floor)
    Fix,
    /// `FUP` (ceiling)
    Fup,
    /// `LN`
    Ln,
    /// `ROUND` (half away from zero)
    Round,
    /// `SIN` (degrees)
    Sin,
    /// `SQRT`
    Sqrt,
    /// `TAN` (degrees)
    Tan,
}

/// A parameter reference.
#[derive(Debug, Clone, PartialEq)]
pub enum Param {
    /// `#n`, `#[expr]`, `##n`: the number is itself an expression.
    Numbered(Box<Expr>),
    /// `#<name>`: lower case, without blanks (global when it starts with `_`).
    Named(String),
}

/// An expression; `col` fields are 0-based byte columns of the original line.
#[derive(Debug, Clone, PartialEq)]
pub enum Expr {
    /// A number.
    Num(f64),
    /// A parameter's value.
    Param {
        /// Which parameter.
        param: Param,
        /// Where the `#` is.
        col: usize,
    },
    /// `-value`.
    Neg(Box<Expr>),
    /// A function of one argument.
    Unary {
        /// The function.
        func: Func,
        /// Its argument.
        arg: Box<Expr>,
        /// Where the function name is.
        col: usize,
    },
    /// `ATAN[y]/[x]` in degrees.
    Atan(Box<Expr>, Box<Expr>),
    /// `EXISTS[#<name>]`: 1 if the named parameter exists.
    Exists(String),
    /// `EXISTS[#n]`: 1 if `n` is a parameter number (1–5601).
    ExistsNumbered(Box<Expr>, usize),
    /// `a op b`.
    Binary {
        /// The operator.
        op: Op,
        /// Left operand.
        a: Box<Expr>,
        /// Right operand.
        b: Box<Expr>,
        /// Where the operator is.
        col: usize,
    },
}

/// A parse or evaluation error at a byte column of the original line.
#[derive(Debug, Clone, PartialEq)]
pub struct ExprError {
    /// 0-based byte column in the original line.
    pub column: usize,
    /// What is wrong.
    pub message: String,
    /// What to do.
    pub help: String,
}

impl ExprError {
    /// An error at `column`.
    pub fn new(column: usize, message: impl Into<String>, help: impl Into<String>) -> Self {
        Self {
            column,
            message: message.into(),
            help: help.into(),
        }
    }
}

/// How an expression reads parameters.
pub trait Lookup {
    /// The value of numbered parameter `n` (already checked to be a whole
    /// number in range).
    fn numbered(&self, n: usize, col: usize) -> Result<f64, ExprError>;
    /// The value of a named parameter (refused when it does not exist).
    fn named(&self, name: &str, col: usize) -> Result<f64, ExprError>;
    /// Whether a named parameter exists.
    fn exists(&self, name: &str) -> bool;
}

/// Largest parameter number plus one (LinuxCNC's `RS274NGC_MAX_PARAMETERS`).
pub const MAX_PARAMETERS: usize = 5602;

/// Deepest nesting of brackets and parameters read (a bound on recursion).
const MAX_DEPTH: u32 = 100;

/// A parser over a normalised line.
pub struct Parser<'a> {
    n: &'a Norm,
    /// Position in the normalised text.
    pub pos: usize,
    depth: u32,
}

impl<'a> Parser<'a> {
    /// A parser at normalised position `pos`.
    pub fn new(n: &'a Norm, pos: usize) -> Self {
        Self { n, pos, depth: 0 }
    }

    fn peek(&self) -> u8 {
        self.n.byte(self.pos)
    }

    fn at(&self, k: usize) -> u8 {
        self.n.byte(self.pos + k)
    }

    /// Column in the original line of the current position.
    pub fn col(&self) -> usize {
        self.n.col(self.pos)
    }

    fn err(&self, message: impl Into<String>, help: impl Into<String>) -> ExprError {
        ExprError::new(self.col(), message, help)
    }

    fn starts_with(&self, s: &[u8]) -> bool {
        self.n.text[self.pos.min(self.n.text.len())..].starts_with(s)
    }

    /// LinuxCNC's `read_real_value`: a number, a parameter, a bracketed
    /// expression, a signed value or a function call.
    pub fn value(&mut self) -> Result<Expr, ExprError> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(self.err("expression nested too deeply", "simplify the expression"));
        }
        let r = self.value_inner();
        self.depth -= 1;
        r
    }

    fn value_inner(&mut self) -> Result<Expr, ExprError> {
        let c = self.peek();
        let c1 = self.at(1);
        match c {
            0 => Err(self.err(
                "a value is missing here",
                "write a number, a #parameter or a [expression]",
            )),
            b'[' => self.bracketed(),
            b'#' => self.parameter(),
            b'+' | b'-' if c1 != 0 && !c1.is_ascii_digit() && c1 != b'.' => {
                self.pos += 1;
                let v = self.value()?;
                Ok(if c == b'-' { Expr::Neg(Box::new(v)) } else { v })
            }
            b'a'..=b'z' => self.unary(),
            _ => self.number(),
        }
    }

    /// A literal number as LinuxCNC's `read_real_number` reads it: optional
    /// sign, digits with at most one point, at least one digit.
    fn number(&mut self) -> Result<Expr, ExprError> {
        let start = self.pos;
        let mut i = self.pos;
        if matches!(self.n.byte(i), b'+' | b'-') {
            i += 1;
        }
        let (mut digits, mut dot) = (0, false);
        loop {
            match self.n.byte(i) {
                b'0'..=b'9' => digits += 1,
                b'.' if !dot => dot = true,
                _ => break,
            }
            i += 1;
        }
        if digits == 0 {
            return Err(self.err(
                "a number is missing here",
                "write a number, a #parameter or a [expression]",
            ));
        }
        let text = std::str::from_utf8(&self.n.text[start..i]).unwrap_or("");
        let v: f64 = text
            .parse()
            .map_err(|_| self.err(format!("`{text}` is not a number"), "fix the number"))?;
        self.pos = i;
        Ok(Expr::Num(v))
    }

    /// `[ expression ]` with LinuxCNC's operator precedence.
    pub fn bracketed(&mut self) -> Result<Expr, ExprError> {
        if self.peek() != b'[' {
            return Err(self.err("`[` expected here", "write the expression in brackets"));
        }
        let open = self.col();
        self.pos += 1;
        let mut values = vec![self.value()?];
        let mut ops: Vec<(Op, usize)> = Vec::new();
        loop {
            let col = self.col();
            match self.operation(open)? {
                None => break,
                Some(op) => {
                    // Reduce while the stacked operator binds at least as tightly.
                    while let Some(&(top, tcol)) = ops.last() {
                        if top.precedence() >= op.precedence() {
                            ops.pop();
                            let b = values.pop().unwrap_or(Expr::Num(0.0));
                            let a = values.pop().unwrap_or(Expr::Num(0.0));
                            values.push(Expr::Binary {
                                op: top,
                                a: Box::new(a),
                                b: Box::new(b),
                                col: tcol,
                            });
                        } else {
                            break;
                        }
                    }
                    ops.push((op, col));
                    values.push(self.value()?);
                }
            }
        }
        while let Some((op, col)) = ops.pop() {
            let b = values.pop().unwrap_or(Expr::Num(0.0));
            let a = values.pop().unwrap_or(Expr::Num(0.0));
            values.push(Expr::Binary {
                op,
                a: Box::new(a),
                b: Box::new(b),
                col,
            });
        }
        Ok(values.pop().unwrap_or(Expr::Num(0.0)))
    }

    /// The next binary operator, or `None` at the closing `]`.
    fn operation(&mut self, open: usize) -> Result<Option<Op>, ExprError> {
        let table: [(&[u8], Op); 15] = [
            (b"**", Op::Power),
            (b"*", Op::Times),
            (b"/", Op::Divide),
            (b"+", Op::Plus),
            (b"-", Op::Minus),
            (b"and", Op::And),
            (b"mod", Op::Mod),
            (b"or", Op::Or),
            (b"xor", Op::Xor),
            (b"eq", Op::Eq),
            (b"ne", Op::Ne),
            (b"ge", Op::Ge),
            (b"gt", Op::Gt),
            (b"le", Op::Le),
            (b"lt", Op::Lt),
        ];
        if self.peek() == b']' {
            self.pos += 1;
            return Ok(None);
        }
        if self.peek() == 0 {
            return Err(ExprError::new(
                open,
                "this `[` is not closed",
                "add the closing `]`",
            ));
        }
        for (text, op) in table {
            if self.starts_with(text) {
                self.pos += text.len();
                return Ok(Some(op));
            }
        }
        Err(self.err(
            "unknown operation",
            "operations are ** * / MOD + - EQ NE GT GE LT LE AND OR XOR, or `]` to close",
        ))
    }

    fn unary(&mut self) -> Result<Expr, ExprError> {
        let col = self.col();
        let table: [(&[u8], Option<Func>); 14] = [
            (b"abs", Some(Func::Abs)),
            (b"acos", Some(Func::Acos)),
            (b"asin", Some(Func::Asin)),
            (b"atan", None),
            (b"cos", Some(Func::Cos)),
            (b"exp", Some(Func::Exp)),
            (b"exists", None),
            (b"fix", Some(Func::Fix)),
            (b"fup", Some(Func::Fup)),
            (b"ln", Some(Func::Ln)),
            (b"round", Some(Func::Round)),
            (b"sin", Some(Func::Sin)),
            (b"sqrt", Some(Func::Sqrt)),
            (b"tan", Some(Func::Tan)),
        ];
        // `exists` before `exp`: both start with `ex`.
        let found = table
            .iter()
            .filter(|(t, _)| self.starts_with(t))
            .max_by_key(|(t, _)| t.len())
            .copied();
        let Some((name, func)) = found else {
            return Err(self.err(
                "unknown function or word",
                "functions are ABS ACOS ASIN ATAN COS EXISTS EXP FIX FUP LN ROUND SIN SQRT TAN, each followed by [ ]",
            ));
        };
        self.pos += name.len();
        if self.peek() != b'[' {
            return Err(self.err(
                "`[` is missing after the function name",
                "write the argument in brackets, e.g. SIN[30]",
            ));
        }
        if name == b"exists" {
            self.pos += 1;
            if self.peek() != b'#' {
                return Err(self.err(
                    "EXISTS takes a parameter",
                    "write EXISTS[#<name>] (or EXISTS[#n])",
                ));
            }
            let (param, pcol) = self.param_ref()?;
            if self.peek() != b']' {
                return Err(self.err("`]` expected", "write EXISTS[#<name>]"));
            }
            self.pos += 1;
            return Ok(match param {
                Param::Named(pname) => Expr::Exists(pname),
                // LinuxCNC: a numbered parameter exists when its number is in range.
                Param::Numbered(index) => Expr::ExistsNumbered(index, pcol),
            });
        }
        let arg = self.bracketed()?;
        match func {
            Some(func) => Ok(Expr::Unary {
                func,
                arg: Box::new(arg),
                col,
            }),
            None => {
                if self.peek() != b'/' {
                    return Err(self.err(
                        "`/` is missing after ATAN's first argument",
                        "write ATAN[y]/[x]",
                    ));
                }
                self.pos += 1;
                let x = self.bracketed()?;
                Ok(Expr::Atan(Box::new(arg), Box::new(x)))
            }
        }
    }

    /// `<name>`: the characters up to `>` (the line is already lower case
    /// and without blanks).
    pub fn name(&mut self) -> Result<String, ExprError> {
        let col = self.col();
        if self.peek() != b'<' {
            return Err(self.err("`<` expected", "write the name as <name>"));
        }
        self.pos += 1;
        let start = self.pos;
        while self.peek() != b'>' {
            if self.peek() == 0 {
                return Err(ExprError::new(
                    col,
                    "this name is not closed with `>`",
                    "add the closing `>`",
                ));
            }
            self.pos += 1;
        }
        let name = String::from_utf8_lossy(&self.n.text[start..self.pos]).into_owned();
        self.pos += 1;
        Ok(name)
    }

    /// `#n`, `#[expr]`, `##n` or `#<name>` (at `#`).
    pub fn param_ref(&mut self) -> Result<(Param, usize), ExprError> {
        let col = self.col();
        self.pos += 1;
        if self.peek() == b'<' {
            return Ok((Param::Named(self.name()?), col));
        }
        let index = self.value()?;
        Ok((Param::Numbered(Box::new(index)), col))
    }

    fn parameter(&mut self) -> Result<Expr, ExprError> {
        let (param, col) = self.param_ref()?;
        Ok(Expr::Param { param, col })
    }
}

// Integers as LinuxCNC 2.9 makes them from reals (src/emc/rs274ngc/). Each
// place that turns a real into an integer uses one of these three rules:
//
// * `read_integer_value` (interp_read.cc): M, T, H and L words,
//   parameter numbers (`#n`, `#n=`), o-word numbers, the P of M98: the value
//   must lie within 0.0001 of a whole number ([`to_integer`]);
// * `round_to_int` (interp_internal.hh, `nearbyint` under the default
//   rounding mode, half to even): repeat counts, the turns P of G2/G3, the
//   Q of M61 ([`round_to_int`]);
// * `is_near_int` (interp_convert.cc, `(int)(v + 0.5)`, a C cast that cuts
//   toward zero): the D of G41/G42, the P (tool) and Q (orientation) of
//   G10 L1/L10/L11 ([`near_int`]).
//
// G codes are read ×10 within 0.001 (`read_g`), the P of G10 L2/L20 with
// `(int)(p + 0.0001)` (`convert_setup`): see the interpreter.

/// LinuxCNC's `read_integer_value` rule: within 0.0001 of a whole number,
/// else "Non integer value for integer".
pub fn to_integer(v: f64, col: usize) -> Result<i64, ExprError> {
    let f = v.floor();
    let i = if v - f > 0.9999 {
        v.ceil()
    } else if v - f > 0.0001 {
        return Err(ExprError::new(
            col,
            format!("{v} is not a whole number, and a whole number is needed here (LinuxCNC: \"Non integer value for integer\")"),
            "round the value, e.g. with ROUND[ ]",
        ));
    } else {
        f
    };
    if !i.is_finite() || i.abs() > f64::from(i32::MAX) {
        return Err(ExprError::new(
            col,
            format!("{v} is out of range for a whole number"),
            "fix the value",
        ));
    }
    Ok(i as i64)
}

/// LinuxCNC's `round_to_int`: `nearbyint`, which rounds half to even
/// (2.5 → 2, 3.5 → 4, 0.5 → 0), saturated to the range of a C `int`
/// (a NaN gives 0).
pub fn round_to_int(v: f64) -> i64 {
    v.round_ties_even()
        .clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i64
}

/// LinuxCNC's `is_near_int`: the integer `(int)(v + 0.5)` (the C cast cuts
/// toward zero, so −1.7 gives −1) and whether `v` lies within 0.0001 of it.
pub fn near_int(v: f64) -> (i64, bool) {
    let i = (v + 0.5)
        .trunc()
        .clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i64;
    (i, (i as f64 - v).abs() < 0.0001)
}

/// The parameter number `index` evaluates to, checked against LinuxCNC's range.
pub fn param_number(index: &Expr, col: usize, lk: &dyn Lookup) -> Result<usize, ExprError> {
    let n = to_integer(eval(index, lk)?, col)?;
    if n < 1 || n as usize >= MAX_PARAMETERS {
        return Err(ExprError::new(
            col,
            format!("parameter number {n} is out of range"),
            "numbered parameters are #1 to #5601 (LinuxCNC: below RS274NGC_MAX_PARAMETERS = 5602)",
        ));
    }
    Ok(n as usize)
}

/// Evaluates `e` as LinuxCNC does; NaN and infinite results are errors.
pub fn eval(e: &Expr, lk: &dyn Lookup) -> Result<f64, ExprError> {
    let v = eval_inner(e, lk)?;
    if !v.is_finite() {
        let col = match e {
            Expr::Binary { col, .. } | Expr::Unary { col, .. } | Expr::Param { col, .. } => *col,
            _ => 0,
        };
        return Err(ExprError::new(
            col,
            "the calculation gives infinity or not a number",
            "check the values the expression uses",
        ));
    }
    Ok(v)
}

fn deg(v: f64) -> f64 {
    v * std::f64::consts::PI / 180.0
}

fn eval_inner(e: &Expr, lk: &dyn Lookup) -> Result<f64, ExprError> {
    Ok(match e {
        Expr::Num(v) => *v,
        Expr::Param { param, col } => match param {
            Param::Named(name) => lk.named(name, *col)?,
            Param::Numbered(index) => lk.numbered(param_number(index, *col, lk)?, *col)?,
        },
        Expr::Neg(v) => -eval(v, lk)?,
        Expr::Exists(name) => f64::from(u8::from(lk.exists(name))),
        Expr::ExistsNumbered(index, col) => {
            let n = to_integer(eval(index, lk)?, *col)?;
            f64::from(u8::from(n >= 1 && (n as usize) < MAX_PARAMETERS))
        }
        Expr::Atan(y, x) => eval(y, lk)?.atan2(eval(x, lk)?).to_degrees(),
        Expr::Unary { func, arg, col } => {
            let v = eval(arg, lk)?;
            let domain = |ok: bool, what: &str| {
                if ok {
                    Ok(())
                } else {
                    Err(ExprError::new(
                        *col,
                        format!("argument {v} {what}"),
                        "check the argument",
                    ))
                }
            };
            match func {
                Func::Abs => v.abs(),
                Func::Acos => {
                    domain((-1.0..=1.0).contains(&v), "of ACOS is outside −1…1")?;
                    v.acos().to_degrees()
                }
                Func::Asin => {
                    domain((-1.0..=1.0).contains(&v), "of ASIN is outside −1…1")?;
                    v.asin().to_degrees()
                }
                Func::Cos => deg(v).cos(),
                Func::Exp => v.exp(),
                Func::Fix => v.floor(),
                Func::Fup => v.ceil(),
                Func::Ln => {
                    domain(v > 0.0, "of LN is zero or negative")?;
                    v.ln()
                }
                Func::Round => {
                    // LinuxCNC: (int)(v ± 0.5), i.e. half away from zero.
                    (v + if v < 0.0 { -0.5 } else { 0.5 }).trunc()
                }
                Func::Sin => deg(v).sin(),
                Func::Sqrt => {
                    domain(v >= 0.0, "of SQRT is negative")?;
                    v.sqrt()
                }
                Func::Tan => deg(v).tan(),
            }
        }
        Expr::Binary { op, a, b, col } => {
            let (a, b) = (eval(a, lk)?, eval(b, lk)?);
            let truth = |t: bool| f64::from(u8::from(t));
            // EQ/NE within 0.0001, LE/GE exact: the rule of the LinuxCNC
            // 2.9.0~pre1 interpreter Debian ships (`rs274`, the oracle);
            // the 2.9.0 release (commit 014777a816) uses 1e-6 for all four.
            const TOL: f64 = 1e-4;
            match op {
                Op::Divide => {
                    if b == 0.0 {
                        return Err(ExprError::new(
                            *col,
                            "division by zero",
                            "check the divisor's value",
                        ));
                    }
                    a / b
                }
                Op::Mod => {
                    let r = a % b;
                    if r < 0.0 {
                        r + b.abs()
                    } else {
                        r
                    }
                }
                Op::Power => {
                    if a < 0.0 && b.floor() != b {
                        return Err(ExprError::new(
                            *col,
                            "a negative number raised to a power that is not whole",
                            "check the operands",
                        ));
                    }
                    a.powf(b)
                }
                Op::Times => a * b,
                Op::Plus => a + b,
                Op::Minus => a - b,
                Op::And => truth(a != 0.0 && b != 0.0),
                Op::Or => truth(a != 0.0 || b != 0.0),
                Op::Xor => truth((a != 0.0) != (b != 0.0)),
                Op::Lt => truth(a < b),
                Op::Gt => truth(a > b),
                Op::Eq => truth((a - b).abs() < TOL),
                Op::Ne => truth((a - b).abs() >= TOL),
                Op::Le => truth(a <= b),
                Op::Ge => truth(a >= b),
            }
        }
    })
}
