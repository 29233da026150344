//! Safe output on every command: no output ever replaces an input or another
//! output, special files are written through (never replaced), nothing is
//! half-written (kills, full disks), and a closed or full standard output
//! is an error. The header and the LinuxCNC filter: `compensated_header.rs`.

use crate::common;

use common::{
    compensate_to, fixture, large_program, read, refused, stderr, tempdir, volcomp, write, PROGRAM,
};
use std::path::Path;
use std::process::{Command, Output, Stdio};

fn snapshot(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap())
        .filter(|e| e.file_type().unwrap().is_file())
        .map(|e| {
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap(),
            )
        })
        .collect();
    v.sort();
    v
}

fn temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(".volcomp-"))
        .collect()
}

/// The arguments `base` followed by `extra`.
fn with<'a>(base: &[&'a str], extra: &[&'a str]) -> Vec<&'a str> {
    [base, extra].concat()
}

/// Runs `args` (with `{OUT}` replaced by each input in turn) and checks that
/// it is refused naming the path, and that no file in `dir` changed.
fn refused_for_every_input(dir: &Path, args: &[&str], inputs: &[&str]) {
    for input in inputs {
        let before = snapshot(dir);
        let argv: Vec<&str> = args
            .iter()
            .map(|a| if *a == "{OUT}" { *input } else { *a })
            .collect();
        let o = volcomp(&argv, dir);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{argv:?} must be refused: {e}");
        assert!(
            e.contains("refusing to write") && e.contains(input),
            "{argv:?}: {e}"
        );
        assert_eq!(snapshot(dir), before, "{argv:?} changed a file");
    }
}

#[test]
fn compensate_outputs_never_replace_inputs() {
    let d = fixture("comp_inputs");
    let base = common::args("compensate part.ngc --map map.csv --setup machine.toml");
    let inputs = ["part.ngc", "map.csv", "machine.toml", "./sub/../map.csv"];
    std::fs::create_dir_all(d.join("sub")).unwrap();
    refused_for_every_input(&d, &with(&base, &["-o", "{OUT}"]), &inputs);
    refused_for_every_input(
        &d,
        &with(&base, &["-o", "out.ngc", "--report", "{OUT}"]),
        &inputs,
    );
    // Through a symbolic link and a hard link to the map.
    std::os::unix::fs::symlink("map.csv", d.join("link.csv")).unwrap();
    std::fs::hard_link(d.join("map.csv"), d.join("hard.csv")).unwrap();
    refused_for_every_input(
        &d,
        &with(&base, &["-o", "{OUT}"]),
        &["link.csv", "hard.csv"],
    );
}

#[test]
fn two_outputs_on_one_path_are_refused() {
    let d = fixture("two_outputs");
    let o = common::run(
        &d,
        "compensate part.ngc --map map.csv --work-offset 200,150,100 -o x.ngc --report x.ngc",
    );
    let e = refused(&o);
    assert!(
        e.contains("--report") && e.contains("-o") && e.contains("same file"),
        "{e}"
    );
    assert!(!d.join("x.ngc").exists());
}

#[test]
fn simulate_outputs_never_replace_inputs() {
    let d = fixture("sim_inputs");
    write(&d, "ref.ngc", PROGRAM);
    let base =
        common::args("simulate part.ngc --map map.csv --setup machine.toml --reference ref.ngc");
    let inputs = ["part.ngc", "map.csv", "machine.toml", "ref.ngc"];
    for flag in ["--errors-csv", "--plot"] {
        refused_for_every_input(&d, &with(&base, &[flag, "{OUT}"]), &inputs);
    }
}

#[test]
fn map_convert_and_plot_never_replace_inputs() {
    let d = tempdir("map_inputs");
    let o = common::run(&d, "map example -o .");
    common::ok(&o);
    // The model and the table it names are both inputs.
    let inputs = ["example21.toml", "example21.csv"];
    for to in ["axis-table", "grid"] {
        refused_for_every_input(
            &d,
            &[
                "map",
                "convert",
                "example21.toml",
                "--to",
                to,
                "--tool-length",
                "100",
                "-o",
                "{OUT}",
            ],
            &inputs,
        );
    }
    // --to model writes OUT and OUT's .csv: `-o example21.toml` would
    // replace both inputs, `-o x.toml` where x.csv is the input's table too.
    std::fs::copy(d.join("example21.csv"), d.join("tables.csv")).unwrap();
    let toml = read(&d, "example21.toml").replace("example21.csv", "tables.csv");
    write(&d, "m.toml", toml);
    let before = snapshot(&d);
    let o = common::run(&d, "map convert m.toml --to model -o tables.toml");
    let e = refused(&o);
    assert!(
        e.contains("refusing to write") && e.contains("tables.csv"),
        "{e}"
    );
    assert_eq!(snapshot(&d), before);
    refused_for_every_input(
        &d,
        &["map", "plot", "m.toml", "-o", "{OUT}"],
        &["tables.csv"],
    );
}

#[test]
fn thermal_outputs_never_replace_inputs() {
    let d = tempdir("thermal_inputs");
    let o = common::run(&d, "thermal example -o .");
    common::ok(&o);
    let inputs = [
        "measurements_train.csv",
        "temperatures_train.csv",
        "artifact.csv",
    ];
    let base = common::args("thermal fit --measurements measurements_train.csv --temperatures temperatures_train.csv --artifact artifact.csv --ranges-mm 0:600,0:400,0:300");
    refused_for_every_input(&d, &with(&base, &["-o", "{OUT}"]), &inputs);
    refused_for_every_input(
        &d,
        &with(&base, &["-o", "t.toml", "--bands", "{OUT}"]),
        &inputs,
    );
}

#[test]
fn straightness_outputs_never_replace_inputs() {
    let d = tempdir("straight_inputs");
    let mut s = String::from("position_mm,deviation_um\n");
    for k in 0..=100 {
        let x = k as f64 * 2.0;
        s.push_str(&format!("{x},{}\n", (x / 40.0).sin()));
    }
    write(&d, "run.csv", &s);
    for args in [
        vec!["straightness", "fit", "run.csv", "-o", "{OUT}"],
        vec!["straightness", "plot", "run.csv", "-o", "{OUT}"],
    ] {
        let before = snapshot(&d);
        let argv: Vec<&str> = args
            .iter()
            .map(|a| if *a == "{OUT}" { "run.csv" } else { *a })
            .collect();
        let o = volcomp(&argv, &d);
        assert_eq!(o.status.code(), Some(2), "{argv:?}: {}", stderr(&o));
        assert_eq!(snapshot(&d), before);
    }
}

#[test]
fn special_files_are_written_through_never_replaced() {
    use std::os::unix::fs::FileTypeExt as _;
    let d = fixture("special");
    let o = compensate_to(&d, "/dev/null");
    common::ok(&o);
    assert!(std::fs::metadata("/dev/null")
        .unwrap()
        .file_type()
        .is_char_device());
    if Path::new("/dev/full").exists() {
        let o = compensate_to(&d, "/dev/full");
        let e = refused(&o);
        assert!(e.contains("/dev/full") && e.contains("No space"), "{e}");
        assert!(std::fs::metadata("/dev/full")
            .unwrap()
            .file_type()
            .is_char_device());
    }
    // /dev/stdout (a symbolic link to the process's descriptor 1, here a
    // pipe): the program arrives on standard output, the link stays.
    let o = compensate_to(&d, "/dev/stdout");
    common::ok(&o);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("(volcomp header end)") && text.contains("M2"),
        "{text}"
    );
    assert!(std::fs::symlink_metadata("/dev/stdout")
        .unwrap()
        .file_type()
        .is_symlink());
    // A FIFO: the program arrives through it, the FIFO stays a FIFO.
    let fifo = d.join("pipe.ngc");
    let made = Command::new("mkfifo").arg(&fifo).status();
    if made.is_ok_and(|s| s.success()) {
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read(fifo).unwrap())
        };
        let o = compensate_to(&d, "pipe.ngc");
        common::ok(&o);
        let got = String::from_utf8(reader.join().unwrap()).unwrap();
        assert!(
            got.contains("(volcomp header end)") && got.contains("M2"),
            "{got}"
        );
        assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());
    }
    // A symbolic link to a regular file: the target gets the program, the
    // link stays a link.
    write(&d, "real.ngc", "old");
    std::os::unix::fs::symlink("real.ngc", d.join("link.ngc")).unwrap();
    let o = compensate_to(&d, "link.ngc");
    common::ok(&o);
    assert!(std::fs::symlink_metadata(d.join("link.ngc"))
        .unwrap()
        .file_type()
        .is_symlink());
    assert!(read(&d, "real.ngc").contains("M2"));
    assert!(temporaries(&d).is_empty());
}

#[test]
fn a_full_disk_leaves_the_old_output_and_no_temporary() {
    let d = fixture("full");
    write(&d, "out.ngc", "old program");
    // The report fails (/dev/full) after the program was staged: neither is
    // put in place, the old program stays.
    let o = common::run(
        &d,
        "compensate part.ngc --map map.csv --setup machine.toml -o out.ngc --report /dev/full",
    );
    refused(&o);
    assert_eq!(read(&d, "out.ngc"), "old program");
    assert!(temporaries(&d).is_empty(), "{:?}", temporaries(&d));
}

#[test]
fn kills_mid_write_leave_no_temporary_and_the_old_output() {
    kills_mid_write("kills", false, &["TERM", "INT", "HUP", "KILL"]);
}

/// The portable path (named `.volcomp-*.tmp` files, removed by the signal
/// handler), forced on Linux; SIGKILL cannot be handled there.
#[test]
fn kills_mid_write_with_named_temporaries() {
    kills_mid_write("kills_named", true, &["TERM", "INT", "HUP"]);
}

fn kills_mid_write(name: &str, named: bool, signals: &[&str]) {
    let d = fixture(name);
    large_program(&d, 400_000);
    for signal in signals {
        write(&d, "out.ngc", "old program");
        let mut child = common::command(
            &d,
            "compensate large.ngc --map map.csv --setup machine.toml --segments 4 -o out.ngc",
        )
        .env_remove("VOLCOMP_NAMED_TEMPORARIES")
        .envs(named.then_some(("VOLCOMP_NAMED_TEMPORARIES", "1")))
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
        // Mid-write: the process has started and is compensating.
        std::thread::sleep(std::time::Duration::from_millis(700));
        if named {
            assert_eq!(
                temporaries(&d).len(),
                1,
                "the named temporary exists mid-write"
            );
        }
        let still_running = child.try_wait().unwrap().is_none();
        Command::new("kill")
            .args([format!("-{signal}"), child.id().to_string()])
            .status()
            .unwrap();
        let status = child.wait().unwrap();
        assert!(
            still_running,
            "the run ended before SIGKILL could interrupt it; make the program larger"
        );
        assert!(!status.success(), "{signal}: {status:?}");
        assert_eq!(read(&d, "out.ngc"), "old program", "{signal}");
        assert!(
            temporaries(&d).is_empty(),
            "{signal}: {:?}",
            temporaries(&d)
        );
    }
}

/// Runs `volcomp LINE` through `sh` in `dir`, so that LINE may redirect
/// volcomp's standard streams.
fn shell(dir: &Path, line: &str) -> Output {
    let volcomp = env!("CARGO_BIN_EXE_volcomp");
    Command::new("sh")
        .arg("-c")
        .arg(format!("'{volcomp}' {line}"))
        .current_dir(dir)
        .output()
        .unwrap()
}

#[test]
fn a_full_disk_on_a_later_output_says_what_was_written() {
    let d = tempdir("later_output");
    common::ok(&common::run(&d, "thermal example -o ."));
    let e = refused(&common::run(&d, "thermal fit --measurements measurements_train.csv --temperatures temperatures_train.csv --artifact artifact.csv --ranges-mm 0:600,0:400,0:300 -o t.toml --bands /dev/full"));
    assert!(e.contains("No space left"), "{e}");
    assert!(
        e.contains("written before the error: t.toml")
            && e.contains("NOT written (left as they were): /dev/full"),
        "{e}"
    );
}

/// A standard output that is full (`> /dev/full`) or closed (`>&-`) is an
/// error that says so.
#[test]
fn a_full_or_closed_standard_output_is_an_error() {
    let d = fixture("bad_stdout");
    for (cmd, said) in [
        (
            "moves part.ngc --setup machine.toml > /dev/full",
            &["standard output", "No space"][..],
        ),
        (
            "compensate part.ngc --map map.csv --setup machine.toml -o - > /dev/full",
            &["standard output", "No space"],
        ),
        (
            "simulate part.ngc --map map.csv --setup machine.toml > /dev/full",
            &["standard output", "No space"],
        ),
        ("moves part.ngc >&-", &["standard output is closed"]),
    ] {
        let o = shell(&d, cmd);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{cmd}: {e}");
        for s in said {
            assert!(e.contains(s), "{cmd}: no `{s}` in: {e}");
        }
    }
}

/// The remaining commands with file outputs: the plan is checked before any
/// input is read, so placeholder inputs are enough to show the refusal.
#[test]
fn every_other_output_flag_against_every_input() {
    let d = tempdir("other_commands");
    for f in [
        "thermal.toml",
        "temps.csv",
        "straight.toml",
        "x.comp",
        "y.comp",
        "z.comp",
        "runs.csv",
        "map.csv",
    ] {
        std::fs::write(d.join(f), format!("placeholder {f}\n")).unwrap();
    }
    let cases: Vec<(Vec<&str>, Vec<&str>)> = vec![
        (
            vec![
                "thermal",
                "predict",
                "--model",
                "thermal.toml",
                "--temperatures",
                "temps.csv",
                "-o",
                "{OUT}",
            ],
            vec!["thermal.toml", "temps.csv"],
        ),
        (
            vec!["thermal", "plot", "--model", "thermal.toml", "-o", "{OUT}"],
            vec!["thermal.toml"],
        ),
        (
            vec!["straightness", "table", "straight.toml", "-o", "{OUT}"],
            vec!["straight.toml"],
        ),
        (
            vec![
                "map",
                "import-linuxcnc",
                "--x",
                "x.comp",
                "--y",
                "y.comp",
                "--z",
                "z.comp",
                "--type",
                "1",
                "--units",
                "mm",
                "-o",
                "{OUT}",
            ],
            vec!["x.comp", "y.comp", "z.comp"],
        ),
        (
            vec!["map", "iso230-2", "runs.csv", "--axis", "x", "-o", "{OUT}"],
            vec!["runs.csv"],
        ),
    ];
    for (args, inputs) in cases {
        refused_for_every_input(&d, &args, &inputs);
    }
    // thermal predict writes OUT.toml and OUT.csv beside it: `-o temps.toml`
    // would replace the temperatures.
    let before = snapshot(&d);
    let e = refused(&common::run(
        &d,
        "thermal predict --model thermal.toml --temperatures temps.csv -o temps.toml",
    ));
    assert!(e.contains("temps.csv"), "{e}");
    assert_eq!(snapshot(&d), before);
    // map convert --to linuxcnc writes x.comp, y.comp, z.comp into a
    // directory: one of them a hard link to the map.
    std::fs::create_dir(d.join("comp")).unwrap();
    std::fs::hard_link(d.join("map.csv"), d.join("comp/y.comp")).unwrap();
    let e = refused(&common::run(
        &d,
        "map convert map.csv --to linuxcnc --type 1 --units mm -o comp",
    ));
    assert!(e.contains("y.comp") && e.contains("MAP"), "{e}");
    assert_eq!(read(&d, "map.csv"), "placeholder map.csv\n");
}

/// Files no option names but an input does — the set-up's `var_file`, a
/// subroutine file found on the subroutine path while the program runs, the
/// tables of a model TOML, the comp files of a LinuxCNC INI, the `.COM`
/// tables of a `.CMA` — are inputs too: no output flag may replace one, and
/// nothing at all is written when one would be.
#[test]
fn files_named_inside_inputs_are_never_replaced() {
    let d = fixture("indirect_inputs");
    // A set-up with a var file (G54 at 200, 150, 100 as #5221…) and a
    // subroutine directory; a program that calls a subroutine file.
    write(
        &d,
        "var.toml",
        "units = \"mm\"\nsubroutine_path = [\"subs\"]\nvar_file = \"sim.var\"\n",
    );
    write(&d, "sim.var", "5220 1\n5221 200\n5222 150\n5223 100\n");
    std::fs::create_dir_all(d.join("subs")).unwrap();
    write(
        &d,
        "subs/pocket.ngc",
        "o<pocket> sub\nG1 X60 Y40\nG1 X10\no<pocket> endsub\n",
    );
    write(
        &d,
        "calls.ngc",
        "G21 G90 G17\nG0 X10 Y10 Z5\nG1 Z-1 F300\no<pocket> call\nG0 Z5\nM2\n",
    );
    let run = |args: &[&str], out: &str| {
        let before = snapshot(&d);
        let sub_before = std::fs::read(d.join("subs/pocket.ngc")).unwrap();
        let o = volcomp(args, &d);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?} must be refused: {e}");
        assert!(
            e.contains("refusing to write") && e.contains(out) && e.contains("nothing was written"),
            "{args:?}: {e}"
        );
        assert_eq!(snapshot(&d), before, "{args:?} changed a file");
        assert_eq!(
            std::fs::read(d.join("subs/pocket.ngc")).unwrap(),
            sub_before,
            "{args:?} changed the subroutine file"
        );
        assert!(temporaries(&d).is_empty(), "{args:?} left a temporary");
        e
    };
    let comp = common::args("compensate calls.ngc --map map.csv --setup var.toml");
    // The run works as it is: the var file gives G54 and the subroutine is found.
    let ok = volcomp(&[&comp[..], &["-o", "ok.ngc"]].concat(), &d);
    common::ok(&ok);
    for (flag, out) in [
        ("-o", "sim.var"),
        ("-o", "subs/pocket.ngc"),
        ("-o", "subs/../subs/pocket.ngc"),
        ("--report", "sim.var"),
        ("--report", "subs/pocket.ngc"),
        ("--report-html", "subs/pocket.ngc"),
    ] {
        let mut args = comp.to_vec();
        if flag != "-o" {
            args.extend(["-o", "out.ngc"]);
        }
        args.extend([flag, out]);
        let e = run(&args, out);
        let role = if out.ends_with("sim.var") {
            "the var file named in var.toml"
        } else {
            "the subroutine file of `o<pocket> call`"
        };
        assert!(e.contains(role), "{args:?}: {e}");
    }
    // simulate --errors-csv over the subroutine file.
    run(
        &[
            "simulate",
            "calls.ngc",
            "--map",
            "map.csv",
            "--setup",
            "var.toml",
            "--errors-csv",
            "subs/pocket.ngc",
        ],
        "subs/pocket.ngc",
    );
    // A 21-component model's table, through `simulate --errors-csv`.
    let o = common::run(&d, "map example -o .");
    common::ok(&o);
    let e = run(
        &[
            "simulate",
            "part.ngc",
            "--map",
            "example21.toml",
            "--setup",
            "machine.toml",
            "--errors-csv",
            "example21.csv",
        ],
        "example21.csv",
    );
    assert!(e.contains("example21.toml"), "{e}");
    // The comp files of a LinuxCNC INI and the .COM tables of a .CMA, named
    // by --controller.
    for (to, dir, controller, named) in [
        ("linuxcnc", "lc", "lc/comp.ini", "lc/y.comp"),
        ("heidenhain", "hh", "hh/VOLCOMP.CMA", "hh/Z.COM"),
    ] {
        let mut args = vec!["map", "export", "map.csv", "--to", to, "-o", dir];
        if to == "linuxcnc" {
            args.extend(["--type", "1", "--units", "mm"]);
        }
        let o = volcomp(&args, &d);
        assert!(o.status.success(), "{to}: {}", stderr(&o));
        for flag in ["-o", "--report"] {
            let mut args = vec![
                "compensate",
                "part.ngc",
                "--map",
                "map.csv",
                "--setup",
                "machine.toml",
                "--controller",
                controller,
            ];
            if flag != "-o" {
                args.extend(["-o", "out.ngc"]);
            }
            args.extend([flag, named]);
            let e = run(&args, named);
            assert!(e.contains("a file named in"), "{args:?}: {e}");
        }
    }
}

/// Standard input and output are the files they are redirected from and
/// to: `- < part.ngc` with `-o part.ngc`, or `-o - >> part.ngc`, would
/// replace (or append to) the program being read.
#[test]
fn redirected_standard_streams_are_compared_as_files() {
    let d = fixture("redirected_streams");
    let program = std::fs::read(d.join("part.ngc")).unwrap();
    let base = ["compensate", "--map", "map.csv", "--setup", "machine.toml"];
    let o = Command::new(env!("CARGO_BIN_EXE_volcomp"))
        .args(base)
        .args(["-", "-o", "part.ngc"])
        .current_dir(&d)
        .stdin(std::fs::File::open(d.join("part.ngc")).unwrap())
        .output()
        .unwrap();
    let e = refused(&o);
    assert!(
        e.contains("refusing to write") && e.contains("part.ngc"),
        "{e}"
    );
    assert_eq!(std::fs::read(d.join("part.ngc")).unwrap(), program);
    let append = std::fs::OpenOptions::new()
        .append(true)
        .open(d.join("part.ngc"))
        .unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_volcomp"))
        .args(base)
        .args(["part.ngc", "-o", "-"])
        .current_dir(&d)
        .stdout(append)
        .output()
        .unwrap();
    let e = refused(&o);
    assert!(
        e.contains("standard output") || e.contains("refusing"),
        "{e}"
    );
    assert_eq!(std::fs::read(d.join("part.ngc")).unwrap(), program);
}
