//! A quick model of the machine from traces in the three planes: per axis
//! its scale error and backlash, the three squarenesses, and the lateral
//! play each trace sees, as an axis-table map (docs/design.md, "The
//! axis-table map") that `compensate` takes like any other.
//!
//! * Scale: each plane `(u, v)` gives the mismatch `s_u − s_v` and, from
//!   the radius, the mean `(s_u + s_v)/2` (a ballbar of calibrated length
//!   is assumed: the radius is read against the nominal length). The six
//!   equations in `s_x, s_y, s_z` are solved by least squares, each
//!   weighted by its uncertainty.
//! * Squareness: `S_xy`, `S_yz`, `S_zx` from their planes (the sign of
//!   docs/design.md: `e_x += S_xy·y + S_zx·z`, `e_y += S_yz·z`).
//! * Backlash: the mean of the axis' reversal steps in the two planes it
//!   moves in (four values), weighted by their uncertainties; it splits
//!   into the reverse table `+b/2` and the forward one `−b/2`.
//! * Lateral play of axis `a` across to axis `c`: from the plane of `a`
//!   and `c`, split the same way in the `c` column of `a`'s tables.
//!
//! * Cyclic error of an axis (when the fits had its pitch): the mean of
//!   its sine and cosine amplitudes in its two planes.
//!
//! What a ballbar cannot see is left at zero: positions along an axis
//! relative to one another (a constant offset), straightness beyond the
//! squareness line, angular errors.

use super::{BallbarError, Plane, TraceFit};
use crate::model::axis_table::{AxisTableMap, AxisTables, Table};
use volcomp_gcode::Vec3;

/// The quick model's values.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct QuickModel {
    /// Scale error of X, Y, Z (µm/m).
    pub scale_um_per_m: [f64; 3],
    /// Squareness S_xy, S_yz, S_zx (µrad).
    pub squareness_urad: [f64; 3],
    /// Backlash of X, Y, Z (µm).
    pub backlash_um: [f64; 3],
    /// Lateral play `[axis][across]` (µm).
    pub lateral_um: [[f64; 3]; 3],
    /// Cyclic error of X, Y, Z: pitch (mm), sine and cosine amplitude (µm),
    /// when the fits had a pitch for the axis.
    pub cyclic: [Option<(f64, f64, f64)>; 3],
}

/// A value and its standard uncertainty.
type Estimate = (f64, f64);

fn weighted_mean(values: &[(f64, f64)]) -> f64 {
    let (mut s, mut w) = (0.0, 0.0);
    for &(v, sd) in values {
        let wi = 1.0 / sd.max(1e-9).powi(2);
        s += wi * v;
        w += wi;
    }
    if w > 0.0 {
        s / w
    } else {
        0.0
    }
}

/// The quick model from fits of one trace per plane (`radius_mm` each);
/// `pitch_mm` the pitches the fits used (cyclic errors: the mean of the
/// axis' two planes).
pub fn quick_model(
    fits: &[(Plane, f64, &TraceFit)],
    pitch_mm: [Option<f64>; 3],
) -> Result<QuickModel, BallbarError> {
    for p in Plane::ALL {
        let n = fits.iter().filter(|f| f.0 == p).count();
        if n != 1 {
            return Err(BallbarError::new(format!(
                "the quick model needs one trace in each plane XY, YZ and ZX; {} {}",
                if n == 0 {
                    "none is in"
                } else {
                    "more than one is in"
                },
                p.name()
            )));
        }
    }
    let get = |f: &TraceFit, id: &str| {
        f.cause(id)
            .map(|c| (c.value, c.std))
            .ok_or_else(|| BallbarError::new(format!("the fit has no `{id}`")))
    };
    // Scale: rows (coefficients on s_x, s_y, s_z; value; sd), normal equations.
    let mut n = [[0.0; 3]; 3];
    let mut g = [0.0; 3];
    let mut squareness = [0.0; 3];
    let mut backlash: [Vec<(f64, f64)>; 3] = Default::default();
    let mut lateral = [[0.0; 3]; 3];
    let mut cyclic: [Vec<(Estimate, Estimate)>; 3] = Default::default();
    for &(plane, r, f) in fits {
        let (u, v) = plane.axes();
        let (nu, nv) = plane.axis_names();
        let (m, sm) = get(f, &format!("scale_mismatch_{}", plane.name()))?;
        let (dr, sr) = get(f, "radius")?;
        let mut rows = vec![];
        let mut a = [0.0; 3];
        a[u] = 1.0;
        a[v] = -1.0;
        rows.push((a, m, sm));
        let mut b = [0.0; 3];
        b[u] = r / 2000.0;
        b[v] = r / 2000.0;
        rows.push((b, dr, sr));
        for (a, y, sd) in rows {
            let w = 1.0 / sd.max(1e-9).powi(2);
            for i in 0..3 {
                g[i] += w * a[i] * y;
                for j in 0..3 {
                    n[i][j] += w * a[i] * a[j];
                }
            }
        }
        let k = match plane {
            Plane::XY => 0,
            Plane::YZ => 1,
            Plane::ZX => 2,
        };
        squareness[k] = get(f, &format!("squareness_{}", plane.name()))?.0;
        for (axis, name) in [(u, nu), (v, nv)] {
            for end in ['+', '-'] {
                backlash[axis].push(get(f, &format!("backlash_{name}{end}"))?);
            }
        }
        for (axis, name) in [(u, nu), (v, nv)] {
            if pitch_mm[axis].is_some() {
                cyclic[axis].push((
                    get(f, &format!("cyclic_{name}_sin"))?,
                    get(f, &format!("cyclic_{name}_cos"))?,
                ));
            }
        }
        lateral[u][v] = get(f, &format!("lateral_play_{nu}"))?.0;
        lateral[v][u] = get(f, &format!("lateral_play_{nv}"))?.0;
    }
    let s = solve3(n, g).ok_or_else(|| BallbarError::new("the scales are undetermined"))?;
    Ok(QuickModel {
        scale_um_per_m: s,
        squareness_urad: squareness,
        backlash_um: [0, 1, 2].map(|a| weighted_mean(&backlash[a])),
        lateral_um: lateral,
        cyclic: [0, 1, 2].map(|a| {
            pitch_mm[a].map(|p| {
                let sines: Vec<(f64, f64)> = cyclic[a].iter().map(|c| c.0).collect();
                let cosines: Vec<(f64, f64)> = cyclic[a].iter().map(|c| c.1).collect();
                (p, weighted_mean(&sines), weighted_mean(&cosines))
            })
        }),
    })
}

fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let m = crate::linalg::Matrix::from_fn(3, 3, |i, j| a[i][j]);
    let v = crate::linalg::Matrix::from_fn(3, 1, |i, _| b[i]);
    let x = crate::linalg::lu_solve(&m, &v)?;
    Some([x[(0, 0)], x[(1, 0)], x[(2, 0)]])
}

impl QuickModel {
    /// The model as an axis-table map over `range_mm` (per axis `[min, max]`).
    pub fn map(&self, range_mm: [[f64; 2]; 3]) -> Result<AxisTableMap, BallbarError> {
        for (a, r) in range_mm.iter().enumerate() {
            if !(r[0].is_finite() && r[1].is_finite() && r[0] < r[1]) {
                return Err(BallbarError::new(format!(
                    "{{range_mm}} of {} must be min < max; got {} to {}",
                    ["X", "Y", "Z"][a],
                    r[0],
                    r[1]
                )));
            }
        }
        let [sxy, syz, szx] = self.squareness_urad;
        let axes = [0, 1, 2].map(|a| {
            let table = |sign: f64| {
                // Two points carry a line; a cyclic error 24 per pitch
                // (linear interpolation within 1 % of its amplitude).
                let [lo, hi] = range_mm[a];
                let n = match self.cyclic[a] {
                    Some((p, _, _)) => ((hi - lo) / p * 24.0).ceil().max(1.0) as usize,
                    None => 1,
                };
                let positions_mm: Vec<f64> = (0..=n)
                    .map(|i| lo + (hi - lo) * i as f64 / n as f64)
                    .collect();
                let errors_um = positions_mm
                    .iter()
                    .map(|&x| {
                        let mut e = Vec3::ZERO;
                        e[a] =
                            self.scale_um_per_m[a] * x / 1000.0 + sign * self.backlash_um[a] / 2.0;
                        if let Some((p, sa, ca)) = self.cyclic[a] {
                            let w = 2.0 * std::f64::consts::PI * x / p;
                            e[a] += sa * w.sin() + ca * w.cos();
                        }
                        for c in 0..3 {
                            if c != a {
                                e[c] += sign * self.lateral_um[a][c] / 2.0;
                            }
                        }
                        match a {
                            1 => e[0] += sxy * x / 1000.0,
                            2 => {
                                e[0] += szx * x / 1000.0;
                                e[1] += syz * x / 1000.0;
                            }
                            _ => {}
                        }
                        e
                    })
                    .collect();
                Table {
                    positions_mm,
                    errors_um,
                }
            };
            AxisTables {
                forward: table(-1.0),
                reverse: table(1.0),
            }
        });
        Ok(AxisTableMap { axes, clamp: false })
    }
}
