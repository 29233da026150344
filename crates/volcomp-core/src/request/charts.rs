//! Charts as data — title, axis labels, series, scales, reference lines —
//! for every job that draws (the map's components, the thermal model, the
//! straightness fit, a simulation's errors along the path): a front end
//! rasterises them (SVG, PNG) or the library puts them in an HTML report
//! ([`charts_report`]).

use crate::identify::straightness::identify::{AxisFit, Fit, FitOptions};
use crate::identify::thermal::files::{ParamFit, ThermalModelFile};
use crate::identify::thermal::uncertainty::LineBands;
use crate::report::charts::{sections, Titled};
use crate::report::map::ComponentChart;
use crate::report::{svg, Document, InputFile};
use std::path::Path;

/// One line (or point set) of a chart.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// Points `(x, y)`.
    pub points: Vec<(f64, f64)>,
    /// Draw markers instead of a line.
    pub markers: bool,
    /// Palette index; by default the series' position. Markers and the
    /// line fitted to them share one colour this way.
    pub colour: Option<usize>,
}

impl Series {
    /// A line series.
    pub fn line(label: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self {
            label: label.into(),
            points,
            markers: false,
            colour: None,
        }
    }

    /// A marker series.
    pub fn markers(label: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self {
            label: label.into(),
            points,
            markers: true,
            colour: None,
        }
    }

    /// The same series drawn in palette colour `index`.
    pub fn colour(mut self, index: usize) -> Self {
        self.colour = Some(index);
        self
    }
}

/// A chart: title, axis labels, series and optional vertical marker lines.
#[derive(Debug, Clone, Default)]
pub struct Chart {
    /// What the chart shows.
    pub title: String,
    /// The x axis' quantity and unit.
    pub x_label: String,
    /// The y axis' quantity and unit.
    pub y_label: String,
    /// The series, drawn in order.
    pub series: Vec<Series>,
    /// Vertical lines `(x, label)`, e.g. a chosen cut-off.
    pub vlines: Vec<(f64, String)>,
    /// Logarithmic y axis (values must be positive).
    pub log_y: bool,
    /// Logarithmic x axis (values must be positive).
    pub log_x: bool,
}

/// Okabe and Ito's colours ([Okabe & Ito 2008]), as in the HTML reports:
/// blue, vermillion, bluish green, reddish purple, orange, sky blue, yellow,
/// black.
pub const PALETTE: [(u8, u8, u8); 8] = [
    (0, 114, 178),
    (213, 94, 0),
    (0, 158, 115),
    (204, 121, 167),
    (230, 159, 0),
    (86, 180, 233),
    (240, 228, 66),
    (0, 0, 0),
];

/// The colour of the `i`-th series `s` of a chart.
pub fn series_colour(i: usize, s: &Series) -> (u8, u8, u8) {
    PALETTE[s.colour.unwrap_or(i) % PALETTE.len()]
}

/// A chart as the library's report draws it: the same series, colours,
/// marks, axes (logarithmic too) and reference lines.
pub fn to_report_chart(c: &Chart) -> svg::Chart {
    use svg::{self as rs, Mark};
    let series = c
        .series
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let colour = series_colour(i, s);
            rs::Series::xy(
                s.label.clone(),
                &format!("#{:02X}{:02X}{:02X}", colour.0, colour.1, colour.2),
                if s.markers { Mark::Markers } else { Mark::Line },
                &s.points,
            )
        })
        .collect();
    rs::Chart {
        x_label: c.x_label.clone(),
        y_label: c.y_label.clone(),
        plot_height: 230.0,
        series,
        vrules: c.vlines.clone(),
        log_x: c.log_x,
        log_y: c.log_y,
        ..rs::Chart::default()
    }
}

/// `charts` as a self-contained HTML report titled `title`, naming its
/// `inputs` and the `command` that made it: charts whose titles share the
/// text before ": " share a page, others go two to a page.
pub fn charts_report(
    charts: &[Chart],
    title: &str,
    inputs: Vec<InputFile>,
    command: &str,
) -> String {
    let mut groups: Vec<(String, Vec<Titled>)> = Vec::new();
    for c in charts {
        let key = c.title.split_once(": ").map(|(k, _)| k.to_string());
        let titled = Titled {
            title: c.title.clone(),
            chart: to_report_chart(c),
        };
        match (groups.last_mut(), &key) {
            (Some((heading, list)), Some(k)) if heading == k => list.push(titled),
            (Some((heading, list)), None) if heading.is_empty() && list.len() < 2 => {
                list.push(titled)
            }
            _ => groups.push((key.unwrap_or_default(), vec![titled])),
        }
    }
    for (heading, list) in &mut groups {
        if heading.is_empty() {
            *heading = list
                .iter()
                .map(|t| t.title.as_str())
                .collect::<Vec<_>>()
                .join("; ");
        }
    }
    Document {
        title: title.to_string(),
        facts: super::run_facts(command),
        inputs,
        sections: sections(&groups),
        ..Default::default()
    }
    .to_html()
}

/// The thermal model's charts: per unit of its `top` most drifting
/// parameters their evolution and regression residuals, then the
/// temperatures and the probing noise.
pub fn thermal_charts(m: &ThermalModelFile, top: usize) -> Vec<Chart> {
    let order = m.by_drift(top);
    // One chart per unit: linear parameters in µm and angular ones in µrad
    // never share an axis. Each parameter's markers (identified) and line
    // (regression) share one colour.
    let mut units: Vec<&str> = Vec::new();
    for p in &order {
        if !units.contains(&p.unit.as_str()) {
            units.push(p.unit.as_str());
        }
    }
    let mut charts = Vec::new();
    for unit_file in &units {
        charts.extend(parameter_charts(m, &order, unit_file));
    }
    charts.extend(run_charts(m));
    charts
}

/// The evolution and the regression residuals of the parameters in one
/// unit (µm and µrad never share an axis); each parameter's markers
/// (identified) and line (regression) share one colour.
fn parameter_charts(m: &ThermalModelFile, order: &[&ParamFit], unit_file: &str) -> [Chart; 2] {
    let t = &m.time_h;
    let unit = super::unit_symbol(unit_file).to_string();
    let mut evolution = Chart {
        title: format!(
            "Parameters in {unit} over time: identified (markers) and regression (lines)"
        ),
        x_label: "time (h)".into(),
        y_label: format!("value − first cycle ({unit})"),
        ..Chart::default()
    };
    let mut residuals = Chart {
        title: format!("Regression residuals of the parameters in {unit}"),
        x_label: "time (h)".into(),
        y_label: format!("identified − regression ({unit})"),
        ..Chart::default()
    };
    for (colour, p) in order.iter().filter(|p| p.unit == *unit_file).enumerate() {
        let base = p.identified[0];
        let label = format!("{} ({unit})", p.name);
        evolution.series.push(
            Series::markers(
                format!("{label} identified"),
                t.iter()
                    .zip(&p.identified)
                    .map(|(x, v)| (*x, v - base))
                    .collect(),
            )
            .colour(colour),
        );
        let f = m.fitted(p);
        evolution.series.push(
            Series::line(
                format!("{label} regression"),
                f.iter().map(|(x, v)| (*x, v - base)).collect(),
            )
            .colour(colour),
        );
        residuals.series.push(
            Series::line(
                label,
                f.iter()
                    .map(|(x, v)| {
                        let c = t.iter().position(|y| y == x).unwrap_or(0);
                        (*x, p.identified[c] - v)
                    })
                    .collect(),
            )
            .colour(colour),
        );
    }
    [evolution, residuals]
}

/// The temperatures and the probing noise per cycle.
fn run_charts(m: &ThermalModelFile) -> [Chart; 2] {
    let t = &m.time_h;
    let mut temps = Chart {
        title: "Temperatures".into(),
        x_label: "time (h)".into(),
        y_label: "temperature (°C)".into(),
        ..Chart::default()
    };
    for (s, name) in m.sensors.iter().enumerate() {
        temps.series.push(Series::line(
            name.clone(),
            t.iter()
                .zip(&m.temperatures_c)
                .map(|(x, v)| (*x, v[s]))
                .collect(),
        ));
    }
    let noise = Chart {
        title: "Probing noise estimated from the artifact residuals per cycle".into(),
        x_label: "time (h)".into(),
        y_label: "σ0 (µm)".into(),
        series: vec![Series::markers(
            "σ0",
            t.iter().zip(&m.sigma0_um).map(|(x, v)| (*x, *v)).collect(),
        )],
        ..Chart::default()
    };
    [temps, noise]
}

/// One chart per axis line: the component along the line's own axis (what a
/// part dimension sees), its estimate and 2.5 / 97.5 % quantiles.
pub fn band_charts(lines: &[LineBands], samples: usize) -> Vec<Chart> {
    lines
        .iter()
        .map(|l| {
            let a = l.axis;
            let name = ['X', 'Y', 'Z'][a];
            let mut series = [Vec::new(), Vec::new(), Vec::new()];
            for (p, b) in l.points_mm.iter().zip(&l.bands) {
                series[0].push((p[a], b.estimate_um[a]));
                series[1].push((p[a], b.lo_um[a]));
                series[2].push((p[a], b.hi_um[a]));
            }
            let [est, lo95, hi95] = series;
            Chart {
                title: format!("identified e_{} along {name} through the middle, 95 % Monte Carlo band ({samples} draws)", name.to_ascii_lowercase()),
                x_label: format!("{name} (mm)"),
                y_label: "deviation (µm)".into(),
                series: vec![Series::line("estimate", est), Series::line("2.5 %", lo95), Series::line("97.5 %", hi95)],
                ..Chart::default()
            }
        })
        .collect()
}

/// Four charts per axis: the spectra per feed rate, P̄(λ) with P_t, σ(λ)
/// with σ_t (all over the wavelength λ in mm on a logarithmic axis, with the
/// cut-off marked), and the measured
/// mean profiles against the model.
pub fn straightness_charts(f: &Fit, o: &FitOptions) -> Vec<Chart> {
    let mut out = Vec::new();
    for a in &f.axes {
        let letter = a.axis.letter();
        let half = a.mean_power.len() - 1;
        let lg = |k: usize| a.wavelength_mm(k);
        let cutoff = vec![(
            a.cutoff_wavelength_mm,
            format!(
                "cut-off λ_c = {:.3} mm (m = {})",
                a.cutoff_wavelength_mm, a.harmonics
            ),
        )];
        let x_label = "wavelength λ (mm, logarithmic)".to_string();
        let (x_lo, x_hi) = (lg(half), lg(1));
        out.push(Chart {
            title: format!(
                "{letter}: power spectra of the averaged runs per feed rate (normalised)"
            ),
            x_label: x_label.clone(),
            y_label: "normalised power (1)".into(),
            series: a
                .feeds
                .iter()
                .map(|g| {
                    Series::line(
                        format!("{} mm/min ({} runs)", g.feed_mm_per_min, g.files.len()),
                        (1..=half).map(|k| (lg(k), g.power[k])).collect(),
                    )
                })
                .collect(),
            vlines: cutoff.clone(),
            log_y: true,
            log_x: true,
        });
        out.push(Chart {
            title: format!("{letter}: mean normalised power P(λ) across feed rates"),
            x_label: x_label.clone(),
            y_label: "mean normalised power (1)".into(),
            series: vec![
                Series::line(
                    "mean power P(λ)",
                    (1..=half).map(|k| (lg(k), a.mean_power[k])).collect(),
                ),
                Series::line(
                    format!("P_t = {}", o.p_t),
                    vec![(x_lo, o.p_t), (x_hi, o.p_t)],
                ),
                Series::markers(
                    "σ < σ_t and mean P > P_t",
                    a.passing
                        .iter()
                        .map(|&k| (lg(k), a.mean_power[k]))
                        .collect(),
                ),
            ],
            vlines: cutoff.clone(),
            log_y: true,
            log_x: true,
        });
        out.push(Chart {
            title: format!("{letter}: relative standard deviation σ(λ) across feed rates"),
            x_label,
            y_label: "σ / mean power (1)".into(),
            series: vec![
                Series::line("σ(λ)", (1..=half).map(|k| (lg(k), a.sigma[k])).collect()),
                Series::line(
                    format!("σ_t = {}", o.sigma_t),
                    vec![(x_lo, o.sigma_t), (x_hi, o.sigma_t)],
                ),
            ],
            vlines: cutoff,
            log_y: true,
            log_x: true,
        });
        out.push(profile_chart(a));
    }
    out
}

fn profile_chart(a: &AxisFit) -> Chart {
    let pts = |v: &[f64]| -> Vec<(f64, f64)> {
        a.positions_mm
            .iter()
            .copied()
            .zip(v.iter().copied())
            .collect()
    };
    let mut series: Vec<Series> = a
        .feeds
        .iter()
        .map(|g| {
            Series::line(
                format!("measured, mean at {} mm/min", g.feed_mm_per_min),
                pts(&g.mean_profile_um),
            )
        })
        .collect();
    series.push(Series::line(
        format!("model (m = {})", a.harmonics),
        pts(&a.model_profile_um),
    ));
    let residual: Vec<f64> = a
        .mean_profile_um
        .iter()
        .zip(&a.model_profile_um)
        .map(|(m, p)| m - p)
        .collect();
    series.push(Series::line(
        "mean of all feed rates − model",
        pts(&residual),
    ));
    Chart {
        title: format!(
            "{}: measured vs modelled straightness e_z({})",
            a.axis.letter(),
            a.axis.letter().to_ascii_lowercase()
        ),
        x_label: format!("{} position (mm)", a.axis.letter()),
        y_label: "Z deviation (µm)".into(),
        series,
        vlines: Vec::new(),
        log_y: false,
        log_x: false,
    }
}

/// The chart of the errors along the path.
pub fn simulate_chart(program: &Path, along: &[(f64, Option<f64>, f64)]) -> Chart {
    let points = along.iter().filter_map(|(s, p, _)| p.map(|p| (*s, p)));
    Chart {
        title: format!("{}: error along the path", program.display()),
        x_label: "commanded path length (mm)".into(),
        y_label: "error (µm)".into(),
        series: vec![
            Series::markers("point error", points.collect()),
            Series::line(
                "largest contour error per segment",
                along.iter().map(|(s, _, c)| (*s, *c)).collect(),
            ),
        ],
        ..Chart::default()
    }
}

/// A map's component charts as line charts.
pub fn component_line_charts(charts: &[ComponentChart]) -> Vec<Chart> {
    charts
        .iter()
        .map(|c| Chart {
            title: c.title.clone(),
            x_label: c.x_label.clone(),
            y_label: c.y_label.clone(),
            series: c
                .series
                .iter()
                .map(|s| Series::line(s.name.clone(), s.points.clone()))
                .collect(),
            ..Chart::default()
        })
        .collect()
}
