//! The human-readable report of `volcomp map iso230-2`.

use crate::output::CliError;
use std::io::Write;
use std::path::Path;
use volcomp_core::identify::iso230_2;

/// The human-readable ISO 230-2 evaluation.
pub(super) fn print_iso230_2(runs: &Path, r: &iso230_2::Iso230_2Report) -> Result<(), CliError> {
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    let mut w = |t: String| writeln!(out, "{t}").map_err(CliError::Stdout);
    w(format!(
        "{}: ISO 230-2 evaluation, {} target positions (µm)",
        runs.display(),
        r.targets.len()
    ))?;
    w("  target_mm     n↑  n↓     x̄↑       x̄↓       s↑      s↓      B_i      x̄_i     R↑_i    R↓_i    R_i".into())?;
    for t in &r.targets {
        w(format!(
            "  {:>10.3}  {:>3} {:>3}  {:>+8.3} {:>+8.3} {:>7.3} {:>7.3} {:>+8.3} {:>+8.3} {:>7.3} {:>7.3} {:>7.3}",
            t.target_mm, t.n_up, t.n_down, t.mean_up_um, t.mean_down_um, t.s_up_um, t.s_down_um,
            t.reversal_um, t.mean_um, t.repeatability_up_um, t.repeatability_down_um, t.repeatability_um
        ))?;
    }
    let f = r.axis;
    w(format!(
        "reversal value               B  = {:.3} µm   (mean reversal value B̄ = {:+.3} µm)",
        f.reversal_b_um, f.mean_reversal_um
    ))?;
    w(format!(
        "repeatability                R↑ = {:.3} µm   R↓ = {:.3} µm   R = {:.3} µm",
        f.repeatability_up_um, f.repeatability_down_um, f.repeatability_um
    ))?;
    w(format!(
        "systematic deviation         E↑ = {:.3} µm   E↓ = {:.3} µm   E = {:.3} µm",
        f.systematic_up_um, f.systematic_down_um, f.systematic_um
    ))?;
    w(format!(
        "mean bidirectional range     M  = {:.3} µm",
        f.mean_range_um
    ))?;
    w(format!(
        "accuracy                     A↑ = {:.3} µm   A↓ = {:.3} µm   A = {:.3} µm",
        f.accuracy_up_um, f.accuracy_down_um, f.accuracy_um
    ))?;
    for n in &r.notes {
        w(format!("note: {n}"))?;
    }
    Ok(())
}
