//! `volcomp surface mirror`: free-form surface compensation from on-machine
//! probing (the mirror method, `docs/mirror.md`): the library's mirror
//! request runs; this module plans the files, writes them and prints.

use super::compensate::command_line;
use super::Machine;
use crate::args::surface::{MirrorArgs, SurfaceArgs, SurfaceCommand};
use crate::options::{flags, Flags};
use crate::output::{check, write_atomically, write_file, CliError, OutputPlan};
use crate::progress::Bar;
use std::io::Write;
use std::path::{Path, PathBuf};
use volcomp_core::io::provenance::now_utc;
use volcomp_core::progress::Counted;
use volcomp_core::request::{Input, MirrorPlan, MirrorRun};
use volcomp_core::surface::mirror::report::{
    compensated_surface_text, report_csv, summary_json, summary_text, FinishingJson, SurfaceFiles,
};
use volcomp_core::surface::mirror::{CompensatedSurface, DeviationField};

pub fn run(a: SurfaceArgs) -> Result<(), CliError> {
    match a.command {
        SurfaceCommand::Mirror(m) => run_mirror(m),
    }
}

fn path(input: &Option<Input>) -> Option<&Path> {
    input.as_ref().and_then(|i| i.path())
}

/// The base name of the compensated surface files.
fn surface_base(a: &MirrorArgs) -> PathBuf {
    a.surface_out.clone().unwrap_or_else(|| {
        let measured = path(&a.job.measured).unwrap_or(Path::new("surface"));
        let stem = measured
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "surface".into());
        measured.with_file_name(format!("{stem}.compensated"))
    })
}

fn with_suffix(base: &Path, suffix: &str) -> PathBuf {
    let mut s = base.as_os_str().to_owned();
    s.push(suffix);
    PathBuf::from(s)
}

fn plan(a: &MirrorArgs) -> Result<(), CliError> {
    let base = surface_base(a);
    let mut plan = OutputPlan::new();
    plan.input_opt("--nominal", path(&a.job.nominal))
        .input_opt("--measured", path(&a.job.measured))
        .input_opt("--finishing", path(&a.job.finishing))
        .input_opt("--setup", path(&a.job.machine.setup))
        .output_opt("-o", a.output.as_ref())
        .output_opt("--baseline", a.baseline.as_ref())
        .output("--surface-out (grid)", with_suffix(&base, ".csv"))
        .output("--surface-out (B-spline)", with_suffix(&base, ".toml"))
        .output_opt("--report", a.report.as_ref());
    check(&plan)?;
    match (&a.job.finishing, &a.output) {
        (Some(_), None) => Err(CliError::Message(
            "--finishing needs -o: the compensated finishing program's file".into(),
        )),
        (Some(Input::File(p)), _) if p.as_os_str() == "-" => Err(CliError::Message(
            "--finishing needs a file: the program is read twice (its frame first)".into(),
        )),
        _ => Ok(()),
    }
}

/// Writes the finishing program compensated for `field` to `out`.
fn finishing(
    a: &MirrorArgs,
    (plan, run): (&MirrorPlan, &MirrorRun),
    machine: &Machine,
    field: &DeviationField,
    out: &Path,
) -> Result<FinishingJson, CliError> {
    let (Some(Input::File(program)), Some(tool)) = (&a.job.finishing, &plan.tool) else {
        return Err(CliError::Internal("no finishing program".into()));
    };
    let file = program.display().to_string();
    let open = || {
        volcomp_core::io::inputs::open(program, "the finishing program")
            .map_err(|e| CliError::Io(program.clone(), e))
    };
    let frame = a
        .job
        .finishing_frame(machine, std::io::BufReader::new(open()?), &file)?;
    let baseline = a.baseline.as_deref() == Some(out);
    let header = a
        .job
        .finishing_header(plan, tool, machine, baseline, now_utc(), &Flags)?;
    let bar = Bar::reading(&format!("mirroring {}", program.display()), program);
    let mut summary = None;
    let written = write_atomically(out, &inputs(a), |w| {
        let reader = Counted::new(open()?, bar.clone());
        summary = Some(a.job.compensate_finishing(
            plan,
            run,
            field,
            machine,
            frame,
            (reader, &file),
            &header,
            w,
        )?);
        Ok(())
    });
    bar.finish();
    written?;
    let summary = summary.ok_or_else(|| CliError::Internal("no finishing summary".into()))?;
    Ok(FinishingJson::new(&out.display().to_string(), &summary))
}

fn inputs(a: &MirrorArgs) -> Vec<&Path> {
    [&a.job.nominal, &a.job.measured, &a.job.finishing]
        .into_iter()
        .filter_map(path)
        .collect()
}

/// The compensated surface's files (grid CSV and B-spline TOML).
fn write_surface(
    a: &MirrorArgs,
    plan: &MirrorPlan,
    run: &MirrorRun,
) -> Result<SurfaceFiles, CliError> {
    let base = surface_base(a);
    let (grid_path, toml_path) = (with_suffix(&base, ".csv"), with_suffix(&base, ".toml"));
    let comp = CompensatedSurface {
        nominal: &run.nominal,
        field: &run.result.field,
    };
    let text = compensated_surface_text(&run.inputs, &comp, plan.grid_size)?;
    for (path, content) in [
        (&grid_path, &text.grid_csv),
        (&toml_path, &text.bspline_toml),
    ] {
        write_file(path, &inputs(a), content.as_bytes())?;
    }
    Ok(SurfaceFiles {
        grid: grid_path.display().to_string(),
        grid_nodes: text.grid_nodes,
        bspline: toml_path.display().to_string(),
        bspline_net: text.bspline_net,
        bspline_error_um: text.bspline_error_um,
    })
}

fn write_report(path: &Path, a: &MirrorArgs, run: &MirrorRun) -> Result<(), CliError> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    let text = match ext.to_ascii_lowercase().as_str() {
        "html" => {
            let files = inputs(a);
            volcomp_core::report::mirror::document(
                &run.inputs,
                &run.result,
                &files,
                &command_line(),
            )?
        }
        "json" => {
            let j = summary_json(&run.inputs, &run.result, None, None, None, true);
            serde_json::to_string_pretty(&j)? + "\n"
        }
        _ => report_csv(&run.inputs, &run.result),
    };
    write_file(path, &inputs(a), text.as_bytes())
}

fn run_mirror(a: MirrorArgs) -> Result<(), CliError> {
    plan(&a)?;
    let plan = a.job.plan()?;
    let run = a.job.run(&plan)?;
    if let Some(w) = &run.worse {
        eprintln!("volcomp: warning: {}", flags(w));
    }
    // The finishing program first: it is the step most likely to be
    // refused, and nothing should be written then.
    let (mut finished, mut baseline) = (None, None);
    if let (Some(output), Some(_)) = (&a.output, &plan.tool) {
        let machine = super::machine(&a.job.machine)?;
        finished = Some(finishing(
            &a,
            (&plan, &run),
            &machine,
            &run.result.field,
            output,
        )?);
        if let Some(path) = &a.baseline {
            let s = run.nominal.surface();
            let constant =
                DeviationField::constant(run.result.baseline_offset_um, s.domain_u(), s.domain_v());
            baseline = Some(finishing(&a, (&plan, &run), &machine, &constant, path)?);
        }
    }
    let surface = write_surface(&a, &plan, &run)?;
    if let Some(path) = &a.report {
        write_report(path, &a, &run)?;
    }
    let text = if a.json {
        let j = summary_json(
            &run.inputs,
            &run.result,
            Some(&surface),
            finished,
            baseline,
            false,
        );
        serde_json::to_string(&j)? + "\n"
    } else {
        summary_text(
            &run.inputs,
            &run.result,
            &surface,
            finished.as_ref(),
            baseline.as_ref(),
        )
    };
    std::io::stdout()
        .lock()
        .write_all(text.as_bytes())
        .map_err(CliError::Stdout)
}
