//! grblHAL backlash compensation: the settings `$160`, `$161`, `$162`
//! ("X/Y/Z-axis backlash compensation", mm, three decimals; grblHAL built
//! with `ENABLE_BACKLASH_COMPENSATION`, [grblHAL settings]).
//!
//! grblHAL adds the setting's distance to the motion when an axis reverses.
//! volcomp's reversal value is `B = E_reverse − E_forward` (docs/design.md,
//! "Direction state and backlash": a lagging axis has its forward error
//! below its reverse one); one setting per axis holds one number, so volcomp
//! writes the mean reversal value `B̄` over the table (ISO 230-2's mean
//! reversal value) and reports the largest departure from it.
//!
//! *Assumption* (grblHAL's documentation gives no sign convention beyond
//! "distance"): the axis' position reference is taken moving forward, so
//! the correction is `0` forward and `B̄` in reverse. A negative `B̄` (the
//! forward error above the reverse one) cannot be set and is refused.

use super::{
    axis_letter, located, round_to, ControllerCorrection, Export, ExportFile, Format, LimitError,
    Positioning, ReadError, Rounding,
};
use crate::io::numfmt::fixed;

/// The setting number of axis `a`'s backlash (`$160 + a`).
pub const BACKLASH_SETTING: usize = 160;

/// The `$16n` lines for the axes with a table.
pub fn export(p: &[Option<Positioning>; 3]) -> Result<Export, LimitError> {
    let mut rounding = Rounding {
        resolution_um: 1.0,
        max_um: 0.0,
    };
    let mut text = String::from(
        "; volcomp: backlash compensation (mm), the mean reversal value of each axis\n",
    );
    let mut applied: [Option<Positioning>; 3] = [None, None, None];
    let mut notes = vec!["grblHAL must be built with ENABLE_BACKLASH_COMPENSATION; send the lines from a sender's console".into()];
    for (a, table) in p.iter().enumerate() {
        let Some(table) = table else { continue };
        let ax = axis_letter(a);
        let b: Vec<f64> = table
            .reverse_um
            .iter()
            .zip(&table.forward_um)
            .map(|(r, f)| r - f)
            .collect();
        let mean = b.iter().sum::<f64>() / b.len() as f64;
        if mean < 0.0 {
            return Err(LimitError {
                format: "grblhal",
                axis: ax,
                message: format!("the mean reversal value is {} um: the forward error lies above the reverse one", fixed(mean, 3)),
                help: "grblHAL's backlash is a distance added on reversal; check the direction columns of the map".into(),
            });
        }
        let spread = b.iter().map(|v| (v - mean).abs()).fold(0.0, f64::max);
        let written_um = round_to(mean, 1.0);
        rounding.max_um = rounding.max_um.max((written_um - mean).abs());
        text.push_str(&format!(
            "${}={}\n",
            BACKLASH_SETTING + a,
            fixed(written_um * 1e-3, 3)
        ));
        notes.push(format!("{ax}: backlash {} um; the reversal value varies by up to {} um along the axis, which one setting cannot hold", fixed(written_um, 3), fixed(spread, 3)));
        applied[a] = Some(Positioning {
            positions_mm: vec![
                table.positions_mm[0],
                table.positions_mm[table.positions_mm.len() - 1],
            ],
            forward_um: vec![0.0, 0.0],
            reverse_um: vec![written_um, written_um],
        });
    }
    Ok(Export {
        files: vec![ExportFile {
            name: "backlash.txt".into(),
            text,
        }],
        applied: ControllerCorrection {
            format: Format::Grblhal,
            axes: applied,
            squareness_urad: None,
            cross: Vec::new(),
            backlash: [None; 3],
            notes: Vec::new(),
        },
        rounding,
        notes,
    })
}

/// Reads `$160=…`, `$161=…`, `$162=…` lines (others are skipped): the
/// correction 0 forward and the backlash in reverse, over all positions.
pub fn parse(text: &str, file: &str) -> Result<ControllerCorrection, ReadError> {
    let mut axes: [Option<Positioning>; 3] = [None, None, None];
    for (i, raw) in text.lines().enumerate() {
        let line = raw.split(';').next().unwrap_or("").trim();
        let Some((k, v)) = line.strip_prefix('$').and_then(|l| l.split_once('=')) else {
            continue;
        };
        let Ok(n) = k.trim().parse::<usize>() else {
            continue;
        };
        if !(BACKLASH_SETTING..BACKLASH_SETTING + 3).contains(&n) {
            continue;
        }
        let mm: f64 = v
            .trim()
            .parse()
            .ok()
            .filter(|x: &f64| x.is_finite() && *x >= 0.0)
            .ok_or_else(|| {
                located(
                    file,
                    text,
                    i + 1,
                    format!("`{}` is not a backlash distance", v.trim()),
                    "a backlash setting is a distance in mm, 0 or more",
                )
            })?;
        axes[n - BACKLASH_SETTING] = Some(Positioning {
            positions_mm: vec![-1e6, 1e6],
            forward_um: vec![0.0, 0.0],
            reverse_um: vec![mm * 1e3, mm * 1e3],
        });
    }
    if axes.iter().all(Option::is_none) {
        return Err(located(
            file,
            text,
            1,
            "no $160, $161 or $162 line",
            "expected grblHAL backlash settings such as $160=0.004",
        ));
    }
    Ok(ControllerCorrection {
        format: Format::Grblhal,
        axes,
        squareness_urad: None,
        cross: Vec::new(),
        backlash: [None; 3],
        notes: Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn backlash_by_hand() {
        // X reversal values 3.0, 4.0, 5.2 µm → mean 4.0667 → 4 µm = 0.004 mm;
        // spread 1.1333 µm, rounding 0.0667 µm.
        let x = Positioning {
            positions_mm: vec![0.0, 50.0, 100.0],
            forward_um: vec![0.0, 1.0, 2.0],
            reverse_um: vec![3.0, 5.0, 7.2],
        };
        let e = export(&[Some(x), None, None]).unwrap();
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
        assert!(e.notes.iter().any(|n| n.contains("1.133")), "{:?}", e.notes);
        let back = parse(&e.files[0].text, "b.txt").unwrap();
        assert!((back.correction_um(0, 30.0, false) - 4.0).abs() < 1e-9);
        assert_eq!(back.correction_um(0, 30.0, true), 0.0);
        // Forward above reverse: refused.
        let y = Positioning {
            positions_mm: vec![0.0, 1.0],
            forward_um: vec![2.0, 2.0],
            reverse_um: vec![0.0, 0.0],
        };
        assert!(export(&[None, Some(y), None])
            .unwrap_err()
            .message
            .contains("-2"));
    }
}
