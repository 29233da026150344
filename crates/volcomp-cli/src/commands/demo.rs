//! `volcomp demo`: the main job on the bundled example.

use super::compensate::{command_line, compensate_file};
use super::Machine;
use crate::args::DemoArgs;
use crate::output::{write_file, CliError};
use std::path::Path;
use volcomp_core::example::{demo_programs, example_map, DEMO_WORK_OFFSET_MM};
use volcomp_core::model::axis_table::AxisTableMap;
use volcomp_core::model::ErrorModel;
use volcomp_core::report::compensation::{
    compensation_sections, lines_to_quote, quote_lines, trace_program, LargestCorrections,
};
use volcomp_core::report::demo::{self as demo_table, Column, Row};
use volcomp_core::report::{InputFile, Section};
use volcomp_core::request::demo;
use volcomp_core::simulate::DEFAULT_CHORD_TOLERANCE_MM;
use volcomp_core::MachineSetup;
use volcomp_core::{SimReport, Simulation};

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

/// Compensates one demo program with every method and measures each; the
/// default method's ("exact") sections of the report.
fn one_program(
    a: &DemoArgs,
    (machine, map, map_path): (&Machine, &AxisTableMap, &Path),
    p: &volcomp_core::example::DemoProgram,
    inputs: &mut Vec<InputFile>,
) -> Result<(Row, Vec<Section>), CliError> {
    let original = a.out_dir.join(format!("{}.ngc", p.name));
    write_file(&original, &[], p.text.as_bytes())?;
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
    for v in demo::variants() {
        let out = a.out_dir.join(format!("{}.{}.ngc", p.name, v.suffix));
        let job = v.compensation(machine, map_path)?;
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

pub fn run(a: DemoArgs) -> Result<(), CliError> {
    std::fs::create_dir_all(&a.out_dir).map_err(|e| CliError::Io(a.out_dir.clone(), e))?;
    let map = example_map();
    let map_path = a.out_dir.join("example_map.csv");
    write_file(&map_path, &[], map.to_csv().as_bytes())?;
    let machine = Machine {
        setup: MachineSetup::default().with_work_offset(DEMO_WORK_OFFSET_MM),
        setup_file: None,
        work_offset_given: false,
    };
    let columns: Vec<Column> = demo::variants()
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
    println!("{}", demo::intro(&map_path));
    print!("{}", demo_table::console(&columns, &rows));
    println!("{}", demo::FOOTNOTES);
    if let Some(path) = &a.markdown {
        let md = demo_table::markdown(&columns, &rows);
        write_file(path, &[], md.as_bytes())?;
    }
    let overview = demo_table::overview(&columns, &rows);
    let html = demo::report_html(
        &command_line(),
        (&machine, &map_path),
        overview,
        sections,
        inputs,
    );
    let report_path = a.out_dir.join("report.html");
    write_file(&report_path, &[], html.as_bytes())?;
    println!("{}", demo::outro(&a.out_dir, &map_path, &report_path));
    Ok(())
}
