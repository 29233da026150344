//! The common block in one step: a straight move (G0 or G1 on the line or
//! in effect) with X, Y, Z, F, N words and comments only, while nothing
//! modal would act on it (no cutter compensation, no rotation, no lathe
//! diameter mode, feed per minute). Most lines of a CAM program are such
//! blocks; the general path decodes every block into a word table and
//! asks it some hundred questions, this one reads the tokens once.
//!
//! It does exactly what the general path does for these blocks, in the
//! same order ([`Interpreter::run_words`] steps 1–3, the motion mode,
//! `end_spline_block_unless`, `extra_target`, and `motion` →
//! `target` → `push`), and declines (returns `false`, having changed
//! nothing) for anything else, including every block the general path
//! would refuse, so that the general path gives the error. A test runs the
//! bundled programs both ways and compares every motion bit for bit: a
//! change to the general path that this mirror does not follow fails it.

use super::options::MotionMode;
use super::{FeedMode, Interpreter, Motion, MotionKind, MotionSource};
use crate::error::GcodeError;
use crate::lexer::{Lexed, Token};

// The fast path takes X, Y, Z as axes 0, 1, 2 of the setup's letters.
const _: () = assert!(
    crate::setup::AxisLetters::ALL[0] == b'X'
        && crate::setup::AxisLetters::ALL[1] == b'Y'
        && crate::setup::AxisLetters::ALL[2] == b'Z'
);

impl Interpreter {
    /// Executes `lexed` if it is a plain straight move (see the module
    /// documentation); `Ok(false)`, with nothing changed, if it is not.
    pub(super) fn fast_block(
        &mut self,
        line: u64,
        lexed: &Lexed,
        out: &mut Vec<Motion>,
    ) -> Result<bool, GcodeError> {
        if !self.fast_blocks
            || self.comp.is_some()
            || self.diameter_mode
            || self.feed_mode != FeedMode::PerMinute
            || self.rotation() != 0.0
        {
            return Ok(false);
        }
        // The target is computed as the words come (each axis once), into
        // locals: nothing is stored that is read back before the move.
        let off = self.frame_offset_mm();
        let mut t = self.words_base();
        let (absolute, mm) = (self.absolute, self.units.mm_per_unit());
        // X, Y, Z are the first three of `AxisLetters::ALL`.
        let axes = self.setup.axes;
        let mut g: Option<(f64, usize)> = None;
        let mut cols: [Option<usize>; 3] = [None; 3];
        let mut f: Option<f64> = None;
        for (k, token) in lexed.tokens.iter().enumerate() {
            let w = match token {
                Token::Word(w) => w,
                Token::Comment(_) | Token::LineComment(_) => continue,
                Token::BlockDelete(_) => return Ok(false),
            };
            let i = match w.letter {
                b'X' => 0,
                b'Y' => 1,
                b'Z' => 2,
                b'G' if g.is_none() => {
                    g = Some((w.value, w.span.start));
                    continue;
                }
                b'F' if f.is_none() => {
                    f = Some(w.value);
                    continue;
                }
                // An unsigned N that starts the line (LinuxCNC reads it
                // nowhere else): the general path refuses the others.
                b'N' if k == 0 && w.value >= 0.0 => continue,
                _ => return Ok(false),
            };
            if cols[i].is_some() || !axes.has_index(i) {
                return Ok(false);
            }
            cols[i] = Some(w.span.start);
            // `to_mm`, with the units looked up once.
            t[i] = if absolute {
                w.value * mm + off[i]
            } else {
                t[i] + w.value * mm
            };
        }
        let axis_col = cols[0].or(cols[1]).or(cols[2]);
        let mode = match g {
            Some((0.0, _)) => MotionMode::Rapid,
            Some((1.0, _)) => MotionMode::Feed,
            Some(_) => return Ok(false),
            None if axis_col.is_some() => match self.motion_mode {
                Some(m @ (MotionMode::Rapid | MotionMode::Feed)) => m,
                _ => return Ok(false),
            },
            None => return Ok(false),
        };
        let feed = f.unwrap_or(self.feed);
        if feed < 0.0 || (mode == MotionMode::Feed && feed == 0.0) {
            return Ok(false);
        }
        // From here on, what the general path does.
        self.plane_before_block = self.plane;
        self.feed = feed;
        self.motion_mode = Some(mode);
        self.end_spline_block_unless(self.motion_mode);
        self.cycle_start_z = None;
        self.extra_target = self.extra;
        let col = g.map(|(_, c)| c).or(axis_col).unwrap_or(0);
        let feed_mm = self.to_mm(self.feed);
        self.arc_not_allowed = false;
        let kind = if mode == MotionMode::Rapid {
            MotionKind::Rapid
        } else {
            MotionKind::Feed
        };
        self.push(out, kind, MotionSource::Program, t, line, col, feed_mm)?;
        Ok(true)
    }
}

#[cfg(test)]
mod tests {
    use crate::{InterpOptions, Motion, Setup, Walker};
    use std::io::Cursor;

    /// Every motion and warning of `program`, with or without the fast
    /// path; the error text if it stops.
    fn run(program: &[u8], setup: &Setup, fast: bool) -> (Vec<Motion>, Vec<String>, String) {
        let mut w = Walker::new(
            Cursor::new(program.to_vec()),
            None,
            setup.clone(),
            InterpOptions::default(),
        );
        w.interp.fast_blocks = fast;
        let mut motions = Vec::new();
        let end = loop {
            match w.next_line() {
                Ok(Some(ev)) => motions.extend_from_slice(ev.motions),
                Ok(None) => break String::new(),
                Err(e) => break e.to_string(),
            }
        };
        let warnings = w.warnings().iter().map(|w| w.to_string()).collect();
        (motions, warnings, end)
    }

    fn setups() -> Vec<Setup> {
        let mut tools =
            String::from("units = \"mm\"\n[work_offsets]\nG54 = [150, 150, 100]\n[tools]\n");
        for i in 1..100 {
            tools.push_str(&format!("{i} = 0\n"));
        }
        vec![Setup::default(), Setup::from_toml(&tools).unwrap()]
    }

    fn same_both_ways(name: &str, program: &[u8]) {
        for setup in setups() {
            let general = run(program, &setup, false);
            let fast = run(program, &setup, true);
            assert_eq!(general.2, fast.2, "{name}: the error differs");
            assert_eq!(general.1, fast.1, "{name}: the warnings differ");
            assert_eq!(general.0.len(), fast.0.len(), "{name}: motion count");
            for (a, b) in general.0.iter().zip(&fast.0) {
                // Bit for bit: `==` on f64 would let -0.0 equal 0.0.
                assert_eq!(format!("{a:?}"), format!("{b:?}"), "{name}");
            }
        }
    }

    #[test]
    fn the_bundled_programs_move_alike_with_and_without_the_fast_path() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/corpus");
        let mut n = 0;
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_some_and(|e| e == "md") {
                continue;
            }
            same_both_ways(&path.display().to_string(), &std::fs::read(&path).unwrap());
            n += 1;
        }
        assert!(n >= 10, "the corpus is in {}", dir.display());
    }

    #[test]
    fn edge_blocks_move_alike_with_and_without_the_fast_path() {
        // Each line is one case: what the fast path takes and the general
        // path's refusals it must leave to it.
        let cases: &[&str] = &[
            "G21 G90\nG0 X1 Y2 Z3\nG1 X4 F100\nY5\nZ-1 F0\nM2\n",
            "G1 X1\nM2\n",
            "G21\nF100\nG1 X1 X2\nM2\n",
            "G21\nG1 F-5 X1\nM2\n",
            "G21\nG0 X1\nG1 Y2 F100 F200\nM2\n",
            "G21\nG0 X1 N1 N2\nM2\n",
            "G20\nG0 X1 (inch)\nG91 G1 X1 F10\nX-2 ; back\nG90 G0 X0\nM2\n",
            "G21\nG00 X1\nG01 Y1 F5\nG0.0 Z1\nG1.0 X2\nG-0 X3\nM2\n",
            "X1\nM2\n",
            "G21\nG1\nG0\nM2\n",
            "G21 G0 X1\nG92 X0\nX1\nG92.1\nG55 X2\nG10 L2 P1 R30\nG54 X1 Y1\nM2\n",
            "G21 G0 X1\nG7\nX4\nG8\nX4\nM2\n",
            "G21 G93 G1 X1 F1\nX2\nG94 X3 F100\nM2\n",
            "G21 G0 X1 A5\nX2\nM2\n",
            "G21 G0 X1\n/ X3\nM2\n",
            "G21 G0 X1\nG43 H1\nX2 Z1\nG49\nX3\nM2\n",
            "G21 G0 X1\nG1 X2 F100\nG41 D1 X5\nX6\nG40 X7\nX8\nM2\n",
            "G21 G0 X200000\nM2\n",
            "G21 G0 X1 E1\nM2\n",
            "G21 G0 X1 Y1\nG5.2 X2 Y2 P1 L3\nX3 Y3\nG5.3\nG0 X4\nM2\n",
            "G21\nN1 G0 X1\nN2 X2\nM2\n",
            "G21\nG0 X2 N2\nM2\n",
            "G21\n(c) N3 G0 X3\nM2\n",
            "G21\nN-1 G0 X1\nM2\n",
            "G21\nG0.0001 X1\nG0.0005 X2\nG0.9995 X3\nM2\n",
            "G21 G0 X1\n%\nG0 X2\nM2\n",
            "G21\nG94 G1 X1\nM2\n",
        ];
        for (i, case) in cases.iter().enumerate() {
            same_both_ways(&format!("case {i}: {case:?}"), case.as_bytes());
        }
    }
}
