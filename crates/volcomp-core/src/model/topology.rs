//! The kinematic chain of a 3-axis machine, written as a structural
//! configuration code (ISO 10791-1 / ISO 230-1 Annex style).
//!
//! The code lists the links from the workpiece to the tool:
//!
//! ```text
//! w X' Y' b Z t     the seed machine: the table rides on X, X on Y, Y on the
//!                   bed; the spindle rides on Z, Z on the bed (column)
//! w b X Y Z t       gantry / bridge: every axis moves the tool
//! w Y' b X Z t      table on Y; a travelling column on X carries Z
//! ```
//!
//! * `w` is the workpiece, `t` the tool, `b` the machine base (bed, frame);
//! * an axis between `w` and `b` moves the workpiece (ISO 841 writes it with a
//!   prime, `X'`: the table moves opposite to the axis' positive direction);
//!   an axis between `b` and `t` moves the tool;
//! * the order is the order in which the axes carry each other: in `w X' Y' b`
//!   the X carriage rides on the Y carriage.
//!
//! Blanks, `-` and `,` between links are ignored, so `wX'Y'bZt`,
//! `w-X'-Y'-b-Z-t` and `W X Y B Z T` are the same chain; the long words
//! `workpiece`, `base` (or `bed`) and `tool` may replace `w`, `b`, `t`. The
//! prime is optional, but where it is written it must be on the workpiece side.
//!
//! What the chain decides (see `docs/kinematic.md`): an angular error of an
//! axis acts on every link between that axis and the tool, so its Abbe arm is
//! made of the positions of the axes after it in the chain plus the tool
//! offset. The position of `b` matters only when angular errors were recorded
//! as rotations of the moving part (`angles = "moving-part"` in the model
//! file): for the axes that carry the workpiece those are the opposite of the
//! tool-relative-to-workpiece rotations.

use std::fmt;

/// A validated kinematic chain from workpiece to tool.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Topology {
    /// Axis indices (0 = X, 1 = Y, 2 = Z) in chain order, workpiece first.
    order: [usize; 3],
    /// How many of them lie between `w` and `b` (they carry the workpiece).
    workpiece_side: usize,
}

pub use crate::error::domain::TopologyError;

const AXES: [char; 3] = ['X', 'Y', 'Z'];

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Link {
    Workpiece,
    Base,
    Tool,
    Axis { axis: usize, primed: bool },
}

impl Topology {
    /// The seed machine: table on X, X on Y, spindle on Z (`w X' Y' b Z t`).
    pub const SEED: Topology = Topology {
        order: [0, 1, 2],
        workpiece_side: 2,
    };

    /// Builds a chain from its axis order (workpiece first) and the number of
    /// axes that carry the workpiece; `None` unless `order` is a permutation
    /// of 0, 1, 2 and `workpiece_side ≤ 3`.
    pub fn new(order: [usize; 3], workpiece_side: usize) -> Option<Topology> {
        let mut seen = [false; 3];
        for &a in &order {
            if a > 2 || seen[a] {
                return None;
            }
            seen[a] = true;
        }
        (workpiece_side <= 3).then_some(Topology {
            order,
            workpiece_side,
        })
    }

    /// Parses a chain such as `w X' Y' b Z t`.
    ///
    /// ```
    /// use volcomp_core::model::topology::Topology;
    /// let t: Topology = "wX'Y'bZt".parse().unwrap();
    /// assert_eq!(t, Topology::SEED);
    /// assert_eq!(t.to_string(), "w X' Y' b Z t");
    /// let e = "w X' Y' Z t".parse::<Topology>().unwrap_err();
    /// assert!(e.message.contains("base"));
    /// ```
    pub fn parse(text: &str) -> Result<Topology, TopologyError> {
        let err = |column: usize, message: String, help: &str| TopologyError {
            text: text.to_string(),
            column,
            message,
            help: help.to_string(),
        };
        let grammar = "write the links from workpiece to tool, e.g. `w X' Y' b Z t` (table on X, X on Y, spindle on Z) or `w b X Y Z t` (gantry)";
        let chars: Vec<char> = text.chars().collect();
        let mut links: Vec<(Link, usize)> = Vec::new();
        let mut i = 0;
        while i < chars.len() {
            let c = chars[i];
            let column = i + 1;
            if c.is_whitespace() || c == '-' || c == ',' {
                i += 1;
                continue;
            }
            if c == '\'' || c == '’' || c == '′' {
                match links.last_mut() {
                    Some((Link::Axis { primed, .. }, _)) if !*primed => *primed = true,
                    _ => {
                        return Err(err(
                            column,
                            "a prime must follow an axis letter".into(),
                            "write X' for an axis that moves the workpiece",
                        ))
                    }
                }
                i += 1;
                continue;
            }
            let rest: String = chars[i..].iter().collect::<String>().to_ascii_lowercase();
            let word = ["workpiece", "base", "bed", "tool"]
                .into_iter()
                .find(|w| rest.starts_with(w));
            let (link, len) = match (word, c.to_ascii_lowercase()) {
                (Some(w), _) => (
                    match w {
                        "workpiece" => Link::Workpiece,
                        "tool" => Link::Tool,
                        _ => Link::Base,
                    },
                    w.chars().count(),
                ),
                (None, 'w') => (Link::Workpiece, 1),
                (None, 'b') => (Link::Base, 1),
                (None, 't') => (Link::Tool, 1),
                (None, 'x') => (
                    Link::Axis {
                        axis: 0,
                        primed: false,
                    },
                    1,
                ),
                (None, 'y') => (
                    Link::Axis {
                        axis: 1,
                        primed: false,
                    },
                    1,
                ),
                (None, 'z') => (
                    Link::Axis {
                        axis: 2,
                        primed: false,
                    },
                    1,
                ),
                _ => {
                    return Err(err(
                        column,
                        format!("`{c}` is not a link of a 3-axis chain"),
                        "links are w (workpiece), b (base), t (tool) and the axes X, Y, Z",
                    ))
                }
            };
            links.push((link, column));
            i += len;
        }
        let end = chars.len() + 1;
        let (Some(first), Some(last)) = (links.first(), links.last()) else {
            return Err(err(1, "the chain is empty".into(), grammar));
        };
        for ((link, col), end, must) in [
            (first, Link::Workpiece, "start at the workpiece `w`"),
            (last, Link::Tool, "end at the tool `t`"),
        ] {
            if *link != end {
                return Err(err(*col, format!("the chain must {must}"), grammar));
            }
        }
        let mut order = Vec::with_capacity(3);
        let mut base: Option<usize> = None;
        let mut seen = [None::<usize>; 3];
        for (k, (link, col)) in links.iter().enumerate() {
            match *link {
                Link::Workpiece if k != 0 => {
                    return Err(err(
                        *col,
                        "the workpiece `w` appears more than once".into(),
                        grammar,
                    ))
                }
                Link::Tool if k + 1 != links.len() => {
                    return Err(err(
                        *col,
                        "the tool `t` appears before the end of the chain".into(),
                        grammar,
                    ))
                }
                Link::Base => {
                    if base.is_some() {
                        return Err(err(
                            *col,
                            "the base `b` appears more than once".into(),
                            "a serial 3-axis machine has one base: the axes before it carry the workpiece, the axes after it the tool",
                        ));
                    }
                    base = Some(order.len());
                }
                Link::Axis { axis, primed } => {
                    if let Some(first) = seen[axis] {
                        return Err(err(
                            *col,
                            format!(
                                "axis {} appears twice (first at character {first})",
                                AXES[axis]
                            ),
                            "name each of X, Y and Z exactly once",
                        ));
                    }
                    seen[axis] = Some(*col);
                    if primed && base.is_some() {
                        return Err(err(
                            *col,
                            format!(
                                "{}' is primed but lies between the base and the tool",
                                AXES[axis]
                            ),
                            "a prime marks an axis that moves the workpiece: it belongs between w and b",
                        ));
                    }
                    order.push(axis);
                }
                _ => {}
            }
        }
        for (a, s) in seen.iter().enumerate() {
            if s.is_none() {
                return Err(err(
                    end,
                    format!("axis {} is missing", AXES[a]),
                    "name each of X, Y and Z exactly once",
                ));
            }
        }
        let Some(workpiece_side) = base else {
            return Err(err(
                end,
                "the chain has no base `b`".into(),
                "put b where the chain meets the machine base: after the axes that carry the workpiece, before those that carry the tool",
            ));
        };
        Ok(Topology {
            order: [order[0], order[1], order[2]],
            workpiece_side,
        })
    }

    /// Axis indices in chain order, workpiece first.
    pub fn order(&self) -> [usize; 3] {
        self.order
    }

    /// Position of `axis` in the chain (0 = next to the workpiece).
    pub fn rank(&self, axis: usize) -> usize {
        self.order.iter().position(|a| *a == axis).unwrap_or(0)
    }

    /// The axes between `axis` and the tool, in chain order: the links an
    /// angular error of `axis` swings (besides the tool offset).
    pub fn after(&self, axis: usize) -> &[usize] {
        &self.order[self.rank(axis) + 1..]
    }

    /// Whether `axis` moves the workpiece (lies between `w` and `b`).
    pub fn carries_workpiece(&self, axis: usize) -> bool {
        self.rank(axis) < self.workpiece_side
    }

    /// Number of axes between `w` and `b`.
    pub fn workpiece_side(&self) -> usize {
        self.workpiece_side
    }
}

impl std::str::FromStr for Topology {
    type Err = TopologyError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Topology::parse(s)
    }
}

impl Default for Topology {
    fn default() -> Self {
        Topology::SEED
    }
}

impl fmt::Display for Topology {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("w")?;
        for (k, a) in self.order.iter().enumerate() {
            if k == self.workpiece_side {
                f.write_str(" b")?;
            }
            write!(f, " {}", AXES[*a])?;
            if k < self.workpiece_side {
                f.write_str("'")?;
            }
        }
        if self.workpiece_side == 3 {
            f.write_str(" b")?;
        }
        f.write_str(" t")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_usual_spellings() {
        for s in [
            "w X' Y' b Z t",
            "wX'Y'bZt",
            "WXYbZT",
            "w-X'-Y'-b-Z-t",
            "workpiece X' Y' base Z tool",
            "w X’ Y’ bed Z t",
        ] {
            assert_eq!(Topology::parse(s).unwrap(), Topology::SEED, "{s}");
        }
        let gantry = Topology::parse("w b X Y Z t").unwrap();
        assert_eq!(gantry.order(), [0, 1, 2]);
        assert_eq!(gantry.workpiece_side(), 0);
        assert_eq!(gantry.to_string(), "w b X Y Z t");
        let column = Topology::parse("w Y' b X Z t").unwrap();
        assert_eq!(column.order(), [1, 0, 2]);
        assert!(column.carries_workpiece(1));
        assert!(!column.carries_workpiece(0));
        assert_eq!(column.after(1), &[0, 2]);
        assert_eq!(column.after(0), &[2]);
        assert_eq!(column.after(2), &[] as &[usize]);
        let all_table = Topology::parse("w Z' Y' X' b t").unwrap();
        assert_eq!(all_table.to_string(), "w Z' Y' X' b t");
        for t in [Topology::SEED, gantry, column, all_table] {
            assert_eq!(Topology::parse(&t.to_string()).unwrap(), t);
        }
    }

    #[test]
    fn refusals_name_the_character() {
        let cases = [
            ("", 1, "empty"),
            ("X' Y' b Z t", 1, "start at the workpiece"),
            ("w X' Y' b Z", 11, "end at the tool"),
            ("w X' X' b Z t", 6, "appears twice"),
            ("w X' Y' Z t", 12, "no base"),
            ("w X' Y' b b Z t", 11, "more than once"),
            ("w X' b Z t", 11, "axis Y is missing"),
            ("w X' b Y' Z t", 8, "primed"),
            ("w X' Q b Y Z t", 6, "not a link"),
            ("w ' X b Y Z t", 3, "prime must follow"),
            ("w X Y t b Z t", 7, "before the end"),
        ];
        for (text, column, words) in cases {
            let e = Topology::parse(text).unwrap_err();
            assert_eq!(e.column, column, "{text}: {e}");
            assert!(e.message.contains(words), "{text}: {e}");
        }
    }

    #[test]
    fn new_checks_the_permutation() {
        assert_eq!(Topology::new([0, 1, 2], 2), Some(Topology::SEED));
        assert_eq!(Topology::new([0, 0, 2], 2), None);
        assert_eq!(Topology::new([0, 1, 2], 4), None);
    }
}
