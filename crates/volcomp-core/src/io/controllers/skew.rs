//! Squareness as 3-D printer firmware corrects it: Klipper's
//! `[skew_correction]` profiles (`xy_skew`, `xz_skew`, `yz_skew`) and
//! Marlin's `M852 I J K` (docs/controllers.md, "Skew correction").
//!
//! Both firmwares apply the same transform (Klipper's module is a port of
//! Marlin's `planner.h`, [Klipper skew], [Marlin M852]): the toolhead ends
//! at the motor position `m` moved by
//!
//! ```text
//! x = m_x + m_y·xy + m_z·xz,     y = m_y + m_z·yz,     z = m_z
//! ```
//!
//! and the firmware commands the exact inverse. volcomp's squareness
//! (docs/design.md, "The 21-component model": Y moves along `(S_xy, 1, 0)`,
//! Z along `(S_zx, S_yz, 1)`) is the same transform:
//! `e_x = S_xy·y + S_zx·z`, `e_y = S_yz·z`. Hence, with S in µrad,
//!
//! ```text
//! xy = S_xy·10⁻⁶,   xz = S_zx·10⁻⁶,   yz = S_yz·10⁻⁶
//! ```
//!
//! (the firmware's factor is the tangent of the angle's deviation from 90°,
//! which is exactly `S·10⁻⁶` for volcomp's direction vectors).

use super::{
    located, ControllerCorrection, Export, ExportFile, Format, LimitError, ReadError, Rounding,
};
use crate::io::finite;
use crate::io::numfmt::fixed;

/// Decimals written for a skew factor: 10⁻⁹ = 0.001 µrad.
pub const DECIMALS: usize = 9;

/// The firmware's three factors `[xy, xz, yz]` of volcomp's squareness
/// `[S_xy, S_yz, S_zx]` (µrad).
///
/// ```
/// use volcomp_core::io::controllers::skew::factors;
/// assert_eq!(factors([12.0, -8.0, 6.0]), [12e-6, 6e-6, -8e-6]);
/// ```
pub fn factors(squareness_urad: [f64; 3]) -> [f64; 3] {
    let [xy, yz, zx] = squareness_urad;
    [xy * 1e-6, zx * 1e-6, yz * 1e-6]
}

/// volcomp's squareness `[S_xy, S_yz, S_zx]` (µrad) of the firmware's
/// factors `[xy, xz, yz]`: the inverse of [`factors`].
pub fn squareness_urad(factors: [f64; 3]) -> [f64; 3] {
    let [xy, xz, yz] = factors;
    [xy * 1e6, yz * 1e6, xz * 1e6]
}

fn rounded(squareness: [f64; 3], rounding: &mut Rounding) -> [f64; 3] {
    factors(squareness).map(|f| {
        let r = super::round_to(f, 10f64.powi(-(DECIMALS as i32)));
        rounding.max_um = rounding.max_um.max((r - f).abs() * 1e6);
        r
    })
}

/// The correction the firmware applies with `factors`.
fn applied(format: Format, f: [f64; 3]) -> ControllerCorrection {
    ControllerCorrection {
        squareness_urad: Some(squareness_urad(f)),
        ..ControllerCorrection::empty(format)
    }
}

/// Nothing rounded yet, at the 0.001 µrad every firmware file is written
/// to (reported in µrad, in [`Rounding::max_um`]'s field).
fn unrounded() -> Rounding {
    Rounding {
        resolution_um: 1e-3,
        max_um: 0.0,
    }
}

/// The first line of a firmware file: the squareness (µrad) it corrects,
/// after the firmware's comment sign, `as` what.
fn header(comment: char, squareness: [f64; 3], what: &str) -> String {
    format!(
        "{comment} volcomp: squareness S_xy {} urad, S_yz {} urad, S_zx {} urad as {what}\n",
        fixed(squareness[0], 4),
        fixed(squareness[1], 4),
        fixed(squareness[2], 4),
    )
}

/// The export of one firmware file `name` with `text`: the firmware holds
/// no table.
fn one_file(
    name: &str,
    text: String,
    applied: ControllerCorrection,
    rounding: Rounding,
    notes: Vec<String>,
) -> Export {
    Export {
        files: vec![ExportFile {
            name: name.into(),
            text,
        }],
        applied,
        rounding,
        holds: [super::table_error::Holds::Nothing; 3],
        zero_at: None,
        notes,
    }
}

/// A firmware file of the factors of `squareness`, rounded to
/// [`DECIMALS`]: `name`, a header after the firmware's `comment` sign saying
/// `what` it is, then `body` of the factors `[xy, xz, yz]` as written.
/// `limit` refuses rounded factors the firmware does not take.
fn factor_file(
    format: Format,
    squareness: [f64; 3],
    (name, comment, what): (&str, char, &str),
    limit: impl Fn([f64; 3]) -> Result<(), LimitError>,
    body: impl Fn([String; 3]) -> String,
    notes: Vec<String>,
) -> Result<Export, LimitError> {
    let mut rounding = unrounded();
    let f = rounded(squareness, &mut rounding);
    limit(f)?;
    let text = header(comment, squareness, what) + &body(f.map(|v| fixed(v, DECIMALS)));
    Ok(one_file(name, text, applied(format, f), rounding, notes))
}

/// A Klipper profile `[skew_correction NAME]` for the squareness (µrad).
/// The rounding is reported in µrad (in [`Rounding::max_um`]'s field).
pub fn klipper(squareness: [f64; 3], profile: &str) -> Result<Export, LimitError> {
    if profile.is_empty() || profile.chars().any(|c| c.is_whitespace() || c == ']') {
        return Err(LimitError {
            format: "klipper",
            axis: 'X',
            message: format!("`{profile}` is not a profile name"),
            help: "name the profile with letters, digits and _ (it is loaded with SKEW_PROFILE LOAD=NAME)".into(),
        });
    }
    factor_file(
        Format::Klipper,
        squareness,
        ("skew_correction.cfg", '#', "Klipper skew factors"),
        |_| Ok(()),
        |[xy, xz, yz]| {
            format!("[skew_correction {profile}]\nxy_skew = {xy}\nxz_skew = {xz}\nyz_skew = {yz}\n")
        },
        vec![
            "printer.cfg: [skew_correction] and this profile section (or [include skew_correction.cfg])".into(),
            format!("load it after homing: SKEW_PROFILE LOAD={profile}"),
        ],
    )
}

/// Marlin's `M852 I J K` line (with `G21`: Marlin reads the factors as
/// linear units) for the squareness (µrad). Marlin refuses factors outside
/// `SKEW_FACTOR_MIN … SKEW_FACTOR_MAX` = −1 … 1.
pub fn marlin(squareness: [f64; 3]) -> Result<Export, LimitError> {
    factor_file(
        Format::Marlin,
        squareness,
        ("skew.gcode", ';', "Marlin skew factors"),
        |f| match f.iter().position(|v| !(-1.0..=1.0).contains(v)) {
            Some(k) => Err(LimitError {
                format: "marlin",
                axis: ['X', 'X', 'Y'][k],
                message: format!("skew factor {} is outside SKEW_FACTOR_MIN … SKEW_FACTOR_MAX (−1 … 1)", f[k]),
                help: "a squareness of more than 45° is not a machine error: check the model's units (µrad)".into(),
            }),
            None => Ok(()),
        },
        |[i, j, k]| format!("G21\nM852 I{i} J{j} K{k}\nM500\n"),
        vec![
            "Marlin needs SKEW_CORRECTION and SKEW_CORRECTION_GCODE; J and K (XZ, YZ) need SKEW_CORRECTION_FOR_Z".into(),
            "M500 stores the factors in EEPROM".into(),
        ],
    )
}

/// The sample length of the `M556` line volcomp writes (mm): RepRapFirmware
/// ignores `S` below 10.
pub const RRF_SAMPLE_MM: f64 = 100.0;

/// RepRapFirmware's `M556 S X Y Z` for the squareness (µrad).
///
/// RepRapFirmware ([RRF M556]) sets `tanXY = X/S`, `tanYZ = Y/S`,
/// `tanXZ = Z/S` and commands the motors to `x + tanXY·y + tanXZ·z`,
/// `y + tanYZ·z` (`Move::AxisTransform`) — the correction itself, where
/// Klipper and Marlin hold the error. The toolhead then lands at
/// `x + (tanXY + S_xy)·y + …`, so `tanXY = −S_xy·10⁻⁶`, `tanYZ = −S_yz·10⁻⁶`,
/// `tanXZ = −S_zx·10⁻⁶` (exact to first order: the neglected product
/// `S_xy·S_yz·z` is 10⁻¹⁰ of z for 10 µrad). volcomp writes `S100` and the
/// deviations over those 100 mm.
pub fn rrf(squareness: [f64; 3]) -> Result<Export, LimitError> {
    let mut rounding = unrounded();
    let [xy, yz, zx] = squareness;
    // Deviations over S in mm, written with 7 decimals: 10⁻⁷ / 100 = 0.001 µrad.
    let mut dev = |s_urad: f64| -> f64 {
        let d = -s_urad * 1e-6 * RRF_SAMPLE_MM;
        let r = super::round_to(d, 1e-7);
        rounding.max_um = rounding.max_um.max((r - d).abs() / RRF_SAMPLE_MM * 1e6);
        r
    };
    let (x, y, z) = (dev(xy), dev(yz), dev(zx));
    let text = format!(
        "{}M556 S{} X{} Y{} Z{}\n",
        header(';', squareness, "RepRapFirmware axis compensation"),
        fixed(RRF_SAMPLE_MM, 0),
        fixed(x, 7),
        fixed(y, 7),
        fixed(z, 7)
    );
    let applied = ControllerCorrection {
        squareness_urad: Some([
            -x / RRF_SAMPLE_MM * 1e6,
            -y / RRF_SAMPLE_MM * 1e6,
            -z / RRF_SAMPLE_MM * 1e6,
        ]),
        ..ControllerCorrection::empty(Format::Rrf)
    };
    Ok(one_file(
        "m556.g",
        text,
        applied,
        rounding,
        vec![
            "put the M556 line in config.g (the XY term corrects X, RepRapFirmware's default)"
                .into(),
        ],
    ))
}

/// Reads a Klipper profile section (`[skew_correction NAME]` with
/// `xy_skew`, `xz_skew`, `yz_skew`) or a Marlin `M852` line: the
/// squareness the firmware corrects.
pub fn parse(text: &str, file: &str) -> Result<ControllerCorrection, ReadError> {
    let mut f = [None; 3];
    let mut format = None;
    let mut rrf_squareness = None;
    for (i, raw) in text.lines().enumerate() {
        let row = i + 1;
        let line = raw.split(['#', ';']).next().unwrap_or("").trim();
        let number = |s: &str| -> Result<f64, ReadError> {
            finite(s.trim()).ok_or_else(|| {
                located(
                    file,
                    text,
                    row,
                    format!("`{}` is not a number", s.trim()),
                    "a skew factor is a number such as 0.000012",
                )
            })
        };
        if let Some((key, value)) = line.split_once(['=', ':']) {
            let k = match key.trim() {
                "xy_skew" => 0,
                "xz_skew" => 1,
                "yz_skew" => 2,
                _ => continue,
            };
            f[k] = Some(number(value)?);
            format = Some(Format::Klipper);
        } else if let Some(rest) = line.strip_prefix("M556") {
            let mut sample = None;
            let mut d = [0.0; 3];
            for word in rest.split_whitespace() {
                let (letter, value) = word.split_at(1);
                let v = number(value)?;
                match letter {
                    "S" => sample = Some(v),
                    "X" => d[0] = v,
                    "Y" => d[1] = v,
                    "Z" => d[2] = v,
                    _ => {
                        return Err(located(
                            file,
                            text,
                            row,
                            format!("`{word}` is not a word of M556"),
                            "M556 takes S, X, Y, Z",
                        ))
                    }
                }
            }
            let s = sample.filter(|s| *s >= 10.0).ok_or_else(|| {
                located(
                    file,
                    text,
                    row,
                    "M556 without S ≥ 10",
                    "RepRapFirmware ignores M556 without S of at least 10 mm",
                )
            })?;
            // tanXY = X/S, tanYZ = Y/S, tanXZ = Z/S; S_xy = −tanXY … (see `rrf`).
            rrf_squareness = Some([-d[0] / s * 1e6, -d[1] / s * 1e6, -d[2] / s * 1e6]);
        } else if let Some(rest) = line.strip_prefix("M852") {
            for word in rest.split_whitespace() {
                let (letter, value) = word.split_at(1);
                let k = match letter {
                    "I" | "S" => 0,
                    "J" => 1,
                    "K" => 2,
                    _ => {
                        return Err(located(
                            file,
                            text,
                            row,
                            format!("`{word}` is not a word of M852"),
                            "M852 takes I (XY), J (XZ), K (YZ)",
                        ))
                    }
                };
                f[k] = Some(number(value)?);
            }
            format = Some(Format::Marlin);
        }
    }
    if let Some(sq) = rrf_squareness {
        return Ok(ControllerCorrection {
            squareness_urad: Some(sq),
            ..ControllerCorrection::empty(Format::Rrf)
        });
    }
    let Some(format) = format else {
        return Err(located(
            file,
            text,
            1,
            "no skew factors found",
            "expected a Klipper section with xy_skew, xz_skew, yz_skew, a Marlin M852 or a RepRapFirmware M556 line",
        ));
    };
    // Klipper reads a stored profile with `getfloat` and no
    // default for each of the three factors (klippy/extras/skew_correction.py,
    // `_load_storage`), so it refuses a profile that lacks one; so does
    // volcomp, rather than take the missing factor as 0. (Marlin's M852
    // leaves a factor it is not given as it was; that case stays 0.)
    if format == Format::Klipper {
        if let Some(k) = f.iter().position(Option::is_none) {
            let name = ["xy_skew", "xz_skew", "yz_skew"][k];
            let row = text
                .lines()
                .position(|l| l.trim_start().starts_with("[skew_correction"))
                .map_or(1, |i| i + 1);
            return Err(located(
                file,
                text,
                row,
                format!("the profile gives no {name}"),
                "Klipper refuses a stored profile without all three factors (xy_skew, xz_skew, yz_skew); write 0 for a square pair of axes",
            ));
        }
    }
    Ok(applied(format, f.map(|v| v.unwrap_or(0.0))))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A Klipper profile without one of its three factors is
    /// refused at its section, as Klipper refuses it.
    #[test]
    fn a_klipper_profile_without_a_factor_is_refused() {
        let text = "# saved\n[skew_correction mine]\nxy_skew = 0.000012\nxz_skew = 0.000006\n";
        let e = parse(text, "skew.cfg").unwrap_err().to_string();
        assert!(
            e.starts_with("skew.cfg:2:1: the profile gives no yz_skew"),
            "{e}"
        );
        let full = format!("{text}yz_skew = 0\n");
        assert_eq!(parse(&full, "skew.cfg").unwrap().format, Format::Klipper);
    }

    #[test]
    fn klipper_by_hand() {
        // S_xy = 12 µrad, S_yz = −8 µrad, S_zx = 6 µrad: xy = 0.000012,
        // xz = 0.000006, yz = −0.000008. At (0, 200, 100) mm the machine is
        // off by e_x = 12·200 + 6·100 = 3000 µrad·mm = 3.0 µm, e_y = −0.8 µm,
        // which is x_phys − x_motor = 200·xy + 100·xz = 0.0030 mm in
        // Klipper's calc_unskew.
        let e = klipper([12.0, -8.0, 6.0], "volcomp").unwrap();
        let t = &e.files[0].text;
        assert!(t.contains("[skew_correction volcomp]\nxy_skew = 0.000012\nxz_skew = 0.000006\nyz_skew = -0.000008\n"), "{t}");
        let [xy, xz, yz] = factors([12.0, -8.0, 6.0]);
        assert!(((200.0 * xy + 100.0 * xz) * 1e3 - 3.0).abs() < 1e-12);
        assert!((100.0 * yz * 1e3 - -0.8).abs() < 1e-12);
        assert!(e.rounding.max_um < 1e-9, "{:?}", e.rounding);
        let back = parse(t, "skew.cfg").unwrap();
        assert_eq!(back.format, Format::Klipper);
        let s = back.squareness_urad.unwrap();
        for (a, b) in s.iter().zip([12.0, -8.0, 6.0]) {
            assert!((a - b).abs() < 1e-9, "{s:?}");
        }
    }

    #[test]
    fn rrf_by_hand() {
        // S_xy = 12, S_yz = −8, S_zx = 6 µrad: over S = 100 mm the
        // corrections are X = −0.0012, Y = +0.0008, Z = −0.0006 mm. At
        // (0, 200, 100) RepRapFirmware commands x + (−0.0012/100)·200 +
        // (−0.0006/100)·100 = x − 0.003 mm: the 3 µm the machine adds.
        let e = rrf([12.0, -8.0, 6.0]).unwrap();
        let t = &e.files[0].text;
        assert!(t.contains("M556 S100 X-0.0012 Y0.0008 Z-0.0006\n"), "{t}");
        assert!(((-0.0012 / 100.0) * 200.0 + (-0.0006 / 100.0) * 100.0 - -0.003f64).abs() < 1e-15);
        let back = parse(t, "m556.g").unwrap();
        assert_eq!(back.format, Format::Rrf);
        let s = back.squareness_urad.unwrap();
        for (a, b) in s.iter().zip([12.0, -8.0, 6.0]) {
            assert!((a - b).abs() < 1e-9, "{s:?}");
        }
        assert!(parse("M556 S5 X1\n", "m.g").is_err());
    }

    #[test]
    fn marlin_by_hand_with_rounding() {
        // 0.0004 µrad is below the 0.001 µrad written: 10.0004 → 0.00001.
        let e = marlin([10.0004, 0.0, -2.5]).unwrap();
        let t = &e.files[0].text;
        assert!(
            t.contains("G21\nM852 I0.00001 J-0.0000025 K0\nM500\n"),
            "{t}"
        );
        assert!(
            (e.rounding.max_um - 0.0004).abs() < 1e-9,
            "{:?}",
            e.rounding
        );
        let back = parse(t, "skew.gcode").unwrap();
        assert_eq!(back.format, Format::Marlin);
        let s = back.squareness_urad.unwrap();
        assert!((s[0] - 10.0).abs() < 1e-9 && (s[2] - -2.5).abs() < 1e-9 && s[1] == 0.0);
        let err = marlin([2e6, 0.0, 0.0]).unwrap_err();
        assert!(err.message.contains("outside"), "{err}");
        assert!(klipper([0.0; 3], "my profile").is_err());
        let bad = parse("M852 I0.1 Q2\n", "s.gcode").unwrap_err();
        assert!(bad.message.contains("Q2"));
    }
}
