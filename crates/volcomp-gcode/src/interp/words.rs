//! Decoding a block: its words by letter and its G and M codes, checked
//! as LinuxCNC checks them before it executes anything (modal groups,
//! duplicate words, words no code uses).

use super::options::MotionMode;
use super::{invalid, unsupported, Interpreter};
use crate::error::GcodeError;
use crate::lexer::{Lexed, Token, Word};
use crate::setup::AxisLetters;

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
    /// The codes of `g` and `m` as sets: the interpreter asks "has the
    /// block G…?" some hundred times a block, one bit test each.
    g_set: CodeSet,
    m_set: CodeSet,
}

/// A set of G or M codes (× 10, as in [`WordTable::g`]) below 1024, which
/// holds every code the interpreter accepts.
#[derive(Debug, Clone, Copy, Default)]
struct CodeSet([u64; 16]);

impl CodeSet {
    const LIMIT: u16 = 1024;

    fn insert(&mut self, code: u16) {
        if code < Self::LIMIT {
            self.0[usize::from(code / 64)] |= 1 << (code % 64);
        }
    }

    /// `Some(member)` for codes below the limit, `None` above it.
    fn contains(&self, code: u16) -> Option<bool> {
        (code < Self::LIMIT).then(|| self.0[usize::from(code / 64)] & (1 << (code % 64)) != 0)
    }

    /// Whether `codes` (this set's codes with their columns) has `code`:
    /// one bit test below the limit.
    fn has(&self, codes: &[(u16, usize)], code: u16) -> bool {
        self.contains(code)
            .unwrap_or_else(|| codes.iter().any(|(c, _)| *c == code))
    }

    /// The column of `code` in `codes` (this set's codes with their
    /// columns), if the block has it.
    fn col(&self, codes: &[(u16, usize)], code: u16) -> Option<usize> {
        if self.contains(code) == Some(false) {
            return None;
        }
        codes.iter().find(|(c, _)| *c == code).map(|(_, col)| *col)
    }
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
        self.get(b'X').is_some()
            || self.get(b'Y').is_some()
            || self.get(b'Z').is_some()
            || self.extra_col().is_some()
    }
    pub(super) fn has_g(&self, code: u16) -> bool {
        self.g_set.has(&self.g, code)
    }
    pub(super) fn g_col(&self, code: u16) -> Option<usize> {
        self.g_set.col(&self.g, code)
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
        self.m_set.has(&self.m, code)
    }
    pub(super) fn m_col(&self, code: u16) -> Option<usize> {
        self.m_set.col(&self.m, code)
    }
}

/// Modal group of a supported G code (×10), or why it is refused.
fn g_group(code: u16) -> Result<u8, &'static str> {
    Ok(match code {
        0 | 10 | 20 | 30 | 50 | 51 | 52 | 730 | 740 | 800 | 810 | 820 | 830 | 840 | 850 | 860 | 870 | 880 | 890 => 1,
        170 | 180 | 190 => 2,
        900 | 910 => 3,
        901 | 911 => 4,
        930 | 940 | 950 => 5,
        200 | 210 => 6,
        70 | 80 => 15,
        400 | 410 | 411 | 420 | 421 => 7,
        430 | 431 | 490 => 8,
        980 | 990 => 10,
        540 | 550 | 560 | 570 | 580 | 590 | 591 | 592 | 593 => 12,
        610 | 611 | 640 => 13,
        960 | 970 => 14,
        150 | 500 | 690 => 16, // cancel polar / scaling / rotation: no-ops here
        40 | 53 | 100 | 280 | 281 | 300 | 301 | 520 | 530 | 920 | 921 | 922 | 923 => 0,
        680 | 681 => return Err("coordinate rotation (G68) is not a pure translation between program and axis frame; post the program without rotation"),
        510 | 511 => return Err("scaling (G51) is not a pure translation between program and axis frame; post the program without scaling"),
        160 => return Err("polar coordinates (G16) are not interpreted; post the program in Cartesian coordinates"),
        760 => return Err("G76 threading is a lathe cycle, not expanded by volcomp (G73, G74 and G81–G89 are); post the cycle as explicit moves"),
        // Probing (G38.2–G38.5) is read only when the caller asks for it
        // (`InterpOptions::accept_probing`, checked in `collect_words`).
        382..=385 => 1,
        380 | 381 => return Err(PROBING_REFUSED),
        330 | 331 => 1,
        700..=722 => return Err("lathe roughing and finishing cycles (G70–G72) are for lathes; volcomp compensates the X, Y, Z of milling machines"),
        430..=439 => return Err("this tool length offset (G43.2) is not interpreted; give the summed length to G43 H in the set-up's tool table"),
        _ => return Err("unknown G code: LinuxCNC does not know it either, unless the machine's INI file remaps it to a subroutine, which volcomp cannot see; write out what it does in the program"),
    })
}

/// Modal group of an M code (×10) as LinuxCNC 2.9 has them
/// (`Interp::_ems`, src/emc/rs274ngc/interp_array.cc), or why it is refused.
fn m_group(code: u16) -> Result<u8, &'static str> {
    Ok(match code / 10 {
        0 | 1 | 2 | 30 | 60 | 99 => 4,
        3..=5 | 19 | 70 | 71 => 7,
        6 | 61 => 6,
        7..=9 => 8,
        48..=53 => 9,
        62..=65 | 67 | 68 => 5,
        66 => return Err("M66 waits for an input of the machine and stores its state in #5399; what it reads is known only when the machine runs; remove the M66 (and what depends on #5399) to compensate the program"),
        72 | 73 => 7,
        98 => 10,
        100..=199 => return Err("M100–M199 run the machine's own user programs (files in its PROGRAM_PREFIX), which volcomp cannot see; LinuxCNC refuses them when the file is missing (\"Unknown m code used\"); remove it, or run that part uncompensated"),
        _ => return Err("unknown M code (\"Unknown m code used\" in LinuxCNC, or above M199: \"M-code greater than 199\"); a remapped M code runs the machine's own subroutine, which volcomp cannot see"),
    })
}

/// The probing moves G38.2–G38.5 (G-code × 10), read only with
/// `InterpOptions::accept_probing`.
pub(super) const PROBE_CODES: [u16; 4] = [382, 383, 384, 385];

/// Why probing is refused unless the caller asks for it.
const PROBING_REFUSED: &str = "probing ends where the probe touches, which is known only when the machine runs; volcomp cannot know the path after it (LinuxCNC's later moves may use the probed position, #5061–#5069)";

/// The canned cycles volcomp expands (G-code × 10).
pub(super) const CYCLE_CODES: [u16; 11] = [730, 740, 810, 820, 830, 840, 850, 860, 870, 880, 890];

/// The motion a G code (× 10) of modal group 1 selects.
pub(super) fn motion_of(code: u16) -> Option<MotionMode> {
    Some(match code {
        0 => MotionMode::Rapid,
        10 => MotionMode::Feed,
        20 => MotionMode::Cw,
        30 => MotionMode::Ccw,
        50..=53 => MotionMode::Spline(code),
        330 | 331 => MotionMode::Synced(code),
        c if PROBE_CODES.contains(&c) => MotionMode::Probe(c),
        c if CYCLE_CODES.contains(&c) => MotionMode::Cycle(c),
        _ => return None,
    })
}

/// A G code ×10 as LinuxCNC's `read_g` (interp_read.cc) makes it: ten
/// times the value, taken to the whole number below unless that is more
/// than 0.001 away ("G-code out of range"), then the one above when within
/// 0.001; negative ("Negative G-code used") or above G99.9 is refused.
fn g_code_of(value: f64) -> Result<u16, &'static str> {
    let v = 10.0 * value;
    let f = v.floor();
    let c = if v - f > 0.999 {
        v.ceil()
    } else if v - f > 0.001 {
        return Err("G-code out of range");
    } else {
        f
    };
    if c < 0.0 {
        return Err("Negative G-code used");
    }
    if c > 999.0 || c.is_nan() {
        return Err("G-code out of range");
    }
    Ok(c as u16)
}

/// A word LinuxCNC reads with `read_integer_value` (M, T, H, L: within
/// 0.0001 of a whole number, interp_read.cc), with its own refusal of a
/// negative value (`read_m`, `read_t`, `read_h`, `read_l`).
fn integer_word(letter: u8, value: f64) -> Result<f64, String> {
    let f = value.floor();
    let i = if value - f > 0.9999 {
        value.ceil()
    } else if value - f > 0.0001 {
        return Err(format!(
            "{}{value} is not a whole number: LinuxCNC reads {} words as whole numbers (\"Non integer value for integer\")",
            letter as char, letter as char
        ));
    } else {
        f
    };
    let negative = match letter {
        // The messages of rs274ngc_return.hh.
        b'M' => (i < 0.0).then_some("Negative m code used"),
        b'T' => (i < 0.0).then_some("Negative tool id (tool not found)"),
        // H-1 is LinuxCNC's own "no H" value, accepted by `read_h`.
        b'H' => (i < -1.0).then_some("Negative h word used"),
        _ => (i < 0.0).then_some("Negative l word used"),
    };
    if let Some(why) = negative {
        return Err(format!(
            "{}{value} is negative; LinuxCNC refuses it (\"{why}\")",
            letter as char
        ));
    }
    if i > f64::from(i32::MAX) {
        return Err(format!("{}{value} is out of range", letter as char));
    }
    Ok(i)
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
        let axes = self.setup.axes;
        let probing = self.options.accept_probing;
        let w = self.words.get_or_insert_with(Box::default);
        w.values = [None; 28];
        w.exponent_col = None;
        w.g.clear();
        w.m.clear();
        w.g_set = CodeSet::default();
        w.m_set = CodeSet::default();
        let mut prev_number_end = None;
        // LinuxCNC reads an N word only as the block's first item (after a
        // block delete `/`, `read_items`); elsewhere `n` has no reader.
        let n_at = lexed.tokens.iter().find_map(|t| match t {
            Token::BlockDelete(_) => None,
            Token::Word(w) if w.letter == b'N' => Some(Some(w.span.start)),
            _ => Some(None),
        });
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
            // A code volcomp refuses, with why.
            let not_supported = |letter: char, code: u16, why: &str| {
                unsupported(
                    line,
                    col,
                    format!("{} is not supported: {why}", code_name(letter, code)),
                    "remove or replace this code; volcomp never guesses what a code means",
                )
            };
            let value = &match letter {
                b'M' | b'T' | b'H' | b'L' => integer_word(*letter, *value).map_err(|why| {
                    invalid(line, col, why, "write a whole number, e.g. T2 or L3")
                })?,
                _ => *value,
            };
            match letter {
                b'G' => {
                    let code = g_code_of(*value).map_err(|why| {
                        invalid(
                            line,
                            col,
                            format!("G{value} is not a G code; LinuxCNC refuses it (\"{why}\")"),
                            "G codes have at most one decimal, e.g. G59.1",
                        )
                    })?;
                    if PROBE_CODES.contains(&code) && !probing {
                        return Err(not_supported('G', code, PROBING_REFUSED));
                    }
                    let group = g_group(code).map_err(|why| not_supported('G', code, why))?;
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
                    w.g_set.insert(code);
                }
                b'M' => {
                    // A whole number (above): M199 and below are looked up.
                    let code = (*value * 10.0).min(9990.0) as u16;
                    let group = m_group(code).map_err(|why| not_supported('M', code, why))?;
                    if let Some((other, _)) = w.m.iter().find(|(c, _)| m_group(*c) == Ok(group)) {
                        return Err(invalid(
                            line,
                            col,
                            format!(
                                "{} and {} are in the same modal group; LinuxCNC refuses it (\"Two M codes used from same modal group\")",
                                code_name('M', *other),
                                code_name('M', code)
                            ),
                            "keep one of them on this line",
                        ));
                    }
                    if matches!(code, 980 | 990) {
                        return Err(unsupported(
                            line,
                            col,
                            "M98/M99 subprogram calls are not interpreted",
                            "expand the subprogram in CAM",
                        ));
                    }
                    w.m.push((code, col));
                    w.m_set.insert(code);
                }
                b'N' if n_at == Some(Some(col)) => {
                    // `read_n_number` reads digits only (`read_integer_unsigned`).
                    if *value < 0.0 {
                        return Err(invalid(
                            line,
                            col,
                            "a negative line number: LinuxCNC reads N as digits and refuses it (\"Bad format unsigned integer\")",
                            "write the line number without a sign",
                        ));
                    }
                    w.values[slot_of(b'N')] = Some((*value, col));
                }
                b'N' => {
                    return Err(invalid(
                        line,
                        col,
                        "an N word that does not start the line: LinuxCNC reads the line number only as the first word of a block, and refuses it elsewhere (\"Bad character 'n' used\")",
                        "move the N word to the start of the line, or remove it",
                    ));
                }
                l if AxisLetters::ALL.contains(l) && !axes.contains(*l) => {
                    // Interp::init drops the reader of every axis the
                    // machine lacks (rs274ngc_pre.cc, GET_EXTERNAL_AXIS_MASK).
                    return Err(invalid(
                        line,
                        col,
                        format!(
                            "the machine has no {} axis (its axes are {}); LinuxCNC refuses the word (\"Bad character '{}' used\")",
                            *l as char,
                            axes.letters(),
                            l.to_ascii_lowercase() as char
                        ),
                        format!(
                            "if the machine has it, name it in the set-up file: axes = \"{}{}\"",
                            axes.letters(),
                            *l as char
                        ),
                    ));
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
        // Lathe diameter mode (G7): an X word is a diameter. LinuxCNC halves
        // it as it reads it (`Interp::read_x`) and again corrects it when
        // the line itself switches the mode (`convert_lathe_diameter_mode`,
        // interp_convert.cc), so every use of the line's X word (motion,
        // G92, G10, G52, cycles) sees half of it exactly when the mode after
        // the line's G7/G8 is diameter. I and K are not scaled.
        self.diameter_mode = w.switch(70, 80).unwrap_or(self.diameter_mode);
        if self.diameter_mode {
            let x = &mut w.values[slot_of(b'X')];
            if let Some((v, _)) = x.as_mut() {
                *v /= 2.0;
            }
        }
        Ok(())
    }

    /// The motion a block will make, as LinuxCNC's `enhance_block` decides
    /// it: the block's own group-1 code, else the modal motion when the block
    /// has axis or polar words, or arc centre words in an arc mode.
    pub(super) fn motion_to_be(&self, w: &WordTable) -> Option<MotionMode> {
        // G5.3 (non-modal) yields to G0–G5.2 on its line.
        let codes = [0u16, 10, 20, 30, 50, 51, 52, 53, 330, 331];
        if let Some(code) = codes
            .into_iter()
            .chain(CYCLE_CODES)
            .chain(PROBE_CODES)
            .find(|&code| w.has_g(code))
        {
            return motion_of(code);
        }
        if w.has_g(800) || [100u16, 280, 300, 520, 920].iter().any(|c| w.has_g(*c)) {
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
        let comp = [410u16, 411, 420, 421].iter().any(|c| w.has_g(*c));
        let g87 = motion == Some(MotionMode::Cycle(870));
        let synced = matches!(motion, Some(MotionMode::Synced(_)));
        let tap = motion == Some(MotionMode::Synced(331));
        let spline = |codes: &[u16]| codes.iter().any(|c| motion == Some(MotionMode::Spline(*c)));
        let (g5, g5_ij, g52) = (spline(&[50]), spline(&[50, 51]), spline(&[52]));
        let m_any = |codes: &[u16]| codes.iter().any(|c| w.has_m(*c));
        let used = |letter: u8| -> Result<(), &'static str> {
            let (ok, why) = match letter {
                b'D' => (comp || w.has_g(960), "D word with no G41, G41.1, G42, G42.1 or G96 to use it"),
                b'E' => (m_any(&[660, 670, 680]), "E word with no G70, G76, M66, M67 or M68 to use it"),
                b'H' => (w.has_g(430), "H word with no G43 or G76 to use it"),
                b'I' => (arc || g10 || g5_ij || g87 || tap, "I word with no G2, G3, G5, G5.1, G10, G33.1 or G87 to use it"),
                b'J' => (arc || g10 || g5_ij || g87, "J word with no G2, G3, G5, G5.1, G10 or G87 to use it"),
                b'K' => (arc || g87 || synced, "K word with no G2, G3, G33, G33.1 or G87 to use it"),
                // LinuxCNC allows L with G73 and G81–G89 only, not G74.
                b'L' => ((cycle && motion != Some(MotionMode::Cycle(740))) || g10 || g52 || comp || m_any(&[660]), "L word with no G10, canned cycle or M66 to use it"),
                b'P' => (
                    g10 || w.has_g(40) || w.has_g(640) || arc || g5 || g52
                        || matches!(motion, Some(MotionMode::Cycle(740 | 820 | 840 | 860 | 880 | 890)))
                        || m_any(&[500, 510, 520, 530, 620, 630, 640, 650, 660, 190]),
                    "P word with no G2, G3, G4, G10, G64, G74, G82, G84, G86, G88, G89 or M19, M50–M53, M62–M66 to use it",
                ),
                b'Q' => (
                    g10 || g5 || w.has_g(640) || m_any(&[660, 670, 680, 610, 190])
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
            // `check_other_codes` tests Q by `q_number != -1.0`, -1 being
            // its own "no Q" value: LinuxCNC lets Q-1 pass anywhere.
            if letter == b'Q' && w.get(b'Q') == Some(-1.0) {
                continue;
            }
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
        [0u16, 10, 20, 30, 50, 51, 52, 53, 330, 331]
            .into_iter()
            .chain(CYCLE_CODES)
            .find_map(|c| w.g_col(c))
    }

    /// The column a block's motion error points at: its motion word, else
    /// its first axis word, else the line's start.
    pub(super) fn motion_col(&self, w: &WordTable) -> usize {
        self.motion_word_col(w)
            .or_else(|| {
                [b'X', b'Y', b'Z', b'@', b'^']
                    .into_iter()
                    .find_map(|l| w.col(l))
            })
            .unwrap_or(0)
    }
}
