//! The evaluation sets of bench/eval (make_set.py, make_set_b.py and the
//! held-out set c of make_set_c.py) against LinuxCNC's stand-alone
//! interpreter `rs274`: every program is valid LinuxCNC G-code (rs274 runs
//! it without a word of complaint) and `volcomp moves` reads it motion by
//! motion as rs274 does (the method and set-up of `rs274_agreement.rs`:
//! G55 and tool 1's length offset differ from bench/eval/setup_c.toml's, so
//! set c's G55 + G43 H1 program is checked on other offsets too). Set c's
//! programs compensated on the held-out coarse map (bench/coarse_map.py,
//! with setup_c.toml as bench/eval/run.py runs them) must be accepted by
//! rs274 as well.
//!
//! Without rs274 or python3 the tests are skipped loudly (failing under CI,
//! see `common::missing`).

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use crate::common;
use crate::rs274::compare::compare;
use crate::rs274::{find_rs274, run_rs274, run_volcomp};
use crate::rs274_agreement::tools;

/// python3 (bench/eval's generators are Python).
const PYTHON: &str = "python3 (bench/eval's program and map generators)";

fn bench() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../bench")
}

fn python_ok() -> bool {
    Command::new("python3")
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .map(|s| s.success())
        .unwrap_or(false)
}

/// Runs a generator of bench/ with `args`; its standard output.
fn python(script: &Path, args: &[&Path]) -> String {
    let out = Command::new("python3")
        .arg(script)
        .args(args)
        .stdin(Stdio::null())
        .output()
        .unwrap_or_else(|e| panic!("cannot run python3 {}: {e}", script.display()));
    assert!(
        out.status.success(),
        "{} failed: {}",
        script.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("utf-8 output")
}

/// Removes a test's work folder when nothing failed; else fails with every
/// failure, the folder kept for a look.
fn clean_up_or_fail(dir: &Path, failures: &[String]) {
    if failures.is_empty() {
        let _ = std::fs::remove_dir_all(dir);
    } else {
        panic!(
            "(work files in {})\n{}",
            dir.display(),
            failures.join("\n\n")
        );
    }
}

/// The programs of one set at F6000, written into `dir`: their paths.
fn programs(maker: &str, dir: &Path) -> Vec<PathBuf> {
    let listed = python(&bench().join("eval").join(maker), &[dir, Path::new("6000")]);
    listed.split_whitespace().map(PathBuf::from).collect()
}

#[test]
fn eval_set_programs_agree_with_rs274() {
    let Some(rs274) = find_rs274() else {
        common::missing(common::RS274, "bench/eval's sets against rs274");
        return;
    };
    if !python_ok() {
        common::missing(PYTHON, "bench/eval's sets against rs274");
        return;
    }
    let tools = tools(rs274, "evalsets");
    let mut failures = Vec::new();
    let mut motions = 0;
    let mut files = 0;
    for (set, maker, kinds) in [
        ("a", "make_set.py", 14),
        ("b", "make_set_b.py", 14),
        ("c", "make_set_c.py", 18),
    ] {
        let progs = programs(maker, &tools.dir.join(set));
        // Every kind in G61, G64 P0.005 and G64.
        assert_eq!(progs.len(), 3 * kinds, "set {set}: {progs:?}");
        for (i, path) in progs.iter().enumerate() {
            let name = format!("set {set} {}", path.file_name().unwrap().to_string_lossy());
            let work = tools.dir.join(format!("{set}{i}"));
            let rs = match run_rs274(&tools, path, &work) {
                Ok(r) => r,
                Err(e) => {
                    failures.push(format!("{name}: {e}"));
                    continue;
                }
            };
            if let Some(why) = rs.rejected {
                failures.push(format!("{name}: rs274 rejects it: {why}"));
                continue;
            }
            assert!(!rs.motions.is_empty(), "{name}: rs274 printed no motion");
            match run_volcomp(&tools, path, &[]) {
                Ok(v) => {
                    let c = compare(&name, &rs.motions, &v);
                    motions += c.pairs;
                    files += 1;
                    failures.extend(c.failures);
                }
                Err(e) => failures.push(format!("{name}: rs274 accepts it but volcomp {e}")),
            }
        }
    }
    println!("{files} evaluation programs, {motions} motions agree with rs274");
    clean_up_or_fail(&tools.dir, &failures);
}

#[test]
fn compensated_set_c_programs_are_accepted_by_rs274() {
    let Some(rs274) = find_rs274() else {
        common::missing(common::RS274, "set c compensated, on rs274");
        return;
    };
    if !python_ok() {
        common::missing(PYTHON, "set c compensated, on rs274");
        return;
    }
    let tools = tools(rs274, "evalsetc");
    let map = tools.dir.join("coarse.csv");
    std::fs::write(&map, python(&bench().join("coarse_map.py"), &[])).unwrap();
    let setup = bench().join("eval").join("setup_c.toml");
    let progs = programs("make_set_c.py", &tools.dir.join("c"));
    assert!(!progs.is_empty());
    let mut failures = Vec::new();
    for (i, path) in progs.iter().enumerate() {
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        let work = tools.dir.join(format!("k{i}"));
        std::fs::create_dir_all(&work).unwrap();
        let out = work.join("compensated.ngc");
        let o = Command::new(&tools.volcomp)
            .arg("compensate")
            .arg(path)
            .arg("--map")
            .arg(&map)
            .arg("--setup")
            .arg(&setup)
            .arg("--quiet")
            .arg("-o")
            .arg(&out)
            .stdin(Stdio::null())
            .output()
            .expect("run volcomp");
        if !o.status.success() {
            failures.push(format!(
                "{name}: volcomp compensate failed: {}",
                String::from_utf8_lossy(&o.stderr)
            ));
            continue;
        }
        match run_rs274(&tools, &out, &work) {
            Err(e) => failures.push(format!("{name}: {e}")),
            Ok(run) => {
                if let Some(why) = run.rejected {
                    failures.push(format!(
                        "{name}: rs274 rejects the compensated program: {why}"
                    ));
                }
            }
        }
    }
    println!(
        "{} compensated set c programs accepted by rs274",
        progs.len() - failures.len()
    );
    clean_up_or_fail(&tools.dir, &failures);
}

/// The judge of bench/eval (judge.py, `read_program`) reads set c's feed
/// moves in the axis frame as `volcomp moves` does (which the test above
/// holds to rs274): the same lines, ends and arc centres, with G55 and tool
/// 1's length offset from bench/eval/setup_c.toml, in inch and in G91. The
/// judge starts from the program's zero (volcomp from the machine's), so
/// rapids are left out.
#[test]
fn the_judge_reads_set_c_as_volcomp_moves_does() {
    if !python_ok() {
        common::missing(PYTHON, "judge.py against volcomp moves");
        return;
    }
    let dir = common::tempdir("evalsetc-judge");
    let setup = bench().join("eval").join("setup_c.toml");
    let progs = programs("make_set_c.py", &dir);
    let reader = dir.join("read.py");
    std::fs::write(
        &reader,
        "import sys, tomllib\n\
         sys.path.insert(0, sys.argv[1])\n\
         import judge\n\
         s = tomllib.load(open(sys.argv[2], 'rb'))\n\
         wo = {k: [float(x) for x in v] for k, v in s['work_offsets'].items()}\n\
         tl = {int(k): float(v) for k, v in s['tools'].items()}\n\
         for m in judge.read_program(sys.argv[3], wo['G54'], wo, tl):\n\
         \x20   if m['kind'] != 'rapid':\n\
         \x20       print(m['line'], *m['end'], *m.get('centre', []))\n",
    )
    .unwrap();
    let eval_dir = bench().join("eval");
    let mut compared = 0;
    for path in progs
        .iter()
        .filter(|p| p.to_string_lossy().ends_with(".g61.ngc"))
    {
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        let judged: Vec<Vec<f64>> = python(
            &reader,
            &[eval_dir.as_path(), setup.as_path(), path.as_path()],
        )
        .lines()
        .map(|l| l.split_whitespace().map(|x| x.parse().unwrap()).collect())
        .collect();
        let out = Command::new(env!("CARGO_BIN_EXE_volcomp"))
            .arg("moves")
            .arg("--extra-axes")
            .arg("--setup")
            .arg(&setup)
            .arg(path)
            .stdin(Stdio::null())
            .output()
            .expect("run volcomp moves");
        assert!(out.status.success(), "{name}: {}", common::stderr(&out));
        let moves = crate::rs274::parse_volcomp_csv(&String::from_utf8_lossy(&out.stdout)).unwrap();
        let feeds: Vec<_> = moves
            .iter()
            .filter(|m| !matches!(m.kind, crate::rs274::Kind::Rapid))
            .collect();
        assert_eq!(judged.len(), feeds.len(), "{name}: feed moves");
        for (j, v) in judged.iter().zip(&feeds) {
            assert_eq!(j[0] as u64, v.line, "{name}");
            let mut want = v.end.to_vec();
            want.extend(v.center.iter().flatten());
            assert_eq!(
                j.len() - 1,
                want.len(),
                "{name} line {}: arc or line",
                v.line
            );
            for (a, b) in j[1..].iter().zip(&want) {
                // volcomp prints six decimals of a millimetre.
                assert!(
                    (a - b).abs() < 2e-6,
                    "{name} line {}: judge {j:?}, volcomp {want:?}",
                    v.line
                );
            }
            compared += 1;
        }
    }
    assert!(compared > 300, "{compared} feed moves compared");
    println!("{compared} feed moves of set c read alike by judge.py and volcomp moves");
    let _ = std::fs::remove_dir_all(&dir);
}
