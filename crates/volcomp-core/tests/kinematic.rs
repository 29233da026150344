//! The 21-component model in the whole pipeline: its files, compensation
//! with the active tool's length, simulation, and the LinuxCNC round trip.

use std::io::Cursor;
use std::path::Path;
use volcomp_core::compensate::{compensate_program, survey_style, CompensateOptions, Segmentation};
use volcomp_core::example::kinematic::{example_files, example_model};
use volcomp_core::io::linuxcnc_comp::{self, CompFileType, MachineUnits, Positioning};
use volcomp_core::io::model_file::{self, read_model};
use volcomp_core::model::kinematic::{
    AxisComponents, ComponentTable, Form, KinematicModel, Kinematics,
};
use volcomp_core::model::topology::Topology;
use volcomp_core::model::{Components, ErrorModel, ALL_FORWARD};
use volcomp_core::simulate::report::simulate_program;
use volcomp_gcode::{InterpOptions, Setup, Vec3, Walker};

fn data(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

#[test]
fn the_example_files_are_the_generator_output() {
    let (toml, csv) = example_files("example21.csv");
    assert_eq!(
        std::fs::read_to_string(data("example21.toml")).unwrap(),
        toml,
        "regenerate with `volcomp map example -o crates/volcomp-core/tests/data`"
    );
    assert_eq!(std::fs::read_to_string(data("example21.csv")).unwrap(), csv);
    let m = read_model(&data("example21.toml")).unwrap();
    assert_eq!(m, example_model());
}

/// Only EAZ = 20 µrad (Z's spindle tilts about X), measured with the
/// reflector at the gauge point, seed chain.
fn eaz_model() -> KinematicModel {
    let axes = [0, 1, 2].map(|a| {
        let g = if a == 2 {
            Vec3::new(20.0, 0.0, 0.0)
        } else {
            Vec3::ZERO
        };
        AxisComponents::both(
            ComponentTable::new(vec![-1000.0, 1000.0], vec![Vec3::ZERO; 2], vec![g, g]).unwrap(),
        )
    });
    KinematicModel::new(axes, Kinematics::new(Topology::SEED))
}

fn setup() -> Setup {
    Setup::from_toml("units = \"mm\"\n[tools]\n1 = 150\n2 = 50\n").unwrap()
}

fn walker(program: &str) -> Walker<Cursor<Vec<u8>>> {
    Walker::new(
        Cursor::new(program.as_bytes().to_vec()),
        Some("t.ngc".into()),
        setup(),
        InterpOptions::default(),
    )
}

fn compensate(program: &str, model: &dyn ErrorModel) -> String {
    let mut out = Vec::new();
    // The words expected below are written with 4 decimals (0.1 µm).
    let opts = CompensateOptions {
        segmentation: Segmentation::Off,
        decimals: Some(4),
        ..Default::default()
    };
    compensate_program(
        &mut walker(program),
        "t.ngc",
        model,
        &survey_style(program.as_bytes()),
        &opts,
        &mut out,
        |_| {},
    )
    .unwrap();
    String::from_utf8(out).unwrap()
}

/// Simulates `program` judged against the nominal path of `original`.
fn simulate(
    program: &str,
    original: &str,
    model: &dyn ErrorModel,
) -> volcomp_core::simulate::report::SimReport {
    let mut reference = walker(original);
    simulate_program(
        &mut walker(program),
        "t.ngc",
        Some(&mut reference),
        model,
        1e-4,
        |_| {},
    )
    .unwrap()
}

#[test]
fn compensation_uses_the_length_of_the_active_tool() {
    // EAZ = 20 µrad tilts the spindle about X; a tip L below the gauge
    // point moves by ε·L along +Y (Rx(ε)·(0, 0, −L) = (0, L·sin ε, …)):
    //   tool 1, L = 150 mm: e_y = 20e-6 · 150 mm = 3.0 µm → command Y −0.003
    //   tool 2, L =  50 mm: e_y = 20e-6 ·  50 mm = 1.0 µm → command Y −0.001
    //   G49 (no offset): the gauge point itself, no error, Y unchanged.
    // (e_z = L·(1 − cos ε) ≈ 3e-5 µm is far below the written 0.1 µm.)
    let program = "G21 G90 G17\nG0 X0 Y0 Z50\nG43 H1 G0 Z20\nG1 X10 F500\nG43 H2 G0 Z30\nG1 X20\nG49 G0 Z80\nG1 X30\nM2\n";
    let out = compensate(program, &eaz_model());
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines[1], "G0 X0 Y0 Z50", "{out}");
    assert_eq!(lines[2], "G43 H1 G0 Z20 Y-0.0030", "{out}");
    assert_eq!(lines[3], "G1 X10 F500", "{out}");
    assert_eq!(lines[4], "G43 H2 G0 Z30 Y-0.0010", "{out}");
    assert_eq!(lines[6], "G49 G0 Z80 Y0.0000", "{out}");
    // Simulated with the same tools against the original's path, the
    // compensated program has no error left; the original has the
    // hand-computed ones along its feed moves (3 µm with tool 1, 1 µm with
    // tool 2, none without a tool).
    let model = eaz_model();
    let before = simulate(program, program, &model);
    assert!((before.point_max_um - 3.0).abs() < 1e-3, "{before:?}");
    let after = simulate(&out, program, &model);
    assert!(after.contour_max_um < 1e-3, "{after:?}");
}

#[test]
fn compensate_accepts_the_example_model_file() {
    let m = read_model(&data("example21.toml")).unwrap();
    // Tool 1 (150 mm) at program Z 100: axis Z 250 of the 0…300 mm travel.
    // In G61: Y reverses at the vertex, taken up exactly there (under G64
    // the fold may leave up to the reversal value, by design).
    let program =
        "G21 G90 G17 G61\nG0 X300 Y200 Z50\nG43 H1 G0 Z100\nG1 X350 Y220 F800\nG1 X400 Y180\nM2\n";
    let out = compensate(program, &m);
    let before = simulate(program, program, &m);
    let after = simulate(&out, program, &m);
    assert!(before.point_max_um > 3.0, "{before:?}");
    // At the commanded points only the four written decimals remain (at
    // most 0.05 µm per axis); between them (no splitting here) the path
    // keeps the curvature of the errors, still 50 times smaller.
    assert!(after.point_max_um < 0.1, "{before:?} → {after:?}\n{out}");
    assert!(
        after.contour_max_um < before.contour_max_um / 20.0,
        "{before:?} → {after:?}"
    );
}

fn positioning(m: &KinematicModel, a: usize) -> Positioning {
    let (p, f, r) = m.positioning(volcomp_geom::Axis::ALL[a]);
    Positioning {
        positions_mm: p,
        forward_um: f,
        reverse_um: r,
    }
}

#[test]
fn model_to_linuxcnc_and_back_loses_nothing_the_format_holds() {
    // LinuxCNC holds E_XX, E_YY, E_ZZ per direction at the table positions;
    // everything else (straightness, angles, squareness) it cannot hold.
    let m = example_model();
    for ty in [CompFileType::Type0, CompFileType::Type1] {
        for units in [MachineUnits::Mm, MachineUnits::Inch] {
            let back: [Positioning; 3] = [0, 1, 2].map(|a| {
                let text = linuxcnc_comp::write(&positioning(&m, a), ty, units).unwrap();
                linuxcnc_comp::parse(&text, "c.comp", ty, units).unwrap()
            });
            let tables = back.clone().map(|p| {
                let t = |v: &[f64]| volcomp_core::model::axis_table::Table {
                    positions_mm: p.positions_mm.clone(),
                    errors_um: v.iter().map(|e| Vec3::new(*e, *e, *e)).collect(),
                };
                (t(&p.forward_um), t(&p.reverse_um))
            });
            let imported = model_file::positioning_model(tables, Topology::SEED).unwrap();
            for a in 0..3 {
                for (k, x) in m.axes[a].forward.positions_mm().iter().enumerate() {
                    let f = m.axes[a].forward.linear_um.errors_um[k][a];
                    let r = m.axes[a].reverse.linear_um.errors_um[k][a];
                    let fi = imported.axes[a].forward.linear_um.errors_um[k][a];
                    let ri = imported.axes[a].reverse.linear_um.errors_um[k][a];
                    assert!(
                        (imported.axes[a].forward.positions_mm()[k] - x).abs() < 1e-8,
                        "{ty:?} {units:?}"
                    );
                    assert!(
                        (f - fi).abs() < 1e-5 && (r - ri).abs() < 1e-5,
                        "{ty:?} {units:?} {a} {x}: {f} {fi} {r} {ri}"
                    );
                }
            }
            // Pitch compensation sees the same errors in both models.
            let q = Vec3::new(123.0, 234.0, 111.0);
            let e0 = m
                .deviation_um(q, ALL_FORWARD, Components::PositioningOnly)
                .unwrap();
            let e1 = imported
                .deviation_um(q, ALL_FORWARD, Components::PositioningOnly)
                .unwrap();
            assert!((e0 - e1).max_abs() < 1e-5);
            // And the imported model has nothing else.
            assert_eq!(
                imported
                    .deviation_um(q, ALL_FORWARD, Components::All)
                    .unwrap(),
                e1
            );
        }
    }
}

#[test]
fn htm_and_first_order_agree_on_the_example_to_nanometres() {
    let m = example_model();
    let tool = Vec3::new(0.0, 0.0, 200.0);
    let mut worst: f64 = 0.0;
    for x in [0.0, 300.0, 600.0] {
        for y in [0.0, 400.0] {
            for z in [0.0, 300.0] {
                let q = Vec3::new(x, y, z);
                let a = m
                    .deviation_form_um(q, ALL_FORWARD, tool, Form::Htm)
                    .unwrap();
                let b = m
                    .deviation_form_um(q, ALL_FORWARD, tool, Form::FirstOrder)
                    .unwrap();
                worst = worst.max((a - b).norm());
            }
        }
    }
    // Angles below 10 µrad and arms below 0.7 m: (1e-5)² · 700 mm = 7e-8 mm.
    assert!(worst < 1e-3, "{worst}");
}
