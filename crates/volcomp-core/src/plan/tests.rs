//! The planner model against closed forms: a move from rest to rest on a
//! trapezoidal profile takes `L/v + v/a` (a triangle `2√(L/a)` when `v`
//! is not reached); the discrete model must land within two servo
//! periods.

use super::*;
use std::f64::consts::TAU;

const PERIOD_S: f64 = 0.001;

fn trapezoid_s(length: f64, v: f64, a: f64) -> f64 {
    if length >= v * v / a {
        length / v + v / a
    } else {
        2.0 * (length / a).sqrt()
    }
}

fn assert_close(got: f64, want: f64, what: &str) {
    assert!(
        (got - want).abs() <= 2.0 * PERIOD_S,
        "{what}: {got:.4} s, closed form {want:.4} s"
    );
}

fn x(v: f64) -> Vec3 {
    Vec3::new(v, 0.0, 0.0)
}

#[test]
fn a_feed_move_under_g61_is_a_trapezoid() {
    let lim = Limits::default();
    let e = estimate(
        &[Move::feed(Vec3::ZERO, x(100.0), 100.0, PathMode::ExactPath)],
        &lim,
    );
    assert_close(
        e.total_s,
        trapezoid_s(100.0, 100.0, 1000.0),
        "G61 G1 X100 F6000",
    );
    assert_eq!(e.total_s, e.cutting_s);
    let e = estimate(
        &[Move::feed(Vec3::ZERO, x(100.0), 50.0, PathMode::ExactStop)],
        &lim,
    );
    assert_close(
        e.total_s,
        trapezoid_s(100.0, 50.0, 1000.0),
        "G61.1 G1 X100 F3000",
    );
}

#[test]
fn a_short_move_is_a_triangle() {
    let e = estimate(
        &[Move::feed(Vec3::ZERO, x(5.0), 100.0, PathMode::ExactPath)],
        &Limits::default(),
    );
    assert_close(e.total_s, 2.0 * (5.0f64 / 1000.0).sqrt(), "G61 G1 X5 F6000");
}

#[test]
fn g64_halves_the_acceleration_of_a_segment_ending_in_a_blend() {
    // LinuxCNC plans every G64 segment to end in a parabolic blend and
    // halves its acceleration, even the program's last: 1.2 s, not 1.1 s.
    let e = estimate(
        &[Move::feed(Vec3::ZERO, x(100.0), 100.0, PathMode::default())],
        &Limits::default(),
    );
    assert_close(
        e.total_s,
        trapezoid_s(100.0, 100.0, 500.0),
        "G64 G1 X100 F6000",
    );
}

#[test]
fn a_diagonal_and_a_rapid_run_at_the_axes_limits() {
    let lim = Limits::default();
    let d = Vec3::new(100.0, 100.0, 0.0);
    let e = estimate(
        &[Move::feed(Vec3::ZERO, d, 100.0, PathMode::ExactPath)],
        &lim,
    );
    let l = d.norm();
    assert_close(
        e.total_s,
        trapezoid_s(l, 100.0, 1000.0 * 2f64.sqrt()),
        "45° diagonal",
    );
    let e = estimate(
        &[Move::rapid(Vec3::ZERO, x(100.0), PathMode::ExactPath)],
        &lim,
    );
    assert_close(e.total_s, trapezoid_s(100.0, 166.7, 1000.0), "G0 X100");
    assert_eq!(e.cutting_s, 0.0);
    assert_eq!(e.rapid_s, e.total_s);
}

#[test]
fn a_circle_runs_at_its_normal_acceleration_limit() {
    // A full circle of r = 10 mm asked for at 200 mm/s: the normal
    // acceleration caps it at v = √((√3/2)·1000·10) = 93.06 mm/s, and the
    // tangent keeps half of the acceleration, 500 mm/s².
    let s = x(10.0);
    let m = Move {
        kind: MoveKind::Arc {
            center: Vec3::ZERO,
            plane: Plane::Xy,
            sweep_rad: -TAU,
        },
        start: s,
        end: s,
        feed_mm_s: 200.0,
        mode: PathMode::ExactPath,
        line: 1,
    };
    let v = (1000.0 * 3f64.sqrt() / 2.0 * 10.0).sqrt();
    let e = estimate(&[m], &Limits::default());
    assert_close(
        e.total_s,
        trapezoid_s(TAU * 10.0, v, 500.0),
        "circle at the cap",
    );
}

#[test]
fn a_circle_of_two_turns_under_naive_cam_is_still_a_circle() {
    // G64 P0.005 (Q = P): LinuxCNC's `chord_deviation` (emccanon.cc) takes
    // the included angle from the end angles alone, so a whole circle has
    // the sagitta of its diameter (20 mm here), far above Q: it is sent as
    // an arc, two turns of it, not as two lines through its middle. It
    // runs at the normal acceleration cap from rest to rest (the closed
    // form of the test above, over twice the length), with the tangent's
    // 500 mm/s² halved as every G64 segment's is (the test of G64 above).
    let s = x(10.0);
    let arc = |mode| Move {
        kind: MoveKind::Arc {
            center: Vec3::ZERO,
            plane: Plane::Xy,
            sweep_rad: 2.0 * TAU,
        },
        start: s,
        end: s,
        feed_mm_s: 200.0,
        mode,
        line: 1,
    };
    let v = (1000.0 * 3f64.sqrt() / 2.0 * 10.0).sqrt();
    let blend = PathMode::Blend {
        tolerance_mm: 0.005,
        naive_cam_mm: 0.005,
    };
    let e = estimate(&[arc(blend)], &Limits::default());
    assert_close(
        e.total_s,
        trapezoid_s(2.0 * TAU * 10.0, v, 250.0),
        "two turns under G64 P0.005",
    );
}

#[test]
fn chord_deviation_is_linuxcnc_s_within_one_turn() {
    use super::canon::chord_deviation;
    let r = 10.0;
    // A counter-clockwise quarter from (10, 0) to (0, 10): 90° included,
    // sagitta r·(1 − cos 45°), middle at 45°.
    let (dev, (mx, my)) = chord_deviation((r, 0.0), (0.0, r), (0.0, 0.0), false);
    let h = std::f64::consts::FRAC_1_SQRT_2;
    assert!((dev - r * (1.0 - h)).abs() < 1e-12, "{dev}");
    assert!((mx - r * h).abs() < 1e-12 && (my - r * h).abs() < 1e-12);
    // The same ends clockwise: the other 270°, middle at −135°.
    let (dev, (mx, my)) = chord_deviation((r, 0.0), (0.0, r), (0.0, 0.0), true);
    assert!((dev - r * (1.0 + h)).abs() < 1e-12, "{dev}");
    assert!((mx + r * h).abs() < 1e-12 && (my + r * h).abs() < 1e-12);
    // A whole circle (ends equal), either way: 360°, the diameter.
    for cw in [false, true] {
        let (dev, _) = chord_deviation((r, 0.0), (r, 0.0), (0.0, 0.0), cw);
        assert!((dev - 2.0 * r).abs() < 1e-12, "{dev}");
    }
    // Ends at −π and +π (atan2's edge: from (−10, −0) to (−10, 0))
    // clockwise: the first correction makes the included angle zero, the
    // second a whole turn.
    let (dev, _) = chord_deviation((-r, -0.0), (-r, 0.0), (0.0, 0.0), true);
    assert!((dev - 2.0 * r).abs() < 1e-9, "{dev}");
}

#[test]
fn collinear_moves_run_through_at_speed() {
    // Ten 10 mm pieces of one line at 100 mm/s under G64: tangent joints
    // (no kink, so no acceleration given up). The last piece ends the
    // program in a parabolic blend: it accelerates at a/2 = 500 mm/s².
    // The look-ahead lets the ninth end at the speed from which the last,
    // whose length is not final, stops in half of it: √(500·10) = 70.71.
    // By hand: up to 100 in 0.1 s (5 mm); down to 70.71 at 1000 mm/s²
    // in 0.0293 s (2.5 mm); 82.5 mm at 100 in 0.825 s; the last piece a
    // triangle from 70.71 up to √7500 = 86.60 and down to rest at
    // 500 mm/s²: 0.0318 + 0.1732 s. In all 1.1593 s.
    let moves: Vec<Move> = (0..10)
        .map(|i| {
            Move::feed(
                x(10.0 * i as f64),
                x(10.0 * (i + 1) as f64),
                100.0,
                PathMode::default(),
            )
        })
        .collect();
    let e = estimate(&moves, &Limits::default());
    let v9 = (500.0f64 * 10.0).sqrt();
    let peak = 7500f64.sqrt();
    let want = 0.1 + 82.5 / 100.0 + (100.0 - v9) / 1000.0 + (peak - v9) / 500.0 + peak / 500.0;
    assert_close(e.total_s, want, "ten collinear pieces");
    assert_eq!(e.counts.tangent_joints, 9);
}

#[test]
fn exact_stop_stops_at_every_joint() {
    // Two 50 mm moves under G61.1: two trapezoids.
    let moves = [
        Move::feed(Vec3::ZERO, x(50.0), 100.0, PathMode::ExactStop),
        Move::feed(x(50.0), x(100.0), 100.0, PathMode::ExactStop),
    ];
    let e = estimate(&moves, &Limits::default());
    assert_close(
        e.total_s,
        2.0 * trapezoid_s(50.0, 100.0, 1000.0),
        "two stops",
    );
}

/// Feeds `moves` to `p` and steps it with `run` (one period a call, false
/// once the queue is done), `keep` segments queued ahead while reading,
/// then to the end: how LinuxCNC's motion controller drains its queue.
fn drive_period_by_period(
    p: &mut Planner,
    moves: &[Move],
    keep: usize,
    run: impl Fn(&mut Planner) -> bool,
) {
    for m in moves {
        p.canon.push(m, &p.limits, &mut p.fresh);
        p.queue_fresh();
        while p.queue.len() > keep {
            run(p);
        }
    }
    p.canon.finish(&p.limits, &mut p.fresh);
    p.queue_fresh();
    while run(p) {}
}

/// The planner as it was before cruising segments ran in one step and the
/// periods that take no decision in a tight loop: every servo period by
/// [`integrate::run_period`].
fn estimate_period_by_period(moves: &[Move], limits: &Limits) -> Estimate {
    let mut p = Planner::new(*limits);
    let keep = limits.blend.optimization_depth + 6;
    let run = |p: &mut Planner| integrate::run_period(&mut p.queue, &mut p.exec, &p.limits);
    drive_period_by_period(&mut p, moves, keep, run);
    p.finish()
}

/// Uniform draws in [0, 1) from a linear congruential generator (Knuth's
/// MMIX constants, the top 53 bits): the same sequence for a seed.
fn uniform(mut seed: u64) -> impl FnMut() -> f64 {
    move || {
        seed = seed
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (seed >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// A random move from `at`: a rapid to `end` where the first draw is below
/// `shares.0`, an XY arc of radius `r_mm.0 + draw·r_mm.1` (centre on +X,
/// sweep ±4 rad) below `shares.1`, else a feed move to `end`.
fn random_move(
    unit: &mut impl FnMut() -> f64,
    (at, end): (Vec3, Vec3),
    feed_mm_s: f64,
    mode: PathMode,
    shares: (f64, f64),
    r_mm: (f64, f64),
) -> Move {
    let pick = unit();
    if pick < shares.0 {
        Move::rapid(at, end, mode)
    } else if pick < shares.1 {
        let r = r_mm.0 + unit() * r_mm.1;
        let center = at + Vec3::new(r, 0.0, 0.0);
        let sweep_rad = (unit() - 0.5) * 8.0;
        let (s, c) = sweep_rad.sin_cos();
        Move {
            kind: MoveKind::Arc {
                center,
                plane: Plane::Xy,
                sweep_rad,
            },
            start: at,
            end: center + Vec3::new(-r * c, -r * s, 0.0),
            feed_mm_s,
            mode,
            line: 0,
        }
    } else {
        Move::feed(at, end, feed_mm_s, mode)
    }
}

#[test]
fn ramps_at_their_end_speed_count_the_periods_stepping_counts() {
    // A CAM finishing pass as bench/run.sh's cam.nc has it: 0.333 mm moves
    // along X at F300 (5 mm/s), the height following a surface by a few
    // hundredths of a millimetre a move, under G64: a blend arc in every
    // corner, shorter than the ramp's 10 ms at the feed, run through on a
    // ramp already at its end speed (`flat_ramp`). Every period must be the
    // one of the planner that steps each period (`run_period`, LinuxCNC's
    // operations in their order), and most of the arcs' periods must have
    // been run that way.
    let limits = Limits {
        traj_max_velocity_mm_s: 166.7,
        ..Limits::default()
    };
    let mut unit = uniform(0x2545_f491_4f6c_dd1d);
    let mut at = Vec3::new(-1.833, 0.0, -6.0);
    let mut moves = Vec::new();
    // The surface's slope wanders by up to ±0.15 a move (corners of up to
    // about 0.15 rad, the smallest of them tangent joints).
    let mut slope: f64 = 0.0;
    for i in 0..600 {
        slope = (slope + (unit() - 0.5) * 0.3).clamp(-1.0, 1.0);
        let z = at.z + 0.333 * slope;
        let x = if (i / 300) % 2 == 0 {
            at.x + 0.333
        } else {
            at.x - 0.333
        };
        let end = Vec3::new(x, at.y, (z * 1000.0).round() / 1000.0);
        moves.push(Move::feed(at, end, 5.0, PathMode::default()));
        at = end;
    }
    integrate::FLAT_RAMP_PERIODS.with(|n| n.set(0));
    let fast = estimate(&moves, &limits);
    let flat = integrate::FLAT_RAMP_PERIODS.with(|n| n.get());
    let slow = estimate_period_by_period(&moves, &limits);
    assert_eq!(fast, slow);
    assert!(fast.counts.blend_arcs > 300, "{:?}", fast.counts);
    assert!(flat > 1_000, "{flat} periods of ramps at their end speed");
}

#[test]
fn cruising_in_one_step_counts_the_periods_stepping_counts() {
    // Random programs: lines from 1 µm to 100 mm, rapids, arcs in the
    // XY plane, feeds from 3 to 200 mm/s, every path mode; the
    // planner that runs a cruise in one step and the periods that take
    // no decision in a tight loop must give every period of the one that
    // steps through them one by one, and the same joints. A third of the
    // programs are mostly short moves (10 µm to 1 mm: segments run
    // through at speed on a ramp); programs 48 on have no blend arcs
    // (every G64 corner a parabolic blend).
    let mut unit = uniform(0x9e37_79b9_7f4a_7c15);
    let mut cruised = 0;
    for program in 0..64 {
        let limits = Limits {
            blend: BlendSettings {
                enable: program < 48,
                ..BlendSettings::default()
            },
            ..Limits::default()
        };
        let short = program % 3 == 1;
        let mut at = Vec3::ZERO;
        // Half the programs run on in one direction most of the time
        // (a raster's collinear moves: segments that end at speed).
        let straight = program % 8 >= 4;
        let mut dir = Vec3::new(1.0, 0.0, 0.0);
        let mut moves = Vec::new();
        let modes = [
            PathMode::ExactPath,
            PathMode::ExactStop,
            PathMode::default(),
            PathMode::Blend {
                tolerance_mm: 0.01,
                naive_cam_mm: 0.01,
            },
        ];
        let mode = modes[program % 4];
        for _ in 0..100 {
            let len = if short && unit() < 0.9 {
                10f64.powf(unit() * 2.0 - 2.0)
            } else {
                10f64.powf(unit() * 5.0 - 3.0)
            };
            if !straight || unit() < 0.3 {
                dir = Vec3::new(unit() - 0.5, unit() - 0.5, (unit() - 0.5) * 0.2);
            }
            let end = at + dir * (len / dir.norm());
            let feed = 10f64.powf(unit() * 1.8 + 0.5);
            let m = random_move(&mut unit, (at, end), feed, mode, (0.1, 0.3), (0.5, 40.0));
            at = m.end;
            moves.push(m);
        }
        let fast = estimate(&moves, &limits);
        let slow = estimate_period_by_period(&moves, &limits);
        assert_eq!(fast, slow, "program {program}");
        cruised += fast.periods;
    }
    assert!(cruised > 100_000, "{cruised} periods");
}

#[test]
fn the_look_ahead_skipping_settled_pairs_leaves_the_queue_as_the_full_pass() {
    // Random programs: lines from 0.3 µm to 30 mm (many shorter than a
    // servo period's travel, whose speed limit the pass clamps), rapids,
    // arcs, feeds from 3 to 200 mm/s, every path mode, look-ahead depths
    // 50, 8 and 3, blend arcs on and off, now and then a wait that runs
    // the queue empty. Two planners take the same moves, one running the
    // look-ahead's full pass (`tpRunOptimization` as LinuxCNC runs it);
    // after every move both queues must be equal field by field (end
    // speeds, limits, flags, progress, speeds), and so must the estimates.
    let mut unit = uniform(0x2f6b_51a3_97c4_d80e);
    let full = |on: bool| lookahead::FULL_PASS.with(|f| f.set(on));
    let modes = [
        PathMode::default(),
        PathMode::Blend {
            tolerance_mm: 0.01,
            naive_cam_mm: 0.0,
        },
        PathMode::ExactPath,
        PathMode::ExactStop,
    ];
    let mut pushed = 0u64;
    for program in 0..48 {
        let limits = Limits {
            blend: BlendSettings {
                enable: program % 6 != 5,
                optimization_depth: [50, 8, 3][program % 3],
                ..BlendSettings::default()
            },
            ..Limits::default()
        };
        let (mut skipping, mut reference) = (Planner::new(limits), Planner::new(limits));
        let mut at = Vec3::ZERO;
        let mut dir = Vec3::new(1.0, 0.0, 0.0);
        // Half the programs are mostly G64 (every fourth move of another
        // mode), half change mode freely.
        let g64 = program % 2 == 0;
        for _ in 0..400 {
            let len = 10f64.powf(unit() * 5.0 - 3.5);
            if unit() < 0.5 {
                dir = Vec3::new(unit() - 0.5, unit() - 0.5, (unit() - 0.5) * 0.2);
            }
            let end = at + dir * (len / dir.norm());
            let feed = 10f64.powf(unit() * 1.8 + 0.5);
            let mode = if g64 && unit() < 0.75 {
                modes[0]
            } else {
                modes[(unit() * 4.0) as usize]
            };
            let m = random_move(&mut unit, (at, end), feed, mode, (0.05, 0.2), (0.05, 20.0));
            at = m.end;
            full(false);
            skipping.push(&m);
            full(true);
            reference.push(&m);
            if unit() < 0.01 {
                full(false);
                skipping.wait();
                full(true);
                reference.wait();
            }
            assert!(skipping.queue == reference.queue, "program {program}");
            pushed += 1;
        }
        full(false);
        let fast = skipping.finish();
        full(true);
        let slow = reference.finish();
        assert_eq!(fast, slow, "program {program}");
    }
    full(false);
    let skipped = lookahead::SKIPPED.with(|n| n.get());
    assert!(skipped > 1_000, "{skipped} pairs skipped in {pushed} moves");
}

/// The time per line: under G61.1 each line stops, so each is its own
/// trapezoid (100 mm: 1.1 s; 50 mm: 0.6 s); under G64 the corner is
/// blended, and the lines' times still add up to the estimate's, which
/// counting them does not change.
#[test]
fn each_line_s_time_is_its_trapezoid_and_they_add_up() {
    let lim = Limits::default();
    let y = |v: f64| Vec3::new(100.0, v, 0.0);
    for mode in [PathMode::ExactStop, PathMode::default()] {
        let mut a = Move::feed(Vec3::ZERO, x(100.0), 100.0, mode);
        a.line = 7;
        let mut b = Move::feed(x(100.0), y(50.0), 100.0, mode);
        b.line = 8;
        let mut p = Planner::per_line(lim);
        p.push(&a);
        p.push(&b);
        let (e, lines) = p.finish_per_line();
        assert_eq!(e, estimate(&[a, b], &lim), "{mode:?}");
        assert_eq!(lines.iter().map(|l| l.line).collect::<Vec<_>>(), [7, 8]);
        let sum: f64 = lines.iter().map(|l| l.total_s).sum();
        assert!(
            (sum - e.total_s).abs() < 1e-9,
            "{sum} against {}",
            e.total_s
        );
        assert!(lines
            .iter()
            .all(|l| l.cutting_s == l.total_s && l.rapid_s == 0.0));
        if mode == PathMode::ExactStop {
            assert_close(
                lines[0].total_s,
                trapezoid_s(100.0, 100.0, 1000.0),
                "line 7",
            );
            assert_close(lines[1].total_s, trapezoid_s(50.0, 100.0, 1000.0), "line 8");
        }
    }
}

/// The time per line of a planner that steps every period
/// ([`integrate::run_period`], LinuxCNC's order) and counts each period
/// for the segment it shows.
fn per_line_period_by_period(moves: &[Move], limits: &Limits) -> (Estimate, Vec<LineTime>) {
    let mut p = Planner::per_line(*limits);
    let keep = limits.blend.optimization_depth + 6;
    let run = |p: &mut Planner| {
        let before = p.exec.periods;
        let more = integrate::run_period(&mut p.queue, &mut p.exec, &p.limits);
        p.log_since(before);
        more
    };
    drive_period_by_period(&mut p, moves, keep, run);
    p.finish_per_line()
}

#[test]
fn the_time_per_line_counts_each_split_period_for_the_segment_it_shows() {
    // Moves of a few tenths of a millimetre at 5 mm/s, each its own
    // line, under G64 (blend arcs, ends at speed: a split period at
    // every joint, which may show the next segment) and under G61 (tangent
    // joints of collinear moves run through, the rest stop). The rows
    // must be those of the planner that steps each period: the stepping
    // that runs a split period with the period before it counts them
    // apart here.
    let mut unit = uniform(0x51f1_5eed_c0ff_ee00);
    for mode in [PathMode::default(), PathMode::ExactPath] {
        let lim = Limits::default();
        let mut at = Vec3::ZERO;
        let mut moves = Vec::new();
        for i in 0..400u64 {
            let turn = unit() < 0.5;
            let end = at + Vec3::new(0.2 + 0.3 * unit(), 0.0, if turn { 0.02 } else { 0.0 });
            let mut m = Move::feed(at, end, 5.0, mode);
            m.line = i + 1;
            moves.push(m);
            at = end;
        }
        let (e, lines) = {
            let mut p = Planner::per_line(lim);
            for m in &moves {
                p.push(m);
            }
            p.finish_per_line()
        };
        let (e_stepped, lines_stepped) = per_line_period_by_period(&moves, &lim);
        assert_eq!(e, e_stepped, "{mode:?}");
        assert_eq!(e, estimate(&moves, &lim), "{mode:?}");
        assert_eq!(lines, lines_stepped, "{mode:?}");
        assert!(lines.len() > 300, "{} rows", lines.len());
    }
}

/// A line run again (a loop's body) keeps one row holding all its runs:
/// under G61.1 each run is a trapezoid from rest to rest, so line 7 run
/// three times takes three trapezoids.
#[test]
fn a_line_run_again_keeps_one_row_with_all_its_runs() {
    let lim = Limits::default();
    let mode = PathMode::ExactStop;
    let mut p = Planner::per_line(lim);
    let mut moves = Vec::new();
    for _ in 0..3 {
        let mut there = Move::feed(Vec3::ZERO, x(100.0), 100.0, mode);
        there.line = 7;
        let mut back = Move::feed(x(100.0), Vec3::ZERO, 50.0, mode);
        back.line = 8;
        moves.extend([there, back]);
    }
    for m in &moves {
        p.push(m);
    }
    let (e, lines) = p.finish_per_line();
    assert_eq!(e, estimate(&moves, &lim));
    assert_eq!(lines.iter().map(|l| l.line).collect::<Vec<_>>(), [7, 8]);
    // Each run within the two periods `assert_close` allows one.
    for (l, want) in lines.iter().zip([
        3.0 * trapezoid_s(100.0, 100.0, 1000.0),
        3.0 * trapezoid_s(100.0, 50.0, 1000.0),
    ]) {
        assert!(
            (l.total_s - want).abs() <= 6.0 * PERIOD_S,
            "line {}: {:.4} s, closed form {want:.4} s",
            l.line,
            l.total_s
        );
    }
}
