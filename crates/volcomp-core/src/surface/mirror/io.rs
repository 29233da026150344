//! The mirror method's input files: probe points (CSV), a nominal surface
//! as a grid of points (CSV) or as a B-spline surface (TOML), and the writer
//! of that TOML format. Every CSV goes through [`crate::io::table`].

use super::nominal::{MaterialSide, NominalSurface};
use super::MirrorError;
use crate::error::MapFileError;
use crate::io::table::{CsvTable, Header, Record};
use crate::surface::bspline::{self, BSplineSurface, Parameterization};
use std::path::Path;
use volcomp_gcode::{Units, Vec3};

/// A probe-point or grid table, read by [`crate::io::table`]; columns
/// other than those looked up are ignored.
struct Csv<'a> {
    table: CsvTable<'a>,
}

fn read_csv<'a>(text: &'a str, file: &str) -> Result<Csv<'a>, MirrorError> {
    let table = CsvTable::parse(
        text,
        file,
        &Header::keep_all("x_mm,y_mm,z_mm (or x_in,y_in,z_in)"),
    )?;
    Ok(Csv { table })
}

impl Csv<'_> {
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
            return Err(MirrorError::File(MapFileError {
                file: file.into(),
                row: csv.table.header_line,
                column: 1,
                message: "only one of the grid index columns i, j is present".into(),
                help: "give both i and j, or neither".into(),
                source_line: String::new(),
                caret_byte: 0,
            }))
        }
    };
    let mut out = Vec::with_capacity(csv.table.records()?.len());
    for row in csv.table.records()? {
        out.push(ProbePoint {
            row: row.line,
            id: id.map(|c| csv.table.text(row, c).to_string()),
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
            return Err(MirrorError::File(MapFileError {
                file: file.into(),
                row: *line,
                column: 1,
                message: format!("a second point for grid node ({i}, {j})"),
                help: help.into(),
                source_line: String::new(),
                caret_byte: 0,
            }));
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
        MirrorError::File(MapFileError {
            file: file.into(),
            row,
            column,
            message,
            help: help.into(),
            source_line: String::new(),
            caret_byte: 0,
        })
    };
    let raw: RawSurface = toml::from_str(text).map_err(|e| {
        let (row, column) = e.span().map_or((1, 1), |s| line_col(text, s.start));
        MirrorError::File(MapFileError {
            file: file.into(),
            row,
            column,
            message: e.message().trim().to_string(),
            help: "see docs/mirror.md for the B-spline surface format (units, degree_u, degree_v, knots_u, knots_v, control_points)".into(),
            source_line: String::new(),
            caret_byte: 0,
        })
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

/// The file formats of a nominal surface.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NominalFormat {
    /// A B-spline surface, TOML ([`read_bspline_toml`]).
    BSplineToml,
    /// A grid of points, CSV ([`read_grid_csv`]), interpolated.
    GridCsv,
}

impl NominalFormat {
    /// The format a file name's extension says (`.toml`, `.csv`, any case).
    pub fn of_path(path: &Path) -> Result<Self, MirrorError> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        match ext.as_str() {
            "toml" => Ok(Self::BSplineToml),
            "csv" => Ok(Self::GridCsv),
            _ => Err(MirrorError::NominalFormat {
                file: path.display().to_string(),
            }),
        }
    }
}

/// Reads a nominal surface from the text of `file` in `format`: a B-spline
/// surface as it is, a grid interpolated with the parameters `params`;
/// `side` is where the material is.
pub fn read_nominal(
    text: &str,
    file: &str,
    format: NominalFormat,
    side: MaterialSide,
    params: &Parameterization,
) -> Result<NominalSurface, MirrorError> {
    match format {
        NominalFormat::BSplineToml => {
            NominalSurface::new(read_bspline_toml(text, file)?, side, file)
        }
        NominalFormat::GridCsv => {
            NominalSurface::from_grid(&read_grid_csv(text, file)?, params, side, file)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_support::plane_surface;
    use super::*;
    use volcomp_gcode::Vec3;

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
    fn the_nominal_format_is_the_extension_in_any_case() {
        use std::path::Path;
        assert_eq!(
            NominalFormat::of_path(Path::new("a/face.TOML")).unwrap(),
            NominalFormat::BSplineToml
        );
        assert_eq!(
            NominalFormat::of_path(Path::new("grid.csv")).unwrap(),
            NominalFormat::GridCsv
        );
        let e = NominalFormat::of_path(Path::new("face.ngc")).unwrap_err();
        assert_eq!(
            e.to_string(),
            "face.ngc: the nominal surface must be a B-spline surface (.toml) or a grid of points (.csv)"
        );
    }

    #[test]
    fn read_nominal_reads_both_formats() {
        // The plane z = 0 as a B-spline file and as a 4 × 3 grid of points.
        let text = write_bspline_toml(&plane_surface(), "plane");
        let n = read_nominal(
            &text,
            "s.toml",
            NominalFormat::BSplineToml,
            MaterialSide::Below,
            &Parameterization::Uniform,
        )
        .unwrap();
        assert!((n.point(0.5, 0.5) - Vec3::new(15.0, 15.0, 0.0)).norm() < 1e-12);
        let mut grid = String::from("x_mm,y_mm,z_mm\n");
        for y in [0.0, 10.0, 20.0] {
            for x in [0.0, 10.0, 20.0, 30.0] {
                grid.push_str(&format!("{x},{y},0\n"));
            }
        }
        let n = read_nominal(
            &grid,
            "g.csv",
            NominalFormat::GridCsv,
            MaterialSide::Below,
            &Parameterization::Uniform,
        )
        .unwrap();
        // Uniform parameters: node (i, j) at (i/3, j/2), normal +Z.
        assert!((n.point(1.0 / 3.0, 0.5) - Vec3::new(10.0, 10.0, 0.0)).norm() < 1e-9);
        assert!((n.normal(0.2, 0.7) - Vec3::new(0.0, 0.0, 1.0)).norm() < 1e-12);
    }
}
