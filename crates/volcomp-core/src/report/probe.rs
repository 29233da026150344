//! The sections of a probing calibration's report (docs/probing.md): what
//! was identified and how well, what could not be seen, the probe's
//! calibration, the placements and the residuals in plan views, the
//! leave-one-placement-out predictions and the uncertainty of a compensated
//! position along the axes.

use super::svg::{self, Chart, Mark, PlanPanel, PlanPiece, Series};
use super::{Block, Section, Table};
use crate::identify::probe::identify::Status;
use crate::identify::probe::request::FitOutput;
use crate::identify::thermal::uncertainty::axis_line_bands;
use crate::io::numfmt;
use crate::io::probe_log::AxisDir;

fn row(cells: &[String]) -> Vec<String> {
    cells.to_vec()
}

/// The report's sections for a fit over `ranges_mm`.
pub fn sections(out: &FitOutput, ranges_mm: [[f64; 2]; 3]) -> Vec<Section> {
    let id = &out.identified;
    let mut s = Vec::new();
    // Parameters.
    let mut t = Table::new(
        &[
            "parameter",
            "value",
            "standard uncertainty",
            "unit",
            "status",
        ],
        &[false, true, true, false, false],
        Vec::new(),
    );
    // With a Monte Carlo, the two uncertainties it took the larger of.
    let mc = id.monte_carlo.as_ref();
    if let Some(mc) = mc {
        t.headers.splice(
            3..3,
            [
                "least squares".to_string(),
                format!("Monte Carlo ({} repeats)", mc.draws),
            ],
        );
        t.numeric.splice(3..3, [true, true]);
    }
    let both = |i: Option<usize>| -> Vec<String> {
        let Some(mc) = mc else { return Vec::new() };
        let cell = |v: Option<&Option<f64>>| {
            v.copied()
                .flatten()
                .map_or("–".into(), |v| numfmt::fixed(v, 3))
        };
        vec![
            cell(i.and_then(|i| mc.least_squares.get(i))),
            cell(i.and_then(|i| mc.sigma.get(i))),
        ]
    };
    for (i, p) in id.params.iter().enumerate() {
        let unit = if p.unit == "um" { "µm" } else { "µrad" };
        let (v, u, st) = match p.status {
            Status::Identified(e) => (
                numfmt::fixed(e.value, 3),
                numfmt::fixed(e.sigma, 3),
                "identified",
            ),
            Status::NotSeen => ("0".into(), "–".into(), "not seen: zero, unknown"),
            Status::NotInModel => (
                "0".into(),
                "–".into(),
                "not in the reduced model: zero, unknown",
            ),
        };
        let mut cells = vec![p.name.clone(), v, u];
        cells.extend(both(Some(i)));
        cells.extend([unit.into(), st.into()]);
        t.rows.push(cells);
    }
    for (a, b) in out.reversal_um.iter().enumerate() {
        let name = format!("reversal {}", ['X', 'Y', 'Z'][a]);
        let (v, u, st) = match b {
            Some(e) => (
                numfmt::fixed(e.value, 3),
                numfmt::fixed(e.sigma, 3),
                "identified (reference sphere)",
            ),
            None => ("0".into(), "–".into(), "not measured: zero, unknown"),
        };
        let mut cells = vec![name, v, u];
        cells.extend(both(None));
        cells.extend(["µm".into(), st.into()]);
        t.rows.push(cells);
    }
    let (rms, max) = crate::identify::probe::result::compensated_uncertainty_um(id, ranges_mm);
    let mut blocks = vec![
        Block::Text(format!(
            "{} observations, rank {} of {} parameters of the model; noise from the residuals σ0 = {} µm per touch (the weights assume {} µm). Uncertainty of a compensated position (1σ at the probe's length, over the volume): RMS {} µm, largest {} µm.",
            id.observations,
            id.ident.rank,
            id.model.len(),
            id.ident.sigma0_um.map_or("–".into(), |v| numfmt::fixed(v, 3)),
            numfmt::fixed(id.touch_sigma_um, 3),
            numfmt::fixed(rms, 2),
            numfmt::fixed(max, 2)
        )),
        Block::Table(t),
    ];
    if let Some(mc) = mc {
        blocks.push(Block::Text(format!(
            "Standard uncertainty: the larger of the least squares' and the Monte Carlo's, {} repeats of the whole fit (probe calibration, sphere centres, identification) with every touch moved by a draw of {} µm along its move (JCGM 101:2008).",
            mc.draws,
            numfmt::fixed(mc.noise_um, 3)
        )));
    }
    for n in &id.notes {
        blocks.push(Block::Text(format!("Note: {n}")));
    }
    for c in &id.combinations {
        blocks.push(Block::Text(format!(
            "Seen only together (not identified): {c}"
        )));
    }
    s.push(Section {
        id: "probe-parameters".into(),
        title: "Identified parameters and what cannot be seen".into(),
        blocks,
    });
    // Probe calibration.
    let mut blocks = Vec::new();
    for c in &out.fitted.calibrations {
        let mut t = Table::new(
            &["quantity", "value", "standard uncertainty"],
            &[false, true, true],
            vec![row(&[
                "effective tip radius (mm)".into(),
                numfmt::fixed(c.tip_radius_mm.value, 5),
                format!("{} µm", numfmt::fixed(c.tip_radius_mm.sigma, 3)),
            ])],
        );
        for d in AxisDir::ALL {
            if let Some(e) = c.pretravel_um[d.index()] {
                t.rows.push(row(&[
                    format!("pre-travel moving {} (µm)", d.label()),
                    numfmt::fixed(e.value, 3),
                    numfmt::fixed(e.sigma, 3),
                ]));
            }
        }
        blocks.push(Block::Text(format!(
            "Probe with tool length {} mm: {} touches on the reference sphere, residual noise {} µm.",
            numfmt::mm(c.tool_length_mm),
            c.residuals_um.len(),
            numfmt::fixed(c.sigma_um, 3)
        )));
        blocks.push(Block::Table(t));
        if !c.unseen.is_empty() {
            blocks.push(Block::Text(format!(
                "Not separated by the reference touches: {}.",
                c.unseen.join(", ")
            )));
        }
    }
    for w in &out.fitted.warnings {
        blocks.push(Block::Text(format!("Warning: {w}")));
    }
    if blocks.is_empty() {
        blocks.push(Block::Text("No reference sphere was probed: touches are not corrected for pre-travel and reversal.".into()));
    }
    s.push(Section {
        id: "probe-calibration".into(),
        title: "Probe calibration on the reference sphere".into(),
        blocks,
    });
    // Placements and residuals.
    let mut panels_xy = Vec::new();
    let mut panels_xz = Vec::new();
    let mut hi: f64 = 0.0;
    let mut placements: Vec<(String, String)> = Vec::new();
    for r in &id.residuals {
        let key = (r.artifact.clone(), r.placement.clone());
        if !placements.contains(&key) {
            placements.push(key);
        }
        hi = hi.max(r.residual_um.norm());
    }
    let mut xy = PlanPanel {
        title: "top view (X, Y)".into(),
        pieces: Vec::new(),
    };
    let mut xz = PlanPanel {
        title: "front view (X, Z)".into(),
        pieces: Vec::new(),
    };
    for r in &id.residuals {
        let v = r.residual_um.norm();
        xy.pieces.push(PlanPiece {
            points: vec![[r.at_mm.x, r.at_mm.y]],
            value: v,
        });
        xz.pieces.push(PlanPiece {
            points: vec![[r.at_mm.x, r.at_mm.z]],
            value: v,
        });
    }
    panels_xy.push(xy);
    panels_xz.push(xz);
    let mut blocks = vec![Block::Text(format!(
        "Every measured sphere centre and face touch of the {} placements, coloured by what the identified model leaves of it (µm): the artifact's own errors and the placements are solved together with the machine.",
        placements.len()
    ))];
    for (panels, y_label, caption) in [
        (
            &panels_xy,
            "Y (mm)",
            "Placements seen from above, residual per sphere or touch.",
        ),
        (&panels_xz, "Z (mm)", "Placements seen from the front."),
    ] {
        blocks.push(Block::Figure {
            svg: svg::plan_view(
                panels,
                (0.0, hi.max(1e-3)),
                6.0,
                "residual (µm)",
                "X (mm)",
                y_label,
            ),
            caption: caption.into(),
        });
    }
    let mut t = Table::new(
        &["artifact", "placement", "observations", "RMS residual (µm)"],
        &[false, false, true, true],
        Vec::new(),
    );
    for (a, p) in &placements {
        let v: Vec<f64> = id
            .residuals
            .iter()
            .filter(|r| &r.artifact == a && &r.placement == p)
            .map(|r| r.residual_um.norm_squared())
            .collect();
        let rms = (v.iter().sum::<f64>() / v.len().max(1) as f64).sqrt();
        t.rows.push(row(&[
            a.clone(),
            p.clone(),
            v.len().to_string(),
            numfmt::fixed(rms, 3),
        ]));
    }
    blocks.push(Block::Table(t));
    if !id.artifact_deviations.is_empty() {
        let mut t = Table::new(
            &["artifact", "feature", "dx", "dy", "dz"],
            &[false, false, true, true, true],
            Vec::new(),
        );
        for (a, f, d) in &id.artifact_deviations {
            t.rows.push(row(&[
                a.clone(),
                f.clone(),
                numfmt::fixed(d.x, 3),
                numfmt::fixed(d.y, 3),
                numfmt::fixed(d.z, 3),
            ]));
        }
        blocks.push(Block::Text("The artifacts as measured: deviation of each sphere from its nominal (or certified) place after the best rigid fit (µm); a gauge's faces relative to the first (µm, in dx); a square's angle from 90° (µrad, in dx).".into()));
        blocks.push(Block::Table(t));
    }
    s.push(Section {
        id: "probe-placements".into(),
        title: "Placements and residuals".into(),
        blocks,
    });
    // Leave one placement out.
    if !out.held_out.is_empty() {
        let mut t = Table::new(
            &[
                "artifact",
                "placement",
                "uncorrected (µm)",
                "predicted (µm)",
            ],
            &[false, false, true, true],
            Vec::new(),
        );
        let mut before = Vec::new();
        let mut after = Vec::new();
        for (k, h) in out.held_out.iter().enumerate() {
            t.rows.push(row(&[
                h.artifact.clone(),
                h.placement.clone(),
                numfmt::fixed(h.before_um, 3),
                numfmt::fixed(h.after_um, 3),
            ]));
            before.push(((k + 1) as f64, h.before_um));
            after.push(((k + 1) as f64, h.after_um));
        }
        let chart = Chart {
            x_label: "placement (in the table's order)".into(),
            y_label: "RMS deviation of the held-out centres (µm)".into(),
            series: vec![
                Series::xy("uncorrected", svg::PALETTE[0], Mark::Markers, &before),
                Series::xy(
                    "corrected by the model fitted without it",
                    svg::PALETTE[1],
                    Mark::Markers,
                    &after,
                ),
            ],
            y_from_zero: true,
            ..Chart::default()
        };
        s.push(Section {
            id: "probe-held-out".into(),
            title: "Leave-one-placement-out prediction".into(),
            blocks: vec![
                Block::Text("Each placement left out in turn: the machine identified from the others, then the left-out placement's sphere centres corrected by that model and compared with the artifact after the best rigid fit.".into()),
                Block::Table(t),
                Block::Figure { svg: svg::chart(&chart), caption: "RMS deviation of each held-out placement, before and after correction.".into() },
            ],
        });
    }
    // Uncertainty along the axes.
    let lines = axis_line_bands(&id.model, &id.ident, ranges_mm, id.probe_length_mm, 200);
    let mut blocks = vec![Block::Text("The identified error along three lines through the middle of the volume, each along one axis, with its 95 % band from the parameters' covariance (Monte Carlo, 200 draws): what a compensated position is uncertain by.".into())];
    for l in &lines {
        let a = l.axis;
        let name = ['X', 'Y', 'Z'][a];
        let pts =
            |f: &dyn Fn(&crate::identify::thermal::uncertainty::Band) -> f64| -> Vec<(f64, f64)> {
                l.points_mm
                    .iter()
                    .zip(&l.bands)
                    .map(|(p, b)| (p[a], f(b)))
                    .collect()
            };
        let chart = Chart {
            x_label: format!("{name} (mm)"),
            y_label: format!("error along {name} (µm)"),
            series: vec![
                Series::xy(
                    "identified",
                    svg::PALETTE[0],
                    Mark::Line,
                    &pts(&|b| b.estimate_um[a]),
                ),
                Series::xy(
                    "2.5 %",
                    svg::PALETTE[1],
                    Mark::Dashed,
                    &pts(&|b| b.lo_um[a]),
                ),
                Series::xy(
                    "97.5 %",
                    svg::PALETTE[1],
                    Mark::Dashed,
                    &pts(&|b| b.hi_um[a]),
                ),
            ],
            ..Chart::default()
        };
        blocks.push(Block::Figure {
            svg: svg::chart(&chart),
            caption: format!("Positioning error along the {name} line and its 95 % band."),
        });
    }
    s.push(Section {
        id: "probe-uncertainty".into(),
        title: "Uncertainty of the compensated position".into(),
        blocks,
    });
    s
}
