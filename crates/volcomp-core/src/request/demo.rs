//! `volcomp demo`: the methods it compares, its report and what it says
//! around its table (the table itself is `report::demo`).

use super::{run_facts, Compensation, Machine};
use crate::compensate::solve::Method;
use crate::compensate::{header_for_map, CompensateOptions, DirectionPolicy, Segmentation};
use crate::example::DEMO_WORK_OFFSET_MM;
use crate::io::provenance::now_utc;
use crate::report::compensation::setup_facts;
use crate::report::{Block, Document, InputFile, Section, Table};
use crate::Error;
use std::path::Path;

/// One column of the demo table.
pub struct Variant {
    /// Its name in the report.
    pub label: &'static str,
    /// Its name in the terminal's table.
    pub short: &'static str,
    /// The compensated program's suffix.
    pub suffix: &'static str,
    /// The method.
    pub options: CompensateOptions,
}

/// The methods compared: the papers' direct and ILC ways (one point per
/// program block, tables by nominal direction), pitch-only, and volcomp's.
pub fn variants() -> Vec<Variant> {
    let base = CompensateOptions::default();
    let papers = CompensateOptions {
        segmentation: Segmentation::Off,
        directions: DirectionPolicy::Nominal,
        take_up: false,
        ..base
    };
    vec![
        Variant {
            label: "pitch",
            short: "pitch",
            suffix: "pitch",
            options: CompensateOptions {
                method: Method::Pitch,
                ..base
            },
        },
        Variant {
            label: "ILC (papers' way)",
            short: "ILC¹",
            suffix: "ilc_papers",
            options: CompensateOptions {
                method: Method::Ilc {
                    gain: 0.5,
                    max_iterations: 20,
                },
                ..papers
            },
        },
        Variant {
            label: "ILC",
            short: "ILC",
            suffix: "ilc",
            options: CompensateOptions {
                method: Method::Ilc {
                    gain: 0.5,
                    max_iterations: 20,
                },
                ..base
            },
        },
        Variant {
            label: "exact",
            short: "exact",
            suffix: "exact",
            options: base,
        },
        Variant {
            label: "exact, adaptive 0.05 µm",
            short: "adaptive²",
            suffix: "adaptive",
            options: CompensateOptions {
                segmentation: Segmentation::Adaptive {
                    tolerance_mm: 0.05e-3,
                    min_length_mm: 0.01,
                },
                ..base
            },
        },
    ]
}

impl Variant {
    /// The compensation of the demo's programs with this method, on the
    /// map `map` (its header names it).
    pub fn compensation(&self, machine: &Machine, map: &Path) -> Result<Compensation, Error> {
        let header = header_for_map(map, None, &machine.setup.setup, &self.options, now_utc())?;
        Ok(Compensation {
            machine: machine.clone(),
            options: self.options,
            header,
            allow_recompensate: false,
            max_output_bytes: None,
        })
    }
}

/// The report of the demo: the overview of every cell, then each program
/// before and after the default method ("exact").
pub fn report_html(
    command: &str,
    (machine, map_path): (&Machine, &Path),
    overview_table: Table,
    sections: Vec<Section>,
    inputs: Vec<InputFile>,
) -> String {
    let o = DEMO_WORK_OFFSET_MM;
    let mut all = vec![Section {
        id: "overview".into(),
        title: "Every program with every method".into(),
        blocks: vec![
            Block::Text(format!("RMS errors in µm of each demo program on the example machine (work offset G54 = {}, {}, {} mm), before compensation and after each method; in brackets the change against 'before'. The following sections show each program before and after the default method (exact).", o.x, o.y, o.z)),
            Block::Table(overview_table),
        ],
    }];
    all.extend(sections);
    let mut facts = run_facts(command);
    facts.push(("map".to_string(), map_path.display().to_string()));
    facts.extend(setup_facts(&machine.setup.setup, None));
    Document {
        title: "volcomp demo report".into(),
        facts,
        inputs,
        sections: all,
        // The metrics every program's sections use, defined once.
        front: vec![crate::report::compensation::definitions()],
        ..Default::default()
    }
    .to_html()
}

/// What the demo says before its table.
pub fn intro(map_path: &Path) -> String {
    let o = DEMO_WORK_OFFSET_MM;
    format!("volcomp demo — example map {} (X 0…600, Y 0…400, Z 0…300 mm; backlash 3/4/2 µm), G54 = {},{},{} mm
RMS errors in µm: point = at the end of every feed block, contour = distance of the actual path
(every 0.05 mm) from the block it was written for; after each method its change against 'before'
(-99.4% = 99.4% smaller, as in the report).
", map_path.display(), o.x, o.y, o.z)
}

/// The footnotes of the demo's table.
pub const FOOTNOTES: &str =
    "¹ the papers' way: one point per block, tables by nominal direction, no take-ups
² exact with adaptive segmentation within 0.05 µm";

/// What the demo says after its table: where its programs and report are,
/// and how to reproduce every figure.
pub fn outro(out_dir: &Path, map_path: &Path, report_path: &Path) -> String {
    let o = DEMO_WORK_OFFSET_MM;
    format!(
        "\nCompensated programs: {dir}/<program>.<method>.ngc\nReport (open in a browser, prints on A4): {}\nEvery figure is what `volcomp simulate` reports; e.g. a 'before' cell:\n  volcomp simulate {dir}/<program>.ngc --map {map} --work-offset {},{},{}\nand a method's cell:\n  volcomp simulate {dir}/<program>.<method>.ngc --reference {dir}/<program>.ngc --map {map} --work-offset {},{},{}",
        report_path.display(),
        o.x,
        o.y,
        o.z,
        o.x,
        o.y,
        o.z,
        dir = out_dir.display(),
        map = map_path.display()
    )
}
