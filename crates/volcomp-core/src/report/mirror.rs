//! The report of a mirror compensation of a free-form surface
//! ([Mirror study], docs/mirror.md): the fit, the error statistics before
//! and after (fit residuals and the leave-one-out prediction), and the
//! probe points in plan view coloured by their measured surface error.

use super::svg::{self, PlanPanel, PlanPiece};
use super::{Block, Section, Table};
use crate::surface::mirror::report::fit_text;
use crate::surface::mirror::report::RunInputs;
use crate::surface::mirror::{DeviationStats, MirrorResult};

fn row(name: &str, s: &DeviationStats) -> Vec<String> {
    // No "-0.000" for values that round to zero.
    let z = |x: f64| format!("{:.3}", if x.abs() < 5e-4 { 0.0 } else { x });
    vec![
        name.to_string(),
        s.count.to_string(),
        z(s.mean_um),
        z(s.std_um),
        z(s.min_um),
        z(s.max_um),
        z(s.profile_um),
        z(s.range_um),
    ]
}

/// The HTML report of a mirror run: what was given, every input file
/// (`files`, with their SHA-256), the statistics and the probe points;
/// `command` is the command (or call) as given.
pub fn document(
    run: &RunInputs,
    r: &MirrorResult,
    files: &[&std::path::Path],
    command: &str,
) -> Result<String, crate::Error> {
    let mut inputs = Vec::new();
    for p in files {
        inputs.push(super::InputFile::read("input", p)?);
    }
    let doc = super::Document {
        title: format!("volcomp mirror compensation report: {}", run.measured),
        facts: vec![
            ("command".into(), command.to_string()),
            ("volcomp".into(), env!("CARGO_PKG_VERSION").into()),
            ("date (UTC)".into(), crate::io::provenance::now_utc()),
            ("nominal surface".into(), run.nominal.clone()),
            ("probe points".into(), run.measured.clone()),
            ("stock D".into(), format!("{} mm", run.stock_mm)),
            (
                "probe ball radius".into(),
                run.probe_radius_mm
                    .map_or("points are surface points".into(), |r| format!("{r} mm")),
            ),
        ],
        inputs,
        sections: sections(r),
        ..Default::default()
    };
    Ok(doc.to_html())
}

/// The sections: statistics with the fit, then the probe points.
pub fn sections(r: &MirrorResult) -> Vec<Section> {
    let mut rows = vec![
        row("measured (no compensation)", &r.before),
        row("after the tool-radius baseline", &r.baseline),
        row("mirror, fit residuals (in-sample)", &r.mirror_fit),
    ];
    if let Some(p) = &r.mirror_predicted {
        rows.push(row("mirror, leave-one-out prediction", p));
    }
    let mut blocks = vec![
        Block::Text(format!("Fit: {}.", fit_text(&r.fit))),
        Block::Table(Table {
            headers: [
                "surface error",
                "points",
                "mean (µm)",
                "std (µm)",
                "min (µm)",
                "max (µm)",
                "profile (µm)",
                "range (µm)",
            ]
            .iter()
            .map(|h| h.to_string())
            .collect(),
            rows,
            numeric: vec![false, true, true, true, true, true, true, true],
        }),
        Block::Text(format!(
            "Tool-radius baseline offset: {:.3} µm (the mean error, removed by a constant offset).",
            r.baseline_offset_um
        )),
    ];
    if r.compensation_predicted_worse() {
        blocks.push(Block::Text("Warning: the leave-one-out prediction after mirror compensation scatters more than the measured error itself: the fit does not predict the error where it was not probed, and compensating would likely make the surface worse (docs/mirror.md).".into()));
    }
    let (lo, hi) = r
        .points
        .iter()
        .map(|p| p.error_um)
        .filter(|e| e.is_finite())
        .fold((f64::MAX, f64::MIN), |(a, b), e| (a.min(e), b.max(e)));
    let panel = PlanPanel {
        title: "semi-finishing error at the probe points".into(),
        pieces: r
            .points
            .iter()
            .map(|p| PlanPiece {
                points: vec![[p.measured_mm.x, p.measured_mm.y]],
                value: p.error_um,
            })
            .collect(),
    };
    let plan = svg::plan_view(
        &[panel],
        (lo.min(hi), hi.max(lo)),
        8.0,
        "semi-finishing error (µm)",
        "X (mm)",
        "Y (mm)",
    );
    vec![
        Section {
            id: "mirror".into(),
            title: "Mirror compensation: errors before and after".into(),
            blocks,
        },
        Section {
            id: "mirror-points".into(),
            title: "The probe points".into(),
            blocks: vec![Block::Figure {
                svg: plan,
                caption: "Each probe point seen from above (X, Y in mm), coloured by its semi-finishing error along the outward normal, (P_R − P_P)·V_N − D in µm: positive where material is left.".into(),
            }],
        },
    ]
}
