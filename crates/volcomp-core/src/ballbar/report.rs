//! What the ballbar jobs show: the figures and the causes as text lines,
//! and the HTML report's pictures: the polar plot (both runs, the nominal
//! circle, the scale rings, the figures), the causes as bars, before and
//! after overlaid (docs/ballbar.md, "Pictures").

use super::{Figures, Sense, Trace, TraceFit};
use crate::io::numfmt::um;
use crate::report::svg::{escape, nice_ticks, tick_label, PALETTE};
use crate::report::{Block, Document, Section, Table};
use std::fmt::Write;

/// The figures as lines of text.
pub fn figures_lines(f: &Figures) -> Vec<String> {
    let opt = |v: Option<f64>| v.map_or("-".to_string(), um);
    vec![
        format!(
            "circular deviation G     {} um (ccw {}, cw {})",
            um(f.g_um),
            opt(f.g_ccw_um),
            opt(f.g_cw_um)
        ),
        format!("circular hysteresis H    {} um", opt(f.h_um)),
        format!(
            "radial deviation F       max {} um, min {} um",
            um(f.f_max_um),
            um(f.f_min_um)
        ),
        format!(
            "least-squares circle     centre {}, {} um from the pivot; radius {} um from nominal",
            um(f.lsc_centre_um[0]),
            um(f.lsc_centre_um[1]),
            um(f.lsc_radius_um)
        ),
    ]
}

/// The quick model as lines of text.
pub fn quick_lines(m: &super::quick_map::QuickModel) -> Vec<String> {
    let three = |v: [f64; 3], names: [&str; 3]| {
        (0..3)
            .map(|i| format!("{} {}", names[i], um(v[i])))
            .collect::<Vec<_>>()
            .join("  ")
    };
    vec![
        format!(
            "scale (um/m)        {}",
            three(m.scale_um_per_m, ["X", "Y", "Z"])
        ),
        format!(
            "squareness (urad)   {}",
            three(m.squareness_urad, ["XY", "YZ", "ZX"])
        ),
        format!(
            "backlash (um)       {}",
            three(m.backlash_um, ["X", "Y", "Z"])
        ),
    ]
}

/// The causes as lines of text, the largest share first.
pub fn fit_lines(fit: &TraceFit) -> Vec<String> {
    let mut out = figures_lines(&fit.figures);
    out.push(format!(
        "{:<38} {:>12} {:>10} {:>7} {:>9} {:>7}",
        "cause", "value", "std", "unit", "rms um", "share"
    ));
    let mut causes: Vec<_> = fit.causes.iter().collect();
    causes.sort_by(|a, b| b.share_pct.total_cmp(&a.share_pct));
    for c in causes {
        out.push(format!(
            "{:<38} {:>12} {:>10} {:>7} {:>9} {:>6.1}%",
            c.label,
            um(c.value),
            um(c.std),
            c.unit,
            um(c.rms_um),
            c.share_pct
        ));
    }
    out.push(format!(
        "residual (no cause)                    rms {} um over {} samples",
        um(fit.residual_rms_um),
        fit.samples
    ));
    out
}

const SIZE: f64 = 560.0;

/// Each run's radial deviations about the least-squares circle of all the
/// trace's runs (the centre offset and the radius removed, as the figures
/// see the trace); the raw deviations if the circle is undetermined.
fn centred(t: &Trace) -> Vec<Vec<f64>> {
    let pts: Vec<[f64; 2]> = t
        .runs
        .iter()
        .flat_map(|r| super::figures::points(r, t.radius_mm))
        .collect();
    match super::figures::least_squares_circle(&pts, t.radius_mm) {
        Some(c) => t
            .runs
            .iter()
            .map(|r| super::figures::about(r, t.radius_mm, &c))
            .collect(),
        None => t.runs.iter().map(|r| r.deviation_um.clone()).collect(),
    }
}

/// The polar plot of `traces` (name, trace; the first in full colour, the
/// others dashed): the deviations about each trace's least-squares circle,
/// magnified about the nominal circle.
pub fn polar_svg(traces: &[(&str, &Trace)]) -> String {
    let devs: Vec<Vec<Vec<f64>>> = traces.iter().map(|(_, t)| centred(t)).collect();
    let all = devs.iter().flatten().flatten().copied();
    let peak = all.fold(0.0_f64, |m, d| m.max(d.abs())).max(0.1);
    let (ticks, step) = nice_ticks(-peak, peak, 4);
    let span = ticks.iter().fold(peak, |m, t| m.max(t.abs()));
    let (cx, cy) = (SIZE / 2.0, SIZE / 2.0);
    let r0 = SIZE * 0.30;
    let k = SIZE * 0.15 / span; // pixels per µm
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 {SIZE} {}\" font-size=\"13\" font-family=\"DejaVu Sans, sans-serif\">",
        SIZE + 24.0 * traces.len() as f64 * 2.0
    );
    for t in &ticks {
        let r = r0 + k * t;
        if r <= 0.0 {
            continue;
        }
        let (stroke, dash) = if *t == 0.0 {
            ("#444", "")
        } else {
            ("#bbb", " stroke-dasharray=\"4 3\"")
        };
        let _ = write!(
            s,
            "<circle cx=\"{cx}\" cy=\"{cy}\" r=\"{r:.2}\" fill=\"none\" stroke=\"{stroke}\"{dash}/><text x=\"{:.1}\" y=\"{:.1}\" fill=\"#555\">{} µm</text>",
            cx + r * 0.72 + 3.0,
            cy - r * 0.72 - 3.0,
            tick_label(*t, step)
        );
    }
    if let Some((_, t)) = traces.first() {
        let (u, v) = t.plane.axis_names();
        let _ = write!(
            s,
            "<line x1=\"{:.1}\" y1=\"{cy}\" x2=\"{:.1}\" y2=\"{cy}\" stroke=\"#ddd\"/><line x1=\"{cx}\" y1=\"{:.1}\" x2=\"{cx}\" y2=\"{:.1}\" stroke=\"#ddd\"/><text x=\"{:.1}\" y=\"{:.1}\">+{u}</text><text x=\"{:.1}\" y=\"18\">+{v}</text>",
            cx - SIZE * 0.48,
            cx + SIZE * 0.48,
            cy - SIZE * 0.48,
            cy + SIZE * 0.48,
            SIZE - 26.0,
            cy - 6.0,
            cx + 6.0
        );
    }
    let mut legend = Vec::new();
    for (i, (name, t)) in traces.iter().enumerate() {
        for (run, dev) in t.runs.iter().zip(&devs[i]) {
            let colour = match run.sense {
                Sense::Ccw => PALETTE[0],
                Sense::Cw => PALETTE[1],
            };
            let dash = if i == 0 {
                ""
            } else {
                " stroke-dasharray=\"5 4\""
            };
            let mut d = String::new();
            for (j, (a, dev)) in run.angle_deg.iter().zip(dev).enumerate() {
                let r = (r0 + k * dev).max(0.0);
                let th = a.to_radians();
                let _ = write!(
                    d,
                    "{}{:.2},{:.2}",
                    if j == 0 { "M" } else { " L" },
                    cx + r * th.cos(),
                    cy - r * th.sin()
                );
            }
            d.push_str(" Z");
            let _ = write!(
                s,
                "<path d=\"{d}\" fill=\"none\" stroke=\"{colour}\" stroke-width=\"1.4\"{dash}/>"
            );
            legend.push((format!("{name}: {}", run.sense.name()), colour, dash));
        }
    }
    for (j, (text, colour, dash)) in legend.iter().enumerate() {
        let y = SIZE + 14.0 + 22.0 * j as f64;
        let _ = write!(
            s,
            "<line x1=\"20\" y1=\"{y}\" x2=\"50\" y2=\"{y}\" stroke=\"{colour}\" stroke-width=\"2\"{dash}/><text x=\"58\" y=\"{:.1}\">{}</text>",
            y + 4.0,
            escape(text)
        );
    }
    s.push_str("</svg>");
    s
}

/// The causes' RMS on the trace as horizontal bars, the largest first.
pub fn causes_svg(fit: &TraceFit) -> String {
    let mut causes: Vec<_> = fit.causes.iter().collect();
    causes.sort_by(|a, b| b.rms_um.total_cmp(&a.rms_um));
    let peak = causes.first().map_or(1.0, |c| c.rms_um).max(1e-3);
    let (row, left, width) = (20.0, 300.0, 680.0);
    let h = row * causes.len() as f64 + 30.0;
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 {width} {h}\" font-size=\"12\" font-family=\"DejaVu Sans, sans-serif\">"
    );
    for (i, c) in causes.iter().enumerate() {
        let y = 10.0 + row * i as f64;
        let w = (width - left - 150.0) * c.rms_um / peak;
        let _ = write!(
            s,
            "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\">{}</text><rect x=\"{left}\" y=\"{y:.1}\" width=\"{w:.1}\" height=\"{:.1}\" fill=\"{}\"/><text x=\"{:.1}\" y=\"{:.1}\">{} µm ({:.1} %)</text>",
            left - 6.0,
            y + 13.0,
            escape(&c.label),
            row - 5.0,
            PALETTE[0],
            left + w + 4.0,
            y + 13.0,
            um(c.rms_um),
            c.share_pct
        );
    }
    let _ = write!(
        s,
        "<text x=\"{left}\" y=\"{:.1}\" fill=\"#555\">RMS of each cause's signature on the trace (µm)</text></svg>",
        h - 4.0
    );
    s
}

fn figures_table(rows: &[(&str, &Figures)]) -> Table {
    let opt = |v: Option<f64>| v.map_or("-".to_string(), um);
    Table {
        headers: [
            "trace",
            "G (µm)",
            "G ccw (µm)",
            "G cw (µm)",
            "H (µm)",
            "F max (µm)",
            "F min (µm)",
        ]
        .map(String::from)
        .to_vec(),
        rows: rows
            .iter()
            .map(|(n, f)| {
                vec![
                    n.to_string(),
                    um(f.g_um),
                    opt(f.g_ccw_um),
                    opt(f.g_cw_um),
                    opt(f.h_um),
                    um(f.f_max_um),
                    um(f.f_min_um),
                ]
            })
            .collect(),
        numeric: vec![false, true, true, true, true, true, true],
    }
}

/// The report's sections for `traces` (name, trace, figures; the first is
/// "after" when there are two), and the fit of the first when given.
pub fn sections(traces: &[(&str, &Trace, &Figures)], fit: Option<&TraceFit>) -> Vec<Section> {
    let pairs: Vec<(&str, &Trace)> = traces.iter().map(|(n, t, _)| (*n, *t)).collect();
    let rows: Vec<(&str, &Figures)> = traces.iter().map(|(n, _, f)| (*n, *f)).collect();
    let mut blocks = vec![
        Block::Text("ISO 230-4 figures: G is the circular deviation (both runs about their common least-squares circle; per run about its own), H the circular hysteresis, F the radial deviation from the nominal radius about the least-squares centre (docs/ballbar.md, \"Figures\").".into()),
        Block::Table(figures_table(&rows)),
        Block::Figure {
            svg: polar_svg(&pairs),
            caption: "Radial deviation around the circle about each trace's least-squares circle (centre offset and radius removed), magnified: the grey circle is 0, the dashed rings the scale; blue counter-clockwise, orange clockwise; a dashed trace is the one before.".into(),
        },
    ];
    let mut out = vec![];
    if let Some(f) = fit {
        blocks.push(Block::Figure {
            svg: causes_svg(f),
            caption: "What each fitted cause explains of the trace.".into(),
        });
        let mut causes = Table {
            headers: ["cause", "value", "std", "unit", "RMS (µm)", "share (%)"]
                .map(String::from)
                .to_vec(),
            rows: vec![],
            numeric: vec![false, true, true, false, true, true],
        };
        for c in &f.causes {
            causes.rows.push(vec![
                c.label.clone(),
                um(c.value),
                um(c.std),
                c.unit.to_string(),
                um(c.rms_um),
                format!("{:.1}", c.share_pct),
            ]);
        }
        out.push(Section {
            id: "causes".into(),
            title: "Causes".into(),
            blocks: vec![
                Block::Text(format!(
                    "Fitted by least squares (docs/ballbar.md, \"Signatures\"); residual RMS {} µm over {} samples.",
                    um(f.residual_rms_um),
                    f.samples
                )),
                Block::Table(causes),
            ],
        });
    }
    out.insert(
        0,
        Section {
            id: "trace".into(),
            title: "Circular test".into(),
            blocks,
        },
    );
    out
}

/// A whole report.
pub fn document(title: &str, facts: Vec<(String, String)>, sections: Vec<Section>) -> Document {
    Document {
        title: title.into(),
        facts,
        inputs: vec![],
        sections,
        ..Default::default()
    }
}
