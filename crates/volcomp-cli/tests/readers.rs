//! Input files read the same way everywhere, and what used to be accepted
//! silently is refused or warned about: located, with what to do.

use std::path::Path;
use std::process::Output;

use crate::common;
use common::{read, refused, stderr, tempdir, volcomp, write};

/// A flat map over `lo…hi` mm on every axis.
fn flat_map(dir: &Path, lo: f64, hi: f64) {
    let mut csv = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
    for a in ["X", "Y", "Z"] {
        csv.push_str(&format!("{a},both,{lo},0,0,0\n{a},both,{hi},1,0,0\n"));
    }
    write(dir, "map.csv", csv);
}

/// A fresh folder `name` with a flat map over 0…500 mm and a program p.ngc
/// that goes to (250, 250, 250).
#[track_caller]
fn flat_dir(name: &str) -> common::TempDir {
    let d = tempdir(name);
    flat_map(&d, 0.0, 500.0);
    write(&d, "p.ngc", "G21 G90\nG0 X250 Y250 Z250\nM2\n");
    d
}

fn compensate(dir: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["compensate", "p.ngc", "--map", "map.csv", "-o", "out.ngc"];
    args.extend_from_slice(extra);
    volcomp(&args, dir)
}

#[test]
fn a_map_in_metres_is_suspected_and_numbers_stay_short() {
    let d = tempdir("unit");
    // Map positions in metres (0 … 0.5), program in mm.
    flat_map(&d, 0.0, 0.5);
    write(
        &d,
        "p.ngc",
        "G21 G90\nG0 X250 Y250 Z250\nG1 X300 F100\nM2\n",
    );
    let o = compensate(&d, &["--work-offset", "0,0,0"]);
    let msg = stderr(&o);
    assert!(!o.status.success());
    assert!(
        msg.contains("axis X = 250 mm is outside the map's range 0 … 0.5 mm"),
        "{msg}"
    );
    assert!(msg.contains("another unit: metres"), "{msg}");
    assert!(!msg.contains("no work offset"), "{msg}");
    // A huge position prints in scientific notation, not 300 digits.
    flat_map(&d, 0.0, 500.0);
    write(
        &d,
        "p.ngc",
        format!("G21 G90\nG0 X{} Y1 Z1\nM2\n", "9".repeat(40)),
    );
    let msg = stderr(&compensate(&d, &["--work-offset", "0,0,0"]));
    assert!(msg.len() < 2000, "{msg}");
    // The message (its first line; the excerpt below shows the source) gives
    // the number in scientific notation.
    let first = msg.lines().next().unwrap_or_default();
    assert!(!first.contains(&"9".repeat(20)), "{msg}");
    assert!(first.contains("1e40"), "{msg}");
}

#[test]
fn bom_quotes_semicolons_and_bad_bytes_in_a_map() {
    let d = tempdir("csv");
    write(&d, "p.ngc", "G21 G90\nG0 X10 Y10 Z10\nG1 X20 F100\nM2\n");
    let good = "axis,direction,position_mm,ex_um,ey_um,ez_um\nX,both,0,0,0,0\nX,both,100,1,0,0\nY,both,0,0,0,0\nY,both,100,0,0,0\nZ,both,0,0,0,0\nZ,both,100,0,0,0\n";
    // A byte-order mark and quoted fields are read.
    let bom = format!(
        "\u{feff}{}",
        good.replace("X,both,100,1", "\"X\",\"both\",\"100\",\"1\"")
    );
    write(&d, "map.csv", bom);
    let o = compensate(&d, &["--work-offset", "0,0,0"]);
    common::ok(&o);
    // Each bad map, with what its message must say: the place, and a hint
    // (what volcomp reads) or the offending byte shown escaped.
    let mut not_utf8 = good.as_bytes().to_vec();
    not_utf8[good.find("X,both,100").unwrap() + 9] = 0xe9;
    for (case, map, said) in [
        (
            "semicolons",
            good.replace(',', ";").into_bytes(),
            ["map.csv:1:1:", "';' as separator"],
        ),
        (
            "a decimal comma: one field too many",
            good.replace("X,both,100,1,0,0", "X,both,100,1,5,0,0")
                .into_bytes(),
            ["map.csv:3:7:", "decimal commas"],
        ),
        (
            "a terminal escape in a field",
            good.replace("X,both,100,1", "X,both,100,\u{1b}[2J")
                .into_bytes(),
            ["map.csv:3:4:", "\\x1b"],
        ),
        (
            "a byte that is not UTF-8",
            not_utf8,
            ["map.csv:3:10:", "UTF-8"],
        ),
    ] {
        write(&d, "map.csv", map);
        let msg = stderr(&compensate(&d, &["--work-offset", "0,0,0"]));
        for s in said {
            assert!(msg.contains(s), "{case}: no `{s}` in: {msg}");
        }
        assert!(!msg.contains('\u{1b}'), "{case}: {msg}");
    }
}

#[test]
fn set_up_errors_are_located() {
    let d = tempdir("setup");
    flat_map(&d, -1000.0, 1000.0);
    write(&d, "p.ngc", "G21 G90\nG0 X10 Y10 Z10\nM2\n");
    write(
        &d,
        "s.toml",
        "units = \"mm\"\n[work_offsets]\nG54 = [250, 200, 150, 1]\n",
    );
    common::said(
        &compensate(&d, &["--setup", "s.toml"]),
        "s.toml:3:7: G54 has 4 value(s)",
    );
    assert!(!d.join("out.ngc").exists());
    write(&d, "s.toml", "units = \"mm\"\n[tools]\n1 = 75\nT1 = 80\n");
    let msg = stderr(&compensate(&d, &["--setup", "s.toml"]));
    assert!(
        msg.contains("s.toml:4:1:") && msg.contains("tool 1"),
        "{msg}"
    );
}

fn thermal_example(d: &Path) {
    let o = common::run(d, "thermal example -o ex");
    common::ok(&o);
}

fn fit(d: &Path, measurements: &str) -> Output {
    volcomp(
        &[
            "thermal",
            "fit",
            "--measurements",
            measurements,
            "--temperatures",
            "ex/temperatures_train.csv",
            "--artifact",
            "ex/artifact.csv",
            "--ranges-mm",
            "0:600,0:400,0:300",
            "-o",
            "thermal.toml",
        ],
        d,
    )
}

#[test]
fn thermal_sensors_need_a_unit_and_predictions_stay_in_range() {
    let d = tempdir("thermal");
    thermal_example(&d);
    let t = read(&d, "ex/temperatures_train.csv");
    write(&d, "bare.csv", t.replacen("bed_C", "bed", 1));
    let o = common::run(&d, "thermal fit --measurements ex/measurements_train.csv --temperatures bare.csv --artifact ex/artifact.csv --ranges-mm 0:600,0:400,0:300 -o thermal.toml");
    let msg = stderr(&o);
    assert!(
        msg.contains("bare.csv:1:3:") && msg.contains("does not say its unit"),
        "{msg}"
    );
    assert!(fit(&d, "ex/measurements_train.csv").status.success());
    // The check run at the example's temperatures predicts; at 60 °C, far
    // outside the fit's range, it is refused unless --extrapolate; 1000 °C
    // is no machine-tool temperature and is refused even then.
    let predict = |temps: &str, extra: &[&str]| {
        let mut args = vec![
            "thermal",
            "predict",
            "--model",
            "thermal.toml",
            "--temperatures",
            temps,
            "-o",
            "pred.toml",
        ];
        args.extend_from_slice(extra);
        volcomp(&args, &d)
    };
    let o = predict("ex/temperatures_check.csv", &[]);
    common::ok(&o);
    let mut lines: Vec<String> = t.lines().map(str::to_string).collect();
    let last = lines.len() - 1;
    let mut f: Vec<String> = lines[last].split(',').map(str::to_string).collect();
    f[2] = "1000".into();
    let mut burnt = lines.clone();
    burnt[last] = f.join(",");
    write(&d, "burnt.csv", burnt.join("\n") + "\n");
    let o = predict("burnt.csv", &["--extrapolate"]);
    let msg = refused(&o);
    assert!(
        msg.contains("burnt.csv:")
            && msg.contains("1000 °C is not a temperature of a machine tool"),
        "{msg}"
    );
    f[2] = "60".into();
    lines[last] = f.join(",");
    write(&d, "hot.csv", lines.join("\n") + "\n");
    let o = predict("hot.csv", &[]);
    let msg = stderr(&o);
    assert!(!o.status.success());
    assert!(
        msg.contains("bed_c") && msg.contains("60 °C") && msg.contains("--extrapolate"),
        "{msg}"
    );
    let o = predict("hot.csv", &["--extrapolate"]);
    common::ok(&o);
    common::said(&o, "warning");
}

#[test]
fn a_sphere_far_off_warns_about_the_noise() {
    let d = tempdir("sigma");
    thermal_example(&d);
    let m = read(&d, "ex/measurements_train.csv");
    // Move one sphere centre 10 mm along x in the first data row.
    let mut out = String::new();
    let mut done = false;
    for l in m.lines() {
        let mut f: Vec<String> = l.split(',').map(str::to_string).collect();
        if !done && !l.starts_with('#') && f.len() == 7 && f[4].parse::<f64>().is_ok() {
            let x: f64 = f[4].parse().unwrap();
            f[4] = format!("{}", x + 10.0);
            done = true;
        }
        out.push_str(&f.join(","));
        out.push('\n');
    }
    write(&d, "off.csv", out);
    let o = fit(&d, "off.csv");
    let msg = stderr(&o);
    assert!(
        msg.contains("warning") && msg.contains("probing noise"),
        "{msg}"
    );
    assert!(msg.contains("largest residuals"), "{msg}");
    // The untouched data warn about nothing.
    let o = fit(&d, "ex/measurements_train.csv");
    assert!(!stderr(&o).contains("probing noise"), "{}", stderr(&o));
}

#[test]
fn a_target_on_the_map_edge_is_reported_with_its_command() {
    let d = tempdir("edge");
    // X error +5 µm everywhere: the command for target X0 is X−0.005, off
    // the map's 0 … 100 mm although the target is on it.
    let csv = "axis,direction,position_mm,ex_um,ey_um,ez_um\nX,both,0,5,0,0\nX,both,100,5,0,0\nY,both,0,0,0,0\nY,both,100,0,0,0\nZ,both,0,0,0,0\nZ,both,100,0,0,0\n";
    write(&d, "map.csv", csv);
    write(&d, "p.ngc", "G21 G90\nG0 X50 Y50 Z50\nG1 X0 F100\nM2\n");
    let o = compensate(&d, &["--work-offset", "0,0,0", "--no-split"]);
    let msg = stderr(&o);
    assert!(!o.status.success(), "{msg}");
    assert!(msg.contains("p.ngc:3:"), "{msg}");
    assert!(msg.contains("the target X 0 Y 50 Z 50 mm"), "{msg}");
    assert!(msg.contains("axis X = -0.005 mm"), "{msg}");
    assert!(!msg.contains("no work offset"), "{msg}");
}

/// The rule that tells millimetres from micrometres: a map position beyond
/// the coordinate limit (±100 000 mm) is refused at its row and column, so a
/// table in µm of an axis longer than 100 mm never reaches a program. Errors
/// beyond 10 mm are refused at their cell too.
#[test]
fn map_values_that_cannot_be_are_refused_where_they_are_written() {
    let d = tempdir("map_values");
    write(
        &d,
        "p.ngc",
        "G21 G90\nG0 X250 Y250 Z250\nG1 X300 F100\nM2\n",
    );
    // The same flat map with X in µm: 0 … 500 000.
    let mut csv = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
    csv.push_str("X,both,0,0,0,0\nX,both,500000,1,0,0\n");
    for a in ["Y", "Z"] {
        csv.push_str(&format!("{a},both,0,0,0,0\n{a},both,500,1,0,0\n"));
    }
    write(&d, "map.csv", &csv);
    let msg = stderr(&compensate(&d, &["--work-offset", "0,0,0"]));
    assert!(
        msg.contains(
            "map.csv:3:3: column 3 `position_mm`: position 500000 mm lies beyond ±100000 mm"
        ),
        "{msg}"
    );
    assert!(msg.contains("divide them by 1000"), "{msg}");
    // An error in nm where µm belong.
    let nm = csv
        .replace("X,both,500000,1,0,0", "X,both,500,0,0,0")
        .replace("Y,both,500,1,0,0", "Y,both,500,0,25000,0");
    write(&d, "map.csv", nm);
    common::said(
        &compensate(&d, &["--work-offset", "0,0,0"]),
        "map.csv:5:5: column 5 `ey_um`: an error of 25000 µm is more than 10000 µm",
    );
}

/// Files named inside a controller file that cannot be read are reported at
/// the line that names them.
#[test]
fn missing_files_named_inside_controller_files_are_located() {
    let d = flat_dir("controller_names");
    for (file, text, said) in [
        (
            "m.ini",
            "[TRAJ]\nLINEAR_UNITS = mm\n\n[JOINT_0]\nCOMP_FILE = none.comp\nCOMP_FILE_TYPE = 1\n[KINS]\nKINEMATICS = trivkins\nJOINTS = 3\n",
            ["m.ini:5:1: cannot read the comp file", "none.comp"],
        ),
        (
            "V.CMA",
            "BEGIN V.CMA\nNR ACTIVE X Y Z\n0 * X.COM Y.COM Z.COM\n[END]\n",
            ["V.CMA:3:1: cannot read the table", "X.COM"],
        ),
    ] {
        write(&d, file, text);
        let msg = stderr(&compensate(
            &d,
            &["--work-offset", "0,0,0", "--controller", file],
        ));
        for s in said {
            assert!(msg.contains(s), "{file}: no `{s}` in: {msg}");
        }
    }
}

/// A temperature no sensor of a machine tool reads, and a thermal model
/// whose intercept is not a number, are refused where they are written.
#[test]
fn thermal_values_that_cannot_be_are_located() {
    let d = tempdir("thermal_values");
    thermal_example(&d);
    let path = d.join("ex/temperatures_train.csv");
    let text = std::fs::read_to_string(&path).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let row = lines
        .iter()
        .position(|l| l.starts_with(|c: char| c.is_ascii_digit()))
        .unwrap()
        + 2;
    let mut fields: Vec<String> = lines[row - 1].split(',').map(str::to_string).collect();
    fields[2] = "2085".into();
    let mut bad = lines.clone();
    let joined = fields.join(",");
    bad[row - 1] = &joined;
    std::fs::write(&path, bad.join("\n") + "\n").unwrap();
    let msg = stderr(&fit(&d, "ex/measurements_train.csv"));
    assert!(
        msg.contains(&format!("temperatures_train.csv:{row}:3:"))
            && msg.contains("2085 °C is not a temperature of a machine tool"),
        "{msg}"
    );
    // A fitted model with `intercept = nan`.
    std::fs::write(&path, text).unwrap();
    let o = fit(&d, "ex/measurements_train.csv");
    common::ok(&o);
    let model = read(&d, "thermal.toml");
    let at = model.find("intercept = ").unwrap();
    let end = at + model[at..].find('\n').unwrap();
    let row = model[..at].matches('\n').count() + 1;
    write(
        &d,
        "thermal.toml",
        format!("{}intercept = nan{}", &model[..at], &model[end..]),
    );
    let msg = refused(&common::run(&d, "thermal predict --model thermal.toml --temperatures ex/temperatures_check.csv -o pred.toml"));
    assert!(
        msg.contains(&format!("thermal.toml:{row}:13:")) && msg.contains("intercept = NaN"),
        "{msg}"
    );
    assert!(!d.join("pred.toml").exists());
}

/// Thermal options are checked before any file is read (these files do not
/// exist), naming the option; none is raised silently; a negative count is
/// a bad value, not an unknown flag.
#[test]
fn thermal_options_are_bounded_before_any_file_is_read() {
    let d = tempdir("thermal_options");
    let base = common::args("thermal fit --measurements none.csv --temperatures none.csv --artifact none.csv --ranges-mm 0:600,0:400,0:300 -o th.toml");
    for (extra, said) in [
        (
            &["--table-samples", "0"][..],
            "--table-samples must be 2 to 10000",
        ),
        (&["--order", "1000"], "--order must be at most 10"),
        (&["--lags", "100000"], "--lags must be at most 100"),
        (
            &["--bands", "b.csv", "--samples", "1000000000"],
            "--samples must be 10 to 10000",
        ),
        (
            &["--bands", "b.csv", "--samples", "5"],
            "--samples must be 10 to 10000",
        ),
        (&["--bands", "b.csv", "--samples", "-1"], "--samples"),
    ] {
        let o = volcomp(&[&base[..], extra].concat(), &d);
        let msg = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {msg}");
        assert!(msg.contains(said), "{extra:?}: {msg}");
        assert!(!msg.contains("unexpected argument"), "{extra:?}: {msg}");
        assert!(
            !msg.contains("none.csv"),
            "{extra:?}: read a file first: {msg}"
        );
    }
    let o = common::run(
        &d,
        "thermal predict --model none.toml --temperatures none.csv --cycle -1 -o p.toml",
    );
    let msg = stderr(&o);
    assert!(
        msg.contains("--cycle") && !msg.contains("unexpected argument"),
        "{msg}"
    );
}

/// File names are printed with their control characters escaped.
#[test]
fn names_with_terminal_escapes_are_printed_escaped() {
    let d = flat_dir("escapes");
    // Both runs write to a name holding a title-setting escape and a bell.
    let run = |map: &str| {
        volcomp(
            &[
                "compensate",
                "p.ngc",
                "--map",
                map,
                "--work-offset",
                "0,0,0",
                "-o",
                "o\x1b]0;t\x07.ngc",
            ],
            &d,
        )
    };
    let o = run("no\x1b[2Jmap.csv");
    let msg = stderr(&o);
    assert!(!msg.contains('\x1b') && !msg.contains('\x07'), "{msg:?}");
    assert!(msg.contains("no\\x1b[2Jmap.csv"), "{msg}");
    std::fs::copy(d.join("map.csv"), d.join("m\x1b[31m.csv")).unwrap();
    let o = run("m\x1b[31m.csv");
    let msg = stderr(&o);
    assert!(o.status.success(), "{msg}");
    assert!(!msg.contains('\x1b') && !msg.contains('\x07'), "{msg:?}");
    assert!(msg.contains("wrote o\\x1b]0;t\\x07.ngc"), "{msg}");
}

/// A program read from a pipe (a FIFO here; `<(…)` in a shell) is
/// compensated as the same program read from a file. The compensation
/// lexes a regular file's lines on a second reader of it; a second reader
/// of a pipe would take bytes from the first (a build that opened one
/// refused the program with a number cut in two), so a pipe gets none.
#[cfg(unix)]
#[test]
fn a_program_read_from_a_pipe_is_compensated_as_from_a_file() {
    let d = tempdir("pipe");
    flat_map(&d, 0.0, 500.0);
    // More lines than a read takes at once (64 KiB), each with decimals.
    let mut p = String::from("G21 G90 G64\nG0 X250 Y250 Z250\n");
    for i in 0..20_000 {
        let x = 250.0 + f64::from(i % 200) * 0.123;
        p += &format!(
            "G1 X{x:.4} Y{:.4} F1000\n",
            250.0 + f64::from(i / 200) * 0.05
        );
    }
    p += "M2\n";
    write(&d, "p.ngc", &p);
    let made = std::process::Command::new("mkfifo")
        .arg(d.join("pipe.ngc"))
        .status();
    if !made.is_ok_and(|s| s.success()) {
        eprintln!("no mkfifo: skipped");
        return;
    }
    let fifo = d.join("pipe.ngc");
    let bytes = p.clone().into_bytes();
    // The writer blocks until the compensation opens the pipe.
    let writer = std::thread::spawn(move || std::fs::write(fifo, bytes));
    let piped = compensate_to(&d, "pipe.ngc", "out_pipe.ngc");
    writer.join().unwrap().unwrap();
    let filed = compensate_to(&d, "p.ngc", "out_file.ngc");
    assert!(piped.status.success(), "{}", stderr(&piped));
    assert!(filed.status.success(), "{}", stderr(&filed));
    let body = |name: &str| -> String {
        read(&d, name)
            .lines()
            .filter(|l| !l.starts_with("(date "))
            .map(|l| format!("{l}\n"))
            .collect()
    };
    let (a, b) = (body("out_pipe.ngc"), body("out_file.ngc"));
    assert!(a.lines().count() > 20_000, "{}", a.lines().count());
    assert!(a == b, "the outputs differ");
}

fn compensate_to(dir: &Path, program: &str, out: &str) -> Output {
    volcomp(
        &[
            "--quiet",
            "compensate",
            program,
            "--map",
            "map.csv",
            "-o",
            out,
            "--work-offset",
            "0,0,0",
        ],
        dir,
    )
}
