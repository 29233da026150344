//! The flags of `volcomp surface` (free-form surfaces): the library's mirror
//! request (`volcomp_core::request::MirrorRequest`) and the files this
//! command writes.

use crate::options::Options;
use clap::{Args, Subcommand};
use std::path::PathBuf;
use volcomp_core::request::MirrorRequest;

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

#[derive(Args, Debug)]
pub struct MirrorArgs {
    #[command(flatten)]
    pub job: Options<MirrorRequest>,
    /// Base name of the compensated surface files BASE.csv (grid) and
    /// BASE.toml (B-spline) [default: POINTS without extension + ".compensated"].
    #[arg(long, value_name = "BASE")]
    pub surface_out: Option<PathBuf>,
    /// The compensated finishing program (with --finishing).
    #[arg(short, long, value_name = "OUT", requires = "finishing")]
    pub output: Option<PathBuf>,
    /// Also write the finishing program with the tool-radius baseline (a
    /// constant offset that only removes the mean error), for comparison.
    #[arg(long, value_name = "FILE", requires = "finishing")]
    pub baseline: Option<PathBuf>,
    /// Write a report: .json (summary and every point), .html (a
    /// self-contained page with the statistics and the probe points) or CSV
    /// (one row per point, the summary in `#` lines).
    #[arg(long, value_name = "FILE")]
    pub report: Option<PathBuf>,
    /// Print the summary as one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
}
