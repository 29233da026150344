//! Free-form surfaces: compensation of a finishing pass from on-machine
//! probing (the mirror method, [`mirror`]), on B-spline surfaces
//! ([`bspline`], algorithms of *The NURBS Book*).

pub mod bspline;
pub mod mirror;
