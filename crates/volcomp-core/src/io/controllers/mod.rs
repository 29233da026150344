//! Controller compensation tables: what volcomp writes for, and reads
//! from, the controllers that compensate positioning errors themselves
//! (docs/controllers.md, one section per vendor, citing its document).
//!
//! Every format goes through the same three steps:
//!
//! 1. the positioning error `E_aa` of each axis, per direction, in
//!    volcomp's sign (`e = actual − commanded`, µm; docs/design.md,
//!    "Deviation sign"): a [`Positioning`] per axis;
//! 2. the controller's layout: its points (equidistant tables are sampled
//!    by [`equidistant`]), its direction handling, its sign and unit;
//! 3. the controller's resolution: every written value is rounded to it
//!    and the largest rounding is reported ([`Rounding`]).
//!
//! Each writer also returns the correction the controller will apply
//! ([`ControllerCorrection`]: the written values read back), which
//! `model::controller` subtracts from the map so that volcomp compensates
//! only the residual.

pub mod fanuc;
pub mod grbl;
pub mod heidenhain;
mod ini;
pub mod isg;
pub mod linuxcnc;
pub mod siemens;
pub mod signcheck;
pub mod skew;
pub mod table_error;

use crate::error::MapFileError;
pub use crate::model::controller::{
    interpolate_held, Backlash, BacklashSide, ControllerCorrection, CrossTable, Format, Positioning,
};

/// The table `p` sampled at `n` points `start_mm + k·step_mm` (k = 0 … n−1),
/// interpolated linearly and held at its ends beyond its range: the layout
/// of controllers whose tables have a start and a fixed spacing.
pub fn equidistant(p: &Positioning, start_mm: f64, step_mm: f64, n: usize) -> Positioning {
    let positions: Vec<f64> = (0..n).map(|k| start_mm + step_mm * k as f64).collect();
    Positioning {
        forward_um: positions
            .iter()
            .map(|&x| interpolate_held(&p.positions_mm, &p.forward_um, x))
            .collect(),
        reverse_um: positions
            .iter()
            .map(|&x| interpolate_held(&p.positions_mm, &p.reverse_um, x))
            .collect(),
        positions_mm: positions,
    }
}

/// The number of points of an equidistant table from `lo_mm` that covers
/// `hi_mm` with spacing `step_mm`: `⌈(hi − lo)/step⌉ + 1` (the last point
/// may lie beyond `hi_mm`; the table is held there).
///
/// ```
/// use volcomp_core::io::controllers::points_covering;
/// assert_eq!(points_covering(0.0, 100.0, 10.0), 11);
/// assert_eq!(points_covering(0.0, 95.0, 10.0), 11);
/// ```
pub fn points_covering(lo_mm: f64, hi_mm: f64, step_mm: f64) -> usize {
    // A tolerance of 1e-9 of a step keeps 100/10 at 10 intervals.
    (((hi_mm - lo_mm) / step_mm - 1e-9).ceil().max(1.0) as usize) + 1
}

/// The mean of the forward and reverse tables (ISO 230-2's mean
/// bidirectional positional deviation `x̄_i`) for a controller that holds
/// one table per axis, and the largest reversal value `|x̄↑ − x̄↓|` it
/// leaves to the controller's backlash compensation.
pub fn bidirectional_mean(p: &Positioning) -> (Positioning, f64) {
    let mean: Vec<f64> = p
        .forward_um
        .iter()
        .zip(&p.reverse_um)
        .map(|(f, r)| 0.5 * (f + r))
        .collect();
    let reversal = p
        .forward_um
        .iter()
        .zip(&p.reverse_um)
        .map(|(f, r)| (r - f).abs())
        .fold(0.0, f64::max);
    (
        Positioning {
            positions_mm: p.positions_mm.clone(),
            forward_um: mean.clone(),
            reverse_um: mean,
        },
        reversal,
    )
}

/// The mean reversal value `B̄` of a table (µm): the mean over its points
/// of `B = E_reverse − E_forward` (ISO 230-2's mean reversal value), the
/// one number a controller's backlash setting holds. The mean rather than
/// the largest: the reversal left over, `B − B̄`, then averages zero along
/// the axis (and has the smallest mean square), where the largest would
/// over-correct every point but one by up to the reversal's whole spread.
///
/// ```
/// use volcomp_core::io::controllers::{mean_reversal_um, Positioning};
/// let p = Positioning { positions_mm: vec![0.0, 50.0, 100.0], forward_um: vec![0.0, 1.0, 2.0], reverse_um: vec![3.0, 5.0, 7.2] };
/// assert!((mean_reversal_um(&p) - 12.2 / 3.0).abs() < 1e-12);
/// ```
pub fn mean_reversal_um(p: &Positioning) -> f64 {
    let n = p.forward_um.len().max(1) as f64;
    p.reverse_um
        .iter()
        .zip(&p.forward_um)
        .map(|(r, f)| r - f)
        .sum::<f64>()
        / n
}

/// The direction in which an axis takes its reference (Siemens reference
/// point approach, MD34010 `$MA_REFP_CAM_DIR_IS_MINUS`; Fanuc reference
/// position return, 1006#5): the travel whose backlash is taken up when
/// the position is set, so a controller's backlash compensation acts on
/// the other one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ReferenceDirection {
    /// In + (the default of both parameters).
    #[default]
    Positive,
    /// In −.
    Negative,
}

impl ReferenceDirection {
    /// The travel a backlash compensation acts on after this reference.
    pub fn backlash_side(self) -> BacklashSide {
        match self {
            ReferenceDirection::Positive => BacklashSide::Reverse,
            ReferenceDirection::Negative => BacklashSide::Forward,
        }
    }
}

/// One table for both directions beside a backlash compensation of the
/// mean reversal value `B̄` acting on `side`: the table that leaves both
/// directions off by at most half the reversal's variation,
/// `t = (E_forward + E_reverse)/2 − (β↑ + β↓)/2` with `β` the backlash's
/// part of the correction per direction (0 for [`BacklashSide::Split`],
/// `B̄/2` when it acts on reverse travel, `−B̄/2` forward), and `B̄`
/// ([`mean_reversal_um`]). Then `c↑ = t + β↑ = E↑ + (B − B̄)/2` and
/// `c↓ = E↓ − (B − B̄)/2`.
pub fn table_beside_backlash(p: &Positioning, side: BacklashSide) -> (Positioning, f64) {
    let b = mean_reversal_um(p);
    let bl = Backlash { value_um: b, side };
    let shift = 0.5 * (bl.correction_um(true) + bl.correction_um(false));
    let t: Vec<f64> = p
        .forward_um
        .iter()
        .zip(&p.reverse_um)
        .map(|(f, r)| 0.5 * (f + r) - shift)
        .collect();
    (
        Positioning {
            positions_mm: p.positions_mm.clone(),
            forward_um: t.clone(),
            reverse_um: t,
        },
        b,
    )
}

/// How much rounding to a controller's resolution changed the values.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Rounding {
    /// The controller's resolution (µm).
    pub resolution_um: f64,
    /// The largest `|written − exact|` (µm), at most half the resolution.
    pub max_um: f64,
}

impl Rounding {
    /// Rounds `v_um` to the resolution and records the change.
    pub fn round(&mut self, v_um: f64) -> f64 {
        let r = round_to(v_um, self.resolution_um);
        self.max_um = self.max_um.max((r - v_um).abs());
        r
    }
}

/// `v` rounded to the nearest multiple of `resolution` (halves away from zero).
///
/// ```
/// use volcomp_core::io::controllers::round_to;
/// assert_eq!(round_to(1.25, 0.5), 1.5);
/// assert_eq!(round_to(-2.4, 1.0), -2.0);
/// ```
pub fn round_to(v: f64, resolution: f64) -> f64 {
    (v / resolution).round() * resolution
}

pub use crate::error::domain::LimitError;

/// One file of an export.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportFile {
    /// The file name the vendor expects (no directory).
    pub name: String,
    /// Its content.
    pub text: String,
}

/// What an exporter made.
#[derive(Debug, Clone, PartialEq)]
pub struct Export {
    /// The files to write.
    pub files: Vec<ExportFile>,
    /// The correction the controller applies from them (what was written,
    /// read back in volcomp's sign).
    pub applied: ControllerCorrection,
    /// The rounding to the controller's resolution.
    pub rounding: Rounding,
    /// Lines to show the user: settings to make on the controller, what
    /// the format leaves out.
    pub notes: Vec<String>,
    /// What each axis holds (for the table error, [`table_error`]).
    pub holds: [table_error::Holds; 3],
    /// The position and direction at which the tables are zero by the
    /// controller's definition (Fanuc: the reference position, in the
    /// return direction), if any.
    pub zero_at: Option<(f64, bool)>,
}

/// A located error in a controller file.
pub type ReadError = MapFileError;

/// The located error for `row` (1-based) of `text`.
pub(crate) fn located(
    file: &str,
    text: &str,
    row: usize,
    message: impl Into<String>,
    help: impl Into<String>,
) -> MapFileError {
    let src = text.lines().nth(row.saturating_sub(1)).unwrap_or("");
    MapFileError::new(file, row, 1, message, help).with_source(src, 0)
}

/// A controller file could not be read.
pub type ControllerReadError = crate::io::FileReadError;

pub(crate) fn read_text(path: &std::path::Path) -> Result<String, ControllerReadError> {
    crate::io::read_text(path, "the controller file")
}

/// [`read_text`] of a file named inside `parent` (a `.COM` table of a
/// `.CMA`, a comp file of an INI), recorded as such (every
/// file read is recorded by `volcomp_geom::inputs` for the output plan).
pub(crate) fn read_named(
    path: &std::path::Path,
    parent: &std::path::Path,
) -> Result<String, ControllerReadError> {
    let role = format!(
        "a file named in {}",
        crate::io::shown_name(&crate::io::file_name(parent))
    );
    crate::io::read_text(path, &role)
}

/// Reads a controller file, telling the format by its name and content:
/// a Heidenhain `.COM` table (its axis from the name, `X.COM`) or `.CMA`
/// assignment (its active line's `.COM` tables, beside it), a Siemens EEC
/// file (`$AA_ENC_COMP`) or a sag/cross-axis file (`$AN_CEC`, read with the
/// default sign: the error; machine axes by their first letter, `X1` is X),
/// a LinuxCNC INI file (`*.ini` with `[JOINT_n] COMP_FILE`, its comp files
/// beside it), a Fanuc pitch error tape as `map export --to fanuc` writes it (its
/// default assumptions), an ISG leadscrew compensation list (`kw.ssfk.*`, its axis from
/// `kopf.log_achs_name`), grblHAL `$160`–`$162` lines, a Klipper
/// `[skew_correction …]` profile, a Marlin `M852` or a RepRapFirmware `M556` line.
pub fn read(path: &std::path::Path) -> Result<ControllerCorrection, ControllerReadError> {
    let text = read_text(path)?;
    let file = path.display().to_string();
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_uppercase())
        .unwrap_or_default();
    if name.ends_with(".COM") {
        let axis = "XYZ".find(name.chars().next().unwrap_or(' ')).ok_or_else(|| {
            located(&file, &text, 1, format!("`{name}` does not say its axis"), "name the table after its axis (X.COM, Y.COM, Z.COM) or pass the .CMA that assigns it")
        })?;
        let mut axes = [None, None, None];
        axes[axis] = Some(heidenhain::parse_com(&text, &file, axis)?);
        return Ok(ControllerCorrection {
            axes,
            ..ControllerCorrection::empty(Format::Heidenhain)
        });
    }
    if name.ends_with(".CMA") {
        let assigned = heidenhain::parse_cma(&text, &file)?;
        let dir = path.parent().unwrap_or(std::path::Path::new("."));
        let mut axes = [None, None, None];
        for (a, com) in assigned.iter().enumerate() {
            if let Some(com) = com {
                let p = dir.join(com);
                // A table that cannot be read is reported at
                // the .CMA line that names it.
                let t = read_named(&p, path).map_err(|e| match e {
                    ControllerReadError::Io { path: p, source } => {
                        let row = text
                            .lines()
                            .position(|l| l.split_whitespace().any(|w| w == com))
                            .map_or(1, |i| i + 1);
                        ControllerReadError::from(located(
                            &file,
                            &text,
                            row,
                            format!(
                                "cannot read the table {}: {source}",
                                crate::io::shown_path(&p)
                            ),
                            "the tables of a .CMA are read from its folder",
                        ))
                    }
                    other => other,
                })?;
                axes[a] = Some(heidenhain::parse_com(&t, &p.display().to_string(), a)?);
            }
        }
        return Ok(ControllerCorrection {
            axes,
            ..ControllerCorrection::empty(Format::Heidenhain)
        });
    }
    if name.ends_with(".INI") || name.ends_with(".INI.EXPANDED") {
        let dir = path.parent().unwrap_or(std::path::Path::new("."));
        return linuxcnc::parse_ini(&text, &file, |n| {
            let p = dir.join(n);
            Ok((p.display().to_string(), read_named(&p, path)?))
        });
    }
    if text.contains("kw.ssfk.") {
        let p = isg::ssfk_parse(&text, &file)?;
        let axis = isg_axis(&text).ok_or_else(|| {
            located(
                &file,
                &text,
                1,
                "the list does not name its axis",
                "give kopf.log_achs_name X, Y or Z",
            )
        })?;
        let mut axes = [None, None, None];
        axes[axis] = Some(p);
        return Ok(ControllerCorrection {
            axes,
            ..ControllerCorrection::empty(Format::IsgSsfk)
        });
    }
    if text.lines().any(|l| l.trim_start().starts_with("$16")) {
        return Ok(grbl::parse(&text, &file)?);
    }
    if text.lines().any(|l| l.trim_start().starts_with("N3620")) {
        return Ok(fanuc::parse(&text, &file, &fanuc::FanucOptions::default())?);
    }
    if text.contains("$AN_CEC") {
        return Ok(ControllerCorrection {
            cross: siemens::cec_parse(&text, &file, siemens::CecSign::Error)?,
            ..ControllerCorrection::empty(Format::SiemensCec)
        });
    }
    if text.contains("$AA_ENC_COMP") {
        return Ok(siemens::parse(&text, &file, None)?);
    }
    let starts = |w: &str| text.lines().any(|l| l.trim_start().starts_with(w));
    if text.contains("[skew_correction") || starts("M852") || starts("M556") {
        return Ok(skew::parse(&text, &file)?);
    }
    Err(located(
        &file,
        &text,
        1,
        "not a controller file volcomp reads",
        "expected a Heidenhain X.COM or .CMA table, a Siemens %_N_AX_EEC_INI, an ISG kw.ssfk list, a Fanuc pitch tape, grblHAL $160-$162 lines, a Klipper [skew_correction] profile, a Marlin M852 or a RepRapFirmware M556 line (docs/controllers.md)",
    )
    .into())
}

/// What the controller named by `path` compensates: an ISG volumetric
/// compensation list (`*.lis` with `file[j]`) is a whole model
/// ([`isg::read_volcomp_lis`]); anything else a table ([`read`]).
pub fn read_applies(
    path: &std::path::Path,
) -> Result<crate::model::controller::ControllerApplies, ControllerReadError> {
    use crate::model::controller::ControllerApplies;
    let is_lis = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("lis"));
    if is_lis {
        let text = read_text(path)?;
        let volumetric = !text.contains("kw.ssfk.")
            && text.lines().any(|l| {
                l.trim_start()
                    .get(..5)
                    .is_some_and(|k| k.eq_ignore_ascii_case("file["))
            });
        if volumetric {
            return Ok(ControllerApplies::Model(Box::new(isg::read_volcomp_lis(
                path,
            )?)));
        }
    }
    Ok(ControllerApplies::Tables(Box::new(read(path)?)))
}

/// The axis of an ISG compensation list: the first letter of
/// `kopf.log_achs_name` (X, Y or Z).
fn isg_axis(text: &str) -> Option<usize> {
    text.lines().find_map(|l| {
        let mut f = l.split_whitespace();
        match (f.next(), f.next()) {
            (Some("kopf.log_achs_name"), Some(name)) => {
                "XYZ".find(name.chars().next()?.to_ascii_uppercase())
            }
            _ => None,
        }
    })
}

/// The axis letter of index `a`.
pub(crate) fn axis_letter(a: usize) -> char {
    ['X', 'Y', 'Z'][a]
}

/// What the controllers' tests share.
#[cfg(test)]
pub(crate) mod test_support {
    /// A reader of the files a controller file names, over `files` (name,
    /// text): a name not among them is not found.
    pub(crate) fn reader<'a>(
        files: &'a [(&str, &str)],
    ) -> impl FnMut(&str) -> Result<(String, String), super::ControllerReadError> + 'a {
        move |name| match files.iter().find(|(n, _)| *n == name) {
            Some((n, t)) => Ok((n.to_string(), t.to_string())),
            None => Err(super::ControllerReadError::Io {
                path: name.into(),
                source: std::io::Error::from(std::io::ErrorKind::NotFound),
            }),
        }
    }

    /// Fails, listing the notes, unless one of them contains `text`.
    #[track_caller]
    pub(crate) fn assert_noted(notes: &[String], text: &str) {
        assert!(
            notes.iter().any(|n| n.contains(text)),
            "no note with `{text}` in {notes:?}"
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equidistant_samples_and_holds_the_ends() {
        let p = Positioning::new(&[0.0, 20.0], &[0.0, 8.0], &[2.0, 2.0]);
        // From −10 every 10 mm, 5 points: −10 (held 0), 0, 10 (4), 20 (8), 30 (held 8).
        let e = equidistant(&p, -10.0, 10.0, 5);
        assert_eq!(e.positions_mm, vec![-10.0, 0.0, 10.0, 20.0, 30.0]);
        assert_eq!(e.forward_um, vec![0.0, 0.0, 4.0, 8.0, 8.0]);
        assert_eq!(e.reverse_um, vec![2.0; 5]);
    }

    #[test]
    fn bidirectional_mean_and_reversal() {
        let p = Positioning::new(&[0.0, 10.0], &[1.0, 2.0], &[3.0, 7.0]);
        let (m, b) = bidirectional_mean(&p);
        assert_eq!(m.forward_um, vec![2.0, 4.5]);
        assert_eq!(m.reverse_um, m.forward_um);
        assert_eq!(b, 5.0);
    }

    #[test]
    fn rounding_reports_the_largest_change() {
        let mut r = Rounding {
            resolution_um: 0.1,
            max_um: 0.0,
        };
        assert!((r.round(1.234) - 1.2).abs() < 1e-12);
        assert!((r.round(-0.06) - -0.1).abs() < 1e-12);
        assert!((r.max_um - 0.04).abs() < 1e-12);
    }

    #[test]
    fn points_covering_counts_intervals() {
        assert_eq!(points_covering(-200.0, 600.0, 1.0), 801);
        assert_eq!(points_covering(0.0, 0.5, 10.0), 2);
    }
}
