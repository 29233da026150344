//! Models from arrays, and evaluated over arrays: what a front end holding
//! numbers in arrays (Python's numpy) hands the library, checked here with
//! messages that name the argument (`what`).

use crate::error::ModelError;
use crate::model::axis_table::Table;
use crate::model::kinematic::{AngleConvention, ComponentTable, Kinematics, MeasuringLine};
use crate::model::topology::Topology;
use crate::model::{Components, Direction, Directions, ErrorModel};
use volcomp_gcode::Vec3;

/// One axis' table from positions (mm) and errors (µm, n×3 flattened by
/// rows): at least two points, finite, positions strictly increasing.
pub fn table(positions_mm: Vec<f64>, errors_um: &[f64], what: &str) -> Result<Table, String> {
    let n = positions_mm.len();
    if errors_um.len() != 3 * n {
        return Err(format!(
            "{what}: {n} positions but {} error values; give errors of shape ({n}, 3) in µm (along X, Y, Z)",
            errors_um.len()
        ));
    }
    if n < 2 {
        return Err(format!(
            "{what}: {n} point(s); give at least two points per table"
        ));
    }
    if let Some(i) = positions_mm.iter().position(|p| !p.is_finite()) {
        let p = positions_mm[i];
        return Err(format!(
            "{what}: position {i} is {p}; give finite positions in mm"
        ));
    }
    if let Some(i) = errors_um.iter().position(|e| !e.is_finite()) {
        let (row, column, e) = (i / 3, i % 3, errors_um[i]);
        return Err(format!(
            "{what}: error value at row {row}, column {column} is {e}; give finite errors in µm"
        ));
    }
    if let Some(i) = positions_mm.windows(2).position(|w| w[1] <= w[0]) {
        let (p, q) = (positions_mm[i + 1], positions_mm[i]);
        return Err(format!(
            "{what}: position {} ({p} mm) does not increase after {q} mm; list positions in strictly increasing order",
            i + 1
        ));
    }
    let errors_um = errors_um
        .chunks_exact(3)
        .map(|c| Vec3::new(c[0], c[1], c[2]))
        .collect();
    Ok(Table {
        positions_mm,
        errors_um,
    })
}

/// One direction of a 21-component model's axis: positions (mm), linear
/// errors (µm) and angular errors (µrad), each checked as [`table`].
pub fn component_table(
    positions_mm: Vec<f64>,
    linear_um: &[f64],
    angular_urad: &[f64],
    what: &str,
) -> Result<ComponentTable, String> {
    let lin = table(positions_mm.clone(), linear_um, what)?;
    let ang = table(positions_mm, angular_urad, what)?;
    ComponentTable::new(lin.positions_mm, lin.errors_um, ang.errors_um)
        .ok_or_else(|| format!("{what}: the table is not valid"))
}

/// The kinematics of a 21-component model as the keys of its file give
/// them: squareness (xy, yz, zx; µrad), where the linear errors were
/// measured (a point, mm, and a tool length, mm) and the angle convention
/// (`"relative"` or `"moving-part"`).
pub fn kinematics(
    topology: Topology,
    squareness_urad: [f64; 3],
    measuring_point_mm: [f64; 3],
    measuring_tool_length_mm: f64,
    angles: &str,
) -> Result<Kinematics, String> {
    let angles = match angles {
        "relative" => AngleConvention::Relative,
        "moving-part" => AngleConvention::MovingPart,
        a => {
            return Err(format!(
                "angles must be \"relative\" or \"moving-part\"; got {a:?}"
            ))
        }
    };
    let named = |vs: [f64; 3], what| vs.map(|v| (v, what));
    let values = named(squareness_urad, "squareness_urad")
        .into_iter()
        .chain(named(measuring_point_mm, "measuring_point_mm"))
        .chain([(measuring_tool_length_mm, "measuring_tool_length_mm")]);
    for (v, what) in values {
        if !v.is_finite() {
            return Err(format!("{what} must be finite; got {v}"));
        }
    }
    let [px, py, pz] = measuring_point_mm;
    let mut k = Kinematics::new(topology);
    k.measuring = [MeasuringLine {
        point_mm: Vec3::new(px, py, pz),
        tool_offset_mm: Vec3::new(0.0, 0.0, measuring_tool_length_mm),
    }; 3];
    [
        k.squareness.xy_urad,
        k.squareness.yz_urad,
        k.squareness.zx_urad,
    ] = squareness_urad;
    k.angles = angles;
    Ok(k)
}

/// What a point outside the model's range gives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outside {
    /// The evaluation stops with the point's row.
    Raise,
    /// Its row is NaN.
    Nan,
}

impl Outside {
    /// `"raise"` or `"nan"`.
    pub fn parse(text: &str) -> Result<Outside, String> {
        match text {
            "raise" => Ok(Outside::Raise),
            "nan" => Ok(Outside::Nan),
            o => Err(format!("outside must be \"raise\" or \"nan\"; got {o:?}")),
        }
    }
}

/// Checks that every direction is +1 or −1 (n×3 flattened by rows).
pub fn check_directions(dirs: &[f64]) -> Result<(), String> {
    match dirs.iter().position(|x| *x != 1.0 && *x != -1.0) {
        Some(i) => Err(format!(
            "directions: row {}, column {} is {}; give +1 (forward) or -1 (reverse)",
            i / 3,
            i % 3,
            dirs[i]
        )),
        None => Ok(()),
    }
}

/// Evaluates `e` at every row of `q_mm` (N×3, mm) with the directions of
/// `dirs` (N×3 or 1×3, ±1) and tool offsets `tool_mm` (N×3 or 1×3, mm) into
/// `out_um` (N×3, µm). `Err((row, error))` at the first point outside the
/// model's range unless `outside` is `Nan`.
pub fn deviations_um(
    model: &dyn ErrorModel,
    (q_mm, dirs, tool_mm): (&[f64], &[f64], &[f64]),
    components: Components,
    outside: Outside,
    out_um: &mut [f64],
) -> Result<(), (usize, ModelError)> {
    let dir = |v: f64| {
        if v < 0.0 {
            Direction::Reverse
        } else {
            Direction::Forward
        }
    };
    let row = |v: &[f64], i: usize| if v.len() > 3 { 3 * i } else { 0 };
    let uses_tool = model.uses_tool_offset();
    for i in 0..q_mm.len() / 3 {
        let q = Vec3::new(q_mm[3 * i], q_mm[3 * i + 1], q_mm[3 * i + 2]);
        let d = row(dirs, i);
        let s: Directions = [dir(dirs[d]), dir(dirs[d + 1]), dir(dirs[d + 2])];
        let e = if uses_tool {
            let t = row(tool_mm, i);
            let tool = Vec3::new(tool_mm[t], tool_mm[t + 1], tool_mm[t + 2]);
            model.deviation_with_tool_um(q, s, components, tool)
        } else {
            model.deviation_um(q, s, components)
        };
        match e {
            Ok(e) => out_um[3 * i..3 * i + 3].copy_from_slice(&[e.x, e.y, e.z]),
            Err(_) if outside == Outside::Nan => out_um[3 * i..3 * i + 3].fill(f64::NAN),
            Err(err) => return Err((i, err)),
        }
    }
    Ok(())
}

/// An ISO 230-1 component's name (`EXX`, `EZX`, `EBY`, any case) as
/// (axis, the component's direction 0–2, angular).
pub fn component_name(name: &str) -> Result<(usize, usize, bool), String> {
    let b = name.to_ascii_uppercase().into_bytes();
    let axis = b
        .get(2)
        .and_then(|c| [b'X', b'Y', b'Z'].iter().position(|a| a == c));
    let dir = b.get(1).and_then(|c| b"XYZABC".iter().position(|a| a == c));
    match (b.len(), b.first(), axis, dir) {
        (3, Some(b'E'), Some(axis), Some(d)) => Ok((axis, d % 3, d >= 3)),
        _ => Err(format!(
            "unknown component {name:?}; use ISO 230-1 names: EXX, EYX, EZX, EAX, EBX, ECX (and the same for Y and Z)"
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn component_names_by_hand() {
        assert_eq!(component_name("EXX"), Ok((0, 0, false)));
        assert_eq!(component_name("ezy"), Ok((1, 2, false)));
        assert_eq!(component_name("EBZ"), Ok((2, 1, true)));
        for bad in ["EX", "EXXX", "EXW", "FXX", "EQX"] {
            assert!(component_name(bad)
                .unwrap_err()
                .contains("unknown component"));
        }
    }

    #[test]
    fn a_table_is_checked_and_read_by_rows() {
        let t = table(vec![0.0, 100.0], &[0.0, 0.0, 0.0, 10.0, 2.0, 0.0], "x").unwrap();
        assert_eq!(t.errors_um[1], Vec3::new(10.0, 2.0, 0.0));
        let e = table(vec![10.0, 0.0], &[0.0; 6], "x").unwrap_err();
        assert!(
            e.contains("position 1 (0 mm) does not increase after 10 mm"),
            "{e}"
        );
        let e = table(vec![0.0, 1.0], &[0.0, 0.0, 0.0, 0.0, f64::NAN, 0.0], "x").unwrap_err();
        assert!(e.contains("row 1, column 1 is NaN"), "{e}");
        assert!(table(vec![0.0], &[0.0; 3], "x").is_err());
    }

    #[test]
    fn directions_are_plus_or_minus_one() {
        assert!(check_directions(&[1.0, -1.0, 1.0]).is_ok());
        let e = check_directions(&[1.0, 1.0, 1.0, 1.0, 0.5, 1.0]).unwrap_err();
        assert!(e.starts_with("directions: row 1, column 1 is 0.5"), "{e}");
        assert_eq!(Outside::parse("nan"), Ok(Outside::Nan));
        assert!(Outside::parse("clip").is_err());
    }
}
