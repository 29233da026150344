//! One option of a request: its name, what it takes, its default and its
//! help, written once here and read by every front end (the CLI builds its
//! flags from it, the Python package its keyword arguments, signature and
//! docstring).
//!
//! Help and error texts name other options as `{name}`; each front end
//! writes them in its own terms ([`Spelling`]): `--chord-tolerance` on the
//! command line, `chord_tolerance_mm` in Python.

use std::fmt;
use std::path::PathBuf;

/// What an option takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// On or off. A switch whose default is on is turned off on the command
    /// line by `--no-<name>`.
    Switch,
    /// A finite number (its unit is in the option's name: `_mm`, `_um`).
    Number,
    /// A whole number ≥ 0.
    Count,
    /// One of [`OptionInfo::choices`].
    Choice,
    /// A file's path.
    Path,
    /// A file: a path, or (in Python) its content from a file object.
    Input,
    /// Three numbers X, Y, Z in mm (`X,Y,Z` on the command line).
    Triple,
    /// A number of bytes or no limit (`256M`, `none` on the command line).
    Size,
    /// Free text (a kinematic chain).
    Text,
    /// Three ranges lo … hi in mm, one per axis (`0:600,0:400,0:300` on
    /// the command line).
    Ranges,
}

/// One option of a request.
#[derive(Debug)]
pub struct OptionInfo {
    /// The option's name: the request's field, the Python keyword and the
    /// name library messages use (`contour_tolerance_um`).
    pub name: &'static str,
    /// The command line's long flag when it is not the name with `-` for
    /// `_` (older flags without their unit). A switch on by default adds
    /// `no-` before it.
    pub flag: Option<&'static str>,
    /// What it takes.
    pub kind: Kind,
    /// The value's placeholder in help (`MM`, `UM`, `N`, `FILE`).
    pub value_name: &'static str,
    /// The default as written on the command line (`"0.5"`, `"exact"`,
    /// `"true"` for a switch on by default); `None`: unset.
    pub default: Option<&'static str>,
    /// For [`Kind::Choice`]: each value and what it means.
    pub choices: &'static [(&'static str, &'static str)],
    /// What the option does, for a person (one paragraph; `{name}` names
    /// another option). A switch's help says what turning it from its
    /// default does.
    pub help: &'static str,
    /// Kept for old scripts, not shown in help.
    pub hidden: bool,
    /// The job cannot run without it.
    pub required: bool,
}

impl OptionInfo {
    /// An option `name` of `kind` with `help`; the rest by the builder methods.
    pub const fn new(name: &'static str, kind: Kind, help: &'static str) -> Self {
        Self {
            name,
            flag: None,
            kind,
            value_name: "",
            default: None,
            choices: &[],
            help,
            hidden: false,
            required: false,
        }
    }

    /// With the command line's flag `flag` (without `--`).
    pub const fn flag(mut self, flag: &'static str) -> Self {
        self.flag = Some(flag);
        self
    }

    /// With the value's placeholder in help.
    pub const fn value(mut self, value_name: &'static str) -> Self {
        self.value_name = value_name;
        self
    }

    /// With a default (as written on the command line).
    pub const fn default(mut self, default: &'static str) -> Self {
        self.default = Some(default);
        self
    }

    /// With its choices (for [`Kind::Choice`]).
    pub const fn choices(mut self, choices: &'static [(&'static str, &'static str)]) -> Self {
        self.choices = choices;
        self
    }

    /// Required: the job cannot run without it.
    pub const fn required(mut self) -> Self {
        self.required = true;
        self
    }

    /// Hidden from help (kept for old scripts).
    pub const fn hidden(mut self) -> Self {
        self.hidden = true;
        self
    }

    /// Whether this is a switch that is on unless turned off.
    pub fn on_by_default(&self) -> bool {
        self.kind == Kind::Switch && self.default == Some("true")
    }

    /// The command line's long flag, without `--`.
    pub fn cli_flag(&self) -> String {
        let base = self
            .flag
            .map(str::to_string)
            .unwrap_or_else(|| self.name.replace('_', "-"));
        if self.on_by_default() {
            format!("no-{base}")
        } else {
            base
        }
    }

    /// Reads the option's value from command-line text (a switch takes no
    /// text). The error is the problem alone (`must be …`); the caller
    /// names the option.
    pub fn parse(&self, text: &str) -> Result<Value, String> {
        let t = text.trim();
        match self.kind {
            Kind::Switch => match t {
                "true" => Ok(Value::Bool(true)),
                "false" => Ok(Value::Bool(false)),
                _ => Err(format!("must be true or false; got `{text}`")),
            },
            Kind::Number => t
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .map(Value::Number)
                .ok_or_else(|| format!("must be a number; got `{text}`")),
            Kind::Count => t
                .parse::<u64>()
                .map(Value::Count)
                .map_err(|_| format!("must be a whole number ≥ 0; got `{text}`")),
            Kind::Choice => self.choice(t).map(|c| Value::Text(c.to_string())),
            Kind::Path | Kind::Input => Ok(Value::Path(PathBuf::from(text))),
            Kind::Triple => parse_triple(t)
                .map(Value::Triple)
                .ok_or_else(|| {
                    format!("expects three numbers in mm separated by commas, like 100,50,-200; got `{text}`")
                }),
            Kind::Size => parse_size(t).map(Value::Size).ok_or_else(|| {
                format!("`{text}` is not a size: write a whole number of bytes, optionally with K, M or G (1024-based), or `none`")
            }),
            Kind::Text => Ok(Value::Text(text.to_string())),
            Kind::Ranges => parse_ranges(t).map(Value::Ranges).ok_or_else(|| {
                format!("`{text}`: write three ranges lo:hi separated by commas, e.g. 0:600,0:400,0:300")
            }),
        }
    }

    /// `text` as one of the choices, or what to write instead.
    pub fn choice(&self, text: &str) -> Result<&'static str, String> {
        if let Some((c, _)) = self
            .choices
            .iter()
            .find(|(c, _)| c.eq_ignore_ascii_case(text))
        {
            return Ok(c);
        }
        let names: Vec<&str> = self.choices.iter().map(|(c, _)| *c).collect();
        let hint = did_you_mean(text, names.iter().copied())
            .map(|s| format!(" (did you mean `{s}`?)"))
            .unwrap_or_default();
        Err(format!(
            "must be one of {}; got `{text}`{hint}",
            names
                .iter()
                .map(|n| format!("`{n}`"))
                .collect::<Vec<_>>()
                .join(", ")
        ))
    }
}

/// A value of an option, as a front end read it.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// A switch.
    Bool(bool),
    /// A number.
    Number(f64),
    /// A whole number.
    Count(u64),
    /// A choice (or other text).
    Text(String),
    /// A file's path.
    Path(PathBuf),
    /// A file's content (from Python: a file object), with its name.
    Content {
        /// The name messages give it.
        name: String,
        /// Its bytes.
        bytes: Vec<u8>,
    },
    /// Three numbers.
    Triple([f64; 3]),
    /// Bytes, or no limit.
    Size(Option<u64>),
    /// Three ranges `[lo, hi]`.
    Ranges([[f64; 2]; 3]),
}

/// A file a request reads: a path, or content a caller already holds.
#[derive(Debug, Clone, PartialEq)]
pub enum Input {
    /// A file on disk.
    File(PathBuf),
    /// Content in memory, with the name messages give it.
    Content {
        /// The name messages give it.
        name: String,
        /// Its bytes.
        bytes: Vec<u8>,
    },
}

impl Input {
    /// The name messages give the input.
    pub fn name(&self) -> String {
        match self {
            Input::File(p) => p.display().to_string(),
            Input::Content { name, .. } => name.clone(),
        }
    }

    /// The file's path, for a file.
    pub fn path(&self) -> Option<&std::path::Path> {
        match self {
            Input::File(p) => Some(p),
            Input::Content { .. } => None,
        }
    }

    /// The input's bytes (the file read whole).
    pub fn bytes(&self) -> Result<std::borrow::Cow<'_, [u8]>, crate::Error> {
        match self {
            Input::File(p) => crate::io::inputs::read(p, "an input")
                .map(std::borrow::Cow::Owned)
                .map_err(|e| crate::Error::io(p, e)),
            Input::Content { bytes, .. } => Ok(std::borrow::Cow::Borrowed(bytes)),
        }
    }

    /// The input read whole as UTF-8 text (a byte-order mark dropped); a
    /// byte that is not UTF-8 is refused at its line and column.
    pub fn text(&self) -> Result<String, crate::Error> {
        let bytes = self.bytes()?;
        let text = crate::io::table::utf8(&bytes, &self.name())?;
        Ok(text.to_string())
    }

    /// A reader over the input: the file opened (`-` is standard input,
    /// the Unix convention), or the content.
    pub fn reader(&self) -> Result<Box<dyn std::io::Read + Send + '_>, crate::Error> {
        match self {
            Input::File(p) if p.as_os_str() == "-" => {
                crate::io::inputs::record_stdin("standard input");
                Ok(Box::new(std::io::stdin()))
            }
            Input::File(p) => crate::io::inputs::open(p, "an input")
                .map(|f| Box::new(f) as Box<dyn std::io::Read + Send>)
                .map_err(|e| crate::Error::io(p, e)),
            Input::Content { bytes, .. } => Ok(Box::new(bytes.as_slice())),
        }
    }
}

impl Value {
    fn kind_name(&self) -> &'static str {
        match self {
            Value::Bool(_) => "true or false",
            Value::Number(_) => "a number",
            Value::Count(_) => "a whole number",
            Value::Text(_) => "text",
            Value::Path(_) => "a path",
            Value::Content { .. } => "a file's content",
            Value::Triple(_) => "three numbers",
            Value::Size(_) => "a size",
            Value::Ranges(_) => "three ranges",
        }
    }

    fn wrong(&self, name: &'static str, want: &str) -> OptionError {
        OptionError::new(name, format!("must be {want}; got {}", self.kind_name()))
    }

    /// The switch's value.
    pub fn bool(self, name: &'static str) -> Result<bool, OptionError> {
        match self {
            Value::Bool(b) => Ok(b),
            v => Err(v.wrong(name, "true or false")),
        }
    }

    /// The number (a whole number is a number too).
    pub fn number(self, name: &'static str) -> Result<f64, OptionError> {
        match self {
            Value::Number(v) => Ok(v),
            Value::Count(v) => Ok(v as f64),
            v => Err(v.wrong(name, "a number")),
        }
    }

    /// The whole number.
    pub fn count(self, name: &'static str) -> Result<u64, OptionError> {
        match self {
            Value::Count(v) => Ok(v),
            Value::Number(v) if v >= 0.0 && v.fract() == 0.0 && v < 2f64.powi(53) => Ok(v as u64),
            v => Err(v.wrong(name, "a whole number ≥ 0")),
        }
    }

    /// The text (a choice).
    pub fn text(self, name: &'static str) -> Result<String, OptionError> {
        match self {
            Value::Text(t) => Ok(t),
            v => Err(v.wrong(name, "text")),
        }
    }

    /// The path.
    pub fn path(self, name: &'static str) -> Result<PathBuf, OptionError> {
        match self {
            Value::Path(p) => Ok(p),
            v => Err(v.wrong(name, "a path")),
        }
    }

    /// The input: a path or content.
    pub fn input(self, name: &'static str) -> Result<Input, OptionError> {
        match self {
            Value::Path(p) => Ok(Input::File(p)),
            Value::Content { name, bytes } => Ok(Input::Content { name, bytes }),
            v => Err(v.wrong(name, "a path or a file object")),
        }
    }

    /// The three numbers.
    pub fn triple(self, name: &'static str) -> Result<[f64; 3], OptionError> {
        match self {
            Value::Triple(t) => Ok(t),
            v => Err(v.wrong(name, "three numbers (X, Y, Z)")),
        }
    }

    /// The three ranges.
    pub fn ranges(self, name: &'static str) -> Result<[[f64; 2]; 3], OptionError> {
        match self {
            Value::Ranges(r) => Ok(r),
            v => Err(v.wrong(name, "three ranges lo:hi (X, Y, Z)")),
        }
    }

    /// The size.
    pub fn size(self, name: &'static str) -> Result<Option<u64>, OptionError> {
        match self {
            Value::Size(s) => Ok(s),
            Value::Count(n) => Ok(Some(n)),
            v => Err(v.wrong(name, "a number of bytes or none")),
        }
    }
}

/// A request's field, read from an option's [`Value`] of the option's
/// [`Kind`] (the field's type says which reader: `f64` a number, `u64` a
/// whole number, `Option<T>` a given value, a size a number of bytes or no
/// limit).
pub trait FromValue: Sized {
    /// The field's value, or the value's kind refused for option `name`.
    fn from_value(value: Value, kind: Kind, name: &'static str) -> Result<Self, OptionError>;

    /// The value of an optional field: given (`Some`), except a size, whose
    /// `none` is no limit.
    fn from_value_optional(
        value: Value,
        kind: Kind,
        name: &'static str,
    ) -> Result<Option<Self>, OptionError> {
        Self::from_value(value, kind, name).map(Some)
    }
}

impl<T: FromValue> FromValue for Option<T> {
    fn from_value(value: Value, kind: Kind, name: &'static str) -> Result<Self, OptionError> {
        T::from_value_optional(value, kind, name)
    }
}

impl FromValue for u64 {
    fn from_value(value: Value, _: Kind, name: &'static str) -> Result<Self, OptionError> {
        value.count(name)
    }

    fn from_value_optional(
        value: Value,
        kind: Kind,
        name: &'static str,
    ) -> Result<Option<Self>, OptionError> {
        match kind {
            Kind::Size => value.size(name),
            _ => value.count(name).map(Some),
        }
    }
}

/// `FromValue` for a type read by one of [`Value`]'s readers.
macro_rules! from_value {
    ($($type:ty => $read:ident),+) => {$(
        impl FromValue for $type {
            fn from_value(value: Value, _: Kind, name: &'static str) -> Result<Self, OptionError> {
                value.$read(name)
            }
        }
    )+};
}

from_value!(
    bool => bool,
    f64 => number,
    String => text,
    PathBuf => path,
    Input => input,
    [f64; 3] => triple,
    [[f64; 2]; 3] => ranges
);

pub use crate::error::OptionError;

// The error's data is defined with the crate's errors (below the requests,
// which the error enum must not import); how it is written is here.
impl OptionError {
    /// The message with options spelt by `spelling`.
    pub fn render(&self, spelling: &dyn Spelling) -> String {
        format!(
            "{} {}",
            spelling.option(self.option),
            render(&self.problem, spelling)
        )
    }
}

impl fmt::Display for OptionError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.render(&Names))
    }
}

impl std::error::Error for OptionError {}

/// How a front end writes an option's name in help and messages.
pub trait Spelling {
    /// The option `name` (a request's field name).
    fn option(&self, name: &str) -> String;
}

/// Options by their names (the library's own messages, Python).
pub struct Names;

impl Spelling for Names {
    fn option(&self, name: &str) -> String {
        name.to_string()
    }
}

/// `text` with every `{name}` of a known option ([`super::find`]) written
/// by `spelling`; other braces stand.
pub fn render(text: &str, spelling: &dyn Spelling) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(open) = rest.find('{') {
        out.push_str(&rest[..open]);
        let after = &rest[open + 1..];
        match after.find('}') {
            Some(close) if super::find(&after[..close]).is_some() => {
                out.push_str(&spelling.option(&after[..close]));
                rest = &after[close + 1..];
            }
            _ => {
                out.push('{');
                rest = after;
            }
        }
    }
    out.push_str(rest);
    out
}

/// The candidate closest to `typed` when it is close enough to be a typing
/// slip (at most one edit in four letters, two in longer words, a swap of
/// neighbours counting one).
pub fn did_you_mean<'a>(
    typed: &str,
    candidates: impl IntoIterator<Item = &'a str>,
) -> Option<&'a str> {
    let limit = if typed.chars().count() <= 4 { 1 } else { 2 };
    candidates
        .into_iter()
        .map(|c| (edit_distance(typed, c), c))
        .filter(|(d, _)| *d <= limit)
        .min_by_key(|(d, _)| *d)
        .map(|(_, c)| c)
}

/// The optimal-string-alignment distance: insertions, deletions,
/// substitutions and swaps of neighbours, each one edit.
fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.chars().collect();
    let b: Vec<char> = b.chars().collect();
    let mut d = vec![vec![0usize; b.len() + 1]; a.len() + 1];
    for (i, row) in d.iter_mut().enumerate() {
        row[0] = i;
    }
    for (j, cell) in d[0].iter_mut().enumerate() {
        *cell = j;
    }
    for i in 1..=a.len() {
        for j in 1..=b.len() {
            let cost = usize::from(a[i - 1] != b[j - 1]);
            let mut v = (d[i - 1][j] + 1)
                .min(d[i][j - 1] + 1)
                .min(d[i - 1][j - 1] + cost);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                v = v.min(d[i - 2][j - 2] + 1);
            }
            d[i][j] = v;
        }
    }
    d[a.len()][b.len()]
}

pub use crate::io::table::parse_triple;

/// `lo:hi,lo:hi,lo:hi`: three ranges of finite numbers.
pub fn parse_ranges(text: &str) -> Option<[[f64; 2]; 3]> {
    let ranges: Vec<[f64; 2]> = text
        .split(',')
        .map(|part| {
            let (lo, hi) = part.split_once(':')?;
            let v = |t: &str| t.trim().parse::<f64>().ok().filter(|x| x.is_finite());
            Some([v(lo)?, v(hi)?])
        })
        .collect::<Option<_>>()?;
    <[[f64; 2]; 3]>::try_from(ranges).ok()
}

/// A byte count such as `1048576`, `64K`, `256M`, `2G` (powers of 1024);
/// `none` is no limit.
pub fn parse_size(text: &str) -> Option<Option<u64>> {
    let t = text.trim();
    if t.eq_ignore_ascii_case("none") {
        return Some(None);
    }
    let (digits, factor) = match t.chars().last().map(|c| c.to_ascii_uppercase()) {
        Some('K') => (&t[..t.len() - 1], 1u64 << 10),
        Some('M') => (&t[..t.len() - 1], 1 << 20),
        Some('G') => (&t[..t.len() - 1], 1 << 30),
        _ => (t, 1),
    };
    digits
        .parse::<u64>()
        .ok()
        .and_then(|n| n.checked_mul(factor))
        .filter(|n| *n > 0)
        .map(Some)
}

/// A request: one job's options, built from plain values a front end read
/// ([`Request::set`]) and checked once ([`Request::check`] and the job's
/// own preparation).
pub trait Request: Default {
    /// The options, grouped, in the order help lists them.
    const OPTIONS: &'static [&'static [OptionInfo]];

    /// Sets the option `name` to `value` (the value's kind is checked, its
    /// range is not yet).
    fn set(&mut self, name: &str, value: Value) -> Result<(), OptionError>;

    /// The option named `name`, if this request has it.
    fn info(name: &str) -> Option<&'static OptionInfo> {
        Self::OPTIONS
            .iter()
            .flat_map(|g| g.iter())
            .find(|o| o.name == name)
    }

    /// Sets `name` to `value`, refusing an unknown name (with the closest
    /// known one).
    fn set_named(&mut self, name: &str, value: Value) -> Result<(), UnknownOption> {
        let Some(info) = Self::info(name) else {
            let names = Self::OPTIONS.iter().flat_map(|g| g.iter()).map(|o| o.name);
            return Err(UnknownOption::Unknown {
                name: name.to_string(),
                suggestion: did_you_mean(name, names).map(str::to_string),
            });
        };
        self.set(info.name, value).map_err(UnknownOption::Value)
    }
}

/// An option a caller named is not one of the request's, or its value is
/// of the wrong kind.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum UnknownOption {
    /// No option has this name.
    Unknown {
        /// The name given.
        name: String,
        /// The closest known name.
        suggestion: Option<String>,
    },
    /// The value is of the wrong kind.
    Value(OptionError),
}

impl UnknownOption {
    /// The message with options spelt by `spelling`.
    pub fn render(&self, spelling: &dyn Spelling) -> String {
        match self {
            UnknownOption::Unknown { name, suggestion } => {
                let hint = suggestion
                    .as_deref()
                    .map(|s| format!(" (did you mean `{}`?)", spelling.option(s)))
                    .unwrap_or_default();
                format!("there is no option `{name}`{hint}")
            }
            UnknownOption::Value(e) => e.render(spelling),
        }
    }
}

impl fmt::Display for UnknownOption {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.render(&Names))
    }
}

impl std::error::Error for UnknownOption {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_slip_finds_its_option() {
        let names = ["map", "method", "clamp", "setup"];
        assert_eq!(did_you_mean("mpa", names), Some("map"));
        assert_eq!(did_you_mean("metod", names), Some("method"));
        assert_eq!(did_you_mean("zzz", names), None);
        assert_eq!(edit_distance("abc", "acb"), 1);
        assert_eq!(edit_distance("", "ab"), 2);
    }

    #[test]
    fn names_in_braces_are_spelt_by_the_front_end() {
        struct Flags;
        impl Spelling for Flags {
            fn option(&self, name: &str) -> String {
                format!("--{}", name.replace('_', "-"))
            }
        }
        let t = "raise {max_correction_mm} {or} {} {Not} {x";
        assert_eq!(
            render(t, &Flags),
            "raise --max-correction-mm {or} {} {Not} {x"
        );
        assert_eq!(
            render(t, &Names),
            "raise max_correction_mm {or} {} {Not} {x"
        );
    }

    #[test]
    fn command_line_text_is_read_by_kind() {
        let n = OptionInfo::new("gain", Kind::Number, "");
        assert_eq!(n.parse("0.5"), Ok(Value::Number(0.5)));
        assert!(n.parse("nan").is_err());
        let t = OptionInfo::new("at", Kind::Triple, "");
        assert_eq!(t.parse("1, 2,-3"), Ok(Value::Triple([1.0, 2.0, -3.0])));
        assert!(t.parse("1,2").is_err());
        let s = OptionInfo::new("max_output_bytes", Kind::Size, "");
        assert_eq!(s.parse("2K"), Ok(Value::Size(Some(2048))));
        assert_eq!(s.parse("none"), Ok(Value::Size(None)));
        assert!(s.parse("0").is_err());
        let c = OptionInfo::new("method", Kind::Choice, "").choices(&[("exact", ""), ("ilc", "")]);
        assert_eq!(c.parse("ilc"), Ok(Value::Text("ilc".into())));
        assert_eq!(
            c.parse("exatc").unwrap_err(),
            "must be one of `exact`, `ilc`; got `exatc` (did you mean `exact`?)"
        );
    }

    #[test]
    fn a_switch_on_by_default_is_turned_off_by_no() {
        let s = OptionInfo::new("take_up", Kind::Switch, "").default("true");
        assert_eq!(s.cli_flag(), "no-take-up");
        let s = OptionInfo::new("chord_tolerance_mm", Kind::Number, "").flag("chord-tolerance");
        assert_eq!(s.cli_flag(), "chord-tolerance");
    }
}
