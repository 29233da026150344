//! grblHAL backlash compensation: the settings `$160`, `$161`, `$162`
//! ("X/Y/Z-axis backlash compensation", mm, three decimals; grblHAL built
//! with `ENABLE_BACKLASH_COMPENSATION`, [grblHAL settings]).
//!
//! What grblHAL does with them (`motion_control.c`, `mc_backlash_init` and
//! `mc_line`, [grblHAL source]): the distance is rounded to whole motor
//! steps (`lroundf(backlash · $10n) / $10n`); at start-up and after homing
//! each axis is taken to have last moved *away from its homing switch*
//! (the pull-off), towards − unless its bit of `$23` (homing direction
//! invert) is set; whenever the axis then moves the other way it inserts
//! an extra move of the distance, and back again on the next reversal. So
//! with the default `$23=0` the motors run `B` ahead on forward travel and
//! exactly as commanded in reverse: in volcomp's sign the correction is
//! `c = −B` forward and `0` in reverse ([`BacklashSide::Forward`]); an
//! axis homing towards − (its `$23` bit set) gets `0` forward and `+B` in
//! reverse ([`BacklashSide::Reverse`]).
//!
//! volcomp's reversal value is `B = E_reverse − E_forward` (docs/design.md,
//! "Direction state and backlash"); one setting per axis holds one number,
//! so volcomp writes the mean reversal value `B̄` ([`super::mean_reversal_um`])
//! and reports how far the reversal departs from it along the axis. A
//! negative `B̄` (the forward error above the reverse one) cannot be set
//! and is refused.

use super::{
    axis_letter, located, mean_reversal_um, round_to, Backlash, BacklashSide, ControllerCorrection,
    Export, ExportFile, Format, LimitError, Positioning, ReadError, Rounding,
};
use crate::io::numfmt::fixed;

/// The setting number of axis `a`'s backlash (`$160 + a`).
pub const BACKLASH_SETTING: usize = 160;
/// The setting number of axis `a`'s steps per mm (`$100 + a`).
pub const STEPS_SETTING: usize = 100;
/// The homing direction invert mask (`$23`): bit `a` set, axis `a` homes towards −.
pub const HOMING_DIR_SETTING: usize = 23;

/// The travel grblHAL's backlash acts on for an axis, from `$23`.
pub fn side(homing_dir_mask: u32, axis: usize) -> BacklashSide {
    if homing_dir_mask & (1 << axis) != 0 {
        BacklashSide::Reverse
    } else {
        BacklashSide::Forward
    }
}

/// The `$16n` lines for the axes with a table; `homing_dir_mask` is the
/// machine's `$23` (which travel grblHAL corrects).
pub fn export(p: &[Option<Positioning>; 3], homing_dir_mask: u32) -> Result<Export, LimitError> {
    let mut rounding = Rounding {
        resolution_um: 1.0,
        max_um: 0.0,
    };
    let mut text = String::from(
        "; volcomp: backlash compensation (mm), the mean reversal value of each axis\n",
    );
    let mut applied = ControllerCorrection::empty(Format::Grblhal);
    let mut notes = vec![
        "grblHAL must be built with ENABLE_BACKLASH_COMPENSATION; send the lines from a sender's console".into(),
        format!("grblHAL adds the backlash to travel away from the homing pull-off: with $23={homing_dir_mask} that is {}; give --controller the machine's $$ listing (with $23 and $100-$102: grblHAL rounds the backlash to whole steps) to compensate the rest exactly", (0..3).filter(|&a| p[a].is_some()).map(|a| format!("{} {}", axis_letter(a), match side(homing_dir_mask, a) { BacklashSide::Forward => "forward", _ => "reverse" })).collect::<Vec<_>>().join(", ")),
    ];
    for (a, table) in p.iter().enumerate() {
        let Some(table) = table else { continue };
        let ax = axis_letter(a);
        let mean = mean_reversal_um(table);
        if mean < 0.0 {
            return Err(LimitError {
                format: "grblhal",
                axis: ax,
                message: format!("the mean reversal value is {} um: the forward error lies above the reverse one", fixed(mean, 3)),
                help: "grblHAL's backlash is a distance added on reversal; check the direction columns of the map".into(),
            });
        }
        let spread = table
            .reverse_um
            .iter()
            .zip(&table.forward_um)
            .map(|(r, f)| (r - f - mean).abs())
            .fold(0.0, f64::max);
        let written_um = round_to(mean, 1.0);
        rounding.max_um = rounding.max_um.max((written_um - mean).abs());
        text.push_str(&format!(
            "${}={}\n",
            BACKLASH_SETTING + a,
            fixed(written_um * 1e-3, 3)
        ));
        // Shown at 3 decimals: below 0.0005 µm it is the same everywhere.
        let varies = if spread < 5e-4 {
            "the same all along the axis, so one setting holds it".to_string()
        } else {
            format!(
                "it varies by up to {} um along the axis, which one setting cannot hold",
                fixed(spread, 3)
            )
        };
        notes.push(format!("{ax}: backlash {} um, the mean reversal value (not the largest: the reversal left over then averages zero along the axis); {varies}", fixed(written_um, 3)));
        applied.backlash[a] = Some(Backlash {
            value_um: written_um,
            side: side(homing_dir_mask, a),
        });
    }
    Ok(Export {
        files: vec![ExportFile {
            name: "backlash.txt".into(),
            text,
        }],
        applied,
        rounding,
        holds: [super::table_error::Holds::BacklashOnly; 3],
        zero_at: None,
        notes,
    })
}

/// Reads grblHAL settings lines (a `$$` listing, or the `$16n` lines of an
/// export; other settings are skipped): `$160`–`$162`, and `$23` and
/// `$100`–`$102` where given, into the correction grblHAL applies. Without
/// `$23` its default 0 is taken; without an axis' `$10n` the backlash is
/// taken as written (grblHAL rounds it to whole steps): both are said in
/// the correction's notes.
pub fn parse(text: &str, file: &str) -> Result<ControllerCorrection, ReadError> {
    let mut backlash: [Option<(f64, usize)>; 3] = [None; 3];
    let mut steps: [Option<f64>; 3] = [None; 3];
    let mut mask: Option<u32> = None;
    for (i, raw) in text.lines().enumerate() {
        let row = i + 1;
        let line = raw.split([';', '(']).next().unwrap_or("").trim();
        let Some((k, v)) = line.strip_prefix('$').and_then(|l| l.split_once('=')) else {
            continue;
        };
        let Ok(n) = k.trim().parse::<usize>() else {
            continue;
        };
        let v = v.trim();
        let bad =
            |what: &str, help: &str| located(file, text, row, format!("`{v}` is not {what}"), help);
        if (BACKLASH_SETTING..BACKLASH_SETTING + 3).contains(&n) {
            let mm: f64 = v
                .parse()
                .ok()
                .filter(|x: &f64| x.is_finite() && *x >= 0.0)
                .ok_or_else(|| {
                    bad(
                        "a backlash distance",
                        "a backlash setting is a distance in mm, 0 or more",
                    )
                })?;
            backlash[n - BACKLASH_SETTING] = Some((mm, row));
        } else if (STEPS_SETTING..STEPS_SETTING + 3).contains(&n) {
            let s: f64 = v
                .parse()
                .ok()
                .filter(|x: &f64| x.is_finite() && *x > 0.0)
                .ok_or_else(|| {
                    bad(
                        "a number of steps per mm",
                        "$100-$102 are the axes' steps per mm, more than 0",
                    )
                })?;
            steps[n - STEPS_SETTING] = Some(s);
        } else if n == HOMING_DIR_SETTING {
            mask = Some(v.parse().map_err(|_| {
                bad(
                    "an axis mask",
                    "$23 is the homing direction invert mask, an integer (bit 0 X, 1 Y, 2 Z)",
                )
            })?);
        }
    }
    if backlash.iter().all(Option::is_none) {
        return Err(located(
            file,
            text,
            1,
            "no $160, $161 or $162 line",
            "expected grblHAL backlash settings such as $160=0.004",
        ));
    }
    let mut out = ControllerCorrection::empty(Format::Grblhal);
    if mask.is_none() {
        out.notes.push("no $23 (homing direction invert mask): grblHAL's default 0 is taken, so the backlash is added to forward travel".into());
    }
    for a in 0..3 {
        let Some((mm, _row)) = backlash[a] else {
            continue;
        };
        let applied_mm = match steps[a] {
            Some(s) => (mm * s).round() / s,
            None => {
                if mm != 0.0 {
                    out.notes.push(format!("no ${} ({} steps per mm): the backlash is taken as written; grblHAL rounds it to whole steps", STEPS_SETTING + a, axis_letter(a)));
                }
                mm
            }
        };
        if applied_mm != 0.0 {
            out.backlash[a] = Some(Backlash {
                value_um: applied_mm * 1e3,
                side: side(mask.unwrap_or(0), a),
            });
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::controllers::test_support::assert_noted;

    #[test]
    fn backlash_by_hand() {
        // X reversal values 3.0, 4.0, 5.2 µm → mean 4.0667 → 4 µm = 0.004 mm;
        // spread 1.1333 µm, rounding 0.0667 µm.
        let x = Positioning::new(&[0.0, 50.0, 100.0], &[0.0, 1.0, 2.0], &[3.0, 5.0, 7.2]);
        let e = export(&[Some(x), None, None], 0).unwrap();
        assert!(
            e.files[0].text.contains("$160=0.004\n"),
            "{}",
            e.files[0].text
        );
        assert!(
            (e.rounding.max_um - 0.0666667).abs() < 1e-6,
            "{:?}",
            e.rounding
        );
        assert_noted(&e.notes, "1.133");
        // grblHAL's default: homing towards +, pull-off towards −, so the
        // 4 µm are added to forward travel (motors 4 µm ahead: c = −4).
        let back = parse(&e.files[0].text, "b.txt").unwrap();
        assert_eq!(back.backlash, e.applied.backlash);
        assert_eq!(back.correction_um(0, 30.0, true), -4.0);
        assert_eq!(back.correction_um(0, 30.0, false), 0.0);
        assert_noted(&back.notes, "$23");
        // The same reversal everywhere: no "varies by up to 0".
        let same = Positioning::new(&[0.0, 100.0], &[0.0, 1.0], &[3.0, 4.0]);
        let notes = export(&[Some(same), None, None], 0).unwrap().notes;
        let x = notes
            .iter()
            .find(|n| n.starts_with("X: backlash 3 um"))
            .unwrap();
        assert!(
            x.ends_with("the same all along the axis, so one setting holds it"),
            "{x}"
        );
        // Forward above reverse: refused.
        let y = Positioning::new(&[0.0, 1.0], &[2.0, 2.0], &[0.0, 0.0]);
        assert!(export(&[None, Some(y), None], 0)
            .unwrap_err()
            .message
            .contains("-2"));
    }

    #[test]
    fn a_settings_listing_gives_the_side_and_the_steps() {
        // $23=2: Y homes towards −, so its backlash acts on reverse travel;
        // X at 800 steps/mm: 0.004 mm = 3.2 steps → 3 steps = 3.75 µm.
        let t = "$23=2\n$100=800.000\n$101=400\n$160=0.004\n$161=0.010\n$130=200.000\n";
        let c = parse(t, "settings.txt").unwrap();
        assert_eq!(c.correction_um(0, 0.0, true), -3.75);
        assert_eq!(c.correction_um(0, 0.0, false), 0.0);
        assert_eq!(c.correction_um(1, 0.0, true), 0.0);
        assert_eq!(c.correction_um(1, 0.0, false), 10.0);
        assert!(c.notes.is_empty(), "{:?}", c.notes);
        let e = parse("$160=-1\n", "s.txt").unwrap_err();
        assert_eq!(e.row, 1);
    }
}
