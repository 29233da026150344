//! Plots written through the CLI's atomic output: the drawing is the
//! library's ([`volcomp_core::request::plot`]).

use crate::output::{write_file, CliError};
use std::path::Path;
pub use volcomp_core::request::charts::{self, Chart};

/// Draws `charts` stacked vertically into `path` (`.svg` or `.png`), atomically.
pub fn write_charts(charts: &[Chart], path: &Path) -> Result<(), CliError> {
    let bytes = volcomp_core::request::plot::chart_bytes(charts, path)?;
    write_file(path, &[], &bytes)
}

/// Draws `charts` into `path`: `.svg` or `.png` as [`write_charts`], or
/// `.html` as a self-contained report titled `title` naming `inputs`
/// (role, file) with their SHA-256; charts whose titles share the text
/// before ": " share a page, others go two to a page.
pub fn write_charts_or_report(
    charts: &[Chart],
    path: &Path,
    title: &str,
    inputs: &[(&str, &Path)],
) -> Result<(), CliError> {
    let is_html = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("html"));
    if !is_html {
        return write_charts(charts, path);
    }
    let mut files = Vec::new();
    for (role, p) in inputs {
        files.push(volcomp_core::report::InputFile::read(*role, p)?);
    }
    let html = charts::charts_report(charts, title, files, &crate::commands::command_line());
    let input_paths: Vec<&Path> = inputs.iter().map(|(_, p)| *p).collect();
    write_file(path, &input_paths, html.as_bytes())
}
