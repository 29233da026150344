//! `volcomp demo`: the main job on the bundled example.

use super::compensate::{command_line, compensate_file};
use super::Machine;
use crate::args::DemoArgs;
use crate::output::{write_atomically, CliError};
use std::path::Path;
use volcomp_core::compensate::solve::Method;
use volcomp_core::compensate::{header_for_map, CompensateOptions, DirectionPolicy, Segmentation};
use volcomp_core::example::{demo_programs, example_map, DEMO_WORK_OFFSET_MM};
use volcomp_core::io::provenance::now_utc;
use volcomp_core::model::ErrorModel;
use volcomp_core::report::compensation::{
    compensation_sections, lines_to_quote, quote_lines, setup_facts, trace_program,
    LargestCorrections,
};
use volcomp_core::report::{Block, Document, InputFile, Section, Table};
use volcomp_core::request::Compensation;
use volcomp_core::simulate::DEFAULT_CHORD_TOLERANCE_MM;
use volcomp_core::MachineSetup;
use volcomp_core::{SimReport, Simulation};

/// One column of the demo table.
pub struct Variant {
    pub label: &'static str,
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
            suffix: "pitch",
            options: CompensateOptions {
                method: Method::Pitch,
                ..base
            },
        },
        Variant {
            label: "ILC (papers' way)",
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
            suffix: "exact",
            options: base,
        },
        Variant {
            label: "exact, adaptive 0.05 µm",
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

fn rate(before: f64, after: f64) -> f64 {
    if before > 0.0 {
        100.0 * (1.0 - after / before)
    } else {
        0.0
    }
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
    let variants = variants();
    println!("volcomp demo — example map {} (X 0…600, Y 0…400, Z 0…300 mm; backlash 3/4/2 µm), work offset G54 = {:.0},{:.0},{:.0} mm", map_path.display(), DEMO_WORK_OFFSET_MM.x, DEMO_WORK_OFFSET_MM.y, DEMO_WORK_OFFSET_MM.z);
    println!("RMS errors in µm; point = at the end of every feed block of the program, contour = distance of the actual path (every 0.05 mm) from the block it was written for; in brackets: improvement over 'before'.\n");
    print!("{:<44} {:>8}", "program", "before");
    for v in &variants {
        print!(" {:>26}", v.label);
    }
    println!();
    // The report: an overview of every cell, then each program before and
    // after the default method ("exact").
    let mut overview = Table {
        headers: vec!["program".into(), "error RMS (µm)".into(), "before".into()],
        rows: Vec::new(),
        numeric: vec![false, false, true],
    };
    for v in &variants {
        overview.headers.push(v.label.into());
        overview.numeric.push(true);
    }
    let mut sections = Vec::new();
    let mut inputs = vec![InputFile::read("map", &map_path)?];
    for p in demo_programs() {
        let original = a.out_dir.join(format!("{}.ngc", p.name));
        write_atomically(&original, &[], |w| {
            w.write_all(p.text.as_bytes())
                .map_err(|e| CliError::Io(original.clone(), e))
        })?;
        inputs.push(InputFile::read("program", &original)?);
        let name = original.display().to_string();
        let traced_before = trace_program(
            &map,
            &machine.setup,
            DEFAULT_CHORD_TOLERANCE_MM,
            "before",
            &name,
            super::simulate::open(&original)?,
            None,
            |_| {},
        )?;
        let before = traced_before.report;
        let mut cells = Vec::new();
        for v in &variants {
            let out = a.out_dir.join(format!("{}.{}.ngc", p.name, v.suffix));
            let job = job(&machine, &map_path, v.options)?;
            let mut corrections = LargestCorrections::default();
            let summary = compensate_file(&original, &out, &job, &map, |pt| corrections.push(pt))?;
            if v.suffix != "exact" {
                cells.push(measure(&machine, &map, &out, Some(&original))?);
                continue;
            }
            // The same simulation as `measure`, keeping the pictures.
            let after = trace_program(
                &map,
                &machine.setup,
                DEFAULT_CHORD_TOLERANCE_MM,
                &format!("after ({})", v.label),
                &out.display().to_string(),
                super::simulate::open(&out)?,
                Some((name.clone(), super::simulate::open(&original)?)),
                |_| {},
            )?;
            cells.push(after.report);
            let want = lines_to_quote(
                &corrections,
                Some(&summary),
                &traced_before
                    .warnings
                    .iter()
                    .map(|w| w.0)
                    .collect::<Vec<_>>(),
            );
            let quoted = quote_lines(p.text.as_bytes(), &want)
                .map_err(|e| CliError::Io(original.clone(), e))?;
            sections.extend(compensation_sections(
                p.title,
                &traced_before,
                &after,
                &summary,
                &corrections,
                &quoted,
            ));
        }
        let mut point_row = vec![
            p.title.to_string(),
            "point".into(),
            format!("{:.3}", before.point_rms_um),
        ];
        let mut contour_row = vec![
            String::new(),
            "contour".into(),
            format!("{:.3}", before.contour_rms_um),
        ];
        for c in &cells {
            point_row.push(format!(
                "{:.3} ({:+.0}\u{a0}%)",
                c.point_rms_um,
                -rate(before.point_rms_um, c.point_rms_um)
            ));
            contour_row.push(format!(
                "{:.3} ({:+.1}\u{a0}%)",
                c.contour_rms_um,
                -rate(before.contour_rms_um, c.contour_rms_um)
            ));
        }
        overview.rows.push(point_row);
        overview.rows.push(contour_row);
        print!(
            "{:<44} {:>8.3}",
            format!("{} point", p.title),
            before.point_rms_um
        );
        for c in &cells {
            print!(
                " {:>26}",
                format!(
                    "{:.3} ({:+.0}%)",
                    c.point_rms_um,
                    rate(before.point_rms_um, c.point_rms_um)
                )
            );
        }
        println!();
        print!("{:<44} {:>8.3}", "  contour", before.contour_rms_um);
        for c in &cells {
            print!(
                " {:>26}",
                format!(
                    "{:.3} ({:+.1}%)",
                    c.contour_rms_um,
                    rate(before.contour_rms_um, c.contour_rms_um)
                )
            );
        }
        println!();
    }
    let o = DEMO_WORK_OFFSET_MM;
    let mut all = vec![Section {
        id: "overview".into(),
        title: "Every program with every method".into(),
        blocks: vec![
            Block::Text(format!("RMS errors in µm of each demo program on the example machine (work offset G54 = {}, {}, {} mm), before compensation and after each method; in brackets the change against 'before'. The following sections show each program before and after the default method (exact).", o.x, o.y, o.z)),
            Block::Table(overview),
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
    };
    let report_path = a.out_dir.join("report.html");
    write_atomically(&report_path, &[], |w| {
        w.write_all(doc.to_html().as_bytes())
            .map_err(|e| CliError::Io(report_path.clone(), e))
    })?;
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
