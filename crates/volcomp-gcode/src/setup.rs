//! The machine state a program runs in: work offsets, tool lengths, reference
//! points and start position, read from a small TOML file.
//!
//! ```toml
//! units = "mm"                 # required: the unit of every length below
//! start = [0, 0, 0]            # machine position when the program starts
//! [work_offsets]               # G54 … G59, G59.1 … G59.3 (machine coordinates)
//! G54 = [100.0, 50.0, -200.0]
//! [tools]                      # tool number = length (along Z)
//! 1 = 75.0
//! [reference]                  # G28 / G30 positions (machine coordinates)
//! G28 = [0, 0, 0]
//! G30 = [0, 0, 0]
//! ```
//!
//! Lengths are converted to millimetres on load; a file without `units`
//! is refused rather than guessed.

use crate::geom::{Units, Vec3};
use std::collections::BTreeMap;

/// Work coordinate system names in P-number order (G10 L2 P1 … P9).
pub const WORK_SYSTEMS: [&str; 9] = [
    "G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3",
];

/// Machine state at program start, all lengths in millimetres.
#[derive(Debug, Clone, PartialEq)]
pub struct Setup {
    /// Work offsets G54 … G59.3 in machine coordinates.
    pub work_offsets_mm: [Vec3; 9],
    /// Tool lengths by tool number.
    pub tool_lengths_mm: BTreeMap<u32, f64>,
    /// G28 reference point.
    pub g28_mm: Vec3,
    /// G30 reference point.
    pub g30_mm: Vec3,
    /// Whether the set-up gives the G28 point (else it is machine zero,
    /// and a program that uses G28 is warned about it).
    pub g28_given: bool,
    /// Whether the set-up gives the G30 point.
    pub g30_given: bool,
    /// Machine position when the program starts.
    pub start_mm: Vec3,
}

impl Default for Setup {
    fn default() -> Self {
        Self {
            work_offsets_mm: [Vec3::ZERO; 9],
            tool_lengths_mm: BTreeMap::new(),
            g28_mm: Vec3::ZERO,
            g30_mm: Vec3::ZERO,
            g28_given: false,
            g30_given: false,
            start_mm: Vec3::ZERO,
        }
    }
}

/// Why a setup file was refused.
#[derive(Debug, thiserror::Error)]
pub enum SetupError {
    /// The TOML did not parse or had the wrong shape.
    #[error("{0}")]
    Toml(#[from] toml::de::Error),
    /// A value made no sense.
    #[error("{0}")]
    Invalid(String),
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSetup {
    units: Option<Units>,
    start: Option<[f64; 3]>,
    #[serde(default)]
    work_offsets: BTreeMap<String, [f64; 3]>,
    #[serde(default)]
    tools: BTreeMap<String, f64>,
    #[serde(default)]
    reference: BTreeMap<String, [f64; 3]>,
}

impl Setup {
    /// Parses a setup file's text.
    ///
    /// ```
    /// let s = volcomp_gcode::Setup::from_toml("units = \"inch\"\n[tools]\n3 = 2.0\n").unwrap();
    /// assert_eq!(s.tool_lengths_mm[&3], 50.8);
    /// ```
    pub fn from_toml(text: &str) -> Result<Setup, SetupError> {
        let raw: RawSetup = toml::from_str(text)?;
        let units = raw.units.ok_or_else(|| {
            SetupError::Invalid(
                "missing `units = \"mm\"` or `units = \"inch\"`: volcomp does not guess the unit of offsets"
                    .into(),
            )
        })?;
        let k = units.mm_per_unit();
        let vec = |name: &str, a: [f64; 3]| -> Result<Vec3, SetupError> {
            let v = Vec3::from_array(a) * k;
            if v.is_finite() {
                Ok(v)
            } else {
                Err(SetupError::Invalid(format!(
                    "{name} is not a finite number"
                )))
            }
        };
        let mut setup = Setup::default();
        if let Some(s) = raw.start {
            setup.start_mm = vec("start", s)?;
        }
        for (name, a) in raw.work_offsets {
            let upper = name.to_ascii_uppercase();
            let i = WORK_SYSTEMS
                .iter()
                .position(|w| *w == upper)
                .ok_or_else(|| {
                    SetupError::Invalid(format!(
                        "unknown work offset `{name}` (expected one of {})",
                        WORK_SYSTEMS.join(", ")
                    ))
                })?;
            setup.work_offsets_mm[i] = vec(&name, a)?;
        }
        for (name, length) in raw.tools {
            let n: u32 = name.trim_start_matches(['T', 't']).parse().map_err(|_| {
                SetupError::Invalid(format!(
                    "tool `{name}` is not a tool number such as 1 or T1"
                ))
            })?;
            if !length.is_finite() {
                return Err(SetupError::Invalid(format!(
                    "tool {n} length is not finite"
                )));
            }
            setup.tool_lengths_mm.insert(n, length * k);
        }
        for (name, a) in raw.reference {
            match name.to_ascii_uppercase().as_str() {
                "G28" => {
                    setup.g28_mm = vec("G28", a)?;
                    setup.g28_given = true;
                }
                "G30" => {
                    setup.g30_mm = vec("G30", a)?;
                    setup.g30_given = true;
                }
                _ => {
                    return Err(SetupError::Invalid(format!(
                        "unknown reference point `{name}` (expected G28 or G30)"
                    )))
                }
            }
        }
        Ok(setup)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_a_full_setup() {
        let s = Setup::from_toml(
            "units = \"mm\"\nstart=[1,2,3]\n[work_offsets]\nG55=[10,20,30]\n\"G59.3\"=[1,1,1]\n[tools]\nT2 = 40.5\n[reference]\nG30=[0,0,-5]\n",
        )
        .unwrap();
        assert_eq!(s.work_offsets_mm[1], Vec3::new(10.0, 20.0, 30.0));
        assert_eq!(s.work_offsets_mm[8], Vec3::new(1.0, 1.0, 1.0));
        assert_eq!(s.tool_lengths_mm[&2], 40.5);
        assert_eq!(s.g30_mm.z, -5.0);
        assert_eq!(s.start_mm, Vec3::new(1.0, 2.0, 3.0));
    }

    #[test]
    fn refuses_missing_units_and_unknown_names() {
        assert!(Setup::from_toml("[tools]\n1=5\n")
            .unwrap_err()
            .to_string()
            .contains("units"));
        assert!(Setup::from_toml("units=\"mm\"\n[work_offsets]\nG60=[0,0,0]\n").is_err());
        assert!(Setup::from_toml("units=\"cm\"\n").is_err());
    }
}
