//! The CSV component tables of the 21-component model: the axis-table
//! layout of docs/design.md with three angle columns, read located and
//! written with the numbers of [`crate::io::numfmt`].

use super::{map_err, AXES, URAD_PER_ARCSEC};
use crate::error::MapFileError;
use crate::io::numfmt;
use crate::io::table::{CsvTable, Header, UnknownColumns};
use crate::model::kinematic::{AxisComponents, ComponentTable};
use volcomp_gcode::Vec3;

// CSV component tables

/// Header of the CSV component table.
pub const CSV_HEADER: &str = "axis,direction,position_mm,ex_um,ey_um,ez_um,ea_urad,eb_urad,ec_urad";

#[derive(Debug, Clone, Copy, PartialEq)]
enum Dir {
    Forward,
    Reverse,
    Both,
}

/// One parsed row, located.
#[derive(Debug, Clone)]
struct Row {
    axis: usize,
    dir: Dir,
    position_mm: f64,
    linear_um: Vec3,
    angular_urad: Vec3,
    /// Shared by every row of its file.
    file: std::rc::Rc<str>,
    row: usize,
    position_column: usize,
}

/// Rows of one or more CSV files, assembled into per-axis tables.
#[derive(Debug, Default)]
pub struct TableRows {
    rows: Vec<Row>,
    last: Option<(String, usize)>,
}

const BASE_COLUMNS: [&str; 3] = ["axis", "direction", "position_mm"];

/// Parses the header field `name` into a column slot and a unit factor.
fn header_slot(name: &str) -> Result<(usize, f64), (String, &'static str)> {
    let lower = name.to_ascii_lowercase();
    if let Some(k) = BASE_COLUMNS.iter().position(|c| *c == lower) {
        return Ok((k, 1.0));
    }
    let (stem, unit) = match lower.split_once('_') {
        Some((s, u)) => (s, Some(u)),
        None => (lower.as_str(), None),
    };
    let linear = ["ex", "ey", "ez"].iter().position(|c| *c == stem);
    let angular = ["ea", "eb", "ec"].iter().position(|c| *c == stem);
    match (linear, angular, unit) {
        (Some(k), _, Some("um")) => Ok((3 + k, 1.0)),
        (_, Some(k), Some("urad")) => Ok((6 + k, 1.0)),
        (_, Some(k), Some("arcsec")) => Ok((6 + k, URAD_PER_ARCSEC)),
        (Some(_), _, None) => Err((
            format!("column `{name}` has no unit"),
            "linear errors are in micrometres: write ex_um, ey_um, ez_um",
        )),
        (_, Some(_), None) => Err((
            format!("column `{name}` has no unit"),
            "angular errors are in microradians or arc seconds: write ea_urad (or ea_arcsec), eb_urad, ec_urad",
        )),
        (Some(_), _, Some(_)) => Err((
            format!("column `{name}`: linear errors must be in µm"),
            "write ex_um, ey_um, ez_um with values in micrometres",
        )),
        (_, Some(_), Some(_)) => Err((
            format!("column `{name}`: angles must be in µrad or arc seconds"),
            "write ea_urad, eb_urad, ec_urad (or _arcsec)",
        )),
        _ if stem == "position" => Err((
            format!("column `{name}`: positions must be in mm"),
            "write position_mm with values in millimetres",
        )),
        _ => Err((
            format!("unknown column `{name}`"),
            "the header names axis,direction,position_mm,ex_um,ey_um,ez_um,ea_urad,eb_urad,ec_urad in any order",
        )),
    }
}

const COLUMN_NAMES: [&str; 9] = [
    "axis",
    "direction",
    "position_mm",
    "ex_um",
    "ey_um",
    "ez_um",
    "ea_urad",
    "eb_urad",
    "ec_urad",
];

const COLUMN_MEANING: [&str; 9] = [
    "the axis the row belongs to",
    "forward, reverse or both",
    "the axis position",
    "the error along X: EXX, EXY, EXZ",
    "the error along Y: EYX, EYY, EYZ",
    "the error along Z: EZX, EZY, EZZ",
    "the rotation about X: EAX, EAY, EAZ",
    "the rotation about Y: EBX, EBY, EBZ",
    "the rotation about Z: ECX, ECY, ECZ",
];

impl TableRows {
    /// Adds the rows of one CSV file; `file` names it in errors.
    pub fn add_csv(&mut self, text: &str, file: &str) -> Result<(), MapFileError> {
        let t = CsvTable::parse(
            text,
            file,
            &Header {
                known: &[],
                unknown: UnknownColumns::Keep,
                layout: CSV_HEADER,
            },
        )?;
        let mut cols = [usize::MAX; 9];
        let mut scale = [1.0; 9];
        for (c, name) in t.header.iter().enumerate() {
            let (k, f) = header_slot(name)
                .map_err(|(message, help)| t.error_at(t.header_line, c, message, help))?;
            if cols[k] != usize::MAX {
                return Err(t.error_at(
                    t.header_line,
                    c,
                    format!(
                        "column `{name}` gives the same component as column {}",
                        cols[k] + 1
                    ),
                    "name each column once",
                ));
            }
            cols[k] = c;
            scale[k] = f;
        }
        if let Some(k) = cols.iter().position(|v| *v == usize::MAX) {
            let mut e = t.missing(COLUMN_NAMES[k], COLUMN_MEANING[k]);
            e.help = "the 21-component table needs axis,direction,position_mm,ex_um,ey_um,ez_um,ea_urad,eb_urad,ec_urad; write 0 for a component that was not measured".into();
            return Err(e);
        }
        let shared: std::rc::Rc<str> = std::rc::Rc::from(file);
        for r in t.records()? {
            let axis = crate::model::axis_table::axis_field(&t, r, cols[0])?;
            let dir = match crate::model::axis_table::direction_field(&t, r, cols[1])? {
                crate::model::axis_table::RowDirection::Forward => Dir::Forward,
                crate::model::axis_table::RowDirection::Reverse => Dir::Reverse,
                crate::model::axis_table::RowDirection::Both => Dir::Both,
            };
            // The rules of every map (docs/errors.md): positions within the
            // coordinate limit, errors within 10 mm, angles within 0.01 rad.
            let mut num = [0.0; 7];
            num[0] = crate::model::axis_table::position_field(&t, r, cols[2])?;
            for k in 1..4 {
                num[k] = crate::model::axis_table::error_field(&t, r, cols[2 + k])?;
            }
            for k in 4..7 {
                let v = t.number(r, cols[2 + k])? * scale[2 + k];
                if v.abs() > crate::limits::MAX_ANGLE_URAD {
                    return Err(t.error(
                        r,
                        cols[2 + k],
                        format!(
                            "an angle of {v} µrad is more than {} µrad (0.01 rad, 0.57°)",
                            crate::limits::MAX_ANGLE_URAD
                        ),
                        "angular errors of machine tools are microradians: check the unit (µrad or arc seconds, as the column's name says) and the column",
                    ));
                }
                num[k] = v;
            }
            self.rows.push(Row {
                axis,
                dir,
                position_mm: num[0],
                linear_um: Vec3::new(num[1], num[2], num[3]),
                angular_urad: Vec3::new(num[4], num[5], num[6]),
                file: shared.clone(),
                row: r.line,
                position_column: cols[2] + 1,
            });
        }
        let last_row = t.last_line();
        self.last = Some((file.to_string(), last_row));
        Ok(())
    }

    /// The per-axis tables; every axis needs a `both` table or a forward and
    /// a reverse one, each with at least two strictly increasing positions.
    pub fn assemble(self) -> Result<[AxisComponents; 3], MapFileError> {
        let (last_file, last_row) = self.last.clone().unwrap_or_default();
        let at_end = |message: String, help: &str| map_err(&last_file, last_row, 1, message, help);
        let mut by: [[Vec<&Row>; 3]; 3] = Default::default();
        for r in &self.rows {
            let d = match r.dir {
                Dir::Forward => 0,
                Dir::Reverse => 1,
                Dir::Both => 2,
            };
            by[r.axis][d].push(r);
        }
        let build =
            |rows: &[&Row], a: usize, label: &str| -> Result<ComponentTable, MapFileError> {
                let name = AXES[a];
                if rows.len() < 2 {
                    return Err(at_end(
                        format!(
                            "axis {name} has {} point(s) in its {label} table",
                            rows.len()
                        ),
                        "give at least two points per table",
                    ));
                }
                for w in rows.windows(2) {
                    if w[1].position_mm <= w[0].position_mm {
                        return Err(map_err(
                            &w[1].file,
                            w[1].row,
                            w[1].position_column,
                            format!(
                                "axis {name} {label}: position {} does not increase after {}",
                                w[1].position_mm, w[0].position_mm
                            ),
                            "list each table's positions in strictly increasing order",
                        ));
                    }
                }
                let table = ComponentTable::new(
                    rows.iter().map(|r| r.position_mm).collect(),
                    rows.iter().map(|r| r.linear_um).collect(),
                    rows.iter().map(|r| r.angular_urad).collect(),
                );
                table.ok_or_else(|| {
                    at_end(
                        format!("axis {name} {label}: bad table"),
                        "check the positions",
                    )
                })
            };
        let mut axes = Vec::with_capacity(3);
        for (a, d) in by.iter().enumerate() {
            let name = AXES[a];
            let comps = format!(
                "E{name}{name}, E{}{name}, E{}{name}, EA{name}, EB{name}, EC{name}",
                AXES[(a + 1) % 3],
                AXES[(a + 2) % 3]
            );
            let t = match (d[0].is_empty(), d[1].is_empty(), d[2].is_empty()) {
                (true, true, false) => AxisComponents::both(build(&d[2], a, "both")?),
                (false, false, true) => AxisComponents {
                    forward: build(&d[0], a, "forward")?,
                    reverse: build(&d[1], a, "reverse")?,
                },
                (true, true, true) => {
                    return Err(at_end(
                        format!("axis {name} has no rows: the model is missing {comps}"),
                        "give a `both` table, or forward and reverse tables, for each of X, Y and Z",
                    ))
                }
                _ => {
                    return Err(at_end(
                        format!("axis {name} must have either a `both` table or both a forward and a reverse table"),
                        "a single direction is not enough: the other direction's error would be a guess",
                    ))
                }
            };
            axes.push(t);
        }
        let mut it = axes.into_iter();
        match (it.next(), it.next(), it.next()) {
            (Some(x), Some(y), Some(z)) => Ok([x, y, z]),
            _ => unreachable!("three axes were pushed"),
        }
    }
}

/// Parses one CSV that holds the tables of all three axes.
///
/// ```
/// use volcomp_core::io::model_file::components_from_csv;
/// let csv = "axis,direction,position_mm,ex_um,ey_um,ez_um,ea_urad,eb_urad,ec_urad\n\
///            X,both,0,0,0,0,0,0,0\nX,both,100,1,0,0,0,0,5\n\
///            Y,both,0,0,0,0,0,0,0\nY,both,100,0,2,0,0,0,0\n\
///            Z,both,0,0,0,0,0,0,0\nZ,both,100,0,0,3,0,0,0\n";
/// let axes = components_from_csv(csv, "m.csv").unwrap();
/// assert_eq!(axes[0].forward.angular_urad.errors_um[1].z, 5.0);
/// ```
pub fn components_from_csv(text: &str, file: &str) -> Result<[AxisComponents; 3], MapFileError> {
    let mut rows = TableRows::default();
    rows.add_csv(text, file)?;
    rows.assemble()
}

/// Writes the tables as CSV (positions, µm and µrad to the fixed precision
/// of [`crate::io::numfmt`]).
pub fn components_to_csv(axes: &[AxisComponents; 3]) -> String {
    let mut s = String::from(
        "# volcomp 21-component tables (ISO 230-1): for the rows of axis X, ex_um is EXX, ey_um EYX,\n\
         # ez_um EZX, ea_urad EAX, eb_urad EBX, ec_urad ECX; likewise for Y and Z.\n",
    );
    s.push_str(CSV_HEADER);
    s.push('\n');
    for (a, t) in axes.iter().enumerate() {
        let dirs: Vec<(&str, &ComponentTable)> = if t.forward == t.reverse {
            vec![("both", &t.forward)]
        } else {
            vec![("forward", &t.forward), ("reverse", &t.reverse)]
        };
        for (name, table) in dirs {
            for (k, p) in table.positions_mm().iter().enumerate() {
                let l = table.linear_um.errors_um[k];
                let g = table.angular_urad.errors_um[k];
                s.push_str(&format!(
                    "{},{name},{},{},{},{},{},{},{}\n",
                    AXES[a],
                    numfmt::mm(*p),
                    numfmt::um(l.x),
                    numfmt::um(l.y),
                    numfmt::um(l.z),
                    numfmt::urad(g.x),
                    numfmt::urad(g.y),
                    numfmt::urad(g.z)
                ));
            }
        }
    }
    s
}
