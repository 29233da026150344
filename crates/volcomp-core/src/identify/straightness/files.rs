//! The straightness workflow's files on disk: reading run files and model
//! files by path, and the prediction table
//! (`x_mm,y_mm,ez_um,z_correction_um`).

use super::run::Run;
use super::StraightnessModel;
use crate::error::Error;
use crate::error::ModelError;
use crate::io::numfmt;
use std::path::Path;

fn read(path: &Path) -> Result<String, Error> {
    crate::io::inputs::read_to_string(path, "a straightness file")
        .map_err(|source| Error::io(path, source))
}

/// Reads a straightness model file ([`StraightnessModel::from_toml`]).
/// Errors: [`Error::Io`] when the file cannot be read, [`Error::Straightness`]
/// (located) when its content is not a model.
pub fn load_model(path: &Path) -> Result<StraightnessModel, Error> {
    Ok(StraightnessModel::from_toml(
        &read(path)?,
        &path.display().to_string(),
    )?)
}

/// Reads one run file ([`Run::from_csv`]); with `negate`, the file's
/// displacement has the opposite sign of the deviation (e.g. workpiece
/// relative to tool) and is negated.
/// Errors as [`load_model`].
pub fn load_run(path: &Path, negate: bool) -> Result<Run, Error> {
    let mut run = Run::from_csv(&read(path)?, &path.display().to_string())?;
    if negate {
        run.negate();
    }
    Ok(run)
}

/// A point of a prediction lies where the model cannot say.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("point {x_mm},{y_mm}: {source}")]
pub struct PointError {
    /// X of the point (mm).
    pub x_mm: f64,
    /// Y of the point (mm).
    pub y_mm: f64,
    /// Why.
    #[source]
    pub source: ModelError,
}

/// The header of [`prediction_csv`].
pub const PREDICTION_HEADER: &str = "x_mm,y_mm,ez_um,z_correction_um\n";

/// One row of [`prediction_csv`]: the predicted Z deviation `e_z` at
/// `(x, y)` (mm) and its correction `−e_z` (µm).
pub fn prediction_row(
    model: &StraightnessModel,
    x_mm: f64,
    y_mm: f64,
) -> Result<String, PointError> {
    let e = model
        .ez_um(x_mm, y_mm)
        .map_err(|source| PointError { x_mm, y_mm, source })?;
    Ok(format!(
        "{},{},{},{}\n",
        numfmt::mm(x_mm),
        numfmt::mm(y_mm),
        numfmt::um(e),
        numfmt::um(-e)
    ))
}

/// The predicted Z deviation `e_z` and its correction `−e_z` (µm) at points
/// `(x, y)` (mm) as CSV ([`PREDICTION_HEADER`]), one row per point in order.
pub fn prediction_csv(
    model: &StraightnessModel,
    points_mm: &[(f64, f64)],
) -> Result<String, PointError> {
    let mut out = String::from(PREDICTION_HEADER);
    for &(x, y) in points_mm {
        out.push_str(&prediction_row(model, x, y)?);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::straightness::{AxisModel, FourierSeries};

    /// e_z(x, y) = 0.5 + sin(2π·x/100) + 10 µrad·x, measured on X 0 … 99 mm.
    fn model(clamp: bool) -> StraightnessModel {
        let axis = AxisModel {
            series: FourierSeries {
                start_mm: 0.0,
                length_mm: 100.0,
                cos_um: vec![0.0],
                sin_um: vec![1.0],
            },
            range_mm: [0.0, 99.0],
            recommended_range_mm: [10.0, 89.0],
            identification: None,
        };
        StraightnessModel {
            offset_um: 0.5,
            beta_zx_urad: 10.0,
            alpha_yz_urad: 0.0,
            x: Some(axis),
            y: None,
            clamp,
        }
    }

    #[test]
    fn prediction_rows_are_deviation_and_its_negation() {
        // x = 25: 0.5 + sin(π/2) + 0.25 = 1.75 µm; x = 50: 0.5 + 0 + 0.5 = 1 µm.
        let csv = prediction_csv(&model(false), &[(25.0, 3.0), (50.0, -7.5)]).unwrap();
        assert_eq!(
            csv,
            "x_mm,y_mm,ez_um,z_correction_um\n25,3,1.75,-1.75\n50,-7.5,1,-1\n"
        );
    }

    #[test]
    fn a_point_outside_the_measured_range_is_refused_unless_clamped() {
        let e = prediction_csv(&model(false), &[(150.0, 0.0)]).unwrap_err();
        assert_eq!((e.x_mm, e.y_mm), (150.0, 0.0));
        assert!(e.to_string().starts_with("point 150,0: "), "{e}");
        // Clamped at x = 99: 0.5 + sin(2π·0.99) + 0.99 µm.
        let csv = prediction_csv(&model(true), &[(150.0, 0.0)]).unwrap();
        let expected = 0.5 + (2.0 * std::f64::consts::PI * 0.99).sin() + 0.99;
        let ez: f64 = csv
            .lines()
            .nth(1)
            .unwrap()
            .split(',')
            .nth(2)
            .unwrap()
            .parse()
            .unwrap();
        assert!((ez - expected).abs() < 1e-4, "{csv}");
    }

    #[test]
    fn negate_flips_the_displacement_of_a_run() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.csv");
        let mut csv =
            String::from("# axis = X\n# feed_mm_per_min = 1000\nposition_mm,displacement_um\n");
        for i in 0..20 {
            csv.push_str(&format!("{},{}\n", i, 0.25 * i as f64));
        }
        std::fs::write(&path, csv).unwrap();
        let plain = load_run(&path, false).unwrap();
        let flipped = load_run(&path, true).unwrap();
        assert_eq!(plain.displacement_um[4], 1.0);
        assert_eq!(flipped.displacement_um[4], -1.0);
        assert_eq!(plain.positions_mm, flipped.positions_mm);
    }

    #[test]
    fn a_missing_file_names_its_path() {
        let e = load_model(Path::new("/nonexistent/s.toml")).unwrap_err();
        assert!(matches!(e, Error::Io { .. }));
        assert!(e.to_string().starts_with("/nonexistent/s.toml: "), "{e}");
    }
}
