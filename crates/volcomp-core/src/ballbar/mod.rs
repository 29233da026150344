//! The circular test with a telescoping ballbar [ISO 230-4]: the trace a
//! ballbar records on a machine with an error model ([`predict`]), the
//! figures of the standard ([`figures`]: circular deviation G, circular
//! hysteresis H, radial deviation F), the causes a service engineer reads
//! from a trace, fitted by least squares with their uncertainties
//! ([`fit`], signatures in closed form to first order in the error
//! [Kakino et al. 1993]), the quick model of scale, squareness and backlash
//! built from traces in the three planes ([`quick_map`]), and the LinuxCNC
//! program that runs the test ([`program`]). docs/ballbar.md explains them.
//!
//! Conventions. A test runs in a plane with axes `(u, v)`: XY `(X, Y)`,
//! YZ `(Y, Z)`, ZX `(Z, X)` (G17, G19, G18). The angle `θ` turns from `u`
//! toward `v`, which is the sense of G3 in every plane: counter-clockwise
//! (ccw) runs have `θ` increasing. A trace's radial deviation is the
//! ballbar's length minus its nominal length `R`, µm, positive when the
//! balls are farther apart; the ballbar's pivot sits at the nominal centre.

pub mod figures;
pub mod fit;
pub mod predict;
pub mod program;
pub mod quick_map;
pub mod report;
pub mod trace;

pub use figures::{figures, Figures};
pub use fit::{fit, Cause, FitOptions, TraceFit};
pub use predict::{predict, TestCircle};

use volcomp_gcode::Vec3;

/// The plane of a circular test.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub enum Plane {
    /// `u = X`, `v = Y` (G17).
    XY,
    /// `u = Y`, `v = Z` (G19).
    YZ,
    /// `u = Z`, `v = X` (G18).
    ZX,
}

impl Plane {
    /// Every plane, in the order of the quick model's three tests.
    pub const ALL: [Plane; 3] = [Plane::XY, Plane::YZ, Plane::ZX];

    /// The axis indices `(u, v)`.
    pub fn axes(self) -> (usize, usize) {
        match self {
            Plane::XY => (0, 1),
            Plane::YZ => (1, 2),
            Plane::ZX => (2, 0),
        }
    }

    /// The axis names `(u, v)`.
    pub fn axis_names(self) -> (char, char) {
        let (u, v) = self.axes();
        (b"XYZ"[u] as char, b"XYZ"[v] as char)
    }

    /// The plane-selection G-code.
    pub fn gcode(self) -> &'static str {
        match self {
            Plane::XY => "G17",
            Plane::YZ => "G19",
            Plane::ZX => "G18",
        }
    }

    /// The name as written in files (`XY`, `YZ`, `ZX`).
    pub fn name(self) -> &'static str {
        match self {
            Plane::XY => "XY",
            Plane::YZ => "YZ",
            Plane::ZX => "ZX",
        }
    }

    /// Reads `XY`, `YZ`, `ZX` (either case; `YX`, `ZY`, `XZ` too).
    pub fn parse(text: &str) -> Option<Plane> {
        match text.trim().to_ascii_uppercase().as_str() {
            "XY" | "YX" => Some(Plane::XY),
            "YZ" | "ZY" => Some(Plane::YZ),
            "ZX" | "XZ" => Some(Plane::ZX),
            _ => None,
        }
    }

    /// The point at angle `theta_rad` on the circle of `radius_mm` about `centre_mm`.
    pub fn point(self, centre_mm: Vec3, radius_mm: f64, theta_rad: f64) -> Vec3 {
        let (u, v) = self.axes();
        let mut p = centre_mm;
        p[u] += radius_mm * theta_rad.cos();
        p[v] += radius_mm * theta_rad.sin();
        p
    }
}

/// The sense of travel of one run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub enum Sense {
    /// Counter-clockwise: `θ` increasing (G3).
    Ccw,
    /// Clockwise: `θ` decreasing (G2).
    Cw,
}

impl Sense {
    /// `+1` counter-clockwise, `−1` clockwise.
    pub fn sign(self) -> f64 {
        match self {
            Sense::Ccw => 1.0,
            Sense::Cw => -1.0,
        }
    }

    /// The name as written in files (`ccw`, `cw`).
    pub fn name(self) -> &'static str {
        match self {
            Sense::Ccw => "ccw",
            Sense::Cw => "cw",
        }
    }

    /// Reads `ccw`/`cw` (also `anticlockwise`, `clockwise`, `G3`, `G2`).
    pub fn parse(text: &str) -> Option<Sense> {
        match text.trim().to_ascii_lowercase().as_str() {
            "ccw" | "anticlockwise" | "counterclockwise" | "g3" => Some(Sense::Ccw),
            "cw" | "clockwise" | "g2" => Some(Sense::Cw),
            _ => None,
        }
    }
}

/// One run of a trace: the samples in the order they were taken.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Run {
    /// The sense of travel.
    pub sense: Sense,
    /// Angle of each sample, degrees in `[0, 360)`, from `u` toward `v`.
    pub angle_deg: Vec<f64>,
    /// Radial deviation of each sample, µm.
    pub deviation_um: Vec<f64>,
}

/// A ballbar trace: one or two runs on one circle.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Trace {
    /// The test plane.
    pub plane: Plane,
    /// The ballbar's nominal length (mm).
    pub radius_mm: f64,
    /// The pivot: the circle's nominal centre in the axis frame (mm).
    pub centre_mm: [f64; 3],
    /// The programmed feed (mm/min).
    pub feed_mm_per_min: f64,
    /// The runs (at most one per sense).
    pub runs: Vec<Run>,
}

impl Trace {
    /// The run of sense `s`, if the trace has one.
    pub fn run(&self, s: Sense) -> Option<&Run> {
        self.runs.iter().find(|r| r.sense == s)
    }
}

pub use crate::error::BallbarError;

#[cfg(test)]
mod tests;
