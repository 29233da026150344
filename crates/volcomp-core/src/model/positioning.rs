//! Positioning tables `E_aa` (one axis, forward and reverse): what a
//! controller's pitch compensation holds (LinuxCNC comp files, ISO 230-2
//! mean deviations), and their conversions to and from the models.

use crate::model::axis_table::{AxisTableMap, AxisTables, Table};
use crate::model::kinematic::KinematicModel;
use volcomp_gcode::Vec3;
use volcomp_geom::Axis;

/// The positioning error of one axis per direction, in volcomp's sign
/// (`e = actual − commanded`).
#[derive(Debug, Clone, PartialEq)]
pub struct Positioning {
    /// Commanded positions (mm), strictly increasing.
    pub positions_mm: Vec<f64>,
    /// `E_aa` while moving forward (µm).
    pub forward_um: Vec<f64>,
    /// `E_aa` while moving in reverse (µm).
    pub reverse_um: Vec<f64>,
}

/// Evenly spaced points from `lo_mm` to `hi_mm` inclusive, at most
/// `step_mm` apart (the last one is `hi_mm` itself, not a rounded sum).
///
/// ```
/// use volcomp_core::model::positioning::grid_axis;
/// assert_eq!(grid_axis(0.0, 100.0, 25.0), vec![0.0, 25.0, 50.0, 75.0, 100.0]);
/// ```
pub fn grid_axis(lo_mm: f64, hi_mm: f64, step_mm: f64) -> Vec<f64> {
    let n = (((hi_mm - lo_mm) / step_mm).ceil() as usize).max(1);
    (0..=n)
        .map(|k| {
            if k == n {
                hi_mm
            } else {
                lo_mm + (hi_mm - lo_mm) * k as f64 / n as f64
            }
        })
        .collect()
}

impl Positioning {
    /// A table from its positions (mm, strictly increasing) and its values
    /// forward and in reverse (µm), as written by hand.
    pub fn new(positions_mm: &[f64], forward_um: &[f64], reverse_um: &[f64]) -> Self {
        Positioning {
            positions_mm: positions_mm.to_vec(),
            forward_um: forward_um.to_vec(),
            reverse_um: reverse_um.to_vec(),
        }
    }

    /// Points the table has when resampled every `step_mm` (both ends
    /// kept); `None` for a step that is not a positive finite length.
    pub fn resampled_points(&self, step_mm: f64) -> Option<u64> {
        let p = &self.positions_mm;
        let span = p.last()? - p.first()?;
        (step_mm.is_finite() && step_mm > 0.0).then(|| (span / step_mm).ceil() as u64 + 1)
    }

    /// The table resampled every `step_mm` over its range (linear
    /// interpolation, both ends kept): a spacing a controller with a fixed
    /// number of entries can hold. The table needs at least two points and
    /// `step_mm` must be positive.
    pub fn resample(&self, step_mm: f64) -> Positioning {
        let p = &self.positions_mm;
        let n = p.len();
        let (lo, hi) = (p[0], p[n - 1]);
        let positions = grid_axis(lo, hi, step_mm);
        let at = |v: &[f64], x: f64| -> f64 {
            let i = p.partition_point(|&q| q <= x).clamp(1, n - 1) - 1;
            let (x0, x1) = (p[i], p[i + 1]);
            v[i] + (v[i + 1] - v[i]) * (x - x0) / (x1 - x0)
        };
        Positioning {
            forward_um: positions.iter().map(|&x| at(&self.forward_um, x)).collect(),
            reverse_um: positions.iter().map(|&x| at(&self.reverse_um, x)).collect(),
            positions_mm: positions,
        }
    }
}

impl AxisTableMap {
    /// `E_aa` of axis `a` at the union of its forward and reverse positions
    /// (each table held at its end value outside its range, as a
    /// controller's table would).
    pub fn positioning(&self, axis: Axis) -> Positioning {
        let a = axis.index();
        let mut positions: Vec<f64> = self.axes[a]
            .forward
            .positions_mm
            .iter()
            .chain(&self.axes[a].reverse.positions_mm)
            .copied()
            .collect();
        positions.sort_by(f64::total_cmp);
        positions.dedup();
        let along = |table: &Table| -> Vec<f64> {
            let [lo, hi] = table.range();
            positions
                .iter()
                .map(|&x| table.eval(x.clamp(lo, hi)).map(|v| v[a]).unwrap_or(0.0))
                .collect()
        };
        Positioning {
            forward_um: along(&self.axes[a].forward),
            reverse_um: along(&self.axes[a].reverse),
            positions_mm: positions,
        }
    }

    /// Axis tables holding only the positioning errors `p` (X, Y, Z); not clamped.
    pub fn from_positioning(p: &[Positioning; 3]) -> AxisTableMap {
        let axes = [0, 1, 2].map(|a| {
            let table = |v: &[f64]| Table {
                positions_mm: p[a].positions_mm.clone(),
                errors_um: v
                    .iter()
                    .map(|e| {
                        let mut w = Vec3::ZERO;
                        w[a] = *e;
                        w
                    })
                    .collect(),
            };
            AxisTables {
                forward: table(&p[a].forward_um),
                reverse: table(&p[a].reverse_um),
            }
        });
        AxisTableMap { axes, clamp: false }
    }
}

impl KinematicModel {
    /// The positioning errors `E_aa` of axis `a` as tabulated: see
    /// [`KinematicModel::positioning`].
    pub fn positioning_table(&self, axis: Axis) -> Positioning {
        let (positions_mm, forward_um, reverse_um) = self.positioning(axis);
        Positioning {
            positions_mm,
            forward_um,
            reverse_um,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_axis_ends_on_the_range() {
        assert_eq!(
            grid_axis(0.0, 100.0, 25.0),
            vec![0.0, 25.0, 50.0, 75.0, 100.0]
        );
        // 90 / 25 = 3.6 → 4 intervals of 22.5 mm.
        assert_eq!(
            grid_axis(0.0, 90.0, 25.0),
            vec![0.0, 22.5, 45.0, 67.5, 90.0]
        );
        // A step longer than the range: the two ends.
        assert_eq!(grid_axis(-5.0, 5.0, 100.0), vec![-5.0, 5.0]);
    }

    #[test]
    fn resample_interpolates_linearly() {
        let p = Positioning::new(&[0.0, 10.0, 30.0], &[0.0, 10.0, 30.0], &[4.0, 4.0, 0.0]);
        let r = p.resample(10.0);
        assert_eq!(r.positions_mm, vec![0.0, 10.0, 20.0, 30.0]);
        assert_eq!(r.forward_um, vec![0.0, 10.0, 20.0, 30.0]);
        // Reverse: 4 at 10, 0 at 30 → 2 at 20.
        assert_eq!(r.reverse_um, vec![4.0, 4.0, 2.0, 0.0]);
    }

    fn table(positions: &[f64], e: &[f64], a: usize) -> Table {
        Table {
            positions_mm: positions.to_vec(),
            errors_um: e
                .iter()
                .map(|&v| {
                    let mut w = Vec3::new(9.0, 9.0, 9.0);
                    w[a] = v;
                    w
                })
                .collect(),
        }
    }

    #[test]
    fn positioning_of_tables_takes_the_union_and_holds_the_ends() {
        let both = |a| AxisTables {
            forward: table(&[0.0, 10.0], &[0.0, 1.0], a),
            reverse: table(&[0.0, 10.0], &[0.0, 1.0], a),
        };
        let mut map = AxisTableMap {
            axes: [both(0), both(1), both(2)],
            clamp: false,
        };
        map.axes[0].reverse = table(&[5.0, 20.0], &[2.0, 5.0], 0);
        let p = map.positioning(Axis::X);
        assert_eq!(p.positions_mm, vec![0.0, 5.0, 10.0, 20.0]);
        // Forward 0→1 over 0…10, held at 1 beyond.
        assert_eq!(p.forward_um, vec![0.0, 0.5, 1.0, 1.0]);
        // Reverse 2→5 over 5…20 (0.2 µm/mm), held at 2 below 5.
        assert_eq!(p.reverse_um, vec![2.0, 2.0, 3.0, 5.0]);
    }

    #[test]
    fn tables_of_positioning_hold_only_the_axis_own_column() {
        let p = |k: f64| Positioning::new(&[0.0, 100.0], &[0.0, k], &[1.0, k + 1.0]);
        let m = AxisTableMap::from_positioning(&[p(2.0), p(3.0), p(4.0)]);
        assert!(!m.clamp);
        assert_eq!(m.axes[1].forward.errors_um[1], Vec3::new(0.0, 3.0, 0.0));
        assert_eq!(m.axes[2].reverse.errors_um[0], Vec3::new(0.0, 0.0, 1.0));
        // And back: the positioning of the tables is what went in.
        assert_eq!(m.positioning(Axis::Y), p(3.0));
    }
}
