//! The small amount of 3-D vocabulary the G-code engine needs: units and
//! arc planes here, [`Vec3`] and [`Axis`] from the bottom layer
//! `volcomp-geom` (re-exported so `volcomp_gcode::geom::Vec3` keeps working).

pub use volcomp_geom::{Axis, Vec3};

/// Length units of a program or a file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Units {
    /// Millimetres (G21).
    Mm,
    /// Inches (G20).
    Inch,
}

impl Units {
    /// Millimetres per unit.
    #[inline]
    pub const fn mm_per_unit(self) -> f64 {
        match self {
            Units::Mm => 1.0,
            Units::Inch => 25.4,
        }
    }
}

/// The arc plane: G17 (XY), G18 (ZX) or G19 (YZ).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Plane {
    /// G17: arcs in XY, helix along Z.
    Xy,
    /// G18: arcs in ZX (first axis Z, second X), helix along Y.
    Zx,
    /// G19: arcs in YZ, helix along X.
    Yz,
}

impl Plane {
    /// Axis indices `(u, v, w)`: the plane's first and second axes, then the
    /// helix axis, ordered so that G3 is counter-clockwise in `(u, v)` as in
    /// RS274/NGC's canonical ARC_FEED.
    #[inline]
    pub const fn axes(self) -> (usize, usize, usize) {
        match self {
            Plane::Xy => (0, 1, 2),
            Plane::Zx => (2, 0, 1),
            Plane::Yz => (1, 2, 0),
        }
    }
}
