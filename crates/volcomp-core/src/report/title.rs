//! The title block of a report: who the part is for and what it is (the
//! customer, the order, the part and its drawing, the machine, the
//! tolerance, the operator), read from a small TOML file the user keeps
//! beside the job (docs/report.md, "Title block"). Every key is optional;
//! the values are printed as written, in a fixed order, at the top of the
//! report's first page, the way a drawing's title block sits in its corner.

use crate::error::MapFileError;
use crate::Error;
use std::path::Path;

/// The keys of a title block, in the order the report prints them, with
/// the heading each is printed under.
pub const KEYS: &[(&str, &str)] = &[
    ("customer", "customer"),
    ("order", "order"),
    ("part", "part"),
    ("drawing", "drawing"),
    ("revision", "revision"),
    ("material", "material"),
    ("machine", "machine"),
    ("tolerance", "tolerance"),
    ("operator", "operator"),
    ("notes", "notes"),
];

/// The largest title-block file read (bytes): a title block is a few lines.
pub const MAX_BYTES: u64 = 64 * 1024;

/// A title block: `(heading, value)` rows in the order of [`KEYS`], only
/// the keys the file gave.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct TitleBlock {
    /// The rows.
    pub rows: Vec<(String, String)>,
}

fn row_col(text: &str, at: usize) -> (usize, usize) {
    let before = &text[..at.min(text.len())];
    let row = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (row, col)
}

const HELP: &str = "a title block is TOML with text values, e.g. customer = \"Acme\"; keys: customer, order, part, drawing, revision, material, machine, tolerance, operator, notes (docs/report.md)";

impl TitleBlock {
    /// Reads a title block from `text` (the file `file`): a TOML table of
    /// text values under the keys of [`KEYS`]. Anything else (an unknown
    /// key, a number, a table) is refused at its line and column.
    pub fn parse(text: &str, file: &str) -> Result<Self, MapFileError> {
        let table: toml::Spanned<toml::Table> = toml::from_str(text).map_err(|e| {
            let (row, col) = e.span().map_or((1, 1), |s| row_col(text, s.start));
            MapFileError::new(file, row, col, e.message().trim().to_string(), HELP)
        })?;
        // Locate a key by its first occurrence at the start of a line.
        let at = |key: &str| -> (usize, usize) {
            let mut offset = 0;
            for line in text.split_inclusive('\n') {
                let t = line.trim_start();
                if t.strip_prefix(key)
                    .is_some_and(|r| r.trim_start().starts_with('='))
                {
                    return row_col(text, offset + line.len() - t.len());
                }
                offset += line.len();
            }
            (1, 1)
        };
        let table = table.into_inner();
        for (key, value) in &table {
            if !KEYS.iter().any(|(k, _)| k == key) {
                let (row, col) = at(key);
                return Err(MapFileError::new(
                    file,
                    row,
                    col,
                    format!("`{key}` is not a title-block key"),
                    HELP,
                ));
            }
            if !value.is_str() {
                let (row, col) = at(key);
                return Err(MapFileError::new(
                    file,
                    row,
                    col,
                    format!("`{key}` is a {}, not text", value.type_str()),
                    format!("write it in quotes: {key} = \"…\""),
                ));
            }
        }
        let rows = KEYS
            .iter()
            .filter_map(|(key, heading)| {
                table
                    .get(*key)
                    .and_then(|v| v.as_str())
                    .map(|v| (heading.to_string(), v.trim().to_string()))
            })
            .collect();
        Ok(Self { rows })
    }

    /// Reads the title-block file at `path` (at most [`MAX_BYTES`]).
    pub fn read(path: &Path) -> Result<Self, Error> {
        let bytes = volcomp_geom::inputs::read_at_most(path, "the title block", MAX_BYTES)
            .map_err(|e| Error::io(path, e))?;
        let file = path.display().to_string();
        let text = String::from_utf8(bytes).map_err(|e| {
            let valid = e.utf8_error().valid_up_to();
            let text = String::from_utf8_lossy(e.as_bytes());
            let (row, col) = row_col(&text, valid);
            MapFileError::new(&file, row, col, "not UTF-8 text", HELP)
        })?;
        Ok(Self::parse(&text, &file)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_are_kept_in_the_reports_order_whatever_the_files() {
        let t = TitleBlock::parse(
            "tolerance = \"±10 µm\"\ncustomer = \"Acme Moulds\"\npart = \"insert 4\"\n",
            "t.toml",
        )
        .unwrap();
        assert_eq!(
            t.rows,
            vec![
                ("customer".to_string(), "Acme Moulds".to_string()),
                ("part".to_string(), "insert 4".to_string()),
                ("tolerance".to_string(), "±10 µm".to_string()),
            ]
        );
    }

    #[test]
    fn a_bad_file_is_refused_at_its_line_and_column() {
        let e = TitleBlock::parse("customer = \"A\"\n  custmer = \"B\"\n", "t.toml").unwrap_err();
        assert_eq!((e.row, e.column), (2, 3), "{e}");
        assert!(
            e.message.contains("`custmer` is not a title-block key"),
            "{e}"
        );
        let e = TitleBlock::parse("part = \"p\"\ntolerance = 0.01\n", "t.toml").unwrap_err();
        assert_eq!((e.row, e.column), (2, 1), "{e}");
        assert!(
            e.message.contains("`tolerance` is a float, not text"),
            "{e}"
        );
        let e = TitleBlock::parse("part = \"p\"\ndrawing = \"D-1\n", "t.toml").unwrap_err();
        assert_eq!(e.row, 2, "{e}");
        assert_eq!(e.file, "t.toml");
    }
}
