//! `volcomp probe`: every generated program is accepted by LinuxCNC's
//! stand-alone interpreter `rs274` (its canonical calls counted: two
//! STRAIGHT_PROBE per touch, each ending at the planned target), and the
//! fit writes a model that `compensate` and `map eval` take.
//!
//! Without `rs274` the rs274 checks print a skip message, except when `CI`
//! is set: there they fail (as the rs274 agreement tests decide).

use crate::common;
use crate::rs274;

use common::{read, stderr, tempdir, volcomp, write};
use std::path::{Path, PathBuf};

fn rs274_or_skip() -> Option<PathBuf> {
    match rs274::find_rs274() {
        Some(p) => Some(p),
        None => {
            common::missing(common::RS274, "the probing program on rs274");
            None
        }
    }
}

/// An inch set-up (rs274 alone is an inch machine: its offsets and tool
/// table are in inches): G54 = (1, 2, −3) in, probe tool 9 of 3.5 in.
const SETUP: &str = "units = \"inch\"\n[work_offsets]\nG54 = [1, 2, -3]\n[tools]\n9 = 3.5\n";

/// Runs rs274 on `program`: `(STRAIGHT_PROBE ends (program units), other
/// output lines)`, or the complaint if it refused the program.
fn run_plan(exe: &Path, program: &Path, dir: &Path) -> Result<Vec<[f64; 3]>, String> {
    let tbl = dir.join("tool.tbl");
    std::fs::write(&tbl, "T9 P9 Z3.5\n").unwrap();
    let var = dir.join("p.var");
    std::fs::write(&var, "5220 1\n5221 1\n5222 2\n5223 -3\n").unwrap();
    let out_path = dir.join("canon.txt");
    let out = rs274::command(exe, dir, &tbl, &var, program, &out_path)
        .output()
        .expect("run rs274");
    let chatter = rs274::chatter(&out);
    let text = std::fs::read_to_string(&out_path).unwrap_or_default();
    if !out.status.success() || !chatter.is_empty() || text.contains("ABORT") {
        return Err(format!(
            "{}: {}\n{}",
            out.status,
            chatter.join(" | "),
            text.lines().rev().take(5).collect::<Vec<_>>().join("\n")
        ));
    }
    let mut probes = Vec::new();
    for l in text.lines() {
        if let Some(i) = l.find("STRAIGHT_PROBE(") {
            let args: Vec<f64> = l[i + 15..]
                .trim_end_matches(')')
                .split(',')
                .filter_map(|v| v.trim().parse().ok())
                .collect();
            probes.push([args[0], args[1], args[2]]);
        }
    }
    Ok(probes)
}

const SQUARE: &str = "artifact = \"square\"\nname = \"sq\"\nlegs_mm = [300, 250]\nheight_above_mm = 10\n[[placements]]\nname = \"a\"\norigin_mm = [100, 60, 30]\n[[placements]]\nname = \"over\"\norigin_mm = [100, 340, 30]\ny_axis = [0, -1, 0]\n";

const ZGAUGE: &str = "artifact = \"gauge\"\nname = \"zstep\"\nfaces_mm = [0, 50, 100]\nfacing = [\"+\", \"+\", \"+\"]\noffsets_mm = [[30, 0], [0, 0], [-30, 0]]\nheight_above_mm = 0\n[[placements]]\nname = \"z\"\norigin_mm = [300, 200, 20]\nx_axis = [0, 0, 1]\ny_axis = [1, 0, 0]\n";

#[test]
fn every_generated_program_is_accepted_by_rs274() {
    let d = tempdir("plans");
    let o = common::run(&d, "probe example -o ex");
    common::ok(&o);
    write(&d, "inch.toml", SETUP);
    write(&d, "square.toml", SQUARE);
    write(&d, "zstep.toml", ZGAUGE);
    let cases = [
        ("ex/reference.toml", vec![]),
        ("ex/plate.toml", vec!["--sphere-touches", "9"]),
        ("ex/gauge.toml", vec![]),
        ("square.toml", vec![]),
        ("zstep.toml", vec!["--no-contact", "skip"]),
    ];
    let exe = rs274_or_skip();
    for (k, (artifact, extra)) in cases.iter().enumerate() {
        let out = format!("p{k}.ngc");
        let mut args = vec![
            "probe",
            "plan",
            artifact,
            "--setup",
            "inch.toml",
            "--probe-tool",
            "9",
            "--tip-diameter-mm",
            "3",
            "-o",
            &out,
        ];
        args.extend(extra.iter());
        let o = volcomp(&args, &d);
        assert!(o.status.success(), "{artifact}: {}", stderr(&o));
        let said = String::from_utf8_lossy(&o.stdout).to_string();
        // "wrote p1.ngc: 324 touches, …" after one line per placement.
        let touches: usize = said
            .lines()
            .find(|l| l.starts_with("wrote "))
            .and_then(|l| l.split(": ").nth(1))
            .and_then(|s| s.split(' ').next())
            .and_then(|s| s.parse().ok())
            .unwrap_or_else(|| panic!("{said}"));
        assert!(said.contains("on the machine"), "{said}");
        let program = std::fs::read_to_string(d.join(&out)).unwrap();
        // Every touch: two probe moves and a log line.
        assert_eq!(program.matches("(LOG,touch").count(), touches, "{artifact}");
        if let Some(exe) = &exe {
            let work = d.join(format!("rs{k}"));
            std::fs::create_dir_all(&work).unwrap();
            // The operator loads the probe first (the program refuses to
            // run otherwise): T9 M6 on the first line keeps line numbers.
            let loaded = work.join("loaded.ngc");
            std::fs::write(&loaded, format!("T9 M6 {program}")).unwrap();
            let probes = run_plan(exe, &loaded, &work)
                .unwrap_or_else(|e| panic!("{artifact}: rs274 refused: {e}"));
            assert_eq!(probes.len(), 2 * touches, "{artifact}");
            if k == 0 {
                // Without the probe in the spindle LinuxCNC stops at once.
                let e = run_plan(exe, &d.join(&out), &work).unwrap_err();
                assert!(e.contains("not in the spindle"), "{e}");
            }
            // The fast and the slow move of a touch end at the same target.
            for pair in probes.chunks(2) {
                for a in 0..3 {
                    assert!(
                        (pair[0][a] - pair[1][a]).abs() < 1e-4,
                        "{artifact}: {pair:?}"
                    );
                }
            }
        }
    }
}

#[test]
fn the_example_campaign_fits_into_a_model_compensate_takes() {
    let d = tempdir("fit");
    assert!(common::run(&d, "probe example -o ex").status.success());
    let said = common::ok(&common::run(&d, "probe fit --artifact ex/reference.toml --artifact ex/plate.toml --artifact ex/gauge.toml --log ex/reference.log --log ex/plate.log --log ex/gauge.log --ranges-mm 0:600,0:400,0:300 --report probe.html -o model.toml"));
    assert!(said.contains("ECY.P1   not seen"), "{said}");
    assert!(said.contains("reversal (backlash, µm): X"), "{said}");
    assert!(d.join("model.csv").is_file());
    let html = read(&d, "probe.html");
    assert!(html.contains("Placements and residuals") && html.contains("<svg"));
    // The model is an ordinary 21-component model.
    common::ok(&common::run(
        &d,
        "map eval model.toml --at 300,200,100 --tool-length 100",
    ));
    write(
        &d,
        "part.ngc",
        "G21 G90\nG0 X100 Y100 Z150\nG1 X400 Y300 Z100 F500\nM2\n",
    );
    common::ok(&common::run(
        &d,
        "compensate part.ngc --map model.toml --work-offset 0,0,0 -o part.comp.ngc",
    ));
    // Verify, applying the model in software to the same run: what is left
    // is the noise.
    let said = common::ok(&common::run(&d, "probe verify --artifact ex/reference.toml --artifact ex/plate.toml --artifact ex/gauge.toml --log ex/reference.log --log ex/plate.log --log ex/gauge.log --ranges-mm 0:600,0:400,0:300 --map model.toml --applied software"));
    assert!(said.contains("what is left: RMS"), "{said}");
}

#[test]
fn a_bad_log_is_located_and_nothing_is_written() {
    let d = tempdir("bad");
    assert!(common::run(&d, "probe example -o ex").status.success());
    let log = read(&d, "ex/plate.log");
    let bad = log.replacen("d=-Z", "d=down", 1);
    write(&d, "bad.log", &bad);
    let o = common::run(
        &d,
        "probe fit --artifact ex/plate.toml --log bad.log --ranges-mm 0:600,0:400,0:300 -o m.toml",
    );
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.contains("bad.log:3:") && e.contains("not a direction"),
        "{e}"
    );
    assert!(!d.join("m.toml").exists() && !d.join("m.csv").exists());
    // A touch of a placement the artifact does not have.
    let bad = log.replacen("p=low ", "p=nowhere ", 1);
    write(&d, "bad.log", &bad);
    let o = common::run(
        &d,
        "probe fit --artifact ex/plate.toml --log bad.log --ranges-mm 0:600,0:400,0:300 -o m.toml",
    );
    common::said(&o, "bad.log:3:");
    common::said(&o, "no placement `nowhere`");
}
