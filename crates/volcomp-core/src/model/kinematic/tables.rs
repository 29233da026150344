//! Conversions between the 21-component model and tables: axis tables for
//! one tool, positioning tables, and a model from axis tables.

use super::{AxisComponents, ComponentTable, Form, KinematicModel, Kinematics};
use crate::error::ModelError;
use crate::model::axis_table::{AxisTableMap, AxisTables, Table};
use crate::model::positioning::grid_axis;
use crate::model::topology::Topology;
use crate::model::Direction;
use volcomp_gcode::Vec3;
use volcomp_geom::Axis;

impl KinematicModel {
    /// The axis-table map (docs/design.md, "The axis-table map") that reproduces this model, for one
    /// tool, along the three lines through a reference point `r`.
    ///
    /// Axis `a`'s table in direction `d` at its own table positions `x`:
    ///
    /// ```text
    /// E_a^d(x) = e(r with q_a = x) − e(r) + c_a^d,   c_a^d = what a contributes at r
    /// ```
    ///
    /// (`e` with axis `a` in direction `d`, the others forward), so the
    /// table sum equals the model on the three lines through `r`, exactly in
    /// the first-order form and up to products of errors of two different
    /// axes (nanometres) in the HTM form; it includes the Abbe terms of every
    /// axis at `r` and this tool, and the cross terms `ε_b × (x − r_a)` of the
    /// axes `b` before `a` in the chain. Away from those lines an axis-table
    /// model cannot hold the products of one axis' angle and another axis'
    /// position: that part is lost.
    ///
    /// The positioning column `E_aa` is never touched by the cross terms (a
    /// rotation moves a point across its arm, not along it); at the axis'
    /// measuring point and tool it is exactly the model's `E_aa`.
    pub fn to_axis_tables(
        &self,
        reference_mm: Vec3,
        tool_offset_mm: Vec3,
        form: Form,
    ) -> Result<AxisTableMap, ModelError> {
        let r = reference_mm;
        let mut axes = Vec::with_capacity(3);
        for a in 0..3 {
            let table = |d: Direction| -> Result<Table, ModelError> {
                let mut s = [Direction::Forward; 3];
                s[a] = d;
                let at_r = self.deviation_form_um(r, s, tool_offset_mm, form)?;
                let own = self.axis_contribution_um(a, r, d, tool_offset_mm, form)?;
                let positions = self.axes[a].table(d).positions_mm().to_vec();
                let mut errors = Vec::with_capacity(positions.len());
                for &x in &positions {
                    let mut q = r;
                    q[a] = x;
                    let e = self.deviation_form_um(q, s, tool_offset_mm, form)?;
                    errors.push(e - at_r + own);
                }
                Ok(Table {
                    positions_mm: positions,
                    errors_um: errors,
                })
            };
            axes.push(AxisTables {
                forward: table(Direction::Forward)?,
                reverse: table(Direction::Reverse)?,
            });
        }
        let mut it = axes.into_iter();
        match (it.next(), it.next(), it.next()) {
            (Some(x), Some(y), Some(z)) => Ok(AxisTableMap {
                axes: [x, y, z],
                clamp: self.clamp,
            }),
            _ => unreachable!("three axes were pushed"),
        }
    }

    /// The positioning errors `E_aa` of axis `a` as tabulated (µm), forward
    /// and reverse at the union of both tables' positions (each table held
    /// at its end value outside its range, as a controller's table would).
    pub fn positioning(&self, axis: Axis) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let a = axis.index();
        let positions = self.positions_mm(axis);
        let along = |t: &ComponentTable| -> Vec<f64> {
            let [lo, hi] = t.range();
            positions
                .iter()
                .map(|&x| {
                    t.linear_um
                        .eval(x.clamp(lo, hi))
                        .map(|v| v[a])
                        .unwrap_or(0.0)
                })
                .collect()
        };
        let f = along(&self.axes[a].forward);
        let r = along(&self.axes[a].reverse);
        (positions, f, r)
    }

    /// A model with the linear tables of an axis-table map (docs/design.md, "The axis-table map") and
    /// no angular errors: the same deviations everywhere (exactly, see
    /// [`Kinematics::htm_um`]), ready to receive measured angles.
    pub fn from_axis_tables(map: &AxisTableMap, topology: Topology) -> Self {
        let axes = [0, 1, 2].map(|a| {
            let t = |table: &Table| ComponentTable {
                linear_um: table.clone(),
                angular_urad: Table {
                    positions_mm: table.positions_mm.clone(),
                    errors_um: vec![Vec3::ZERO; table.positions_mm.len()],
                },
            };
            AxisComponents {
                forward: t(&map.axes[a].forward),
                reverse: t(&map.axes[a].reverse),
            }
        });
        let mut m = KinematicModel::new(axes, Kinematics::new(topology));
        m.clamp = map.clamp;
        m
    }

    /// The union of the table positions of axis `a` (both directions).
    pub fn positions_mm(&self, axis: Axis) -> Vec<f64> {
        let a = axis.index();
        let mut p: Vec<f64> = self.axes[a]
            .forward
            .positions_mm()
            .iter()
            .chain(self.axes[a].reverse.positions_mm())
            .copied()
            .collect();
        p.sort_by(f64::total_cmp);
        p.dedup();
        p
    }

    /// The measuring point (axis positions, mm) and the measuring tool offset
    /// (mm) shared by the three axes' measuring lines, each `None` when the
    /// axes were measured along different lines or with different tools.
    pub fn shared_measuring(&self) -> (Option<Vec3>, Option<Vec3>) {
        let l = self.kinematics.measuring;
        let p = (l[0].point_mm == l[1].point_mm && l[1].point_mm == l[2].point_mm)
            .then_some(l[0].point_mm);
        let t = (l[0].tool_offset_mm == l[1].tool_offset_mm
            && l[1].tool_offset_mm == l[2].tool_offset_mm)
            .then_some(l[0].tool_offset_mm);
        (p, t)
    }

    /// The largest `|e_model − e_tables|` (µm) over a 5×5×5 grid of the
    /// model's range, all axes forward, for the tool `tool_offset_mm`: how
    /// far axis tables made by [`KinematicModel::to_axis_tables`] stray from
    /// the model away from their reference lines.
    pub fn largest_difference_um(
        &self,
        tool_offset_mm: Vec3,
        map: &AxisTableMap,
    ) -> Result<f64, ModelError> {
        use crate::model::{Components, ErrorModel};
        let r = self.range_mm();
        let axes: Vec<Vec<f64>> = (0..3)
            .map(|a| grid_axis(r[a][0], r[a][1], (r[a][1] - r[a][0]) / 4.0))
            .collect();
        let mut worst: f64 = 0.0;
        for &x in &axes[0] {
            for &y in &axes[1] {
                for &z in &axes[2] {
                    let q = Vec3::new(x, y, z);
                    let s = [Direction::Forward; 3];
                    let e = self.deviation_with_tool_um(q, s, Components::All, tool_offset_mm)?;
                    let t = map.deviation_um(q, s, Components::All)?;
                    worst = worst.max((e - t).norm());
                }
            }
        }
        Ok(worst)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::kinematic::MeasuringLine;

    fn flat() -> KinematicModel {
        let t = ComponentTable::zeros(vec![0.0, 100.0]).unwrap();
        let axes = [0, 1, 2].map(|_| AxisComponents::both(t.clone()));
        KinematicModel::new(axes, Kinematics::new(Topology::SEED))
    }

    #[test]
    fn shared_measuring_only_when_all_three_agree() {
        let mut m = flat();
        let line = MeasuringLine {
            point_mm: Vec3::new(1.0, 2.0, 3.0),
            tool_offset_mm: Vec3::new(0.0, 0.0, 50.0),
        };
        m.kinematics.measuring = [line; 3];
        assert_eq!(
            m.shared_measuring(),
            (
                Some(Vec3::new(1.0, 2.0, 3.0)),
                Some(Vec3::new(0.0, 0.0, 50.0))
            )
        );
        m.kinematics.measuring[2].point_mm.x = 9.0;
        assert_eq!(
            m.shared_measuring(),
            (None, Some(Vec3::new(0.0, 0.0, 50.0)))
        );
        m.kinematics.measuring[1].tool_offset_mm.z = 0.0;
        assert_eq!(m.shared_measuring(), (None, None));
    }

    #[test]
    fn largest_difference_of_a_shifted_map() {
        // The model is zero everywhere; tables with a constant 3 µm in X on
        // the X axis and 4 µm in Y on the Y axis differ from it by |(3, 4, 0)| = 5 µm.
        let m = flat();
        let mut map = m.to_axis_tables(Vec3::ZERO, Vec3::ZERO, Form::Htm).unwrap();
        for e in map.axes[0].forward.errors_um.iter_mut() {
            e.x = 3.0;
        }
        for e in map.axes[1].forward.errors_um.iter_mut() {
            e.y = 4.0;
        }
        let d = m.largest_difference_um(Vec3::ZERO, &map).unwrap();
        assert!((d - 5.0).abs() < 1e-12, "{d}");
    }
}
