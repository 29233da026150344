//! The one reader of every CSV table volcomp takes (axis tables, the
//! 21-component tables, ISO 230-2 runs, thermal files, straightness runs,
//! probe points and surface grids).
//!
//! Rules, the same for every table (RFC 4180 records via the `csv` crate):
//! a UTF-8 byte-order mark is stripped; lines whose first non-blank
//! character is `#` and blank lines are skipped (the `#` lines are kept in
//! [`CsvTable::comments`] for formats that carry `# key = value` metadata);
//! quoted fields are accepted; fields are trimmed; the first record is the
//! header, whose names are matched case-insensitively in any order; a column
//! named twice is refused; unknown columns are refused or kept as the
//! caller says. Every error names file, row and column (the 1-based field
//! number and the header name) and shows the line, bounded and escaped.

use crate::error::MapFileError;
pub use crate::limits::{MAX_TABLE_LINE_BYTES, MAX_TABLE_ROWS};

/// What to do with header names the format does not know.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UnknownColumns {
    /// Refuse the file, naming the column (a misspelt unit must not be
    /// ignored).
    Refuse,
    /// Keep them; the caller looks up only the columns it needs.
    Keep,
}

/// The header a format expects.
#[derive(Debug, Clone, Copy)]
pub struct Header<'a> {
    /// Every name the format knows (lower case), required or not.
    pub known: &'a [&'a str],
    /// Unknown names: refused or kept.
    pub unknown: UnknownColumns,
    /// What the header should look like, for the help of header errors.
    pub layout: &'a str,
}

impl<'a> Header<'a> {
    /// A header whose every column is kept (the reader looks its columns
    /// up itself); `layout` for the help of header errors.
    pub const fn keep_all(layout: &'a str) -> Self {
        Header {
            known: &[],
            unknown: UnknownColumns::Keep,
            layout,
        }
    }
}

/// One data record: its 1-based line; its trimmed fields are read through
/// the table ([`CsvTable::text`], [`CsvTable::fields`]), which holds the
/// fields of every record in one buffer (a table of millions of rows takes
/// a few bytes per field beyond its text).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Record {
    /// 1-based line where the record starts.
    pub line: usize,
    /// Index of its first field in the table's field list.
    first: u32,
    /// Byte offset of its line in the text.
    offset: u32,
}

/// A table read from CSV text (borrowed: the source lines of errors are
/// taken from it).
#[derive(Debug, Clone)]
pub struct CsvTable<'a> {
    /// File name, for errors.
    pub file: String,
    /// 1-based line of the header.
    pub header_line: usize,
    /// Header names, trimmed and lower case.
    pub header: Vec<String>,
    /// `#` lines: 1-based line and the text after `#`, trimmed.
    pub comments: Vec<(usize, String)>,
    /// Data records in file order (see [`CsvTable::records`]).
    records: Vec<Record>,
    /// The first record whose field count differs from the header's,
    /// reported by [`CsvTable::records`] (after the caller's header checks,
    /// so that a missing column is named before a row that lacks it).
    width_error: Option<MapFileError>,
    /// The text (after a byte-order mark).
    text: &'a str,
    /// The trimmed fields of every record, one after the other.
    fields: String,
    /// End of each field in `fields`.
    ends: Vec<u32>,
}

/// The hint for a file that uses `;` between fields (a spreadsheet saved
/// with a decimal-comma locale).
const SEMICOLON_HINT: &str = "the file uses ';' as separator: volcomp reads comma-separated values with '.' decimals; export it as CSV with ',' between fields and '.' in numbers";

/// Decodes `bytes` as UTF-8 (after a byte-order mark), locating the first
/// invalid byte by line and column.
///
/// ```
/// use volcomp_core::io::table::utf8;
/// let e = utf8(b"a,b\n1,\xff\n", "t.csv").unwrap_err();
/// assert_eq!((e.row, e.column), (2, 3));
/// ```
pub fn utf8<'a>(bytes: &'a [u8], file: &str) -> Result<&'a str, MapFileError> {
    let bytes = bytes.strip_prefix(b"\xef\xbb\xbf").unwrap_or(bytes);
    std::str::from_utf8(bytes).map_err(|e| {
        let at = e.valid_up_to();
        let before = &bytes[..at];
        let row = before.iter().filter(|&&b| b == b'\n').count() + 1;
        let line_start = before
            .iter()
            .rposition(|&b| b == b'\n')
            .map_or(0, |i| i + 1);
        let line_end = bytes[at..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(bytes.len(), |i| at + i);
        let line = String::from_utf8_lossy(&bytes[line_start..line_end]);
        let column = String::from_utf8_lossy(&bytes[line_start..at])
            .chars()
            .count()
            + 1;
        MapFileError::new(
            file,
            row,
            column,
            format!("byte 0x{:02x} is not UTF-8 text", bytes[at]),
            "save the file as UTF-8 (plain text); volcomp does not guess a text encoding",
        )
        .with_source(&line, at - line_start)
    })
}

/// The `#` lines of a table: 1-based line and the text after `#`, trimmed
/// (formats such as straightness runs carry `# key = value` metadata).
pub fn comment_lines(text: &str) -> Vec<(usize, String)> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    text.split('\n')
        .enumerate()
        .filter_map(|(i, l)| {
            l.trim_start()
                .strip_prefix('#')
                .map(|c| (i + 1, c.trim().to_string()))
        })
        .collect()
}

/// Byte offset of field `k` (0-based) in a CSV line, honouring quotes.
fn field_offset(line: &str, k: usize) -> usize {
    let mut field = 0;
    let mut quoted = false;
    for (i, c) in line.char_indices() {
        if field == k {
            return i + (line[i..].len() - line[i..].trim_start().len());
        }
        match c {
            '"' => quoted = !quoted,
            ',' if !quoted => field += 1,
            _ => {}
        }
    }
    line.len()
}

impl<'a> CsvTable<'a> {
    /// Reads CSV text. `file` names it in errors.
    ///
    /// ```
    /// use volcomp_core::io::table::{CsvTable, Header, UnknownColumns};
    /// let h = Header { known: &["x_mm", "name"], unknown: UnknownColumns::Refuse, layout: "x_mm,name" };
    /// let t = CsvTable::parse("\u{feff}# made by hand\nName, X_mm\n\"a, b\",1.5\n", "t.csv", &h).unwrap();
    /// let x = t.require("x_mm").unwrap();
    /// let r = &t.records().unwrap()[0];
    /// assert_eq!(t.number(r, x).unwrap(), 1.5);
    /// assert_eq!(t.text(r, 0), "a, b");
    /// let e = t.require("y_mm");
    /// assert!(e.is_err());
    /// ```
    pub fn parse(
        text: &'a str,
        file: &str,
        header: &Header<'_>,
    ) -> Result<CsvTable<'a>, MapFileError> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let comments = comment_lines(text);
        let mut table = CsvTable {
            file: file.to_string(),
            header_line: 0,
            header: Vec::new(),
            comments,
            records: Vec::new(),
            width_error: None,
            text,
            fields: String::new(),
            ends: Vec::new(),
        };
        table.check_size()?;
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .trim(csv::Trim::All)
            .from_reader(text.as_bytes());
        let mut record = csv::StringRecord::new();
        loop {
            let more = reader.read_record(&mut record).map_err(|e| {
                let line = e.position().map_or(1, |p| p.line() as usize);
                table.error_at(
                    line,
                    0,
                    format!("unreadable CSV record: {e}"),
                    "close every quoted field with a \"; write \"\" for a quote inside one",
                )
            })?;
            if !more {
                break;
            }
            let (line, offset) = record
                .position()
                .map_or((1, 0), |p| (p.line() as usize, p.byte() as usize));
            if record.iter().all(str::is_empty)
                || record.get(0).is_some_and(|f| f.starts_with('#'))
                || text[offset.min(text.len())..].trim_start().starts_with('#')
            {
                continue;
            }
            if table.header_line == 0 {
                table.set_header(line, &record, header)?;
                continue;
            }
            let width = table.header.len();
            if record.len() != width {
                let help = if record.len() > width {
                    "give one value per header column; if the numbers use decimal commas (1,5), write them with '.' (1.5)"
                } else {
                    "give one value per header column, separated by commas"
                };
                if table.width_error.is_none() {
                    table.width_error = Some(table.error_at(
                        line,
                        record.len().min(width),
                        format!("{} fields where the header has {width}", record.len()),
                        help,
                    ));
                }
                continue;
            }
            if table.records.len() >= MAX_TABLE_ROWS {
                return Err(table.error_at(
                    line,
                    0,
                    format!("the table has more than {MAX_TABLE_ROWS} rows, the most a table may have"),
                    "resample it more coarsely (a million points per axis is finer than a micrometre along a metre) or split it",
                ));
            }
            table.records.push(Record {
                line,
                first: table.ends.len() as u32,
                // check_size keeps offsets within u32.
                offset: offset as u32,
            });
            for f in record.iter() {
                table.fields.push_str(f);
                table.ends.push(table.fields.len() as u32);
            }
        }
        if table.header_line == 0 {
            return Err(MapFileError::new(
                file,
                1,
                1,
                "the file has no header",
                format!("start with the header line {}", header.layout),
            ));
        }
        Ok(table)
    }

    /// Refuses a text larger than the table reader holds (2 GiB: offsets
    /// and field indices are 32 bits) and, at its line, a line longer than
    /// [`MAX_TABLE_LINE_BYTES`] (a table's line is a few numbers; a huge one
    /// is not a table, and would be held whole while it is split).
    fn check_size(&self) -> Result<(), MapFileError> {
        if self.text.len() >= i32::MAX as usize {
            return Err(MapFileError::new(
                &self.file,
                1,
                1,
                format!(
                    "the table is {} bytes long, more than the 2 GiB a table may have",
                    self.text.len()
                ),
                "split it, or resample it more coarsely",
            ));
        }
        let bytes = self.text.as_bytes();
        let mut start = 0;
        let ends = memchr::memchr_iter(b'\n', bytes).chain(std::iter::once(bytes.len()));
        for (line, end) in (1..).zip(ends) {
            if end - start > MAX_TABLE_LINE_BYTES {
                return Err(MapFileError::new(
                    &self.file,
                    line,
                    1,
                    format!(
                        "line {line} is {} bytes long, more than the {} a line of a table may have",
                        end - start,
                        MAX_TABLE_LINE_BYTES
                    ),
                    "this is not a table of values (one row per line): check the file",
                )
                .with_source(&self.text[start..start + 200.min(end - start)], 0));
            }
            start = end + 1;
        }
        Ok(())
    }

    fn set_header(
        &mut self,
        line: usize,
        record: &csv::StringRecord,
        spec: &Header<'_>,
    ) -> Result<(), MapFileError> {
        self.header_line = line;
        let names: Vec<String> = record.iter().map(|f| f.to_ascii_lowercase()).collect();
        if names.len() == 1 && names[0].contains(';') {
            return Err(self.error_at(
                line,
                0,
                format!(
                    "the header `{}` is one field",
                    shown(record.get(0).unwrap_or(""))
                ),
                SEMICOLON_HINT,
            ));
        }
        let mut seen: std::collections::HashMap<&str, usize> = std::collections::HashMap::new();
        for (c, name) in names.iter().enumerate() {
            if let Some(&first) = seen.get(name.as_str()) {
                return Err(self.error_at(
                    line,
                    c,
                    format!(
                        "column `{name}` appears twice (first as column {})",
                        first + 1
                    ),
                    "name each column once",
                ));
            }
            seen.insert(name.as_str(), c);
            if spec.unknown == UnknownColumns::Refuse && !spec.known.contains(&name.as_str()) {
                let help = if name.contains(';') {
                    SEMICOLON_HINT.to_string()
                } else {
                    format!(
                        "the header names {} (units are part of the names)",
                        spec.layout
                    )
                };
                return Err(self.error_at(
                    line,
                    c,
                    format!("unknown column `{}`", shown(name)),
                    help,
                ));
            }
        }
        self.header = names;
        Ok(())
    }

    /// The data records in file order, or the error for the first record
    /// whose field count differs from the header's.
    pub fn records(&self) -> Result<&[Record], MapFileError> {
        match &self.width_error {
            Some(e) => Err(e.clone()),
            None => Ok(&self.records),
        }
    }

    /// The 0-based index of column `name` (lower case), if present.
    pub fn column(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|h| h == name)
    }

    /// The 0-based index of the first of `names` present.
    pub fn column_of(&self, names: &[&str]) -> Option<usize> {
        names.iter().find_map(|n| self.column(n))
    }

    /// The 0-based index of column `name`, or an error naming it.
    pub fn require(&self, name: &str) -> Result<usize, MapFileError> {
        self.column(name).ok_or_else(|| self.missing(name, ""))
    }

    /// The error for a missing column `name`; `meaning` says what it holds.
    pub fn missing(&self, name: &str, meaning: &str) -> MapFileError {
        let what = if meaning.is_empty() {
            String::new()
        } else {
            format!(" ({meaning})")
        };
        let raw = self.source(self.header_line);
        let help = if raw.contains(';') && !raw.contains(',') {
            SEMICOLON_HINT.to_string()
        } else {
            format!("the header names {}", self.layout_hint())
        };
        MapFileError::new(
            &self.file,
            self.header_line,
            self.header.len() + 1,
            format!("the header has no `{name}` column{what}"),
            help,
        )
        .with_source(raw, raw.len())
    }

    fn layout_hint(&self) -> String {
        format!("its columns by name; found {}", self.header.join(","))
    }

    /// The text of 1-based `line` (without its line ending; empty past the
    /// end).
    fn source(&self, line: usize) -> &str {
        let start = match self.records.binary_search_by_key(&line, |r| r.line) {
            Ok(i) => self.records[i].offset as usize,
            Err(_) if line <= 1 => 0,
            Err(_) => match memchr::memchr_iter(b'\n', self.text.as_bytes()).nth(line - 2) {
                Some(i) => i + 1,
                None => return "",
            },
        };
        let rest = &self.text[start.min(self.text.len())..];
        let end = memchr::memchr(b'\n', rest.as_bytes()).unwrap_or(rest.len());
        let l = &rest[..end];
        l.strip_suffix('\r').unwrap_or(l)
    }

    /// An error at `line` and 0-based column `col` (reported 1-based, with
    /// the header name when there is one), showing the line.
    pub fn error_at(
        &self,
        line: usize,
        col: usize,
        message: impl Into<String>,
        help: impl Into<String>,
    ) -> MapFileError {
        let message = match self.header.get(col) {
            Some(name) if line != self.header_line => {
                format!("column {} `{name}`: {}", col + 1, message.into())
            }
            _ => message.into(),
        };
        let src = self.source(line);
        MapFileError::new(&self.file, line, col + 1, message, help)
            .with_source(src, field_offset(src, col))
    }

    /// The error for a record's field.
    pub fn error(
        &self,
        record: &Record,
        col: usize,
        message: impl Into<String>,
        help: impl Into<String>,
    ) -> MapFileError {
        self.error_at(record.line, col, message, help)
    }

    /// The text of a record's field.
    pub fn text(&self, record: &Record, col: usize) -> &str {
        if col >= self.header.len() {
            return "";
        }
        let i = record.first as usize + col;
        let start = if i == 0 { 0 } else { self.ends[i - 1] as usize };
        &self.fields[start..self.ends[i] as usize]
    }

    /// The trimmed fields of a record, one per header column.
    pub fn fields<'t>(&'t self, record: &Record) -> impl Iterator<Item = &'t str> + 't {
        let record = *record;
        (0..self.header.len()).map(move |c| self.text(&record, c))
    }

    /// A finite number; the error names the unit the column's name gives
    /// (`_mm`, `_um`, `_urad`, `_h`, `_c`, …).
    pub fn number(&self, record: &Record, col: usize) -> Result<f64, MapFileError> {
        let raw = self.text(record, col);
        if let Ok(v) = raw.parse::<f64>() {
            if v.is_finite() {
                return Ok(v);
            }
        }
        // The error's words only when there is an error.
        let text = shown(raw);
        let unit = self.header.get(col).and_then(|h| unit_of(h));
        let in_unit = unit.map_or(String::new(), |u| format!(" in {u}"));
        match raw.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(_) => Err(self.error(
                record,
                col,
                format!("`{text}` is not a finite number"),
                format!("write the measured value{in_unit}; remove NaN/inf values"),
            )),
            Err(_) if raw.is_empty() => Err(self.error(
                record,
                col,
                "the value is missing",
                format!("write a decimal number{in_unit} such as -1.25"),
            )),
            Err(_) => {
                let help = if text.contains(',') {
                    "write numbers with '.' decimals (1.5, not 1,5)".to_string()
                } else {
                    format!("write a decimal number{in_unit} such as -1.25")
                };
                Err(self.error(record, col, format!("`{text}` is not a number"), help))
            }
        }
    }

    /// A whole number (may be negative).
    pub fn integer(&self, record: &Record, col: usize) -> Result<i64, MapFileError> {
        self.whole(record, col, "a whole number")
    }

    /// A whole number ≥ 0.
    pub fn index(&self, record: &Record, col: usize) -> Result<usize, MapFileError> {
        self.whole(record, col, "a whole number ≥ 0")
    }

    /// A whole number of type `T`, refused as not `what`.
    fn whole<T: std::str::FromStr>(
        &self,
        record: &Record,
        col: usize,
        what: &str,
    ) -> Result<T, MapFileError> {
        let text = self.text(record, col);
        text.parse::<T>().map_err(|_| {
            let text = shown(text);
            self.error(
                record,
                col,
                format!("`{text}` is not {what}"),
                "write an integer such as 3",
            )
        })
    }

    /// The last line of the file that holds a record (or the header).
    pub fn last_line(&self) -> usize {
        self.records
            .last()
            .map_or(self.header_line.max(1), |r| r.line)
    }
}

/// A field's text as shown in a message: at most 40 characters, control
/// characters escaped.
pub fn shown(text: &str) -> String {
    let (mut s, _) = volcomp_gcode::error::excerpt(text.as_bytes(), 0);
    if s.chars().count() > 40 {
        s = s.chars().take(40).collect::<String>() + "…";
    }
    s
}

/// The unit a column name ends in, spelled out.
pub fn unit_of(name: &str) -> Option<&'static str> {
    let (_, suffix) = name.rsplit_once('_')?;
    Some(match suffix {
        "mm" => "mm",
        "um" => "µm",
        "urad" => "µrad",
        "in" | "inch" => "inch",
        "h" => "hours",
        "c" => "°C",
        "k" => "K",
        "s" => "seconds",
        "min" => "mm/min",
        _ => return None,
    })
}

/// `X,Y,Z`: three finite numbers.
pub fn parse_triple(text: &str) -> Option<[f64; 3]> {
    let v: Vec<f64> = text
        .split(',')
        .map(|p| p.trim().parse::<f64>().ok().filter(|x| x.is_finite()))
        .collect::<Option<_>>()?;
    <[f64; 3]>::try_from(v).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    const H: Header<'static> = Header {
        known: &["a_mm", "b_um"],
        unknown: UnknownColumns::Refuse,
        layout: "a_mm,b_um",
    };

    #[test]
    fn bom_quotes_order_and_case() {
        let t = CsvTable::parse(
            "\u{feff}B_UM , a_mm\r\n\"2\",1\r\n\n  # c\n3,4\n",
            "t.csv",
            &H,
        )
        .unwrap();
        let (a, b) = (t.require("a_mm").unwrap(), t.require("b_um").unwrap());
        assert_eq!((a, b), (1, 0));
        assert_eq!(t.records().unwrap().len(), 2);
        assert_eq!(t.number(&t.records().unwrap()[0], b).unwrap(), 2.0);
        assert_eq!(t.records().unwrap()[1].line, 5);
        assert_eq!(t.comments, vec![(4, "c".to_string())]);
    }

    #[test]
    fn errors_name_row_column_and_header() {
        let t = CsvTable::parse("a_mm,b_um\n1,x\n", "t.csv", &H).unwrap();
        let e = t.number(&t.records().unwrap()[0], 1).unwrap_err();
        assert_eq!((e.row, e.column), (2, 2));
        let s = e.to_string();
        assert!(
            s.starts_with("t.csv:2:2: column 2 `b_um`: `x` is not a number"),
            "{s}"
        );
        assert!(s.contains("in µm"), "{s}");
        assert!(s.contains("2 | 1,x\n  |   ^"), "{s}");
    }

    #[test]
    fn duplicate_unknown_and_missing_columns() {
        let e = CsvTable::parse("a_mm,A_MM\n", "t.csv", &H).unwrap_err();
        assert_eq!((e.row, e.column), (1, 2));
        assert!(e.message.contains("twice"));
        let e = CsvTable::parse("a_mm,c\n", "t.csv", &H).unwrap_err();
        assert_eq!((e.row, e.column), (1, 2));
        let keep = Header {
            unknown: UnknownColumns::Keep,
            ..H
        };
        let t = CsvTable::parse("a_mm,c\n", "t.csv", &keep).unwrap();
        let e = t.require("b_um").unwrap_err();
        assert!(e.message.contains("`b_um`"));
        assert!(CsvTable::parse("# only\n", "t.csv", &H).is_err());
    }

    #[test]
    fn semicolons_and_decimal_commas_get_a_hint() {
        let e = CsvTable::parse("a_mm;b_um\n1,5;2\n", "t.csv", &H).unwrap_err();
        assert!(e.help.contains("';' as separator"), "{e}");
        let t = CsvTable::parse("a_mm,b_um\n1,5,2\n", "t.csv", &H).unwrap();
        let e = t.records().unwrap_err();
        assert_eq!((e.row, e.column), (2, 3));
        assert!(e.help.contains("decimal commas"), "{e}");
    }

    #[test]
    fn excerpts_are_bounded_and_escaped() {
        let long = format!("a_mm,b_um\n1,\u{1b}]0;{}\n", "9".repeat(100_000));
        let t = CsvTable::parse(&long, "t.csv", &H).unwrap();
        let s = t
            .number(&t.records().unwrap()[0], 1)
            .unwrap_err()
            .to_string();
        assert!(!s.contains('\u{1b}'));
        assert!(s.contains("\\x1b"));
        assert!(s.len() < 1000, "{}", s.len());
    }

    #[test]
    fn non_utf8_is_located() {
        let e = utf8(b"a_mm,b_um\n1,2\n3,\xe9\n", "t.csv").unwrap_err();
        assert_eq!((e.row, e.column), (3, 3));
        assert_eq!(utf8(b"\xef\xbb\xbfa", "t").unwrap(), "a");
    }
}
