//! Free-form surface compensation from on-machine probing: the mirror method.
//!
//! A semi-finishing pass should leave the stock `D` on the ideal finishing
//! surface `S_F`; the part is probed on the machine, and the finishing pass is
//! corrected so that it removes what the probing found:
//!
//! * For the ideal point `P_P` (closest point of `S_F` to the measured point
//!   `P_R`, outward unit normal `V_N`), the mirror surface lies halfway
//!   between `S_F` and the ideal semi-finished surface:
//!   `P_M = P_P + (D/2)·V_N`.
//! * `D_M = (P_R − P_M)·V_N` is the signed distance of the measured point to
//!   the mirror surface, and the compensation point is `P_C = P_R − 2·D_M·V_N`,
//!   the reflection of `P_R` in the mirror surface. Material left (undercut)
//!   becomes a target below `S_F` (overcut) and vice versa, so a finishing
//!   pass that repeats the machine's error lands on `S_F`.
//! * A smooth surface is fitted through the compensation points. It is kept
//!   as a normal offset of the nominal surface,
//!   `S_C(u, v) = S_F(u, v) + δ(u, v)·n(u, v)`, with `δ` a bicubic B-spline
//!   over `S_F`'s parameters through the heights `δ_k = (P_C − P_P)·V_N`
//!   (least squares to a stated tolerance, or interpolation of a probe grid).
//!   `S_C` passes through (within the tolerance of) every `P_C`; fitting
//!   the points in space instead would add the shape error of a new surface
//!   through a coarse probe grid (micrometres on curved parts) to the µm-size
//!   correction.
//! * Every cutter-location (CL) point of a ball-end finishing program is moved
//!   by `δ·n` at its contact point (the foot of the ball centre on `S_F`) and
//!   written back through the G-code engine, byte for byte unchanged
//!   elsewhere (see [`compensate_finishing`]).
//!
//! Frames and units: the nominal surface, the probe points and the finishing
//! program's coordinates share one frame, the *program frame* (work
//! coordinates, mm). Deviations are in µm, positive away from the material
//! (ISO: actual − nominal along the outward normal; positive = material
//! left, an undercut). The finishing program's tool axis is +Z.
//!
//! Metrics ([`DeviationStats`]): mean, standard deviation, and the profile
//! error of ISO 1101 style: the width of the zone centred on the nominal
//! surface that contains every deviation, `2·max|d|`; the range `max − min`
//! (the zone allowed to float) is reported too.

use crate::surface::bspline::{
    self, BSplineError, BSplineSurface, LeastSquaresFit, Parameterization, ProjectionIndex,
};
use crate::compensate::{
    compensate_program, CompensateOptions, CompensateSummary, DirectionPolicy, ProgramStyle,
    Segmentation,
};
use crate::error::{CompensationError, MapFileError, ModelError};
use crate::io::table::{CsvTable, Header, Record, UnknownColumns};
use crate::model::{Components, Directions, ErrorModel};
use crate::compensate::solve::Method;
use std::io::{BufRead, Write};
use std::sync::Mutex;
use volcomp_gcode::{GcodeError, MotionKind, MotionSource, Units, Vec3, Walker};

/// Why the mirror method refused its input. Every message says what is wrong,
/// where, and what to do.
#[derive(Debug, thiserror::Error)]
pub enum MirrorError {
    /// A value in a file (row and column are 1-based; column 0: the whole row).
    #[error("{file}:{row}:{column}: {message}\n  help: {help}")]
    AtRow {
        /// File name.
        file: String,
        /// 1-based line.
        row: usize,
        /// 1-based column (CSV field number, or character column in TOML).
        column: usize,
        /// What is wrong.
        message: String,
        /// What to do.
        help: String,
    },
    /// A located error in a table file.
    #[error(transparent)]
    File(#[from] MapFileError),
    /// A file as a whole.
    #[error("{file}: {message}\n  help: {help}")]
    InFile {
        /// File name.
        file: String,
        /// What is wrong.
        message: String,
        /// What to do.
        help: String,
    },
    /// The method's parameters or the data as a whole.
    #[error("{message}\n  help: {help}")]
    Method {
        /// What is wrong.
        message: String,
        /// What to do.
        help: String,
    },
    /// Reading or writing the finishing program failed.
    #[error(transparent)]
    Program(#[from] CompensationError),
}

impl From<GcodeError> for MirrorError {
    fn from(e: GcodeError) -> Self {
        MirrorError::Program(CompensationError::Gcode(e))
    }
}

fn method_error(message: impl Into<String>, help: impl Into<String>) -> MirrorError {
    MirrorError::Method {
        message: message.into(),
        help: help.into(),
    }
}

fn v3(a: [f64; 3]) -> Vec3 {
    Vec3::from_array(a)
}

fn fmt_point(p: Vec3) -> String {
    format!("({:.4}, {:.4}, {:.4})", p.x, p.y, p.z)
}

// ---- Statistics -------------------------------------------------------------

/// Statistics of a set of deviations (µm).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct DeviationStats {
    /// Number of values.
    pub count: usize,
    /// Mean.
    pub mean_um: f64,
    /// Sample standard deviation (n − 1).
    pub std_um: f64,
    /// Smallest value.
    pub min_um: f64,
    /// Largest value.
    pub max_um: f64,
    /// Profile error: width of the zone centred on the nominal that contains
    /// every deviation, `2·max|d|` (ISO 1101 surface profile, no datum shift).
    pub profile_um: f64,
    /// Range `max − min`: width of the zone when it may float.
    pub range_um: f64,
}

/// Statistics of `values` (µm); all zero for an empty set.
pub fn deviation_stats(values: impl IntoIterator<Item = f64>) -> DeviationStats {
    let v: Vec<f64> = values.into_iter().collect();
    if v.is_empty() {
        return DeviationStats::default();
    }
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = if v.len() > 1 {
        v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)
    } else {
        0.0
    };
    let min = v.iter().copied().fold(f64::INFINITY, f64::min);
    let max = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    DeviationStats {
        count: v.len(),
        mean_um: mean,
        std_um: var.sqrt(),
        min_um: min,
        max_um: max,
        profile_um: 2.0 * min.abs().max(max.abs()),
        range_um: max - min,
    }
}

// ---- CSV ---------------------------------------------------------------------

/// A probe-point or grid table, read by [`crate::io::table`]; columns
/// other than those looked up are ignored.
struct Csv {
    table: CsvTable,
}

fn read_csv(text: &str, file: &str) -> Result<Csv, MirrorError> {
    let table = CsvTable::parse(
        text,
        file,
        &Header {
            known: &[],
            unknown: UnknownColumns::Keep,
            layout: "x_mm,y_mm,z_mm (or x_in,y_in,z_in)",
        },
    )?;
    Ok(Csv { table })
}

impl Csv {
    fn column(&self, names: &[&str]) -> Option<usize> {
        self.table.column_of(names)
    }

    /// The x, y, z columns and their unit (`x_mm`… or `x_in`…).
    fn xyz(&self) -> Result<([usize; 3], Units), MirrorError> {
        let t = &self.table;
        let mut found: [Option<(usize, Units)>; 3] = [None; 3];
        for (a, letter) in ["x", "y", "z"].iter().enumerate() {
            for (suffix, unit) in [
                ("_mm", Units::Mm),
                ("_in", Units::Inch),
                ("_inch", Units::Inch),
            ] {
                if let Some(c) = self.column(&[&format!("{letter}{suffix}")]) {
                    if let Some((first, _)) = found[a] {
                        return Err(t
                            .error_at(
                                t.header_line,
                                c,
                                format!(
                                    "column `{}` gives {letter} again (first in column {})",
                                    t.header[c],
                                    first + 1
                                ),
                                "give each coordinate once",
                            )
                            .into());
                    }
                    found[a] = Some((c, unit));
                }
            }
            if found[a].is_none() {
                let help = "name the coordinate columns with their unit: x_mm,y_mm,z_mm (or x_in,y_in,z_in); volcomp never guesses a unit";
                return Err(match self.column(&[letter]) {
                    Some(c) => t.error_at(
                        t.header_line,
                        c,
                        format!("column `{letter}` does not say its unit"),
                        help,
                    ),
                    None => {
                        let mut e = t.missing(&format!("{letter}_mm"), "");
                        e.help = help.into();
                        e
                    }
                }
                .into());
            }
        }
        let units: Vec<Units> = found.iter().flatten().map(|f| f.1).collect();
        if units.iter().any(|u| *u != units[0]) {
            return Err(MapFileError::new(
                &t.file,
                t.header_line,
                1,
                "the coordinate columns mix millimetres and inches",
                "write all three coordinates in one unit",
            )
            .into());
        }
        Ok((
            [0, 1, 2].map(|a| found[a].map(|f| f.0).unwrap_or(0)),
            units[0],
        ))
    }

    fn integer(&self, row: &Record, col: usize) -> Result<i64, MirrorError> {
        self.table.integer(row, col).map_err(|mut e| {
            e.help = format!(
                "column `{}` holds a grid index (0, 1, 2, …)",
                self.table.header[col]
            );
            e.into()
        })
    }

    fn point(&self, row: &Record, cols: [usize; 3], units: Units) -> Result<Vec3, MirrorError> {
        let k = units.mm_per_unit();
        let t = &self.table;
        Ok(Vec3::new(
            t.number(row, cols[0])? * k,
            t.number(row, cols[1])? * k,
            t.number(row, cols[2])? * k,
        ))
    }
}

// ---- Probe points ----------------------------------------------------------

/// One probed point as read from the CSV.
#[derive(Debug, Clone, PartialEq)]
pub struct ProbePoint {
    /// 1-based line in the file.
    pub row: usize,
    /// The `id` column, when the file has one.
    pub id: Option<String>,
    /// The `i`, `j` grid indices, when the file has them.
    pub grid: Option<(i64, i64)>,
    /// Position (program frame, mm): the surface point, or the probe ball's
    /// centre when a probe radius is given.
    pub position_mm: Vec3,
}

/// Reads probe points: a CSV with a header naming `x_mm,y_mm,z_mm` (or
/// `x_in,y_in,z_in`), optionally `id` and the grid indices `i,j`; `#` lines
/// are comments; other columns are ignored.
pub fn read_probe_points(text: &str, file: &str) -> Result<Vec<ProbePoint>, MirrorError> {
    let csv = read_csv(text, file)?;
    let (cols, units) = csv.xyz()?;
    let id = csv.column(&["id", "name", "point"]);
    let grid = match (csv.column(&["i"]), csv.column(&["j"])) {
        (Some(i), Some(j)) => Some((i, j)),
        (None, None) => None,
        _ => {
            return Err(MirrorError::AtRow {
                file: file.into(),
                row: csv.table.header_line,
                column: 1,
                message: "only one of the grid index columns i, j is present".into(),
                help: "give both i and j, or neither".into(),
            })
        }
    };
    let mut out = Vec::with_capacity(csv.table.records()?.len());
    for row in csv.table.records()? {
        out.push(ProbePoint {
            row: row.line,
            id: id.map(|c| row.fields[c].to_string()),
            grid: match grid {
                Some((i, j)) => Some((csv.integer(row, i)?, csv.integer(row, j)?)),
                None => None,
            },
            position_mm: csv.point(row, cols, units)?,
        });
    }
    if out.is_empty() {
        return Err(MirrorError::InFile {
            file: file.into(),
            message: "no probe points".into(),
            help: "write one row x_mm,y_mm,z_mm per probed point".into(),
        });
    }
    Ok(out)
}

// ---- Surface files ---------------------------------------------------------

/// A regular grid of surface points, `points[i * count_v + j]` (mm).
#[derive(Debug, Clone, PartialEq)]
pub struct PointGrid {
    /// Points along u (index `i`).
    pub count_u: usize,
    /// Points along v (index `j`).
    pub count_v: usize,
    /// The points, row-major.
    pub points: Vec<[f64; 3]>,
}

/// Reads a grid CSV: `i,j,x_mm,y_mm,z_mm` (indices from any start, every
/// pair present once), or without `i,j` a height field whose `x, y` form a
/// rectangular lattice (`i` along x, `j` along y).
pub fn read_grid_csv(text: &str, file: &str) -> Result<PointGrid, MirrorError> {
    let csv = read_csv(text, file)?;
    let (cols, units) = csv.xyz()?;
    let mut pts = Vec::with_capacity(csv.table.records()?.len());
    for row in csv.table.records()? {
        pts.push((row.line, csv.point(row, cols, units)?));
    }
    let idx: Vec<(i64, i64)> = match (csv.column(&["i"]), csv.column(&["j"])) {
        (Some(ci), Some(cj)) => {
            let mut v = Vec::with_capacity(csv.table.records()?.len());
            for row in csv.table.records()? {
                v.push((csv.integer(row, ci)?, csv.integer(row, cj)?));
            }
            v
        }
        _ => {
            // A height field: the distinct x and y values (to 1 nm).
            let key = |x: f64| (x * 1e6).round() as i64;
            let mut xs: Vec<i64> = pts.iter().map(|p| key(p.1.x)).collect();
            let mut ys: Vec<i64> = pts.iter().map(|p| key(p.1.y)).collect();
            xs.sort_unstable();
            xs.dedup();
            ys.sort_unstable();
            ys.dedup();
            pts.iter()
                .map(|p| {
                    (
                        xs.binary_search(&key(p.1.x)).unwrap_or(0) as i64,
                        ys.binary_search(&key(p.1.y)).unwrap_or(0) as i64,
                    )
                })
                .collect()
        }
    };
    let (i0, j0) = (
        idx.iter().map(|x| x.0).min().unwrap_or(0),
        idx.iter().map(|x| x.1).min().unwrap_or(0),
    );
    let count_u = (idx.iter().map(|x| x.0).max().unwrap_or(-1) - i0 + 1).max(0) as usize;
    let count_v = (idx.iter().map(|x| x.1).max().unwrap_or(-1) - j0 + 1).max(0) as usize;
    let help = "a grid needs one point for every (i, j) pair: write i,j columns, or for a height field an x-y lattice with one z per node";
    // Indices far beyond the number of points: refuse before allocating.
    if count_u.saturating_mul(count_v) > 4 * pts.len() + 16 {
        return Err(MirrorError::InFile {
            file: file.into(),
            message: format!(
                "{} points do not fill the {count_u} × {count_v} grid their indices span",
                pts.len()
            ),
            help: help.into(),
        });
    }
    if count_u < 2 || count_v < 2 {
        return Err(MirrorError::InFile {
            file: file.into(),
            message: format!(
                "the points form a {count_u} × {count_v} grid; at least 2 × 2 are needed"
            ),
            help: help.into(),
        });
    }
    let mut grid: Vec<Option<[f64; 3]>> = vec![None; count_u * count_v];
    for ((line, p), (i, j)) in pts.iter().zip(&idx) {
        let k = (i - i0) as usize * count_v + (j - j0) as usize;
        if grid[k].is_some() {
            return Err(MirrorError::AtRow {
                file: file.into(),
                row: *line,
                column: 1,
                message: format!("a second point for grid node ({i}, {j})"),
                help: help.into(),
            });
        }
        grid[k] = Some(p.to_array());
    }
    if let Some(k) = grid.iter().position(Option::is_none) {
        return Err(MirrorError::InFile {
            file: file.into(),
            message: format!(
                "{} points for a {count_u} × {count_v} grid: node ({}, {}) is missing",
                pts.len(),
                k / count_v + i0 as usize,
                k % count_v + j0 as usize
            ),
            help: help.into(),
        });
    }
    Ok(PointGrid {
        count_u,
        count_v,
        points: grid.into_iter().flatten().collect(),
    })
}

/// Control points with their places in the file, for located errors.
type SpannedNet = toml::Spanned<Vec<toml::Spanned<Vec<toml::Spanned<Vec<f64>>>>>>;

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSurface {
    #[serde(default)]
    name: Option<String>,
    units: Option<toml::Spanned<Units>>,
    degree_u: toml::Spanned<i64>,
    degree_v: toml::Spanned<i64>,
    knots_u: toml::Spanned<Vec<f64>>,
    knots_v: toml::Spanned<Vec<f64>>,
    control_points: SpannedNet,
    #[serde(default)]
    weights: Option<toml::Spanned<toml::Value>>,
}

fn line_col(text: &str, at: usize) -> (usize, usize) {
    let at = at.min(text.len());
    let before = &text[..at];
    let row = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (row, col)
}

/// Reads a B-spline surface file (TOML, see `docs/mirror.md`):
///
/// ```toml
/// units = "mm"                 # required: "mm" or "inch"
/// degree_u = 3
/// degree_v = 3
/// knots_u = [0, 0, 0, 0, 1, 1, 1, 1]          # clamped, non-decreasing
/// knots_v = [0, 0, 0, 0, 1, 1, 1, 1]
/// control_points = [                           # [i][j]: i along u, j along v
///   [[0, 0, 0], [0, 10, 0], [0, 20, 0], [0, 30, 0]],
///   # … count_u rows of count_v points
/// ]
/// ```
pub fn read_bspline_toml(text: &str, file: &str) -> Result<BSplineSurface<3>, MirrorError> {
    let at = |span: std::ops::Range<usize>, message: String, help: &str| {
        let (row, column) = line_col(text, span.start);
        MirrorError::AtRow {
            file: file.into(),
            row,
            column,
            message,
            help: help.into(),
        }
    };
    let raw: RawSurface = toml::from_str(text).map_err(|e| {
        let (row, column) = e.span().map_or((1, 1), |s| line_col(text, s.start));
        MirrorError::AtRow {
            file: file.into(),
            row,
            column,
            message: e.message().trim().to_string(),
            help: "see docs/mirror.md for the B-spline surface format (units, degree_u, degree_v, knots_u, knots_v, control_points)".into(),
        }
    })?;
    let _ = raw.name;
    if let Some(w) = raw.weights {
        return Err(at(
            w.span(),
            "rational surfaces (weights) are not supported".into(),
            "export the surface as a non-rational B-spline, or as a grid of points",
        ));
    }
    let units = match raw.units {
        Some(u) => *u.get_ref(),
        None => {
            return Err(MirrorError::InFile {
                file: file.into(),
                message: "the file does not say its unit".into(),
                help: "add `units = \"mm\"` (or \"inch\"): volcomp never guesses a unit".into(),
            })
        }
    };
    let degree = |d: &toml::Spanned<i64>, dir: char| -> Result<usize, MirrorError> {
        let v = *d.get_ref();
        if !(1..=bspline::MAX_DEGREE as i64).contains(&v) {
            return Err(at(
                d.span(),
                format!("degree_{dir} = {v} is not supported"),
                &format!("the degree must be 1 … {}", bspline::MAX_DEGREE),
            ));
        }
        Ok(v as usize)
    };
    let p = degree(&raw.degree_u, 'u')?;
    let q = degree(&raw.degree_v, 'v')?;
    let rows = raw.control_points.get_ref();
    if rows.is_empty() {
        return Err(at(
            raw.control_points.span(),
            "no control points".into(),
            "write count_u rows of count_v [x, y, z] points",
        ));
    }
    let count_u = rows.len();
    let count_v = rows[0].get_ref().len();
    let k = units.mm_per_unit();
    let mut control = Vec::with_capacity(count_u * count_v);
    for (i, row) in rows.iter().enumerate() {
        if row.get_ref().len() != count_v {
            return Err(at(
                row.span(),
                format!(
                    "control_points row {i} has {} points, row 0 has {count_v}",
                    row.get_ref().len()
                ),
                "every row of the control net has the same number of points",
            ));
        }
        for (j, pt) in row.get_ref().iter().enumerate() {
            let c = pt.get_ref();
            if c.len() != 3 || c.iter().any(|x| !x.is_finite()) {
                return Err(at(
                    pt.span(),
                    format!("control point [{i}][{j}] is not three finite numbers"),
                    "write each control point as [x, y, z]",
                ));
            }
            control.push([c[0] * k, c[1] * k, c[2] * k]);
        }
    }
    let knots = |s: &toml::Spanned<Vec<f64>>| s.get_ref().clone();
    BSplineSurface::new(
        p,
        q,
        knots(&raw.knots_u),
        knots(&raw.knots_v),
        count_u,
        count_v,
        control,
    )
    .map_err(|e| {
        let msg = e.to_string();
        let span = if msg.contains("knots_u") || msg.contains("along u") {
            raw.knots_u.span()
        } else if msg.contains("knots_v") || msg.contains("along v") {
            raw.knots_v.span()
        } else {
            raw.control_points.span()
        };
        at(
            span,
            msg,
            "a clamped knot vector has count + degree + 1 non-decreasing values, the first and last degree + 1 equal",
        )
    })
}

/// Writes a surface in the format [`read_bspline_toml`] reads (mm).
pub fn write_bspline_toml(surface: &BSplineSurface<3>, comment: &str) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    for line in comment.lines() {
        let _ = writeln!(s, "# {line}");
    }
    let _ = writeln!(
        s,
        "# volcomp B-spline surface: non-rational, clamped knot vectors;\n# control_points[i][j]: i along u (knots_u), j along v (knots_v)."
    );
    let list = |v: &[f64]| {
        v.iter()
            .map(|x| format!("{x:?}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let _ = writeln!(s, "units = \"mm\"");
    let _ = writeln!(s, "degree_u = {}", surface.degree_u());
    let _ = writeln!(s, "degree_v = {}", surface.degree_v());
    let _ = writeln!(s, "knots_u = [{}]", list(surface.knots_u()));
    let _ = writeln!(s, "knots_v = [{}]", list(surface.knots_v()));
    let _ = writeln!(s, "control_points = [");
    for i in 0..surface.count_u() {
        let row: Vec<String> = (0..surface.count_v())
            .map(|j| format!("[{}]", list(&surface.control_point(i, j))))
            .collect();
        let _ = writeln!(s, "  [{}],", row.join(", "));
    }
    let _ = writeln!(s, "]");
    s
}

// ---- The nominal surface ---------------------------------------------------

/// Which side of the surface the material is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MaterialSide {
    /// Below the surface (−Z): the usual 3-axis case, the tool comes from +Z.
    Below,
    /// Above the surface (+Z).
    Above,
    /// The surface's own normal `Su × Sv` points out of the material.
    NormalOut,
    /// The surface's own normal `Su × Sv` points into the material.
    NormalIn,
}

/// The foot of a point on the nominal surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Foot {
    /// Parameter u.
    pub u: f64,
    /// Parameter v.
    pub v: f64,
    /// The closest surface point (mm).
    pub point: Vec3,
    /// Outward unit normal there.
    pub normal: Vec3,
    /// Signed distance along the outward normal (mm).
    pub height_mm: f64,
    /// Whether the point lies over the surface: its foot is interior, or on
    /// the boundary with the point less than 1 µm beyond the edge (rounding
    /// of written coordinates).
    pub orthogonal: bool,
}

/// The ideal finishing surface `S_F` with its material side, ready for
/// closest-point queries.
#[derive(Debug, Clone)]
pub struct NominalSurface {
    surface: BSplineSurface<3>,
    sign: f64,
    index: ProjectionIndex,
    grid_params: Option<(Vec<f64>, Vec<f64>)>,
    /// Smallest radius of curvature on the concave side (where the surface
    /// bends towards the outward normal), with its parameters.
    concave: Option<(f64, f64, f64)>,
}

/// Parameters with `per_span` samples in every knot span, ends included.
fn refine_breaks(breaks: &[f64], per_span: usize) -> Vec<f64> {
    let mut out = Vec::with_capacity(breaks.len() * per_span + 1);
    for w in breaks.windows(2) {
        for k in 0..per_span {
            out.push(w[0] + (w[1] - w[0]) * k as f64 / per_span as f64);
        }
    }
    if let Some(l) = breaks.last() {
        out.push(*l);
    }
    out
}

impl NominalSurface {
    /// Prepares `surface`, checking that it is regular (a normal everywhere)
    /// and, for [`MaterialSide::Below`]/[`MaterialSide::Above`], that it
    /// never faces the other way. `file` names it in messages.
    pub fn new(
        surface: BSplineSurface<3>,
        side: MaterialSide,
        file: &str,
    ) -> Result<Self, MirrorError> {
        let us = refine_breaks(&surface.breaks_u(), 4);
        let vs = refine_breaks(&surface.breaks_v(), 4);
        let mut sum_z = 0.0;
        let mut normals = Vec::with_capacity(us.len() * vs.len());
        for u in &us {
            for v in &vs {
                let n = surface.unit_normal(*u, *v).ok_or_else(|| MirrorError::InFile {
                    file: file.into(),
                    message: format!(
                        "the surface has no normal at u = {u:.6}, v = {v:.6}, point {} (a collapsed edge or a fold)",
                        fmt_point(v3(surface.point(*u, *v)))
                    ),
                    help: "export a regular surface (no degenerate edges), or trim it".into(),
                })?;
                sum_z += n[2];
                normals.push((*u, *v, n));
            }
        }
        let sign = match side {
            MaterialSide::NormalOut => 1.0,
            MaterialSide::NormalIn => -1.0,
            MaterialSide::Below | MaterialSide::Above => {
                let want = if side == MaterialSide::Below {
                    1.0
                } else {
                    -1.0
                };
                let sign = if sum_z * want >= 0.0 { 1.0 } else { -1.0 };
                if let Some((u, v, _)) = normals.iter().find(|(_, _, n)| n[2] * sign * want < -0.02)
                {
                    return Err(MirrorError::InFile {
                        file: file.into(),
                        message: format!(
                            "with the material {} it, the surface faces away from the tool at {} (u = {u:.6}, v = {v:.6})",
                            if want > 0.0 { "below" } else { "above" },
                            fmt_point(v3(surface.point(*u, *v)))
                        ),
                        help: "a 3-axis ball-end pass cannot reach an overhang; if the surface is not a height field, say the side with --material normal-out or normal-in".into(),
                    });
                }
                sign
            }
        };
        let mut concave: Option<(f64, f64, f64)> = None;
        for (u, v, _) in &normals {
            if let Some(k) = surface.curvatures(*u, *v) {
                // Curvature towards the outward normal.
                let toward = if sign > 0.0 { k.max } else { -k.min };
                if toward > 0.0 {
                    let r = 1.0 / toward;
                    if concave.is_none_or(|c| r < c.0) {
                        concave = Some((r, *u, *v));
                    }
                }
            }
        }
        let index = ProjectionIndex::new(&surface, 6);
        Ok(Self {
            surface,
            sign,
            index,
            grid_params: None,
            concave,
        })
    }

    /// Interpolates a grid of points (A9.4, degree ≤ 3 each way) into the
    /// nominal surface.
    pub fn from_grid(
        grid: &PointGrid,
        params: &Parameterization,
        side: MaterialSide,
        file: &str,
    ) -> Result<Self, MirrorError> {
        let p = (grid.count_u - 1).min(3);
        let q = (grid.count_v - 1).min(3);
        let surface = bspline::interpolate(&grid.points, grid.count_u, grid.count_v, p, q, params)
            .map_err(|e| MirrorError::InFile {
                file: file.into(),
                message: format!("cannot interpolate the grid: {e}"),
                help: "check for repeated or collapsed rows of points".into(),
            })?;
        let gp = bspline::mesh_params(&grid.points, grid.count_u, grid.count_v, params).map_err(
            |e| MirrorError::InFile {
                file: file.into(),
                message: e.to_string(),
                help: "check the grid".into(),
            },
        )?;
        let mut s = Self::new(surface, side, file)?;
        s.grid_params = Some(gp);
        Ok(s)
    }

    /// The B-spline surface.
    pub fn surface(&self) -> &BSplineSurface<3> {
        &self.surface
    }

    /// The parameters of the grid nodes, when the surface came from a grid.
    pub fn grid_params(&self) -> Option<&(Vec<f64>, Vec<f64>)> {
        self.grid_params.as_ref()
    }

    /// Smallest concave radius of curvature (mm) and where, `None` when the
    /// surface never bends towards the outward normal.
    pub fn min_concave_radius(&self) -> Option<(f64, Vec3)> {
        self.concave
            .map(|(r, u, v)| (r, v3(self.surface.point(u, v))))
    }

    /// `S_F(u, v)`.
    pub fn point(&self, u: f64, v: f64) -> Vec3 {
        v3(self.surface.point(u, v))
    }

    /// Outward unit normal (away from the material).
    pub fn normal(&self, u: f64, v: f64) -> Vec3 {
        let n = self.surface.unit_normal(u, v).unwrap_or([0.0, 0.0, 1.0]);
        v3(n) * self.sign
    }

    /// The closest point of the surface to `p` within `radius` (mm).
    pub fn project(&self, p: Vec3, radius: f64, hint: Option<(f64, f64)>) -> Option<Foot> {
        let c = self
            .surface
            .closest_point(&self.index, p.to_array(), radius, hint)?;
        let point = v3(c.point);
        let normal = self.normal(c.u, c.v);
        Some(Foot {
            u: c.u,
            v: c.v,
            point,
            normal,
            height_mm: (p - point).dot(normal),
            orthogonal: c.orthogonal || c.tangential <= 1e-3,
        })
    }
}

// ---- Matching and the mirror -------------------------------------------------

/// How the compensation points are fitted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FitMethod {
    /// Bicubic least squares: among the control nets (4 × 4 up to as many
    /// coefficients as points), the one with the smallest leave-one-out
    /// error, i.e. the best predicted compensation (cross-validation: Hastie,
    /// Tibshirani & Friedman, *The Elements of Statistical Learning*, 2009,
    /// §7.10). The complexity is chosen by the data: a net that fits the
    /// probe noise predicts each left-out point badly and is not chosen.
    LeastSquares {
        /// With `Some(t)`, only nets whose residual at every compensation
        /// point is within `t` µm are considered (the probe noise then must
        /// stay within `t`: `t` ≳ 3σ). `None` (the default): every net.
        tolerance_um: Option<f64>,
    },
    /// Bicubic interpolation (A9.4) of a probe grid given by `i, j` columns.
    Interpolate,
}

/// Options of [`mirror`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MirrorOptions {
    /// Stock `D` left by the semi-finishing pass (mm).
    pub stock_mm: f64,
    /// Probe ball radius (mm) when the points are ball centres; `None` when
    /// the probe software already compensated it.
    pub probe_radius_mm: Option<f64>,
    /// Largest accepted `|measured height − D|` (mm): farther points are
    /// refused as mismatched.
    pub max_error_mm: f64,
    /// How the compensation points are fitted.
    pub fit: FitMethod,
}

impl Default for MirrorOptions {
    fn default() -> Self {
        Self {
            stock_mm: 0.2,
            probe_radius_mm: None,
            max_error_mm: 0.1,
            fit: FitMethod::LeastSquares { tolerance_um: None },
        }
    }
}

/// One probe point after matching, mirroring and fitting.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct MatchedPoint {
    /// 1-based line in the probe file.
    pub row: usize,
    /// The `id` column.
    pub id: Option<String>,
    /// Grid indices.
    pub grid: Option<(i64, i64)>,
    /// Measured surface point `P_R` (mm; probe radius removed).
    pub measured_mm: Vec3,
    /// Parameter u of the ideal point.
    pub u: f64,
    /// Parameter v of the ideal point.
    pub v: f64,
    /// Ideal point `P_P` on `S_F` (mm).
    pub nominal_mm: Vec3,
    /// Outward unit normal `V_N` at `P_P`.
    pub normal: Vec3,
    /// Semi-finishing error `(P_R − P_P)·V_N − D` (µm, positive = material left).
    pub error_um: f64,
    /// `D_M`: signed distance of `P_R` to the mirror surface (µm).
    pub mirror_distance_um: f64,
    /// Compensation point `P_C = P_R − 2·D_M·V_N` (mm).
    pub compensation_mm: Vec3,
    /// Height of `P_C` over `S_F`, `(P_C − P_P)·V_N` (µm) = −error.
    pub offset_um: f64,
    /// Fitted height minus `offset_um` (µm).
    pub fit_residual_um: f64,
    /// Finishing error predicted for this point by the fit made without it
    /// (leave-one-out, least squares only), µm.
    pub predicted_um: Option<f64>,
}

/// How the compensation points were fitted.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct FitInfo {
    /// `least-squares` or `interpolation`.
    pub method: String,
    /// Degrees (u, v).
    pub degree: (usize, usize),
    /// Control net (u, v).
    pub net: (usize, usize),
    /// Tolerance (least squares), µm.
    pub tolerance_um: Option<f64>,
    /// Largest |residual| at the compensation points (µm).
    pub max_residual_um: f64,
    /// RMS residual (µm).
    pub rms_residual_um: f64,
    /// Estimated probe noise `σ̂ = sqrt(Σ r² / (n − p))` (least squares;
    /// `p` the control net's coefficients), µm.
    pub noise_estimate_um: Option<f64>,
    /// RMS of the leave-one-out prediction errors of the chosen net (least
    /// squares), µm: the criterion the net was chosen by.
    pub leave_one_out_rms_um: Option<f64>,
    /// Parameter rectangle the field is defined on (u0, u1, v0, v1).
    pub domain: [f64; 4],
}

/// The fitted height `δ(u, v)` of the compensated surface over `S_F` (µm),
/// defined on the parameter rectangle the probe points cover; outside it the
/// value at the nearest edge is used.
#[derive(Debug, Clone, PartialEq)]
pub struct DeviationField {
    surface: BSplineSurface<1>,
}

impl DeviationField {
    /// A field from a scalar B-spline surface (µm).
    pub fn new(surface: BSplineSurface<1>) -> Self {
        Self { surface }
    }

    /// A constant offset (the tool-radius baseline) over the given rectangle.
    pub fn constant(offset_um: f64, u: [f64; 2], v: [f64; 2]) -> Self {
        Self {
            surface: BSplineSurface::constant([offset_um], u, v),
        }
    }

    /// `δ(u, v)` in µm (clamped to the field's rectangle).
    pub fn offset_um(&self, u: f64, v: f64) -> f64 {
        self.surface.point(u, v)[0]
    }

    /// Whether `(u, v)` lies inside the field's rectangle (1e-9 slack).
    pub fn contains(&self, u: f64, v: f64) -> bool {
        let [u0, u1] = self.surface.domain_u();
        let [v0, v1] = self.surface.domain_v();
        let (su, sv) = (1e-9 * (u1 - u0).max(1e-300), 1e-9 * (v1 - v0).max(1e-300));
        u >= u0 - su && u <= u1 + su && v >= v0 - sv && v <= v1 + sv
    }

    /// An upper bound of `|δ|` (µm): the largest control coefficient.
    pub fn max_abs_um(&self) -> f64 {
        self.surface
            .control_points()
            .iter()
            .map(|c| c[0].abs())
            .fold(0.0, f64::max)
    }

    /// The scalar B-spline.
    pub fn surface(&self) -> &BSplineSurface<1> {
        &self.surface
    }
}

/// Everything the mirror method computed.
#[derive(Debug, Clone)]
pub struct MirrorResult {
    /// Every probe point, in file order.
    pub points: Vec<MatchedPoint>,
    /// The fit.
    pub fit: FitInfo,
    /// The fitted height of the compensated surface.
    pub field: DeviationField,
    /// The measured errors: what an uncompensated finishing pass would leave
    /// if it repeats them.
    pub before: DeviationStats,
    /// The constant offset of the tool-radius baseline (µm, = −mean error).
    pub baseline_offset_um: f64,
    /// Errors after the tool-radius baseline (`error − mean`).
    pub baseline: DeviationStats,
    /// Fit residuals at the probe points (in-sample).
    pub mirror_fit: DeviationStats,
    /// Leave-one-out prediction of the errors after mirror compensation
    /// (least squares only).
    pub mirror_predicted: Option<DeviationStats>,
}

impl MirrorResult {
    /// Whether the leave-one-out prediction of the finishing error after
    /// mirror compensation has a larger standard deviation than the
    /// measured error itself (no compensation): the fit does not predict
    /// the error where it was not probed, and compensating would likely
    /// make the surface worse. `false` when there is no prediction
    /// (interpolation).
    pub fn compensation_predicted_worse(&self) -> bool {
        self.mirror_predicted
            .as_ref()
            .is_some_and(|p| p.std_um > self.before.std_um)
    }
}

/// Fewest probe points of a bicubic least-squares fit.
pub const MIN_POINTS: usize = 16;

/// Matches every probe point to the nominal surface and mirrors it.
pub fn match_points(
    nominal: &NominalSurface,
    probes: &[ProbePoint],
    options: &MirrorOptions,
    file: &str,
) -> Result<Vec<MatchedPoint>, MirrorError> {
    let d = options.stock_mm;
    if !(d.is_finite() && d > 0.0) {
        return Err(method_error(
            format!("the stock must be a positive length in mm; got {d}"),
            "pass --stock with the allowance the semi-finishing pass leaves, e.g. 0.2",
        ));
    }
    let r = options.probe_radius_mm.unwrap_or(0.0);
    if !(r.is_finite() && r >= 0.0) {
        return Err(method_error(
            format!("the probe radius must be a length ≥ 0 in mm; got {r}"),
            "pass the probe ball's radius, or leave it out when the points are already compensated",
        ));
    }
    let max_err = options.max_error_mm;
    if !(max_err.is_finite() && max_err > 0.0) {
        return Err(method_error(
            format!("the largest accepted error must be positive; got {max_err} mm"),
            "pass --max-error in mm, e.g. 0.1",
        ));
    }
    if let Some((rho, at)) = nominal.min_concave_radius() {
        if d + r >= 0.9 * rho {
            return Err(method_error(
                format!(
                    "the stock {d} mm{} is too large for the nominal surface's smallest concave radius of curvature, {rho:.4} mm at {}: the offset surfaces fold there and probe points cannot be matched to single points",
                    if r > 0.0 { format!(" plus the probe radius {r} mm") } else { String::new() },
                    fmt_point(at)
                ),
                "check --stock (mm), the material side (--material), and that the nominal is the finishing surface; a smaller probe ball helps",
            ));
        }
    }
    let expected = d + r;
    let mut out = Vec::with_capacity(probes.len());
    let mut hint = None;
    for pp in probes {
        let p = pp.position_mm;
        let at = |message: String, help: String| MirrorError::AtRow {
            file: file.into(),
            row: pp.row,
            column: 1,
            message,
            help,
        };
        let radius = expected + max_err;
        let foot = nominal
            .project(p, radius, hint)
            .filter(|f| f.orthogonal && (f.height_mm - expected).abs() <= max_err);
        let foot = match foot {
            Some(f) => f,
            None => return Err(far_point(nominal, p, expected, max_err, &at)),
        };
        hint = Some((foot.u, foot.v));
        let n = foot.normal;
        let measured = p - n * r;
        let height = foot.height_mm - r;
        let error = height - d;
        let d_m = height - d / 2.0;
        let compensation = measured - n * (2.0 * d_m);
        let offset = (compensation - foot.point).dot(n);
        out.push(MatchedPoint {
            row: pp.row,
            id: pp.id.clone(),
            grid: pp.grid,
            measured_mm: measured,
            u: foot.u,
            v: foot.v,
            nominal_mm: foot.point,
            normal: n,
            error_um: error * 1e3,
            mirror_distance_um: d_m * 1e3,
            compensation_mm: compensation,
            offset_um: offset * 1e3,
            fit_residual_um: 0.0,
            predicted_um: None,
        });
    }
    Ok(out)
}

/// The error for a point that does not match the surface, with a diagnosis.
fn far_point(
    nominal: &NominalSurface,
    p: Vec3,
    expected: f64,
    max_err: f64,
    at: &dyn Fn(String, String) -> MirrorError,
) -> MirrorError {
    let fits = |q: Vec3| {
        nominal
            .project(q, expected + max_err, None)
            .is_some_and(|f| f.orthogonal && (f.height_mm - expected).abs() <= max_err)
    };
    let window = format!("{:.4} ± {:.4} mm", expected, max_err);
    if fits(p * 25.4) {
        return at(
            format!("point {} does not lie near the surface, but it would if its coordinates were inches", fmt_point(p)),
            "name the columns x_in,y_in,z_in when the file is in inches".into(),
        );
    }
    if fits(p * (1.0 / 25.4)) {
        return at(
            format!("point {} does not lie near the surface, but it would if its coordinates were millimetres", fmt_point(p)),
            "name the columns x_mm,y_mm,z_mm when the file is in millimetres".into(),
        );
    }
    match nominal.project(p, 1e12, None) {
        Some(f) if !f.orthogonal => at(
            format!(
                "point {} lies beyond the edge of the nominal surface (its closest point {} is on the boundary)",
                fmt_point(p),
                fmt_point(f.point)
            ),
            "probe inside the surface, or give a nominal surface that covers the probed area".into(),
        ),
        Some(f) if (f.height_mm + expected).abs() <= max_err => at(
            format!(
                "point {} lies {:.4} mm on the material side of the nominal surface",
                fmt_point(p),
                -f.height_mm
            ),
            "the material side looks reversed: check --material".into(),
        ),
        Some(f) => at(
            format!(
                "point {} is {:.4} mm from the nominal surface along its outward normal; a probe point should be {window} from it (stock{})",
                fmt_point(p),
                f.height_mm,
                if expected > 0.0 { " + probe radius" } else { "" }
            ),
            "check the stock (--stock), the probe radius (--probe-radius), the frame of the points (the program's work coordinates), or raise --max-error if the part is really this far off".into(),
        ),
        None => at(
            format!("point {} is far from the nominal surface", fmt_point(p)),
            "check the frame and units of the points".into(),
        ),
    }
}

/// Runs the mirror method: matches, mirrors and fits.
pub fn mirror(
    nominal: &NominalSurface,
    probes: &[ProbePoint],
    options: &MirrorOptions,
    file: &str,
) -> Result<MirrorResult, MirrorError> {
    let mut points = match_points(nominal, probes, options, file)?;
    let (field, fit, loo) = match options.fit {
        FitMethod::LeastSquares { tolerance_um } => {
            fit_least_squares(nominal, &points, tolerance_um)?
        }
        FitMethod::Interpolate => fit_interpolation(&points, file)?,
    };
    for (k, pt) in points.iter_mut().enumerate() {
        pt.fit_residual_um = field.offset_um(pt.u, pt.v) - pt.offset_um;
        pt.predicted_um = loo.as_ref().and_then(|l| l[k]);
    }
    let before = deviation_stats(points.iter().map(|p| p.error_um));
    let baseline_offset_um = -before.mean_um;
    let baseline = deviation_stats(points.iter().map(|p| p.error_um + baseline_offset_um));
    let mirror_fit = deviation_stats(points.iter().map(|p| p.fit_residual_um));
    let mirror_predicted = loo.as_ref().and_then(|l| {
        l.iter()
            .all(Option::is_some)
            .then(|| deviation_stats(l.iter().flatten().copied()))
    });
    Ok(MirrorResult {
        points,
        fit,
        field,
        before,
        baseline_offset_um,
        baseline,
        mirror_fit,
        mirror_predicted,
    })
}

type Fitted = (DeviationField, FitInfo, Option<Vec<Option<f64>>>);

fn domain_of(points: &[MatchedPoint]) -> Result<[f64; 4], MirrorError> {
    let (mut u0, mut u1, mut v0, mut v1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for p in points {
        u0 = u0.min(p.u);
        u1 = u1.max(p.u);
        v0 = v0.min(p.v);
        v1 = v1.max(p.v);
    }
    if !(u1 - u0 > 1e-9 && v1 - v0 > 1e-9) {
        return Err(method_error(
            "the probe points lie along one line of the surface: they cannot determine a surface",
            "probe a two-dimensional pattern covering the surface (a grid of at least 4 × 4 points)",
        ));
    }
    Ok([u0, u1, v0, v1])
}

fn too_few(n: usize) -> MirrorError {
    method_error(
        format!("{n} probe points are too few for a bicubic fit (at least {MIN_POINTS})"),
        "probe at least a 4 × 4 grid over the surface",
    )
}

fn fit_least_squares(
    nominal: &NominalSurface,
    points: &[MatchedPoint],
    tolerance_um: Option<f64>,
) -> Result<Fitted, MirrorError> {
    if let Some(tolerance_um) = tolerance_um.filter(|t| !(t.is_finite() && *t > 0.0)) {
        return Err(method_error(
            format!("the fitting tolerance must be positive; got {tolerance_um} µm"),
            "pass --tolerance in µm, e.g. 1",
        ));
    }
    if points.len() < MIN_POINTS {
        return Err(too_few(points.len()));
    }
    let dom = domain_of(points)?;
    let uv: Vec<(f64, f64)> = points.iter().map(|p| (p.u, p.v)).collect();
    let vals: Vec<[f64; 1]> = points.iter().map(|p| [p.offset_um]).collect();
    // Spans in proportion to the probed area's extent in space along u and
    // along v (measured on the nominal's mid iso-lines), so that the spans
    // are about square.
    let length = |along_u: bool| {
        let mut l = 0.0;
        let mut prev: Option<Vec3> = None;
        for k in 0..=32 {
            let t = k as f64 / 32.0;
            let p = if along_u {
                nominal.point(dom[0] + t * (dom[1] - dom[0]), 0.5 * (dom[2] + dom[3]))
            } else {
                nominal.point(0.5 * (dom[0] + dom[1]), dom[2] + t * (dom[3] - dom[2]))
            };
            if let Some(q) = prev {
                l += (p - q).norm();
            }
            prev = Some(p);
        }
        l
    };
    let (lu, lv) = (length(true), length(false));
    let ratio = if lu > 0.0 && lv > 0.0 {
        (lv / lu).clamp(0.05, 20.0)
    } else {
        1.0
    };
    // Every net from 4 × 4 up to as many coefficients as points; among those
    // whose residual meets the tolerance, the one with the smallest
    // leave-one-out error (the best predicted compensation) is taken.
    let mut best_residual: Option<(f64, (usize, usize))> = None;
    let mut chosen: Option<(f64, LeastSquaresFit<1>, (usize, usize))> = None;
    let mut last = (0, 0);
    let mut singular = None;
    for s in [1usize, 2, 3, 4, 5, 6, 8, 10, 12, 16, 20, 24, 32] {
        let (su, sv) = if ratio <= 1.0 {
            (s, ((s as f64 * ratio).round() as usize).max(1))
        } else {
            (((s as f64 / ratio).round() as usize).max(1), s)
        };
        if (su, sv) == last {
            continue;
        }
        if (su + 3) * (sv + 3) > points.len() {
            break;
        }
        last = (su, sv);
        let fit: Result<LeastSquaresFit<1>, BSplineError> = bspline::fit_least_squares(
            &uv,
            &vals,
            3,
            3,
            bspline::uniform_knots(dom[0], dom[1], su, 3),
            bspline::uniform_knots(dom[2], dom[3], sv, 3),
            1e-6,
        );
        let fit = match fit {
            Ok(f) => f,
            Err(e) => {
                singular = Some(e);
                break;
            }
        };
        let max = fit.residuals.iter().map(|r| r[0].abs()).fold(0.0, f64::max);
        if best_residual.is_none_or(|b| max < b.0) {
            best_residual = Some((max, (su + 3, sv + 3)));
        }
        if tolerance_um.is_some_and(|t| max > t) {
            continue;
        }
        let loo: Option<f64> = fit
            .leave_one_out
            .iter()
            .map(|l| l.map(|x| x[0] * x[0]))
            .sum::<Option<f64>>()
            .map(|s| (s / points.len() as f64).sqrt());
        let score = loo.unwrap_or(f64::INFINITY);
        if chosen.as_ref().is_none_or(|c| score < c.0) {
            chosen = Some((score, fit, (su + 3, sv + 3)));
        }
    }
    if let Some((score, fit, net)) = chosen {
        let max = fit.residuals.iter().map(|r| r[0].abs()).fold(0.0, f64::max);
        let rss = fit.residuals.iter().map(|r| r[0] * r[0]).sum::<f64>();
        let rms = (rss / fit.residuals.len() as f64).sqrt();
        let dof = fit.residuals.len().saturating_sub(net.0 * net.1);
        let info = FitInfo {
            method: "least-squares".into(),
            degree: (3, 3),
            net,
            tolerance_um,
            max_residual_um: max,
            rms_residual_um: rms,
            noise_estimate_um: (dof > 0).then(|| (rss / dof as f64).sqrt()),
            leave_one_out_rms_um: score.is_finite().then_some(score),
            domain: dom,
        };
        let loo = fit.leave_one_out.iter().map(|l| l.map(|x| x[0])).collect();
        return Ok((DeviationField::new(fit.surface), info, Some(loo)));
    }
    if let (None, Some(e)) = (best_residual, singular) {
        return Err(method_error(
            format!("the probe points do not determine a surface: {e}"),
            "probe a two-dimensional pattern covering the surface (a grid of at least 4 × 4 points)",
        ));
    }
    let (max, net) = best_residual.unwrap_or((f64::NAN, (4, 4)));
    let tol = tolerance_um.map_or("the tolerance".to_string(), |t| format!("±{t} µm"));
    Err(method_error(
        format!(
            "the compensation points cannot be fitted within {tol} with fewer coefficients than points (best: {max:.3} µm with a {} × {} control net, {} points)",
            net.0, net.1, points.len()
        ),
        "leave --tolerance out (the fit is then chosen by leave-one-out cross-validation), or loosen it: every residual includes the probe noise, so it must exceed about 3 σ of the noise",
    ))
}

fn fit_interpolation(points: &[MatchedPoint], file: &str) -> Result<Fitted, MirrorError> {
    let help = "--fit interpolate needs a complete probe grid: i,j columns with one point per node";
    if points.iter().any(|p| p.grid.is_none()) {
        return Err(MirrorError::InFile {
            file: file.into(),
            message: "the probe points have no i,j grid indices".into(),
            help: format!("{help}; or use --fit least-squares for scattered points"),
        });
    }
    let idx: Vec<(i64, i64)> = points.iter().map(|p| p.grid.unwrap_or((0, 0))).collect();
    let i0 = idx.iter().map(|x| x.0).min().unwrap_or(0);
    let j0 = idx.iter().map(|x| x.1).min().unwrap_or(0);
    let ni = (idx.iter().map(|x| x.0).max().unwrap_or(0) - i0 + 1) as usize;
    let nj = (idx.iter().map(|x| x.1).max().unwrap_or(0) - j0 + 1) as usize;
    if ni.saturating_mul(nj) > 4 * points.len() + 16 {
        return Err(MirrorError::InFile {
            file: file.into(),
            message: format!(
                "{} probe points do not fill the {ni} × {nj} grid their i,j indices span",
                points.len()
            ),
            help: help.into(),
        });
    }
    let mut at: Vec<Option<usize>> = vec![None; ni * nj];
    for (k, (i, j)) in idx.iter().enumerate() {
        let c = (i - i0) as usize * nj + (j - j0) as usize;
        if at[c].is_some() {
            return Err(MirrorError::AtRow {
                file: file.into(),
                row: points[k].row,
                column: 1,
                message: format!("a second probe point for grid node ({i}, {j})"),
                help: help.into(),
            });
        }
        at[c] = Some(k);
    }
    if ni < 4 || nj < 4 || at.iter().any(Option::is_none) {
        return Err(MirrorError::InFile {
            file: file.into(),
            message: format!(
                "the i,j indices do not form a complete grid of at least 4 × 4 ({} points, {ni} × {nj} nodes)",
                points.len()
            ),
            help: help.into(),
        });
    }
    let node = |i: usize, j: usize| &points[at[i * nj + j].unwrap_or(0)];
    // Does i run along u (or along v)? Pick the assignment whose rows are
    // closest to iso-parameter lines.
    let spread = |f: &dyn Fn(usize, usize) -> f64, a: usize, b: usize| {
        let mut worst: f64 = 0.0;
        for x in 0..a {
            let m = (0..b).map(|y| f(x, y)).sum::<f64>() / b as f64;
            for y in 0..b {
                worst = worst.max((f(x, y) - m).abs());
            }
        }
        worst
    };
    let i_is_u = spread(&|i, j| node(i, j).u, ni, nj) <= spread(&|j, i| node(i, j).u, nj, ni);
    let (nu, nv) = if i_is_u { (ni, nj) } else { (nj, ni) };
    let pt = |a: usize, b: usize| if i_is_u { node(a, b) } else { node(b, a) };
    let mean_u: Vec<f64> = (0..nu)
        .map(|a| (0..nv).map(|b| pt(a, b).u).sum::<f64>() / nv as f64)
        .collect();
    let mean_v: Vec<f64> = (0..nv)
        .map(|b| (0..nu).map(|a| pt(a, b).v).sum::<f64>() / nu as f64)
        .collect();
    let ord_u: Vec<usize> = sorted_order(&mean_u);
    let ord_v: Vec<usize> = sorted_order(&mean_v);
    let us: Vec<f64> = ord_u.iter().map(|a| mean_u[*a]).collect();
    let vs: Vec<f64> = ord_v.iter().map(|b| mean_v[*b]).collect();
    let gap = |t: &[f64]| {
        t.windows(2)
            .map(|w| w[1] - w[0])
            .fold(f64::INFINITY, f64::min)
    };
    let (gu, gv) = (gap(&us), gap(&vs));
    let dev_u = spread(&|a, b| pt(a, b).u, nu, nv);
    let dev_v = spread(&|b, a| pt(a, b).v, nv, nu);
    if !(gu > 0.0 && gv > 0.0) || dev_u > 0.25 * gu || dev_v > 0.25 * gv {
        return Err(MirrorError::InFile {
            file: file.into(),
            message: "the probe grid does not follow the surface's parameter lines closely enough to interpolate (rows cross or wander by more than a quarter of their spacing)".into(),
            help: "use --fit least-squares, which takes every point where it lies".into(),
        });
    }
    let mut vals = Vec::with_capacity(nu * nv);
    for a in &ord_u {
        for b in &ord_v {
            vals.push([pt(*a, *b).offset_um]);
        }
    }
    let surface = bspline::interpolate(
        &vals,
        nu,
        nv,
        3,
        3,
        &Parameterization::Given(us.clone(), vs.clone()),
    )
    .map_err(|e| {
        method_error(
            format!("interpolation failed: {e}"),
            "use --fit least-squares",
        )
    })?;
    let field = DeviationField::new(surface);
    let res: Vec<f64> = points
        .iter()
        .map(|p| field.offset_um(p.u, p.v) - p.offset_um)
        .collect();
    let max = res.iter().map(|r| r.abs()).fold(0.0, f64::max);
    let rms = (res.iter().map(|r| r * r).sum::<f64>() / res.len() as f64).sqrt();
    let info = FitInfo {
        method: "interpolation".into(),
        degree: (3, 3),
        net: (nu, nv),
        tolerance_um: None,
        max_residual_um: max,
        rms_residual_um: rms,
        noise_estimate_um: None,
        leave_one_out_rms_um: None,
        domain: [us[0], us[nu - 1], vs[0], vs[nv - 1]],
    };
    Ok((field, info, None))
}

fn sorted_order(v: &[f64]) -> Vec<usize> {
    let mut o: Vec<usize> = (0..v.len()).collect();
    o.sort_by(|a, b| v[*a].total_cmp(&v[*b]));
    o
}

// ---- The compensated surface ---------------------------------------------------

/// `S_C = S_F + δ·n`: the nominal surface moved by a deviation field.
#[derive(Debug, Clone, Copy)]
pub struct CompensatedSurface<'a> {
    /// `S_F`.
    pub nominal: &'a NominalSurface,
    /// `δ` (µm).
    pub field: &'a DeviationField,
}

/// One node of a surface grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridNode {
    /// Index along u.
    pub i: usize,
    /// Index along v.
    pub j: usize,
    /// Point (mm).
    pub point_mm: Vec3,
    /// Height over `S_F` along the outward normal (µm).
    pub offset_um: f64,
}

impl CompensatedSurface<'_> {
    /// `S_C(u, v)` (mm).
    pub fn point(&self, u: f64, v: f64) -> Vec3 {
        self.nominal.point(u, v) + self.nominal.normal(u, v) * (self.field.offset_um(u, v) * 1e-3)
    }

    /// Grid nodes: at the nominal grid's nodes when it came from a grid,
    /// otherwise `n × n` nodes equally spaced in the parameters.
    pub fn grid(&self, n: usize) -> Vec<GridNode> {
        let n = n.max(2);
        let even = |[a, b]: [f64; 2]| -> Vec<f64> {
            (0..n)
                .map(|k| a + (b - a) * k as f64 / (n - 1) as f64)
                .collect()
        };
        let (us, vs) = match self.nominal.grid_params() {
            Some((u, v)) => (u.clone(), v.clone()),
            None => (
                even(self.nominal.surface().domain_u()),
                even(self.nominal.surface().domain_v()),
            ),
        };
        let mut out = Vec::with_capacity(us.len() * vs.len());
        for (i, u) in us.iter().enumerate() {
            for (j, v) in vs.iter().enumerate() {
                out.push(GridNode {
                    i,
                    j,
                    point_mm: self.point(*u, *v),
                    offset_um: self.field.offset_um(*u, *v),
                });
            }
        }
        out
    }

    /// A B-spline surface approximating `S_C` within `tolerance_mm` in
    /// parameter space (so within it in space too): A9.4 through `S_C`
    /// sampled at `k` points per knot span of `S_F`, `k` doubled until the
    /// error at every cell centre is within the tolerance (or `k = 32`, or 250 000 samples).
    /// Returns the surface and the largest error found (mm).
    pub fn to_bspline(&self, tolerance_mm: f64) -> Result<(BSplineSurface<3>, f64), MirrorError> {
        let s = self.nominal.surface();
        let mut result = None;
        for k in [1usize, 2, 4, 8, 16, 32] {
            let mut us = refine_breaks(&s.breaks_u(), k);
            let mut vs = refine_breaks(&s.breaks_v(), k);
            if us.len() < 4 {
                us = refine_breaks(&s.breaks_u(), 3);
            }
            if vs.len() < 4 {
                vs = refine_breaks(&s.breaks_v(), 3);
            }
            if result.is_some() && us.len() * vs.len() > 250_000 {
                // Finer sampling would not fit in memory sensibly: keep the
                // last surface (its error is reported).
                break;
            }
            let mut pts = Vec::with_capacity(us.len() * vs.len());
            for u in &us {
                for v in &vs {
                    pts.push(self.point(*u, *v).to_array());
                }
            }
            let surf = bspline::interpolate(
                &pts,
                us.len(),
                vs.len(),
                3,
                3,
                &Parameterization::Given(us.clone(), vs.clone()),
            )
            .map_err(|e| {
                method_error(
                    format!("cannot build the compensated B-spline: {e}"),
                    "please report this with the input files",
                )
            })?;
            let mid =
                |t: &[f64]| -> Vec<f64> { t.windows(2).map(|w| 0.5 * (w[0] + w[1])).collect() };
            let mut worst: f64 = 0.0;
            for u in mid(&us).iter().chain(&us) {
                for v in mid(&vs).iter().chain(&vs) {
                    let e = (v3(surf.point(*u, *v)) - self.point(*u, *v)).norm();
                    worst = worst.max(e);
                }
            }
            let done = worst <= tolerance_mm;
            result = Some((surf, worst));
            if done {
                break;
            }
        }
        result.ok_or_else(|| method_error("no compensated surface", "please report this"))
    }
}

// ---- The finishing program --------------------------------------------------------

/// Which point of the ball-end mill the program's coordinates give.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ClPoint {
    /// The tool tip (most CAM posts): the ball centre is `r` above it (+Z).
    Tip,
    /// The ball centre.
    Centre,
}

/// A ball-end mill.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BallTool {
    /// Ball radius (mm).
    pub radius_mm: f64,
    /// Which point the program's coordinates give.
    pub cl: ClPoint,
}

/// A CL point that touches the nominal surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// Parameter u of the contact point.
    pub u: f64,
    /// Parameter v of the contact point.
    pub v: f64,
    /// Contact point on `S_F` (mm).
    pub point: Vec3,
    /// Outward normal there.
    pub normal: Vec3,
    /// How far the ball stands off `S_F` as commanded (mm; 0 for an exact CL point).
    pub standoff_mm: f64,
    /// `δ` at the contact point (µm).
    pub offset_um: f64,
    /// Whether the contact point lies in the probed rectangle.
    pub inside_field: bool,
}

/// The finishing-pass displacement `δ·n` at each CL point, as an
/// [`ErrorModel`] so that [`compensate_program`] writes it: with the direct
/// method the command is `q = t − e(t)`, and `e(t) = −δ·n` at the contact
/// point of `t` (zero when `t` does not touch the surface).
pub struct SurfaceModel<'a> {
    nominal: &'a NominalSurface,
    field: &'a DeviationField,
    tool: BallTool,
    frame_offset_mm: Vec3,
    contact_tolerance_mm: f64,
    hint: Mutex<Option<(f64, f64)>>,
}

impl<'a> SurfaceModel<'a> {
    /// A model for a program whose program frame is the axis frame minus
    /// `frame_offset_mm` (see [`program_frame_offset`]). A CL point is in
    /// contact when its ball is within `contact_tolerance_mm` of `S_F`.
    pub fn new(
        nominal: &'a NominalSurface,
        field: &'a DeviationField,
        tool: BallTool,
        frame_offset_mm: Vec3,
        contact_tolerance_mm: f64,
    ) -> Result<Self, MirrorError> {
        let r = tool.radius_mm;
        if !(r.is_finite() && r > 0.0) {
            return Err(method_error(
                format!("the tool radius must be positive; got {r} mm"),
                "pass --tool-radius with the ball-end mill's radius in mm (half its diameter)",
            ));
        }
        if !(contact_tolerance_mm.is_finite() && contact_tolerance_mm > 0.0) {
            return Err(method_error(
                format!("the contact tolerance must be positive; got {contact_tolerance_mm} mm"),
                "pass --contact-tolerance in mm, e.g. 0.02",
            ));
        }
        if let Some((rho, at)) = nominal.min_concave_radius() {
            if r >= rho {
                return Err(method_error(
                    format!(
                        "the ball radius {r} mm exceeds the nominal surface's smallest concave radius of curvature, {rho:.4} mm at {}: the ball cannot touch the surface there, so CL points have no single contact point",
                        fmt_point(at)
                    ),
                    "check --tool-radius (a radius, not a diameter) and --material",
                ));
            }
        }
        Ok(Self {
            nominal,
            field,
            tool,
            frame_offset_mm,
            contact_tolerance_mm,
            hint: Mutex::new(None),
        })
    }

    /// The contact of the CL point `p` (program frame, mm), if it touches `S_F`.
    pub fn contact(&self, p: Vec3) -> Option<Contact> {
        let r = self.tool.radius_mm;
        let centre = match self.tool.cl {
            ClPoint::Tip => p + Vec3::new(0.0, 0.0, r),
            ClPoint::Centre => p,
        };
        let mut hint = self.hint.lock().unwrap_or_else(|e| e.into_inner());
        let foot = self
            .nominal
            .project(centre, r + self.contact_tolerance_mm, *hint)?;
        *hint = Some((foot.u, foot.v));
        let standoff = foot.height_mm - r;
        if !foot.orthogonal || standoff.abs() > self.contact_tolerance_mm {
            return None;
        }
        Some(Contact {
            u: foot.u,
            v: foot.v,
            point: foot.point,
            normal: foot.normal,
            standoff_mm: standoff,
            offset_um: self.field.offset_um(foot.u, foot.v),
            inside_field: self.field.contains(foot.u, foot.v),
        })
    }

    /// The displacement of the CL point `p` (program frame, mm).
    pub fn displacement_mm(&self, p: Vec3) -> Vec3 {
        self.contact(p)
            .map_or(Vec3::ZERO, |c| c.normal * (c.offset_um * 1e-3))
    }

    /// Program frame of axis-frame `q`.
    pub fn program_point(&self, q: Vec3) -> Vec3 {
        q - self.frame_offset_mm
    }
}

impl ErrorModel for SurfaceModel<'_> {
    fn deviation_um(&self, q_mm: Vec3, _s: Directions, _c: Components) -> Result<Vec3, ModelError> {
        Ok(self.displacement_mm(self.program_point(q_mm)) * -1e3)
    }

    fn range_mm(&self) -> [[f64; 2]; 3] {
        [[-1e9, 1e9]; 3]
    }
}

/// The frame offset (axis − program frame, mm) of a program's feed moves,
/// which must not change: the surface is given in one program frame.
pub fn program_frame_offset<R: BufRead>(
    walker: &mut Walker<R>,
    file: &str,
) -> Result<Vec3, MirrorError> {
    let mut first: Option<(Vec3, u64)> = None;
    while let Some(ev) = walker.next_line()? {
        if ev.after_end {
            continue;
        }
        let cuts = ev
            .motions
            .iter()
            .any(|m| m.source == MotionSource::Program && !matches!(m.kind, MotionKind::Rapid));
        if !cuts {
            continue;
        }
        let o = ev.interp.frame_offset_mm();
        match first {
            None => first = Some((o, ev.number)),
            Some((f, line)) if (f - o).norm() > 1e-9 => {
                return Err(MirrorError::AtRow {
                    file: file.into(),
                    row: ev.number as usize,
                    column: 1,
                    message: format!(
                        "the program frame changes here (work offset, tool length or G92 differ from line {line}'s)"
                    ),
                    help: "the surface and the points are in one program frame: compensate each setup's part of the program separately".into(),
                });
            }
            _ => {}
        }
    }
    Ok(first.map_or(Vec3::ZERO, |f| f.0))
}

/// Options of [`compensate_finishing`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FinishingOptions {
    /// Split feed moves into pieces of at most this length (mm); `None`: do
    /// not split (arcs are still linearised).
    pub segment_length_mm: Option<f64>,
    /// Chord tolerance for linearising arcs (mm).
    pub chord_tolerance_mm: f64,
    /// Written decimals (`None`: 4 in mm, 5 in inch).
    pub decimals: Option<u8>,
    /// Tag inserted lines with `(volcomp Ln)`.
    pub trace_comments: bool,
}

impl Default for FinishingOptions {
    fn default() -> Self {
        Self {
            segment_length_mm: Some(2.0),
            chord_tolerance_mm: 1e-3,
            decimals: None,
            trace_comments: true,
        }
    }
}

/// What [`compensate_finishing`] did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FinishingSummary {
    /// Lines and points of the rewrite.
    pub program: CompensateSummary,
    /// Feed-move points (CL points and split points).
    pub feed_points: u64,
    /// Of those, the ones touching the nominal surface (moved).
    pub in_contact: u64,
    /// Of those, the ones outside the probed rectangle (moved by the edge value).
    pub outside_field: u64,
    /// Largest `δ` applied (µm).
    pub max_offset_um: f64,
    /// Smallest `δ` applied (µm).
    pub min_offset_um: f64,
}

/// Rewrites a ball-end finishing program so that every CL point touching the
/// nominal surface moves by `δ·n` at its contact point; every other byte is
/// kept (the rewrite is [`compensate_program`]'s, with the direct method and
/// no backlash take-up). Fails when no CL point touches the surface; on any
/// failure what was written to `out` is incomplete (write to a temporary
/// file and keep it only on success).
pub fn compensate_finishing<R: BufRead>(
    walker: &mut Walker<R>,
    file: &str,
    style: &ProgramStyle,
    model: &SurfaceModel<'_>,
    options: &FinishingOptions,
    out: &mut dyn Write,
) -> Result<FinishingSummary, MirrorError> {
    let segmentation = match options.segment_length_mm {
        Some(l) if l.is_finite() && l > 0.0 => Segmentation::MaxLength(l),
        Some(l) => {
            return Err(method_error(
                format!("the segment length must be positive; got {l} mm"),
                "pass --segment-length in mm, or --no-split",
            ))
        }
        None => Segmentation::Off,
    };
    let copts = CompensateOptions {
        method: Method::Direct,
        segmentation,
        chord_tolerance_mm: options.chord_tolerance_mm,
        decimals: options.decimals,
        // |δ| never exceeds the largest control coefficient (convex hull).
        max_correction_mm: model.field.max_abs_um() * 1e-3 + 1e-3,
        directions: DirectionPolicy::Commanded,
        take_up: false,
        trace_comments: options.trace_comments,
        // The direct step is exact for a displacement field (no iteration).
        max_residual_um: None,
    };
    let mut s = FinishingSummary {
        min_offset_um: f64::INFINITY,
        max_offset_um: f64::NEG_INFINITY,
        ..FinishingSummary::default()
    };
    let program = compensate_program(walker, file, model, style, &copts, out, |rec| {
        if rec.rapid {
            return;
        }
        s.feed_points += 1;
        if let Some(c) = model.contact(model.program_point(rec.target_mm)) {
            s.in_contact += 1;
            s.outside_field += u64::from(!c.inside_field);
            s.max_offset_um = s.max_offset_um.max(c.offset_um);
            s.min_offset_um = s.min_offset_um.min(c.offset_um);
        }
    })?;
    if s.in_contact == 0 {
        return Err(MirrorError::InFile {
            file: file.into(),
            message: format!(
                "none of the program's {} feed points touches the nominal surface (ball radius {} mm, CL point at the {})",
                s.feed_points,
                model.tool.radius_mm,
                match model.tool.cl {
                    ClPoint::Tip => "tip",
                    ClPoint::Centre => "ball centre",
                }
            ),
            help: "check --tool-radius and --cl-point, and that the program and the surface share a frame (work offset, G43 tool length) and units".into(),
        });
    }
    s.program = program;
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plane_surface() -> BSplineSurface<3> {
        let pts: Vec<[f64; 3]> = (0..16)
            .map(|k| {
                let (i, j) = (k / 4, k % 4);
                [i as f64 * 10.0, j as f64 * 10.0, 0.0]
            })
            .collect();
        bspline::interpolate(&pts, 4, 4, 3, 3, &Parameterization::Uniform).unwrap()
    }

    #[test]
    fn stats_follow_their_definitions() {
        let s = deviation_stats([1.0, -3.0, 2.0, 4.0]);
        assert_eq!(s.count, 4);
        assert!((s.mean_um - 1.0).abs() < 1e-15);
        let var = (0.0 + 16.0 + 1.0 + 9.0) / 3.0;
        assert!((s.std_um - f64::sqrt(var)).abs() < 1e-12);
        assert_eq!(
            (s.min_um, s.max_um, s.profile_um, s.range_um),
            (-3.0, 4.0, 8.0, 7.0)
        );
        assert_eq!(deviation_stats([]), DeviationStats::default());
    }

    #[test]
    fn the_mirror_reflects_the_measured_point_in_the_halfway_surface() {
        // A flat nominal at z = 0, material below, stock 0.2 mm. A point
        // measured at 0.205 mm (5 µm left over) has D_M = 105 µm and its
        // compensation point lies 5 µm below the nominal.
        let nominal = NominalSurface::new(plane_surface(), MaterialSide::Below, "s").unwrap();
        let probes = vec![ProbePoint {
            row: 2,
            id: None,
            grid: None,
            position_mm: Vec3::new(12.0, 17.0, 0.205),
        }];
        let opts = MirrorOptions {
            stock_mm: 0.2,
            ..MirrorOptions::default()
        };
        let m = match_points(&nominal, &probes, &opts, "p.csv").unwrap();
        let p = &m[0];
        assert!((p.error_um - 5.0).abs() < 1e-9);
        assert!((p.mirror_distance_um - 105.0).abs() < 1e-9);
        assert!((p.offset_um + 5.0).abs() < 1e-9);
        assert!((p.compensation_mm - Vec3::new(12.0, 17.0, -0.005)).norm() < 1e-12);
        assert!((p.nominal_mm - Vec3::new(12.0, 17.0, 0.0)).norm() < 1e-12);
        // With a probe radius the centre is compensated along the normal.
        let probes = vec![ProbePoint {
            position_mm: Vec3::new(12.0, 17.0, 1.0 + 0.195),
            ..probes[0].clone()
        }];
        let opts = MirrorOptions {
            probe_radius_mm: Some(1.0),
            ..opts
        };
        let m = match_points(&nominal, &probes, &opts, "p.csv").unwrap();
        assert!((m[0].error_um + 5.0).abs() < 1e-9 && (m[0].offset_um - 5.0).abs() < 1e-9);
    }

    #[test]
    fn far_points_are_refused_with_a_diagnosis() {
        let nominal = NominalSurface::new(plane_surface(), MaterialSide::Below, "s").unwrap();
        let opts = MirrorOptions::default();
        let one = |p: Vec3| {
            let probes = vec![ProbePoint {
                row: 7,
                id: None,
                grid: None,
                position_mm: p,
            }];
            match_points(&nominal, &probes, &opts, "p.csv")
                .unwrap_err()
                .to_string()
        };
        let e = one(Vec3::new(10.0, 10.0, 0.5));
        assert!(
            e.starts_with("p.csv:7:1: point") && e.contains("0.5000 mm from the nominal"),
            "{e}"
        );
        let e = one(Vec3::new(10.0, 10.0, -0.2));
        assert!(e.contains("material side"), "{e}");
        let e = one(Vec3::new(45.0, 10.0, 0.2));
        assert!(e.contains("beyond the edge"), "{e}");
        let e = one(Vec3::new(10.0 / 25.4, 10.0 / 25.4, 0.2 / 25.4));
        assert!(e.contains("inches"), "{e}");
    }

    #[test]
    fn csv_errors_name_row_and_column() {
        let e = read_probe_points("# c\nx_mm,y_mm,z_mm\n1,2,3\n1,NaN,3\n", "p.csv").unwrap_err();
        assert!(
            e.to_string()
                .starts_with("p.csv:4:2: column 2 `y_mm`: `NaN` is not a finite number"),
            "{e}"
        );
        let e = read_probe_points("x,y,z\n1,2,3\n", "p.csv").unwrap_err();
        assert!(e.to_string().contains("does not say its unit"), "{e}");
        let e = read_probe_points("x_mm,y_in,z_mm\n1,2,3\n", "p.csv").unwrap_err();
        assert!(e.to_string().contains("mix"), "{e}");
        let e = read_probe_points("x_mm,y_mm,z_mm\n1,2\n", "p.csv").unwrap_err();
        assert!(e.to_string().starts_with("p.csv:2:3:"), "{e}");
        let p = read_probe_points("id,x_in,y_in,z_in\nA,1,2,0.5\n", "p.csv").unwrap();
        assert_eq!(p[0].position_mm, Vec3::new(25.4, 50.8, 12.7));
        assert_eq!(p[0].id.as_deref(), Some("A"));
    }

    #[test]
    fn grid_csv_reads_indexed_grids_and_height_fields() {
        let mut t = String::from("x_mm,y_mm,z_mm\n");
        for y in [0.0, 5.0, 10.0] {
            for x in [0.0, 10.0, 20.0, 30.0] {
                t.push_str(&format!("{x},{y},{}\n", x * 0.1));
            }
        }
        let g = read_grid_csv(&t, "g.csv").unwrap();
        assert_eq!((g.count_u, g.count_v), (4, 3));
        assert_eq!(g.points[2 * 3 + 1], [20.0, 5.0, 2.0]);
        let e = read_grid_csv(
            "i,j,x_mm,y_mm,z_mm\n0,0,0,0,0\n0,1,0,1,0\n1,0,1,0,0\n",
            "g.csv",
        )
        .unwrap_err();
        assert!(e.to_string().contains("node (1, 1) is missing"), "{e}");
    }

    #[test]
    fn bspline_files_round_trip_and_errors_are_located() {
        let s = plane_surface();
        let text = write_bspline_toml(&s, "test");
        let back = read_bspline_toml(&text, "s.toml").unwrap();
        assert_eq!(back, s);
        let inch = text.replace("units = \"mm\"", "units = \"inch\"");
        let back = read_bspline_toml(&inch, "s.toml").unwrap();
        assert!((back.control_point(3, 3)[0] - 30.0 * 25.4).abs() < 1e-9);
        let no_units = text.replace("units = \"mm\"\n", "");
        assert!(read_bspline_toml(&no_units, "s.toml")
            .unwrap_err()
            .to_string()
            .contains("unit"));
        let nan = text.replacen("[0.0, 0.0, 0.0]", "[0.0, nan, 0.0]", 1);
        let e = read_bspline_toml(&nan, "s.toml").unwrap_err().to_string();
        assert!(
            e.contains("control point [0][0]") && e.starts_with("s.toml:"),
            "{e}"
        );
        let line = nan.lines().position(|l| l.contains("nan")).unwrap() + 1;
        assert!(e.starts_with(&format!("s.toml:{line}:")), "{e}");
        let bad_knots = text.replacen("knots_u = [0.0,", "knots_u = [0.5,", 1);
        let e = read_bspline_toml(&bad_knots, "s.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("knots_u"), "{e}");
    }

    #[test]
    fn a_stock_beyond_the_concave_radius_is_refused() {
        // A trough z = x²/(2·5): radius 5 mm at the bottom, material below.
        let mut pts = Vec::new();
        for i in 0..9 {
            let x = -4.0 + i as f64;
            for j in 0..4 {
                pts.push([x, 3.0 * j as f64, x * x / 10.0]);
            }
        }
        let s = bspline::interpolate(&pts, 9, 4, 3, 3, &Parameterization::Uniform).unwrap();
        let nominal = NominalSurface::new(s, MaterialSide::Below, "s").unwrap();
        let (rho, _) = nominal.min_concave_radius().unwrap();
        assert!((rho - 5.0).abs() < 1e-6, "{rho}");
        let probes = vec![ProbePoint {
            row: 2,
            id: None,
            grid: None,
            position_mm: Vec3::new(0.0, 4.0, 5.0),
        }];
        let opts = MirrorOptions {
            stock_mm: 5.0,
            ..MirrorOptions::default()
        };
        let e = match_points(&nominal, &probes, &opts, "p")
            .unwrap_err()
            .to_string();
        assert!(e.contains("concave radius"), "{e}");
        let field = DeviationField::constant(0.0, [0.0, 1.0], [0.0, 1.0]);
        let tool = BallTool {
            radius_mm: 6.0,
            cl: ClPoint::Tip,
        };
        let e = SurfaceModel::new(&nominal, &field, tool, Vec3::ZERO, 0.02)
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("ball radius"), "{e}");
    }

    #[test]
    fn too_few_points_are_refused() {
        let nominal = NominalSurface::new(plane_surface(), MaterialSide::Below, "s").unwrap();
        let probes: Vec<ProbePoint> = (0..9)
            .map(|k| ProbePoint {
                row: k + 2,
                id: None,
                grid: None,
                position_mm: Vec3::new(
                    5.0 + 10.0 * (k / 3) as f64,
                    5.0 + 10.0 * (k % 3) as f64,
                    0.2,
                ),
            })
            .collect();
        let e = mirror(&nominal, &probes, &MirrorOptions::default(), "p").unwrap_err();
        assert!(e.to_string().contains("too few"), "{e}");
    }
}
