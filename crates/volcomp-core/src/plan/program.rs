//! A G-code program's moves, path modes and waits, read with volcomp's
//! interpreter and fed to the [`Planner`].
//!
//! The path mode (G61, G61.1, G64 P Q) comes with every motion from the
//! interpreter. What the program's words say beyond its motions:
//! * **where the machine waits for motion to end**: LinuxCNC's task runs a
//!   spindle command (an S word, M3, M4, M5, M19), coolant (M7, M8, M9), a
//!   tool change (M6), a dwell (G4), an offset change (G10, G43, G49,
//!   G52, G54–G59.3, G92), a stop (M0, M1, M60) or an input wait (M66) only
//!   with the queue empty (src/emc/task/emctaskmain.cc,
//!   `emcTaskCheckPreconditions`: "waiting for motion"), so the moves
//!   before it end at rest;
//! * **dwell time** (G4 P), counted apart from the motion.
//!
//! Feed rates: G94 F (mm/min) as given; G93 (inverse time) the move's
//! length times F per minute; G95 (per revolution) F times the last S.

use super::{Estimate, Limits, LineTime, Move, MoveKind, PathMode, Planner};
use crate::compensate::MachineSetup;
use crate::error::Error;
use std::io::Read;
use volcomp_gcode::interp::{FeedMode, MotionKind};
use volcomp_gcode::lexer::Lexed;
use volcomp_gcode::LineEvent;

/// The estimate of a whole program.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct ProgramEstimate {
    /// The motion (LinuxCNC's planner, period by period).
    pub motion: Estimate,
    /// Dwell time (G4 P), s, not in `motion`.
    pub dwell_s: f64,
    /// Places where the machine waits for the motion to end.
    pub waits: u64,
    /// Moves of the program.
    pub moves: u64,
    /// Moves in G61.1, G61 and G64 (any P) respectively.
    pub moves_by_mode: [u64; 3],
}

/// `code` (×10: G4 = 40, G92.1 = 921) of a G or M word: `(10·value)`
/// rounded half away from zero, as `f64::round(x) as i64` gives it for
/// every `x` (saturating, NaN 0), without the library call `round` is on
/// the baseline x86-64 target: the integer part `t` of `x` (the
/// conversion truncates and saturates) and the fraction `x − t`, exact
/// (`t` is `x` without its fraction, or `x` itself from 2^52 on); one
/// more away from zero when the fraction is at least a half.
fn code10(value: f64) -> i64 {
    let x = value * 10.0;
    let t = x as i64;
    let frac = x - t as f64;
    if frac >= 0.5 {
        t.saturating_add(1)
    } else if frac <= -0.5 {
        t.saturating_sub(1)
    } else {
        t
    }
}

/// What a line says beyond its motions: whether the machine waits for
/// motion to end before its motions and after them, the dwell in
/// seconds, and the spindle speed of its S word.
#[derive(Debug, Clone, Copy, PartialEq)]
struct LineWaits {
    before: bool,
    after: bool,
    dwell_s: f64,
    spindle_rpm: Option<f64>,
}

/// What makes the machine wait for motion to end on a line (see
/// [`LineWaits`]). One pass over the words; only G and M words are
/// decoded (a line of coordinates costs a letter test per word).
fn waits_of_line(lexed: &Lexed) -> LineWaits {
    let (mut before, mut after, mut dwell) = (false, false, false);
    let (mut p_word, mut spindle_rpm) = (None, None);
    for w in lexed.words() {
        match w.letter {
            b'S' => {
                before = true;
                spindle_rpm.get_or_insert(w.value);
            }
            b'P' => {
                p_word.get_or_insert(w.value);
            }
            b'M' => match code10(w.value) {
                30 | 40 | 50 | 60 | 70 | 80 | 90 | 190 | 660 => before = true,
                0 | 10 | 600 => after = true,
                _ => {}
            },
            b'G' => match code10(w.value) {
                40 => dwell = true,
                100 | 430 | 431 | 432 | 490 | 520 | 920 | 921 | 922 | 923 => before = true,
                540 | 550 | 560 | 570 | 580 | 590 | 591 | 592 | 593 => before = true,
                _ => {}
            },
            _ => {}
        }
    }
    let mut dwell_s = 0.0;
    if dwell {
        before = true;
        dwell_s = p_word.map_or(0.0, |p: f64| p.max(0.0));
    }
    LineWaits {
        before,
        after,
        dwell_s,
        spindle_rpm,
    }
}

/// The program's time on LinuxCNC's planner with `limits`, read with the
/// machine's set-up (the moves from its start position); `file` names
/// the program in errors.
pub fn estimate_program(
    program: impl Read,
    file: &str,
    setup: &MachineSetup,
    limits: &Limits,
) -> Result<ProgramEstimate, Error> {
    let (mut out, planner) = run_program(program, file, setup, Planner::new(*limits))?;
    out.motion = planner.finish();
    Ok(out)
}

/// [`estimate_program`], and the time per program line
/// ([`LineTime`], [`Planner::per_line`]): where the time goes.
pub fn estimate_program_per_line(
    program: impl Read,
    file: &str,
    setup: &MachineSetup,
    limits: &Limits,
) -> Result<(ProgramEstimate, Vec<LineTime>), Error> {
    let (mut out, planner) = run_program(program, file, setup, Planner::per_line(*limits))?;
    let (motion, lines) = planner.finish_per_line();
    out.motion = motion;
    Ok((out, lines))
}

/// The planner's limits checked before any move: an error naming the
/// set-up's `[limits]` table.
pub(super) fn check_limits(limits: &Limits) -> Result<(), Error> {
    limits.check().map_err(|m| {
        Error::Setup(volcomp_gcode::GcodeError::new(
            volcomp_gcode::ErrorClass::Invalid,
            0,
            0,
            m,
            "fix the [limits] table of the set-up file",
        ))
    })
}

/// What one program line gives the estimate, in order: the waits for the
/// motion to end, its dwell and its moves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Step {
    /// The machine waits for the motion to end.
    Wait,
    /// A dwell (G4 P), s.
    Dwell(f64),
    /// A move of the program.
    Move(Move),
}

impl Step {
    /// The step fed to `planner`, counted in `out`.
    pub(super) fn apply(self, planner: &mut Planner, out: &mut ProgramEstimate) {
        match self {
            Step::Wait => {
                planner.wait();
                out.waits += 1;
            }
            Step::Dwell(s) => out.dwell_s += s,
            Step::Move(m) => {
                out.moves += 1;
                out.moves_by_mode[match m.mode {
                    PathMode::ExactStop => 0,
                    PathMode::ExactPath => 1,
                    PathMode::Blend { .. } => 2,
                }] += 1;
                planner.push(&m);
            }
        }
    }
}

/// The [`Step`]s of the line `ev` (none after the program end), given to
/// `f` in order; `spindle_rpm` is the last S word's speed, kept from line
/// to line (for feeds per revolution).
pub(super) fn steps_of_line(ev: &LineEvent<'_>, spindle_rpm: &mut f64, mut f: impl FnMut(Step)) {
    if ev.after_end {
        return;
    }
    let units = ev.interp.units().mm_per_unit();
    let LineWaits {
        before,
        after,
        dwell_s,
        spindle_rpm: s_word,
    } = waits_of_line(ev.lexed);
    if let Some(s) = s_word {
        *spindle_rpm = s;
    }
    if before {
        f(Step::Wait);
    }
    // A line without a dwell adds nothing (the sum is never negative:
    // `x + 0.0` is `x`).
    if dwell_s != 0.0 {
        f(Step::Dwell(dwell_s));
    }
    for m in ev.motions {
        let length = match m.kind {
            MotionKind::Arc(a) => a.length(),
            _ => (m.end - m.start).norm(),
        };
        let feed_mm_s = match m.feed_mode {
            FeedMode::PerMinute => m.feed / 60.0,
            // `feed` is the inverse-time value converted as a length.
            FeedMode::InverseTime => length * (m.feed / units) / 60.0,
            FeedMode::PerRevolution => m.feed * *spindle_rpm / 60.0,
        };
        let kind = match m.kind {
            MotionKind::Rapid => MoveKind::Rapid,
            MotionKind::Feed => MoveKind::Feed,
            MotionKind::Arc(a) => MoveKind::Arc {
                center: a.center,
                plane: a.plane,
                sweep_rad: a.sweep_rad,
            },
        };
        f(Step::Move(Move {
            kind,
            start: m.start,
            end: m.end,
            feed_mm_s,
            mode: m.path_mode,
            line: m.line,
        }));
    }
    if after {
        f(Step::Wait);
    }
}

/// The program's moves and waits fed to `planner` (its limits checked
/// first); the estimate without its motion, and the planner to finish.
fn run_program(
    program: impl Read,
    file: &str,
    setup: &MachineSetup,
    mut planner: Planner,
) -> Result<(ProgramEstimate, Planner), Error> {
    check_limits(planner.limits())?;
    let reader = std::io::BufReader::new(program);
    let mut walker = setup.walker(reader, file);
    let mut out = ProgramEstimate::default();
    let mut spindle_rpm = 0.0;
    while let Some(ev) = walker.next_line().map_err(Error::Gcode)? {
        steps_of_line(&ev, &mut spindle_rpm, |step| {
            step.apply(&mut planner, &mut out);
        });
    }
    Ok((out, planner))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lex(s: &str) -> Lexed {
        let mut l = Lexed::default();
        volcomp_gcode::lexer::lex_block(s.as_bytes(), &mut l).unwrap();
        l
    }

    #[test]
    fn codes_are_the_words_times_ten_rounded_as_f64_round_rounds() {
        // Second method: `f64::round` (half away from zero), on the codes
        // of G and M words, their ties and neighbours, huge values,
        // infinities, NaN and random bit patterns.
        let by_round = |v: f64| (v * 10.0).round() as i64;
        let mut values = vec![
            0.0,
            -0.0,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            f64::MAX,
            f64::MIN,
            f64::MIN_POSITIVE,
            9.223_372_036_854_776e17,
            -9.223_372_036_854_776e17,
            4.503_599_627_370_496e14,
            0.049_999_999_999_999_996,
        ];
        for code in -2000..20_000 {
            let v = code as f64 / 100.0;
            for x in [v, v + 0.005, v - 0.005] {
                values.extend([x, x.next_up(), x.next_down(), -x]);
            }
        }
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
        for _ in 0..200_000 {
            seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            values.push(f64::from_bits(seed));
        }
        for v in values {
            assert_eq!(code10(v), by_round(v), "{v:e}");
        }
        // By hand: G92.1 is 921, G4 40, M0 0; 0.45 (4.5 after the
        // product) rounds away from zero to 5, −0.45 to −5.
        assert_eq!((code10(92.1), code10(4.0), code10(0.0)), (921, 40, 0));
        assert_eq!((code10(0.45), code10(-0.45)), (5, -5));
    }

    #[test]
    fn spindle_coolant_tools_dwells_and_offsets_wait_for_motion() {
        let w = |s: &str| {
            let l = waits_of_line(&lex(s));
            (l.before, l.after, l.dwell_s)
        };
        assert_eq!(w("M3 S1000"), (true, false, 0.0));
        assert_eq!(w("G4 P1.5"), (true, false, 1.5));
        assert_eq!(w("P1.5 G4"), (true, false, 1.5));
        assert_eq!(w("G1 X1 M0"), (false, true, 0.0));
        assert_eq!(w("G55"), (true, false, 0.0));
        assert_eq!(w("G1 X1 F100"), (false, false, 0.0));
        assert_eq!(w("M62 P1"), (false, false, 0.0));
        assert_eq!(w("G1 X1 P2"), (false, false, 0.0));
        assert_eq!(waits_of_line(&lex("M3 S1000")).spindle_rpm, Some(1000.0));
        assert_eq!(waits_of_line(&lex("G1 X1")).spindle_rpm, None);
    }
}
