//! volcomp's model of LinuxCNC checked on LinuxCNC 2.9's real motion
//! controller (the headless simulation of `bench/cycle_time/config/`):
//! exported comp files at 21 stops per axis each way, a `BACKLASH`-only
//! joint and a gantry (`coordinates=XYYZ`), a hybrid program beside
//! `BACKLASH`, and, first,
//!
//! `BACKLASH` beside a `COMP_FILE`:
//! `bench/lcnc_backlash.py` runs the headless simulation of
//! `bench/cycle_time/config/` with joint 0 carrying `BACKLASH = 0.004` and a
//! type-1 comp file (trims +0.001 / −0.003 mm) and joint 1 `BACKLASH = 0.004`
//! alone, and reads each joint's `backlash-corr` pin after forward and after
//! reverse travel. The script checks the values against `compute_screw_comp`
//! (`src/emc/motion/control.c`: the comp file's trim where the joint has one,
//! ±BACKLASH/2 where it has none); this test then reads the same INI file
//! with volcomp's reader and checks that the correction it models is what
//! the controller applied (volcomp's sign: the controller commands `q − c`,
//! so `c = −backlash-corr`), within 1 nm.
//!
//! It holds the LinuxCNC lock (`flock /tmp/volcomp-linuxcnc.lock`) for its
//! whole run. Without LinuxCNC the test is skipped loudly, except when `CI`
//! is set: there it fails (CI installs `linuxcnc-uspace`).

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common;
use common::{read, tempdir, write};

/// Whether LinuxCNC's simulator can run here; if not, says (or under CI
/// fails) that `not_checked` was not checked.
fn installed(not_checked: &str) -> bool {
    let found = simulator();
    if !found {
        common::missing(common::LINUXCNC, not_checked);
    }
    found
}

/// A fresh folder `name` holding the comp map, or `None` (saying what was
/// not checked) where LinuxCNC is not installed.
fn work_with_map(name: &str, not_checked: &str) -> Option<common::TempDir> {
    if !installed(not_checked) {
        return None;
    }
    let work = tempdir(name);
    comp_map(&work);
    Some(work)
}

fn simulator() -> bool {
    let on_path = |tool: &str| {
        Command::new("sh")
            .args(["-c", &format!("command -v {tool}")])
            .output()
            .is_ok_and(|o| o.status.success())
    };
    on_path("linuxcnc")
        && on_path("halcmd")
        && on_path("flock")
        && Command::new("/usr/bin/python3")
            .args(["-c", "import linuxcnc, hal"])
            .output()
            .is_ok_and(|o| o.status.success())
}

#[test]
fn backlash_beside_a_comp_file_is_modelled_as_the_motion_controller_applies_it() {
    if !installed("BACKLASH beside COMP_FILE on the motion controller") {
        return;
    }
    let work = tempdir("lcnc-backlash");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../bench/lcnc_backlash.py");
    let o = Command::new("flock")
        .arg("/tmp/volcomp-linuxcnc.lock")
        .arg("/usr/bin/python3")
        .arg(&script)
        .env("VOLCOMP_LCNC_WORK", &work)
        .output()
        .unwrap();
    let out = String::from_utf8_lossy(&o.stdout).to_string();
    assert!(
        o.status.success(),
        "{out}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    // "fwd: joint 0 backlash-corr +0.001000000 mm (expected +0.001)"
    let mut seen = 0;
    let c = volcomp_core::io::controllers::read(&work.join("config/machine.ini")).unwrap();
    for line in out.lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        if f.len() < 5 || f[3] != "backlash-corr" {
            continue;
        }
        let forward = f[0] == "fwd:";
        let joint: usize = f[2].parse().unwrap();
        let applied_mm: f64 = f[4].parse().unwrap();
        // Program positions lie inside the comp file's -2000 … 2000 mm.
        let modelled_um = c.correction_um(joint, 100.0, forward);
        assert!(
            (modelled_um + applied_mm * 1e3).abs() < 1e-3,
            "{line}: volcomp models c = {modelled_um} µm"
        );
        seen += 1;
    }
    assert_eq!(seen, 4, "{out}");
    let _ = std::fs::remove_dir_all(&work);
}

/// The cycle-time machine (`bench/cycle_time/config/`) in `work/config`,
/// with `keys` added to `[JOINT_n]`, the files `files` (from `work`) beside
/// it, and for a gantry (`XYYZ`) four joints, the fourth a copy of the
/// third with its HAL loop. Its axes move at 1000 mm/s and 20 m/s² (the
/// benchmark's are 166.7 mm/s and 1 m/s²): every check is made at rest, once
/// the joint stands at the commanded stop, and the 126 stops of a test take
/// a fraction of the time.
fn machine(work: &Path, keys: &[(usize, String)], files: &[&str], gantry: bool) -> PathBuf {
    let config = work.join("config");
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../bench/cycle_time/config");
    std::fs::create_dir_all(&config).unwrap();
    for e in std::fs::read_dir(&src).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), config.join(e.file_name())).unwrap();
    }
    for f in files {
        std::fs::copy(work.join(f), config.join(Path::new(f).file_name().unwrap())).unwrap();
    }
    let ini = config.join("machine.ini");
    let mut text = std::fs::read_to_string(&ini).unwrap();
    let (vel, acc) = ("VELOCITY = 166.7\n", "ACCELERATION = 1000\n");
    assert_eq!(text.matches(vel).count(), 8, "{text}");
    assert_eq!(text.matches(acc).count(), 8, "{text}");
    text = text
        .replace(vel, "VELOCITY = 1000\n")
        .replace(acc, "ACCELERATION = 20000\n");
    if gantry {
        let kins = "KINEMATICS = trivkins coordinates=XYZ\nJOINTS = 3\n";
        assert_eq!(text.matches(kins).count(), 1);
        text = text.replace(
            kins,
            "KINEMATICS = trivkins coordinates=XYYZ kinstype=BOTH\nJOINTS = 4\n",
        );
        let j2 = text.find("[JOINT_2]").unwrap();
        let end = text[j2 + 1..]
            .find("\n[")
            .map_or(text.len(), |i| j2 + 1 + i + 1);
        let copy = text[j2..end].replace("[JOINT_2]", "[JOINT_3]");
        text.push_str(&format!("\n{copy}"));
        let hal = config.join("machine.hal");
        let mut h = std::fs::read_to_string(&hal).unwrap();
        h.push_str("net Apos joint.3.motor-pos-cmd => joint.3.motor-pos-fb\n");
        std::fs::write(&hal, h).unwrap();
    }
    for (j, k) in keys {
        let head = format!("[JOINT_{j}]\nTYPE = LINEAR\n");
        assert_eq!(text.matches(&head).count(), 1, "{head}");
        text = text.replace(&head, &format!("{head}{k}"));
    }
    std::fs::write(&ini, text).unwrap();
    ini
}

/// A stop: axis, position (mm), moving forward; `None` for a move between.
type Stop = Option<(usize, f64, bool)>;

/// MDI lines for 21 stops per axis (`letters`) going up and 21 going
/// down between the table's points, and what each stop is: `(axis index
/// in `letters`, position, forward)`, `None` for the moves between.
fn stop_lines(letters: &[&str]) -> (Vec<String>, Vec<Stop>) {
    let stops: Vec<f64> = (0..21).map(|k| 7.3 + 13.7 * k as f64).collect();
    let mut lines = Vec::new();
    let mut expect = Vec::new();
    for (a, l) in letters.iter().enumerate() {
        lines.push(format!("G53 G0 {l}0"));
        expect.push(None);
        for &p in &stops {
            lines.push(format!("G53 G0 {l}{p:.4}"));
            expect.push(Some((a, p, true)));
        }
        // Past the last stop first, so the first stop down is reached
        // moving down.
        lines.push(format!("G53 G0 {l}295"));
        expect.push(None);
        for &p in stops.iter().rev() {
            lines.push(format!("G53 G0 {l}{p:.4}"));
            expect.push(Some((a, p, false)));
        }
    }
    (lines, expect)
}

/// A map over 0 … 300 mm every 25 mm: pitch error with a wave, a reversal
/// that grows along the axis, one table per direction; exported as type-1
/// comp files every 5 mm (`work/lc/`).
fn comp_map(work: &Path) {
    let mut s = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
    for (a, axis) in ["X", "Y", "Z"].iter().enumerate() {
        for k in 0..=12 {
            let p = 25.0 * k as f64;
            let f = 0.02 * p + (2.0 + a as f64) * (p / 40.0).sin();
            let r = f + 3.0 + 0.01 * p;
            let put = |v: f64| match a {
                0 => format!("{v:.4},0,0"),
                1 => format!("0,{v:.4},0"),
                _ => format!("0,0,{v:.4}"),
            };
            s.push_str(&format!(
                "{axis},forward,{p},{}\n{axis},reverse,{p},{}\n",
                put(f),
                put(r)
            ));
        }
    }
    write(work, "m.csv", s);
    let o = common::run(
        work,
        "map export m.csv --to linuxcnc --type 1 --units mm --step 5 -o lc",
    );
    common::ok(&o);
}

/// Runs MDI `lines` on the cycle-time machine whose folder is `config`
/// (under the LinuxCNC lock) and returns, per line, the `pins` after it.
fn mdi_stops(
    work: &Path,
    config: &Path,
    lines: &[String],
    pins: &[String],
    gantry: bool,
) -> serde_json::Value {
    let bench = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../bench/cycle_time");
    // Each line with the joints' positions to wait for (machine
    // coordinates: G53, or G54 = 0), joint = axis (trivkins XYZ; a
    // gantry's second Y motor follows the first).
    let with_ends: Vec<String> = lines
        .iter()
        .map(|l| {
            let ends: Vec<String> = if l.starts_with("G53 ") || l.starts_with("G0 ") {
                l.split_whitespace()
                    .filter_map(|w| {
                        let j = "XYZ".find(w.chars().next()?)?;
                        let j = if gantry && j == 2 { 3 } else { j };
                        Some(format!("{j}:{}", &w[1..]))
                    })
                    .collect()
            } else {
                Vec::new()
            };
            format!("{l}\t{}", ends.join(" "))
        })
        .collect();
    write(work, "stops.mdi", with_ends.join("\n") + "\n");
    write(work, "none.ngc", "M2\n");
    let py = format!(
        "import json, sys\nsys.path.insert(0, {bench:?})\nimport lcnc\nlcnc.CONFIG = {config:?}\nr = lcnc.run_program({prog:?}, {runs:?}, 300.0)\nprint(json.dumps(r['stops']))\n",
        bench = bench.display().to_string(),
        config = config.display().to_string(),
        prog = work.join("none.ngc").display().to_string(),
        runs = work.join("runs").display().to_string(),
    );
    let o = Command::new("flock")
        .arg("/tmp/volcomp-linuxcnc.lock")
        .args(["/usr/bin/python3", "-c", &py])
        .env("CT_MDI", work.join("stops.mdi"))
        .env("CT_PINS", pins.join(" "))
        .output()
        .unwrap();
    common::json(&o)
}

#[test]
fn exported_comp_files_are_applied_as_modelled_at_every_stop() {
    let Some(work) = work_with_map("lcnc-comp", "exported comp files on the motion controller")
    else {
        return;
    };
    // The cycle-time machine with the three comp files.
    let keys: Vec<(usize, String)> = ["x.comp", "y.comp", "z.comp"]
        .iter()
        .enumerate()
        .map(|(j, f)| (j, format!("COMP_FILE = {f}\nCOMP_FILE_TYPE = 1\n")))
        .collect();
    let ini = machine(
        &work,
        &keys,
        &["lc/x.comp", "lc/y.comp", "lc/z.comp"],
        false,
    );
    let config = ini.parent().unwrap().to_path_buf();
    let (lines, expect) = stop_lines(&["X", "Y", "Z"]);
    let pins = pins(3);
    let got = mdi_stops(&work, &config, &lines, &pins, false);
    let c = volcomp_core::io::controllers::read(&ini).unwrap();
    let worst = applied_as_modelled(&got, &expect, &c, &[&[0], &[1], &[2]]);
    assert_eq!(got.as_array().unwrap().len(), lines.len());
    eprintln!("largest difference {:.6} nm over 126 stops", worst * 1e3);
    let _ = std::fs::remove_dir_all(&work);
}

#[test]
fn backlash_alone_and_a_gantry_are_applied_as_modelled_at_every_stop() {
    let Some(work) = work_with_map(
        "lcnc-gantry",
        "BACKLASH and a gantry on the motion controller",
    ) else {
        return;
    };
    // X: the BACKLASH map export --backlash-only writes; Y: a gantry, both
    // motors (joints 1 and 2, coordinates=XYYZ) with y.comp; Z: joint 3.
    let comp = |f: &str| format!("COMP_FILE = {f}\nCOMP_FILE_TYPE = 1\n");
    let keys = [
        backlash_keys(&work).swap_remove(0),
        (1, comp("y.comp")),
        (2, comp("y.comp")),
        (3, comp("z.comp")),
    ];
    let ini = machine(&work, &keys, &["lc/y.comp", "lc/z.comp"], true);
    let config = ini.parent().unwrap().to_path_buf();
    let (lines, expect) = stop_lines(&["X", "Y", "Z"]);
    let pins = pins(4);
    let got = mdi_stops(&work, &config, &lines, &pins, true);
    let c = volcomp_core::io::controllers::read(&ini).unwrap();
    assert!(c.backlash[0].is_some() && c.axes[0].is_none(), "{c:?}");
    let worst = applied_as_modelled(&got, &expect, &c, &[&[0], &[1, 2], &[3]]);
    assert_eq!(got.as_array().unwrap().len(), lines.len());
    eprintln!(
        "largest difference {:.6} nm over 126 stops (168 joint readings)",
        worst * 1e3
    );
    let _ = std::fs::remove_dir_all(&work);
}

/// The pins read at every stop: each joint's backlash correction and
/// commanded position.
fn pins(joints: usize) -> Vec<String> {
    (0..joints)
        .flat_map(|j| {
            [
                format!("joint.{j}.backlash-corr"),
                format!("joint.{j}.pos-cmd"),
            ]
        })
        .collect()
}

/// `map export --backlash-only` of `comp_map` (in `work/lb`): the
/// `BACKLASH = …` key of each joint 0…2, as `machine` takes keys.
fn backlash_keys(work: &Path) -> Vec<(usize, String)> {
    let o = common::run(
        work,
        "map export m.csv --to linuxcnc --backlash-only --units mm -o lb",
    );
    common::ok(&o);
    let lb = read(work, "lb/comp.ini");
    (0..3)
        .map(|j| {
            let s = &lb[lb.find(&format!("[JOINT_{j}]")).unwrap()..];
            let b = s[s.find("BACKLASH = ").unwrap()..].lines().next().unwrap();
            (j, format!("{b}\n"))
        })
        .collect()
}

/// Checks that at every stop of `expect` the correction LinuxCNC applied on
/// each joint of the moving axis (`joints[axis]`) is what volcomp models for
/// the machine `c`; returns the largest difference (µm).
fn applied_as_modelled(
    got: &serde_json::Value,
    expect: &[Stop],
    c: &volcomp_core::model::controller::ControllerCorrection,
    joints: &[&[usize]],
) -> f64 {
    let mut worst: f64 = 0.0;
    for (stop, want) in got.as_array().unwrap().iter().zip(expect) {
        let Some((a, p, forward)) = *want else {
            continue;
        };
        for &j in joints[a] {
            let pos = stop["pins"][format!("joint.{j}.pos-cmd")].as_f64().unwrap();
            let corr = stop["pins"][format!("joint.{j}.backlash-corr")]
                .as_f64()
                .unwrap();
            // The planner ends within a fraction of a nm of the target; the
            // correction is taken where the joint stands.
            assert!((pos - p).abs() < 1e-6, "{stop}");
            let modelled_um = c.correction_um(a, pos, forward);
            worst = worst.max((modelled_um + corr * 1e3).abs());
            assert!(
                (modelled_um + corr * 1e3).abs() < 1e-3,
                "joint {j}: {stop}: volcomp models c = {modelled_um} µm, LinuxCNC applied {} µm",
                corr * 1e3
            );
        }
    }
    worst
}

/// The error of `comp_map` along axis `a` at `q` (µm), moving `forward`:
/// its table as written (four decimals), interpolated linearly — computed
/// here, not by volcomp.
fn map_error_um(a: usize, q: f64, forward: bool) -> f64 {
    let v = |p: f64| {
        let f = 0.02 * p + (2.0 + a as f64) * (p / 40.0).sin();
        let e = if forward { f } else { f + 3.0 + 0.01 * p };
        (e * 1e4).round() / 1e4
    };
    let k = ((q / 25.0).floor() as i64).clamp(0, 11) as f64;
    let (p0, p1) = (25.0 * k, 25.0 * (k + 1.0));
    v(p0) + (v(p1) - v(p0)) * (q - p0) / 25.0
}

#[test]
fn a_hybrid_program_leaves_nothing_at_every_stop_beside_backlash() {
    let Some(work) = work_with_map("lcnc-hybrid", "a hybrid program on the motion controller")
    else {
        return;
    };
    // The machine applies the BACKLASH of map export --backlash-only on
    // every joint; volcomp compensates the rest (the pitch error and the
    // reversal's variation along each axis) with --controller.
    let keys = backlash_keys(&work);
    let ini = machine(&work, &keys, &[], false);
    let config = ini.parent().unwrap().to_path_buf();
    // The program: 21 stops per axis up and 21 down, in G54 = 0.
    let (moves, expect) = stop_lines(&["X", "Y", "Z"]);
    let mut program = vec!["G21 G90".to_string(), "G0 X1 Y1 Z1".to_string()];
    program.extend(moves.iter().map(|l| {
        l.replace("G53 G0 ", "G0 ")
            .replace("X0", "X1")
            .replace("Y0", "Y1")
            .replace("Z0", "Z1")
    }));
    program.push("M2".into());
    write(&work, "p.ngc", program.join("\n") + "\n");
    let ini_arg = ini.display().to_string();
    let o = common::volcomp(
        &[
            "compensate",
            "p.ngc",
            "--map",
            "m.csv",
            "--controller",
            &ini_arg,
            "--work-offset",
            "0,0,0",
            "--decimals",
            "6",
            "-o",
            "h.ngc",
        ],
        &work,
    );
    common::ok(&o);
    let hybrid: Vec<String> = read(&work, "h.ngc")
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('(') && *l != "M2")
        .map(str::to_string)
        .collect();
    // Rapids only: each after the first starts where the program put the
    // machine and settles the side of the bands it moves (the map keeps a
    // band the controller does not take up), so no approach is written
    // (docs/compensation.md, "Each axis approaches from one side").
    assert!(!hybrid.iter().any(|l| l.contains("approach")), "{hybrid:?}");
    // One compensated line per line of the program (no take-up moves).
    assert_eq!(hybrid.len(), program.len() - 1, "{hybrid:?}");
    let mut lines = vec!["G10 L2 P1 X0 Y0 Z0".to_string()];
    lines.extend(hybrid);
    let pins = pins(3);
    let got = mdi_stops(&work, &config, &lines, &pins, false);
    let got = got.as_array().unwrap();
    assert_eq!(got.len(), lines.len());
    // The stops of `moves` are lines 3 … of the MDI (after G10, G21 G90,
    // G0 X1 Y1 Z1). The moving axis is checked at each of its stops: the
    // tool lands at motor + e(motor) (the map's error, computed here), the
    // motor at pos-cmd + backlash-corr.
    //
    // A standing axis is not: LinuxCNC's compute_screw_comp takes the
    // direction from the sign of vel_cmd, and the planner's rounding moves
    // a standing joint by 1e-15 mm during another axis' move, which flips
    // its BACKLASH (measured: X at 7.298689 mm after moving down, a Y move
    // leaves it at +B/2). Those flips are counted and printed.
    let mut worst: f64 = 0.0;
    let mut checked = 0;
    let mut flips = 0;
    for (stop, want) in got[3..].iter().zip(&expect) {
        let Some((a, p, forward)) = *want else {
            continue;
        };
        let pin = |name: String| stop["pins"][name].as_f64().unwrap();
        for axis in (0..3).filter(|&x| x != a) {
            let corr = pin(format!("joint.{axis}.backlash-corr"));
            if (corr > 0.0) != (axis > a) {
                flips += 1;
            }
        }
        let pos = pin(format!("joint.{a}.pos-cmd"));
        let corr = pin(format!("joint.{a}.backlash-corr"));
        let motor = pos + corr;
        let actual = motor + map_error_um(a, motor, forward) * 1e-3;
        let left_um = (actual - p) * 1e3;
        worst = worst.max(left_um.abs());
        assert!(
            left_um.abs() <= 0.01,
            "{}: axis {a} lands {left_um} µm from {p} mm\n{stop}",
            stop["mdi"]
        );
        checked += 1;
    }
    eprintln!(
        "readings of a standing joint at the other direction's BACKLASH (flipped by the planner's rounding): {flips} of {}",
        2 * checked
    );
    assert_eq!(checked, 126);
    eprintln!("a hybrid program leaves at most {worst:.4} µm at 126 stops (the moving axis)");
    let _ = std::fs::remove_dir_all(&work);
}
