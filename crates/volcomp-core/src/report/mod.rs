//! Reports people hand on: one self-contained HTML file per run, with what
//! was done and with what (the inputs and their SHA-256, the set-up, the
//! method and options, volcomp's version, the date), the figures in tables
//! and the pictures as inline SVG.
//!
//! Everything here is a pure function from results to strings: no terminal,
//! no network, no file written (a front end writes the string through
//! [`crate::io::output`]). The HTML needs no script and names no external
//! resource, so it reads the same offline, archived or printed: the style
//! sheet sets A4 pages and starts every section on a new page (CSS Paged
//! Media, [CSS Fragmentation 3] `break-before`).
//!
//! * [`svg`]: the charts (x–y with legends below the data, plan views on
//!   one colour scale with a colour bar, histograms);
//! * [`trace`]: what a report keeps of a simulated program, bounded in
//!   memory, peaks kept;
//! * [`compensation`]: the sections of a compensation or a simulation
//!   (before/after tables, plan view, error along the path, histogram,
//!   largest corrections, held axes and warnings).

pub mod charts;
pub mod columns;
pub mod compensation;
pub mod demo;
pub mod iso230_2;
pub mod machining_time;
pub mod map;
pub mod mirror;
pub mod probe;
pub mod svg;
pub mod text;
pub mod title;
pub mod trace;

use crate::error::Error;
use std::fmt::Write as _;
use std::io::Read;
use std::path::Path;
use svg::escape;

/// A file a run read, identified by its SHA-256.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct InputFile {
    /// What the file was to the run (`program`, `map`, `set-up`, …).
    pub role: String,
    /// Its name as the user gave it.
    pub name: String,
    /// Its size (bytes), when known.
    pub bytes: Option<u64>,
    /// Its SHA-256, lower-case hex (FIPS 180-4).
    pub sha256: String,
}

impl InputFile {
    /// Reads `path` once to size and hash it.
    pub fn read(role: impl Into<String>, path: &Path) -> Result<Self, Error> {
        use sha2::Digest as _;
        let role = role.into();
        let mut f = crate::io::inputs::open(path, &format!("the {role}"))
            .map_err(|e| Error::io(path, e))?;
        let mut hasher = sha2::Sha256::new();
        let mut buf = vec![0u8; 1 << 16];
        let mut bytes = 0u64;
        loop {
            let n = f.read(&mut buf).map_err(|e| Error::io(path, e))?;
            if n == 0 {
                break;
            }
            bytes += n as u64;
            hasher.update(&buf[..n]);
        }
        Ok(Self {
            role,
            name: path.display().to_string(),
            bytes: Some(bytes),
            sha256: hasher
                .finalize()
                .iter()
                .map(|b| format!("{b:02x}"))
                .collect(),
        })
    }

    /// An input held in memory (standard input, or a file already read).
    pub fn from_bytes(role: impl Into<String>, name: impl Into<String>, data: &[u8]) -> Self {
        Self {
            role: role.into(),
            name: name.into(),
            bytes: Some(data.len() as u64),
            sha256: crate::io::provenance::sha256_hex(data),
        }
    }
}

/// A table; cells are plain text (escaped when rendered).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Table {
    /// Column headings (with units).
    pub headers: Vec<String>,
    /// Rows of cells.
    pub rows: Vec<Vec<String>>,
    /// Columns aligned right (numbers).
    pub numeric: Vec<bool>,
}

impl Table {
    /// A table with these headings, `numeric[i]` for each column aligned
    /// right (none when empty), and these rows.
    pub fn new(headers: &[&str], numeric: &[bool], rows: Vec<Vec<String>>) -> Self {
        Self {
            headers: headers.iter().map(|h| h.to_string()).collect(),
            rows,
            numeric: numeric.to_vec(),
        }
    }
}

/// One piece of a section.
#[derive(Debug, Clone, PartialEq)]
pub enum Block {
    /// A paragraph of plain text.
    Text(String),
    /// A table.
    Table(Table),
    /// An inline SVG drawing (from [`svg`]) and its caption.
    Figure {
        /// The `<svg>` element.
        svg: String,
        /// What it shows.
        caption: String,
    },
    /// Program lines, quoted: `(line number, text)`.
    Lines(Vec<(u64, String)>),
}

/// A section: a page of the printed report.
#[derive(Debug, Clone, PartialEq)]
pub struct Section {
    /// Anchor (letters, digits, '-').
    pub id: String,
    /// Heading.
    pub title: String,
    /// Content, in order.
    pub blocks: Vec<Block>,
}

/// A whole report.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Document {
    /// The title.
    pub title: String,
    /// What was done and with what: `(what, value)` rows of the first
    /// section (version, date, command, method, options, set-up).
    pub facts: Vec<(String, String)>,
    /// The files read.
    pub inputs: Vec<InputFile>,
    /// The sections after the first.
    pub sections: Vec<Section>,
    /// The title block (customer, part, drawing, …), printed above
    /// everything else on the first page; empty: none.
    pub title_block: title::TitleBlock,
    /// What the first page says once for the whole document after the
    /// inputs (e.g. the definitions of the metrics every section uses).
    pub front: Vec<Block>,
}

/// The style sheet: A4 pages with the page number in the bottom margin
/// (`@page` margin boxes and the `page`/`pages` counters, CSS Paged Media
/// 3 §5, printed by Chromium since version 131), one section per page,
/// headings kept with what follows them, tables and figures kept whole; on
/// a narrow (phone) screen drawings keep a readable width and scroll
/// sideways rather than shrink their text. The running title at the bottom
/// left is added per document ([`Document::to_html`]).
const CSS: &str = r#"
@page { size: A4; margin: 15mm 14mm 17mm 14mm;
  @bottom-right { content: "page " counter(page) " of " counter(pages); font: 8.5pt "DejaVu Sans", Helvetica, Arial, sans-serif; color: #444; }
}
* { box-sizing: border-box; }
body { font-family: "DejaVu Sans", Helvetica, Arial, sans-serif; font-size: 11pt; color: #111; margin: 0 auto; max-width: 190mm; padding: 8px; line-height: 1.35; }
h1 { font-size: 17pt; margin: 0 0 4px 0; }
h2 { font-size: 14pt; border-bottom: 2px solid #0072B2; padding-bottom: 2px; margin: 0 0 8px 0; break-after: avoid; page-break-after: avoid; }
h2 .no { color: #0072B2; margin-right: 0.4em; }
section { margin-bottom: 28px; }
section + section { break-before: page; page-break-before: always; }
table { border-collapse: collapse; margin: 6px 0 10px 0; font-size: 9.5pt; break-inside: avoid; }
th, td { border: 1px solid #bbb; padding: 2px 6px; text-align: left; vertical-align: top; }
th { background: #eef3f8; }
td.n { text-align: right; font-variant-numeric: tabular-nums; }
td.h { font-family: "DejaVu Sans Mono", monospace; font-size: 8pt; word-break: break-all; }
table.titleblock { border: 2px solid #111; margin: 8px 0 14px 0; min-width: 60%; }
table.titleblock th { width: 9em; background: #f4f4f4; font-weight: normal; color: #333; }
table.titleblock td { font-weight: bold; }
figure { margin: 6px 0 14px 0; break-inside: avoid; }
figure svg { display: block; width: 100%; height: auto; }
figcaption { font-size: 9.5pt; color: #333; margin-top: 2px; }
p { orphans: 3; widows: 3; }
pre { font-family: "DejaVu Sans Mono", monospace; font-size: 8.5pt; background: #f6f6f6; padding: 4px 6px; white-space: pre-wrap; word-break: break-all; }
nav.contents ol { margin: 4px 0; padding-left: 26px; }
.table-wrap { overflow-x: auto; }
figure { overflow-x: auto; }
@media (max-width: 600px) { body { font-size: 10pt; } figure svg { min-width: 560px; } }
@media print { .table-wrap, figure { overflow: visible; } figure svg { min-width: 0; } nav.contents a { color: inherit; text-decoration: none; } }
"#;

/// `text` as a CSS string literal that is safe inside `<style>`.
fn css_string(text: &str) -> String {
    let mut out = String::from("\"");
    for c in text.chars() {
        match c {
            '"' | '\\' | '<' | '>' | '&' => {
                let _ = write!(out, "\\{:x} ", c as u32);
            }
            c if c.is_control() => out.push(' '),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

fn anchor(id: &str) -> String {
    id.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .collect()
}

fn table_html(out: &mut String, t: &Table) {
    out.push_str("<div class=\"table-wrap\"><table>");
    if !t.headers.is_empty() {
        out.push_str("<thead><tr>");
        for h in &t.headers {
            let _ = write!(out, "<th>{}</th>", escape(h));
        }
        out.push_str("</tr></thead>");
    }
    out.push_str("<tbody>");
    for row in &t.rows {
        out.push_str("<tr>");
        for (i, cell) in row.iter().enumerate() {
            let class = if t.numeric.get(i).copied().unwrap_or(false) {
                " class=\"n\""
            } else {
                ""
            };
            let _ = write!(out, "<td{class}>{}</td>", escape(cell));
        }
        out.push_str("</tr>");
    }
    out.push_str("</tbody></table></div>\n");
}

fn block_html(out: &mut String, b: &Block) {
    match b {
        Block::Text(t) => {
            let _ = writeln!(out, "<p>{}</p>", escape(t));
        }
        Block::Table(t) => table_html(out, t),
        Block::Figure { svg, caption } => {
            let _ = writeln!(
                out,
                "<figure>{svg}<figcaption>{}</figcaption></figure>",
                escape(caption)
            );
        }
        Block::Lines(lines) => {
            out.push_str("<pre>");
            for (n, text) in lines {
                let _ = writeln!(out, "{n:>7}  {}", escape(text));
            }
            out.push_str("</pre>\n");
        }
    }
}

fn inputs_html(out: &mut String, inputs: &[InputFile]) {
    if inputs.is_empty() {
        return;
    }
    out.push_str("<div class=\"table-wrap\"><table><thead><tr><th>input</th><th>file</th><th>bytes</th><th>SHA-256</th></tr></thead><tbody>");
    for f in inputs {
        let _ = write!(
            out,
            "<tr><td>{}</td><td>{}</td><td class=\"n\">{}</td><td class=\"h\">{}</td></tr>",
            escape(&f.role),
            escape(&f.name),
            f.bytes.map_or("–".to_string(), |b| b.to_string()),
            escape(&f.sha256)
        );
    }
    out.push_str("</tbody></table></div>\n");
}

impl Document {
    /// The first page: the title, the title block, what was done with
    /// what, the inputs, what is said once for the whole document, and the
    /// contents (numbered as the sections' headings are, shown on screen
    /// and in print).
    fn first_page_html(&self, out: &mut String) {
        let _ = writeln!(
            out,
            "<section id=\"run\">\n<h1>{}</h1>",
            escape(&self.title)
        );
        if !self.title_block.rows.is_empty() {
            out.push_str("<table class=\"titleblock\"><tbody>");
            for (k, v) in &self.title_block.rows {
                let _ = write!(out, "<tr><th>{}</th><td>{}</td></tr>", escape(k), escape(v));
            }
            out.push_str("</tbody></table>\n");
        }
        out.push_str("<h2>What was done, with what</h2>\n");
        let facts = Table {
            headers: vec![],
            rows: self
                .facts
                .iter()
                .map(|(k, v)| vec![k.clone(), v.clone()])
                .collect(),
            numeric: vec![],
        };
        table_html(out, &facts);
        inputs_html(out, &self.inputs);
        for b in &self.front {
            block_html(out, b);
        }
        if !self.sections.is_empty() {
            out.push_str("<nav class=\"contents\"><b>Contents</b><ol>");
            for s in &self.sections {
                let _ = write!(
                    out,
                    "<li><a href=\"#{}\">{}</a></li>",
                    anchor(&s.id),
                    escape(&s.title)
                );
            }
            out.push_str("</ol></nav>\n");
        }
        out.push_str("</section>\n");
    }

    /// The report as one HTML document (UTF-8), with no script and no
    /// external resource. Printed, every page carries the document's title
    /// at the bottom left and "page N of M" at the bottom right.
    pub fn to_html(&self) -> String {
        let mut out = String::with_capacity(1 << 16);
        let _ = write!(
            out,
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n<meta name=\"generator\" content=\"volcomp {}\">\n<title>{}</title>\n<style>{CSS}@page {{ @bottom-left {{ content: {}; font: 8.5pt \"DejaVu Sans\", Helvetica, Arial, sans-serif; color: #444; }} }}\n</style>\n</head>\n<body>\n",
            env!("CARGO_PKG_VERSION"),
            escape(&self.title),
            css_string(&self.title)
        );
        self.first_page_html(&mut out);
        for (k, s) in self.sections.iter().enumerate() {
            let _ = write!(
                out,
                "<section id=\"{}\">\n<h2><span class=\"no\">{}</span>{}</h2>\n",
                anchor(&s.id),
                k + 1,
                escape(&s.title)
            );
            for b in &s.blocks {
                block_html(&mut out, b);
            }
            out.push_str("</section>\n");
        }
        out.push_str("</body>\n</html>\n");
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_input_is_identified_by_its_sha256() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.ngc");
        std::fs::write(&p, b"abc").unwrap();
        let f = InputFile::read("program", &p).unwrap();
        // FIPS 180-2, appendix B.1: SHA-256("abc").
        assert_eq!(
            f.sha256,
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        assert_eq!(f.bytes, Some(3));
        assert_eq!(
            f,
            InputFile::from_bytes("program", p.display().to_string(), b"abc")
        );
    }

    #[test]
    fn the_document_is_self_contained_and_breaks_pages_between_sections() {
        let d = Document {
            title: "t <1>".into(),
            facts: vec![("volcomp".into(), "0.1.0".into())],
            inputs: vec![InputFile::from_bytes("map", "m.csv", b"")],
            sections: vec![Section {
                id: "a b".into(),
                title: "A".into(),
                blocks: vec![
                    Block::Text("x & y".into()),
                    Block::Lines(vec![(12, "G1 X<1>".into())]),
                ],
            }],
            title_block: title::TitleBlock {
                rows: vec![("customer".into(), "A & B".into())],
            },
            front: vec![Block::Text("said once".into())],
        };
        let html = d.to_html();
        assert!(html.starts_with("<!DOCTYPE html>"));
        assert!(html.contains("<title>t &lt;1&gt;</title>"));
        assert!(html.contains("section + section { break-before: page;"));
        assert!(html.contains("<section id=\"a-b\">\n<h2><span class=\"no\">1</span>A</h2>"));
        // The contents are numbered as the headings are, and printed.
        assert!(html.contains(
            "<nav class=\"contents\"><b>Contents</b><ol><li><a href=\"#a-b\">A</a></li></ol></nav>"
        ));
        assert!(!html.contains("nav { display: none"));
        // The title block comes first, then the facts; what is said once
        // comes after the inputs.
        let tb = html
            .find("<tr><th>customer</th><td>A &amp; B</td></tr>")
            .unwrap();
        assert!(tb < html.find("What was done").unwrap());
        assert!(html.find("<p>said once</p>").unwrap() > html.find("SHA-256").unwrap());
        // Page numbers and the running title in the page margins, the
        // title escaped as a CSS string inside <style>.
        assert!(html
            .contains("@bottom-right { content: \"page \" counter(page) \" of \" counter(pages);"));
        assert!(html.contains("@bottom-left { content: \"t \\3c 1\\3e \";"));
        assert!(html.contains("     12  G1 X&lt;1&gt;"));
        // SHA-256 of the empty string (FIPS 180-2 test vectors).
        assert!(html.contains("e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855"));
        assert!(!html.contains("<script"));
        // No resource outside the document (the SVG namespace is a name,
        // not a fetch).
        let outside = html
            .replace("xmlns=\"http://www.w3.org/2000/svg\"", "")
            .contains("http");
        assert!(!outside);
    }
}
