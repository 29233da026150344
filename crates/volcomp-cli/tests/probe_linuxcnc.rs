//! A probing program run unmodified on LinuxCNC itself (docs/probing.md,
//! "Checked on LinuxCNC"): a headless simulated machine
//! (`tests/linuxcnc/probe/`) whose probe input is driven, every servo
//! cycle, by realtime HAL components that compare the tool's position —
//! with a machine error applied (a scale of 60 µm/m and an offset) — with
//! a virtual sphere. The reference sphere's program, as `volcomp probe plan`
//! writes it, runs to its end; the log LinuxCNC writes is read back, and the
//! sphere's centre found by the fit must lie within 0.1 µm of where the
//! simulated machine put it: `(c − offset)/gain` in machine coordinates.
//!
//! The probe input is sampled once per servo period (1 ms): a touch is
//! recorded up to `feed × 1 ms` inside the surface. At the slow feed of
//! 6 mm/min that is 0.1 µm, the same for opposite touches on average, so
//! the centre's error stays well below it.
//!
//! LinuxCNC is one per machine: the test holds an exclusive lock on
//! `/tmp/volcomp-linuxcnc.lock` for its whole run. Without LinuxCNC it
//! prints a skip message, except when `CI` is set: there it fails.

use crate::common;

use common::{tempdir, volcomp, write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;
use volcomp_core::identify::probe::artifact::parse_artifact;
use volcomp_core::identify::probe::fit::fit_touches;
use volcomp_core::io::probe_log::read_linuxcnc_log;
use volcomp_gcode::Vec3;

fn config_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/linuxcnc/probe")
}

fn linuxcnc_or_skip() -> bool {
    let found = |tool: &str| {
        std::env::var_os("PATH")
            .map(|p| std::env::split_paths(&p).any(|d| d.join(tool).is_file()))
            .unwrap_or(false)
    };
    let python = Command::new("/usr/bin/python3")
        .args(["-c", "import linuxcnc, hal"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if found("linuxcnc") && found("halcmd") && python {
        return true;
    }
    common::missing(common::LINUXCNC, "probing on LinuxCNC's simulator");
    false
}

/// The sphere the simulated machine has, and its error.
const GAIN: f64 = 1.00006;
const OFFSET_MM: [f64; 3] = [0.012, -0.008, 0.005];
/// Where the sphere really is (the actual tool position at its centre).
const CENTRE_MM: [f64; 3] = [120.1, 80.05, 30.02];
const DIAMETER_MM: f64 = 25.0;
const TIP_DIAMETER_MM: f64 = 2.0;
const G54_MM: [f64; 3] = [50.0, 20.0, -10.0];

/// The last 15 lines of `text`, newest first (for a failure message).
fn last_lines(text: &str) -> String {
    text.lines().rev().take(15).collect::<Vec<_>>().join("\n")
}

/// Runs `program` on a fresh copy of the configuration; returns the
/// display's result line (JSON) or the run's logs.
fn run_linuxcnc(program: &Path, work: &Path) -> Result<String, String> {
    let cfg = work.join("machine");
    std::fs::create_dir_all(&cfg).unwrap();
    for f in ["machine.ini", "probe.hal", "tool.tbl", "probe_display.py"] {
        std::fs::copy(config_dir().join(f), cfg.join(f)).unwrap();
    }
    let rho = DIAMETER_MM / 2.0 + TIP_DIAMETER_MM / 2.0;
    let mut hal = String::from("# written by tests/probe_linuxcnc.rs\n");
    for (a, n) in ["dx", "dy", "dz"].iter().enumerate() {
        hal.push_str(&format!("setp sphere-{n}.gain {GAIN:.12}\n"));
        hal.push_str(&format!(
            "setp sphere-{n}.offset {:.12}\n",
            OFFSET_MM[a] - CENTRE_MM[a]
        ));
    }
    hal.push_str(&format!("setp sphere-inside.in1 {:.12}\n", rho * rho));
    write(&cfg, "sphere.hal", hal);
    let result = work.join("result.jsonl");
    // probe_display.py appends its line: a run starts from no result.
    let _ = std::fs::remove_file(&result);
    let mut cmd = Command::new("linuxcnc");
    cmd.arg(cfg.join("machine.ini"))
        .arg(program)
        .current_dir(work)
        .env("PROBE_RESULT", &result)
        .env(
            "PROBE_G54",
            format!("{},{},{}", G54_MM[0], G54_MM[1], G54_MM[2]),
        )
        .env("HOME", work)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    // As root, LinuxCNC's rtapi_app needs a user to fall back to and a
    // socket folder that user may write (src/rtapi/uspace_rtapi_app.cc).
    let root = Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| o.stdout.starts_with(b"0"));
    let fifo = work.join("rtapi");
    if root {
        std::fs::create_dir_all(&fifo).unwrap();
        let _ = Command::new("chown").arg("65534").arg(&fifo).status();
        let _ = Command::new("chmod").arg("755").arg(work).status();
        cmd.env("RTAPI_UID", "65534")
            .env("RTAPI_FIFO_PATH", fifo.join("rtapi_fifo"));
    }
    let mut child = cmd
        .spawn()
        .map_err(|e| format!("cannot run linuxcnc: {e}"))?;
    let deadline = std::time::Instant::now() + Duration::from_secs(170);
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if std::time::Instant::now() > deadline {
            let _ = child.kill();
            return Err("LinuxCNC did not finish within 170 s".into());
        }
        std::thread::sleep(Duration::from_millis(200));
    };
    let out = child.wait_with_output().unwrap();
    let line = std::fs::read_to_string(&result).unwrap_or_default();
    if !status.success() || line.is_empty() || line.contains("\"error\"") {
        let debug = std::fs::read_to_string(work.join("linuxcnc_debug.txt")).unwrap_or_default();
        return Err(format!(
            "LinuxCNC run failed ({status}): {line}\n{}\n{}\n{}",
            last_lines(&common::stdout(&out)),
            last_lines(&common::stderr(&out)),
            last_lines(&debug)
        ));
    }
    Ok(line)
}

#[test]
fn the_reference_sphere_is_found_within_a_tenth_of_a_micrometre_on_linuxcnc() {
    if !linuxcnc_or_skip() {
        return;
    }
    // One LinuxCNC on the machine at a time, for this whole test.
    let lock = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open("/tmp/volcomp-linuxcnc.lock")
        .expect("open the LinuxCNC lock file");
    lock.lock().expect("lock /tmp/volcomp-linuxcnc.lock");
    let d = tempdir("lcnc");
    // Where the machine puts the sphere in its own (commanded) coordinates.
    let want = Vec3::new(
        (CENTRE_MM[0] - OFFSET_MM[0]) / GAIN,
        (CENTRE_MM[1] - OFFSET_MM[1]) / GAIN,
        (CENTRE_MM[2] - OFFSET_MM[2]) / GAIN,
    );
    // The artifact as described: 0.1 mm off where the sphere is.
    let artifact = format!(
        "artifact = \"reference-sphere\"\nname = \"ref\"\n[certificate]\ndiameter_mm = {DIAMETER_MM}\nu_diameter_um = 0.1\n[[placements]]\nname = \"r\"\norigin_mm = [120, 80, 30]\n"
    );
    write(&d, "ref.toml", &artifact);
    std::fs::write(
        d.join("setup.toml"),
        format!(
            "units = \"mm\"\n[work_offsets]\nG54 = [{}, {}, {}]\n[tools]\n1 = 40\n",
            G54_MM[0], G54_MM[1], G54_MM[2]
        ),
    )
    .unwrap();
    let log = d.join("probe.log");
    let o = volcomp(
        &[
            "probe",
            "plan",
            "ref.toml",
            "--setup",
            "setup.toml",
            "--probe-tool",
            "1",
            "--tip-diameter-mm",
            "2",
            "--slow-feed-mm-min",
            "6",
            "--backoff-mm",
            "0.1",
            "--reference-repeats",
            "1",
            "--rapid-mm-min",
            "3000",
            "--accel-mm-s2",
            "1000",
            "--log-file",
            log.to_str().unwrap(),
            "-o",
            "ref.ngc",
        ],
        &d,
    );
    common::ok(&o);
    let said = String::from_utf8_lossy(&o.stdout).to_string();
    // A simulated machine that fails to come up (machine on, homing or the
    // run timing out while the host is loaded) is started once more, as
    // bench/cycle_time does; its error is kept in the test's output. The
    // checks on what it measured below are not retried.
    let result = run_linuxcnc(&d.join("ref.ngc"), &d)
        .or_else(|e| {
            eprintln!("LinuxCNC run failed, starting it once more: {e}");
            let _ = std::fs::remove_file(&log);
            run_linuxcnc(&d.join("ref.ngc"), &d)
        })
        .unwrap_or_else(|e| panic!("{e}"));
    drop(lock);
    let text = std::fs::read_to_string(&log).expect("LinuxCNC wrote the log");
    let touches = read_linuxcnc_log(&text, "probe.log").unwrap();
    assert_eq!(touches.len(), 17);
    assert!(touches.iter().all(|t| t.tripped));
    let art = parse_artifact(&artifact, "ref.toml").unwrap();
    let fitted = fit_touches(&[art], &touches, None).unwrap();
    let cal = &fitted.calibrations[0];
    let off = (cal.centre_mm - want) * 1e3;
    eprintln!(
        "centre off by ({:.4}, {:.4}, {:.4}) µm; tip radius {:.5} mm; residual noise {:.4} µm; LinuxCNC: {result}; plan: {said}",
        off.x, off.y, off.z, cal.tip_radius_mm.value, cal.sigma_um
    );
    assert!(off.norm() < 0.1, "{off:?}");
    // The probe's effective radius: the sphere is (R + r)/gain in commanded
    // coordinates, with no pre-travel: r_eff = (R + r)/gain − R (µm-level).
    let r_eff = (DIAMETER_MM / 2.0 + TIP_DIAMETER_MM / 2.0) / GAIN - DIAMETER_MM / 2.0;
    for d in volcomp_core::io::probe_log::AxisDir::ALL {
        if cal.pretravel_um[d.index()].is_some() {
            let e = cal.effective_radius_mm(d, 1.0);
            assert!((e - r_eff).abs() < 0.3e-3, "{}: {e} vs {r_eff}", d.label());
        }
    }
    // No reversal in this machine.
    for b in cal.reversal_um.iter().flatten() {
        assert!(b.value.abs() < 0.2, "{b:?}");
    }
    // The plan's time is what LinuxCNC took, within 25 %.
    let moving: f64 = result
        .split("\"moving_s\":")
        .nth(1)
        .and_then(|s| s.split([',', '}']).next())
        .and_then(|s| s.trim().parse().ok())
        .unwrap();
    let planned: f64 = said
        .split("about ")
        .last()
        .and_then(|s| s.split(" s ").next())
        .map(|s| {
            let p: Vec<f64> = s
                .split(|c: char| !c.is_ascii_digit())
                .filter_map(|x| x.parse().ok())
                .collect();
            if p.len() == 2 {
                p[0] * 60.0 + p[1]
            } else {
                p[0]
            }
        })
        .unwrap();
    eprintln!("planned {planned} s, LinuxCNC {moving} s");
    assert!(
        (planned - moving).abs() < 0.25 * moving,
        "planned {planned} s, LinuxCNC {moving} s"
    );
}
