//! `volcomp compensate`.

use super::Machine;
use crate::args::{CompensateArgs, MapArgs, Method as MethodArg};
use crate::output::{write_atomically, CliError};
use std::io::{Read, Write};
use std::path::Path;
use volcomp_core::compensate::{
    compensate_program, survey_style, CompensateOptions, CompensateSummary, DirectionPolicy,
    PointRecord, Segmentation,
};
use volcomp_core::model::ErrorModel;
use volcomp_core::solve::Method;

/// Loads the error map named by `--map`.
pub fn load_map(a: &MapArgs) -> Result<Box<dyn ErrorModel>, CliError> {
    let text = super::read_utf8(&a.map)?;
    // A straightness model (docs/straightness.md): TOML with `kind = "straightness"`.
    if volcomp_core::straightness::StraightnessModel::is_model_toml(&text) {
        let mut m = volcomp_core::straightness::StraightnessModel::from_toml(
            &text,
            &a.map.display().to_string(),
        )?;
        m.clamp = a.clamp;
        return Ok(Box::new(m));
    }
    // Axis tables (.csv, design §2) or a 21-component kinematic model (.toml,
    // docs/kinematic.md), which is evaluated at the tool active on each line.
    Ok(super::map::load(&a.map, a.clamp)?.into_model())
}

/// Validated options from the raw flags.
pub fn options(a: &CompensateArgs) -> Result<CompensateOptions, CliError> {
    let method = match a.method {
        MethodArg::Exact => Method::Exact,
        MethodArg::Direct => Method::Direct,
        MethodArg::Pitch => Method::Pitch,
        MethodArg::Ilc => {
            if !(a.gain > 0.0 && a.gain <= 1.0) {
                return Err(CliError::Message(format!(
                    "--gain must satisfy 0 < γ ≤ 1; got {}",
                    a.gain
                )));
            }
            Method::Ilc {
                gain: a.gain,
                max_iterations: a.max_iterations,
            }
        }
    };
    let segmentation = match (
        a.no_split,
        a.segments,
        a.segment_length,
        a.contour_tolerance_um,
    ) {
        (true, ..) => Segmentation::Off,
        (_, Some(0), ..) => return Err(CliError::Message("--segments must be at least 1".into())),
        (_, Some(n), ..) => Segmentation::Count(n),
        (_, _, Some(l), _) if !(l.is_finite() && l > 0.0) => {
            return Err(CliError::Message(format!(
                "--segment-length must be a positive length in mm; got {l}"
            )))
        }
        (_, _, Some(l), _) => Segmentation::MaxLength(l),
        (_, _, _, Some(t)) => {
            let positive = |v: f64| v.is_finite() && v > 0.0;
            if !(positive(t) && positive(a.min_segment_length)) {
                return Err(CliError::Message(
                    "--contour-tolerance-um and --min-segment-length must be positive".into(),
                ));
            }
            Segmentation::Adaptive {
                tolerance_mm: t * 1e-3,
                min_length_mm: a.min_segment_length,
            }
        }
        _ => Segmentation::MaxLength(1.0),
    };
    if !(a.chord_tolerance.is_finite() && a.chord_tolerance > 0.0) {
        return Err(CliError::Message(
            "--chord-tolerance must be a positive length in mm".into(),
        ));
    }
    if a.decimals.is_some_and(|d| !(1..=9).contains(&d)) {
        return Err(CliError::Message("--decimals must be 1 … 9".into()));
    }
    Ok(CompensateOptions {
        method,
        segmentation,
        chord_tolerance_mm: a.chord_tolerance,
        decimals: a.decimals,
        max_correction_mm: a.max_correction,
        directions: if a.nominal_directions {
            DirectionPolicy::Nominal
        } else {
            DirectionPolicy::Commanded
        },
        take_up: !a.no_take_up,
        trace_comments: !a.no_trace,
    })
}

/// Compensates `program` into `output`; returns the summary and records.
pub fn compensate_file(
    program: &Path,
    output: &Path,
    machine: &Machine,
    model: &dyn ErrorModel,
    options: &CompensateOptions,
    mut on_point: impl FnMut(&PointRecord),
) -> Result<CompensateSummary, CliError> {
    let mut head = Vec::with_capacity(1 << 16);
    std::fs::File::open(program)
        .and_then(|f| f.take(1 << 16).read_to_end(&mut head))
        .map_err(|e| CliError::Io(program.to_path_buf(), e))?;
    let style = survey_style(&head);
    let mut walker = machine.walk(program)?;
    let file = program.display().to_string();
    let mut summary = None;
    write_atomically(output, &[program], |out| {
        let s = compensate_program(
            &mut walker,
            &file,
            model,
            &style,
            options,
            out,
            &mut on_point,
        )
        .map_err(|e| machine.explain(e))?;
        summary = Some(s);
        Ok(())
    })?;
    summary.ok_or_else(|| CliError::Message("compensation produced no summary".into()))
}

pub fn run(a: CompensateArgs) -> Result<(), CliError> {
    let machine = Machine::from_args(&a.machine)?;
    machine.warn_without_work_offset();
    let model = load_map(&a.map)?;
    let opts = options(&a)?;
    let mut report: Option<Vec<u8>> = a.report.as_ref().map(|_| {
        b"line,target_x_mm,target_y_mm,target_z_mm,command_x_mm,command_y_mm,command_z_mm,iterations,residual_um,reversed,held,take_up\n".to_vec()
    });
    let summary = compensate_file(
        &a.program,
        &a.output,
        &machine,
        model.as_ref(),
        &opts,
        |p| {
            if let Some(r) = report.as_mut() {
                let axes = |f: [bool; 3]| -> String {
                    ['X', 'Y', 'Z']
                        .iter()
                        .zip(f)
                        .filter(|(_, b)| *b)
                        .map(|(c, _)| *c)
                        .collect()
                };
                let _ = writeln!(
                    r,
                    "{},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{},{:.6},{},{},{}",
                    p.line,
                    p.target_mm.x,
                    p.target_mm.y,
                    p.target_mm.z,
                    p.command_mm.x,
                    p.command_mm.y,
                    p.command_mm.z,
                    p.iterations,
                    p.residual_um,
                    axes(p.reversed),
                    axes(p.held),
                    p.take_up
                );
            }
        },
    )?;
    if let (Some(path), Some(bytes)) = (&a.report, report) {
        write_atomically(path, &[&a.program], |w| {
            w.write_all(&bytes)
                .map_err(|e| CliError::Io(path.clone(), e))
        })?;
    }
    eprintln!(
        "volcomp: wrote {} ({} lines from {}; {} points compensated, largest correction {:.2} µm, largest residual {:.4} µm, {} take-up moves)",
        a.output.display(),
        summary.lines_out,
        summary.lines_in,
        summary.points,
        summary.max_correction_um,
        summary.max_residual_um,
        summary.take_ups
    );
    if summary.held_count > 0 {
        let first: Vec<String> = summary
            .held
            .iter()
            .take(10)
            .map(|(l, a)| format!("line {l} ({a})"))
            .collect();
        eprintln!(
            "volcomp: warning: {} point(s) kept an axis still because the map's reversal value is negative there (forward error above reverse), so no command can reverse by less than it: {}",
            summary.held_count,
            first.join(", ")
        );
    }
    Ok(())
}
