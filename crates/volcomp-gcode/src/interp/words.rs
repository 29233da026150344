//! Decoding a block: its words by letter and its G and M codes, checked
//! as LinuxCNC checks them before it executes anything (modal groups,
//! duplicate words, words no code uses).

use super::options::MotionMode;
use super::{invalid, unsupported, Interpreter};
use crate::error::GcodeError;
use crate::lexer::{Lexed, Word};

/// The words of one block by letter, plus its G and M codes.
#[derive(Debug, Clone, Default)]
pub(super) struct WordTable {
    /// `A`–`Z`, then LinuxCNC's polar words `@` (radius) and `^` (angle).
    pub(super) values: [Option<(f64, usize)>; 28],
    /// Column of an `E` word written right after another word's number
    /// (`X1e-05`): scientific notation, read by LinuxCNC as an E word.
    pub(super) exponent_col: Option<usize>,
    pub(super) g: Vec<(u16, usize)>,
    pub(super) m: Vec<(u16, usize)>,
}

/// Slot of a word letter in [`WordTable::values`].
fn slot_of(letter: u8) -> usize {
    match letter {
        b'@' => 26,
        b'^' => 27,
        _ => usize::from(letter - b'A'),
    }
}

impl WordTable {
    pub(super) fn get(&self, letter: u8) -> Option<f64> {
        self.values[slot_of(letter)].map(|(v, _)| v)
    }
    pub(super) fn col(&self, letter: u8) -> Option<usize> {
        self.values[slot_of(letter)].map(|(_, c)| c)
    }
    /// Whether the block has a polar word (`@` radius or `^` angle).
    pub(super) fn has_polar(&self) -> bool {
        self.get(b'@').is_some() || self.get(b'^').is_some()
    }
    pub(super) fn polar_col(&self) -> Option<usize> {
        self.col(b'@').or(self.col(b'^'))
    }
    pub(super) fn has_axis(&self) -> bool {
        self.get(b'X').is_some() || self.get(b'Y').is_some() || self.get(b'Z').is_some()
    }
    pub(super) fn has_g(&self, code: u16) -> bool {
        self.g.iter().any(|(c, _)| *c == code)
    }
    pub(super) fn g_col(&self, code: u16) -> Option<usize> {
        self.g.iter().find(|(c, _)| *c == code).map(|(_, col)| *col)
    }
    /// `Some(true)` when the block has `on`, `Some(false)` when it has `off`
    /// (two codes of one modal group, so never both).
    pub(super) fn switch(&self, on: u16, off: u16) -> Option<bool> {
        if self.has_g(on) {
            Some(true)
        } else if self.has_g(off) {
            Some(false)
        } else {
            None
        }
    }
    pub(super) fn has_m(&self, code: u16) -> bool {
        self.m.iter().any(|(c, _)| *c == code)
    }
}

/// Modal group of a supported G code (×10), or why it is refused.
fn g_group(code: u16) -> Result<u8, &'static str> {
    Ok(match code {
        0 | 10 | 20 | 30 | 730 | 800 | 810..=890 if code.is_multiple_of(10) => 1,
        170 | 180 | 190 => 2,
        900 | 910 => 3,
        901 | 911 => 4,
        930 | 940 | 950 => 5,
        200 | 210 => 6,
        400 => 7,
        430 | 431 | 490 => 8,
        980 | 990 => 10,
        540 | 550 | 560 | 570 | 580 | 590 | 591 | 592 | 593 => 12,
        610 | 611 | 640 => 13,
        960 | 970 => 14,
        150 | 500 | 690 => 16, // cancel polar / scaling / rotation: no-ops here
        40 | 100 | 280 | 281 | 300 | 301 | 530 | 920 | 921 | 922 | 923 => 0,
        410 | 411 | 420 | 421 => return Err("cutter radius compensation (G41/G42) changes the path by the tool radius, which volcomp does not model; post the program with compensation computed in CAM (\"in computer\"), or pass it through without volcomp"),
        680 | 681 => return Err("coordinate rotation (G68) is not a pure translation between program and axis frame; post the program without rotation"),
        510 | 511 => return Err("scaling (G51) is not a pure translation between program and axis frame; post the program without scaling"),
        160 => return Err("polar coordinates (G16) are not interpreted; post the program in Cartesian coordinates"),
        520 => return Err("G52 local offsets are not interpreted yet; use G92 or a work offset"),
        740 | 760 => return Err("this canned cycle is not expanded by volcomp (G73 and G81–G89 are); post the cycle as explicit moves"),
        50 | 51 | 52 | 53 | 70 | 80 | 330 | 331 | 380..=385 | 430..=439 => return Err("this G code moves the machine in a way volcomp does not model"),
        _ => return Err("unknown G code"),
    })
}

/// The canned cycles volcomp expands (G-code × 10).
pub(super) const CYCLE_CODES: [u16; 10] = [730, 810, 820, 830, 840, 850, 860, 870, 880, 890];

fn code_of(value: f64) -> Option<u16> {
    let c = (value * 10.0).round();
    if (value * 10.0 - c).abs() > 1e-6 || !(0.0..=9999.0).contains(&c) {
        return None;
    }
    Some(c as u16)
}

fn code_name(letter: char, code: u16) -> String {
    if code.is_multiple_of(10) {
        format!("{letter}{}", code / 10)
    } else {
        format!("{letter}{}.{}", code / 10, code % 10)
    }
}

impl Interpreter {
    pub(super) fn collect_words(&mut self, line: u64, lexed: &Lexed) -> Result<(), GcodeError> {
        let w = self.words.get_or_insert_with(Box::default);
        w.values = [None; 28];
        w.exponent_col = None;
        w.g.clear();
        w.m.clear();
        let mut prev_number_end = None;
        for word in lexed.words() {
            if word.letter == b'E' && prev_number_end == Some(word.span.start) {
                w.exponent_col = Some(word.span.start);
            }
            prev_number_end = Some(word.span.end);
            let Word {
                letter,
                value,
                span,
                ..
            } = word;
            let col = span.start;
            match letter {
                b'G' => {
                    let code = code_of(*value).ok_or_else(|| {
                        invalid(
                            line,
                            col,
                            format!("G{value} is not a G code"),
                            "G codes have at most one decimal, e.g. G59.1",
                        )
                    })?;
                    let group = g_group(code).map_err(|why| {
                        unsupported(
                            line,
                            col,
                            format!("{} is not supported: {why}", code_name('G', code)),
                            "remove or replace this code; volcomp never guesses what a code means",
                        )
                    })?;
                    // LinuxCNC accepts G80 beside G0/G1 (`G00 G17 G40 G49 G80 G90`,
                    // a common safe-start line): the cycle is cancelled and the
                    // other motion code takes effect.
                    let g80_pair = |a: u16, b: u16| a == 800 || b == 800;
                    if let Some((other, _)) = w.g.iter().find(|(c, _)| {
                        group != 0 && g_group(*c) == Ok(group) && !g80_pair(*c, code)
                    }) {
                        return Err(invalid(
                            line,
                            col,
                            format!(
                                "{} and {} are in the same modal group",
                                code_name('G', *other),
                                code_name('G', code)
                            ),
                            "keep one of them on this line",
                        ));
                    }
                    w.g.push((code, col));
                }
                b'M' => {
                    let code = code_of(*value).filter(|c| c % 10 == 0).ok_or_else(|| {
                        invalid(
                            line,
                            col,
                            format!("M{value} is not an M code"),
                            "M codes are whole numbers",
                        )
                    })?;
                    if matches!(code, 980 | 990) {
                        return Err(unsupported(
                            line,
                            col,
                            "M98/M99 subprogram calls are not interpreted",
                            "expand the subprogram in CAM",
                        ));
                    }
                    w.m.push((code, col));
                }
                b'A' | b'B' | b'C' | b'U' | b'V' | b'W' => {
                    return Err(unsupported(line, col, format!("axis word {} is not supported: volcomp compensates 3-axis (X, Y, Z) machines", *letter as char), "remove rotary/extra axis words or use a 3-axis program"));
                }
                b'N' if w.values[slot_of(b'N')].is_none() => {
                    w.values[slot_of(b'N')] = Some((*value, col));
                }
                _ => {
                    let slot = &mut w.values[slot_of(*letter)];
                    if slot.is_some() {
                        return Err(invalid(
                            line,
                            col,
                            format!("{} word given twice on one line", *letter as char),
                            "remove one of them",
                        ));
                    }
                    *slot = Some((*value, col));
                }
            }
        }
        Ok(())
    }

    /// The motion a block will make, as LinuxCNC's `enhance_block` decides
    /// it: the block's own group-1 code, else the modal motion when the block
    /// has axis or polar words, or arc centre words in an arc mode.
    pub(super) fn motion_to_be(&self, w: &WordTable) -> Option<MotionMode> {
        for (code, mode) in [
            (0u16, MotionMode::Rapid),
            (10, MotionMode::Feed),
            (20, MotionMode::Cw),
            (30, MotionMode::Ccw),
        ]
        .into_iter()
        .chain(CYCLE_CODES.map(|c| (c, MotionMode::Cycle(c))))
        {
            if w.has_g(code) {
                return Some(mode);
            }
        }
        if w.has_g(800) || [100u16, 280, 300, 920].iter().any(|c| w.has_g(*c)) {
            return None;
        }
        let ijk = [b'I', b'J', b'K'].iter().any(|l| w.get(*l).is_some());
        match self.motion_mode {
            m if w.has_axis() || w.has_polar() => m,
            m @ Some(MotionMode::Cw | MotionMode::Ccw) if ijk => m,
            _ => None,
        }
    }

    /// Refuses words that no code of the block uses, as LinuxCNC's
    /// `Interp::check_other_codes` (src/emc/rs274ngc/interp_check.cc) does
    /// for the codes volcomp interprets: a stray word is a sign that the
    /// program means something volcomp (and the controller) would not do.
    pub(super) fn check_word_use(&self, line: u64, w: &WordTable) -> Result<(), GcodeError> {
        let motion = self.motion_to_be(w);
        let arc = matches!(motion, Some(MotionMode::Cw | MotionMode::Ccw));
        let cycle = matches!(motion, Some(MotionMode::Cycle(_)));
        let g10 = w.has_g(100);
        let g87 = motion == Some(MotionMode::Cycle(870));
        let m_any = |codes: &[u16]| codes.iter().any(|c| w.has_m(*c));
        let used = |letter: u8| -> Result<(), &'static str> {
            let (ok, why) = match letter {
                b'D' => (w.has_g(960), "D word with no G41, G41.1, G42, G42.1 or G96 to use it"),
                b'E' => (m_any(&[660, 670, 680]), "E word with no G70, G76, M66, M67 or M68 to use it"),
                b'H' => (w.has_g(430), "H word with no G43 or G76 to use it"),
                b'I' => (arc || g10 || g87, "I word with no G2, G3, G10 or G87 to use it"),
                b'J' => (arc || g10 || g87, "J word with no G2, G3, G10 or G87 to use it"),
                b'K' => (arc || g87, "K word with no G2, G3 or G87 to use it"),
                b'L' => (cycle || g10 || m_any(&[660]), "L word with no G10, canned cycle or M66 to use it"),
                b'P' => (
                    g10 || w.has_g(40) || w.has_g(640) || arc
                        || matches!(motion, Some(MotionMode::Cycle(820 | 840 | 860 | 880 | 890)))
                        || m_any(&[500, 510, 520, 530, 620, 630, 640, 650, 660, 190]),
                    "P word with no G2, G3, G4, G10, G64, G82, G84, G86, G88, G89 or M19, M50–M53, M62–M66 to use it",
                ),
                b'Q' => (
                    g10 || w.has_g(640) || m_any(&[660, 670, 680, 610, 190])
                        || matches!(motion, Some(MotionMode::Cycle(730 | 830))),
                    "Q word with no G10, G64, G73, G83, M19, M61, M66, M67 or M68 to use it",
                ),
                b'R' => (
                    // LinuxCNC 2.9 has no G64 R (it came with 2.10's planner).
                    arc || cycle || g10 || m_any(&[190]),
                    "R word with no G2, G3, canned cycle, G10 or M19 to use it",
                ),
                _ => (true, ""),
            };
            if ok {
                Ok(())
            } else {
                Err(why)
            }
        };
        for letter in *b"DEHIJKLPQR" {
            let Some(col) = w.col(letter) else { continue };
            if let Err(why) = used(letter) {
                if letter == b'E' && w.exponent_col == Some(col) {
                    return Err(invalid(
                        line,
                        col,
                        "scientific notation (such as `1e-05`) is not G-code: the `e` starts an E word, which LinuxCNC refuses here (\"E word with no G70, G76, M66, M67 or M68 to use it\")",
                        "write the number in plain decimals, e.g. X0.00001 instead of X1e-05",
                    ));
                }
                return Err(invalid(
                    line,
                    col,
                    format!("{why}; LinuxCNC refuses it too"),
                    format!(
                        "remove the {} word, or add the code that uses it",
                        letter as char
                    ),
                ));
            }
        }
        Ok(())
    }

    pub(super) fn motion_word_col(&self, w: &WordTable) -> Option<usize> {
        [0u16, 10, 20, 30]
            .into_iter()
            .chain(CYCLE_CODES)
            .find_map(|c| w.g_col(c))
    }
}
