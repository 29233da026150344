//! The flags of `volcomp surface` (free-form surfaces): clap structures
//! only; `commands::surface` turns them into library options.

use super::MachineArgs;
use clap::{Args, Subcommand, ValueEnum};
use std::path::PathBuf;
use volcomp_core::surface::bspline::Parameterization;
use volcomp_core::surface::mirror::{advice, FitMethod, MaterialSide, MirrorError};

/// Free-form surfaces.
#[derive(Args, Debug)]
pub struct SurfaceArgs {
    #[command(subcommand)]
    pub command: SurfaceCommand,
}

#[derive(Subcommand, Debug)]
pub enum SurfaceCommand {
    /// Mirror compensation: fit the probed error of a semi-finished surface and
    /// move a ball-end finishing program so that it lands on the nominal.
    Mirror(MirrorArgs),
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum Material {
    /// Below the surface (−Z): the tool comes from above.
    Below,
    /// Above the surface (+Z).
    Above,
    /// The surface's own normal (Su × Sv) points out of the material.
    NormalOut,
    /// The surface's own normal (Su × Sv) points into the material.
    NormalIn,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum Fit {
    /// Bicubic least squares, the control net chosen by leave-one-out
    /// cross-validation (any probe pattern).
    LeastSquares,
    /// Bicubic interpolation through every point (probe grid with i,j columns).
    Interpolate,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum GridParams {
    /// Chord length, averaged over the grid rows.
    ChordLength,
    /// Centripetal (square root of the chord length), averaged.
    Centripetal,
    /// Equally spaced.
    Uniform,
}

#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum Cl {
    /// The tool tip (the ball centre is one radius above it, +Z).
    Tip,
    /// The ball centre.
    Center,
}

#[derive(Args, Debug)]
pub struct MirrorArgs {
    /// Nominal finishing surface: a B-spline surface (.toml) or a grid of
    /// points (.csv), in the program frame.
    #[arg(long, value_name = "SURF")]
    pub nominal: PathBuf,
    /// Probe points of the semi-finished part (CSV: x_mm,y_mm,z_mm; optional id, i, j).
    #[arg(long, value_name = "POINTS")]
    pub measured: PathBuf,
    /// Stock D the semi-finishing pass leaves on the nominal surface (mm).
    #[arg(long, value_name = "D")]
    pub stock: f64,
    /// Which side of the surface the material is on.
    #[arg(long, value_enum, default_value_t = Material::Below)]
    pub material: Material,
    /// Probe ball radius (mm) when the points are ball centres; leave out when
    /// the probing software already compensated it.
    #[arg(long, value_name = "MM")]
    pub probe_radius: Option<f64>,
    /// Largest accepted distance of a probe point from where it should be
    /// (nominal + stock), in mm; farther points are refused as mismatched.
    #[arg(long, value_name = "MM", default_value_t = 0.1)]
    pub max_error: f64,
    /// How the compensation points are fitted.
    #[arg(long, value_enum, default_value_t = Fit::LeastSquares)]
    pub fit: Fit,
    /// Only consider control nets whose residual at every compensation point is within
    /// this (µm). Every residual includes the probe noise: give at least 3× its σ.
    /// Without it the net is chosen by leave-one-out cross-validation alone.
    #[arg(long, value_name = "UM")]
    pub tolerance: Option<f64>,
    /// Refuse (write nothing, exit non-zero) when the leave-one-out prediction of the
    /// finishing error after compensation is worse (larger std) than not compensating;
    /// without it a warning is printed.
    #[arg(long)]
    pub refuse_worse: bool,
    /// Parameters used to interpolate a grid nominal (CSV).
    #[arg(long, value_enum, default_value_t = GridParams::ChordLength)]
    pub grid_params: GridParams,
    /// Base name of the compensated surface files BASE.csv (grid) and
    /// BASE.toml (B-spline) [default: POINTS without extension + ".compensated"].
    #[arg(long, value_name = "BASE")]
    pub surface_out: Option<PathBuf>,
    /// Nodes per direction of the compensated grid when the nominal is a
    /// B-spline (a grid nominal keeps its own nodes).
    #[arg(long, value_name = "N", default_value_t = 41)]
    pub grid_size: usize,
    /// Ball-end finishing program to compensate.
    #[arg(long, value_name = "PROGRAM", requires_all = ["output", "tool_radius"])]
    pub finishing: Option<PathBuf>,
    /// The compensated finishing program.
    #[arg(short, long, value_name = "OUT", requires = "finishing")]
    pub output: Option<PathBuf>,
    /// Also write the finishing program with the tool-radius baseline (a
    /// constant offset that only removes the mean error), for comparison.
    #[arg(long, value_name = "FILE", requires = "finishing")]
    pub baseline: Option<PathBuf>,
    /// Ball radius of the finishing tool (mm; half its diameter).
    #[arg(long, value_name = "MM")]
    pub tool_radius: Option<f64>,
    /// Which point of the tool the program's coordinates give.
    #[arg(long, value_enum, default_value_t = Cl::Tip)]
    pub cl_point: Cl,
    /// A CL point is on the surface when its ball is this close to it (mm).
    #[arg(long, value_name = "MM", default_value_t = 0.02)]
    pub contact_tolerance: f64,
    /// Split feed moves into pieces of at most this length (mm).
    #[arg(long, value_name = "MM", default_value_t = 2.0)]
    pub segment_length: f64,
    /// Do not split feed moves (arcs are still linearised).
    #[arg(long)]
    pub no_split: bool,
    /// Decimal places of written coordinates (default 5 in mm, 6 in inch).
    #[arg(long)]
    pub decimals: Option<u8>,
    /// Do not tag inserted lines with `(volcomp Ln)` comments.
    #[arg(long)]
    pub no_trace: bool,
    #[command(flatten)]
    pub machine: MachineArgs,
    /// Write a report: .json (summary and every point), .html (a
    /// self-contained page with the statistics and the probe points) or CSV
    /// (one row per point, the summary in `#` lines).
    #[arg(long, value_name = "FILE")]
    pub report: Option<PathBuf>,
    /// Print the summary as one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Compensate a finishing program that volcomp compensated already.
    #[arg(long)]
    pub allow_recompensate: bool,
}

impl MirrorArgs {
    /// The material side the flags give.
    pub fn material_side(&self) -> MaterialSide {
        match self.material {
            Material::Below => MaterialSide::Below,
            Material::Above => MaterialSide::Above,
            Material::NormalOut => MaterialSide::NormalOut,
            Material::NormalIn => MaterialSide::NormalIn,
        }
    }

    /// The parameters of a grid nominal the flags give.
    pub fn grid_parameterization(&self) -> Parameterization {
        match self.grid_params {
            GridParams::ChordLength => Parameterization::ChordLength,
            GridParams::Centripetal => Parameterization::Centripetal,
            GridParams::Uniform => Parameterization::Uniform,
        }
    }

    /// The fit the flags give.
    pub fn fit_method(&self) -> FitMethod {
        match self.fit {
            Fit::LeastSquares => FitMethod::LeastSquares {
                tolerance_um: self.tolerance,
            },
            Fit::Interpolate => FitMethod::Interpolate,
        }
    }
}

/// The library's advice (`surface::mirror::advice`) in terms of this
/// command's flags.
const FLAG_HELP: &[(&str, &str)] = &[
    (
        advice::STOCK_POSITIVE,
        "pass --stock with the allowance the semi-finishing pass leaves, e.g. 0.2",
    ),
    (advice::MAX_ERROR_POSITIVE, "pass --max-error in mm, e.g. 0.1"),
    (
        advice::STOCK_TOO_LARGE,
        "check --stock (mm), the material side (--material), and that the nominal is the finishing surface; a smaller probe ball helps",
    ),
    (
        advice::MATERIAL_REVERSED,
        "the material side looks reversed: check --material",
    ),
    (
        advice::POINT_OFF,
        "check the stock (--stock), the probe radius (--probe-radius), the frame of the points (the program's work coordinates), or raise --max-error if the part is really this far off",
    ),
    (
        advice::OVERHANG,
        "a 3-axis ball-end pass cannot reach an overhang; if the surface is not a height field, say the side with --material normal-out or normal-in",
    ),
    (advice::TOLERANCE_POSITIVE, "pass --tolerance in µm, e.g. 1"),
    (
        advice::TOLERANCE_UNMET,
        "leave --tolerance out (the fit is then chosen by leave-one-out cross-validation), or loosen it: every residual includes the probe noise, so it must exceed about 3 σ of the noise",
    ),
    (
        advice::INTERPOLATION_NEEDS_GRID,
        "--fit interpolate needs a complete probe grid: i,j columns with one point per node",
    ),
    (
        advice::INTERPOLATION_NEEDS_INDICES,
        "--fit interpolate needs a complete probe grid: i,j columns with one point per node; or use --fit least-squares for scattered points",
    ),
    (
        advice::GRID_OFF_PARAMETER_LINES,
        "use --fit least-squares, which takes every point where it lies",
    ),
    (advice::INTERPOLATION_FAILED, "use --fit least-squares"),
    (
        advice::TOOL_RADIUS_POSITIVE,
        "pass --tool-radius with the ball-end mill's radius in mm (half its diameter)",
    ),
    (
        advice::CONTACT_TOLERANCE_POSITIVE,
        "pass --contact-tolerance in mm, e.g. 0.02",
    ),
    (
        advice::BALL_TOO_LARGE,
        "check --tool-radius (a radius, not a diameter) and --material",
    ),
    (
        advice::SEGMENT_LENGTH_POSITIVE,
        "pass --segment-length in mm, or --no-split",
    ),
    (
        advice::NO_CONTACT,
        "check --tool-radius and --cl-point, and that the program and the surface share a frame (work offset, G43 tool length) and units",
    ),
];

/// A refusal of the mirror method with its help naming this command's
/// flags where the library's names an option.
pub fn flag_help(mut e: MirrorError) -> MirrorError {
    if let MirrorError::File(volcomp_core::error::MapFileError { help, .. })
    | MirrorError::InFile { help, .. }
    | MirrorError::Method { help, .. } = &mut e
    {
        if let Some((_, flags)) = FLAG_HELP.iter().find(|(lib, _)| lib == help) {
            *help = (*flags).to_string();
        }
    }
    e
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_advice_has_distinct_flag_help_that_names_a_flag() {
        for (k, (lib, flags)) in FLAG_HELP.iter().enumerate() {
            assert!(!lib.contains("--"), "{lib}");
            assert!(flags.contains("--"), "{flags}");
            assert!(
                FLAG_HELP[k + 1..].iter().all(|(other, _)| other != lib),
                "{lib} twice"
            );
        }
        let e = flag_help(MirrorError::Method {
            message: "m".into(),
            help: advice::MATERIAL_REVERSED.into(),
        });
        assert_eq!(
            e.to_string(),
            "m\n  help: the material side looks reversed: check --material"
        );
    }
}
