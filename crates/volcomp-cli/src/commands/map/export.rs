//! `volcomp map export --to FORMAT`: the library's export request
//! (`volcomp_core::request::MapExportRequest`: the controller's tables,
//! checked against the map, and the sign check), its notes and summary
//! printed.

use super::{load_map, write_text, ExportArgs};
use crate::options::flags;
use crate::output::{check, CliError, OutputPlan};
use std::io::Write;

pub fn export(a: ExportArgs) -> Result<(), CliError> {
    let mut plan = OutputPlan::new();
    plan.map_input("MAP", &a.map);
    for n in a.job.file_names()? {
        plan.output(format!("-o (its {n})"), a.output.join(n));
    }
    check(&plan)?;
    let map = load_map(&a.map, false)?;
    let out = a.job.run(map.view(), &a.map.display().to_string())?;
    std::fs::create_dir_all(&a.output).map_err(|err| CliError::Io(a.output.clone(), err))?;
    for f in out.files() {
        write_text(&a.output.join(&f.name), &[&a.map], &f.text)?;
    }
    let stdout = std::io::stdout();
    let mut w = stdout.lock();
    for n in &out.export.notes {
        writeln!(w, "# {n}").map_err(CliError::Stdout)?;
    }
    for line in out.summary(&a.output.display().to_string()) {
        crate::note!("{}", flags(&line));
    }
    Ok(())
}
