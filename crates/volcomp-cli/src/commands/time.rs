//! `volcomp time`: a program's machining time on the planner model
//! (`volcomp_core::plan`), alone or beside the program it was made from.

use super::simulate::open;
use super::MachineExt;
use crate::args::TimeArgs;
use crate::output::CliError;
use std::io::Write;

pub fn run(a: TimeArgs) -> Result<(), CliError> {
    let reference = a.job.reference.as_ref().and_then(|r| r.path());
    if reference.is_some_and(|r| r.as_os_str() == "-") {
        return Err(CliError::Message(
            "--reference must name a file (standard input is for PROGRAM)".into(),
        ));
    }
    let machine = super::machine(&a.job.machine)?;
    let name = a.program.display().to_string();
    let t = a
        .job
        .run(&machine, open(&a.program)?, &name)
        .map_err(|e| machine.refused(e))?;
    let text = if a.json {
        serde_json::to_string(&t)? + "\n"
    } else {
        t.summary_lines().join("\n") + "\n"
    };
    std::io::stdout()
        .lock()
        .write_all(text.as_bytes())
        .map_err(CliError::Stdout)
}
