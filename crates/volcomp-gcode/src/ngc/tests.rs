//! Hand-derived checks of expressions, parameters and control flow. The
//! motion-by-motion agreement with LinuxCNC is in the rs274 agreement test
//! (fixtures `ngc_*.ngc`).

use crate::{InterpOptions, Setup, Walker};
use std::io::Cursor;

/// The X end points of every motion of `program` (mm), or the error text.
fn xs(program: &str) -> Result<Vec<f64>, String> {
    xs_with(program, Setup::default())
}

fn xs_with(program: &str, setup: Setup) -> Result<Vec<f64>, String> {
    let mut w = Walker::new(
        Cursor::new(program.as_bytes().to_vec()),
        Some("p.ngc".into()),
        setup,
        InterpOptions::default(),
    );
    let mut out = Vec::new();
    while let Some(ev) = w.next_line().map_err(|e| e.to_string())? {
        out.extend(ev.motions.iter().map(|m| m.end.x));
    }
    Ok(out)
}

fn x_of(expr: &str) -> f64 {
    let v = xs(&format!("G21 G0 X{expr}\nM2\n")).unwrap();
    assert_eq!(v.len(), 1, "{expr}");
    v[0]
}

#[test]
fn operators_follow_linuxcnc_precedence_and_rules() {
    // ** binds tighter than *, * than +, + than comparisons, comparisons than AND.
    assert_eq!(x_of("[1 + 2 * 3 ** 2]"), 19.0);
    // Equal precedence associates to the left: (2**3)**2, (8/4)/2, (7-2)-1.
    assert_eq!(x_of("[2 ** 3 ** 2]"), 64.0);
    assert_eq!(x_of("[8 / 4 / 2]"), 1.0);
    assert_eq!(x_of("[7 - 2 - 1]"), 4.0);
    // MOD is never negative: -7 mod 3 = 2 (fmod gives -1, plus |3|).
    assert_eq!(x_of("[-7 MOD 3]"), 2.0);
    assert_eq!(x_of("[1 + 1 EQ 2]"), 1.0);
    assert_eq!(x_of("[1 LT 2 AND 3 GT 4]"), 0.0);
    assert_eq!(x_of("[0 OR 2 XOR 1]"), 0.0);
    // EQ/NE within 0.0001 and LE exact, as the rs274 of Debian's LinuxCNC
    // 2.9.0~pre1 (checked: `[0.1 EQ 0.10005]` is true there, and a loop
    // `while [#1 LE 0.3]` stepping 0.1 from 0 runs 3 times).
    assert_eq!(x_of("[1 EQ 1.00005]"), 1.0);
    assert_eq!(x_of("[1 NE 1.0002]"), 1.0);
    assert_eq!(x_of("[0.30000000000000004 LE 0.3]"), 0.0);
}

#[test]
fn functions_work_in_degrees_and_round_half_away_from_zero() {
    assert!((x_of("[SIN[30]]") - 0.5).abs() < 1e-12);
    assert!((x_of("[COS[60]]") - 0.5).abs() < 1e-12);
    assert!((x_of("[ATAN[1]/[-1]]") - 135.0).abs() < 1e-12);
    assert!((x_of("[ACOS[0]]") - 90.0).abs() < 1e-12);
    assert_eq!(x_of("[ROUND[2.5]]"), 3.0);
    assert_eq!(x_of("[ROUND[-2.5]]"), -3.0);
    assert_eq!(x_of("[FIX[-1.5]]"), -2.0);
    assert_eq!(x_of("[FUP[-1.5]]"), -1.0);
    assert_eq!(x_of("[SQRT[2] * SQRT[2]]").round(), 2.0);
    assert_eq!(x_of("[EXISTS[#<nope>]]"), 0.0);
    assert_eq!(x_of("-[2]"), -2.0);
}

#[test]
fn settings_take_effect_after_the_line() {
    // #1 is 1 when the line is read; X uses it, then #1 becomes 5.
    let v = xs("G21\n#1 = 1\n#1 = 5 G0 X#1\nG0 X#1\nM2\n").unwrap();
    assert_eq!(v, vec![1.0, 5.0]);
    // Two settings on one line both read the old value.
    let v = xs("G21\n#1=1\n#1=2 #2=#1\nG0 X#2\nM2\n").unwrap();
    assert_eq!(v, vec![1.0]);
}

#[test]
fn predefined_parameters_show_the_program_position_in_program_units() {
    let mut setup = Setup::default();
    setup.work_offsets_mm[0] = crate::Vec3::new(100.0, 0.0, 0.0);
    // In G20 with G54 X = 100 mm: at machine X 125.4 mm the program X is 1 inch.
    let v = xs_with(
        "G20 G0 X1\nG0 X[#<_x> + 1]\nG0 X[#5420 + 1]\nG21\nG0 X#5221\nM2\n",
        setup,
    )
    .unwrap();
    assert_eq!(v.len(), 4);
    assert!((v[1] - (100.0 + 2.0 * 25.4)).abs() < 1e-9);
    assert!((v[2] - (100.0 + 3.0 * 25.4)).abs() < 1e-9);
    // #5221 in mm after G21: the G54 X offset, 100, so X100 → machine 200.
    assert!((v[3] - 200.0).abs() < 1e-9);
}

#[test]
fn loops_calls_and_branches_run_as_written() {
    let p = "G21\n#1=0\no1 while [#1 LT 3]\nG0 X#1\n#1=[#1+1]\no1 endwhile\n\
             o2 repeat [2]\nG0 X10\no2 endrepeat\n\
             o3 sub\nG0 X[#1 * 100]\no3 return [7]\no3 endsub\n\
             o3 call [4]\nG0 X#<_value>\n\
             o4 if [0]\nG0 X-1\no4 elseif [1]\nG0 X-2\no4 else\nG0 X-3\no4 endif\n\
             #2=0\no5 do\n#2=[#2+1]\no6 if [#2 EQ 2]\no5 continue\no6 endif\no7 if [#2 EQ 4]\no5 break\no7 endif\nG0 X[50+#2]\no5 while [1]\nM2\n";
    let v = xs(p).unwrap();
    assert_eq!(
        v,
        vec![0.0, 1.0, 2.0, 10.0, 10.0, 400.0, 7.0, -2.0, 51.0, 53.0]
    );
}

#[test]
fn subroutine_files_are_found_on_the_subroutine_path() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("shift.ngc"),
        "(a subroutine file)\no<shift> sub\nG0 X[#1 + #2]\no<shift> endsub\nM2\n",
    )
    .unwrap();
    let mut setup = Setup::default();
    setup.subroutine_path.push(dir.path().to_path_buf());
    let v = xs_with(
        "G21\no<shift> call [1] [2]\no<shift> call [3] [4]\nM2\n",
        setup,
    )
    .unwrap();
    assert_eq!(v, vec![3.0, 7.0]);
    let e = xs("G21\no<shift> call [1]\nM2\n").unwrap_err();
    assert!(e.contains("p.ngc:2:1") && e.contains("shift.ngc"), "{e}");
}

#[test]
fn fanuc_subprograms_repeat_and_return() {
    let v = xs("G21 G91\nM98 P100 L3\nG90 G0 X0\nM30\nO100\nG0 X1\nM99\n").unwrap();
    assert_eq!(v, vec![1.0, 2.0, 3.0, 0.0]);
}

#[test]
fn locals_belong_to_their_call_and_numbered_1_to_30_are_restored() {
    let p =
        "G21\n#1=9\n#<a>=1\no1 sub\n#<a>=2\nG0 X#1\no1 endsub\no1 call [5]\nG0 X[#1 + #<a>]\nM2\n";
    assert_eq!(xs(p).unwrap(), vec![5.0, 10.0]);
    // A subroutine does not see its caller's locals.
    let e = xs("G21\n#<a>=1\no1 sub\nG0 X#<a>\no1 endsub\no1 call\nM2\n").unwrap_err();
    assert!(e.contains("#<a> is not defined"), "{e}");
}

#[test]
fn bad_programs_are_refused_where_they_go_wrong() {
    let cases = [
        ("G21\nG0 X[1/0]\nM2\n", "p.ngc:2:7", "division by zero"),
        ("G21\nG0 X#<nope>\nM2\n", "p.ngc:2:5", "not defined"),
        ("G21\nG0 X[1+2\nM2\n", "p.ngc:2:5", "not closed"),
        ("G21\nG0 X[FOO[1]]\nM2\n", "p.ngc:2:6", "unknown function"),
        (
            "G21\no1 while [1]\nG0 X1\n",
            "p.ngc",
            "o1 (opened on line 2) is not closed",
        ),
        (
            "G21\no1 endwhile\nM2\n",
            "p.ngc:2:1",
            "undefined O-word label",
        ),
        // LinuxCNC binds a control label to one line (rs274: "duplicate
        // O-word label"), in sequence as well as nested.
        (
            "G21\no1 if [1]\no1 endif\no1 if [1]\no1 endif\nM2\n",
            "p.ngc:4:1",
            "duplicate O-word label",
        ),
        (
            "G21\no1 if [1]\no1 if [1]\no1 endif\no1 endif\nM2\n",
            "p.ngc:3:1",
            "already used on line 2",
        ),
        // rs274: "undefined O-word label", "no matching label".
        (
            "G21\no1 if [1]\no2 endif\nM2\n",
            "p.ngc:3:1",
            "undefined O-word label",
        ),
        (
            "G21\no1 if [1]\no1 endwhile\nM2\n",
            "p.ngc:3:1",
            "belongs to the `if` of line 2",
        ),
        (
            "G21\no1 sub\no1 endsub\no1 sub\no1 endsub\nM2\n",
            "p.ngc:4:1",
            "redefining sub",
        ),
        (
            "G21\no9 call\nM2\n",
            "p.ngc:2:1",
            "not defined in the program",
        ),
        (
            "G21\no1 sub\no1 call\no1 endsub\no1 call\nM2\n",
            "p.ngc:3:1",
            "nested subroutine calls",
        ),
        ("G21\nM99\n", "p.ngc:2:1", "M99 in the main program"),
    ];
    for (p, at, what) in cases {
        let e = xs(p).unwrap_err();
        assert!(e.contains(at) && e.contains(what), "{p:?}: {e}");
    }
}

/// Only lines executed again count against the limit: a long program
/// without control flow runs whatever its length; a loop's passes after the
/// first and a subroutine's lines count (2 lines × 5 passes here: the first
/// pass is the main program's own lines).
#[test]
fn only_repeated_lines_count_against_the_limit() {
    let run = |text: String, max: u64| -> Result<(), String> {
        let options = InterpOptions {
            max_executed_lines: max,
            ..InterpOptions::default()
        };
        let mut w = Walker::new(
            Cursor::new(text.into_bytes()),
            Some("p.ngc".into()),
            Setup::default(),
            options,
        );
        loop {
            match w.next_line() {
                Ok(Some(_)) => {}
                Ok(None) => return Ok(()),
                Err(e) => return Err(e.to_string()),
            }
        }
    };
    let long: String = (0..50).map(|k| format!("G1 X{k} F100\n")).collect();
    run(format!("G21\n{long}M2\n"), 10).unwrap();
    // The first pass runs the main program's lines for the first time
    // (free); passes 2 to 5 run `while`, the two body lines and `endwhile`
    // again (4 × 4 = 16); the last test of the condition is one more: 17.
    let looped = "G21\n#1 = 0\no1 while [#1 LT 5]\nG1 X#1 F100\n#1 = [#1 + 1]\no1 endwhile\nM2\n";
    let counted = (1..40u64)
        .find(|&m| run(looped.to_string(), m).is_ok())
        .unwrap();
    assert_eq!(counted, 17, "{counted}");
    assert!(run(looped.to_string(), counted - 1)
        .unwrap_err()
        .contains(&format!("executed {} lines of loops", counted - 1)));
}

#[test]
fn a_loop_that_never_ends_is_stopped() {
    let options = InterpOptions {
        max_executed_lines: 10_000,
        ..InterpOptions::default()
    };
    let mut w = Walker::new(
        Cursor::new(b"G21\no1 while [1]\nG0 X1\no1 endwhile\nM2\n".to_vec()),
        Some("p.ngc".into()),
        Setup::default(),
        options,
    );
    let e = loop {
        match w.next_line() {
            Ok(Some(_)) => {}
            Ok(None) => panic!("an endless loop ended"),
            Err(e) => break e.to_string(),
        }
    };
    assert!(
        e.contains("executed 10000 lines of loops and subroutine calls without ending"),
        "{e}"
    );
}

#[test]
fn a_var_file_sets_the_start_state_and_presets_parameters() {
    let dir = tempfile::tempdir().unwrap();
    // G28 at X 1 in, G55 (the one in use, #5220 = 2) at X 10 in, #100 = 2.
    std::fs::write(
        dir.path().join("m.var"),
        "100\t2.000000\n5161\t1.000000\n5220\t2.000000\n5241\t10.000000\n",
    )
    .unwrap();
    let toml = "units = \"inch\"\nvar_file = \"m.var\"\n";
    let file = dir.path().join("setup.toml");
    let setup = Setup::from_toml_in(toml, &file.display().to_string()).unwrap();
    // G21 X#100 = 2 mm in G55: machine X = 254 + 2 mm; G28 through the
    // current point to 25.4 mm; #5241 reads 10 (inches, the machine's unit)
    // in a G21 program: X10 mm in G55. rs274 -v with this file prints the
    // same four moves.
    let v = xs_with("G21 G0 X#100\nG28\nG0 X[#5241]\nM2\n", setup).unwrap();
    let want = [256.0, 256.0, 25.4, 264.0];
    assert_eq!(v.len(), 4, "{v:?}");
    for (a, b) in v.iter().zip(want) {
        assert!((a - b).abs() < 1e-9, "{v:?}");
    }
    // Both a var file and tables: one place only.
    let both = format!("{toml}[work_offsets]\nG54 = [0, 0, 0]\n");
    let e = Setup::from_toml_in(&both, &file.display().to_string()).unwrap_err();
    assert!(e.to_string().contains("both a var_file"), "{e}");
    // A bad line is located.
    std::fs::write(dir.path().join("m.var"), "5161 1\n5162 x\n").unwrap();
    let e = Setup::from_toml_in(toml, &file.display().to_string()).unwrap_err();
    assert!(e.to_string().contains("m.var:2:6"), "{e}");
    // LinuxCNC requires ascending numbers ("Parameter file out of order").
    std::fs::write(dir.path().join("m.var"), "5162 1\n5161 1\n").unwrap();
    let e = Setup::from_toml_in(toml, &file.display().to_string()).unwrap_err();
    assert!(
        e.to_string().contains("m.var:2:1") && e.to_string().contains("order"),
        "{e}"
    );
}

#[test]
fn bracketed_numbers_and_double_signs_are_rendered() {
    // `[1]` is an expression (LinuxCNC's read_real_expression), `+-7` a
    // unary plus before -7 (read_real_value): both render to plain numbers.
    let v = xs("G21\n#2=1\nG0 X[1]\nG0 X[-2]\nG0 X[[3]]\nG0 X+-7 Y#2\nM2\n").unwrap();
    assert_eq!(v, vec![1.0, -2.0, 3.0, -7.0]);
}

#[test]
fn a_setting_declares_its_name_for_the_rest_of_the_line() {
    // add_named_param at read time: the new name reads 0 further along
    // the line, so a first `#<c> = [#<c> + 1]` sets 1, and EXISTS is 1.
    let v =
        xs("G21\n#<c> = [#<c> + 1]\nG0 X#<c>\n#<n> = 5 G0 X[EXISTS[#<n>] + #<n>]\nM2\n").unwrap();
    assert_eq!(v, vec![1.0, 1.0]);
    // Read before the setting on the line: still not defined.
    let e = xs("G21\nG0 X#<q> #<q> = 5\nM2\n").unwrap_err();
    assert!(e.contains("p.ngc:2:5"), "{e}");
}

#[test]
fn parameter_numbers_stop_at_5601_and_the_tool_changer_ones_are_refused() {
    // The (DEBUG, …) flag starts at 1 (`Interp::init`).
    assert_eq!(x_of("#5599"), 1.0);
    assert_eq!(x_of("[EXISTS[#5601] + EXISTS[#5602] * 2]"), 1.0);
    let e = xs("G21\nG0 X#5602\nM2\n").unwrap_err();
    assert!(e.contains("p.ngc:2:5") && e.contains("out of range"), "{e}");
    let e = xs("G21\n#5602 = 1\nM2\n").unwrap_err();
    assert!(e.contains("out of range"), "{e}");
    let e = xs("G21\nG0 X#5601\nM2\n").unwrap_err();
    assert!(e.contains("tool changer"), "{e}");
}

#[test]
fn rendered_values_are_the_shortest_round_trip_without_exponent() {
    let text = |v: f64| {
        let mut out = Vec::new();
        super::line::format_value(v, &mut out);
        String::from_utf8(out).unwrap()
    };
    assert_eq!(text(0.1 + 0.2), "0.30000000000000004");
    assert_eq!(text(-0.0), "0");
    assert_eq!(text(-12.5), "-12.5");
    assert_eq!(text(1e-7), "0.0000001");
    // Past 40 characters: 15 decimals, trailing zeros dropped.
    assert_eq!(text(1e-25), format!("0.{}1", "0".repeat(24)));
    assert_eq!(text(1e-45), "0");
    assert_eq!(text(1e40), "10000000000000000303786028427003666890752");
}

/// The fast writer of computed values against the standard library's
/// `{}` (the reference: the same text, shortest round-trip digits, no
/// exponent) on random bit patterns and on values a program computes.
#[test]
fn rendered_values_match_the_standard_formatter() {
    let text = |v: f64| {
        let mut out = Vec::new();
        super::line::format_value(v, &mut out);
        String::from_utf8(out).unwrap()
    };
    let reference = |v: f64| {
        let v = if v == 0.0 { 0.0 } else { v };
        let s = format!("{v}");
        (s.len() <= 40).then_some(s)
    };
    let mut x = 0x2545_f491_4f6c_dd1du64;
    let mut next = move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        x
    };
    let mut checked = 0;
    for i in 0..300_000u64 {
        let r = next();
        let v = match i % 5 {
            0 => f64::from_bits(r),
            1 => (r % 2_000_000) as f64 * 0.001 - 1000.0,
            2 => ((r % 100_000) as f64 * 0.01).sin() * 50.0,
            // Few binary fraction digits: where two shortest candidates
            // can be equally close (`0x430567a485f3fa62`: `…540.3`).
            3 => (r >> (11 + r % 8)) as f64 / 8.0,
            _ => (r >> 11) as f64 / (1u64 << 53) as f64 * 10f64.powi((r % 40) as i32 - 20),
        };
        if let Some(s) = reference(v) {
            assert_eq!(text(v), s, "{v:e} ({:#x})", v.to_bits());
            checked += 1;
        }
    }
    assert!(checked > 200_000, "{checked}");
    for v in [
        1e-5,
        1e-6,
        1e15,
        1e16,
        1e17,
        123456.0,
        0.5,
        -0.001,
        5e-324,
        f64::MAX,
        f64::from_bits(0x4305_67a4_85f3_fa62),
    ] {
        if let Some(s) = reference(v) {
            assert_eq!(text(v), s, "{v:e}");
        }
    }
}
