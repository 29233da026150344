//! Results as named columns and figures: what a front end turns into its
//! own containers (Python: a dict of numpy arrays) without knowing the
//! result's fields. One builder per result: the per-point records of a
//! compensation, the measured commands of a simulation, the motions of a
//! program, the ISO 230-2 figures, a straightness fit, thermal bands.

use crate::compensate::PointRecord;
use crate::identify::iso230_2::{Iso230_2Report, TargetStats};
use crate::identify::straightness::identify::AxisFit;
use crate::identify::straightness::Axis;
use crate::identify::thermal::uncertainty::LineBands;
use crate::io::LoadedModel;
use crate::model::axis_table::Table;
use crate::model::setup::MachineSetup;
use crate::simulate::report::SegmentError;
use volcomp_gcode::{GcodeError, MotionKind, Vec3, Warning};

/// A column (1-D, or N×3 rows) or a single figure.
#[derive(Debug, Clone, PartialEq)]
pub enum Field {
    /// Numbers (float64).
    Numbers(Vec<f64>),
    /// Counts (uint64).
    Counts(Vec<u64>),
    /// Small counts (uint32).
    Small(Vec<u32>),
    /// Yes or no per row.
    Flags(Vec<bool>),
    /// N rows of X, Y, Z.
    Rows3(Vec<Vec3>),
    /// Words of a fixed set (an array of text).
    Words(Vec<&'static str>),
    /// Free texts (a list).
    Texts(Vec<String>),
    /// One number.
    Number(f64),
    /// One count.
    Count(u64),
    /// Named fields within.
    Group(Fields),
}

/// Named fields in order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Fields(pub Vec<(String, Field)>);

impl Fields {
    fn with(mut self, name: &str, f: Field) -> Self {
        self.0.push((name.to_string(), f));
        self
    }
}

fn col<T, U>(rows: &[T], f: impl Fn(&T) -> U) -> Vec<U> {
    rows.iter().map(f).collect()
}

/// The letters of the axes set in `f`.
fn axes(f: [bool; 3]) -> String {
    ['X', 'Y', 'Z']
        .iter()
        .zip(f)
        .filter_map(|(c, b)| b.then_some(*c))
        .collect()
}

/// A compensation's per-point records (the CLI's `--report` CSV columns).
pub fn points(r: &[PointRecord]) -> Fields {
    use Field::*;
    Fields::default()
        .with("line", Counts(col(r, |p| p.line)))
        .with("target_mm", Rows3(col(r, |p| p.target_mm)))
        .with("command_mm", Rows3(col(r, |p| p.command_mm)))
        .with("iterations", Small(col(r, |p| p.iterations)))
        .with("residual_um", Numbers(col(r, |p| p.residual_um)))
        .with("reversed", Texts(col(r, |p| axes(p.reversed))))
        .with("held", Texts(col(r, |p| axes(p.held))))
        .with("take_up", Flags(col(r, |p| p.take_up)))
        .with("rapid", Flags(col(r, |p| p.rapid)))
}

/// A simulation's measured feed commands (NaN where a command ends no
/// nominal feed move).
pub fn segments(r: &[SegmentError]) -> Fields {
    use Field::*;
    let nan = Vec3::new(f64::NAN, f64::NAN, f64::NAN);
    Fields::default()
        .with("line", Counts(col(r, |s| s.line)))
        .with("nominal_line", Counts(col(r, |s| s.nominal_line)))
        .with("command_mm", Rows3(col(r, |s| s.command_mm)))
        .with("actual_mm", Rows3(col(r, |s| s.actual_mm)))
        .with("target_mm", Rows3(col(r, |s| s.target_mm.unwrap_or(nan))))
        .with(
            "point_um",
            Numbers(col(r, |s| s.point_um.unwrap_or(f64::NAN))),
        )
        .with("contour_max_um", Numbers(col(r, |s| s.contour_max_um)))
}

/// What the interpreter understood of `program`, one row per motion in
/// machine coordinates (the columns of `volcomp moves`' CSV), and its
/// warnings (given also when the program is refused).
pub fn motions(
    setup: &MachineSetup,
    program: &[u8],
    file: &str,
    extra_axes: bool,
) -> (Result<Fields, GcodeError>, Vec<Warning>) {
    let mut walker = setup.walker(program, file);
    let (mut line, mut column, mut kind, mut source) = (vec![], vec![], vec![], vec![]);
    let (mut end, mut centre): (Vec<[f64; 3]>, Vec<[f64; 3]>) = (vec![], vec![]);
    let mut extra: Vec<[f64; 6]> = vec![];
    let r = (|| {
        while let Some(ev) = walker.next_line()? {
            for mo in ev.motions {
                line.push(mo.line);
                column.push(mo.column as u64);
                kind.push(mo.kind.name());
                source.push(mo.source.name());
                let c = match mo.kind {
                    MotionKind::Arc(arc) => arc.center,
                    _ => Vec3::new(f64::NAN, f64::NAN, f64::NAN),
                };
                end.push([mo.end[0], mo.end[1], mo.end[2]]);
                centre.push([c[0], c[1], c[2]]);
                if extra_axes {
                    extra.push(mo.extra.end);
                }
            }
        }
        Ok(())
    })();
    let warnings = walker.warnings().to_vec();
    let r = r.map(|()| {
        use Field::*;
        let mut f = Fields::default()
            .with("line", Counts(line))
            .with("column", Counts(column))
            .with("kind", Words(kind))
            .with("source", Words(source));
        for (k, name) in ["x_mm", "y_mm", "z_mm"].iter().enumerate() {
            f = f.with(name, Numbers(col(&end, |e| e[k])));
        }
        for (k, name) in ["cx_mm", "cy_mm", "cz_mm"].iter().enumerate() {
            f = f.with(name, Numbers(col(&centre, |e| e[k])));
        }
        if extra_axes {
            let names = ["a_deg", "b_deg", "c_deg", "u_mm", "v_mm", "w_mm"];
            for (k, name) in names.iter().enumerate() {
                f = f.with(name, Numbers(col(&extra, |e| e[k])));
            }
        }
        f
    });
    (r, warnings)
}

/// The ISO 230-2 figures: `targets` (columns per target), `axis` (the
/// axis' figures), `notes`.
pub fn iso230_2(r: &Iso230_2Report) -> Fields {
    use Field::*;
    let t = &r.targets;
    let mut targets = Fields::default()
        .with("target_mm", Numbers(col(t, |s| s.target_mm)))
        .with("n_up", Counts(col(t, |s| s.n_up as u64)))
        .with("n_down", Counts(col(t, |s| s.n_down as u64)));
    type Stat = fn(&TargetStats) -> f64;
    let per_target: [(&str, Stat); 9] = [
        ("mean_up_um", |s| s.mean_up_um),
        ("mean_down_um", |s| s.mean_down_um),
        ("s_up_um", |s| s.s_up_um),
        ("s_down_um", |s| s.s_down_um),
        ("reversal_um", |s| s.reversal_um),
        ("mean_um", |s| s.mean_um),
        ("repeatability_up_um", |s| s.repeatability_up_um),
        ("repeatability_down_um", |s| s.repeatability_down_um),
        ("repeatability_um", |s| s.repeatability_um),
    ];
    for (name, f) in per_target {
        targets = targets.with(name, Numbers(col(t, f)));
    }
    let a = &r.axis;
    let mut axis = Fields::default();
    for (name, v) in [
        ("reversal_b_um", a.reversal_b_um),
        ("mean_reversal_um", a.mean_reversal_um),
        ("repeatability_up_um", a.repeatability_up_um),
        ("repeatability_down_um", a.repeatability_down_um),
        ("repeatability_um", a.repeatability_um),
        ("systematic_up_um", a.systematic_up_um),
        ("systematic_down_um", a.systematic_down_um),
        ("systematic_um", a.systematic_um),
        ("mean_range_um", a.mean_range_um),
        ("accuracy_up_um", a.accuracy_up_um),
        ("accuracy_down_um", a.accuracy_down_um),
        ("accuracy_um", a.accuracy_um),
    ] {
        axis = axis.with(name, Number(v));
    }
    Fields::default()
        .with("targets", Group(targets))
        .with("axis", Group(axis))
        .with("notes", Texts(r.notes.clone()))
}

/// What a straightness fit found, per axis letter.
pub fn straightness(fits: &[AxisFit]) -> Fields {
    use Field::*;
    let mut out = Fields::default();
    for a in fits {
        let index = |v: &[usize]| Counts(col(v, |k| *k as u64));
        let f = Fields::default()
            .with("harmonics", Count(a.harmonics as u64))
            .with("cutoff_wavelength_mm", Number(a.cutoff_wavelength_mm))
            .with("residual_rms_um", Number(a.residual_rms_um))
            .with("runs", Count(a.runs as u64))
            .with("spacing_mm", Number(a.spacing_mm))
            .with("length_mm", Number(a.length_mm))
            .with("line_intercept_um", Number(a.line.0))
            .with("line_slope_um_per_mm", Number(a.line.1))
            .with("positions_mm", Numbers(a.positions_mm.clone()))
            .with("mean_profile_um", Numbers(a.mean_profile_um.clone()))
            .with("model_profile_um", Numbers(a.model_profile_um.clone()))
            .with(
                "feeds_mm_per_min",
                Numbers(col(&a.feeds, |f| f.feed_mm_per_min)),
            )
            .with("mean_power", Numbers(a.mean_power.clone()))
            .with("sigma", Numbers(a.sigma.clone()))
            .with("passing", index(&a.passing))
            .with("unstable_in_band", index(&a.unstable_in_band));
        out = out.with(&a.axis.letter().to_string(), Group(f));
    }
    out
}

/// Monte Carlo bands along lines, per axis letter: `points_mm`,
/// `estimate_um`, `std_um`, `lo_um`, `hi_um` (N×3 each).
pub fn bands(lines: &[LineBands]) -> Fields {
    use Field::*;
    let mut out = Fields::default();
    for l in lines {
        let b = &l.bands;
        let f = Fields::default()
            .with("points_mm", Rows3(l.points_mm.clone()))
            .with("estimate_um", Rows3(col(b, |b| b.estimate_um)))
            .with("std_um", Rows3(col(b, |b| b.std_um)))
            .with("lo_um", Rows3(col(b, |b| b.lo_um)))
            .with("hi_um", Rows3(col(b, |b| b.hi_um)));
        out = out.with(&['X', 'Y', 'Z'][l.axis].to_string(), Group(f));
    }
    out
}

/// A model's components per axis and direction: `position_mm` and
/// `linear_um` (N×3: the errors along X, Y, Z the axis causes), the
/// 21-component model's `angular_urad` (N×3) and `squareness_urad` (`xy`,
/// `yz`, `zx`); the straightness model's part of `e_z` that depends on
/// each measured axis (`position_mm`, `ez_um`) at 201 points over its
/// measured range.
pub fn components(model: &LoadedModel) -> Result<Fields, crate::error::ModelError> {
    use Field::*;
    let mut out = Fields::default();
    let direction = |t: &Table, angular: Option<&Table>| {
        let f = Fields::default()
            .with("position_mm", Numbers(t.positions_mm.clone()))
            .with("linear_um", Rows3(t.errors_um.clone()));
        Group(match angular {
            Some(a) => f.with("angular_urad", Rows3(a.errors_um.clone())),
            None => f,
        })
    };
    let both = |f: Field, r: Field| Group(Fields::default().with("forward", f).with("reverse", r));
    match model {
        LoadedModel::AxisTables(m) => {
            for (t, a) in m.axes.iter().zip(["X", "Y", "Z"]) {
                out = out.with(
                    a,
                    both(direction(&t.forward, None), direction(&t.reverse, None)),
                );
            }
        }
        LoadedModel::Kinematic(m) => {
            for (t, a) in m.axes.iter().zip(["X", "Y", "Z"]) {
                let (f, r) = (&t.forward, &t.reverse);
                let f = direction(&f.linear_um, Some(&f.angular_urad));
                out = out.with(a, both(f, direction(&r.linear_um, Some(&r.angular_urad))));
            }
            let s = &m.kinematics.squareness;
            let sq = Fields::default()
                .with("xy", Number(s.xy_urad))
                .with("yz", Number(s.yz_urad))
                .with("zx", Number(s.zx_urad));
            out = out.with("squareness_urad", Group(sq));
        }
        LoadedModel::Straightness(m) => {
            for axis in [Axis::X, Axis::Y] {
                // Sampled every 1/200 of the measured range: the series is
                // smooth (its shortest wavelength is the cut-off, many
                // samples long).
                let Some(r) = m.sampled_axis_part(axis, 201) else {
                    continue;
                };
                let (p, e) = r?;
                let f = Fields::default()
                    .with("position_mm", Numbers(p))
                    .with("ez_um", Numbers(e));
                out = out.with(&axis.letter().to_string(), Group(f));
            }
        }
    }
    Ok(out)
}
