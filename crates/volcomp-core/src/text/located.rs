//! Where a value of a TOML text is, for errors located in the file that
//! holds the bad value (row, column and the line with a caret).
//!
//! Readers that deserialise a whole file with serde keep no spans; when a
//! value read that way is refused (not finite, out of its range, the wrong
//! count), [`key_error`] finds its key in the text — in the top level, in a
//! `[table]` or in the n-th `[[array]]` entry — and locates the error there.

use crate::error::MapFileError;

/// 1-based row and column (in characters) of byte `offset` of `text`.
pub fn row_col(text: &str, offset: usize) -> (usize, usize) {
    let mut offset = offset.min(text.len());
    while !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let before = &text[..offset];
    let row = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    (row, before[line_start..].chars().count() + 1)
}

/// The part of a TOML text a key is looked for in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scope<'a> {
    /// The keys before the first table header.
    Top,
    /// The table `[name]`.
    Table(&'a str),
    /// The `index`-th (0-based) entry `[[name]]` of an array of tables.
    Entry(&'a str, usize),
}

/// The byte offset of the value of `key` in `scope`, if the key is written
/// there as `key = value` on a line of its own (as volcomp writes every file,
/// and as people write them by hand).
pub fn value_offset(text: &str, scope: Scope<'_>, key: &str) -> Option<usize> {
    let mut in_scope = scope == Scope::Top;
    let mut entries = 0usize;
    let mut at = 0usize;
    for line in text.split_inclusive('\n') {
        let start = at;
        at += line.len();
        let t = line.trim_start();
        if t.starts_with('[') {
            let header = t.trim_end();
            in_scope = match scope {
                Scope::Top => false,
                Scope::Table(name) => header.starts_with(&format!("[{name}]")),
                Scope::Entry(name, index) => {
                    if header.starts_with(&format!("[[{name}]]")) {
                        entries += 1;
                        entries == index + 1
                    } else {
                        false
                    }
                }
            };
            continue;
        }
        if !in_scope {
            continue;
        }
        let bare = t.strip_prefix(key);
        let quoted = t.strip_prefix(&format!("\"{key}\""));
        if let Some(value) = bare
            .or(quoted)
            .and_then(|rest| rest.trim_start().strip_prefix('='))
        {
            return Some(start + line.len() - value.trim_start().len());
        }
    }
    None
}

/// An error at the value of `key` in `scope` of `text` (at the file's first
/// line when the key is not written there), showing its line.
pub fn key_error(
    file: &str,
    text: &str,
    scope: Scope<'_>,
    key: &str,
    message: impl Into<String>,
    help: impl Into<String>,
) -> MapFileError {
    at_offset(file, text, value_offset(text, scope, key), message, help)
}

/// An error at byte `offset` of `text` (the first line when `None`),
/// showing its line.
pub fn at_offset(
    file: &str,
    text: &str,
    offset: Option<usize>,
    message: impl Into<String>,
    help: impl Into<String>,
) -> MapFileError {
    let offset = offset.unwrap_or(0).min(text.len());
    let (row, column) = row_col(text, offset);
    let line_start = text[..offset].rfind('\n').map_or(0, |i| i + 1);
    let line = text[line_start..].lines().next().unwrap_or("");
    MapFileError::new(file, row, column, message, help).with_source(line, offset - line_start)
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "model = \"x\"\noffset_um = nan\n[x]\nstart_mm = 1\n\
                        [[params]]\nintercept = 1\n[[params]]\n  intercept  =  nan\n";

    #[test]
    fn keys_are_found_in_their_scope() {
        let at = |s, k| value_offset(TEXT, s, k).map(|o| row_col(TEXT, o));
        assert_eq!(at(Scope::Top, "offset_um"), Some((2, 13)));
        assert_eq!(at(Scope::Table("x"), "start_mm"), Some((4, 12)));
        assert_eq!(at(Scope::Entry("params", 1), "intercept"), Some((8, 17)));
        assert_eq!(at(Scope::Entry("params", 0), "intercept"), Some((6, 13)));
        assert_eq!(at(Scope::Top, "start_mm"), None);
    }

    #[test]
    fn the_error_shows_the_line_with_a_caret() {
        let e = key_error(
            "t.toml",
            TEXT,
            Scope::Entry("params", 1),
            "intercept",
            "not finite",
            "write a number",
        );
        assert_eq!((e.row, e.column), (8, 17));
        let s = e.to_string();
        assert!(s.starts_with("t.toml:8:17: not finite"), "{s}");
        // The caret under the value's first character (16 characters in).
        let caret = format!("8 |   intercept  =  nan\n  | {}^", " ".repeat(16));
        assert!(s.contains(&caret), "{s}");
    }
}
