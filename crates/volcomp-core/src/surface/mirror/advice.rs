//! The `help` texts of the mirror method's refusals that point at one of its
//! options. They speak of the options (the stock, the material side…), not
//! of any command line's flags; a front end that names its flags can
//! recognise these texts (they are constants) and say its own.

/// The stock is not a positive length.
pub const STOCK_POSITIVE: &str =
    "give the stock: the allowance the semi-finishing pass leaves, in mm, e.g. 0.2";
/// The largest accepted error is not positive.
pub const MAX_ERROR_POSITIVE: &str = "give the largest accepted error in mm, e.g. 0.1";
/// The stock is too large for the surface's curvature.
pub const STOCK_TOO_LARGE: &str = "check the stock (mm), the material side, and that the nominal is the finishing surface; a smaller probe ball helps";
/// A probe point lies on the material side: the side looks reversed.
pub const MATERIAL_REVERSED: &str = "the material side looks reversed: check it";
/// A probe point is farther from the nominal than the stock allows.
pub const POINT_OFF: &str = "check the stock, the probe radius, the frame of the points (the program's work coordinates), or raise the largest accepted error if the part is really this far off";
/// The surface faces away from the tool with the material below or above.
pub const OVERHANG: &str = "a 3-axis ball-end pass cannot reach an overhang; if the surface is not a height field, give the material side by the surface's own normal (normal out or normal in)";
/// The fitting tolerance is not positive.
pub const TOLERANCE_POSITIVE: &str = "give the fitting tolerance in µm, e.g. 1";
/// No control net fits within the tolerance.
pub const TOLERANCE_UNMET: &str = "leave the tolerance out (the fit is then chosen by leave-one-out cross-validation), or loosen it: every residual includes the probe noise, so it must exceed about 3 σ of the noise";
/// Interpolation needs a complete grid.
pub const INTERPOLATION_NEEDS_GRID: &str =
    "interpolation needs a complete probe grid: i,j columns with one point per node";
/// Interpolation of points without grid indices.
pub const INTERPOLATION_NEEDS_INDICES: &str = "interpolation needs a complete probe grid: i,j columns with one point per node; or fit by least squares for scattered points";
/// The probe grid does not follow the parameter lines.
pub const GRID_OFF_PARAMETER_LINES: &str =
    "fit by least squares, which takes every point where it lies";
/// Interpolation failed.
pub const INTERPOLATION_FAILED: &str = "fit by least squares";
/// The tool radius is not positive.
pub const TOOL_RADIUS_POSITIVE: &str = "give the ball-end mill's radius in mm (half its diameter)";
/// The contact tolerance is not positive.
pub const CONTACT_TOLERANCE_POSITIVE: &str = "give the contact tolerance in mm, e.g. 0.02";
/// The ball is larger than the surface's concave radius.
pub const BALL_TOO_LARGE: &str =
    "check the tool radius (a radius, not a diameter) and the material side";
/// The segment length is not positive.
pub const SEGMENT_LENGTH_POSITIVE: &str = "give the segment length in mm, or do not split";
/// No CL point of the finishing program touches the surface.
pub const NO_CONTACT: &str = "check the tool radius and the CL point, and that the program and the surface share a frame (work offset, G43 tool length) and units";
