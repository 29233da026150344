//! ISO 230-1 parameter files from instruments and other software, read
//! into the 21-component model: the ISG CSV and the Etalon exchange format
//! as the ISG/Beckhoff volumetric compensation documents them ([ISG
//! VolComp], "File formats supported"; docs/controllers.md), and the ISG
//! CSV written from a model (`volcomp map export --to isg-csv`).
//!
//! Both hold named ISO 230-1 parameters in mm (lengths) and rad (angles):
//! component errors `E<dir><axis>` (`EXX` … `ECZ`) as tables over their
//! axis' position (mm), and position errors `<dir>0<axis>` as constants.
//! volcomp's model needs, per axis, the six component errors at the same
//! positions (a component given at other positions is interpolated
//! linearly onto the axis' positions; one that does not cover them is
//! refused, never extrapolated; one not given is zero and reported) and
//! the three squareness errors, from the position errors of ISO 230-1's
//! right-hand rule (the orientation error of the axis about X, Y, Z) with X
//! as the reference:
//!
//! ```text
//! Y along (S_xy, 1, 0): Y turned about Z by −S_xy  →  C0Y = −S_xy
//! Z along (S_zx, S_yz, 1): about Y by +S_zx, about X by −S_yz
//!                                                  →  B0Z = S_zx, A0Z = −S_yz
//! ```
//!
//! (S in µrad = 10⁻⁶ rad). Position errors of rotary axes (`…A`, `…B`,
//! `…C`) are listed as not used; other position errors are refused, since a
//! model with X as the reference cannot hold them.

use crate::error::MapFileError;
use crate::io::controllers::located;
use crate::io::finite;
use crate::model::axis_table::Table;
use crate::model::kinematic::{AxisComponents, ComponentTable, KinematicModel, Kinematics};
use crate::model::topology::Topology;
use volcomp_gcode::Vec3;

/// A component error as read: its name, its `(position mm, value)` rows
/// and the row of the file it starts on.
pub type NamedTable = (String, Vec<(f64, f64)>, usize);

/// Named parameters as read: constants and tables (position mm, value in
/// mm or rad), each with the row it starts on.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct Parameters {
    /// Position errors: name, value, row.
    pub constants: Vec<(String, f64, usize)>,
    /// Component errors: name, (position, value) rows, row.
    pub tables: Vec<NamedTable>,
}

/// A model read from parameters, and what was assumed or left out.
#[derive(Debug, Clone)]
pub struct Imported {
    /// The model (seed measuring lines at the origin, the given chain).
    pub model: KinematicModel,
    /// Components not in the file (taken as zero).
    pub assumed_zero: Vec<String>,
    /// Parameters in the file that a 3-axis model does not use (rotary axes).
    pub not_used: Vec<String>,
}

fn number(file: &str, text: &str, row: usize, s: &str) -> Result<f64, MapFileError> {
    finite(s).ok_or_else(|| {
        located(
            file,
            text,
            row,
            format!("`{s}` is not a number"),
            "values are numbers in mm or rad, positions in mm",
        )
    })
}

/// Reads an ISG CSV file: `//` comments, a header line of names, rows of
/// numbers separated by blanks, `#` starts a new block with a new header.
/// A block has one argument column (X, Y or Z) and component errors, or
/// only position errors (one row).
pub fn parse_isg_csv(text: &str, file: &str) -> Result<Parameters, MapFileError> {
    let mut out = Parameters::default();
    let mut header: Option<(Vec<String>, usize)> = None;
    let mut rows: Vec<(usize, Vec<f64>)> = Vec::new();
    let flush =
        |header: &Option<(Vec<String>, usize)>,
         rows: &mut Vec<(usize, Vec<f64>)>,
         out: &mut Parameters|
         -> Result<(), MapFileError> {
            let Some((names, hrow)) = header else {
                return Ok(());
            };
            let args: Vec<usize> = (0..names.len())
                .filter(|&i| ["X", "Y", "Z", "A", "B", "C"].contains(&names[i].as_str()))
                .collect();
            match args.as_slice() {
                [] => {
                    let [(row, values)] = rows.as_slice() else {
                        return Err(located(
                            file,
                            text,
                            *hrow,
                            format!("a block of position errors has {} rows", rows.len()),
                            "give position errors (constants) in one row",
                        ));
                    };
                    for (n, v) in names.iter().zip(values) {
                        out.constants.push((n.clone(), *v, *row));
                    }
                }
                [arg] => {
                    for (c, n) in names.iter().enumerate() {
                        if c != *arg {
                            out.tables.push((
                                n.clone(),
                                rows.iter().map(|(_, v)| (v[*arg], v[c])).collect(),
                                *hrow,
                            ));
                        }
                    }
                }
                _ => return Err(located(
                    file,
                    text,
                    *hrow,
                    "more than one argument column",
                    "volcomp reads component errors over their own axis (one of X, Y, Z per block)",
                )),
            }
            rows.clear();
            Ok(())
        };
    for (i, raw) in text.lines().enumerate() {
        let row = i + 1;
        let line = raw.split("//").next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        if line.starts_with('#') {
            flush(&header, &mut rows, &mut out)?;
            header = None;
            continue;
        }
        let fields: Vec<&str> = line.split_whitespace().collect();
        match &header {
            None => header = Some((fields.iter().map(|f| f.to_ascii_uppercase()).collect(), row)),
            Some((names, _)) => {
                if fields.len() != names.len() {
                    return Err(located(
                        file,
                        text,
                        row,
                        format!("{} values for {} columns", fields.len(), names.len()),
                        "give a value in every column of the header",
                    ));
                }
                let v = fields
                    .iter()
                    .map(|f| number(file, text, row, f))
                    .collect::<Result<Vec<_>, _>>()?;
                rows.push((row, v));
            }
        }
    }
    flush(&header, &mut rows, &mut out)?;
    Ok(out)
}

/// Reads an Etalon exchange file ("Vendor" variant): blocks `[NAME]` with
/// `VALUE = v` (a position error) or `Gridpoints = { position value … }`
/// (a component error); `//` comments.
pub fn parse_etalon(text: &str, file: &str) -> Result<Parameters, MapFileError> {
    let mut out = Parameters::default();
    let mut name: Option<(String, usize)> = None;
    let mut grid: Option<Vec<(f64, f64)>> = None;
    for (i, raw) in text.lines().enumerate() {
        let row = i + 1;
        let line = raw.split("//").next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        if let Some(points) = grid.as_mut() {
            if line.starts_with('}') {
                let (n, r) = name.clone().unwrap_or_default();
                out.tables.push((n, grid.take().unwrap_or_default(), r));
                continue;
            }
            let f: Vec<&str> = line.split_whitespace().collect();
            let [p, v] = f.as_slice() else {
                return Err(located(
                    file,
                    text,
                    row,
                    format!("{} numbers on a grid line", f.len()),
                    "each Gridpoints line is `position value`",
                ));
            };
            points.push((number(file, text, row, p)?, number(file, text, row, v)?));
            continue;
        }
        if let Some(n) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
            name = Some((n.trim().to_ascii_uppercase(), row));
            continue;
        }
        let Some((key, value)) = line.split_once('=') else {
            return Err(located(
                file,
                text,
                row,
                format!("`{line}` is not `KEY = value`"),
                "a block holds VALUE = v or Gridpoints = { … }",
            ));
        };
        let Some((n, r)) = name.clone() else {
            return Err(located(
                file,
                text,
                row,
                "a value outside a [NAME] block",
                "each parameter starts with its name in square brackets",
            ));
        };
        match key.trim().to_ascii_uppercase().as_str() {
            "VALUE" => out
                .constants
                .push((n, number(file, text, row, value.trim())?, r)),
            "GRIDPOINTS" if value.trim() == "{" => grid = Some(Vec::new()),
            k => {
                return Err(located(
                    file,
                    text,
                    row,
                    format!("`{k}` in [{n}]"),
                    "expected VALUE = v or Gridpoints = {",
                ))
            }
        }
    }
    if grid.is_some() {
        return Err(located(
            file,
            text,
            text.lines().count(),
            "a Gridpoints block is not closed",
            "end the block with }",
        ));
    }
    Ok(out)
}

/// The 21-component model of `p` on `chain` (see the module's text).
pub fn to_model(
    p: &Parameters,
    file: &str,
    text: &str,
    chain: Topology,
) -> Result<Imported, MapFileError> {
    let axes = ['X', 'Y', 'Z'];
    let dirs = ['X', 'Y', 'Z', 'A', 'B', 'C'];
    // A refusal at a row of the file.
    let refuse = |row: usize, message: String, help: &str| located(file, text, row, message, help);
    let mut not_used = Vec::new();
    let mut kin = Kinematics::new(chain);
    for (n, v, row) in &p.constants {
        match n.as_str() {
            "C0Y" => kin.squareness.xy_urad = -v * 1e6,
            "B0Z" => kin.squareness.zx_urad = v * 1e6,
            "A0Z" => kin.squareness.yz_urad = -v * 1e6,
            _ if n.len() == 3 && n.as_bytes()[1] == b'0' && "ABC".contains(&n[2..]) => not_used.push(n.clone()),
            _ if *v == 0.0 => not_used.push(n.clone()),
            _ => {
                return Err(refuse(*row, format!("position error {n} = {v}"), "with X as the reference volcomp's model holds the squareness C0Y, B0Z, A0Z only; refer the measurement to X"))
            }
        }
    }
    let mut assumed_zero = Vec::new();
    let mut per_axis: Vec<AxisComponents> = Vec::new();
    for ax in axes.iter() {
        let mine: Vec<(usize, &NamedTable)> = p
            .tables
            .iter()
            .filter(|(n, _, _)| n.len() == 3 && n.starts_with('E') && n.ends_with(*ax))
            .filter_map(|t| {
                dirs.iter()
                    .position(|&d| t.0.as_bytes()[1] as char == d)
                    .map(|d| (d, t))
            })
            .collect();
        if mine.is_empty() {
            return Err(refuse(
                1,
                format!("no component errors of {ax} (E?{ax})"),
                "the file must hold at least one table per axis, e.g. EXX",
            ));
        }
        // The axis' positions: the union of its tables'.
        let mut pos: Vec<f64> = mine
            .iter()
            .flat_map(|(_, t)| t.1.iter().map(|q| q.0))
            .collect();
        pos.sort_by(f64::total_cmp);
        pos.dedup();
        let mut lin = vec![Vec3::ZERO; pos.len()];
        let mut ang = vec![Vec3::ZERO; pos.len()];
        for d in 0..6 {
            let name = format!("E{}{ax}", dirs[d]);
            let Some((_, (_, pts, row))) = mine.iter().find(|(k, _)| *k == d) else {
                assumed_zero.push(name);
                continue;
            };
            if pts.windows(2).any(|w| w[1].0 <= w[0].0) || pts.len() < 2 {
                return Err(refuse(
                    *row,
                    format!("{name}: positions do not strictly increase (or fewer than two)"),
                    "give each table's positions in increasing order",
                ));
            }
            let (lo, hi) = (pts[0].0, pts[pts.len() - 1].0);
            if lo > pos[0] || hi < pos[pos.len() - 1] {
                return Err(refuse(*row, format!("{name} covers {lo} … {hi} mm, the axis' other tables {} … {} mm", pos[0], pos[pos.len() - 1]), "give every component of an axis over the same range (volcomp does not extrapolate)"));
            }
            let t = Table {
                positions_mm: pts.iter().map(|q| q.0).collect(),
                errors_um: pts.iter().map(|q| Vec3::new(q.1, 0.0, 0.0)).collect(),
            };
            for (k, &x) in pos.iter().enumerate() {
                let v = t.eval(x).map(|e| e.x).unwrap_or(0.0);
                if d < 3 {
                    lin[k][d] = v * 1e3;
                } else {
                    ang[k][d - 3] = v * 1e6;
                }
            }
        }
        let table = ComponentTable::new(pos, lin, ang).ok_or_else(|| {
            refuse(
                1,
                format!("the tables of {ax} have fewer than two positions"),
                "give at least two positions per axis",
            )
        })?;
        per_axis.push(AxisComponents {
            forward: table.clone(),
            reverse: table,
        });
    }
    let axes: [AxisComponents; 3] = per_axis
        .try_into()
        .map_err(|_| refuse(1, "three axes expected".into(), ""))?;
    Ok(Imported {
        model: KinematicModel::new(axes, kin),
        assumed_zero,
        not_used,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Components, ErrorModel, ALL_FORWARD};

    const ETALON: &str = "// Etalon exchange format (Vendor)\n[C0Y]\nVALUE = -0.000012\n[B0Z]\nVALUE = 0.000006\n[A0Z]\nVALUE = 0.000008\n[C0B]\nVALUE = 0.000022355737\n[EXX]\nGridpoints = {\n  0.0 0.0\n  100.0 0.005\n}  // end of EXX\n[EYX]\nGridpoints = {\n  0.0 0.0\n  50.0 0.001\n  100.0 0.0\n}\n[EYY]\nGridpoints = {\n 0 0\n 200 -0.004\n}\n[EZZ]\nGridpoints = {\n 0 0\n 100 0.002\n}\n[EAZ]\nGridpoints = {\n 0 0.00002\n 100 0.00002\n}\n";

    #[test]
    fn etalon_by_hand() {
        let p = parse_etalon(ETALON, "e.txt").unwrap();
        assert_eq!(p.constants.len(), 4);
        let m = to_model(&p, "e.txt", ETALON, Topology::SEED).unwrap();
        // C0Y = −12 µrad → S_xy = +12; B0Z = 6 → S_zx = 6; A0Z = 8 µrad → S_yz = −8.
        let s = m.model.kinematics.squareness;
        assert!(
            (s.xy_urad - 12.0).abs() < 1e-9
                && (s.zx_urad - 6.0).abs() < 1e-9
                && (s.yz_urad - -8.0).abs() < 1e-9,
            "{s:?}"
        );
        assert_eq!(m.not_used, vec!["C0B".to_string()]);
        assert!(
            m.assumed_zero.contains(&"EZX".to_string())
                && m.assumed_zero.contains(&"ECY".to_string())
        );
        // X's positions: the union 0, 50, 100; EXX at 50 interpolated: 2.5 µm.
        let x = &m.model.axes[0].forward;
        assert_eq!(x.positions_mm(), &[0.0, 50.0, 100.0]);
        assert!((x.linear_um.errors_um[1] - Vec3::new(2.5, 1.0, 0.0)).norm() < 1e-9);
        // EAZ = 20 µrad = 0.00002 rad.
        assert!((m.model.axes[2].forward.angular_urad.errors_um[0].x - 20.0).abs() < 1e-9);
        // At (50, 100, 50) with no tool: e = (2.5 + S_xy·100 + S_zx·50 µrad·mm, 1 − 2 + S_yz·50, 1)
        // = (2.5 + 1.2 + 0.3, −1 − 0.4, 1) µm; EAZ swings nothing at L = 0 (arm (0, 0, 0)).
        let e = m
            .model
            .deviation_um(Vec3::new(50.0, 100.0, 50.0), ALL_FORWARD, Components::All)
            .unwrap();
        assert!((e - Vec3::new(4.0, -1.4, 1.0)).norm() < 1e-6, "{e:?}");
    }

    #[test]
    fn isg_csv_reads_blocks_and_refuses_gaps() {
        let t = "// constants\nC0Y B0Z A0Z\n-0.000012 0.000006 0.000008\n#\nX EXX EYX\n0 0 0\n100 0.005 0\n#\nY EYY\n0 0\n200 -0.004\n#\nZ EZZ\n0 0\n100 0.002\n";
        let p = parse_isg_csv(t, "v.csv").unwrap();
        let m = to_model(&p, "v.csv", t, Topology::SEED).unwrap();
        assert!((m.model.kinematics.squareness.xy_urad - 12.0).abs() < 1e-9);
        assert!((m.model.axes[0].forward.linear_um.errors_um[1].x - 5.0).abs() < 1e-9);
        // EYX over 0 … 50 only while EXX goes to 100: refused, not extrapolated.
        let bad = "X EXX\n0 0\n100 0.001\n#\nX EYX\n0 0\n50 0.001\n#\nY EYY\n0 0\n1 0\n#\nZ EZZ\n0 0\n1 0\n";
        let p = parse_isg_csv(bad, "v.csv").unwrap();
        let e = to_model(&p, "v.csv", bad, Topology::SEED).unwrap_err();
        assert!(e.message.contains("EYX covers 0 … 50"), "{e}");
        let e = parse_isg_csv("X EXX\n0 0 1\n", "v.csv").unwrap_err();
        assert_eq!(e.row, 2);
        // A position error a model referred to X cannot hold.
        let t2 = "A0Y\n0.00001\n#\nX EXX\n0 0\n1 0\n#\nY EYY\n0 0\n1 0\n#\nZ EZZ\n0 0\n1 0\n";
        let p = parse_isg_csv(t2, "v.csv").unwrap();
        assert!(to_model(&p, "v.csv", t2, Topology::SEED)
            .unwrap_err()
            .message
            .contains("A0Y"));
    }
}
