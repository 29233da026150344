//! Charts as inline SVG strings: pure functions from numbers to markup,
//! drawn for a report read on paper (A4) and on screens of any width (the
//! drawings scale to their container; text is the reader's sans-serif font).
//!
//! Every axis carries its quantity and unit; legends sit below the plot area,
//! never over the data; a series' legend swatch is drawn with the series' own
//! colour and mark. Colours: the Okabe–Ito palette for series and the viridis
//! map for values ([Okabe & Ito 2008], [viridis] in docs/references.md), both
//! readable with the common colour-vision deficiencies and in grey print.

use std::fmt::Write as _;

/// Width of every chart's coordinate system (CSS pixels at 100 %).
pub const WIDTH: f64 = 720.0;
const LEFT: f64 = 78.0;
const RIGHT: f64 = 24.0;
const TOP: f64 = 14.0;
const AXIS_BELOW: f64 = 52.0;
const LEGEND_ROW: f64 = 22.0;
const FONT: f64 = 14.0;

/// The Okabe–Ito colours, in the order series take them: blue,
/// vermillion, bluish green, reddish purple, orange, sky blue, black.
pub const PALETTE: [&str; 7] = [
    "#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000",
];

/// Escapes text for XML and HTML content and attribute values.
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// Tick positions at 1, 2 or 5 × 10ⁿ covering `[lo, hi]` with about
/// `target` intervals, and the step. A degenerate range is widened by one
/// unit of its magnitude so that an axis always has extent.
pub fn nice_ticks(lo: f64, hi: f64, target: usize) -> (Vec<f64>, f64) {
    let (mut lo, mut hi) = if lo <= hi { (lo, hi) } else { (hi, lo) };
    if !(lo.is_finite() && hi.is_finite()) {
        return (vec![0.0, 1.0], 1.0);
    }
    if hi - lo <= f64::EPSILON * hi.abs().max(lo.abs()).max(1e-300) {
        let pad = if hi == 0.0 { 1.0 } else { hi.abs() * 0.1 };
        lo -= pad;
        hi += pad;
    }
    let raw = (hi - lo) / target.max(1) as f64;
    let magnitude = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * magnitude)
        .find(|s| *s >= raw * (1.0 - 1e-12))
        .unwrap_or(10.0 * magnitude);
    let first = (lo / step).floor() as i64;
    let last = (hi / step).ceil() as i64;
    let ticks = (first..=last).map(|k| k as f64 * step).collect();
    (ticks, step)
}

/// Ticks at 1, 2 or 5 × 10ⁿ that lie within `[lo, hi]`, at least three of
/// them (a plan view's axis is the drawing's extent, not widened to the
/// ticks, so [`nice_ticks`] alone can leave a single tick inside it): the
/// step is made finer until three fit.
pub fn ticks_within(lo: f64, hi: f64, target: usize) -> (Vec<f64>, f64) {
    let (lo, hi) = if lo <= hi { (lo, hi) } else { (hi, lo) };
    let slack = (hi - lo).abs() * 1e-9;
    let mut last = (vec![], 1.0);
    for t in target.max(2)..target.max(2) + 12 {
        let (ticks, step) = nice_ticks(lo, hi, t);
        let inside: Vec<f64> = ticks
            .into_iter()
            .filter(|v| *v >= lo - slack && *v <= hi + slack)
            .collect();
        if inside.len() >= 3 {
            return (inside, step);
        }
        last = (inside, step);
    }
    last
}

/// A tick label with as many decimals as the step needs and a true minus.
pub fn tick_label(value: f64, step: f64) -> String {
    let decimals = (-step.log10().floor()).max(0.0) as usize;
    let v = if value.abs() < step * 1e-9 {
        0.0
    } else {
        value
    };
    format!("{v:.decimals$}").replace('-', "−")
}

/// The viridis colour map at `t` ∈ [0, 1] (clamped: the colour bar shows
/// the range), linear between nine of its published stops.
pub fn viridis(t: f64) -> (u8, u8, u8) {
    const STOPS: [(u8, u8, u8); 9] = [
        (68, 1, 84),
        (71, 44, 122),
        (59, 81, 139),
        (44, 113, 142),
        (33, 144, 141),
        (39, 173, 129),
        (92, 200, 99),
        (170, 220, 50),
        (253, 231, 37),
    ];
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let x = t * (STOPS.len() - 1) as f64;
    let i = (x.floor() as usize).min(STOPS.len() - 2);
    let f = x - i as f64;
    let mix = |a: u8, b: u8| (a as f64 + (b as f64 - a as f64) * f).round() as u8;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    (mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

fn hex((r, g, b): (u8, u8, u8)) -> String {
    format!("#{r:02x}{g:02x}{b:02x}")
}

/// How a series is drawn.
#[derive(Debug, Clone, PartialEq)]
pub enum Mark {
    /// A polyline through the points; a NaN point lifts the pen.
    Line,
    /// A dashed polyline.
    Dashed,
    /// A circle at every point.
    Markers,
    /// For each `(x, lo, hi)` a vertical stroke from `lo` to `hi`, joined
    /// in order: the envelope of a long signal decimated to its minimum and
    /// maximum per bin, so that no peak is lost.
    Envelope,
    /// For each `(x, centre, half)` a marker at `centre` and a bar
    /// `centre ± half`.
    ErrorBars,
}

/// One data series. For [`Mark::Envelope`] and [`Mark::ErrorBars`] each
/// point is `(x, a, b)`; otherwise `(x, y, _)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// CSS colour.
    pub colour: String,
    /// How it is drawn.
    pub mark: Mark,
    /// The points.
    pub points: Vec<(f64, f64, f64)>,
}

impl Series {
    /// A series of `(x, y)` points.
    pub fn xy(name: impl Into<String>, colour: &str, mark: Mark, xy: &[(f64, f64)]) -> Self {
        Self {
            name: name.into(),
            colour: colour.into(),
            mark,
            points: xy.iter().map(|&(x, y)| (x, y, 0.0)).collect(),
        }
    }
}

/// An x–y chart.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Chart {
    /// The x axis' quantity and unit, e.g. `commanded path length (mm)`.
    pub x_label: String,
    /// The y axis' quantity and unit.
    pub y_label: String,
    /// Height of the plot area.
    pub plot_height: f64,
    /// The series, drawn in order.
    pub series: Vec<Series>,
    /// Horizontal reference lines `(y, label)`.
    pub rules: Vec<(f64, String)>,
    /// Force y = 0 into the range.
    pub y_from_zero: bool,
    /// Vertical reference lines `(x, label)` (e.g. a cut-off), in the legend.
    pub vrules: Vec<(f64, String)>,
    /// Logarithmic x axis, ticks at the decades (non-positive x not drawn).
    pub log_x: bool,
    /// Logarithmic y axis, ticks at the decades (non-positive y not drawn).
    pub log_y: bool,
}

/// A decade's label: `0.01`, `1`, `1000`, or `1e-5`, `1e6` beyond.
pub fn decade_label(exponent: f64) -> String {
    let k = exponent.round() as i32;
    if (-3..=4).contains(&k) {
        let v = 10f64.powi(k);
        tick_label(v, v)
    } else {
        format!("1e{k}").replace('-', "−")
    }
}

/// Decade ticks covering `[lo, hi]` (exponents), every `n`-th decade so
/// that there are at most about eight.
fn decade_ticks(lo: f64, hi: f64) -> (Vec<f64>, f64) {
    let (a, b) = (lo.floor(), hi.ceil().max(lo.floor() + 1.0));
    let step = ((b - a) / 8.0).ceil().max(1.0);
    let mut t = Vec::new();
    let mut k = a;
    while k <= b + 1e-9 {
        t.push(k);
        k += step;
    }
    if *t.last().unwrap_or(&a) < b {
        t.push(k);
    }
    (t, step)
}

fn series_range(series: &[Series]) -> ((f64, f64), (f64, f64)) {
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for s in series {
        for &(x, a, b) in &s.points {
            if !(x.is_finite() && a.is_finite()) {
                continue;
            }
            let (lo, hi) = match s.mark {
                Mark::Envelope => (a.min(b), a.max(b)),
                Mark::ErrorBars => (a - b.abs(), a + b.abs()),
                _ => (a, a),
            };
            x0 = x0.min(x);
            x1 = x1.max(x);
            y0 = y0.min(lo);
            y1 = y1.max(hi);
        }
    }
    if x0 > x1 {
        return ((0.0, 1.0), (0.0, 1.0));
    }
    ((x0, x1), (y0, y1))
}

/// A linear map from data to drawing coordinates.
#[derive(Debug, Clone, Copy)]
struct Scale {
    d0: f64,
    d1: f64,
    p0: f64,
    p1: f64,
}

impl Scale {
    fn at(&self, v: f64) -> f64 {
        self.p0 + (v - self.d0) / (self.d1 - self.d0) * (self.p1 - self.p0)
    }
}

fn f(v: f64) -> String {
    format!("{v:.1}")
}

/// The frame, grid, ticks and labels of a plot area (no y tick labels
/// when `y_label` is empty: a panel sharing its neighbour's y scale).
#[allow(clippy::too_many_arguments)]
fn axes(
    svg: &mut String,
    xs: Scale,
    ys: Scale,
    xt: &(Vec<f64>, f64),
    yt: &(Vec<f64>, f64),
    x_label: &str,
    y_label: &str,
    log: (bool, bool),
) {
    let label = |t: f64, step: f64, log: bool| {
        if log {
            decade_label(t)
        } else {
            tick_label(t, step)
        }
    };
    let (left, right, top, bottom) = (xs.p0, xs.p1, ys.p1, ys.p0);
    for &t in &xt.0 {
        let x = xs.at(t);
        let _ = write!(
            svg,
            r##"<line x1="{x}" y1="{top}" x2="{x}" y2="{bottom}" stroke="#ddd"/><text x="{x}" y="{}" text-anchor="middle">{}</text>"##,
            f(bottom + 18.0),
            label(t, xt.1, log.0),
            x = f(x),
            top = f(top),
            bottom = f(bottom)
        );
    }
    for &t in &yt.0 {
        let y = ys.at(t);
        let _ = write!(
            svg,
            r##"<line x1="{left}" y1="{y}" x2="{right}" y2="{y}" stroke="#ddd"/>"##,
            y = f(y),
            left = f(left),
            right = f(right)
        );
        // A panel beside another on the same y scale repeats no labels.
        if !y_label.is_empty() {
            let _ = write!(
                svg,
                r##"<text x="{}" y="{}" text-anchor="end">{}</text>"##,
                f(left - 6.0),
                f(y + 5.0),
                label(t, yt.1, log.1)
            );
        }
    }
    let _ = write!(
        svg,
        r##"<rect x="{}" y="{}" width="{}" height="{}" fill="none" stroke="#444"/>"##,
        f(left),
        f(top),
        f(right - left),
        f(bottom - top)
    );
    let _ = write!(
        svg,
        r##"<text x="{}" y="{}" text-anchor="middle">{}</text>"##,
        f((left + right) / 2.0),
        f(bottom + 40.0),
        escape(x_label)
    );
    let cy = (top + bottom) / 2.0;
    let _ = write!(
        svg,
        r##"<text x="18" y="{cy}" text-anchor="middle" transform="rotate(-90 18 {cy})">{}</text>"##,
        escape(y_label),
        cy = f(cy)
    );
}

fn open_svg(height: f64, label: &str) -> String {
    format!(
        r##"<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {WIDTH} {h}" width="100%" role="img" aria-label="{}" font-family="DejaVu Sans, Helvetica, Arial, sans-serif" font-size="{FONT}">"##,
        escape(label),
        h = f(height)
    )
}

/// The swatch of a series in a legend: its own colour and mark.
fn swatch(svg: &mut String, x: f64, y: f64, s: &Series) {
    match s.mark {
        Mark::Markers => {
            let _ = write!(
                svg,
                r##"<circle cx="{}" cy="{}" r="3.5" fill="{c}" stroke="{c}"/>"##,
                f(x + 12.0),
                f(y),
                c = escape(&s.colour)
            );
        }
        Mark::ErrorBars => {
            let _ = write!(
                svg,
                r##"<line x1="{x}" y1="{}" x2="{x}" y2="{}" stroke="{c}" stroke-width="1.5"/><circle cx="{x}" cy="{}" r="3.5" fill="{c}"/>"##,
                f(y - 7.0),
                f(y + 7.0),
                f(y),
                x = f(x + 12.0),
                c = escape(&s.colour)
            );
        }
        _ => {
            let dash = if s.mark == Mark::Dashed {
                r#" stroke-dasharray="6 4""#
            } else {
                ""
            };
            let _ = write!(
                svg,
                r##"<line x1="{}" y1="{y}" x2="{}" y2="{y}" stroke="{}" stroke-width="2.5"{dash}/>"##,
                f(x),
                f(x + 24.0),
                escape(&s.colour),
                y = f(y)
            );
        }
    }
}

/// A legend below the plot, wrapping into rows; returns the rows' height.
fn legend(svg: &mut String, top: f64, names: &[&Series]) -> f64 {
    let mut x = LEFT;
    let mut y = top + LEGEND_ROW / 2.0;
    let mut rows = if names.is_empty() { 0 } else { 1 };
    for s in names {
        // Glyph width is about 0.6 em in a sans-serif font.
        let w = 34.0 + s.name.chars().count() as f64 * FONT * 0.6 + 18.0;
        if x + w > WIDTH - RIGHT && x > LEFT {
            x = LEFT;
            y += LEGEND_ROW;
            rows += 1;
        }
        swatch(svg, x, y, s);
        let _ = write!(
            svg,
            r##"<text x="{}" y="{}">{}</text>"##,
            f(x + 32.0),
            f(y + 5.0),
            escape(&s.name)
        );
        x += w;
    }
    rows as f64 * LEGEND_ROW
}

fn legend_height(names: &[&Series]) -> f64 {
    let mut scratch = String::new();
    legend(&mut scratch, 0.0, names)
}

/// An x–y chart as an SVG element.
pub fn chart(c: &Chart) -> String {
    // On a logarithmic axis everything is drawn in decades (log10).
    let decades = |log: bool, v: f64| match (log, v > 0.0) {
        (false, _) => v,
        (true, true) => v.log10(),
        (true, false) => f64::NAN,
    };
    let tx = |v: f64| decades(c.log_x, v);
    let ty = |v: f64| decades(c.log_y, v);
    let series: Vec<Series> = c
        .series
        .iter()
        .map(|s| Series {
            points: s
                .points
                .iter()
                .map(|&(x, a, b)| match s.mark {
                    Mark::ErrorBars => (tx(x), ty(a), b),
                    _ => (tx(x), ty(a), ty(b)),
                })
                .collect(),
            ..s.clone()
        })
        .collect();
    let rules: Vec<(f64, String)> = c.rules.iter().map(|(y, l)| (ty(*y), l.clone())).collect();
    let vrules: Vec<(f64, String)> = c.vrules.iter().map(|(x, l)| (tx(*x), l.clone())).collect();
    let ((mut x0, mut x1), (mut y0, mut y1)) = series_range(&series);
    for (y, _) in rules.iter().filter(|r| r.0.is_finite()) {
        y0 = y0.min(*y);
        y1 = y1.max(*y);
    }
    for (x, _) in vrules.iter().filter(|r| r.0.is_finite()) {
        x0 = x0.min(*x);
        x1 = x1.max(*x);
    }
    if c.y_from_zero && !c.log_y {
        y0 = y0.min(0.0);
        y1 = y1.max(0.0);
    }
    let xt = if c.log_x {
        decade_ticks(x0, x1)
    } else {
        nice_ticks(x0, x1, 8)
    };
    let yt = if c.log_y {
        decade_ticks(y0, y1)
    } else {
        nice_ticks(y0, y1, 6)
    };
    let plot_h = if c.plot_height > 0.0 {
        c.plot_height
    } else {
        260.0
    };
    // Vertical rules are listed in the legend as black dotted lines.
    let rule_series: Vec<Series> = vrules
        .iter()
        .map(|(_, l)| Series {
            name: l.clone(),
            colour: "#000000".into(),
            mark: Mark::Dashed,
            points: vec![],
        })
        .collect();
    let shown: Vec<&Series> = series
        .iter()
        .chain(&rule_series)
        .filter(|s| !s.name.is_empty())
        .collect();
    let height = TOP + plot_h + AXIS_BELOW + legend_height(&shown) + 6.0;
    let xs = Scale {
        d0: xt.0[0],
        d1: *xt.0.last().unwrap_or(&1.0),
        p0: LEFT,
        p1: WIDTH - RIGHT,
    };
    let ys = Scale {
        d0: yt.0[0],
        d1: *yt.0.last().unwrap_or(&1.0),
        p0: TOP + plot_h,
        p1: TOP,
    };
    let mut svg = open_svg(height, &format!("{} over {}", c.y_label, c.x_label));
    axes(
        &mut svg,
        xs,
        ys,
        &xt,
        &yt,
        &c.x_label,
        &c.y_label,
        (c.log_x, c.log_y),
    );
    for (x, _) in vrules.iter().filter(|r| r.0.is_finite()) {
        let px = f(xs.at(*x));
        let _ = write!(
            svg,
            r##"<line x1="{px}" y1="{}" x2="{px}" y2="{}" stroke="#000" stroke-dasharray="6 4"/>"##,
            f(ys.p1),
            f(ys.p0)
        );
    }
    for (y, label) in rules.iter().filter(|r| r.0.is_finite()) {
        let py = f(ys.at(*y));
        let _ = write!(
            svg,
            r##"<line x1="{}" y1="{py}" x2="{}" y2="{py}" stroke="#666" stroke-dasharray="2 3"/><text x="{}" y="{}" text-anchor="end" fill="#444">{}</text>"##,
            f(xs.p0),
            f(xs.p1),
            f(xs.p1 - 4.0),
            f(ys.at(*y) - 4.0),
            escape(label)
        );
    }
    for s in &series {
        draw_series(&mut svg, s, xs, ys);
    }
    legend(&mut svg, TOP + plot_h + AXIS_BELOW, &shown);
    svg.push_str("</svg>");
    svg
}

fn draw_series(svg: &mut String, s: &Series, xs: Scale, ys: Scale) {
    let colour = escape(&s.colour);
    match s.mark {
        Mark::Line | Mark::Dashed | Mark::Envelope => {
            let mut d = String::new();
            let mut pen_up = true;
            let put = |d: &mut String, x: f64, y: f64, pen_up: &mut bool| {
                let _ = write!(
                    d,
                    "{}{} {} ",
                    if *pen_up { "M" } else { "L" },
                    f(xs.at(x)),
                    f(ys.at(y))
                );
                *pen_up = false;
            };
            for &(x, a, b) in &s.points {
                if !(x.is_finite() && a.is_finite()) {
                    pen_up = true;
                    continue;
                }
                if s.mark == Mark::Envelope {
                    put(&mut d, x, a, &mut pen_up);
                    put(&mut d, x, b, &mut pen_up);
                } else {
                    put(&mut d, x, a, &mut pen_up);
                }
            }
            let dash = if s.mark == Mark::Dashed {
                r#" stroke-dasharray="6 4""#
            } else {
                ""
            };
            let _ = write!(
                svg,
                r##"<path d="{}" fill="none" stroke="{colour}" stroke-width="1.5" stroke-linejoin="round"{dash}/>"##,
                d.trim_end()
            );
        }
        Mark::Markers => {
            for &(x, y, _) in s
                .points
                .iter()
                .filter(|p| p.0.is_finite() && p.1.is_finite())
            {
                let _ = write!(
                    svg,
                    r##"<circle cx="{}" cy="{}" r="3" fill="{colour}"/>"##,
                    f(xs.at(x)),
                    f(ys.at(y))
                );
            }
        }
        Mark::ErrorBars => {
            for &(x, c, h) in s
                .points
                .iter()
                .filter(|p| p.0.is_finite() && p.1.is_finite())
            {
                let px = f(xs.at(x));
                let _ = write!(
                    svg,
                    r##"<line x1="{px}" y1="{}" x2="{px}" y2="{}" stroke="{colour}" stroke-width="1.5"/><circle cx="{px}" cy="{}" r="3" fill="{colour}"/>"##,
                    f(ys.at(c - h.abs())),
                    f(ys.at(c + h.abs())),
                    f(ys.at(c))
                );
            }
        }
    }
}

/// One piece of a path in plan view: a polyline (a NaN point lifts the
/// pen) and the value its colour shows.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanPiece {
    /// The points (mm).
    pub points: Vec<[f64; 2]>,
    /// The value (the colour bar's unit).
    pub value: f64,
}

/// One panel of a plan view.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanPanel {
    /// The panel's title, above it.
    pub title: String,
    /// Its pieces.
    pub pieces: Vec<PlanPiece>,
}

/// Colour levels of a plan view (pieces are grouped into one SVG path
/// per level, drawn from the lowest to the highest so peaks stay on top).
const LEVELS: usize = 32;

/// Plan views side by side on one colour scale `value_range` (low, high)
/// with its colour bar on the right, labelled `value_label`; axes labelled
/// `x_label`, `y_label`, equal scale in x and y. A piece of one point is
/// drawn as a dot; lines and dots are `stroke_px` wide.
pub fn plan_view(
    panels: &[PlanPanel],
    value_range: (f64, f64),
    stroke_px: f64,
    value_label: &str,
    x_label: &str,
    y_label: &str,
) -> String {
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for p in panels.iter().flat_map(|p| &p.pieces) {
        for q in p
            .points
            .iter()
            .filter(|q| q[0].is_finite() && q[1].is_finite())
        {
            x0 = x0.min(q[0]);
            x1 = x1.max(q[0]);
            y0 = y0.min(q[1]);
            y1 = y1.max(q[1]);
        }
    }
    if x0 > x1 {
        (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
    }
    // Equal scale: widen the shorter extent around its centre.
    let n = panels.len().max(1) as f64;
    let bar_w = 110.0;
    let gap = 30.0;
    let panel_w = (WIDTH - LEFT - bar_w - gap * (n - 1.0)) / n;
    let panel_h = (panel_w * (y1 - y0).max(1e-9) / (x1 - x0).max(1e-9)).clamp(160.0, 420.0);
    let per_px = ((x1 - x0) / panel_w).max((y1 - y0) / panel_h).max(1e-9) * 1.04;
    let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    let (dx, dy) = (per_px * panel_w / 2.0, per_px * panel_h / 2.0);
    let xt = ticks_within(cx - dx, cx + dx, (panel_w / 70.0).max(2.0) as usize);
    let yt = ticks_within(cy - dy, cy + dy, (panel_h / 50.0).max(2.0) as usize);
    let top = TOP + 22.0;
    let height = top + panel_h + AXIS_BELOW + 4.0;
    let mut svg = open_svg(
        height,
        &format!(
            "plan view coloured by {value_label}, {} panels",
            panels.len()
        ),
    );
    let vmin = if value_range.0.is_finite() {
        value_range.0
    } else {
        0.0
    };
    let vmax = if value_range.1 > vmin && value_range.1.is_finite() {
        value_range.1
    } else {
        vmin + 1.0
    };
    let span = vmax - vmin;
    for (k, panel) in panels.iter().enumerate() {
        let left = LEFT + k as f64 * (panel_w + gap);
        let xs = Scale {
            d0: cx - dx,
            d1: cx + dx,
            p0: left,
            p1: left + panel_w,
        };
        let ys = Scale {
            d0: cy - dy,
            d1: cy + dy,
            p0: top + panel_h,
            p1: top,
        };
        let inside = |t: &f64, s: &Scale| *t >= s.d0.min(s.d1) && *t <= s.d0.max(s.d1);
        let xt_in = (
            xt.0.iter().copied().filter(|t| inside(t, &xs)).collect(),
            xt.1,
        );
        let yt_in = (
            yt.0.iter().copied().filter(|t| inside(t, &ys)).collect(),
            yt.1,
        );
        axes(
            &mut svg,
            xs,
            ys,
            &xt_in,
            &yt_in,
            x_label,
            if k == 0 { y_label } else { "" },
            (false, false),
        );
        let _ = write!(
            svg,
            r##"<text x="{}" y="{}" text-anchor="middle" font-weight="bold">{}</text>"##,
            f(left + panel_w / 2.0),
            f(top - 8.0),
            escape(&panel.title)
        );
        let mut paths = vec![String::new(); LEVELS];
        for piece in &panel.pieces {
            let level = (((piece.value - vmin) / span) * LEVELS as f64).floor();
            let level = if level.is_nan() {
                0
            } else {
                (level as usize).min(LEVELS - 1)
            };
            let d = &mut paths[level];
            let mut pen_up = true;
            let dot;
            let points: &[[f64; 2]] = if piece.points.len() == 1 {
                dot = [piece.points[0], piece.points[0]];
                &dot
            } else {
                &piece.points
            };
            for q in points {
                if !(q[0].is_finite() && q[1].is_finite()) {
                    pen_up = true;
                    continue;
                }
                let _ = write!(
                    d,
                    "{}{} {} ",
                    if pen_up { "M" } else { "L" },
                    f(xs.at(q[0])),
                    f(ys.at(q[1]))
                );
                pen_up = false;
            }
        }
        for (level, d) in paths.iter().enumerate() {
            if d.is_empty() {
                continue;
            }
            let colour = hex(viridis((level as f64 + 0.5) / LEVELS as f64));
            let _ = write!(
                svg,
                r##"<path d="{}" fill="none" stroke="{colour}" stroke-width="{}" stroke-linecap="round" stroke-linejoin="round"/>"##,
                d.trim_end(),
                f(stroke_px)
            );
        }
    }
    // The colour bar.
    let bx = WIDTH - bar_w + 14.0;
    let bw = 16.0;
    for level in 0..LEVELS {
        let h = panel_h / LEVELS as f64;
        let y = top + panel_h - (level as f64 + 1.0) * h;
        let _ = write!(
            svg,
            r##"<rect x="{}" y="{}" width="{bw}" height="{}" fill="{}"/>"##,
            f(bx),
            f(y),
            f(h + 0.6),
            hex(viridis((level as f64 + 0.5) / LEVELS as f64))
        );
    }
    let _ = write!(
        svg,
        r##"<rect x="{}" y="{}" width="{bw}" height="{}" fill="none" stroke="#444"/>"##,
        f(bx),
        f(top),
        f(panel_h)
    );
    let bt = nice_ticks(vmin, vmax, 5);
    for &t in
        bt.0.iter()
            .filter(|t| **t <= vmax + span * 1e-9 && **t >= vmin - span * 1e-9)
    {
        let y = top + panel_h - (t - vmin) / span * panel_h;
        let _ = write!(
            svg,
            r##"<line x1="{}" y1="{y}" x2="{}" y2="{y}" stroke="#444"/><text x="{}" y="{}">{}</text>"##,
            f(bx + bw),
            f(bx + bw + 4.0),
            f(bx + bw + 6.0),
            f(y + 5.0),
            tick_label(t, bt.1),
            y = f(y)
        );
    }
    let lx = bx + bw + 62.0;
    let ly = top + panel_h / 2.0;
    let _ = write!(
        svg,
        r##"<text x="{lx}" y="{ly}" text-anchor="middle" transform="rotate(-90 {lx} {ly})">{}</text>"##,
        escape(value_label),
        lx = f(lx),
        ly = f(ly)
    );
    svg.push_str("</svg>");
    svg
}

/// Histograms on shared bins: `edges` (n + 1 increasing values) and, per
/// series, n heights; drawn as outlined steps with a light fill.
pub fn histogram(
    edges: &[f64],
    series: &[(String, String, Vec<f64>)],
    x_label: &str,
    y_label: &str,
) -> String {
    let mut chart_series = Vec::new();
    for (name, colour, heights) in series {
        let mut pts = Vec::new();
        for (i, h) in heights.iter().enumerate() {
            if i + 1 >= edges.len() {
                break;
            }
            pts.push((edges[i], *h, 0.0));
            pts.push((edges[i + 1], *h, 0.0));
        }
        if let (Some(first), Some(last)) = (pts.first().copied(), pts.last().copied()) {
            pts.insert(0, (first.0, 0.0, 0.0));
            pts.push((last.0, 0.0, 0.0));
        }
        chart_series.push(Series {
            name: name.clone(),
            colour: colour.clone(),
            mark: Mark::Line,
            points: pts,
        });
    }
    let c = Chart {
        x_label: x_label.into(),
        y_label: y_label.into(),
        plot_height: 220.0,
        series: chart_series,
        y_from_zero: true,
        ..Chart::default()
    };
    chart(&c)
}

/// The number in the last `name="…"` attribute before byte `at` of `svg`
/// (for tests that find where a text was drawn).
#[cfg(test)]
pub(crate) fn attribute_before(svg: &str, at: usize, name: &str) -> f64 {
    let after = svg[..at].rsplit(&format!("{name}=\"")).next().unwrap();
    after.split('"').next().unwrap().parse().unwrap()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_one_two_five_multiples_covering_the_range() {
        // 0…7.3 in about 6 steps: raw 1.2167 → 2; 0, 2, 4, 6, 8.
        let (t, step) = nice_ticks(0.0, 7.3, 6);
        assert_eq!(step, 2.0);
        assert_eq!(t, vec![0.0, 2.0, 4.0, 6.0, 8.0]);
        // −0.013…0.021 in 4: raw 0.0085 → 0.01; −0.02 … 0.03.
        let (t, step) = nice_ticks(-0.013, 0.021, 4);
        assert!((step - 0.01).abs() < 1e-15);
        assert_eq!(t.len(), 6);
        assert!((t[0] + 0.02).abs() < 1e-12 && (t[5] - 0.03).abs() < 1e-12);
        // A single value still has extent.
        let (t, _) = nice_ticks(5.0, 5.0, 4);
        assert!(t[0] < 5.0 && *t.last().unwrap() > 5.0);
    }

    #[test]
    fn an_axis_over_a_drawings_extent_gets_at_least_three_ticks_inside_it() {
        // 9.3 … 10.9 mm: 1-2-5 steps for two intervals give 1 mm, and a
        // single tick (10) inside; three need 0.5 mm steps.
        assert_eq!(nice_ticks(9.3, 10.9, 2).0, vec![9.0, 10.0, 11.0]);
        let (t, step) = ticks_within(9.3, 10.9, 2);
        assert_eq!(step, 0.5);
        assert_eq!(t, vec![9.5, 10.0, 10.5]);
        // Every tick is inside, and the ends count.
        let (t, _) = ticks_within(-40.0, 40.0, 3);
        assert!(
            t.len() >= 3 && t.iter().all(|v| (-40.0..=40.0).contains(v)),
            "{t:?}"
        );
        assert_eq!(t.first(), Some(&-40.0));
    }

    #[test]
    fn tick_labels_carry_the_steps_decimals_and_a_true_minus() {
        assert_eq!(tick_label(-0.02, 0.01), "−0.02");
        assert_eq!(tick_label(400.0, 100.0), "400");
        assert_eq!(tick_label(2.5, 0.5), "2.5");
        // Rounding noise around zero is not shown as −0.
        assert_eq!(tick_label(-1e-18, 0.01), "0.00");
    }

    #[test]
    fn viridis_ends_are_the_published_colours() {
        // matplotlib's viridis: #440154 at 0, #fde725 at 1, #21918c at 0.5.
        assert_eq!(hex(viridis(0.0)), "#440154");
        assert_eq!(hex(viridis(1.0)), "#fde725");
        assert_eq!(hex(viridis(0.5)), "#21908d");
    }

    #[test]
    fn text_is_escaped() {
        assert_eq!(escape("a<b & \"c\""), "a&lt;b &amp; &quot;c&quot;");
        let c = Chart {
            x_label: "x <mm>".into(),
            y_label: "y (µm)".into(),
            series: vec![Series::xy(
                "s&t",
                "#000",
                Mark::Line,
                &[(0.0, 0.0), (1.0, 1.0)],
            )],
            ..Chart::default()
        };
        let svg = chart(&c);
        assert!(svg.contains("x &lt;mm&gt;") && svg.contains("s&amp;t"));
        assert!(!svg.contains("x <mm>"));
    }

    #[test]
    fn the_legend_is_below_the_plot_area() {
        let c = Chart {
            x_label: "x (mm)".into(),
            y_label: "y (µm)".into(),
            plot_height: 200.0,
            series: vec![Series::xy(
                "before",
                PALETTE[1],
                Mark::Line,
                &[(0.0, 5.0), (10.0, 9.0)],
            )],
            ..Chart::default()
        };
        let svg = chart(&c);
        // The plot area ends at TOP + 200; the legend text sits below the
        // axis labels.
        let at = svg.find(">before</text>").unwrap();
        let y = attribute_before(&svg, at, "y");
        assert!(y > TOP + 200.0 + 40.0, "{y}");
    }
}

#[cfg(test)]
mod log_tests {
    use super::*;

    #[test]
    fn logarithmic_axes_are_labelled_at_the_decades_in_the_values() {
        assert_eq!(decade_label(-2.0), "0.01");
        assert_eq!(decade_label(3.0), "1000");
        assert_eq!(decade_label(-5.0), "1e−5");
        // 0.5 … 200 mm: decades −1 … 3.
        let (t, step) = decade_ticks(0.5f64.log10(), 200f64.log10());
        assert_eq!((t, step), (vec![-1.0, 0.0, 1.0, 2.0, 3.0], 1.0));
        let svg = chart(&Chart {
            x_label: "wavelength λ (mm)".into(),
            y_label: "power (1)".into(),
            series: vec![Series::xy(
                "P",
                PALETTE[0],
                Mark::Line,
                &[(0.5, 1e-6), (10.0, 0.1), (200.0, 0.01), (-1.0, 5.0)],
            )],
            vrules: vec![(4.0, "cut-off 4 mm".into())],
            log_x: true,
            log_y: true,
            ..Chart::default()
        });
        for label in [">0.1<", ">1<", ">10<", ">100<", ">1000<", ">1e−6<"] {
            assert!(svg.contains(label), "{label}");
        }
        // The non-positive point is not drawn (three points, one path).
        assert_eq!(svg.matches(" L").count(), 2);
        assert!(svg.contains(">cut-off 4 mm</text>"));
    }
}
