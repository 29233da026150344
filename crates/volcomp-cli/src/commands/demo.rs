//! `volcomp demo`: the main job on the bundled example.

use super::compensate::{compensate_file, header_for};
use super::Machine;
use crate::args::DemoArgs;
use crate::output::{write_atomically, CliError};
use std::path::Path;
use volcomp_core::compensate::solve::Method;
use volcomp_core::compensate::{CompensateOptions, DirectionPolicy, Segmentation};
use volcomp_core::example::{demo_programs, example_map, DEMO_WORK_OFFSET_MM};
use volcomp_core::model::ErrorModel;
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
        .setup(machine.0.clone())
        .file_name(program.display().to_string());
    if let Some(o) = original {
        simulation = simulation.reference_named(o.display().to_string(), super::simulate::open(o)?);
    }
    Ok(simulation.run(super::simulate::open(program)?)?)
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
    let machine = Machine(MachineSetup::default().with_work_offset(DEMO_WORK_OFFSET_MM));
    let variants = variants();
    println!("volcomp demo — example map {} (X 0…600, Y 0…400, Z 0…300 mm; backlash 3/4/2 µm), work offset G54 = {:.0},{:.0},{:.0} mm", map_path.display(), DEMO_WORK_OFFSET_MM.x, DEMO_WORK_OFFSET_MM.y, DEMO_WORK_OFFSET_MM.z);
    println!("RMS errors in µm; point = at the end of every feed block of the program, contour = distance of the actual path (every 0.05 mm) from the block it was written for; in brackets: improvement over 'before'.\n");
    print!("{:<44} {:>8}", "program", "before");
    for v in &variants {
        print!(" {:>26}", v.label);
    }
    println!();
    for p in demo_programs() {
        let original = a.out_dir.join(format!("{}.ngc", p.name));
        write_atomically(&original, &[], |w| {
            w.write_all(p.text.as_bytes())
                .map_err(|e| CliError::Io(original.clone(), e))
        })?;
        let before = measure(&machine, &map, &original, None)?;
        let mut cells = Vec::new();
        for v in &variants {
            let out = a.out_dir.join(format!("{}.{}.ngc", p.name, v.suffix));
            let header = header_for(&map_path, None, &machine, &v.options)?;
            compensate_file(&original, &out, &machine, &map, &v.options, &header, |_| {})?;
            let after = measure(&machine, &map, &out, Some(&original))?;
            cells.push(after);
        }
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
    println!(
        "\nCompensated programs: {}/<program>.<method>.ngc",
        a.out_dir.display()
    );
    let o = DEMO_WORK_OFFSET_MM;
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
