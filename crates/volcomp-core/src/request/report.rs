//! The HTML reports of a compensation and of a simulation (docs/report.md):
//! the library simulates what the report shows and assembles the document;
//! a front end names the files and writes the HTML where it is asked to.

use super::compensate::Compensation;
use super::machine::Machine;
use super::simulate::SimulateRequest;
use crate::compensate::CompensateSummary;
use crate::io::provenance::{now_utc, ProgramHeader};
use crate::model::ErrorModel;
use crate::report::compensation::{
    definitions, header_facts, lines_to_quote, quote_lines, setup_facts, simulation_sections,
    trace_program, LargestCorrections, Traced,
};
use crate::report::title::TitleBlock;
use crate::report::{compensation::compensation_sections, Document, InputFile};
use crate::Error;
use std::path::{Path, PathBuf};

request! {
    /// What an HTML report says besides the run, as plain values.
    pub struct ReportRequest {}
    /// The options of [`ReportRequest`]: what an HTML report says besides the
    /// run (the compensation's and the simulation's).
    pub const REPORT_OPTIONS, unknown "report_title";

    /// The title-block file.
    report_title: Option<PathBuf> = None, Path.value("FILE.toml"),
        "Title block of the HTML report: a TOML file with customer, order, part, drawing, revision, material, machine, tolerance, operator, notes (each optional; docs/report.md, \"Title block\").";
}

impl ReportRequest {
    /// The title block, read and checked before any work (an empty one
    /// when none was given). `html`: whether an HTML report is written; a
    /// title block without one is refused rather than ignored.
    pub fn title_block(&self, html: bool) -> Result<TitleBlock, Error> {
        match &self.report_title {
            None => Ok(TitleBlock::default()),
            Some(_) if !html => Err(Error::Request(
                "{report_title} is the title block of the HTML report, and no HTML report is written: ask for the report too, or leave {report_title} out".into(),
            )),
            Some(path) => TitleBlock::read(path),
        }
    }
}

/// The files of a program header (the map and the tables it names) as
/// report inputs.
pub fn header_inputs(header: &ProgramHeader) -> Vec<InputFile> {
    header
        .files
        .iter()
        .map(|(label, name, sha)| InputFile {
            role: label.clone(),
            name: name.clone(),
            bytes: std::fs::metadata(name).ok().map(|m| m.len()),
            sha256: sha.clone(),
        })
        .collect()
}

fn open(path: &Path) -> Result<std::fs::File, Error> {
    crate::io::inputs::open(path, "an input").map_err(|e| Error::io(path, e))
}

/// What a report says of the run besides its figures: the command as the
/// user gave it (a front end's words) and the names it shows for the
/// files.
#[derive(Debug, Clone, Copy)]
pub struct RunNames<'a> {
    /// The command (or call) as given.
    pub command: &'a str,
    /// The program's name.
    pub program: &'a str,
    /// Where the compensated program went (`standard output`, a file).
    pub output: &'a str,
    /// The title block (from [`ReportRequest::title_block`]).
    pub title_block: &'a TitleBlock,
}

impl Compensation {
    /// The HTML report of this compensation of the program file `program`
    /// into `written` (the compensated program's bytes): the original
    /// simulated alone ("before") and the compensated program against it
    /// ("after"), the compensation's figures, its largest `corrections`,
    /// held axes and warnings.
    pub fn report_html(
        &self,
        model: &dyn ErrorModel,
        program: &Path,
        written: &[u8],
        summary: &CompensateSummary,
        corrections: &LargestCorrections,
        names: RunNames<'_>,
    ) -> Result<String, Error> {
        let (machine, header) = (&self.machine, &self.header);
        let chord = self.options.chord_tolerance_mm;
        let name = names.program;
        let before = trace_program(
            model,
            &machine.setup,
            chord,
            "before",
            name,
            open(program)?,
            None,
            |_| {},
        )?;
        let reference = Some((name.to_string(), Box::new(open(program)?) as Box<_>));
        let after = trace_program(
            model,
            &machine.setup,
            chord,
            "after",
            names.output,
            written,
            reference,
            |_| {},
        )?;
        let warned: Vec<u64> = before.warnings.iter().map(|w| w.0).collect();
        let want = lines_to_quote(corrections, Some(summary), &warned);
        let quoted = quote_lines(std::io::BufReader::new(open(program)?), &want)
            .map_err(|e| Error::io(program, e))?;
        let mut inputs = vec![InputFile::read("program", program)?];
        inputs.extend(header_inputs(header));
        if let Some(s) = &machine.setup_file {
            inputs.push(InputFile::read("set-up", s)?);
        }
        let mut facts = vec![
            ("command".to_string(), names.command.to_string()),
            ("program".to_string(), name.to_string()),
            ("compensated program".to_string(), names.output.to_string()),
        ];
        facts.extend(header_facts(header));
        let mut sections =
            compensation_sections("", &before, &after, summary, corrections, &quoted);
        // The machining time on the planner model (docs/planner.md).
        let time = self.machining_time(program, written, names.output)?;
        sections.push(crate::report::machining_time::machining_time_section(&time));
        Ok(Document {
            title: format!("volcomp compensation report: {name}"),
            facts,
            inputs,
            sections,
            title_block: names.title_block.clone(),
            front: vec![definitions()],
        }
        .to_html())
    }
}

impl SimulateRequest {
    /// The HTML report of a simulation of `program` (a file, or `-` for
    /// standard input, which is not read again) already simulated as
    /// `after`; with a reference, the reference on its own is simulated
    /// too, as "before". `map` is the map file, listed with its SHA-256;
    /// `command` and `title_block` head the first page.
    #[allow(clippy::too_many_arguments)]
    pub fn report_html(
        &self,
        model: &dyn ErrorModel,
        machine: &Machine,
        program: &Path,
        map: &Path,
        after: &Traced,
        command: &str,
        title_block: &TitleBlock,
    ) -> Result<String, Error> {
        let chord = self.chord_tolerance_mm()?;
        let before = match &self.reference {
            Some(r) => {
                let name = r.name();
                Some(trace_program(
                    model,
                    &machine.setup,
                    chord,
                    &name,
                    &name,
                    r.reader()?,
                    None,
                    |_| {},
                )?)
            }
            None => None,
        };
        let stdin = program.as_os_str() == "-";
        let warned: Vec<u64> = after.warnings.iter().map(|w| w.0).collect();
        let want = lines_to_quote(&Default::default(), None, &warned);
        let quoted = if stdin {
            Default::default()
        } else {
            quote_lines(std::io::BufReader::new(open(program)?), &want)
                .map_err(|e| Error::io(program, e))?
        };
        let mut inputs = vec![if stdin {
            InputFile {
                role: "program".into(),
                name: "<standard input>".into(),
                bytes: None,
                sha256: "(standard input: not kept)".into(),
            }
        } else {
            InputFile::read("program", program)?
        }];
        if let Some(r) = self.reference.as_ref().and_then(|r| r.path()) {
            inputs.push(InputFile::read("reference", r)?);
        }
        inputs.push(InputFile::read("map", map)?);
        if let Some(s) = &machine.setup_file {
            inputs.push(InputFile::read("set-up", s)?);
        }
        let mut facts = vec![
            ("command".to_string(), command.to_string()),
            ("volcomp".to_string(), env!("CARGO_PKG_VERSION").to_string()),
            ("date (UTC)".to_string(), now_utc()),
            ("chord tolerance".to_string(), format!("{chord} mm")),
        ];
        facts.extend(setup_facts(&machine.setup.setup, None));
        let mut sections = simulation_sections("", before.as_ref(), after, &quoted);
        // The machining time on the planner model (docs/planner.md).
        if let Some(time) = self.machining_time(machine, program)? {
            sections.push(crate::report::machining_time::machining_time_section(&time));
        }
        Ok(Document {
            title: format!("volcomp simulation report: {}", program.display()),
            facts,
            inputs,
            sections,
            title_block: title_block.clone(),
            front: vec![definitions()],
        }
        .to_html())
    }
}
