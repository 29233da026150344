//! The `help` texts of the mirror method's refusals that point at one of its
//! options. They name the options as `{name}` (the names of the mirror
//! request's options, `crate::request`); a front end writes each its own
//! way (`--stock`, `stock_mm`).

/// The stock is not a positive length.
pub const STOCK_POSITIVE: &str =
    "give the stock ({stock_mm}): the allowance the semi-finishing pass leaves, in mm, e.g. 0.2";
/// The largest accepted error is not positive.
pub const MAX_ERROR_POSITIVE: &str =
    "give the largest accepted error ({max_error_mm}) in mm, e.g. 0.1";
/// The stock is too large for the surface's curvature.
pub const STOCK_TOO_LARGE: &str = "check the stock ({stock_mm}, mm), the material side ({material}), and that the nominal is the finishing surface; a smaller probe ball helps";
/// A probe point lies on the material side: the side looks reversed.
pub const MATERIAL_REVERSED: &str = "the material side looks reversed: check {material}";
/// A probe point is farther from the nominal than the stock allows.
pub const POINT_OFF: &str = "check the stock ({stock_mm}), the probe radius ({probe_radius_mm}), the frame of the points (the program's work coordinates), or raise {max_error_mm} if the part is really this far off";
/// The surface faces away from the tool with the material below or above.
pub const OVERHANG: &str = "a 3-axis ball-end pass cannot reach an overhang; if the surface is not a height field, give the material side ({material}) by the surface's own normal: normal-out or normal-in";
/// The fitting tolerance is not positive.
pub const TOLERANCE_POSITIVE: &str = "give the fitting tolerance ({tolerance_um}) in µm, e.g. 1";
/// No control net fits within the tolerance.
pub const TOLERANCE_UNMET: &str = "leave the tolerance ({tolerance_um}) out (the fit is then chosen by leave-one-out cross-validation), or loosen it: every residual includes the probe noise, so it must exceed about 3 σ of the noise";
/// Interpolation needs a complete grid.
pub const INTERPOLATION_NEEDS_GRID: &str =
    "interpolation ({fit} interpolate) needs a complete probe grid: i,j columns with one point per node";
/// Interpolation of points without grid indices.
pub const INTERPOLATION_NEEDS_INDICES: &str = "interpolation ({fit} interpolate) needs a complete probe grid: i,j columns with one point per node; or fit by least squares ({fit} least-squares) for scattered points";
/// The probe grid does not follow the parameter lines.
pub const GRID_OFF_PARAMETER_LINES: &str =
    "fit by least squares ({fit} least-squares), which takes every point where it lies";
/// Interpolation failed.
pub const INTERPOLATION_FAILED: &str = "fit by least squares ({fit} least-squares)";
/// The tool radius is not positive.
pub const TOOL_RADIUS_POSITIVE: &str =
    "give the ball-end mill's radius ({tool_radius_mm}) in mm (half its diameter)";
/// The contact tolerance is not positive.
pub const CONTACT_TOLERANCE_POSITIVE: &str =
    "give the contact tolerance ({contact_tolerance_mm}) in mm, e.g. 0.02";
/// The ball is larger than the surface's concave radius.
pub const BALL_TOO_LARGE: &str =
    "check the tool radius ({tool_radius_mm}: a radius, not a diameter) and the material side ({material})";
/// The segment length is not positive.
pub const SEGMENT_LENGTH_POSITIVE: &str =
    "give the segment length ({segment_length_mm}) in mm, or do not split ({no_split})";
/// No CL point of the finishing program touches the surface.
pub const NO_CONTACT: &str = "check the tool radius ({tool_radius_mm}) and the CL point ({cl_point}), and that the program and the surface share a frame (work offset, G43 tool length) and units";
