//! `volcomp demo`: the main job on the bundled example.

use super::compensate::{command_line, compensate_file};
use super::Machine;
use crate::args::DemoArgs;
use crate::output::{write_atomically, CliError};
use std::path::{Path, PathBuf};
use volcomp_core::compensate::solve::Method;
use volcomp_core::compensate::{header_for_map, CompensateOptions, DirectionPolicy, Segmentation};
use volcomp_core::example::{demo_programs, example_map, DEMO_WORK_OFFSET_MM};
use volcomp_core::io::provenance::now_utc;
use volcomp_core::model::axis_table::AxisTableMap;
use volcomp_core::model::ErrorModel;
use volcomp_core::report::compensation::{
    compensation_sections, definitions, lines_to_quote, quote_lines, setup_facts, trace_program,
    LargestCorrections,
};
use volcomp_core::report::demo::{self as demo_table, Column, Row};
use volcomp_core::report::{Block, Document, InputFile, Section};
use volcomp_core::request::Compensation;
use volcomp_core::simulate::DEFAULT_CHORD_TOLERANCE_MM;
use volcomp_core::MachineSetup;
use volcomp_core::{SimReport, Simulation};

/// One column of the demo table.
pub struct Variant {
    pub label: &'static str,
    pub short: &'static str,
    pub suffix: &'static str,
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

/// Simulates a program, against its original when it is a compensated one:
/// exactly what `volcomp simulate PROGRAM [--reference ORIGINAL]` does with
/// the same map and work offset, so every figure of the demo can be
/// reproduced with that command.
pub fn measure(
    machine: &Machine,
    model: &dyn ErrorModel,
    program: &Path,
    original: Option<&Path>,
) -> Result<SimReport, CliError> {
    let mut simulation = Simulation::new(model)
        .setup(machine.setup.clone())
        .file_name(program.display().to_string());
    if let Some(o) = original {
        simulation = simulation.reference_named(o.display().to_string(), super::simulate::open(o)?);
    }
    Ok(simulation.run(super::simulate::open(program)?)?)
}

/// The compensation of the demo's programs with `options`.
fn job(
    machine: &Machine,
    map: &Path,
    options: CompensateOptions,
) -> Result<Compensation, CliError> {
    let header = header_for_map(map, None, &machine.setup.setup, &options, now_utc())?;
    Ok(Compensation {
        machine: machine.clone(),
        options,
        header,
        allow_recompensate: false,
        max_output_bytes: None,
    })
}

/// Compensates one demo program with every method and measures each; the
/// default method's ("exact") sections of the report.
fn one_program(
    a: &DemoArgs,
    (machine, map, map_path): (&Machine, &AxisTableMap, &Path),
    p: &volcomp_core::example::DemoProgram,
    inputs: &mut Vec<InputFile>,
) -> Result<(Row, Vec<Section>), CliError> {
    let original = a.out_dir.join(format!("{}.ngc", p.name));
    write_atomically(&original, &[], |w| {
        w.write_all(p.text.as_bytes())
            .map_err(|e| CliError::Io(original.clone(), e))
    })?;
    inputs.push(InputFile::read("program", &original)?);
    let name = original.display().to_string();
    let open = super::simulate::open;
    let chord = DEFAULT_CHORD_TOLERANCE_MM;
    let before = trace_program(
        map,
        &machine.setup,
        chord,
        "before",
        &name,
        open(&original)?,
        None,
        |_| {},
    )?;
    let mut row = Row {
        title: p.title.to_string(),
        before: before.report,
        after: Vec::new(),
    };
    let mut sections = Vec::new();
    for v in variants() {
        let out = a.out_dir.join(format!("{}.{}.ngc", p.name, v.suffix));
        let job = job(machine, map_path, v.options)?;
        let mut corrections = LargestCorrections::default();
        let summary = compensate_file(&original, &out, &job, map, |pt| corrections.push(pt))?;
        if v.suffix != "exact" {
            row.after
                .push(measure(machine, map, &out, Some(&original))?);
            continue;
        }
        // The same simulation as `measure`, keeping the pictures.
        let label = format!("after ({})", v.label);
        let reference = Some((name.clone(), open(&original)?));
        let after = trace_program(
            map,
            &machine.setup,
            chord,
            &label,
            &out.display().to_string(),
            open(&out)?,
            reference,
            |_| {},
        )?;
        row.after.push(after.report);
        let warned: Vec<u64> = before.warnings.iter().map(|w| w.0).collect();
        let want = lines_to_quote(&corrections, Some(&summary), &warned);
        let quoted =
            quote_lines(p.text.as_bytes(), &want).map_err(|e| CliError::Io(original.clone(), e))?;
        sections.extend(compensation_sections(
            p.title,
            &before,
            &after,
            &summary,
            &corrections,
            &quoted,
        ));
    }
    Ok((row, sections))
}

/// The report of the demo: the overview of every cell, then each program
/// before and after the default method ("exact").
fn write_report(
    a: &DemoArgs,
    (machine, map_path): (&Machine, &Path),
    overview_table: volcomp_core::report::Table,
    sections: Vec<Section>,
    inputs: Vec<InputFile>,
) -> Result<PathBuf, CliError> {
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
    let mut facts = vec![
        ("command".to_string(), command_line()),
        ("volcomp".to_string(), env!("CARGO_PKG_VERSION").to_string()),
        ("date (UTC)".to_string(), now_utc()),
        ("map".to_string(), map_path.display().to_string()),
    ];
    facts.extend(setup_facts(&machine.setup.setup, None));
    let doc = Document {
        title: "volcomp demo report".into(),
        facts,
        inputs,
        sections: all,
        front: vec![definitions()],
        ..Default::default()
    };
    let report_path = a.out_dir.join("report.html");
    write_atomically(&report_path, &[], |w| {
        w.write_all(doc.to_html().as_bytes())
            .map_err(|e| CliError::Io(report_path.clone(), e))
    })?;
    Ok(report_path)
}

pub fn run(a: DemoArgs) -> Result<(), CliError> {
    std::fs::create_dir_all(&a.out_dir).map_err(|e| CliError::Io(a.out_dir.clone(), e))?;
    let map = example_map();
    let map_path = a.out_dir.join("example_map.csv");
    write_atomically(&map_path, &[], |w| {
        w.write_all(map.to_csv().as_bytes())
            .map_err(|e| CliError::Io(map_path.clone(), e))
    })?;
    let machine = Machine {
        setup: MachineSetup::default().with_work_offset(DEMO_WORK_OFFSET_MM),
        setup_file: None,
        work_offset_given: false,
    };
    let columns: Vec<Column> = variants()
        .iter()
        .map(|v| Column {
            label: v.label,
            short: v.short,
        })
        .collect();
    let (mut rows, mut sections) = (Vec::new(), Vec::new());
    let mut inputs = vec![InputFile::read("map", &map_path)?];
    for p in demo_programs() {
        let (row, s) = one_program(&a, (&machine, &map, &map_path), &p, &mut inputs)?;
        rows.push(row);
        sections.extend(s);
    }
    let o = DEMO_WORK_OFFSET_MM;
    println!("volcomp demo — example map {} (X 0…600, Y 0…400, Z 0…300 mm; backlash 3/4/2 µm), G54 = {},{},{} mm", map_path.display(), o.x, o.y, o.z);
    println!("RMS errors in µm: point = at the end of every feed block, contour = distance of the actual path");
    println!("(every 0.05 mm) from the block it was written for; after each method its change against 'before'");
    println!("(-99.4% = 99.4% smaller, as in the report).\n");
    print!("{}", demo_table::console(&columns, &rows));
    println!("¹ the papers' way: one point per block, tables by nominal direction, no take-ups");
    println!("² exact with adaptive segmentation within 0.05 µm");
    if let Some(path) = &a.markdown {
        let md = demo_table::markdown(&columns, &rows);
        write_atomically(path, &[], |w| {
            w.write_all(md.as_bytes())
                .map_err(|e| CliError::Io(path.clone(), e))
        })?;
    }
    let overview = demo_table::overview(&columns, &rows);
    let report_path = write_report(&a, (&machine, &map_path), overview, sections, inputs)?;
    println!(
        "\nCompensated programs: {}/<program>.<method>.ngc",
        a.out_dir.display()
    );
    println!(
        "Report (open in a browser, prints on A4): {}",
        report_path.display()
    );
    println!(
        "Every figure is what `volcomp simulate` reports; e.g. a 'before' cell:\n  volcomp simulate {dir}/<program>.ngc --map {map} --work-offset {},{},{}\nand a method's cell:\n  volcomp simulate {dir}/<program>.<method>.ngc --reference {dir}/<program>.ngc --map {map} --work-offset {},{},{}",
        o.x,
        o.y,
        o.z,
        o.x,
        o.y,
        o.z,
        dir = a.out_dir.display(),
        map = map_path.display()
    );
    Ok(())
}
