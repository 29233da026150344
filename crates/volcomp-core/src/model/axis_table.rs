//! The axis-table error map (docs/design.md, "The axis-table map"): per axis and motion direction, the
//! displacement errors that the axis' motion causes along X, Y and Z.
//!
//! `e(q, s) = E_X^{s_X}(q_X) + E_Y^{s_Y}(q_Y) + E_Z^{s_Z}(q_Z)` (vector sum, µm),
//! each table linearly interpolated between its points (the seed model of the [Seed papers],
//! docs/references.md).
//!
//! The CSV is read by [`crate::text::table`], which names the row and column
//! of every bad value.

use crate::error::{MapFileError, ModelError};
use crate::limits::{MAX_ERROR_UM, MAX_POSITION_MM};
use crate::model::{Cell, Cells, Components, Direction, Directions, ErrorModel};
use crate::text::table::{shown, CsvTable, Header, Record, UnknownColumns};
use volcomp_gcode::Vec3;

/// One table: strictly increasing positions and the error vector at each.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// Axis positions (mm), strictly increasing.
    pub positions_mm: Vec<f64>,
    /// Errors `(E_aX, E_aY, E_aZ)` in µm at each position.
    pub errors_um: Vec<Vec3>,
}

/// Where a position lies in a table: on its only point, or between two.
enum At {
    Point(Vec3),
    Between { t: f64, p: [f64; 2], e: [Vec3; 2] },
}

impl Table {
    /// Linear interpolation at `x_mm`; `None` outside the range.
    #[inline]
    pub fn eval(&self, x_mm: f64) -> Option<Vec3> {
        Some(match self.at(x_mm)? {
            At::Point(v) => v,
            At::Between { t, e, .. } => e[0].lerp(e[1], t),
        })
    }

    /// The cell that holds `x_mm` ([`Cell`]); `None` outside the table.
    pub fn cell(&self, x_mm: f64) -> Option<Cell> {
        Some(match self.at(x_mm)? {
            At::Point(v) => Cell {
                p: [x_mm; 2],
                e: [v; 2],
                upper: true,
            },
            At::Between { p, e, .. } => Cell {
                p,
                e,
                upper: self.positions_mm.last() == Some(&p[1]),
            },
        })
    }

    #[inline(always)]
    fn at(&self, x_mm: f64) -> Option<At> {
        let (p, e) = (self.positions_mm.as_slice(), self.errors_um.as_slice());
        match p {
            [] => None,
            [only] => (*only == x_mm).then(|| At::Point(e[0])),
            [first, .., last] => {
                if !(*first <= x_mm && x_mm <= *last) {
                    return None;
                }
                // `interval` keeps `i + 1` within `p`; `e` has one error per
                // position (checked once here, not per element).
                let i = interval(p, x_mm);
                let (Some(&[p0, p1]), Some(&[e0, e1])) = (p.get(i..i + 2), e.get(i..i + 2)) else {
                    unreachable!("a table has one error per position")
                };
                Some(At::Between {
                    t: (x_mm - p0) / (p1 - p0),
                    p: [p0, p1],
                    e: [e0, e1],
                })
            }
        }
    }

    /// `[first, last]` position.
    pub fn range(&self) -> [f64; 2] {
        [
            self.positions_mm.first().copied().unwrap_or(0.0),
            self.positions_mm.last().copied().unwrap_or(0.0),
        ]
    }
}

/// Index `i` of the interval `[p[i], p[i+1]]` that holds `x` (`p[0] ≤ x ≤ p[n−1]`).
///
/// Measured tables are nearly always evenly spaced, so the first guess is
/// the proportional position, corrected by a step or two; uneven tables fall
/// back to a binary search.
#[inline(always)]
fn interval(p: &[f64], x: f64) -> usize {
    let last = p.len() - 2;
    let (first, end) = (p[0], p[last + 1]);
    // Through `i64`: the float-to-unsigned conversion costs several times
    // more; out-of-range and NaN guesses land on the ends all the same.
    let guess = ((x - first) / (end - first) * (last + 1) as f64) as i64;
    let i = guess.clamp(0, last as i64) as usize;
    // The guess is right (the usual case on an even table), or one off.
    if let Some(&[lo, hi]) = p.get(i..i + 2) {
        if lo <= x && (x < hi || i == last) {
            return i;
        }
        if x < lo && i > 0 && p[i - 1] <= x {
            return i - 1;
        }
        if x >= hi && i < last && (x < p[i + 2] || i + 1 == last) {
            return i + 1;
        }
    }
    p.partition_point(|&v| v <= x).clamp(1, last + 1) - 1
}

/// `p.partition_point(|k| *k <= x)` for a non-decreasing `p` (how many of
/// its points lie at or below `x`), from [`interval`]'s proportional guess:
/// O(1) on an evenly spaced table, where a binary search takes ~log₂ n
/// steps.
pub(crate) fn count_at_or_below(p: &[f64], x: f64) -> usize {
    match p.len() {
        // Within [p₀, p_last): interval's i has p[i] ≤ x < p[i+1].
        n if n >= 2 && x >= p[0] && x < p[n - 1] => interval(p, x) + 1,
        _ => p.partition_point(|k| *k <= x),
    }
}

/// Forward and reverse tables of one axis (the same table when the file says `both`).
#[derive(Debug, Clone, PartialEq)]
pub struct AxisTables {
    /// Table used while the axis moves forward.
    pub forward: Table,
    /// Table used while the axis moves in reverse.
    pub reverse: Table,
}

impl AxisTables {
    /// The table of direction `d`.
    pub fn table(&self, d: Direction) -> &Table {
        match d {
            Direction::Forward => &self.forward,
            Direction::Reverse => &self.reverse,
        }
    }
}

/// Which table a CSV row belongs to (`direction` column).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum RowDirection {
    /// `forward`, `fwd`, `+`.
    Forward,
    /// `reverse`, `rev`, `-`.
    Reverse,
    /// `both`: one table for both directions.
    Both,
}

impl RowDirection {
    /// Index 0, 1, 2 for forward, reverse, both.
    pub(crate) fn index(self) -> usize {
        self as usize
    }
}

/// Reads an `axis` field: 0, 1, 2 for X, Y, Z.
pub(crate) fn axis_field(t: &CsvTable, r: &Record, col: usize) -> Result<usize, MapFileError> {
    let text = t.text(r, col);
    match text.to_ascii_uppercase().as_str() {
        "X" => Ok(0),
        "Y" => Ok(1),
        "Z" => Ok(2),
        _ => Err(t.error(
            r,
            col,
            format!("unknown axis `{}`", shown(text)),
            "use X, Y or Z",
        )),
    }
}

/// Reads a `direction` field.
pub(crate) fn direction_field(
    t: &CsvTable,
    r: &Record,
    col: usize,
) -> Result<RowDirection, MapFileError> {
    let text = t.text(r, col);
    match text.to_ascii_lowercase().as_str() {
        "forward" | "fwd" | "+" => Ok(RowDirection::Forward),
        "reverse" | "rev" | "-" => Ok(RowDirection::Reverse),
        "both" => Ok(RowDirection::Both),
        _ => Err(t.error(
            r,
            col,
            format!("unknown direction `{}`", shown(text)),
            "use forward, reverse or both",
        )),
    }
}

/// Reads a position (mm): a finite number within ±[`MAX_POSITION_MM`].
///
/// The rule that tells millimetres from micrometres: no program point can
/// lie beyond the coordinate limit, so a table position beyond it can only
/// be in another unit — a table in µm of any axis longer than 100 mm is
/// refused here, at its row, instead of being read as a table 1000 times
/// too long whose every program point falls near its start.
pub(crate) fn position_field(t: &CsvTable, r: &Record, col: usize) -> Result<f64, MapFileError> {
    let v = t.number(r, col)?;
    if v.abs() > MAX_POSITION_MM {
        return Err(t.error(
            r,
            col,
            format!(
                "position {} mm lies beyond ±{MAX_POSITION_MM} mm, the coordinate limit",
                crate::error::fmt_mm(v)
            ),
            "positions are millimetres from the machine datum: a table in µm has 1000 times the numbers (divide them by 1000)",
        ));
    }
    Ok(v)
}

/// Reads an error (µm): a finite number within ±[`MAX_ERROR_UM`].
pub(crate) fn error_field(t: &CsvTable, r: &Record, col: usize) -> Result<f64, MapFileError> {
    let v = t.number(r, col)?;
    if v.abs() > MAX_ERROR_UM {
        return Err(t.error(
            r,
            col,
            format!("an error of {v} µm is more than {MAX_ERROR_UM} µm (10 mm)"),
            "errors are micrometres: a value in nm is 1000 times too large, a value in mm would be far smaller; check the unit and the column",
        ));
    }
    Ok(v)
}

/// The axis-table map of a machine.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisTableMap {
    /// Tables of X, Y, Z.
    pub axes: [AxisTables; 3],
    /// Clamp positions outside a table to its end instead of refusing them.
    pub clamp: bool,
}

const AXES: [char; 3] = ['X', 'Y', 'Z'];

impl ErrorModel for AxisTableMap {
    fn deviation_um(
        &self,
        q_mm: Vec3,
        s: Directions,
        components: Components,
    ) -> Result<Vec3, ModelError> {
        let mut e = Vec3::ZERO;
        for a in 0..3 {
            let table = self.axes[a].table(s[a]);
            // Inside the table (nearly always): no range work beyond eval's.
            let v = match table.eval(q_mm[a]) {
                Some(v) => v,
                None => self.eval_outside(table, a, q_mm[a])?,
            };
            match components {
                Components::All => e += v,
                Components::PositioningOnly => e[a] += v[a],
            }
        }
        Ok(e)
    }

    fn range_mm(&self) -> [[f64; 2]; 3] {
        let r = |a: usize| {
            let f = self.axes[a].forward.range();
            let b = self.axes[a].reverse.range();
            [f[0].max(b[0]), f[1].min(b[1])]
        };
        [r(0), r(1), r(2)]
    }

    /// The cell of each axis' table that holds `q_mm` (as [`Table::eval`]
    /// finds it); `None` outside a table (clamped, or at an end within
    /// rounding: [`ErrorModel::deviation_um`] then takes the end).
    fn deviation_cells(&self, q_mm: Vec3, s: Directions, components: Components) -> Option<Cells> {
        let cell = |a: usize| self.axes[a].table(s[a]).cell(q_mm[a]);
        Some(Cells {
            axes: [cell(0)?, cell(1)?, cell(2)?],
            components,
        })
    }

    /// The cell of the axis' table for `d` that holds `x_mm` (as
    /// [`Table::eval`] finds it); `None` outside the table.
    fn axis_cell(&self, axis: usize, d: Direction, x_mm: f64) -> Option<Cell> {
        self.axes.get(axis)?.table(d).cell(x_mm)
    }

    /// The table's points: linear interpolation changes slope only there.
    fn knots_mm(&self, axis: usize, d: Direction) -> &[f64] {
        self.axes
            .get(axis)
            .map_or(&[], |t| t.table(d).positions_mm.as_slice())
    }

    /// A sum of per-axis tables interpolated linearly (held at the ends
    /// when clamped): affine between table points.
    fn piecewise_linear(&self) -> bool {
        true
    }
}

impl AxisTableMap {
    /// The error of `table` (axis `a`) at `x_mm` where `x_mm` is not inside
    /// the table: at its end when clamped or within the rounding of a
    /// computed position of it, else out of range.
    #[cold]
    fn eval_outside(&self, table: &Table, a: usize, x_mm: f64) -> Result<Vec3, ModelError> {
        let [lo, hi] = table.range();
        let x = if self.clamp {
            x_mm.clamp(lo, hi)
        } else {
            // Within the rounding of a computed position: at the end.
            crate::model::within_range(x_mm, lo, hi).unwrap_or(x_mm)
        };
        table.eval(x).ok_or(ModelError::OutOfRange {
            axis: AXES[a],
            position_mm: x_mm,
            min_mm: lo,
            max_mm: hi,
        })
    }
}

/// The header of an axis-table CSV file: its columns as volcomp writes them
/// (a file may give them in any order).
pub const CSV_HEADER: &str = "axis,direction,position_mm,ex_um,ey_um,ez_um";

impl AxisTableMap {
    /// Parses the CSV text of a map; `file` names it in errors.
    ///
    /// ```
    /// use volcomp_core::model::axis_table::AxisTableMap;
    /// use volcomp_core::model::{ErrorModel, Components, ALL_FORWARD};
    /// use volcomp_gcode::Vec3;
    /// let csv = "axis,direction,position_mm,ex_um,ey_um,ez_um\n\
    ///            X,both,0,0,0,0\nX,both,10,2,0,0\n\
    ///            Y,both,0,0,0,0\nY,both,10,0,0,0\n\
    ///            Z,both,0,0,0,0\nZ,both,10,0,0,0\n";
    /// let map = AxisTableMap::from_csv(csv, "m.csv").unwrap();
    /// let e = map.deviation_um(Vec3::new(2.5, 1.0, 1.0), ALL_FORWARD, Components::All).unwrap();
    /// assert!((e.x - 0.5).abs() < 1e-12);
    /// ```
    pub fn from_csv(text: &str, file: &str) -> Result<AxisTableMap, MapFileError> {
        let err = |row: usize, column: usize, message: String, help: &str| {
            MapFileError::new(file, row, column, message, help)
        };
        let columns: Vec<&str> = CSV_HEADER.split(',').collect();
        let layout = format!("{CSV_HEADER} (positions in mm, errors in µm) in any order");
        let t = CsvTable::parse(
            text,
            file,
            &Header {
                known: &columns,
                unknown: UnknownColumns::Refuse,
                layout: &layout,
            },
        )?;
        let mut cols = [0; 6];
        for (k, name) in columns.iter().enumerate() {
            cols[k] = t.require(name)?;
        }
        let header = Some(cols);
        // [axis][0 forward, 1 reverse, 2 both] → rows (position, errors, row number)
        let mut rows: [[Vec<(f64, Vec3, usize)>; 3]; 3] = Default::default();
        for r in t.records()? {
            let axis = axis_field(&t, r, cols[0])?;
            let dir = direction_field(&t, r, cols[1])?.index();
            let position = position_field(&t, r, cols[2])?;
            let mut e = [0.0; 3];
            for (k, slot) in e.iter_mut().enumerate() {
                *slot = error_field(&t, r, cols[3 + k])?;
            }
            rows[axis][dir].push((position, Vec3::new(e[0], e[1], e[2]), r.line));
        }
        let last_row = t.last_line();
        let mut axes = Vec::with_capacity(3);
        for (a, by_dir) in rows.into_iter().enumerate() {
            let [fwd, rev, both] = by_dir;
            let name = AXES[a];
            let build = |rows: Vec<(f64, Vec3, usize)>,
                         label: &str|
             -> Result<Table, MapFileError> {
                if rows.len() < 2 {
                    return Err(err(
                        last_row,
                        1,
                        format!(
                            "axis {name} has {} point(s) in its {label} table",
                            rows.len()
                        ),
                        "give at least two points per table",
                    ));
                }
                for w in rows.windows(2) {
                    if w[1].0 <= w[0].0 {
                        return Err(t.error_at(
                                w[1].2,
                                cols_position(&header) - 1,
                                format!(
                                    "axis {name} {label}: position {} does not increase after {} (row {})",
                                    w[1].0, w[0].0, w[0].2
                                ),
                                "list each table's positions in strictly increasing order",
                            ));
                    }
                }
                Ok(Table {
                    positions_mm: rows.iter().map(|r| r.0).collect(),
                    errors_um: rows.iter().map(|r| r.1).collect(),
                })
            };
            let tables = match (fwd.is_empty(), rev.is_empty(), both.is_empty()) {
                (true, true, false) => {
                    let t = build(both, "both")?;
                    AxisTables { forward: t.clone(), reverse: t }
                }
                (false, false, true) => AxisTables {
                    forward: build(fwd, "forward")?,
                    reverse: build(rev, "reverse")?,
                },
                (true, true, true) => return Err(err(last_row, 1, format!("axis {name} has no table"), "give forward and reverse tables, or one `both` table, for X, Y and Z")),
                _ => return Err(err(last_row, 1, format!("axis {name} must have either a `both` table or both a forward and a reverse table"), "a single direction is not enough: the other direction's error would be a guess")),
            };
            axes.push(tables);
        }
        let axes: [AxisTables; 3] = axes.try_into().unwrap_or_else(|_| unreachable!());
        Ok(AxisTableMap { axes, clamp: false })
    }

    /// Writes the map as CSV (the layout of docs/design.md, "The axis-table map").
    pub fn to_csv(&self) -> String {
        let mut s = format!("{CSV_HEADER}\n");
        for (a, t) in self.axes.iter().enumerate() {
            let same = t.forward == t.reverse;
            let dirs: &[(&str, &Table)] = if same {
                &[("both", &t.forward)]
            } else {
                &[("forward", &t.forward), ("reverse", &t.reverse)]
            };
            for (name, table) in dirs {
                for (p, e) in table.positions_mm.iter().zip(&table.errors_um) {
                    s.push_str(&format!(
                        "{},{name},{},{},{},{}\n",
                        AXES[a],
                        crate::text::numfmt::mm(*p),
                        crate::text::numfmt::um(e.x),
                        crate::text::numfmt::um(e.y),
                        crate::text::numfmt::um(e.z)
                    ));
                }
            }
        }
        s
    }
}

fn cols_position(header: &Option<[usize; 6]>) -> usize {
    header.map(|h| h[2] + 1).unwrap_or(3)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ALL_FORWARD;

    const HEAD: &str = "axis,direction,position_mm,ex_um,ey_um,ez_um\n";

    fn flat(axis: &str) -> String {
        format!("{axis},both,0,0,0,0\n{axis},both,100,0,0,0\n")
    }

    /// A map file with these rows of X (after the header) and flat Y and Z.
    fn with_x(x_rows: &str) -> String {
        format!("{HEAD}{x_rows}{}{}", flat("Y"), flat("Z"))
    }

    #[test]
    fn interpolates_by_hand() {
        // X forward: 0 → 0 µm, 15 → 1.21 µm; at 5 mm: 1.21·5/15 = 0.40333… µm.
        let csv = with_x("# comment\nX,forward,0,0,0,0\nX,forward,15,1.21,-0.30,0.12\nX,reverse,0,1,0,0\nX,reverse,15,3,0,0\n");
        let m = AxisTableMap::from_csv(&csv, "m.csv").unwrap();
        let e = m
            .deviation_um(Vec3::new(5.0, 50.0, 50.0), ALL_FORWARD, Components::All)
            .unwrap();
        assert!((e.x - 1.21 / 3.0).abs() < 1e-12);
        assert!((e.y + 0.1).abs() < 1e-12);
        assert!((e.z - 0.04).abs() < 1e-12);
        let s = [Direction::Reverse, Direction::Forward, Direction::Forward];
        let e = m
            .deviation_um(Vec3::new(7.5, 0.0, 0.0), s, Components::All)
            .unwrap();
        assert!((e.x - 2.0).abs() < 1e-12);
    }

    #[test]
    fn interval_search_agrees_with_binary_search() {
        let uneven = [0.0, 0.5, 3.0, 3.1, 10.0, 11.0, 40.0];
        let even: Vec<f64> = (0..50).map(|k| k as f64 * 2.0).collect();
        for p in [&uneven[..], &even[..]] {
            let n = p.len();
            for k in 0..=1000 {
                let x = p[0] + (p[n - 1] - p[0]) * k as f64 / 1000.0;
                let expected = p.partition_point(|&v| v <= x).clamp(1, n - 1) - 1;
                assert_eq!(interval(p, x), expected, "x = {x}");
            }
        }
    }

    /// The guessed count is the binary search's, inside the table, at its
    /// points, outside it and for NaN, on even, uneven and repeated points.
    #[test]
    fn count_at_or_below_agrees_with_binary_search() {
        let uneven = [0.0, 0.5, 3.0, 3.1, 10.0, 11.0, 40.0];
        let repeated = [0.0, 1.0, 1.0, 2.0, 5.0, 5.0, 6.0];
        let even: Vec<f64> = (0..50).map(|k| k as f64 * 2.0).collect();
        for p in [&uneven[..], &repeated[..], &even[..], &[3.0][..], &[][..]] {
            let mut xs: Vec<f64> = (-20..=1020)
                .map(|k| -1.0 + 102.0 * k as f64 / 1000.0)
                .collect();
            xs.extend(p.iter().copied());
            xs.extend(p.iter().map(|v| v - 1e-12));
            xs.push(f64::NAN);
            for x in xs {
                let expected = p.partition_point(|&v| v <= x);
                assert_eq!(count_at_or_below(p, x), expected, "x = {x}, p = {p:?}");
            }
        }
    }

    /// Inside the cells the map's value is the evaluation's to the bit,
    /// on a hand-made map of uneven cells, both directions, positioning
    /// only too, on the table points themselves and at the tables' ends;
    /// outside a cell it is `None`, outside a table there are no cells.
    #[test]
    fn the_cells_give_the_map_to_the_bit() {
        let csv = format!(
            "{HEAD}X,forward,0,0,0,0\nX,forward,3,1.5,-0.3,0.2\nX,forward,10,-2,0.4,0.1\n\
             X,reverse,0,1,0,0\nX,reverse,10,3,0.5,0\n\
             Y,both,-5,0.2,1,0\nY,both,5,0.1,-1,0.3\nY,both,20,0,2,0\n\
             Z,both,-10,0,0,-1\nZ,both,0,0.3,0.1,0\nZ,both,10,0,0,2\n"
        );
        let m = AxisTableMap::from_csv(&csv, "m.csv").unwrap();
        let states = [
            ALL_FORWARD,
            [Direction::Reverse, Direction::Forward, Direction::Reverse],
        ];
        let mut points: Vec<Vec3> = (0..300)
            .map(|k| {
                let f = f64::from(k) / 299.0;
                Vec3::new(10.0 * f, -5.0 + 25.0 * f * f, 10.0 - 20.0 * f)
            })
            .collect();
        points.extend([
            Vec3::new(3.0, 5.0, 0.0),
            Vec3::new(10.0, 20.0, 10.0),
            Vec3::new(0.0, -5.0, -10.0),
        ]);
        for s in states {
            for c in [Components::All, Components::PositioningOnly] {
                for (i, &q) in points.iter().enumerate() {
                    let cells = m.deviation_cells(q, s, c).unwrap();
                    let e = m.deviation_um(q, s, c).unwrap();
                    assert_eq!(cells.deviation_um(q), Some(e), "q = {q:?}");
                    // The cells of q at every other point: the map's value
                    // where that point lies in them, else none.
                    for &r in &points[i..] {
                        if let Some(v) = cells.deviation_um(r) {
                            assert_eq!(v, m.deviation_um(r, s, c).unwrap(), "{q:?} {r:?}");
                            assert_eq!(m.deviation_cells(r, s, c), Some(cells));
                        }
                    }
                }
            }
        }
        // By hand: X forward's cell [3, 10) holds 4 mm, not 10 (the last
        // cell holds its end); 3 mm lies in it, not in [0, 3).
        let cells = m.deviation_cells(Vec3::new(4.0, 0.0, 0.0), ALL_FORWARD, Components::All);
        let x = cells.unwrap().axes[0];
        assert_eq!((x.p, x.upper), ([3.0, 10.0], true));
        let cells = m.deviation_cells(Vec3::new(1.0, 0.0, 0.0), ALL_FORWARD, Components::All);
        let cells = cells.unwrap();
        assert_eq!((cells.axes[0].p, cells.axes[0].upper), ([0.0, 3.0], false));
        assert_eq!(cells.deviation_um(Vec3::new(3.0, 0.0, 0.0)), None);
        let outside = Vec3::new(10.5, 0.0, 0.0);
        assert_eq!(
            m.deviation_cells(outside, ALL_FORWARD, Components::All),
            None
        );
    }

    #[test]
    fn any_column_order() {
        let csv = format!(
            "position_mm,axis,ez_um,ey_um,ex_um,direction\n0,X,0,0,0,both\n10,X,3,2,1,both\n{}",
            "0,Y,0,0,0,both\n10,Y,0,0,0,both\n0,Z,0,0,0,both\n10,Z,0,0,0,both\n"
        );
        let m = AxisTableMap::from_csv(&csv, "m.csv").unwrap();
        let e = m
            .deviation_um(Vec3::new(10.0, 0.0, 0.0), ALL_FORWARD, Components::All)
            .unwrap();
        assert_eq!(e, Vec3::new(1.0, 2.0, 3.0));
    }

    #[test]
    fn bad_files_name_row_and_column() {
        let csv = with_x("X,both,0,0,0,0\nX,both,10,nan,0,0\n");
        let e = AxisTableMap::from_csv(&csv, "m.csv").unwrap_err();
        assert_eq!((e.row, e.column), (3, 4));
        let csv = with_x("X,both,0,0,0,0\nX,both,0,1,0,0\n");
        let e = AxisTableMap::from_csv(&csv, "m.csv").unwrap_err();
        assert_eq!((e.row, e.column), (3, 3));
        assert!(e.message.contains("does not increase"));
        let e = AxisTableMap::from_csv("axis,direction,position_in,ex_um,ey_um,ez_um\n", "m.csv")
            .unwrap_err();
        assert_eq!((e.row, e.column), (1, 3));
        let csv = with_x("X,forward,0,0,0,0\nX,forward,10,0,0,0\n");
        assert!(AxisTableMap::from_csv(&csv, "m.csv").is_err());
    }

    #[test]
    fn out_of_range_is_an_error_unless_clamped() {
        let csv = format!("{HEAD}{}{}{}", flat("X"), flat("Y"), flat("Z"));
        let mut m = AxisTableMap::from_csv(&csv, "m.csv").unwrap();
        let e = m
            .deviation_um(Vec3::new(0.0, 100.5, 0.0), ALL_FORWARD, Components::All)
            .unwrap_err();
        assert!(matches!(e, ModelError::OutOfRange { axis: 'Y', .. }));
        m.clamp = true;
        assert!(m
            .deviation_um(Vec3::new(0.0, 100.5, 0.0), ALL_FORWARD, Components::All)
            .is_ok());
    }

    #[test]
    fn csv_round_trip() {
        let csv = format!("{HEAD}X,forward,0,0,0,0\nX,forward,15,1.21,-0.3,0.12\nX,reverse,0,1,0,0\nX,reverse,15,3,0,0\n{}{}", flat("Y"), flat("Z"));
        let m = AxisTableMap::from_csv(&csv, "m.csv").unwrap();
        let again = AxisTableMap::from_csv(&m.to_csv(), "again.csv").unwrap();
        assert_eq!(m, again);
    }
}
