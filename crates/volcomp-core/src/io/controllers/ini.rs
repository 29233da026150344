//! LinuxCNC's INI file, read as LinuxCNC 2.9 reads it
//! (`src/libnml/inifile/inifile.cc`, `IniFile::Find`; the `linuxcnc`
//! script's `handle_includes`): what `[JOINT_n] COMP_FILE`, `BACKLASH` and
//! `[KINS] KINEMATICS` mean to the controller depends on these rules, so
//! volcomp follows them rather than a generic INI grammar.
//!
//! * A **section** is found at the first line whose first non-blank text
//!   starts with `[NAME]`; a second section of the same name is never read
//!   (the search starts from the top of the file every time).
//! * Within it, a **key** is the first line whose first non-blank text is
//!   the key followed by a blank or `=`; later lines with the same key are
//!   never read. The section ends at the next line starting with `[`.
//! * A line whose first non-blank character is `;` or `#` is a comment.
//!   There are **no comments after a value**: the value is everything after
//!   the first `=`, blanks trimmed at both ends, `#` and `;` included. A
//!   number is read from the start of the value (C's `sscanf "%lf"`), so
//!   `BACKLASH = 0.002 # mm` is 0.002, but `COMP_FILE = x.comp # X` names
//!   the file `x.comp # X`.
//! * A line ending in `\` continues on the next one (within a section).
//! * A key line without `=` (or with nothing after it) ends the search:
//!   the key is taken as missing.
//! * A carriage return not followed by a line end is refused (LinuxCNC
//!   stops with "ambiguous carriage returns").
//! * `#INCLUDE file` at the start of a line of the machine's INI file is
//!   replaced by that file's lines (relative to the INI's folder; the
//!   included files' own `#INCLUDE` lines stay comments).

use super::{located, ControllerReadError};
use crate::error::MapFileError;

/// One line as LinuxCNC sees it, and where it came from.
#[derive(Debug, Clone)]
struct Line {
    /// Index into [`Ini::files`].
    file: usize,
    /// 1-based row in that file.
    row: usize,
    text: String,
}

/// A key's value, found as `IniFile::Find` finds it.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Found {
    /// The value (after `=`, blanks trimmed).
    pub value: String,
    /// The line it is on (index into the expanded lines).
    pub line: usize,
}

/// An INI file and the files it includes, as lines.
#[derive(Debug, Clone)]
pub(crate) struct Ini {
    /// `(name, text)` of the INI file and every included file.
    files: Vec<(String, String)>,
    lines: Vec<Line>,
}

/// The first non-blank text of a line, or `None` for a blank or comment
/// line (`IniFile::SkipWhite`).
fn skip_white(line: &str) -> Option<&str> {
    let t = line.trim_start_matches([' ', '\t', '\r', '\n']);
    if t.is_empty() || t.starts_with(';') || t.starts_with('#') {
        None
    } else {
        Some(t)
    }
}

impl Ini {
    /// Reads `text` (the INI file `file`), expanding `#INCLUDE` lines with
    /// `read_file` (a name relative to the INI's folder → its display name
    /// and text).
    pub fn parse(
        text: &str,
        file: &str,
        mut read_file: impl FnMut(&str) -> Result<(String, String), ControllerReadError>,
    ) -> Result<Ini, ControllerReadError> {
        let mut ini = Ini {
            files: vec![(file.to_string(), text.to_string())],
            lines: Vec::new(),
        };
        ini.check_line_ends(0)?;
        let expand = text.lines().any(|l| l.starts_with("#INCLUDE"));
        for (i, raw) in text.lines().enumerate() {
            let row = i + 1;
            let mut words = raw.split_whitespace();
            if expand && words.next() == Some("#INCLUDE") {
                let name = raw.trim_start()["#INCLUDE".len()..].trim();
                if name.is_empty() {
                    return Err(ini
                        .error(
                            0,
                            row,
                            "#INCLUDE without a file name".into(),
                            "name the file to include, relative to the INI's folder",
                        )
                        .into());
                }
                if name.contains(['$', '`', '~']) {
                    return Err(ini.error(0, row, format!("#INCLUDE {name}: the shell expands this name when LinuxCNC starts"), "volcomp does not expand shell variables: write the included file's path relative to the INI's folder").into());
                }
                let (shown, body) = read_file(name).map_err(|e| match e {
                    ControllerReadError::Io { .. } => ControllerReadError::from(ini.error(
                        0,
                        row,
                        format!("cannot read the included file {name}"),
                        "#INCLUDE names a file relative to the INI's folder",
                    )),
                    other => other,
                })?;
                let f = ini.files.len();
                ini.files.push((shown, body));
                ini.check_line_ends(f)?;
                let included: Vec<Line> = ini.files[f]
                    .1
                    .lines()
                    .enumerate()
                    .map(|(k, l)| Line {
                        file: f,
                        row: k + 1,
                        text: l.to_string(),
                    })
                    .collect();
                ini.lines.extend(included);
            } else {
                ini.lines.push(Line {
                    file: 0,
                    row,
                    text: raw.to_string(),
                });
            }
        }
        Ok(ini)
    }

    fn check_line_ends(&self, f: usize) -> Result<(), MapFileError> {
        let text = &self.files[f].1;
        for (i, l) in text.split('\n').enumerate() {
            if l.trim_end_matches('\r').contains('\r') {
                return Err(self.error(f, i + 1, "a carriage return inside a line".into(), "LinuxCNC refuses INI files with carriage returns that do not end a line (\"ambiguous carriage returns\"): save the file with Unix or DOS line ends"));
            }
        }
        Ok(())
    }

    fn error(&self, file: usize, row: usize, message: String, help: &str) -> MapFileError {
        let (name, text) = &self.files[file];
        located(name, text, row, message, help)
    }

    /// A located error at expanded line `line`.
    pub fn error_at(&self, line: usize, message: String, help: &str) -> MapFileError {
        match self.lines.get(line) {
            Some(l) => self.error(l.file, l.row, message, help),
            None => self.error(0, 1, message, help),
        }
    }

    /// A located error at the top of the INI file.
    pub fn error_top(&self, message: String, help: &str) -> MapFileError {
        self.error(0, 1, message, help)
    }

    /// `file:row` of expanded line `line`, for messages.
    pub fn place(&self, line: usize) -> String {
        match self.lines.get(line) {
            Some(l) => format!("{}:{}", self.files[l.file].0, l.row),
            None => self.files[0].0.clone(),
        }
    }

    /// The lines that open section `name` (`[name]` at the start of the
    /// line's text), in order.
    pub fn sections(&self, name: &str) -> Vec<usize> {
        let bracket = format!("[{name}]");
        self.lines
            .iter()
            .enumerate()
            .filter(|(_, l)| skip_white(&l.text).is_some_and(|t| t.starts_with(&bracket)))
            .map(|(i, _)| i)
            .collect()
    }

    /// Every line of the section opened at line `start` whose key is
    /// `tag`, with its value (`None`: a line without `=` or value, which
    /// stops LinuxCNC's search), continuation lines joined.
    fn keys_in(&self, start: usize, tag: &str) -> Vec<(usize, Option<String>)> {
        let mut out = Vec::new();
        let mut i = start + 1;
        while i < self.lines.len() {
            let first = i;
            let mut text = self.lines[i].text.clone();
            while text.ends_with('\\') && i + 1 < self.lines.len() {
                text.pop();
                i += 1;
                text.push_str(&self.lines[i].text);
            }
            i += 1;
            let Some(t) = skip_white(&text) else { continue };
            if t.starts_with('[') {
                break;
            }
            let Some(rest) = t.strip_prefix(tag) else {
                continue;
            };
            if !rest.starts_with([' ', '\t', '\r', '=']) {
                continue;
            }
            let value = rest
                .split_once('=')
                .map(|(_, v)| v.trim_matches([' ', '\t', '\r', '\n']));
            out.push((first, value.filter(|v| !v.is_empty()).map(str::to_string)));
        }
        out
    }

    /// `IniFile::Find(tag, section)`: the first key `tag` of the first
    /// section `section`.
    pub fn find(&self, tag: &str, section: &str) -> Option<Found> {
        let start = *self.sections(section).first()?;
        let (line, value) = self.keys_in(start, tag).into_iter().next()?;
        Some(Found {
            value: value?,
            line,
        })
    }

    /// Where the controller does not read a key it might seem to: `tag` in
    /// a later section `[section]`, or again in the first one. One note per
    /// line, naming it and the line LinuxCNC reads instead.
    pub fn ignored(&self, tag: &str, section: &str) -> Vec<String> {
        let starts = self.sections(section);
        let Some(&first) = starts.first() else {
            return Vec::new();
        };
        let read = self.keys_in(first, tag).first().map(|(l, _)| *l);
        let mut notes = Vec::new();
        for (k, &s) in starts.iter().enumerate() {
            for (j, (line, _)) in self.keys_in(s, tag).into_iter().enumerate() {
                if k == 0 && j == 0 {
                    continue;
                }
                let why = if k > 0 {
                    format!(
                        "it is in a second [{section}] section ({}), and LinuxCNC reads only the first ({})",
                        self.place(s),
                        self.place(first)
                    )
                } else {
                    "LinuxCNC reads the first one of a section".to_string()
                };
                let instead = match read {
                    Some(r) => format!("it reads {} instead", self.place(r)),
                    None => format!("[{section}] has no {tag} LinuxCNC reads"),
                };
                notes.push(format!(
                    "{}: [{section}] {tag} is not read by LinuxCNC: {why}; {instead}. Merge the keys into the first section",
                    self.place(line)
                ));
            }
        }
        notes
    }
}

/// The number at the start of `value` as C's `sscanf("%lf")` reads it
/// (decimal; `None` when it does not start with one): `0.002 # mm` is 0.002.
pub(crate) fn leading_f64(value: &str) -> Option<f64> {
    let b = value.trim_start().as_bytes();
    let mut i = 0;
    if i < b.len() && (b[i] == b'+' || b[i] == b'-') {
        i += 1;
    }
    let digits = |i: &mut usize| {
        let s = *i;
        while *i < b.len() && b[*i].is_ascii_digit() {
            *i += 1;
        }
        *i - s
    };
    let mut n = digits(&mut i);
    if i < b.len() && b[i] == b'.' {
        i += 1;
        n += digits(&mut i);
    }
    if n == 0 {
        return None;
    }
    if i < b.len() && (b[i] == b'e' || b[i] == b'E') {
        let mut j = i + 1;
        if j < b.len() && (b[j] == b'+' || b[j] == b'-') {
            j += 1;
        }
        if digits(&mut j) > 0 {
            i = j;
        }
    }
    std::str::from_utf8(&b[..i]).ok()?.parse().ok()
}

/// The integer at the start of `value` as C's `sscanf("%i")` reads it
/// (decimal, `0x` hexadecimal or `0` octal).
pub(crate) fn leading_int(value: &str) -> Option<i64> {
    let t = value.trim_start();
    let (neg, t) = match t.as_bytes().first() {
        Some(b'-') => (true, &t[1..]),
        Some(b'+') => (false, &t[1..]),
        _ => (false, t),
    };
    let (radix, body) = if let Some(h) = t.strip_prefix("0x").or_else(|| t.strip_prefix("0X")) {
        (16, h)
    } else if t.starts_with('0') {
        (8, t)
    } else {
        (10, t)
    };
    let end = body
        .find(|c: char| !c.is_digit(radix))
        .unwrap_or(body.len());
    if end == 0 {
        return None;
    }
    let v = i64::from_str_radix(&body[..end], radix).ok()?;
    Some(if neg { -v } else { v })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ini(text: &str) -> Ini {
        Ini::parse(text, "m.ini", |_| unreachable!()).unwrap()
    }

    #[test]
    fn the_first_section_and_the_first_key_are_read() {
        let i = ini("[JOINT_0]\nBACKLASH = 0.1\nBACKLASH = 0.2\n[JOINT_1]\nX=1\n[JOINT_0]\nBACKLASH = 0.3\nCOMP_FILE = x.comp\n");
        assert_eq!(i.find("BACKLASH", "JOINT_0").unwrap().value, "0.1");
        // The second [JOINT_0] is never read.
        assert_eq!(i.find("COMP_FILE", "JOINT_0"), None);
        let notes = i.ignored("BACKLASH", "JOINT_0");
        assert_eq!(notes.len(), 2, "{notes:?}");
        assert!(notes[0].starts_with("m.ini:3:"), "{notes:?}");
        assert!(
            notes[1].contains("second [JOINT_0] section (m.ini:6)"),
            "{notes:?}"
        );
    }

    #[test]
    fn values_keep_hashes_and_numbers_are_read_from_their_start() {
        let i = ini("[JOINT_0]\n# BACKLASH = 9\n  ; COMP_FILE = y\nCOMP_FILE = x#1.comp  \nBACKLASH=0.002 # mm\nCOMP_FILE_TYPE\t= 0x1\n");
        assert_eq!(i.find("COMP_FILE", "JOINT_0").unwrap().value, "x#1.comp");
        let b = i.find("BACKLASH", "JOINT_0").unwrap();
        assert_eq!((b.value.as_str(), b.line), ("0.002 # mm", 4));
        assert_eq!(leading_f64(&b.value), Some(0.002));
        assert_eq!(
            leading_int(&i.find("COMP_FILE_TYPE", "JOINT_0").unwrap().value),
            Some(1)
        );
        assert_eq!(leading_f64("abc"), None);
        assert_eq!(leading_f64("-1.5e-3x"), Some(-0.0015));
        assert_eq!(leading_int("010"), Some(8));
        // A key must be followed by a blank or `=`: COMP_FILE_TYPE is not COMP_FILE.
        let i = ini("[J]\nCOMP_FILE_TYPE = 1\n");
        assert_eq!(i.find("COMP_FILE", "J"), None);
        // A key line without `=` stops the search.
        let i = ini("[J]\nBACKLASH 1\nBACKLASH = 2\n");
        assert_eq!(i.find("BACKLASH", "J"), None);
        // Continuation lines.
        let i = ini("[J]\nCOMP_FILE = a\\\nb.comp\n[K]\n");
        assert_eq!(i.find("COMP_FILE", "J").unwrap().value, "ab.comp");
    }

    #[test]
    fn includes_are_expanded_from_the_ini_only() {
        let i = Ini::parse("[KINS]\n#INCLUDE joints.inc\n", "m.ini", |n| {
            assert_eq!(n, "joints.inc");
            Ok((
                "dir/joints.inc".into(),
                "JOINTS = 4\n#INCLUDE other.inc\n".into(),
            ))
        })
        .unwrap();
        let f = i.find("JOINTS", "KINS").unwrap();
        assert_eq!(f.value, "4");
        assert_eq!(i.place(f.line), "dir/joints.inc:1");
        let e = Ini::parse("#INCLUDE $HOME/x.inc\n", "m.ini", |_| unreachable!()).unwrap_err();
        assert!(e.to_string().contains("shell"), "{e}");
        let e = Ini::parse("[A]\nB = 1\rC = 2\n", "m.ini", |_| unreachable!()).unwrap_err();
        assert!(e.to_string().contains("carriage return"), "{e}");
    }
}
