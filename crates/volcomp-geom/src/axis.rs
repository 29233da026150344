//! The three linear machine axes as a type rather than a bare index.

use std::fmt;
use std::str::FromStr;

/// A linear machine axis.
///
/// Its index (X = 0, Y = 1, Z = 2) is the component of a [`crate::Vec3`]
/// and the row of the ISO 230-1 error-component tables; serialised as the
/// upper-case letter (`"X"`).
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize,
)]
pub enum Axis {
    /// The X axis (index 0).
    X,
    /// The Y axis (index 1).
    Y,
    /// The Z axis (index 2).
    Z,
}

impl Axis {
    /// The three axes in index order.
    pub const ALL: [Axis; 3] = [Axis::X, Axis::Y, Axis::Z];

    /// The component index: X = 0, Y = 1, Z = 2.
    #[inline]
    pub const fn index(self) -> usize {
        match self {
            Axis::X => 0,
            Axis::Y => 1,
            Axis::Z => 2,
        }
    }

    /// The axis of a component index, `None` beyond 2.
    #[inline]
    pub const fn from_index(i: usize) -> Option<Axis> {
        match i {
            0 => Some(Axis::X),
            1 => Some(Axis::Y),
            2 => Some(Axis::Z),
            _ => None,
        }
    }

    /// The upper-case letter: `'X'`, `'Y'` or `'Z'`.
    #[inline]
    pub const fn letter(self) -> char {
        match self {
            Axis::X => 'X',
            Axis::Y => 'Y',
            Axis::Z => 'Z',
        }
    }
}

impl fmt::Display for Axis {
    /// The upper-case letter.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.letter())
    }
}

/// A text that does not name an axis.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ParseAxisError {
    /// The text as given.
    pub text: String,
}

impl fmt::Display for ParseAxisError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "`{}` is not an axis: write X, Y or Z (x, y and z are accepted too)",
            self.text.escape_debug()
        )
    }
}

impl std::error::Error for ParseAxisError {}

impl FromStr for Axis {
    type Err = ParseAxisError;

    /// Accepts exactly `X`, `Y`, `Z`, `x`, `y` or `z` (no spaces, no
    /// other spelling: a wrong axis is refused, not guessed).
    fn from_str(s: &str) -> Result<Axis, ParseAxisError> {
        match s {
            "X" | "x" => Ok(Axis::X),
            "Y" | "y" => Ok(Axis::Y),
            "Z" | "z" => Ok(Axis::Z),
            _ => Err(ParseAxisError {
                text: s.chars().take(40).collect(),
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_and_from_index_are_inverse() {
        assert_eq!(Axis::ALL.map(Axis::index), [0, 1, 2]);
        for a in Axis::ALL {
            assert_eq!(Axis::from_index(a.index()), Some(a));
        }
        assert_eq!(Axis::from_index(3), None);
        assert_eq!(Axis::from_index(usize::MAX), None);
    }

    #[test]
    fn letters_and_display() {
        assert_eq!(Axis::ALL.map(Axis::letter), ['X', 'Y', 'Z']);
        assert_eq!(Axis::Y.to_string(), "Y");
        assert_eq!(format!("{}{}", Axis::X, Axis::Z), "XZ");
    }

    #[test]
    fn parses_upper_and_lower_case_only() {
        assert_eq!("X".parse(), Ok(Axis::X));
        assert_eq!("x".parse(), Ok(Axis::X));
        assert_eq!("Y".parse(), Ok(Axis::Y));
        assert_eq!("y".parse(), Ok(Axis::Y));
        assert_eq!("Z".parse(), Ok(Axis::Z));
        assert_eq!("z".parse(), Ok(Axis::Z));
        for bad in ["", " X", "XY", "A", "0", "ｘ"] {
            let e = bad.parse::<Axis>().unwrap_err();
            assert_eq!(e.text, bad);
            let msg = e.to_string();
            assert!(msg.contains("write X, Y or Z"), "{msg}");
        }
        assert_eq!(
            "w".parse::<Axis>().unwrap_err().to_string(),
            "`w` is not an axis: write X, Y or Z (x, y and z are accepted too)"
        );
    }

    #[test]
    fn serde_uses_the_upper_case_letter() {
        assert_eq!(serde_json::to_string(&Axis::Z).unwrap(), "\"Z\"");
        assert_eq!(serde_json::from_str::<Axis>("\"Y\"").unwrap(), Axis::Y);
        assert!(serde_json::from_str::<Axis>("\"y\"").is_err());
    }
}
