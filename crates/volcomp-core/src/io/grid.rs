//! The 3-D grid CSV: a model's deviation at every point of a regular grid
//! over its range (`x_mm,y_mm,z_mm,ex_um,ey_um,ez_um`), for tools that take
//! a volumetric table.

use crate::error::ModelError;
use crate::io::numfmt;
use crate::model::positioning::grid_axis;
use crate::model::{direction_letters, Components, Directions, ErrorModel};
use volcomp_gcode::Vec3;

/// The most points a grid may have (bounded memory and time on any range).
pub const MAX_POINTS: f64 = 5e6;

/// A grid could not be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GridError {
    /// The spacing gives more than [`MAX_POINTS`] points.
    #[error("a {step_mm} mm grid over this range has {points} points; choose a larger spacing")]
    TooManyPoints {
        /// The spacing asked for (mm).
        step_mm: f64,
        /// How many points it would give.
        points: f64,
    },
    /// The model failed at a grid point.
    #[error(transparent)]
    Model(#[from] ModelError),
}

/// The grid axes over `range_mm` at most `step_mm` apart, ends included,
/// or [`GridError::TooManyPoints`].
pub fn grid_axes(range_mm: [[f64; 2]; 3], step_mm: f64) -> Result<[Vec<f64>; 3], GridError> {
    let points: f64 = (0..3)
        .map(|k| {
            ((range_mm[k][1] - range_mm[k][0]) / step_mm)
                .ceil()
                .max(1.0)
                + 1.0
        })
        .product();
    if points > MAX_POINTS {
        return Err(GridError::TooManyPoints { step_mm, points });
    }
    Ok([0, 1, 2].map(|k| grid_axis(range_mm[k][0], range_mm[k][1], step_mm)))
}

/// The grid CSV of `model` every `step_mm` over its range, for the tool
/// `tool_offset_mm` and direction state `s`; `name` names the map in the
/// header comment. Returns the text and the number of points.
pub fn grid_csv(
    model: &dyn ErrorModel,
    name: &str,
    tool_offset_mm: Vec3,
    s: Directions,
    step_mm: f64,
) -> Result<(String, usize), GridError> {
    let axes = grid_axes(model.range_mm(), step_mm)?;
    let count = axes.iter().map(Vec::len).product::<usize>();
    let t = tool_offset_mm;
    let mut text = format!(
        "# volcomp 3-D grid of {name}: e = actual - commanded (µm) at axis positions (mm)\n# tool length offset {}, {}, {} mm; directions {} (X, Y, Z; + forward, - reverse)\nx_mm,y_mm,z_mm,ex_um,ey_um,ez_um\n",
        t.x,
        t.y,
        t.z,
        direction_letters(s)
    );
    for &x in &axes[0] {
        for &y in &axes[1] {
            for &z in &axes[2] {
                let q = Vec3::new(x, y, z);
                let e = model.deviation_with_tool_um(q, s, Components::All, tool_offset_mm)?;
                text.push_str(&format!(
                    "{},{},{},{},{},{}\n",
                    numfmt::mm(x),
                    numfmt::mm(y),
                    numfmt::mm(z),
                    numfmt::um(e.x),
                    numfmt::um(e.y),
                    numfmt::um(e.z)
                ));
            }
        }
    }
    Ok((text, count))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::axis_table::AxisTableMap;
    use crate::model::ALL_FORWARD;

    #[test]
    fn grid_of_a_linear_map() {
        // X: 0 → 2 µm over 0…10 mm; Y and Z zero; 10 mm cube, 5 mm step.
        let csv = "axis,direction,position_mm,ex_um,ey_um,ez_um\n\
                   X,both,0,0,0,0\nX,both,10,2,0,0\nY,both,0,0,0,0\nY,both,10,0,0,0\n\
                   Z,both,0,0,0,0\nZ,both,10,0,0,0\n";
        let m = AxisTableMap::from_csv(csv, "m.csv").unwrap();
        let (text, n) = grid_csv(&m, "m.csv", Vec3::ZERO, ALL_FORWARD, 5.0).unwrap();
        assert_eq!(n, 27);
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 3 + 27);
        assert!(lines[1].ends_with("directions +++ (X, Y, Z; + forward, - reverse)"));
        assert_eq!(lines[2], "x_mm,y_mm,z_mm,ex_um,ey_um,ez_um");
        // Z varies fastest, then Y, then X; the 10th point is x = 5, y = 0, z = 0: ex = 1 µm.
        let f: Vec<f64> = lines[3 + 9]
            .split(',')
            .map(|v| v.parse().unwrap())
            .collect();
        assert_eq!(f, vec![5.0, 0.0, 0.0, 1.0, 0.0, 0.0]);
    }

    #[test]
    fn too_fine_a_grid_is_refused() {
        let r = [[0.0, 1000.0]; 3];
        // 1001³ ≈ 1e9 points at 1 mm.
        let e = grid_axes(r, 1.0).unwrap_err();
        assert!(
            matches!(e, GridError::TooManyPoints { points, .. } if points == 1001.0f64.powi(3))
        );
        assert_eq!(grid_axes(r, 500.0).unwrap()[2], vec![0.0, 500.0, 1000.0]);
    }
}
