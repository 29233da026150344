//! A point or vector in 3-D, in millimetres.

use crate::Axis;
use std::iter::Sum;
use std::ops::{
    Add, AddAssign, Div, DivAssign, Index, IndexMut, Mul, MulAssign, Neg, Sub, SubAssign,
};

/// A point or vector in millimetres (axis frame unless a name says otherwise).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Vec3 {
    /// X component.
    pub x: f64,
    /// Y component.
    pub y: f64,
    /// Z component.
    pub z: f64,
}

impl Vec3 {
    /// The origin.
    pub const ZERO: Vec3 = Vec3::new(0.0, 0.0, 0.0);

    /// Builds a vector.
    #[inline]
    pub const fn new(x: f64, y: f64, z: f64) -> Self {
        Self { x, y, z }
    }

    /// Builds a vector from an array.
    #[inline]
    pub const fn from_array(a: [f64; 3]) -> Self {
        Self::new(a[0], a[1], a[2])
    }

    /// The components as an array.
    #[inline]
    pub const fn to_array(self) -> [f64; 3] {
        [self.x, self.y, self.z]
    }

    /// Dot product.
    #[inline]
    pub fn dot(self, o: Vec3) -> f64 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    /// Euclidean norm.
    #[inline]
    pub fn norm(self) -> f64 {
        self.dot(self).sqrt()
    }

    /// Largest absolute component.
    #[inline]
    pub fn max_abs(self) -> f64 {
        self.x.abs().max(self.y.abs()).max(self.z.abs())
    }

    /// Whether every component is finite.
    #[inline]
    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.z.is_finite()
    }

    /// Linear interpolation `self + t·(o − self)`.
    #[inline]
    pub fn lerp(self, o: Vec3, t: f64) -> Vec3 {
        self + (o - self) * t
    }

    /// Component-wise map.
    #[inline]
    pub fn map(self, f: impl Fn(f64) -> f64) -> Vec3 {
        Vec3::new(f(self.x), f(self.y), f(self.z))
    }

    /// Cross product `self × o` (right-handed: X × Y = Z).
    #[inline]
    pub fn cross(self, o: Vec3) -> Vec3 {
        Vec3::new(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }

    /// Squared Euclidean norm (no square root).
    #[inline]
    pub fn norm_squared(self) -> f64 {
        self.dot(self)
    }

    /// Euclidean distance to `o`.
    #[inline]
    pub fn distance(self, o: Vec3) -> f64 {
        (o - self).norm()
    }

    /// The unit vector along `self`, or `None` when its norm is zero or
    /// not finite (a direction is never invented).
    #[inline]
    pub fn normalized(self) -> Option<Vec3> {
        let n = self.norm();
        (n > 0.0 && n.is_finite()).then(|| self / n)
    }

    /// Component-wise absolute value.
    #[inline]
    pub fn abs(self) -> Vec3 {
        self.map(f64::abs)
    }

    /// The component along `axis`.
    #[inline]
    pub fn get(self, axis: Axis) -> f64 {
        self[axis]
    }

    /// A copy with the component along `axis` replaced by `value`.
    #[inline]
    pub fn with(mut self, axis: Axis, value: f64) -> Vec3 {
        self[axis] = value;
        self
    }
}

impl Add for Vec3 {
    type Output = Vec3;
    #[inline]
    fn add(self, o: Vec3) -> Vec3 {
        Vec3::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl AddAssign for Vec3 {
    #[inline]
    fn add_assign(&mut self, o: Vec3) {
        *self = *self + o;
    }
}

impl Sub for Vec3 {
    type Output = Vec3;
    #[inline]
    fn sub(self, o: Vec3) -> Vec3 {
        Vec3::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

impl SubAssign for Vec3 {
    #[inline]
    fn sub_assign(&mut self, o: Vec3) {
        *self = *self - o;
    }
}

impl Mul<f64> for Vec3 {
    type Output = Vec3;
    #[inline]
    fn mul(self, k: f64) -> Vec3 {
        Vec3::new(self.x * k, self.y * k, self.z * k)
    }
}

impl Mul<Vec3> for f64 {
    type Output = Vec3;
    #[inline]
    fn mul(self, v: Vec3) -> Vec3 {
        v * self
    }
}

impl MulAssign<f64> for Vec3 {
    #[inline]
    fn mul_assign(&mut self, k: f64) {
        *self = *self * k;
    }
}

impl Div<f64> for Vec3 {
    type Output = Vec3;
    #[inline]
    fn div(self, k: f64) -> Vec3 {
        Vec3::new(self.x / k, self.y / k, self.z / k)
    }
}

impl DivAssign<f64> for Vec3 {
    #[inline]
    fn div_assign(&mut self, k: f64) {
        *self = *self / k;
    }
}

impl Sum for Vec3 {
    fn sum<I: Iterator<Item = Vec3>>(iter: I) -> Vec3 {
        iter.fold(Vec3::ZERO, Add::add)
    }
}

impl Neg for Vec3 {
    type Output = Vec3;
    #[inline]
    fn neg(self) -> Vec3 {
        Vec3::new(-self.x, -self.y, -self.z)
    }
}

impl Index<usize> for Vec3 {
    type Output = f64;
    #[inline]
    fn index(&self, i: usize) -> &f64 {
        match i {
            0 => &self.x,
            1 => &self.y,
            2 => &self.z,
            _ => panic!("axis index {i} out of range 0..3"),
        }
    }
}

impl IndexMut<usize> for Vec3 {
    #[inline]
    fn index_mut(&mut self, i: usize) -> &mut f64 {
        match i {
            0 => &mut self.x,
            1 => &mut self.y,
            2 => &mut self.z,
            _ => panic!("axis index {i} out of range 0..3"),
        }
    }
}

impl Index<Axis> for Vec3 {
    type Output = f64;
    #[inline]
    fn index(&self, a: Axis) -> &f64 {
        match a {
            Axis::X => &self.x,
            Axis::Y => &self.y,
            Axis::Z => &self.z,
        }
    }
}

impl IndexMut<Axis> for Vec3 {
    #[inline]
    fn index_mut(&mut self, a: Axis) -> &mut f64 {
        match a {
            Axis::X => &mut self.x,
            Axis::Y => &mut self.y,
            Axis::Z => &mut self.z,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const A: Vec3 = Vec3::new(1.0, 2.0, 3.0);
    const B: Vec3 = Vec3::new(4.0, -5.0, 6.0);

    #[test]
    fn cross_of_the_unit_axes_is_right_handed() {
        let (x, y, z) = (
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
        );
        assert_eq!(x.cross(y), z);
        assert_eq!(y.cross(z), x);
        assert_eq!(z.cross(x), y);
        assert_eq!(y.cross(x), -z);
    }

    #[test]
    fn cross_by_hand() {
        // (2·6 − 3·(−5), 3·4 − 1·6, 1·(−5) − 2·4) = (27, 6, −13)
        assert_eq!(A.cross(B), Vec3::new(27.0, 6.0, -13.0));
        // Orthogonal to both factors: 27 + 12 − 39 = 0, 108 − 30 − 78 = 0.
        assert_eq!(A.cross(B).dot(A), 0.0);
        assert_eq!(A.cross(B).dot(B), 0.0);
        assert_eq!(A.cross(A), Vec3::ZERO);
    }

    #[test]
    fn dot_norms_and_distance_by_hand() {
        // 4 − 10 + 18 = 12
        assert_eq!(A.dot(B), 12.0);
        assert_eq!(A.norm_squared(), 14.0);
        assert_eq!(Vec3::new(3.0, 4.0, 12.0).norm(), 13.0);
        // B − A = (3, −7, 3): 9 + 49 + 9 = 67
        assert_eq!(A.distance(B), 67f64.sqrt());
        assert_eq!(B.max_abs(), 6.0);
        assert_eq!(B.abs(), Vec3::new(4.0, 5.0, 6.0));
    }

    #[test]
    fn normalized_is_a_unit_vector_or_none() {
        assert_eq!(
            Vec3::new(0.0, 3.0, 4.0).normalized(),
            Some(Vec3::new(0.0, 0.6, 0.8))
        );
        assert_eq!(Vec3::ZERO.normalized(), None);
        assert_eq!(Vec3::new(f64::INFINITY, 0.0, 0.0).normalized(), None);
        assert_eq!(Vec3::new(f64::NAN, 1.0, 0.0).normalized(), None);
    }

    #[test]
    fn arithmetic_by_hand() {
        assert_eq!(A + B, Vec3::new(5.0, -3.0, 9.0));
        assert_eq!(A - B, Vec3::new(-3.0, 7.0, -3.0));
        assert_eq!(A * 2.0, Vec3::new(2.0, 4.0, 6.0));
        assert_eq!(2.0 * A, Vec3::new(2.0, 4.0, 6.0));
        assert_eq!(B / 2.0, Vec3::new(2.0, -2.5, 3.0));
        let mut v = A;
        v *= 3.0;
        assert_eq!(v, Vec3::new(3.0, 6.0, 9.0));
        v /= 3.0;
        assert_eq!(v, A);
        v += B;
        v -= A;
        assert_eq!(v, B);
        assert_eq!([A, B, -A].into_iter().sum::<Vec3>(), B);
        assert_eq!(A.lerp(B, 0.5), Vec3::new(2.5, -1.5, 4.5));
        assert_eq!(A.map(|c| c * c), Vec3::new(1.0, 4.0, 9.0));
        assert_eq!(Vec3::from_array([1.0, 2.0, 3.0]), A);
        assert_eq!(A.to_array(), [1.0, 2.0, 3.0]);
    }

    #[test]
    fn indexing_by_axis_and_by_number_agree() {
        for a in Axis::ALL {
            assert_eq!(B[a], B[a.index()]);
            assert_eq!(B.get(a), B[a.index()]);
        }
        assert_eq!((B[Axis::X], B[Axis::Y], B[Axis::Z]), (4.0, -5.0, 6.0));
        let mut v = Vec3::ZERO;
        v[Axis::Y] = 7.0;
        assert_eq!(v, Vec3::new(0.0, 7.0, 0.0));
        assert_eq!(v.with(Axis::Z, -1.0), Vec3::new(0.0, 7.0, -1.0));
    }

    #[test]
    fn serde_is_a_struct_of_x_y_z() {
        let text = serde_json::to_string(&A).unwrap();
        assert_eq!(text, r#"{"x":1.0,"y":2.0,"z":3.0}"#);
        assert_eq!(serde_json::from_str::<Vec3>(&text).unwrap(), A);
    }
}
