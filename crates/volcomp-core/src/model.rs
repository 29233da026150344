//! What every error model gives: the deviation `e(q, s) = actual − commanded`
//! (design §1) at an axis position `q` with motion-direction state `s`.
//!
//! Compensation and simulation only talk to [`ErrorModel`], so richer models
//! (21-component kinematic, thermal, grids) plug in without touching them.

use crate::error::ModelError;
use volcomp_gcode::Vec3;

/// Direction of the most recent commanded motion of one axis (design §2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Direction {
    /// Increasing position.
    Forward,
    /// Decreasing position.
    Reverse,
}

impl Direction {
    /// The other direction.
    pub fn flipped(self) -> Direction {
        match self {
            Direction::Forward => Direction::Reverse,
            Direction::Reverse => Direction::Forward,
        }
    }

    /// `+1` forward, `−1` reverse.
    pub fn sign(self) -> f64 {
        match self {
            Direction::Forward => 1.0,
            Direction::Reverse => -1.0,
        }
    }

    /// The direction of a change `delta`, or `None` when it is zero.
    pub fn of_delta(delta: f64) -> Option<Direction> {
        if delta > 0.0 {
            Some(Direction::Forward)
        } else if delta < 0.0 {
            Some(Direction::Reverse)
        } else {
            None
        }
    }
}

/// Direction state of the three axes.
pub type Directions = [Direction; 3];

/// All axes forward: the state before any motion (design §2).
pub const ALL_FORWARD: Directions = [Direction::Forward; 3];

/// Which error components a model evaluation includes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Components {
    /// Every component of the model.
    All,
    /// Only the positioning errors E_XX, E_YY, E_ZZ: what an ordinary
    /// controller's pitch compensation already covers.
    PositioningOnly,
}

/// A volumetric error model of a 3-axis machine.
pub trait ErrorModel: Send + Sync {
    /// Deviation `e(q, s)` in µm at axis position `q_mm` (axis frame).
    fn deviation_um(
        &self,
        q_mm: Vec3,
        s: Directions,
        components: Components,
    ) -> Result<Vec3, ModelError>;

    /// The axis ranges the model is defined on, `[min, max]` per axis (mm).
    fn range_mm(&self) -> [[f64; 2]; 3];
}

/// `q + e(q, s)`: where the tool actually is when commanded to `q_mm`.
pub fn actual_mm(
    model: &dyn ErrorModel,
    q_mm: Vec3,
    s: Directions,
    components: Components,
) -> Result<Vec3, ModelError> {
    Ok(q_mm + model.deviation_um(q_mm, s, components)? * 1e-3)
}
