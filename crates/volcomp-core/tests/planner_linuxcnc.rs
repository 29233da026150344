//! The planner model against LinuxCNC 2.9's own trajectory planner: every
//! program of tests/fixtures/planner/ (the cycle-time benchmark's programs
//! at F3000 and F6000, as written, under G61 and G64 P0.005, and
//! compensated; a few programs of corners, arcs, short pieces and inverse
//! time) was run on LinuxCNC's simulated machine of bench/cycle_time and
//! its time read from HAL timers counting servo periods
//! (bench/cycle_time/planner_fixtures.py says how). The estimate must
//! agree within ±3 % in the whole-program time and in the cutting time.

use std::path::Path;
use volcomp_core::compensate::MachineSetup;
use volcomp_core::plan::{estimate_program, Limits};

const TOLERANCE: f64 = 0.03;

struct Row {
    program: String,
    moving_s: f64,
    cutting_s: f64,
}

fn rows(dir: &Path) -> Vec<Row> {
    let text = std::fs::read_to_string(dir.join("times.csv")).expect("times.csv");
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().expect("a header").split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).expect(name);
    let (p, m, c) = (col("program"), col("moving_s"), col("cutting_s"));
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            Row {
                program: f[p].to_string(),
                moving_s: f[m].parse().unwrap(),
                cutting_s: f[c].parse().unwrap(),
            }
        })
        .collect()
}

#[test]
fn the_estimate_agrees_with_linuxcnc_within_three_percent() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/planner");
    let setup = MachineSetup::from_setup_file(&dir.join("setup.toml")).unwrap();
    let limits = Limits::from_setup(setup.setup.limits.as_ref());
    assert_eq!(limits.traj_max_velocity_mm_s, 166.7);
    let mut failures = Vec::new();
    let rows = rows(&dir);
    println!("| program | LinuxCNC s | estimate s | Δ | cutting LinuxCNC s | estimate s | Δ |");
    for r in &rows {
        let path = dir.join("programs").join(format!("{}.ngc", r.program));
        let f = std::fs::File::open(&path).unwrap();
        let e = estimate_program(f, &r.program, &setup, &limits)
            .unwrap_or_else(|e| panic!("{}: {e}", r.program));
        let dm = e.motion.total_s / r.moving_s - 1.0;
        let dc = if r.cutting_s > 0.0 {
            e.motion.cutting_s / r.cutting_s - 1.0
        } else {
            0.0
        };
        println!(
            "| {} | {:.3} | {:.3} | {:+.1} % | {:.3} | {:.3} | {:+.1} % |",
            r.program,
            r.moving_s,
            e.motion.total_s,
            dm * 100.0,
            r.cutting_s,
            e.motion.cutting_s,
            dc * 100.0
        );
        if dm.abs() > TOLERANCE || dc.abs() > TOLERANCE {
            failures.push(format!(
                "{}: whole {:.3} s vs LinuxCNC {:.3} s ({:+.1} %), cutting {:.3} s vs {:.3} s ({:+.1} %)",
                r.program,
                e.motion.total_s,
                r.moving_s,
                dm * 100.0,
                e.motion.cutting_s,
                r.cutting_s,
                dc * 100.0
            ));
        }
    }
    assert!(rows.len() >= 90, "{} programs", rows.len());
    assert!(
        failures.is_empty(),
        "{} of {} programs outside ±3 %:\n{}",
        failures.len(),
        rows.len(),
        failures.join("\n")
    );
}
