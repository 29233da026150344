//! `volcomp map …` and the 21-component model in `compensate`/`simulate`,
//! as a user meets them.

use std::path::Path;

use crate::common;
use common::{json, ok, read, refused, stderr, stdout, tempdir, volcomp, write};

/// A model whose only error is EAZ = 20 µrad (the spindle tilts about X).
fn write_eaz_model(dir: &Path) {
    write(dir, "m.toml", "model = \"kinematic-21\"\nchain = \"w X' Y' b Z t\"\ntables = \"m.csv\"\n[squareness_urad]\nxy = 0\nyz = 0\nzx = 0\n");
    let mut csv =
        String::from("axis,direction,position_mm,ex_um,ey_um,ez_um,ea_urad,eb_urad,ec_urad\n");
    for a in ["X", "Y", "Z"] {
        let ea = if a == "Z" { 20 } else { 0 };
        csv.push_str(&format!(
            "{a},both,-500,0,0,0,{ea},0,0\n{a},both,500,0,0,0,{ea},0,0\n"
        ));
    }
    write(dir, "m.csv", csv);
}

#[test]
fn eval_sees_the_tool_length() {
    let dir = tempdir("eval");
    write_eaz_model(&dir);
    // e_y = EAZ · L: 20e-6 · 150 mm = 3.0 µm; 20e-6 · 50 mm = 1.0 µm; 0 at L = 0.
    for (l, ey) in [("150", 3.0), ("50", 1.0), ("0", 0.0)] {
        let v = json(&volcomp(
            &[
                "map",
                "eval",
                "m.toml",
                "--at",
                "10,20,30",
                "--tool-length",
                l,
                "--json",
            ],
            &dir,
        ));
        let e = v["deviation_um"][1].as_f64().unwrap();
        assert!((e - ey).abs() < 1e-6, "L = {l}: {v}");
        assert_eq!(
            v["abbe_arms_mm"]["Z"][2].as_f64().unwrap(),
            -l.parse::<f64>().unwrap()
        );
        assert_eq!(v["components"]["EAZ"].as_f64().unwrap(), 20.0);
    }
    let o = common::run(&dir, "map eval m.toml --at 10,20,30 --tool-length 150");
    ok(&o);
    assert!(stdout(&o).contains("EAZ +20.00"), "{}", stdout(&o));
}

#[test]
fn compensate_and_simulate_take_the_model_and_the_active_tool() {
    let dir = tempdir("comp");
    write_eaz_model(&dir);
    write(&dir, "setup.toml", "units = \"mm\"\n[tools]\n1 = 150\n");
    let program = "G21 G90 G17\nG0 X0 Y0 Z50\nG43 H1 G0 Z20\nG1 X10 F500\nM2\n";
    write(&dir, "p.ngc", program);
    let o = common::run(
        &dir,
        "compensate p.ngc --map m.toml --setup setup.toml -o out.ngc",
    );
    ok(&o);
    let out = read(&dir, "out.ngc");
    // Tool 1 is 150 mm long: e_y = 3.0 µm, so Y is commanded 3 µm short.
    assert!(out.contains("G43 H1 G0 Z20 Y-0.0030"), "{out}");
    let v = json(&common::run(
        &dir,
        "simulate out.ngc --map m.toml --setup setup.toml --reference p.ngc --json",
    ));
    assert!(v["contour_max_um"].as_f64().unwrap() < 1e-3, "{v}");
    let v = json(&common::run(
        &dir,
        "simulate p.ngc --map m.toml --setup setup.toml --json",
    ));
    assert!(
        (v["point_max_um"].as_f64().unwrap() - 3.0).abs() < 1e-3,
        "{v}"
    );
}

#[test]
fn example_converts_and_round_trips_through_linuxcnc() {
    let dir = tempdir("convert");
    ok(&common::run(&dir, "map example -o ."));
    for ty in ["0", "1"] {
        let o = volcomp(
            &[
                "map",
                "convert",
                "example21.toml",
                "--to",
                "linuxcnc",
                "--type",
                ty,
                "--units",
                "mm",
                "-o",
                "comp",
            ],
            &dir,
        );
        ok(&o);
        assert!(
            stdout(&o).contains(&format!("COMP_FILE_TYPE = {ty}")),
            "{}",
            stdout(&o)
        );
        let x = read(&dir, "comp/x.comp");
        assert!(!x.contains('#') && x.lines().count() == 25, "{x}");
        ok(&volcomp(
            &[
                "map",
                "import-linuxcnc",
                "--x",
                "comp/x.comp",
                "--y",
                "comp/y.comp",
                "--z",
                "comp/z.comp",
                "--type",
                ty,
                "--units",
                "mm",
                "-o",
                "imported.toml",
            ],
            &dir,
        ));
        // Positioning-only compensation of both models agrees.
        for at in ["0,0,0", "123,234,111", "600,400,300"] {
            for d in ["fff", "rrr"] {
                let a = json(&volcomp(
                    &[
                        "map",
                        "eval",
                        "example21.toml",
                        "--at",
                        at,
                        "--direction",
                        d,
                        "--json",
                    ],
                    &dir,
                ));
                let b = json(&volcomp(
                    &[
                        "map",
                        "eval",
                        "imported.toml",
                        "--at",
                        at,
                        "--direction",
                        d,
                        "--json",
                    ],
                    &dir,
                ));
                for k in 0..3 {
                    let (x, y) = (
                        a["positioning_um"][k].as_f64().unwrap(),
                        b["positioning_um"][k].as_f64().unwrap(),
                    );
                    assert!((x - y).abs() < 1e-6, "{at} {d}: {a} {b}");
                }
            }
        }
    }
    let o = common::run(
        &dir,
        "map convert example21.toml --to axis-table --tool-length 120 -o tables.csv",
    );
    ok(&o);
    common::said(&o, "differs from the model by up to");
    // At the reference point the axis tables give the model's deviation.
    let a = json(&common::run(
        &dir,
        "map eval example21.toml --at 300,200,150 --tool-length 120 --json",
    ));
    let b = json(&common::run(
        &dir,
        "map eval tables.csv --at 300,200,150 --json",
    ));
    for k in 0..3 {
        let (x, y) = (
            a["deviation_um"][k].as_f64().unwrap(),
            b["deviation_um"][k].as_f64().unwrap(),
        );
        assert!((x - y).abs() < 1e-3, "{a} {b}");
    }
    // Without a tool length the conversion is refused (it depends on it).
    let o = common::run(&dir, "map convert example21.toml --to axis-table -o t2.csv");
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--tool-length"));
    ok(&common::run(
        &dir,
        "map convert example21.toml --to grid --step 150 -o grid.csv",
    ));
    let grid = read(&dir, "grid.csv");
    // 5 × 4 × 3 points and the header.
    assert_eq!(
        grid.lines().filter(|l| !l.starts_with('#')).count(),
        61,
        "{grid}"
    );
    common::run_all(
        &dir,
        &[
            "map convert tables.csv --to model -o from_tables.toml",
            "map plot example21.toml -o plot.svg",
        ],
    );
    let svg = read(&dir, "plot.svg");
    assert!(
        svg.contains("<svg") && svg.contains("EBX"),
        "plot has the components"
    );
}

/// Axis tables of X, Y and Z with a point every 2 mm over 0…600 mm (301 a
/// table), one for both directions: `ex_um(axis, position)` along X, no
/// other error.
fn dense_tables(ex_um: impl Fn(&str, f64) -> f64) -> String {
    let mut csv = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
    for a in ["X", "Y", "Z"] {
        for k in 0..=300 {
            let p = 2.0 * k as f64;
            csv.push_str(&format!("{a},both,{p},{},0,0\n", ex_um(a, p)));
        }
    }
    csv
}

#[test]
fn dense_axis_tables_go_to_linuxcnc_with_a_resampling_step() {
    let dir = tempdir("dense");
    // 301 points every 2 mm: more than LinuxCNC's 256 per joint.
    write(&dir, "dense.csv", dense_tables(|_, p| 0.01 * p));
    let o = common::run(
        &dir,
        "map convert dense.csv --to linuxcnc --type 1 --units mm -o comp",
    );
    assert_eq!(o.status.code(), Some(2));
    common::said(&o, "--step");
    ok(&common::run(
        &dir,
        "map convert dense.csv --to linuxcnc --type 1 --units mm --step 10 -o comp",
    ));
    let x = read(&dir, "comp/x.comp");
    // 0 … 600 every 10 mm: 61 lines; at 600 mm E_XX = 6 µm, trim −0.006 mm.
    assert_eq!(x.lines().count(), 61);
    assert_eq!(x.lines().last().unwrap(), "600 -0.006 -0.006");
    // Without --type LinuxCNC's file type is not guessed.
    let o = common::run(&dir, "map convert dense.csv --to linuxcnc --units mm -o c2");
    common::said(&o, "--type 0 or --type 1");
}

#[test]
fn iso230_2_prints_the_figures_of_the_hand_example() {
    let dir = tempdir("iso");
    // The hand example of volcomp_core::identify::iso230_2's tests:
    // B = 3, B̄ = −2, R↑ = 8, R↓ = 4, R = 8, E = 6, M = 3.5, A = 10 (µm).
    let runs = "target_mm,cycle,direction,deviation_um\n\
        0,1,up,1\n0,2,up,2\n0,3,up,3\n0,1,down,4\n0,2,down,5\n0,3,down,6\n\
        100,1,up,0\n100,2,up,2\n100,3,up,4\n100,1,down,2\n100,2,down,3\n100,3,down,4\n\
        200,1,up,-2\n200,2,up,-1\n200,3,up,0\n200,1,down,1\n200,2,down,1\n200,3,down,1\n";
    write(&dir, "runs.csv", runs);
    let o = common::run(&dir, "map iso230-2 runs.csv");
    ok(&o);
    let text = stdout(&o);
    for want in [
        "B  = 3.000",
        "B̄ = -2.000",
        "R↑ = 8.000",
        "R↓ = 4.000",
        "R = 8.000",
        "E = 6.000",
        "M  = 3.500",
        "A = 10.000",
    ] {
        assert!(text.contains(want), "{want}: {text}");
    }
    let v = json(&common::run(&dir, "map iso230-2 runs.csv --json"));
    assert_eq!(v["axis"]["accuracy_um"].as_f64().unwrap(), 10.0);
    ok(&common::run(
        &dir,
        "map iso230-2 runs.csv --axis x -o x.comp --type 1 --units mm",
    ));
    // x̄↑ at 0 is 2 µm, x̄↓ 5 µm: trims −0.002 and −0.005 mm.
    assert!(read(&dir, "x.comp").starts_with("0 -0.002 -0.005\n"));
}

#[test]
fn bad_model_files_name_file_row_and_column() {
    let dir = tempdir("bad");
    write_eaz_model(&dir);
    let csv = read(&dir, "m.csv");
    let cases: Vec<(&str, String, String, &str)> = vec![
        (
            "nan",
            read(&dir, "m.toml"),
            csv.replace("Y,both,500,0,0,0,0,0,0", "Y,both,500,0,nan,0,0,0,0"),
            "m.csv:5:5:",
        ),
        (
            "order",
            read(&dir, "m.toml"),
            csv.replace("Y,both,500", "Y,both,-600"),
            "m.csv:5:3:",
        ),
        (
            "unit",
            read(&dir, "m.toml"),
            csv.replace("ea_urad", "ea"),
            "m.csv:1:7:",
        ),
        (
            "missing",
            read(&dir, "m.toml").replace("zx = 0\n", ""),
            csv.clone(),
            "m.toml:4:1:",
        ),
        (
            "axis",
            read(&dir, "m.toml"),
            csv.lines()
                .filter(|l| !l.starts_with('Z'))
                .map(|l| format!("{l}\n"))
                .collect(),
            "EZZ",
        ),
    ];
    for (name, toml, csv, want) in cases {
        write(&dir, "b.toml", toml.replace("m.csv", "b.csv"));
        write(&dir, "b.csv", csv);
        let o = common::run(&dir, "map eval b.toml --at 0,0,0");
        let msg = stderr(&o)
            .replace("b.csv", "m.csv")
            .replace("b.toml", "m.toml");
        assert_eq!(o.status.code(), Some(2), "{name}: {msg}");
        assert!(msg.contains(want) && msg.contains("help:"), "{name}: {msg}");
    }
    // A file whose name and content name no model kind: the formats listed.
    write(&dir, "m.json", "{}\n");
    let o = common::run(&dir, "map eval m.json --at 0,0,0");
    common::said(&o, ".toml for a 21-component model");
    // The component table given where a map is expected: pointed to its TOML.
    let o = common::run(&dir, "compensate x.ngc --map m.csv -o o.ngc");
    common::said(&o, "model = \"kinematic-21\"");
}

#[test]
fn an_export_that_leaves_more_than_the_table_error_names_the_flag_to_change() {
    let dir = tempdir("table_error");
    // E_XX = 3 µm · sin(2π x / 16 mm), a point every 2 mm: a table every
    // 10 mm cannot follow a 16 mm wave (the sine's own values at 10 mm
    // spacing, interpolated, miss it by more than 1 µm between them).
    let wave = |a: &str, p: f64| match a {
        "X" => 3.0 * (2.0 * std::f64::consts::PI * p / 16.0).sin(),
        _ => 0.0,
    };
    write(&dir, "wave.csv", dense_tables(wave));
    let args = |extra: &[&'static str]| {
        let mut v = vec![
            "map", "export", "wave.csv", "--to", "linuxcnc", "--type", "1", "--units", "mm",
            "--step", "10", "-o", "comp",
        ];
        v.extend_from_slice(extra);
        v
    };
    let e = refused(&volcomp(&args(&[]), &dir));
    assert!(e.contains("axis X") && e.contains("finer step"), "{e}");
    assert!(e.contains("(--max-table-error-um)"), "{e}");
    assert!(!e.contains("max_table_error_um"), "{e}");
    assert!(!dir.join("comp").exists(), "nothing written on refusal");
    // Allowing the whole wave (3 µm amplitude, 6 µm peak to peak) writes it.
    ok(&volcomp(&args(&["--max-table-error-um", "7"]), &dir));
    assert!(dir.join("comp/x.comp").exists());
}
