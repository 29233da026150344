//! `volcomp time`: a program's machining time on the planner model
//! (`volcomp_core::plan`), alone or beside the program it was made from.

use super::simulate::open;
use super::Machine;
use crate::args::TimeArgs;
use crate::output::CliError;
use std::io::Write;
use volcomp_core::plan::compare_programs;

pub fn run(a: TimeArgs) -> Result<(), CliError> {
    if a.reference.as_ref().is_some_and(|r| r.as_os_str() == "-") {
        return Err(CliError::Message(
            "--reference must name a file (standard input is for PROGRAM)".into(),
        ));
    }
    let machine = Machine::from_args(&a.machine)?;
    let name = a.program.display().to_string();
    let ref_name = a.reference.as_ref().map(|r| r.display().to_string());
    let original = match (&a.reference, &ref_name) {
        (Some(r), Some(n)) => Some((open(r)?, n.as_str())),
        _ => None,
    };
    let t = compare_programs((open(&a.program)?, name.as_str()), original, &machine)
        .map_err(|e| machine.explain(e))?;
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    if a.json {
        let text = serde_json::to_string(&t)?;
        writeln!(out, "{text}").map_err(CliError::Stdout)?;
    } else {
        for line in t.summary_lines() {
            writeln!(out, "{line}").map_err(CliError::Stdout)?;
        }
    }
    Ok(())
}
