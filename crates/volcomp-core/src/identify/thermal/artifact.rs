//! The ball-array artifact: spheres on a line with calibrated distances,
//! placed at several positions and orientations in the working volume.
//!
//! Sign (docs/design.md, "Deviation sign"): commanded to `q` the machine puts the probe at
//! `q + e(q)`. It touches a sphere whose true centre is `s` when
//! `q + e(q) = s`, and it reports the commanded (scale) coordinates, so the
//! **measured centre is `m = s − e(s)`** to first order. A distance between
//! two measured centres therefore changes by `−u·(e(s_j) − e(s_i))`.

use crate::rng::Rng;
use volcomp_gcode::Vec3;

/// A ball array: calibrated distance of every sphere from sphere 1 (mm),
/// the first being 0, strictly increasing.
#[derive(Debug, Clone, PartialEq)]
pub struct BallArray {
    /// Calibrated distances from sphere 1 (mm).
    pub distances_mm: Vec<f64>,
}

impl BallArray {
    /// `n` spheres `pitch_mm` apart.
    pub fn uniform(n: usize, pitch_mm: f64) -> Self {
        Self {
            distances_mm: (0..n).map(|i| i as f64 * pitch_mm).collect(),
        }
    }

    /// Number of spheres.
    pub fn len(&self) -> usize {
        self.distances_mm.len()
    }

    /// Whether there are no spheres.
    pub fn is_empty(&self) -> bool {
        self.distances_mm.is_empty()
    }
}

/// One placement: where sphere 1 sits and the unit direction of the array.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// Centre of sphere 1 (machine coordinates, mm).
    pub start_mm: Vec3,
    /// Direction of the array (normalised on construction).
    pub direction: Vec3,
}

impl Placement {
    /// A placement from sphere 1 towards `end_mm` (the direction only).
    pub fn between(start_mm: Vec3, end_mm: Vec3) -> Self {
        let d = end_mm - start_mm;
        Self {
            start_mm,
            direction: d * (1.0 / d.norm()),
        }
    }

    /// True sphere centres (mm).
    pub fn centres_mm(&self, array: &BallArray) -> Vec<Vec3> {
        array
            .distances_mm
            .iter()
            .map(|&d| self.start_mm + self.direction * d)
            .collect()
    }
}

/// Standard placements in a box `ranges_mm` (fractions of each range):
/// three lines along each axis at different offsets (9), two diagonals in
/// planes parallel to each coordinate plane, at different offsets (6) the four body diagonals (4) and three oblique lines
/// in further directions (3), 22 in all. Each array (`array_length_mm`
/// from sphere 1 to the last) is centred on its line; it must not be longer
/// than the shortest travel, or the axis-parallel lines stick out of the box.
///
/// A line only sees the deviation as a polynomial in the position along it
/// (degree `n` along an axis, `n + 1` across axes for order `n`), minus its
/// constant, so it contributes at most `n + 1` independent numbers however
/// many spheres the array has: with order 3 (39 visible parameters on the
/// seed chain) eight placements cannot identify everything; the leading (cubic
/// and quartic) coefficients along a line depend on its direction only, so
/// more *directions* — not more offsets — are needed: these 22 (16
/// directions) identify every parameter the chain lets the probe see. The
/// first eight (one line per axis, one diagonal per coordinate plane, two body
/// diagonals) are the study's eight orientations.
pub fn standard_placements(ranges_mm: [[f64; 2]; 3], array_length_mm: f64) -> Vec<Placement> {
    let at = |f: [f64; 3]| {
        Vec3::new(
            ranges_mm[0][0] + f[0] * (ranges_mm[0][1] - ranges_mm[0][0]),
            ranges_mm[1][0] + f[1] * (ranges_mm[1][1] - ranges_mm[1][0]),
            ranges_mm[2][0] + f[2] * (ranges_mm[2][1] - ranges_mm[2][0]),
        )
    };
    let lines = [
        ([0.0, 0.2, 0.2], [1.0, 0.2, 0.2]),
        ([0.8, 0.0, 0.8], [0.8, 1.0, 0.8]),
        ([0.2, 0.8, 0.0], [0.2, 0.8, 1.0]),
        ([0.0, 0.0, 0.2], [1.0, 1.0, 0.2]),
        ([0.0, 0.8, 1.0], [1.0, 0.8, 0.0]),
        ([0.2, 0.0, 0.0], [0.2, 1.0, 1.0]),
        ([0.0, 0.0, 0.0], [1.0, 1.0, 1.0]),
        ([1.0, 0.0, 1.0], [0.0, 1.0, 0.0]),
        ([0.0, 0.8, 0.8], [1.0, 0.8, 0.8]),
        ([0.0, 0.2, 0.8], [1.0, 0.2, 0.8]),
        ([0.2, 0.0, 0.2], [0.2, 1.0, 0.2]),
        ([0.8, 0.0, 0.2], [0.8, 1.0, 0.2]),
        ([0.8, 0.8, 0.0], [0.8, 0.8, 1.0]),
        ([0.2, 0.2, 0.0], [0.2, 0.2, 1.0]),
        ([1.0, 0.0, 0.8], [0.0, 1.0, 0.8]),
        ([0.0, 0.2, 0.0], [1.0, 0.2, 1.0]),
        ([0.8, 1.0, 0.0], [0.8, 0.0, 1.0]),
        ([0.0, 1.0, 0.0], [1.0, 0.0, 1.0]),
        ([1.0, 1.0, 0.0], [0.0, 0.0, 1.0]),
        ([0.0, 0.1, 0.3], [1.0, 0.6, 0.9]),
        ([0.1, 0.0, 0.9], [0.6, 1.0, 0.1]),
        ([0.9, 0.2, 0.0], [0.1, 0.5, 1.0]),
    ];
    lines
        .iter()
        .map(|&(a, b)| {
            let (a, b) = (at(a), at(b));
            let len = (b - a).norm();
            let mid = (a + b) * 0.5;
            let u = (b - a) * (1.0 / len);
            let half = 0.5 * array_length_mm;
            Placement {
                start_mm: mid - u * half,
                direction: u,
            }
        })
        .collect()
}

/// Measured sphere centres of one placement in one cycle (mm).
#[derive(Debug, Clone, PartialEq)]
pub struct PlacementMeasurement {
    /// Measured centres, sphere 1 first.
    pub centres_mm: Vec<Vec3>,
}

/// Simulates measuring `placement`: `m = s − e(s) + noise`, with `e` in µm
/// from `deviation_um` and independent normal probing noise of
/// `noise_um` per coordinate.
pub fn simulate_measurement(
    array: &BallArray,
    placement: &Placement,
    deviation_um: &dyn Fn(Vec3) -> Vec3,
    noise_um: f64,
    rng: &mut Rng,
) -> PlacementMeasurement {
    let centres_mm = placement
        .centres_mm(array)
        .into_iter()
        .map(|s| {
            let n = Vec3::new(rng.normal(), rng.normal(), rng.normal()) * noise_um;
            s - (deviation_um(s) - n) * 1e-3
        })
        .collect();
    PlacementMeasurement { centres_mm }
}

/// Observations of one placement: `d_j = |m_j − m_1| − D_j` (µm) for
/// spheres `j = 2 … N`, with the unit direction `u_j = (m_j − m_1)/|m_j − m_1|`.
pub fn observations(array: &BallArray, m: &PlacementMeasurement) -> Vec<(f64, Vec3)> {
    let c = &m.centres_mm;
    (1..c.len().min(array.len()))
        .map(|j| {
            let d = c[j] - c[0];
            let len = d.norm();
            ((len - array.distances_mm[j]) * 1e3, d * (1.0 / len))
        })
        .collect()
}
