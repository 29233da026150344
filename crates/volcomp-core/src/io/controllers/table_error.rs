//! How far an exported table, as the controller applies it, lies from the
//! map it was made from, over the whole range and between the table's
//! points: the resampling to the controller's layout and the rounding to
//! its resolution, and, apart from them, what the format leaves by design
//! (the reversal's variation beside one backlash value, the positioning
//! error of a backlash-only format).
//!
//! **How the largest deviation is found.** The map's positioning table
//! and the controller's table are both piecewise linear in the position
//! (linear interpolation, ends held), so their difference is piecewise
//! linear with its corners at the points of either table: its largest
//! magnitude lies at one of them. [`table_error`] evaluates the difference
//! at every point of both tables within the map's range and at its ends,
//! in both directions, so the figure is exact, not a sampled estimate.
//! Eight evenly spaced extra samples per interval guard against a table
//! that is not linear between its points (none of volcomp's are).

use super::{
    axis_letter, interpolate_held, mean_reversal_um, Backlash, ControllerCorrection, LimitError,
    Positioning,
};
use crate::io::numfmt::fixed;

/// What an exported axis holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Holds {
    /// Nothing of this axis' positioning error.
    #[default]
    Nothing,
    /// One table per direction.
    BothDirections,
    /// One table for both directions (beside a backlash value, if the
    /// correction has one).
    OneTable,
    /// Only a backlash value, no table.
    BacklashOnly,
}

/// Samples per table interval besides its points (a guard; see the module).
const EXTRA_SAMPLES: usize = 8;

/// The largest deviation of a controller's table from what it stands for.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TableError {
    /// The largest `|applied − intended|` (µm): resampling and rounding.
    pub max_um: f64,
    /// Where: axis (0, 1, 2), position (mm), direction (forward or not).
    pub at: Option<(usize, f64, bool)>,
    /// The largest deviation of the applied correction from the map itself
    /// (µm): `max_um` plus what the format leaves by design; what
    /// volcomp's `--controller` compensation takes over.
    pub left_um: f64,
    /// Points evaluated.
    pub evaluated: usize,
}

/// The correction axis `a` would get at infinite point density and
/// resolution, with the format's direction handling: `map`'s own errors
/// (both directions held), their mean shifted beside the applied backlash
/// (one table), or the backlash alone. `zero_at`: a table relative to a
/// reference (Fanuc: zero at the position in the direction given).
fn intended(
    p: &Positioning,
    holds: Holds,
    backlash: Option<Backlash>,
    zero_at: Option<(f64, bool)>,
) -> impl Fn(f64, bool) -> f64 + '_ {
    let b = backlash.map(|bl| Backlash {
        value_um: mean_reversal_um(p),
        side: bl.side,
    });
    let beta = move |forward: bool| b.map_or(0.0, |b| b.correction_um(forward));
    let raw = move |q: f64, forward: bool| -> f64 {
        let e = |fw: bool| {
            interpolate_held(
                &p.positions_mm,
                if fw { &p.forward_um } else { &p.reverse_um },
                q,
            )
        };
        match holds {
            Holds::Nothing => 0.0,
            Holds::BothDirections => e(forward),
            Holds::OneTable => {
                0.5 * (e(true) + e(false)) - 0.5 * (beta(true) + beta(false)) + beta(forward)
            }
            Holds::BacklashOnly => beta(forward),
        }
    };
    move |q, forward| {
        let offset = zero_at.map_or(0.0, |(x, fw)| raw(x, fw) - beta(fw));
        raw(q, forward) - offset
    }
}

/// The positions to evaluate: every point of `a` and `b` within `[lo, hi]`,
/// the ends, and [`EXTRA_SAMPLES`] between neighbours.
fn positions(a: &[f64], b: &[f64], lo: f64, hi: f64) -> Vec<f64> {
    let mut x: Vec<f64> = a
        .iter()
        .chain(b)
        .copied()
        .filter(|&x| x >= lo && x <= hi)
        .chain([lo, hi])
        .collect();
    x.sort_by(f64::total_cmp);
    x.dedup();
    let mut out = Vec::with_capacity(x.len() * (EXTRA_SAMPLES + 1));
    for w in x.windows(2) {
        for k in 0..=EXTRA_SAMPLES {
            out.push(w[0] + (w[1] - w[0]) * k as f64 / (EXTRA_SAMPLES + 1) as f64);
        }
    }
    out.push(hi);
    out
}

/// The table error of an export: `map` are the map's positioning tables
/// the export was made from (before any resampling), `applied` what the
/// controller applies from the written files, `holds` what each axis
/// holds and `zero_at` the reference a table is relative to.
pub fn table_error(
    map: &[Option<Positioning>; 3],
    applied: &ControllerCorrection,
    holds: [Holds; 3],
    zero_at: Option<(f64, bool)>,
) -> TableError {
    let mut out = TableError::default();
    for a in 0..3 {
        let Some(p) = &map[a] else { continue };
        if holds[a] == Holds::Nothing {
            continue;
        }
        let n = p.positions_mm.len();
        let (lo, hi) = (p.positions_mm[0], p.positions_mm[n - 1]);
        let table_points: &[f64] = applied.axes[a]
            .as_ref()
            .map_or(&[], |t| t.positions_mm.as_slice());
        let want = intended(p, holds[a], applied.backlash[a], zero_at);
        for x in positions(&p.positions_mm, table_points, lo, hi) {
            for forward in [true, false] {
                let c = applied.correction_um(a, x, forward);
                let d = (c - want(x, forward)).abs();
                out.evaluated += 1;
                if d > out.max_um || out.at.is_none() {
                    out.max_um = out.max_um.max(d);
                    if d >= out.max_um {
                        out.at = Some((a, x, forward));
                    }
                }
                let e = interpolate_held(
                    &p.positions_mm,
                    if forward {
                        &p.forward_um
                    } else {
                        &p.reverse_um
                    },
                    x,
                );
                out.left_um = out.left_um.max((e - c).abs());
            }
        }
    }
    out
}

/// The table error of cross-axis tables (Siemens CEC): each written table
/// against the mean of the map's forward and reverse straightness it
/// stands for (`map`: input axis, output axis, table).
pub fn cross_error(
    map: &[(usize, usize, Positioning)],
    applied: &ControllerCorrection,
) -> TableError {
    let mut out = TableError::default();
    for (i, o, p) in map {
        let Some((_, _, t)) = applied.cross.iter().find(|(ti, to, _)| ti == i && to == o) else {
            continue;
        };
        let n = p.positions_mm.len();
        let (lo, hi) = (p.positions_mm[0], p.positions_mm[n - 1]);
        for x in positions(&p.positions_mm, &t.positions_mm, lo, hi) {
            let e = |v: &[f64]| interpolate_held(&p.positions_mm, v, x);
            let mean = 0.5 * (e(&p.forward_um) + e(&p.reverse_um));
            let c = interpolate_held(&t.positions_mm, &t.forward_um, x);
            let d = (c - mean).abs();
            out.evaluated += 1;
            if d >= out.max_um {
                out.max_um = d;
                out.at = Some((*o, x, true));
            }
            for v in [&p.forward_um, &p.reverse_um] {
                out.left_um = out.left_um.max((e(v) - c).abs());
            }
        }
    }
    out
}

/// A length in µm with sensible digits: four significant ones, at most
/// seven decimals (0.1 pm), trailing zeros dropped.
///
/// ```
/// use volcomp_core::io::controllers::table_error::um;
/// assert_eq!(um(1.16349), "1.163");
/// assert_eq!(um(1e-7), "0.0000001");
/// assert_eq!(um(0.0), "0");
/// assert_eq!(um(123.456), "123.5");
/// ```
pub fn um(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return fixed(v, 0);
    }
    let decimals = (3 - v.abs().log10().floor() as i64).clamp(0, 7) as usize;
    fixed(v, decimals)
}

/// The default of `max_table_error_um`: 1 µm. A controller that holds
/// values at 1 µm (Siemens, Fanuc IS-B) rounds by up to 0.5 µm, which
/// leaves as much again for the resampling; below the repeatability of
/// the machines such tables are made for (a few µm, ISO 230-2), and far
/// below the 1.16 µm a 10 mm step leaves of 16 mm waviness.
pub const DEFAULT_MAX_TABLE_ERROR_UM: f64 = 1.0;

/// Refuses an export whose table lies farther than `max_um` from what it
/// stands for, with the step that would fit (the interpolation error of a
/// smooth table shrinks with the square of the step) or, when the
/// controller's resolution alone is the cause, the limit to raise.
pub fn check(
    format: &'static str,
    err: &TableError,
    rounding_um: f64,
    step_mm: Option<f64>,
    max_um: f64,
) -> Result<(), LimitError> {
    if err.max_um <= max_um {
        return Ok(());
    }
    let (a, x, forward) = err.at.unwrap_or((0, 0.0, true));
    let message = format!(
        "the table as the controller applies it lies up to {} um from the map ({} at {} mm, {}); the largest allowed ({{max_table_error_um}}) is {} um",
        um(err.max_um),
        axis_letter(a),
        fixed(x, 4),
        if forward { "forward" } else { "reverse" },
        um(max_um)
    );
    let help = if rounding_um >= max_um {
        format!(
            "the controller's resolution alone rounds by up to {} um: allow more ({{max_table_error_um}}) or give the controller a finer resolution",
            um(rounding_um)
        )
    } else {
        let budget = (max_um - rounding_um).max(0.0);
        let interpolation = (err.max_um - rounding_um).max(1e-12);
        match step_mm {
            Some(s) => {
                let suggested = s * (budget / interpolation).sqrt() * 0.9;
                format!(
                    "choose a finer step: about {} mm (the error between points shrinks with the square of the step), or allow more ({{max_table_error_um}})",
                    fixed(suggested, 3)
                )
            }
            None => "give a step (the map's own points are too far apart for the controller) or allow more ({max_table_error_um})".into(),
        }
    };
    Err(LimitError {
        format,
        axis: axis_letter(a),
        message,
        help,
    })
}

/// The table error of a squareness correction (the firmwares' skew
/// factors): the largest `|Δc|` the rounded factors make over the map's
/// range `range_mm`, at its corners (the correction is linear in the
/// position, so its largest change lies at a corner).
pub fn squareness_error(
    model_urad: [f64; 3],
    applied: &ControllerCorrection,
    range_mm: [[f64; 2]; 3],
) -> TableError {
    let mut out = TableError::default();
    let a = applied.squareness_urad.unwrap_or([0.0; 3]);
    let d = [
        a[0] - model_urad[0],
        a[1] - model_urad[1],
        a[2] - model_urad[2],
    ];
    for corner in 0..8 {
        let at = |k: usize| range_mm[k][(corner >> k) & 1];
        let (y, z) = (at(1), at(2));
        // e_x = S_xy·y + S_zx·z, e_y = S_yz·z (µrad · mm = 10⁻³ µm).
        let dx = (d[0] * y + d[2] * z) * 1e-3;
        let dy = d[1] * z * 1e-3;
        out.evaluated += 1;
        for (axis, v) in [(0, dx), (1, dy)] {
            if v.abs() >= out.max_um {
                out.max_um = v.abs();
                out.at = Some((axis, if axis == 0 { y } else { z }, true));
            }
        }
    }
    out.left_um = out.max_um;
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::controller::{BacklashSide, Format};

    /// A sine of 16 mm period, 1 µm amplitude, every 2 mm over 0 … 160 mm.
    fn wavy() -> Positioning {
        let positions_mm: Vec<f64> = (0..=80).map(|i| 2.0 * i as f64).collect();
        let v: Vec<f64> = positions_mm
            .iter()
            .map(|x| (2.0 * std::f64::consts::PI * x / 16.0).sin())
            .collect();
        Positioning {
            positions_mm,
            forward_um: v.clone(),
            reverse_um: v,
        }
    }

    #[test]
    fn the_largest_deviation_between_points_is_found_exactly() {
        // Resampled every 8 mm (the sine's zeros), the table is 0 at every
        // point: the largest deviation is the sine's peak, 1 µm at 4 mm
        // (and every 8 mm on), between the table's points.
        let p = wavy();
        let t = p.resample(8.0);
        let mut applied = ControllerCorrection::empty(Format::Linuxcnc);
        applied.axes[0] = Some(t);
        let e = table_error(
            &[Some(p), None, None],
            &applied,
            [Holds::BothDirections, Holds::Nothing, Holds::Nothing],
            None,
        );
        assert!((e.max_um - 1.0).abs() < 1e-9, "{e:?}");
        let (a, x, _) = e.at.unwrap();
        assert_eq!(a, 0);
        assert!(((x - 4.0) / 8.0).fract().abs() < 1e-9, "{x}");
        assert_eq!(e.left_um, e.max_um);
    }

    #[test]
    fn one_table_beside_a_backlash_is_judged_by_what_it_can_hold() {
        // Reversal 2 µm at 0 mm, 4 µm at 100 mm: B̄ = 3 µm on reverse
        // travel; the intended table is the mean minus 1.5 µm. A table
        // exactly that, with B̄ = 3, has no table error; it leaves
        // |B − B̄|/2 = 0.5 µm of the map at the ends.
        let p = Positioning::new(&[0.0, 100.0], &[0.0, 0.0], &[2.0, 4.0]);
        let mut applied = ControllerCorrection::empty(Format::SiemensEec);
        applied.axes[0] = Some(Positioning::new(
            &[0.0, 50.0, 100.0],
            &[-0.5, 0.0, 0.5],
            &[-0.5, 0.0, 0.5],
        ));
        applied.backlash[0] = Some(Backlash {
            value_um: 3.0,
            side: BacklashSide::Reverse,
        });
        let e = table_error(
            &[Some(p), None, None],
            &applied,
            [Holds::OneTable, Holds::Nothing, Holds::Nothing],
            None,
        );
        assert!(e.max_um < 1e-12, "{e:?}");
        assert!((e.left_um - 0.5).abs() < 1e-12, "{e:?}");
        // Refused beyond the limit, with a step to choose.
        let big = TableError {
            max_um: 1.16,
            at: Some((0, 4.0, true)),
            left_um: 1.16,
            evaluated: 1,
        };
        let r = check("linuxcnc", &big, 0.0, Some(10.0), 1.0).unwrap_err();
        assert!(r.message.contains("1.16 um"), "{r}");
        assert!(r.help.contains("about 8.356 mm"), "{r}");
        let r = check("siemens-eec", &big, 0.5, Some(10.0), 0.4).unwrap_err();
        assert!(r.help.contains("resolution"), "{r}");
    }
}
