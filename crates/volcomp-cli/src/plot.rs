//! Line charts as SVG or PNG, for every command that draws.
//!
//! Built on `plotters` without its native font stack: the DejaVu Sans font is
//! bundled (`assets/fonts`) and registered through `ab_glyph`, so plots look
//! the same on every machine and need no system library.

use crate::output::{write_atomically, CliError};
use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};
use std::path::Path;
use std::sync::Once;

static FONT: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

fn register() {
    REGISTER.call_once(|| {
        // The bundled font is valid; failing to parse it would be a build error
        // caught by the plot tests.
        let _ = register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// One line (or point set) of a chart.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// Points `(x, y)`.
    pub points: Vec<(f64, f64)>,
    /// Draw markers instead of a line.
    pub markers: bool,
}

impl Series {
    /// A line series.
    pub fn line(label: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self {
            label: label.into(),
            points,
            markers: false,
        }
    }

    /// A marker series.
    pub fn markers(label: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self {
            label: label.into(),
            points,
            markers: true,
        }
    }
}

/// A chart: title, axis labels, series and optional vertical marker lines.
#[derive(Debug, Clone, Default)]
pub struct Chart {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    /// Vertical lines `(x, label)`, e.g. a chosen cut-off.
    pub vlines: Vec<(f64, String)>,
    /// Logarithmic y axis (values must be positive).
    pub log_y: bool,
}

const PALETTE: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
];

fn bounds(chart: &Chart) -> ((f64, f64), (f64, f64)) {
    let pts = chart
        .series
        .iter()
        .flat_map(|s| s.points.iter())
        .filter(|(x, y)| x.is_finite() && y.is_finite() && (!chart.log_y || *y > 0.0));
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for &(x, y) in pts {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    for (x, _) in &chart.vlines {
        x0 = x0.min(*x);
        x1 = x1.max(*x);
    }
    if !x0.is_finite() {
        return ((0.0, 1.0), (0.0, 1.0));
    }
    let pad = |a: f64, b: f64| {
        if b - a < 1e-12 {
            (a - 0.5, b + 0.5)
        } else {
            (a, b)
        }
    };
    let (x0, x1) = pad(x0, x1);
    let (y0, y1) = if chart.log_y {
        (y0 * 0.8, y1 * 1.25)
    } else {
        let m = 0.05 * (y1 - y0);
        pad(y0 - m, y1 + m)
    };
    ((x0, x1), (y0, y1))
}

fn draw<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    chart: &Chart,
) -> Result<(), String> {
    let ((x0, x1), (y0, y1)) = bounds(chart);
    let mut builder = ChartBuilder::on(area);
    builder
        .caption(&chart.title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60);
    macro_rules! body {
        ($ctx:expr) => {{
            let mut ctx = $ctx;
            ctx.configure_mesh()
                .x_label_formatter(&|v| tick(*v))
                .y_label_formatter(&|v| tick(*v))
                .x_desc(chart.x_label.as_str())
                .y_desc(chart.y_label.as_str())
                .label_style(("sans-serif", 12))
                .draw()
                .map_err(|e| e.to_string())?;
            for (i, s) in chart.series.iter().enumerate() {
                let color = PALETTE[i % PALETTE.len()];
                let pts: Vec<(f64, f64)> = s
                    .points
                    .iter()
                    .copied()
                    .filter(|(x, y)| x.is_finite() && y.is_finite() && (!chart.log_y || *y > 0.0))
                    .collect();
                let anno = if s.markers {
                    ctx.draw_series(pts.iter().map(|p| Circle::new(*p, 2, color.filled())))
                        .map_err(|e| e.to_string())?
                } else {
                    ctx.draw_series(LineSeries::new(pts, color.stroke_width(1)))
                        .map_err(|e| e.to_string())?
                };
                anno.label(s.label.as_str()).legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 16, y)], color.stroke_width(2))
                });
            }
            for (x, label) in &chart.vlines {
                ctx.draw_series(LineSeries::new(
                    vec![(*x, y0), (*x, y1)],
                    BLACK.stroke_width(1),
                ))
                .map_err(|e| e.to_string())?
                .label(label.as_str())
                .legend(|(x, y)| {
                    PathElement::new(vec![(x, y), (x + 16, y)], BLACK.stroke_width(1))
                });
            }
            if !chart.series.is_empty() {
                ctx.configure_series_labels()
                    .background_style(WHITE.mix(0.85))
                    .border_style(BLACK)
                    .label_font(("sans-serif", 12))
                    .draw()
                    .map_err(|e| e.to_string())?;
            }
        }};
    }
    if chart.log_y {
        body!(builder
            .build_cartesian_2d(x0..x1, (y0..y1).log_scale())
            .map_err(|e| e.to_string())?);
    } else {
        body!(builder
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|e| e.to_string())?);
    }
    Ok(())
}

/// A tick label: short, no float noise (`0.5`, `1200`, `1e-6`).
fn tick(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 {
        "0".into()
    } else if !(1e-3..1e5).contains(&a) {
        let s = format!("{v:.0e}");
        s.replace("e0", "")
    } else {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

/// Fills the background and draws the charts stacked vertically.
fn render<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    charts: &[Chart],
) -> Result<(), String> {
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    for (area, chart) in root
        .split_evenly((charts.len().max(1), 1))
        .iter()
        .zip(charts)
    {
        draw(area, chart)?;
    }
    root.present().map_err(|e| e.to_string())
}

/// Draws `charts` stacked vertically into `path` (`.svg` or `.png`), atomically.
pub fn write_charts(charts: &[Chart], path: &Path) -> Result<(), CliError> {
    let bytes = chart_bytes(charts, path)?;
    write_atomically(path, &[], |out| {
        out.write_all(&bytes)
            .map_err(|e| CliError::Io(path.to_path_buf(), e))
    })
}

/// The bytes of `charts` drawn as the file `path` names (`.svg` or `.png`).
pub fn chart_bytes(charts: &[Chart], path: &Path) -> Result<Vec<u8>, CliError> {
    register();
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let (w, h) = (900u32, 360u32 * charts.len().max(1) as u32);
    let fail =
        |e: String| CliError::Message(format!("{}: cannot draw the plot: {e}", path.display()));
    match ext.as_deref() {
        Some("svg") => {
            let mut text = String::new();
            {
                render(
                    SVGBackend::with_string(&mut text, (w, h)).into_drawing_area(),
                    charts,
                )
                .map_err(fail)?;
            }
            Ok(text.into_bytes())
        }
        Some("png") => {
            // Drawn in memory and encoded here, so the file goes through
            // the same atomic output as every other.
            let mut rgb = vec![0u8; w as usize * h as usize * 3];
            {
                render(
                    BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area(),
                    charts,
                )
                .map_err(fail)?;
            }
            let mut png = Vec::new();
            use image::ImageEncoder as _;
            image::codecs::png::PngEncoder::new(&mut png)
                .write_image(&rgb, w, h, image::ColorType::Rgb8)
                .map_err(|e| fail(e.to_string()))?;
            Ok(png)
        }
        _ => Err(CliError::Message(format!(
            "{}: plots are written as .svg or .png; choose one of those extensions",
            path.display()
        ))),
    }
}
