//! `volcomp time`: a program's machining time on the planner model
//! (`volcomp_core::plan`), alone or beside the program it was made from;
//! with `--per-line`, the time of each of its lines.

use super::simulate::open;
use super::MachineExt;
use crate::args::TimeArgs;
use crate::output::CliError;
use std::io::{BufRead, Write};
use volcomp_core::plan::LineTime;

pub fn run(a: TimeArgs) -> Result<(), CliError> {
    let reference = a.job.reference.as_ref().and_then(|r| r.path());
    if reference.is_some_and(|r| r.as_os_str() == "-") {
        return Err(CliError::Message(
            "--reference must name a file (standard input is for PROGRAM)".into(),
        ));
    }
    let machine = super::machine(&a.job.machine)?;
    let name = a.program.display().to_string();
    let input = open(&a.program)?;
    let (t, lines) = if a.per_line {
        a.job.run_per_line(&machine, input, &name)
    } else {
        a.job.run(&machine, input, &name).map(|t| (t, Vec::new()))
    }
    .map_err(|e| machine.refused(e))?;
    let text = if a.json {
        let mut v = serde_json::to_value(t)?;
        if a.per_line {
            v["per_line"] = serde_json::to_value(&lines)?;
        }
        serde_json::to_string(&v)? + "\n"
    } else {
        let mut out = t.summary_lines();
        if a.per_line {
            // The lines' text beside their times, when the program is a
            // file (standard input has been read).
            let texts = (a.program.as_os_str() != "-")
                .then(|| volcomp_core::io::inputs::open(&a.program, "a program").ok())
                .flatten()
                .map(std::io::BufReader::new);
            out.extend(per_line_rows(&lines, texts));
        }
        out.join("\n") + "\n"
    };
    std::io::stdout()
        .lock()
        .write_all(text.as_bytes())
        .map_err(CliError::Stdout)
}

/// The rows of `--per-line`: a heading, then per line its number, its
/// time, cutting and rapid time in ms, the speed its motion ends at
/// (mm/s), and its text when `program` gives it (read once, in step with
/// the rows, which are in line order).
fn per_line_rows(lines: &[LineTime], program: Option<impl BufRead>) -> Vec<String> {
    let mut rows = vec![format!(
        "time per line ({} lines): line, ms, cutting ms, rapid ms, end mm/s, text",
        lines.len()
    )];
    let mut texts = program.map(|p| p.lines());
    let mut at = 0u64;
    for l in lines {
        let mut text = String::new();
        let mut ended = false;
        if let Some(t) = texts.as_mut() {
            while at < l.line {
                at += 1;
                match t.next() {
                    Some(Ok(s)) if at == l.line => text = s,
                    Some(Ok(_)) => {}
                    _ => {
                        ended = true;
                        break;
                    }
                }
            }
        }
        if ended {
            texts = None;
        }
        rows.push(
            format!(
                "{:>8} {:>9.0} {:>9.0} {:>9.0} {:>8.1}  {}",
                l.line,
                l.total_s * 1e3,
                l.cutting_s * 1e3,
                l.rapid_s * 1e3,
                l.end_speed_mm_s,
                text.trim_end()
            )
            .trim_end()
            .to_string(),
        );
    }
    rows
}
