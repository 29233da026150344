//! Line charts as SVG or PNG, for every command that draws (the charts'
//! data: [`super::charts`]).
//!
//! Built on `plotters` without its native font stack: the DejaVu Sans font is
//! bundled (`assets/fonts`) and registered through `ab_glyph`, so plots look
//! the same on every machine and need no system library.

use super::charts::{self, Chart, Series};
use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};
use std::path::{Path, PathBuf};
use std::sync::Once;

/// A plot that cannot be drawn as asked.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The file name asks for a format other than SVG or PNG.
    #[error("{}: plots are written as .svg or .png; choose one of those extensions", path.display())]
    Format {
        /// The plot's file.
        path: PathBuf,
    },
    /// The drawing or the encoding failed.
    #[error("{}: cannot draw the plot: {reason}", path.display())]
    Draw {
        /// The plot's file.
        path: PathBuf,
        /// What failed.
        reason: String,
    },
}

static FONT: &[u8] = include_bytes!("../../../../assets/fonts/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

fn register() {
    REGISTER.call_once(|| {
        // The bundled font is valid; failing to parse it would be a build error
        // caught by the plot tests.
        let _ = register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

fn series_colour(i: usize, s: &Series) -> RGBColor {
    let (r, g, b) = charts::series_colour(i, s);
    RGBColor(r, g, b)
}

fn bounds(chart: &Chart) -> ((f64, f64), (f64, f64)) {
    let pts = chart
        .series
        .iter()
        .flat_map(|s| s.points.iter())
        .filter(|(x, y)| {
            x.is_finite()
                && y.is_finite()
                && (!chart.log_y || *y > 0.0)
                && (!chart.log_x || *x > 0.0)
        });
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
    let (x0, x1) = if chart.log_x {
        (x0 * 0.9, x1 * 1.1)
    } else {
        pad(x0, x1)
    };
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
    // The legend has its own column right of the plot: it never covers data.
    let (w, _) = area.dim_in_pixel();
    let (plot_area, legend_area) = area.split_horizontally(w * 70 / 100);
    let mut builder = ChartBuilder::on(&plot_area);
    builder
        .caption(&chart.title, ("sans-serif", 16))
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
                let color = series_colour(i, s);
                let pts: Vec<(f64, f64)> = s
                    .points
                    .iter()
                    .copied()
                    .filter(|(x, y)| {
                        x.is_finite()
                            && y.is_finite()
                            && (!chart.log_y || *y > 0.0)
                            && (!chart.log_x || *x > 0.0)
                    })
                    .collect();
                if s.markers {
                    ctx.draw_series(pts.iter().map(|p| Circle::new(*p, 3, color.filled())))
                        .map_err(|e| e.to_string())?;
                } else {
                    ctx.draw_series(LineSeries::new(pts, color.stroke_width(2)))
                        .map_err(|e| e.to_string())?;
                }
            }
            for (x, _) in &chart.vlines {
                ctx.draw_series(LineSeries::new(
                    vec![(*x, y0), (*x, y1)],
                    BLACK.stroke_width(1),
                ))
                .map_err(|e| e.to_string())?;
            }
        }};
    }
    match (chart.log_x, chart.log_y) {
        (false, false) => body!(builder
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|e| e.to_string())?),
        (false, true) => body!(builder
            .build_cartesian_2d(x0..x1, (y0..y1).log_scale())
            .map_err(|e| e.to_string())?),
        (true, false) => body!(builder
            .build_cartesian_2d((x0..x1).log_scale(), y0..y1)
            .map_err(|e| e.to_string())?),
        (true, true) => body!(builder
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(|e| e.to_string())?),
    }
    legend(&legend_area, chart)
}

/// The legend in its own area: each entry's swatch drawn as its series
/// (a filled circle for markers, a line for lines) in the series' colour.
fn legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    chart: &Chart,
) -> Result<(), String> {
    let (_, h) = area.dim_in_pixel();
    let row = 18i32;
    let mut y = 40i32;
    let font = ("sans-serif", 12).into_font().color(&BLACK);
    let entries: Vec<(RGBColor, bool, &str)> = chart
        .series
        .iter()
        .enumerate()
        .map(|(i, s)| (series_colour(i, s), s.markers, s.label.as_str()))
        .chain(chart.vlines.iter().map(|(_, l)| (BLACK, false, l.as_str())))
        .collect();
    for (k, (colour, markers, label)) in entries.iter().enumerate() {
        if y + row > h as i32 - 8 {
            let rest = format!("… {} more", entries.len() - k);
            area.draw(&Text::new(rest, (4, y), font.clone()))
                .map_err(|e| e.to_string())?;
            break;
        }
        if *markers {
            area.draw(&Circle::new((12, y), 3, colour.filled()))
                .map_err(|e| e.to_string())?;
        } else {
            area.draw(&PathElement::new(
                vec![(2, y), (22, y)],
                colour.stroke_width(2),
            ))
            .map_err(|e| e.to_string())?;
        }
        area.draw(&Text::new(label.to_string(), (28, y - 7), font.clone()))
            .map_err(|e| e.to_string())?;
        y += row;
    }
    Ok(())
}

/// A tick label: short, no float noise (`0.5`, `1200`, `1e-6`).
fn tick(v: f64) -> String {
    let a = v.abs();
    // A tick at zero computed as a sum of steps carries float noise (6e-17).
    if a < 1e-12 {
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

/// The bytes of `charts` drawn as the file `path` names (`.svg` or `.png`).
pub fn chart_bytes(charts: &[Chart], path: &Path) -> Result<Vec<u8>, PlotError> {
    register();
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let (w, h) = (900u32, 360u32 * charts.len().max(1) as u32);
    let fail = |reason: String| PlotError::Draw {
        path: path.to_path_buf(),
        reason,
    };
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
        _ => Err(PlotError::Format {
            path: path.to_path_buf(),
        }),
    }
}

#[cfg(test)]
mod legend_tests {
    use super::*;

    fn svg(chart: Chart) -> String {
        let bytes = chart_bytes(&[chart], Path::new("t.svg")).unwrap();
        String::from_utf8(bytes).unwrap()
    }

    #[test]
    fn markers_and_their_fit_share_a_colour_and_the_legend_is_beside_the_plot() {
        let s = svg(Chart {
            title: "t".into(),
            x_label: "time (h)".into(),
            y_label: "value (µm)".into(),
            series: vec![
                Series::markers("p identified", vec![(0.0, 1.0), (1.0, 2.0)]).colour(2),
                Series::line("p regression", vec![(0.0, 1.0), (1.0, 2.0)]).colour(2),
            ],
            ..Chart::default()
        });
        // Palette entry 2 (bluish green, 0 158 115) for both; no other
        // palette colour is used.
        assert!(s.contains("#009E73"), "{s}");
        for other in ["#0072B2", "#D55E00"] {
            assert!(!s.contains(other), "{other}");
        }
        // The legend's text starts right of the plot area (70 % of 900 px).
        let at = s.find(">\np regression\n<").unwrap();
        let x = crate::report::svg::attribute_before(&s, at, "x");
        assert!(x > 630.0, "{x}");
    }

    #[test]
    fn a_logarithmic_x_axis_is_labelled_in_the_values_themselves() {
        let s = svg(Chart {
            title: "spectrum".into(),
            x_label: "wavelength λ (mm, logarithmic)".into(),
            y_label: "power (1)".into(),
            series: vec![Series::line("P", vec![(0.5, 1.0), (5.0, 2.0), (50.0, 3.0)])],
            log_x: true,
            ..Chart::default()
        });
        // Ticks in mm (1, 10 …), not their logarithms (0, 1 …).
        assert!(s.contains(">\n10\n<") && s.contains(">\n1\n<"), "{s}");
    }
}
