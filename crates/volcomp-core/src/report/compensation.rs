//! The sections of a compensation or simulation report: the errors before
//! and after in a table, the path in plan view coloured by contour error
//! (before and after on one colour scale), the error along the path
//! overlaid, the distribution of the contour error by path length, the
//! largest corrections and every held axis and warning with its program
//! line. Point and contour error as defined in docs/design.md,
//! "Simulation and metrics" ([`crate::simulate::report`]).

use super::svg::{self, Chart, Mark, PlanPanel, PlanPiece, Series, PALETTE};
use super::text::count;
use super::trace::{LengthHistogram, PathBin, PathTrace};
use super::{Block, Section, Table};
use crate::compensate::{CompensateSummary, PointRecord};
use crate::io::provenance::ProgramHeader;
use crate::simulate::report::{CONTOUR_DEFINITION, POINT_DEFINITION};
use crate::simulate::SimReport;
use std::collections::{BTreeMap, BTreeSet};
use std::io::BufRead;

/// The colour of "before" (Okabe–Ito vermillion).
pub const BEFORE: &str = PALETTE[1];
/// The colour of "after" (Okabe–Ito blue).
pub const AFTER: &str = PALETTE[0];
/// Largest corrections listed.
pub const LARGEST: usize = 12;
/// Characters of a program line quoted (longer lines end in " …").
pub const QUOTE_CHARS: usize = 160;

/// One simulated program: its metrics and what a picture needs of it.
#[derive(Debug, Clone, Copy)]
pub struct Measured<'a> {
    /// Its name in the report (`before`, `after`, a file name).
    pub label: &'a str,
    /// Its metrics.
    pub report: &'a SimReport,
    /// Its trace.
    pub trace: &'a PathTrace,
}

/// One compensated point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Correction {
    /// Source line.
    pub line: u64,
    /// Nominal target (axis frame, mm).
    pub target_mm: volcomp_gcode::Vec3,
    /// `‖command − target‖` (µm).
    pub correction_um: f64,
    /// Model residual (µm).
    pub residual_um: f64,
    /// Axes held.
    pub held: [bool; 3],
}

/// The [`LARGEST`] largest corrections of a run, kept as points arrive.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LargestCorrections {
    /// Largest first.
    pub items: Vec<Correction>,
}

impl LargestCorrections {
    /// Considers one compensated point (rapid ends too: they are written).
    pub fn push(&mut self, p: &PointRecord) {
        let c = Correction {
            line: p.line,
            target_mm: p.target_mm,
            correction_um: (p.command_mm - p.target_mm).norm() * 1e3,
            residual_um: p.residual_um,
            held: p.held,
        };
        if !c.correction_um.is_finite() {
            return;
        }
        if self.items.len() == LARGEST
            && self
                .items
                .last()
                .is_some_and(|l| l.correction_um >= c.correction_um)
        {
            return;
        }
        let at = self
            .items
            .partition_point(|x| x.correction_um >= c.correction_um);
        self.items.insert(at, c);
        self.items.truncate(LARGEST);
    }
}

/// The text of `lines` (1-based) of a program, each cut at
/// [`QUOTE_CHARS`] characters with a visible " …".
pub fn quote_lines(
    program: impl BufRead,
    lines: &BTreeSet<u64>,
) -> std::io::Result<BTreeMap<u64, String>> {
    let mut out = BTreeMap::new();
    let Some(&last) = lines.iter().next_back() else {
        return Ok(out);
    };
    for (i, line) in program.split(b'\n').enumerate() {
        let n = i as u64 + 1;
        if n > last {
            break;
        }
        let line = line?;
        if lines.contains(&n) {
            let text = String::from_utf8_lossy(&line);
            let text = text.trim_end_matches('\r');
            let mut q: String = text.chars().take(QUOTE_CHARS).collect();
            if text.chars().count() > QUOTE_CHARS {
                q.push_str(" …");
            }
            out.insert(n, q);
        }
    }
    Ok(out)
}

/// The "what was done" rows of a compensation: the header written into
/// the compensated program, in words.
pub fn header_facts(header: &ProgramHeader) -> Vec<(String, String)> {
    let mut rows = vec![
        ("volcomp".to_string(), header.version.clone()),
        ("date (UTC)".to_string(), header.date_utc.clone()),
        ("method".to_string(), header.method.clone()),
        ("options".to_string(), header.options.clone()),
    ];
    rows.push((
        "set-up file".to_string(),
        header
            .setup_file
            .clone()
            .unwrap_or_else(|| "none given".into()),
    ));
    rows.extend(setup_facts(
        &header.setup,
        header.work_offset_note.as_deref(),
    ));
    rows
}

/// The set-up in words: work offsets that are set, tool lengths.
pub fn setup_facts(
    setup: &volcomp_gcode::Setup,
    work_offset_note: Option<&str>,
) -> Vec<(String, String)> {
    const NAMES: [&str; 9] = [
        "G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3",
    ];
    let mut rows = Vec::new();
    for (name, w) in NAMES.iter().zip(&setup.work_offsets_mm) {
        if w.x != 0.0 || w.y != 0.0 || w.z != 0.0 || *name == "G54" {
            let note = match (work_offset_note, *name == "G54") {
                (Some(n), true) => format!(" ({n})"),
                _ => String::new(),
            };
            rows.push((
                format!("work offset {name}"),
                format!("X {} Y {} Z {} mm{note}", w.x, w.y, w.z),
            ));
        }
    }
    let tools = if setup.tool_lengths_mm.is_empty() {
        "none".to_string()
    } else {
        setup
            .tool_lengths_mm
            .iter()
            .map(|(t, l)| format!("T{t} {l} mm"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    rows.push(("tool lengths".to_string(), tools));
    rows
}

fn pct(before: f64, after: f64) -> String {
    if before > 0.0 {
        format!("{:+.1}\u{a0}%", -100.0 * (1.0 - after / before))
    } else {
        "–".into()
    }
}

/// A figure read from a report.
type Metric<T> = fn(&SimReport) -> T;

/// The metrics of one or two runs in a table (µm), with the change of
/// `after` against `before` in percent.
pub fn results_table(before: Option<&Measured>, after: &Measured) -> Table {
    let mut headers = vec!["error (µm)".to_string()];
    if let Some(b) = before {
        headers.push(b.label.to_string());
    }
    headers.push(after.label.to_string());
    if before.is_some() {
        headers.push("change".into());
    }
    let rows: [(&str, Metric<f64>); 4] = [
        ("point error, RMS", |r| r.point_rms_um),
        ("point error, max", |r| r.point_max_um),
        ("contour error, RMS", |r| r.contour_rms_um),
        ("contour error, max", |r| r.contour_max_um),
    ];
    let mut table = Table {
        numeric: vec![false, true, true, true],
        headers,
        rows: Vec::new(),
    };
    for (name, get) in rows {
        let mut row = vec![name.to_string()];
        if let Some(b) = before {
            row.push(format!("{:.3}", get(b.report)));
        }
        row.push(format!("{:.3}", get(after.report)));
        if let Some(b) = before {
            row.push(pct(get(b.report), get(after.report)));
        }
        table.rows.push(row);
    }
    let count_rows: [(&str, Metric<String>); 4] = [
        ("points measured", |r| r.points.to_string()),
        ("contour samples", |r| r.samples.to_string()),
        ("feed path length (mm)", |r| {
            format!("{:.3}", r.feed_length_mm)
        }),
        ("nominal path", |r| r.nominal.to_string()),
    ];
    for (name, get) in count_rows {
        let mut row = vec![name.to_string()];
        if let Some(b) = before {
            row.push(get(b.report));
        }
        row.push(get(after.report));
        if before.is_some() {
            row.push(String::new());
        }
        table.rows.push(row);
    }
    table
}

fn plan_panel(m: &Measured) -> PlanPanel {
    PlanPanel {
        title: m.label.to_string(),
        pieces: m
            .trace
            .plan
            .iter()
            .map(|r| PlanPiece {
                points: r.points.clone(),
                value: r.max_um,
            })
            .collect(),
    }
}

/// Shares (%) of path length per bin on common bins for all `histograms`:
/// the bin edges (µm) and one height list per histogram. At most about 40
/// bins, covering the largest value.
pub fn common_bins(histograms: &[&LengthHistogram]) -> (Vec<f64>, Vec<Vec<f64>>) {
    let width = histograms
        .iter()
        .map(|h| h.width_um)
        .fold(super::trace::BASE_WIDTH_UM, f64::max);
    let mut hs: Vec<LengthHistogram> = histograms.iter().map(|h| h.at_width(width)).collect();
    let used = |hs: &[LengthHistogram]| {
        hs.iter()
            .filter_map(|h| h.length_mm.iter().rposition(|v| *v > 0.0))
            .max()
            .map_or(1, |i| i + 1)
    };
    while used(&hs) > 40 {
        hs.iter_mut().for_each(LengthHistogram::coarsen);
    }
    let n = used(&hs).max(4);
    let w = hs.first().map_or(width, |h| h.width_um);
    let edges = (0..=n).map(|k| k as f64 * w).collect();
    let heights = hs
        .iter()
        .map(|h| {
            let total = h.total_mm();
            h.length_mm[..n]
                .iter()
                .map(|v| if total > 0.0 { 100.0 * v / total } else { 0.0 })
                .collect()
        })
        .collect();
    (edges, heights)
}

/// The largest contour error of "after" when it gets a zoomed view of its
/// own: there is a "before" on the same scale and "after" stays below a
/// fifth of it (on the shared scale it would be drawn within the bottom
/// fifth, the colour bar's darkest colours).
fn zoomed(before: Option<&Measured>, after: &Measured, shared_max_um: f64) -> Option<f64> {
    let after_max = after.trace.max_um();
    (before.is_some() && after_max > 0.0 && after_max < 0.2 * shared_max_um).then_some(after_max)
}

/// A run's error along the path: `what` of each bin, drawn as `mark` at the
/// bin's middle.
fn along_series(
    m: &Measured,
    colour: &str,
    what: &str,
    mark: Mark,
    value: impl Fn(&PathBin) -> Option<(f64, f64)>,
) -> Series {
    Series {
        name: format!("{}: {what}", m.label),
        colour: colour.to_string(),
        mark,
        points: m
            .trace
            .bins
            .iter()
            .filter_map(|b| value(b).map(|(lo, hi)| (b.mid_mm(), lo, hi)))
            .collect(),
    }
}

fn contour_series(m: &Measured, colour: &str) -> Series {
    let what = "largest contour error per command";
    along_series(m, colour, what, Mark::Envelope, |b| {
        Some((b.contour_min_um, b.contour_max_um))
    })
}

fn point_series(m: &Measured, colour: &str) -> Series {
    along_series(m, colour, "point error", Mark::Markers, |b| {
        b.point_max_um.map(|p| (p, 0.0))
    })
}

fn along_chart(y_label: &str, plot_height: f64, series: Vec<Series>) -> String {
    svg::chart(&Chart {
        x_label: "commanded feed path length (mm)".into(),
        y_label: y_label.into(),
        plot_height,
        series,
        rules: vec![],
        y_from_zero: true,
        ..Chart::default()
    })
}

/// The picture sections: plan view, error along the path, histogram. With
/// `before`, "before" and "after" share every scale and axis.
/// When "after" stays within the bottom fifth of the shared scale, it gets
/// a view of its own too: a plan view on its own colour scale and its
/// errors along the path on their own axis.
pub fn picture_sections(before: Option<&Measured>, after: &Measured) -> Vec<Section> {
    let runs: Vec<(&Measured, &str)> = before
        .map(|b| (b, BEFORE))
        .into_iter()
        .chain(std::iter::once((after, AFTER)))
        .collect();
    let vmax = runs
        .iter()
        .map(|(m, _)| m.trace.max_um())
        .fold(0.0, f64::max);
    let panels: Vec<PlanPanel> = runs.iter().map(|(m, _)| plan_panel(m)).collect();
    let plan = svg::plan_view(
        &panels,
        (0.0, vmax),
        2.0,
        "contour error (µm)",
        "X (mm)",
        "Y (mm)",
    );
    let both = if before.is_some() {
        "; both on one colour scale"
    } else {
        ""
    };
    let mut plan_blocks = vec![Block::Figure {
        svg: plan,
        caption: format!("Feed moves in the machine's axis frame, seen from above (X, Y in mm), each coloured by the largest contour error along it (µm){both}. Rapids are not drawn. Long paths are merged in pairs of neighbouring moves, each coloured by the larger error, so no peak is lost."),
    }];
    let zoom = zoomed(before, after, vmax);
    if let Some(after_max) = zoom {
        plan_blocks.push(Block::Figure {
            svg: svg::plan_view(
                &[plan_panel(after)],
                (0.0, after_max),
                2.0,
                "contour error (µm)",
                "X (mm)",
                "Y (mm)",
            ),
            caption: format!("'{}' alone on its own colour scale (0 to {} µm), so that what is left after compensation can be seen: on the shared scale above it is near the bottom colour.", after.label, svg::tick_label(after_max, after_max / 1000.0)),
        });
    }
    let plan_section = Section {
        id: "plan".into(),
        title: "The path in plan view, coloured by contour error".into(),
        blocks: plan_blocks,
    };
    let contours: Vec<Series> = runs.iter().map(|(m, c)| contour_series(m, c)).collect();
    let points: Vec<Series> = runs.iter().map(|(m, c)| point_series(m, c)).collect();
    let mut along_blocks = vec![
        Block::Figure {
            svg: along_chart("contour error (µm)", 230.0, contours),
            caption: "The largest contour error of each feed command over the commanded feed path length. Long paths are decimated into bins drawn from their smallest to their largest value, so every peak stays visible.".into(),
        },
        Block::Figure {
            svg: along_chart("point error (µm)", 200.0, points),
            caption: "The point error at the end of every feed move of the program (the largest per bin on long paths).".into(),
        },
    ];
    if zoom.is_some() {
        along_blocks.push(Block::Figure {
            svg: along_chart(
                "error (µm)",
                200.0,
                vec![contour_series(after, AFTER), point_series(after, PALETTE[2])],
            ),
            caption: format!("'{}' alone on its own scale: the largest contour error per command and the point errors, which the shared scale above flattens towards zero.", after.label),
        });
    }
    let along = Section {
        id: "along".into(),
        title: "Error along the path".into(),
        blocks: along_blocks,
    };
    let hists: Vec<&LengthHistogram> = runs.iter().map(|(m, _)| &m.trace.histogram).collect();
    let (edges, heights) = common_bins(&hists);
    let hist_series: Vec<(String, String, Vec<f64>)> = runs
        .iter()
        .zip(heights)
        .map(|((m, colour), h)| (m.label.to_string(), colour.to_string(), h))
        .collect();
    let histogram = Section {
        id: "histogram".into(),
        title: "Distribution of the contour error".into(),
        blocks: vec![Block::Figure {
            svg: svg::histogram(
                &edges,
                &hist_series,
                "largest contour error per command (µm)",
                "share of feed path length (%)",
            ),
            caption: format!(
                "Share of the feed path length whose command has its largest contour error in each bin ({} µm wide).",
                svg::tick_label(edges.get(1).copied().unwrap_or(0.0), edges.get(1).copied().unwrap_or(1.0) / 100.0)
            ),
        }],
    };
    vec![plan_section, along, histogram]
}

/// Where the results sections send the reader for the metrics' meaning:
/// the definitions are given once per document, on its first page
/// ([`definitions`] in [`super::Document::front`]).
pub const DEFINED_ONCE: &str =
    "Point and contour error are defined on the first page (docs/design.md, \"Simulation and metrics\").";

/// The definitions of the metrics, as the tables use them: given once per
/// document, on its first page ([`super::Document::front`]).
pub fn definitions() -> Block {
    Block::Table(Table::new(
        &["metric", "definition (docs/design.md)"],
        &[],
        vec![
            vec!["point error".into(), POINT_DEFINITION.into()],
            vec!["contour error".into(), CONTOUR_DEFINITION.into()],
        ],
    ))
}

/// The compensation's own figures.
pub fn summary_table(s: &CompensateSummary) -> Table {
    let rows = [
        (
            "lines read / written",
            format!("{} / {}", s.lines_in, s.lines_out),
        ),
        ("target points compensated", s.points.to_string()),
        (
            "largest correction (µm)",
            format!("{:.3}", s.max_correction_um),
        ),
        (
            "largest model residual (µm)",
            format!("{:.4}", s.max_residual_um),
        ),
        (
            "take-up blocks written (a stop each)",
            s.take_ups.to_string(),
        ),
        (
            "take-ups folded into their moves",
            s.take_ups_folded.to_string(),
        ),
        (
            "take-ups ahead in an idle move",
            s.take_ups_idle.to_string(),
        ),
        (
            "largest excursion at a folded reversal (µm)",
            format!("{:.3}", s.max_fold_excursion_um),
        ),
        ("points with an axis held", s.held_count.to_string()),
        (
            "canned-cycle holes kept as cycles / written as moves",
            format!("{} / {}", s.cycle_holes_kept, s.cycle_holes_expanded),
        ),
        (
            "largest error a kept cycle leaves (µm)",
            format!("{:.3}", s.max_cycle_error_um),
        ),
        (
            "feed moves NOT compensated (an axis never set)",
            s.uncompensated_moves.to_string(),
        ),
    ];
    Table::new(
        &["compensation", ""],
        &[false, true],
        rows.into_iter().map(|(k, v)| vec![k.into(), v]).collect(),
    )
}

fn axes_text(f: [bool; 3]) -> String {
    ['X', 'Y', 'Z']
        .iter()
        .zip(f)
        .filter(|(_, b)| *b)
        .map(|(c, _)| *c)
        .collect()
}

/// The columns of the per-point report (CSV), one row a compensated point
/// ([`point_csv_row`]).
pub const POINT_CSV_HEADER: &str = "line,target_x_mm,target_y_mm,target_z_mm,command_x_mm,command_y_mm,command_z_mm,iterations,residual_um,reversed,held,take_up\n";

/// One compensated point as a row of the per-point report (mm and µm with
/// six decimals; the reversed and held axes as letters).
pub fn point_csv_row(p: &PointRecord, out: &mut String) {
    use std::fmt::Write as _;
    let _ = writeln!(
        out,
        "{},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{},{:.6},{},{},{}",
        p.line,
        p.target_mm.x,
        p.target_mm.y,
        p.target_mm.z,
        p.command_mm.x,
        p.command_mm.y,
        p.command_mm.z,
        p.iterations,
        p.residual_um,
        axes_text(p.reversed),
        axes_text(p.held),
        p.take_up
    );
}

/// The columns of the per-segment errors (CSV), one row a measured command
/// ([`segment_csv_row`]).
pub const SEGMENT_CSV_HEADER: &str =
    "line,nominal_line,x_mm,y_mm,z_mm,point_error_um,contour_max_um\n";

/// One measured command as a row of the per-segment errors (the point
/// error is empty where the command ends no nominal feed move).
pub fn segment_csv_row(s: &crate::simulate::SegmentError, out: &mut String) {
    use std::fmt::Write as _;
    let point = s.point_um.map(|p| format!("{p:.4}")).unwrap_or_default();
    let _ = writeln!(
        out,
        "{},{},{:.6},{:.6},{:.6},{},{:.4}",
        s.line,
        s.nominal_line,
        s.command_mm.x,
        s.command_mm.y,
        s.command_mm.z,
        point,
        s.contour_max_um
    );
}

/// A simulation's metrics as a table for a person; `with_reference`: the
/// nominal path is the reference program's.
pub fn simulation_text(r: &SimReport, with_reference: bool) -> String {
    let nominal = if with_reference {
        "the reference program (each line paired with the original block it was written for)"
    } else {
        "this program"
    };
    format!(
        "blocks              {}\n\
         feed length         {:.3} mm\n\
         point error         RMS {:8.3} µm   max {:8.3} µm   ({} points)\n\
         contour error       RMS {:8.3} µm   max {:8.3} µm   ({} samples ≤ 0.05 mm apart)\n\
         nominal path        {nominal}\n\
         point error:   {}\n\
         contour error: {}\n",
        r.blocks,
        r.feed_length_mm,
        r.point_rms_um,
        r.point_max_um,
        r.points,
        r.contour_rms_um,
        r.contour_max_um,
        r.samples,
        r.point_definition,
        r.contour_definition
    )
}

/// What a compensation did, in two lines for a person (`output` names
/// where the program went).
pub fn summary_lines(s: &CompensateSummary, output: &str) -> [String; 2] {
    let ratio = if s.blocks_in > 0 {
        format!(" (x{:.2})", s.blocks_out as f64 / s.blocks_in as f64)
    } else {
        String::new()
    };
    let contour = match s.max_estimated_contour_um {
        Some(um) => format!(
            "{} estimated (plus the rounding of the written numbers)",
            super::text::um(um)
        ),
        None => "not estimated (fixed segmentation)".into(),
    };
    // What became of the canned-cycle holes.
    let cycles = if s.cycle_holes_kept + s.cycle_holes_expanded > 0 {
        format!(
            "; canned-cycle holes: {} kept as cycles (largest error they leave {}), {} written as moves",
            s.cycle_holes_kept,
            super::text::um(s.max_cycle_error_um),
            s.cycle_holes_expanded
        )
    } else {
        String::new()
    };
    let not_compensated = if s.uncompensated_moves > 0 {
        format!(
            ", {} NOT compensated",
            count(s.uncompensated_moves, "feed move", "feed moves")
        )
    } else {
        String::new()
    };
    [
        format!(
            "wrote {output} ({} from {}; {} compensated{not_compensated}, largest correction {}, largest residual {}; {})",
            count(s.lines_out, "line", "lines"),
            s.lines_in,
            count(s.points, "point", "points"),
            super::text::um(s.max_correction_um),
            super::text::um(s.max_residual_um),
            s.reversals_text(),
        ),
        format!(
            "size {} -> {} bytes, {} -> {} blocks{ratio}; largest contour deviation the segmentation leaves: {contour}{cycles}",
            s.bytes_in, s.bytes_out, s.blocks_in, s.blocks_out
        ),
    ]
}

/// The warning of a compensation that wrote feed moves without
/// compensation because an axis was never set (`None` when there were
/// none): how many, why, and what to do (options as `{name}`).
pub fn uncompensated_warning(s: &CompensateSummary) -> Option<String> {
    let text = s.uncompensated_text()?;
    let axes = crate::compensate::unset_axes_text(s.unset_axes);
    Some(format!(
        "{text}; they are written as they are, with the machine's error; give the machine's position when the program starts as `start = [X, Y, Z]` in the set-up file ({{setup}}), or a move of {axes} in the program, to compensate them"
    ))
}

/// The warning of a compensation that held axes (`None` when none was
/// held): how many, and the first ten lines.
pub fn held_warning(s: &CompensateSummary) -> Option<String> {
    if s.held_count == 0 {
        return None;
    }
    let first: Vec<String> = s
        .held
        .iter()
        .take(10)
        .map(|(l, a)| format!("line {l} ({a})"))
        .collect();
    Some(format!(
        "{} kept an axis still because no command moves it the way its table was chosen for: the reversal value of the error compensated (the map's, or with a controller what it leaves of the map) is negative there (forward error above reverse), so no command can reverse by less than it: {}",
        count(s.held_count, "point", "points"),
        first.join(", ")
    ))
}

/// The program lines a corrections section quotes.
pub fn lines_to_quote(
    corrections: &LargestCorrections,
    summary: Option<&CompensateSummary>,
    warning_lines: &[u64],
) -> BTreeSet<u64> {
    let mut set: BTreeSet<u64> = corrections.items.iter().map(|c| c.line).collect();
    if let Some(s) = summary {
        set.extend(s.held.iter().map(|(l, _)| *l));
    }
    set.extend(warning_lines.iter().copied());
    set
}

/// The largest corrections, the held axes and the warnings, with their
/// program lines (`quoted`, from [`quote_lines`]).
pub fn corrections_section(
    corrections: &LargestCorrections,
    summary: &CompensateSummary,
    warnings: &[(u64, String)],
    quoted: &BTreeMap<u64, String>,
) -> Section {
    let q = |l: u64| quoted.get(&l).cloned().unwrap_or_default();
    let mut blocks = vec![Block::Text(format!(
        "The {} largest corrections ‖command − target‖ of the run (targets in the machine's axis frame).",
        corrections.items.len()
    ))];
    blocks.push(Block::Table(Table::new(
        &[
            "line",
            "program line",
            "target X, Y, Z (mm)",
            "correction (µm)",
            "residual (µm)",
            "held",
        ],
        &[true, false, true, true, true, false],
        corrections
            .items
            .iter()
            .map(|c| {
                vec![
                    c.line.to_string(),
                    q(c.line),
                    format!(
                        "{:.4}, {:.4}, {:.4}",
                        c.target_mm.x, c.target_mm.y, c.target_mm.z
                    ),
                    format!("{:.3}", c.correction_um),
                    format!("{:.4}", c.residual_um),
                    axes_text(c.held),
                ]
            })
            .collect(),
    )));
    if summary.held_count == 0 {
        blocks.push(Block::Text(
            "No axis was held: every reversal could be compensated.".into(),
        ));
    } else {
        blocks.push(Block::Text(format!(
            "{} point(s) kept an axis still because no command moves it the way its table was chosen for: the reversal value of the error compensated (the map's, or with a controller what it leaves of the map) is negative there (forward error above reverse), so no command can reverse by less than it{}:",
            summary.held_count,
            if summary.held_count as usize > summary.held.len() {
                format!("; the first {} are listed", summary.held.len())
            } else {
                String::new()
            }
        )));
        blocks.push(Block::Lines(
            summary
                .held
                .iter()
                .map(|(l, a)| (*l, format!("[{a} held]  {}", q(*l))))
                .collect(),
        ));
    }
    blocks.extend(warnings_blocks(warnings, quoted));
    Section {
        id: "corrections".into(),
        title: "Largest corrections, held axes and warnings".into(),
        blocks,
    }
}

/// The interpreter's warnings with their program lines.
pub fn warnings_blocks(warnings: &[(u64, String)], quoted: &BTreeMap<u64, String>) -> Vec<Block> {
    if warnings.is_empty() {
        return vec![Block::Text("The interpreter gave no warning.".into())];
    }
    let mut lines = Vec::new();
    for (l, w) in warnings {
        lines.push((*l, format!("warning: {w}")));
        if let Some(t) = quoted.get(l) {
            lines.push((*l, t.clone()));
        }
    }
    vec![
        Block::Text(format!(
            "{} warning(s) of the interpreter (what it assumed about the program):",
            warnings.len()
        )),
        Block::Lines(lines),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use volcomp_gcode::Vec3;

    fn point(line: u64, dx_um: f64) -> PointRecord {
        PointRecord {
            line,
            target_mm: Vec3::new(1.0, 2.0, 3.0),
            command_mm: Vec3::new(1.0 + dx_um * 1e-3, 2.0, 3.0),
            iterations: 1,
            residual_um: 0.0,
            reversed: [false; 3],
            held: [false; 3],
            take_up: false,
            rapid: false,
        }
    }

    #[test]
    fn the_largest_corrections_are_kept_in_order() {
        let mut c = LargestCorrections::default();
        for i in 0..100u64 {
            // Corrections 0, 7, 14, … 693 µm, out of order.
            let k = (i * 37) % 100;
            c.push(&point(k, 7.0 * k as f64));
        }
        assert_eq!(c.items.len(), LARGEST);
        assert_eq!(c.items[0].line, 99);
        assert!((c.items[0].correction_um - 693.0).abs() < 1e-6);
        assert_eq!(c.items[LARGEST - 1].line, 100 - LARGEST as u64);
    }

    #[test]
    fn lines_are_quoted_by_number_and_long_ones_marked() {
        let long = "G1 X1 ".repeat(40);
        let text = format!("G21\r\nG0 X0\n{long}\nM2\n");
        let want: BTreeSet<u64> = [2, 3, 9].into();
        let q = quote_lines(text.as_bytes(), &want).unwrap();
        assert_eq!(q[&2], "G0 X0");
        assert!(q[&3].ends_with(" …"));
        assert_eq!(q[&3].chars().count(), QUOTE_CHARS + 2);
        assert!(!q.contains_key(&9));
    }

    #[test]
    fn results_show_the_change_in_percent() {
        let b = SimReport {
            point_rms_um: 10.0,
            contour_max_um: 4.0,
            ..SimReport::default()
        };
        let a = SimReport {
            point_rms_um: 2.5,
            contour_max_um: 5.0,
            ..SimReport::default()
        };
        let t = PathTrace::default();
        let table = results_table(
            Some(&Measured {
                label: "before",
                report: &b,
                trace: &t,
            }),
            &Measured {
                label: "after",
                report: &a,
                trace: &t,
            },
        );
        // 10 → 2.5: −75 %; 4 → 5: +25 %.
        assert_eq!(
            table.rows[0],
            vec!["point error, RMS", "10.000", "2.500", "-75.0\u{a0}%"]
        );
        assert_eq!(table.rows[3][3], "+25.0\u{a0}%");
    }

    #[test]
    fn common_bins_share_one_width_and_sum_to_100_percent() {
        let mut a = LengthHistogram::default();
        let mut b = LengthHistogram::default();
        a.add(10.0, 3.0);
        a.add(1.0, 1.0);
        b.add(0.1, 2.0);
        let (edges, h) = common_bins(&[&a, &b]);
        assert_eq!(h[0].len() + 1, edges.len());
        assert!(edges.len() <= 42);
        // 10 µm is covered.
        assert!(*edges.last().unwrap() > 10.0);
        for hs in &h {
            assert!((hs.iter().sum::<f64>() - 100.0).abs() < 1e-9);
        }
        // a: 75 % of its length at 10 µm.
        let w = edges[1];
        assert!((h[0][(10.0 / w) as usize] - 75.0).abs() < 1e-9);
    }
}

/// A program simulated for a report: its metrics, its trace and the
/// interpreter's warnings `(line, message)`.
#[derive(Debug, Clone, Default)]
pub struct Traced {
    /// Its name in the report.
    pub label: String,
    /// Its metrics.
    pub report: SimReport,
    /// What the pictures need of it.
    pub trace: PathTrace,
    /// The interpreter's warnings.
    pub warnings: Vec<(u64, String)>,
}

impl Traced {
    /// The view the sections take of it.
    pub fn measured(&self) -> Measured<'_> {
        Measured {
            label: &self.label,
            report: &self.report,
            trace: &self.trace,
        }
    }
}

/// Simulates `program` (named `name`) on `setup` with `model`'s errors,
/// against `reference` when given, keeping what a report needs; `label`
/// names it in the report. `on_segment` sees every measured command too
/// (for a caller's own outputs or progress).
#[allow(clippy::too_many_arguments)]
pub fn trace_program<'a>(
    model: &'a dyn crate::model::ErrorModel,
    setup: &crate::compensate::MachineSetup,
    chord_tolerance_mm: f64,
    label: &str,
    name: &str,
    program: impl std::io::Read,
    reference: Option<(String, Box<dyn std::io::Read + 'a>)>,
    mut on_segment: impl FnMut(&crate::simulate::SegmentError),
) -> Result<Traced, crate::Error> {
    let mut trace = PathTrace::default();
    let mut warnings = Vec::new();
    let mut sim = crate::Simulation::new(model)
        .setup(setup.clone())
        .chord_tolerance_mm(chord_tolerance_mm)
        .file_name(name);
    if let Some((n, r)) = reference {
        sim = sim.reference_named(n, r);
    }
    let report = sim
        .on_segment(|s| {
            trace.push(s);
            on_segment(s);
        })
        .on_warning(|w| warnings.push((w.line, w.message.clone())))
        .run(program)?;
    Ok(Traced {
        label: label.to_string(),
        report,
        trace,
        warnings,
    })
}

fn prefixed(prefix: &str, mut sections: Vec<Section>) -> Vec<Section> {
    if !prefix.is_empty() {
        for s in &mut sections {
            s.id = format!("{prefix}-{}", s.id);
            s.title = format!("{prefix}: {}", s.title);
        }
    }
    sections
}

/// The sections of a compensation: results before and after (with the
/// compensation's figures and the metrics' definitions), the pictures,
/// the largest corrections with held axes and warnings. `prefix` (may be
/// empty) starts every section's title and anchor, for several
/// compensations in one document.
pub fn compensation_sections(
    prefix: &str,
    before: &Traced,
    after: &Traced,
    summary: &CompensateSummary,
    corrections: &LargestCorrections,
    quoted: &BTreeMap<u64, String>,
) -> Vec<Section> {
    let (b, a) = (before.measured(), after.measured());
    let mut sections = vec![Section {
        id: "results".into(),
        title: "Errors before and after compensation".into(),
        blocks: vec![
            Block::Text(format!("'{}' is the original program on the machine with the map's errors; '{}' is the compensated program on the same machine, judged against the original's moves.", b.label, a.label)),
            Block::Table(results_table(Some(&b), &a)),
            Block::Table(summary_table(summary)),
            Block::Text(DEFINED_ONCE.into()),
        ],
    }];
    sections.extend(picture_sections(Some(&b), &a));
    sections.push(corrections_section(
        corrections,
        summary,
        &before.warnings,
        quoted,
    ));
    prefixed(prefix, sections)
}

/// The sections of a simulation: results (and those of `before`, e.g. the
/// reference program itself, when given), the pictures, the warnings.
pub fn simulation_sections(
    prefix: &str,
    before: Option<&Traced>,
    after: &Traced,
    quoted: &BTreeMap<u64, String>,
) -> Vec<Section> {
    let b = before.map(Traced::measured);
    let a = after.measured();
    let mut results = vec![
        Block::Table(results_table(b.as_ref(), &a)),
        Block::Text(DEFINED_ONCE.into()),
    ];
    // No page for a warning that was not given: one line here instead.
    if after.warnings.is_empty() {
        results.extend(warnings_blocks(&after.warnings, quoted));
    }
    let mut sections = vec![Section {
        id: "results".into(),
        title: "Errors of the simulated program".into(),
        blocks: results,
    }];
    sections.extend(picture_sections(b.as_ref(), &a));
    if !after.warnings.is_empty() {
        sections.push(Section {
            id: "warnings".into(),
            title: "Warnings".into(),
            blocks: warnings_blocks(&after.warnings, quoted),
        });
    }
    prefixed(prefix, sections)
}

#[cfg(test)]
mod held_tests {
    use super::*;

    #[test]
    fn held_axes_and_warnings_are_listed_with_their_program_lines() {
        let summary = CompensateSummary {
            held: vec![(3, 'X'), (7, 'Z')],
            held_count: 5,
            ..CompensateSummary::default()
        };
        let quoted: BTreeMap<u64, String> = [
            (3, "G1 X5".to_string()),
            (4, "G1 X6 F100".to_string()),
            (7, "G1 Z-1".to_string()),
        ]
        .into();
        let warnings = vec![(4, "no feed rate before this line; F100 assumed".to_string())];
        let s = corrections_section(&LargestCorrections::default(), &summary, &warnings, &quoted);
        let lines: Vec<&Vec<(u64, String)>> = s
            .blocks
            .iter()
            .filter_map(|b| match b {
                Block::Lines(l) => Some(l),
                _ => None,
            })
            .collect();
        assert_eq!(
            lines[0],
            &vec![
                (3, "[X held]  G1 X5".to_string()),
                (7, "[Z held]  G1 Z-1".to_string())
            ]
        );
        assert_eq!(lines[1][0].0, 4);
        assert!(lines[1][0].1.starts_with("warning: no feed rate"));
        assert_eq!(lines[1][1], (4, "G1 X6 F100".to_string()));
        // 5 holds, 2 listed: said so.
        assert!(s
            .blocks
            .iter()
            .any(|b| matches!(b, Block::Text(t) if t.contains("the first 2 are listed"))));
        // The lines to quote: the held and warned lines.
        let want = lines_to_quote(&LargestCorrections::default(), Some(&summary), &[4]);
        assert_eq!(want, [3, 4, 7].into());
    }
}
