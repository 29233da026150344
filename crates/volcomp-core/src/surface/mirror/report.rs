//! What the mirror method reports: the fit and statistics as text lines, the
//! per-point report (CSV), the summary as a serializable structure (JSON),
//! the compensated surface files (grid CSV and B-spline TOML) and the
//! header text of a compensated finishing program.
//!
//! The writers return text; where it is written (atomically, next to which
//! input) is the caller's choice.

use super::compensated::{CompensatedSurface, GridNode};
use super::finishing::{BallTool, ClPoint, FinishingSummary};
use super::io::write_bspline_toml;
use super::method::{FitInfo, FitKind, FitMethod, MatchedPoint, MirrorResult};
use super::stats::DeviationStats;
use super::MirrorError;
use std::fmt::Write as _;

/// The run a report describes: the input files as the user named them, and
/// the stock and probe radius the points were mirrored with.
#[derive(Debug, Clone, PartialEq)]
pub struct RunInputs {
    /// The nominal surface file.
    pub nominal: String,
    /// The probe-point file.
    pub measured: String,
    /// Stock `D` (mm).
    pub stock_mm: f64,
    /// Probe ball radius (mm), when the points are ball centres.
    pub probe_radius_mm: Option<f64>,
}

/// One line of text describing the fit.
pub fn fit_text(f: &FitInfo) -> String {
    match f.method {
        FitKind::LeastSquares => format!(
            "least squares, bicubic, {} × {} control points (least leave-one-out error{}); residual max {:.3} µm, RMS {:.3} µm; probe noise σ ≈ {} µm; leave-one-out RMS {} µm",
            f.net.0,
            f.net.1,
            f.tolerance_um
                .map(|t| format!(" among nets within ±{t} µm"))
                .unwrap_or_default(),
            f.max_residual_um,
            f.rms_residual_um,
            f.noise_estimate_um
                .map_or("?".into(), |v| format!("{v:.3}")),
            f.leave_one_out_rms_um
                .map_or("?".into(), |v| format!("{v:.3}")),
        ),
        FitKind::Interpolation => format!(
            "interpolation, bicubic, {} × {} control points; residual max {:.3} µm",
            f.net.0, f.net.1, f.max_residual_um
        ),
    }
}

/// One row of the statistics table: `name` then mean, std, min, max,
/// profile and range (µm, 3 decimals; values that round to zero are
/// written without a minus sign).
pub fn stats_line(name: &str, s: &DeviationStats) -> String {
    // No "-0.000" for values that round to zero.
    let z = |x: f64| if x.abs() < 5e-4 { 0.0 } else { x };
    let s = DeviationStats {
        mean_um: z(s.mean_um),
        min_um: z(s.min_um),
        max_um: z(s.max_um),
        ..*s
    };
    format!(
        "{name:<30} {:>9.3} {:>9.3} {:>9.3} {:>9.3} {:>9.3} {:>9.3}",
        s.mean_um, s.std_um, s.min_um, s.max_um, s.profile_um, s.range_um
    )
}

/// The statistics table: a heading and one row each for the measured
/// errors, the tool-radius baseline, the leave-one-out prediction (least
/// squares only) and the fit residual.
pub fn stats_table(r: &MirrorResult) -> Vec<String> {
    let mut v = vec![
        format!(
            "{:<30} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9}",
            "deviations (µm)", "mean", "std", "min", "max", "profile", "range"
        ),
        stats_line("measured (no compensation)", &r.before),
        stats_line("tool-radius baseline", &r.baseline),
    ];
    if let Some(p) = &r.mirror_predicted {
        v.push(stats_line("mirror, predicted (LOO)", p));
    }
    v.push(stats_line("mirror, fit residual", &r.mirror_fit));
    v
}

/// The per-point report: the summary in `#` lines, then one CSV row per
/// probe point (file order) with its match, mirror and fit.
pub fn report_csv(inputs: &RunInputs, r: &MirrorResult) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# volcomp surface mirror: nominal {}, probe points {}, stock {} mm, {} points",
        inputs.nominal,
        inputs.measured,
        inputs.stock_mm,
        r.points.len()
    );
    let _ = writeln!(s, "# fit: {}", fit_text(&r.fit));
    let _ = writeln!(
        s,
        "# tool-radius baseline: constant offset {:.4} µm",
        r.baseline_offset_um
    );
    for line in stats_table(r) {
        let _ = writeln!(s, "# {line}");
    }
    let _ = writeln!(s, "# profile = 2·max|d| (zone centred on the nominal, ISO 1101); range = max − min; error > 0: material left");
    let _ = writeln!(s, "row,id,i,j,x_mm,y_mm,z_mm,u,v,nominal_x_mm,nominal_y_mm,nominal_z_mm,nx,ny,nz,error_um,mirror_distance_um,comp_x_mm,comp_y_mm,comp_z_mm,offset_um,fit_residual_um,predicted_um,baseline_um");
    for p in &r.points {
        let (i, j) = p
            .grid
            .map(|(i, j)| (i.to_string(), j.to_string()))
            .unwrap_or_default();
        let _ = writeln!(
            s,
            "{},{},{},{},{:.6},{:.6},{:.6},{:.9},{:.9},{:.6},{:.6},{:.6},{:.9},{:.9},{:.9},{:.4},{:.4},{:.6},{:.6},{:.6},{:.4},{:.4},{},{:.4}",
            p.row,
            p.id.as_deref().unwrap_or(""),
            i,
            j,
            p.measured_mm.x,
            p.measured_mm.y,
            p.measured_mm.z,
            p.u,
            p.v,
            p.nominal_mm.x,
            p.nominal_mm.y,
            p.nominal_mm.z,
            p.normal.x,
            p.normal.y,
            p.normal.z,
            p.error_um,
            p.mirror_distance_um,
            p.compensation_mm.x,
            p.compensation_mm.y,
            p.compensation_mm.z,
            p.offset_um,
            p.fit_residual_um,
            p.predicted_um.map(|x| format!("{x:.4}")).unwrap_or_default(),
            p.error_um + r.baseline_offset_um
        );
    }
    s
}

/// The compensated surface as written: the grid CSV and the B-spline TOML
/// texts, with what the summary says about them.
#[derive(Debug, Clone, PartialEq)]
pub struct CompensatedSurfaceText {
    /// `i,j,x_mm,y_mm,z_mm,offset_um` rows under `#` comments.
    pub grid_csv: String,
    /// Nodes of the grid (u, v).
    pub grid_nodes: (usize, usize),
    /// The B-spline surface in the format of [`super::read_bspline_toml`].
    pub bspline_toml: String,
    /// Its control net (u, v).
    pub bspline_net: (usize, usize),
    /// Its largest distance from `S_F + δ·n` found (µm).
    pub bspline_error_um: f64,
}

/// The compensated surface `S_C` as files: a grid of `grid_size` nodes per
/// direction (a grid nominal keeps its own nodes) and a bicubic B-spline
/// within 0.1 µm of `S_C` (see [`CompensatedSurface::to_bspline`]).
pub fn compensated_surface_text(
    inputs: &RunInputs,
    surface: &CompensatedSurface<'_>,
    grid_size: usize,
) -> Result<CompensatedSurfaceText, MirrorError> {
    let nodes = surface.grid(grid_size);
    let grid_csv = grid_csv(inputs, &nodes);
    let ni = nodes.iter().map(|n| n.i + 1).max().unwrap_or(0);
    let nj = nodes.iter().map(|n| n.j + 1).max().unwrap_or(0);
    let (bs, err_mm) = surface.to_bspline(1e-4)?;
    let bspline_toml = write_bspline_toml(
        &bs,
        &format!(
            "compensated surface from volcomp surface mirror\nnominal {}, probe points {}, stock {} mm\nwithin {:.4} µm of S_F + offset·n",
            inputs.nominal,
            inputs.measured,
            inputs.stock_mm,
            err_mm * 1e3
        ),
    );
    Ok(CompensatedSurfaceText {
        grid_csv,
        grid_nodes: (ni, nj),
        bspline_toml,
        bspline_net: (bs.count_u(), bs.count_v()),
        bspline_error_um: err_mm * 1e3,
    })
}

/// The grid CSV of the compensated surface: `#` comments naming the inputs,
/// then `i,j,x_mm,y_mm,z_mm,offset_um` (6 and 4 decimals).
pub fn grid_csv(inputs: &RunInputs, nodes: &[GridNode]) -> String {
    let mut csv = format!(
        "# volcomp surface mirror: compensated surface S_C = S_F + offset·n (program frame, mm)\n# nominal {}, probe points {}, stock {} mm\ni,j,x_mm,y_mm,z_mm,offset_um\n",
        inputs.nominal, inputs.measured, inputs.stock_mm
    );
    for n in nodes {
        let _ = writeln!(
            csv,
            "{},{},{:.6},{:.6},{:.6},{:.4}",
            n.i, n.j, n.point_mm.x, n.point_mm.y, n.point_mm.z, n.offset_um
        );
    }
    csv
}

/// The compensated surface files in the summary.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SurfaceFiles {
    /// The grid CSV.
    pub grid: String,
    /// Its nodes (u, v).
    pub grid_nodes: (usize, usize),
    /// The B-spline TOML.
    pub bspline: String,
    /// Its control net (u, v).
    pub bspline_net: (usize, usize),
    /// Its distance from `S_F + δ·n` (µm).
    pub bspline_error_um: f64,
}

/// A compensated finishing program in the summary.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FinishingJson {
    /// The written program.
    pub output: String,
    /// Lines read.
    pub lines_in: u64,
    /// Lines written.
    pub lines_out: u64,
    /// Feed-move points.
    pub feed_points: u64,
    /// Of those, the ones moved (touching the nominal surface).
    pub moved: u64,
    /// Of those, the ones outside the probed area.
    pub outside_probed_area: u64,
    /// Smallest offset applied (µm).
    pub min_offset_um: f64,
    /// Largest offset applied (µm).
    pub max_offset_um: f64,
}

impl FinishingJson {
    /// The summary of the program written to `output`.
    pub fn new(output: &str, s: &FinishingSummary) -> Self {
        Self {
            output: output.to_string(),
            lines_in: s.program.lines_in,
            lines_out: s.program.lines_out,
            feed_points: s.feed_points,
            moved: s.in_contact,
            outside_probed_area: s.outside_field,
            min_offset_um: s.min_offset_um,
            max_offset_um: s.max_offset_um,
        }
    }
}

/// The summary of a run (the `--json` output and the JSON report).
#[derive(Debug, Clone, serde::Serialize)]
pub struct SummaryJson<'a> {
    /// The nominal surface file.
    pub nominal: String,
    /// The probe-point file.
    pub measured: String,
    /// Stock (mm).
    pub stock_mm: f64,
    /// Probe ball radius (mm).
    pub probe_radius_mm: Option<f64>,
    /// Number of probe points.
    pub points: usize,
    /// The fit.
    pub fit: &'a FitInfo,
    /// The measured errors (what an uncompensated finishing pass repeats).
    pub before: DeviationStats,
    /// The tool-radius baseline's constant offset (µm).
    pub baseline_offset_um: f64,
    /// Errors after the baseline.
    pub baseline: DeviationStats,
    /// Leave-one-out prediction after mirror compensation.
    pub mirror_predicted: Option<DeviationStats>,
    /// The leave-one-out prediction is worse (larger std) than no compensation.
    pub compensation_predicted_worse: bool,
    /// Fit residuals.
    pub mirror_fit: DeviationStats,
    /// The compensated surface files.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub surface: Option<&'a SurfaceFiles>,
    /// The compensated finishing program.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub finishing: Option<FinishingJson>,
    /// The finishing program with the tool-radius baseline.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub baseline_program: Option<FinishingJson>,
    /// Every probe point (the report only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub probe_points: Option<&'a [MatchedPoint]>,
}

/// The summary of a run; `with_points` adds every probe point.
pub fn summary_json<'a>(
    inputs: &RunInputs,
    r: &'a MirrorResult,
    surface: Option<&'a SurfaceFiles>,
    finishing: Option<FinishingJson>,
    baseline_program: Option<FinishingJson>,
    with_points: bool,
) -> SummaryJson<'a> {
    SummaryJson {
        nominal: inputs.nominal.clone(),
        measured: inputs.measured.clone(),
        stock_mm: inputs.stock_mm,
        probe_radius_mm: inputs.probe_radius_mm,
        points: r.points.len(),
        fit: &r.fit,
        before: r.before,
        baseline_offset_um: r.baseline_offset_um,
        baseline: r.baseline,
        mirror_predicted: r.mirror_predicted,
        compensation_predicted_worse: r.compensation_predicted_worse(),
        mirror_fit: r.mirror_fit,
        surface,
        finishing,
        baseline_program,
        probe_points: with_points.then_some(r.points.as_slice()),
    }
}

/// The summary a person reads after a run: probe points and fit, the
/// statistics table, the baseline, the surface files and the finishing
/// programs written (`baseline_program` only with `finishing`).
pub fn summary_text(
    inputs: &RunInputs,
    r: &MirrorResult,
    surface: &SurfaceFiles,
    finishing: Option<&FinishingJson>,
    baseline_program: Option<&FinishingJson>,
) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "probe points  {} ({}), stock {} mm{}",
        r.points.len(),
        inputs.measured,
        inputs.stock_mm,
        inputs
            .probe_radius_mm
            .map(|p| format!(", probe radius {p} mm"))
            .unwrap_or_default()
    );
    let _ = writeln!(out, "fit           {}", fit_text(&r.fit));
    let _ = writeln!(out);
    for line in stats_table(r) {
        let _ = writeln!(out, "{line}");
    }
    let _ = writeln!(
        out,
        "(profile: 2·max|d|, the zone centred on the nominal; range: max − min; error > 0: material left)"
    );
    let _ = writeln!(out);
    let _ = writeln!(
        out,
        "baseline      constant offset {:.3} µm (a tool-radius change): removes the mean only",
        r.baseline_offset_um
    );
    let _ = writeln!(
        out,
        "surface       {} ({} × {} nodes), {} (bicubic {} × {}, within {:.3} µm of S_F + offset·n)",
        surface.grid,
        surface.grid_nodes.0,
        surface.grid_nodes.1,
        surface.bspline,
        surface.bspline_net.0,
        surface.bspline_net.1,
        surface.bspline_error_um
    );
    if let Some(f) = finishing {
        let _ = writeln!(out, "finishing     {}", finishing_line(f));
        if let Some(b) = baseline_program {
            let _ = writeln!(out, "baseline      {}", finishing_line(b));
        }
    }
    out
}

/// What a finishing program's rewrite did, in one line.
fn finishing_line(s: &FinishingJson) -> String {
    format!(
        "{} ({} lines from {}; {} of {} feed points on the surface moved by {:.3} … {:.3} µm{})",
        s.output,
        s.lines_out,
        s.lines_in,
        s.moved,
        s.feed_points,
        s.min_offset_um,
        s.max_offset_um,
        if s.outside_probed_area > 0 {
            format!(
                "; {} outside the probed area took the value at its edge",
                s.outside_probed_area
            )
        } else {
            String::new()
        }
    )
}

/// The `method` line of a compensated finishing program's header.
pub fn header_method(baseline: bool) -> &'static str {
    if baseline {
        "surface mirror baseline, constant offset"
    } else {
        "surface mirror"
    }
}

/// The `options` line of a compensated finishing program's header: stock,
/// tool, fit, splitting (`None`: no split) and contact tolerance.
pub fn header_options(
    stock_mm: f64,
    tool: &BallTool,
    fit: &FitMethod,
    segment_length_mm: Option<f64>,
    contact_tolerance_mm: f64,
) -> String {
    let fit = match fit {
        FitMethod::LeastSquares { tolerance_um } => match tolerance_um {
            Some(t) => format!("least-squares fit within {t} um"),
            None => "least-squares fit, net by leave-one-out".to_string(),
        },
        FitMethod::Interpolate => "interpolating fit".to_string(),
    };
    let split = match segment_length_mm {
        None => "no split".to_string(),
        Some(l) => format!("segment length {l} mm"),
    };
    format!(
        "stock {stock_mm} mm, tool radius {} mm, CL point {}, {fit}, {split}, contact tolerance {contact_tolerance_mm} mm",
        tool.radius_mm,
        match tool.cl {
            ClPoint::Tip => "tip",
            ClPoint::Centre => "center",
        },
    )
}

#[cfg(test)]
mod tests {
    use super::super::test_support::plane_surface;
    use super::super::{mirror, MaterialSide, MirrorOptions, NominalSurface, ProbePoint};
    use super::*;
    use volcomp_gcode::Vec3;

    fn stats(mean: f64) -> DeviationStats {
        DeviationStats {
            count: 3,
            mean_um: mean,
            std_um: 1.5,
            min_um: -2.25,
            max_um: 3.0,
            profile_um: 6.0,
            range_um: 5.25,
        }
    }

    #[test]
    fn a_stats_line_is_a_name_column_and_six_right_aligned_numbers() {
        let want = "x".to_string()
            + &" ".repeat(29)
            + "     0.000     1.500    -2.250     3.000     6.000     5.250";
        assert_eq!(stats_line("x", &stats(0.0004)), want);
        // A mean that rounds to zero is written without a minus sign.
        assert_eq!(stats_line("x", &stats(-0.0004)), want);
        assert!(stats_line("x", &stats(-0.0006)).contains("   -0.001 "));
    }

    #[test]
    fn the_header_options_name_every_choice() {
        let tool = BallTool {
            radius_mm: 3.0,
            cl: ClPoint::Centre,
        };
        assert_eq!(
            header_options(
                0.2,
                &tool,
                &FitMethod::LeastSquares {
                    tolerance_um: Some(1.5)
                },
                Some(2.0),
                0.02
            ),
            "stock 0.2 mm, tool radius 3 mm, CL point center, least-squares fit within 1.5 um, segment length 2 mm, contact tolerance 0.02 mm"
        );
        let tip = BallTool {
            cl: ClPoint::Tip,
            ..tool
        };
        let o = header_options(0.3, &tip, &FitMethod::Interpolate, None, 0.05);
        assert_eq!(
            o,
            "stock 0.3 mm, tool radius 3 mm, CL point tip, interpolating fit, no split, contact tolerance 0.05 mm"
        );
        assert_eq!(
            header_method(true),
            "surface mirror baseline, constant offset"
        );
        assert_eq!(header_method(false), "surface mirror");
    }

    /// The mirror method on a flat plate at z = 0 with 5 × 5 probe points
    /// 0.2 mm + 3 µm above it (a uniform 3 µm undercut).
    fn flat_run() -> (RunInputs, MirrorResult) {
        let nominal = NominalSurface::new(plane_surface(), MaterialSide::Below, "s").unwrap();
        let probes: Vec<ProbePoint> = (0..25)
            .map(|k| ProbePoint {
                row: k + 2,
                id: Some(format!("P{k}")),
                grid: Some(((k / 5) as i64, (k % 5) as i64)),
                position_mm: Vec3::new(
                    3.0 + 6.0 * (k / 5) as f64,
                    3.0 + 6.0 * (k % 5) as f64,
                    0.203,
                ),
            })
            .collect();
        let r = mirror(&nominal, &probes, &MirrorOptions::default(), "p.csv").unwrap();
        let inputs = RunInputs {
            nominal: "s.toml".into(),
            measured: "p.csv".into(),
            stock_mm: 0.2,
            probe_radius_mm: None,
        };
        (inputs, r)
    }

    #[test]
    fn the_csv_report_has_the_summary_then_one_row_per_point() {
        let (inputs, r) = flat_run();
        let text = report_csv(&inputs, &r);
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(
            lines[0],
            "# volcomp surface mirror: nominal s.toml, probe points p.csv, stock 0.2 mm, 25 points"
        );
        // A uniform 3 µm undercut: the baseline offset is −3 µm.
        assert_eq!(
            lines[2],
            "# tool-radius baseline: constant offset -3.0000 µm"
        );
        let header = lines.iter().position(|l| l.starts_with("row,")).unwrap();
        assert_eq!(lines[header].split(',').count(), 24);
        assert_eq!(lines.len(), header + 1 + 25);
        let first: Vec<&str> = lines[header + 1].split(',').collect();
        assert_eq!(first.len(), 24);
        assert_eq!(&first[..4], &["2", "P0", "0", "0"]);
        // Measured point, nominal point, normal, error and its mirror: by
        // hand, P_R = (3, 3, 0.203), P_P = (3, 3, 0), n = +Z, error 3 µm,
        // D_M = 203 − 100 = 103 µm, P_C = P_R − 2·D_M·n = (3, 3, −0.003).
        assert_eq!(&first[4..7], &["3.000000", "3.000000", "0.203000"]);
        assert_eq!(&first[9..12], &["3.000000", "3.000000", "0.000000"]);
        assert_eq!(first[14], "1.000000000");
        assert_eq!(&first[15..17], &["3.0000", "103.0000"]);
        assert_eq!(first[19], "-0.003000");
        assert_eq!(first[20], "-3.0000");
        assert_eq!(first[23], "0.0000");
    }

    #[test]
    fn the_summary_text_names_the_files_and_the_finishing_programs() {
        let (inputs, r) = flat_run();
        let surface = SurfaceFiles {
            grid: "g.csv".into(),
            grid_nodes: (41, 41),
            bspline: "g.toml".into(),
            bspline_net: (7, 7),
            bspline_error_um: 0.05,
        };
        let text = summary_text(&inputs, &r, &surface, None, None);
        assert!(
            text.starts_with("probe points  25 (p.csv), stock 0.2 mm\n"),
            "{text}"
        );
        assert!(text.contains(
            "\nsurface       g.csv (41 × 41 nodes), g.toml (bicubic 7 × 7, within 0.050 µm of S_F + offset·n)\n"
        ), "{text}");
        assert!(!text.contains("finishing"), "{text}");
        let f = FinishingJson {
            output: "f.ngc".into(),
            lines_in: 10,
            lines_out: 12,
            feed_points: 8,
            moved: 6,
            outside_probed_area: 1,
            min_offset_um: -3.0,
            max_offset_um: -2.5,
        };
        let text = summary_text(&inputs, &r, &surface, Some(&f), Some(&f));
        let want = "f.ngc (12 lines from 10; 6 of 8 feed points on the surface moved by -3.000 … -2.500 µm; 1 outside the probed area took the value at its edge)";
        assert!(
            text.contains(&format!("\nfinishing     {want}\n")),
            "{text}"
        );
        assert!(
            text.ends_with(&format!("\nbaseline      {want}\n")),
            "{text}"
        );
    }

    #[test]
    fn the_fit_text_of_an_interpolation() {
        let (_, r) = flat_run();
        let f = FitInfo {
            method: FitKind::Interpolation,
            net: (7, 5),
            max_residual_um: 0.0001,
            ..r.fit
        };
        assert_eq!(
            fit_text(&f),
            "interpolation, bicubic, 7 × 5 control points; residual max 0.000 µm"
        );
    }
}
