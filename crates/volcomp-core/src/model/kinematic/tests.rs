//! Tests of the 21-component model.

use super::*;
use crate::model::axis_table::{AxisTableMap, AxisTables, CSV_HEADER};
use crate::model::{WithTool, ALL_FORWARD};

const F: Direction = Direction::Forward;
const R: Direction = Direction::Reverse;

/// A model whose only non-zero component is `set` on axis `a`, tables
/// over −500 … 500 mm with two points (constant values).
fn single(
    topology: &str,
    a: usize,
    linear_um: Vec3,
    angular_urad: Vec3,
    squareness: Squareness,
) -> KinematicModel {
    let axes = [0, 1, 2].map(|k| {
        let (l, g) = if k == a {
            (linear_um, angular_urad)
        } else {
            (Vec3::ZERO, Vec3::ZERO)
        };
        AxisComponents::both(
            ComponentTable::new(vec![-500.0, 500.0], vec![l, l], vec![g, g]).unwrap(),
        )
    });
    let mut k = Kinematics::new(topology.parse().unwrap());
    k.squareness = squareness;
    KinematicModel::new(axes, k)
}

/// Only the angular errors `angular_urad` of axis `a`, chain `w X' Y' b Z t`.
fn angular_only(a: usize, angular_urad: Vec3) -> KinematicModel {
    single(
        "w X' Y' b Z t",
        a,
        Vec3::ZERO,
        angular_urad,
        Squareness::default(),
    )
}

fn eval(m: &KinematicModel, q: Vec3, tool: Vec3, form: Form) -> Vec3 {
    m.deviation_form_um(q, ALL_FORWARD, tool, form).unwrap()
}

fn close(a: Vec3, b: Vec3, tol: f64) -> bool {
    (a - b).max_abs() <= tol
}

#[test]
fn pure_yaw_of_x_at_two_tool_lengths() {
    // ECX = 10 µrad (yaw of X: rotation about Z), chain w X' Y' b Z t,
    // measured at the origin with the reflector at the gauge point.
    // Arm of X = (y − 0)·ŷ + (z − 0)·ẑ + (0 − L)·ẑ.
    // ε × arm = (0, 0, ε) × (0, y, z − L) = (−ε·y, 0, 0): the tool length
    // lies along the rotation axis and does not matter.
    // At y = 200 mm: e_x = −10e-6 · 200 mm = −2.0e-3 mm = −2.0 µm,
    // for L = 0 and for L = 150 mm alike.
    let m = angular_only(0, Vec3::new(0.0, 0.0, 10.0));
    let q = Vec3::new(300.0, 200.0, 50.0);
    for l in [0.0, 150.0] {
        let tool = Vec3::new(0.0, 0.0, l);
        let fo = eval(&m, q, tool, Form::FirstOrder);
        assert!(
            close(fo, Vec3::new(-2.0, 0.0, 0.0), 1e-12),
            "L = {l}: {fo:?}"
        );
        // HTM: the exact rotation of the arm (0, 200, 50 − L) about Z by
        // 1e-5 rad moves it by (−200·sin ε, 200·(cos ε − 1), 0):
        // e_y = −200 mm · 5e-11 = −1e-8 mm = −1e-5 µm.
        let htm = eval(&m, q, tool, Form::Htm);
        assert!((htm.x - (-200.0 * (1e-5f64).sin() * 1e3)).abs() < 1e-9);
        assert!((htm.y - (-1e-5)).abs() < 1e-9, "{htm:?}");
    }
    // A tool offset with an X–Y part does see the yaw: an angle head whose
    // tip sits 40 mm towards −Y of the gauge point (G43.1 Y40 Z150) has
    // arm_y = 200 − 40 = 160 mm → e_x = −10e-6 · 160 mm = −1.6 µm.
    let angle_head = Vec3::new(0.0, 40.0, 150.0);
    let fo = eval(&m, q, angle_head, Form::FirstOrder);
    assert!(close(fo, Vec3::new(-1.6, 0.0, 0.0), 1e-12), "{fo:?}");
}

#[test]
fn pure_pitch_of_x_sees_the_tool_length() {
    // EBX = 20 µrad (pitch of X: rotation about Y). Arm (0, y, z − L).
    // (0, ε, 0) × (0, y, z − L) = (ε·(z − L), 0, 0).
    // z = 50, L = 0:   e_x = 20e-6 · 50 mm   = +1.0 µm
    // z = 50, L = 150: e_x = 20e-6 · (−100) = −2.0 µm
    let m = angular_only(0, Vec3::new(0.0, 20.0, 0.0));
    let q = Vec3::new(300.0, 200.0, 50.0);
    let short = eval(&m, q, Vec3::ZERO, Form::FirstOrder);
    let long = eval(&m, q, Vec3::new(0.0, 0.0, 150.0), Form::FirstOrder);
    assert!(close(short, Vec3::new(1.0, 0.0, 0.0), 1e-12), "{short:?}");
    assert!(close(long, Vec3::new(-2.0, 0.0, 0.0), 1e-12), "{long:?}");
}

#[test]
fn pure_pitch_of_z_with_a_tool_offset() {
    // EAZ = 20 µrad (rotation of Z about X), measured with the reflector
    // at the gauge point. Arm of Z = (0, 0, 0 − L) = (0, 0, −150) for a
    // 150 mm tool. (ε, 0, 0) × (0, 0, −L) = (0, ε·L, 0):
    // e_y = 20e-6 · 150 mm = 3.0e-3 mm = +3.0 µm.
    // Exactly: Rx(ε)·(0, 0, −L) = (0, L·sin ε, −L·cos ε), so
    // e_y = 150·sin(2e-5)·1e3 µm and e_z = 150·(1 − cos 2e-5)·1e3 = 3e-5 µm.
    let m = angular_only(2, Vec3::new(20.0, 0.0, 0.0));
    let q = Vec3::new(100.0, 100.0, 100.0);
    let tool = Vec3::new(0.0, 0.0, 150.0);
    let fo = eval(&m, q, tool, Form::FirstOrder);
    assert!(close(fo, Vec3::new(0.0, 3.0, 0.0), 1e-12), "{fo:?}");
    let htm = eval(&m, q, tool, Form::Htm);
    let eps: f64 = 2e-5;
    assert!((htm.y - 150.0 * eps.sin() * 1e3).abs() < 1e-9, "{htm:?}");
    assert!(
        (htm.z - 150.0 * (1.0 - eps.cos()) * 1e3).abs() < 1e-9,
        "{htm:?}"
    );
    assert!((htm.z - 3e-5).abs() < 1e-8);
    // No tool: the measuring point itself, no Abbe error at all.
    assert!(close(eval(&m, q, Vec3::ZERO, Form::Htm), Vec3::ZERO, 0.0));
    // With the reflector 100 mm long during the measurement, the 150 mm
    // tool is 50 mm further: e_y = 20e-6 · 50 = 1.0 µm.
    let mut m2 = m.clone();
    m2.kinematics.measuring[2].tool_offset_mm = Vec3::new(0.0, 0.0, 100.0);
    let fo = eval(&m2, q, tool, Form::FirstOrder);
    assert!(close(fo, Vec3::new(0.0, 1.0, 0.0), 1e-12), "{fo:?}");
}

#[test]
fn squareness_alone() {
    // S_xy = 10, S_yz = −20, S_zx = 30 µrad; at (100, 200, 300) mm:
    // e_x = S_xy·y + S_zx·z = 10e-6·200 + 30e-6·300 = 2e-3 + 9e-3 mm = 11 µm
    // e_y = S_yz·z = −20e-6·300 = −6e-3 mm = −6 µm,  e_z = 0.
    let sq = Squareness {
        xy_urad: 10.0,
        yz_urad: -20.0,
        zx_urad: 30.0,
    };
    let m = single("w X' Y' b Z t", 0, Vec3::ZERO, Vec3::ZERO, sq);
    let q = Vec3::new(100.0, 200.0, 300.0);
    for form in [Form::Htm, Form::FirstOrder] {
        for tool in [Vec3::ZERO, Vec3::new(0.0, 0.0, 250.0)] {
            let e = eval(&m, q, tool, form);
            assert!(
                close(e, Vec3::new(11.0, -6.0, 0.0), 1e-12),
                "{form:?}: {e:?}"
            );
        }
    }
    // Pitch-only compensation sees none of it.
    let e = m
        .deviation_um(q, ALL_FORWARD, Components::PositioningOnly)
        .unwrap();
    assert_eq!(e, Vec3::ZERO);
}

#[test]
fn a_topology_change_moves_the_abbe_arm() {
    // EAY = 10 µrad (roll of Y: rotation about X), z = 200, no tool,
    // measured at the origin.
    // w X' Y' b Z t: after Y in the chain come Z and the tool: arm (0, 0, z)
    //   (ε, 0, 0) × (0, 0, 200) = (0, −ε·200, 0) → e_y = −10e-6·200 mm = −2.0 µm.
    // w Y' b Z X t: after Y come Z and X: arm (x, 0, z) = (100, 0, 200)
    //   (ε, 0, 0) × (100, 0, 200) = (0, −200ε, 0) → still −2.0 µm in y
    //   (x lies along the rotation axis).
    // w Z' Y' b X t: after Y comes only X: arm (x, 0, 0)
    //   (ε, 0, 0) × (100, 0, 0) = 0 → no error: Z now lies on the
    //   workpiece side of Y, so Y's roll tilts the table and Z together.
    let q = Vec3::new(100.0, 50.0, 200.0);
    let eps = Vec3::new(10.0, 0.0, 0.0);
    for chain in ["w X' Y' b Z t", "w Y' b Z X t"] {
        let e1 = eval(
            &single(chain, 1, Vec3::ZERO, eps, Squareness::default()),
            q,
            Vec3::ZERO,
            Form::FirstOrder,
        );
        assert!(
            close(e1, Vec3::new(0.0, -2.0, 0.0), 1e-12),
            "{chain}: {e1:?}"
        );
    }
    let e2 = eval(
        &single("w Z' Y' b X t", 1, Vec3::ZERO, eps, Squareness::default()),
        q,
        Vec3::ZERO,
        Form::FirstOrder,
    );
    assert!(close(e2, Vec3::ZERO, 1e-12), "{e2:?}");
    // EBY = 10 µrad (rotation about Y) in the same two machines:
    // w X' Y' b Z t: (0, ε, 0) × (0, 0, 200) = (200ε, 0, 0) → e_x = +2.0 µm
    // w Y' b X Z t: after Y come X and Z: (0, ε, 0) × (100, 0, 200)
    //   = (ε·200, 0, −ε·100) → e = (+2.0, 0, −1.0) µm: the arm gained x.
    let eps = Vec3::new(0.0, 10.0, 0.0);
    let e3 = eval(
        &single("w X' Y' b Z t", 1, Vec3::ZERO, eps, Squareness::default()),
        q,
        Vec3::ZERO,
        Form::FirstOrder,
    );
    assert!(close(e3, Vec3::new(2.0, 0.0, 0.0), 1e-12), "{e3:?}");
    let e4 = eval(
        &single("w Y' b X Z t", 1, Vec3::ZERO, eps, Squareness::default()),
        q,
        Vec3::ZERO,
        Form::FirstOrder,
    );
    assert!(close(e4, Vec3::new(2.0, 0.0, -1.0), 1e-12), "{e4:?}");
}

#[test]
fn moving_part_angles_flip_only_on_the_workpiece_side() {
    // EBX = 20 µrad recorded on the moving table (X' carries the
    // workpiece): the relative rotation is −20 µrad. At z = 50, L = 0:
    // relative convention e_x = +1.0 µm (see the pitch test), moving-part −1.0 µm.
    let mut m = angular_only(0, Vec3::new(0.0, 20.0, 0.0));
    let q = Vec3::new(0.0, 0.0, 50.0);
    m.kinematics.angles = AngleConvention::MovingPart;
    // (HTM adds e_z = 50 mm·(cos ε − 1) = −1e-5 µm.)
    for form in [Form::FirstOrder, Form::Htm] {
        let e = eval(&m, q, Vec3::ZERO, form);
        assert!(close(e, Vec3::new(-1.0, 0.0, 0.0), 2e-5), "{e:?}");
    }
    // Z moves the tool: its angles are not flipped.
    let mut z = angular_only(2, Vec3::new(20.0, 0.0, 0.0));
    z.kinematics.angles = AngleConvention::MovingPart;
    let e = eval(&z, q, Vec3::new(0.0, 0.0, 150.0), Form::FirstOrder);
    assert!(close(e, Vec3::new(0.0, 3.0, 0.0), 1e-12), "{e:?}");
}

/// A model with every component non-zero and position dependent; the
/// linear errors are scaled by `lin`, the angles by `scale`, squareness
/// by `sq`.
fn busy_scaled(lin: f64, scale: f64, sq: f64) -> KinematicModel {
    let axes = [0, 1, 2].map(|a| {
        let pos: Vec<f64> = (0..=10).map(|k| -100.0 + 60.0 * k as f64).collect();
        let table = |rev: f64| {
            let lin = pos
                .iter()
                .map(|&x| {
                    let u = x / 500.0;
                    Vec3::new(
                        3.0 * u + rev,
                        -2.0 * u * u + 0.3 * a as f64,
                        1.5 * (3.0 * u).sin(),
                    ) * lin
                })
                .collect();
            let ang = pos
                .iter()
                .map(|&x| {
                    let u = x / 500.0;
                    Vec3::new(
                        scale * (8.0 * u + 2.0),
                        scale * (-6.0 * u * u + 5.0),
                        scale * (4.0 * (2.0 * u).cos() - 1.0 + a as f64),
                    )
                })
                .collect();
            ComponentTable::new(pos.clone(), lin, ang).unwrap()
        };
        AxisComponents {
            forward: table(0.0),
            reverse: table(2.5),
        }
    });
    let mut k = Kinematics::new(Topology::SEED);
    k.squareness = Squareness {
        xy_urad: 12.0 * sq,
        yz_urad: -7.0 * sq,
        zx_urad: 5.0 * sq,
    };
    k.measuring = [
        MeasuringLine {
            point_mm: Vec3::new(0.0, 150.0, 200.0),
            tool_offset_mm: Vec3::new(0.0, 0.0, 100.0),
        },
        MeasuringLine {
            point_mm: Vec3::new(250.0, 0.0, 180.0),
            tool_offset_mm: Vec3::new(0.0, 0.0, 100.0),
        },
        MeasuringLine {
            point_mm: Vec3::new(250.0, 150.0, 0.0),
            tool_offset_mm: Vec3::new(0.0, 0.0, 50.0),
        },
    ];
    KinematicModel::new(axes, k)
}

fn busy(scale: f64) -> KinematicModel {
    busy_scaled(1.0, scale, 1.0)
}

#[test]
fn zero_angles_reduce_exactly_to_the_axis_tables() {
    let m = busy(0.0);
    let map = AxisTableMap {
        axes: [0, 1, 2].map(|a| AxisTables {
            forward: m.axes[a].forward.linear_um.clone(),
            reverse: m.axes[a].reverse.linear_um.clone(),
        }),
        clamp: false,
    };
    let mut square = m.clone();
    square.kinematics.squareness = Squareness::default();
    for (i, q) in [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(123.4, -56.7, 300.0),
        Vec3::new(499.0, 400.0, -100.0),
        Vec3::new(-100.0, 250.5, 77.7),
    ]
    .into_iter()
    .enumerate()
    {
        let s = [[F, F, F], [R, F, R], [F, R, F], [R, R, R]][i];
        let tables = map.deviation_um(q, s, Components::All).unwrap();
        for tool in [Vec3::ZERO, Vec3::new(0.0, 0.0, 120.0)] {
            for form in [Form::Htm, Form::FirstOrder] {
                let e = square.deviation_form_um(q, s, tool, form).unwrap();
                assert_eq!(e, tables, "{q:?} {form:?}");
                // With squareness: exactly the tables plus e_⊥.
                let e = m.deviation_form_um(q, s, tool, form).unwrap();
                let sq = m.kinematics.squareness.deviation_um(q);
                assert_eq!(e, tables + sq, "{q:?} {form:?}");
            }
        }
        assert_eq!(
            square
                .deviation_um(q, s, Components::PositioningOnly)
                .unwrap(),
            map.deviation_um(q, s, Components::PositioningOnly).unwrap()
        );
    }
}

#[test]
fn htm_and_first_order_agree_to_second_order() {
    // Scale every error (linear, angular, squareness) by k: the difference
    // HTM − first order is made of products of two errors, so it grows
    // like k² (a factor 4 per doubling), while the errors grow like k.
    let q = Vec3::new(420.0, -80.0, 260.0);
    let tool = Vec3::new(0.0, 0.0, 180.0);
    let s = [F, R, F];
    let diff = |scale: f64| {
        let m = busy_scaled(scale / 16.0, scale, scale / 16.0);
        let a = m.deviation_form_um(q, s, tool, Form::Htm).unwrap();
        let b = m.deviation_form_um(q, s, tool, Form::FirstOrder).unwrap();
        (a - b).norm()
    };
    let d: Vec<f64> = [4.0, 8.0, 16.0, 32.0].iter().map(|k| diff(*k)).collect();
    for w in d.windows(2) {
        let ratio = w[1] / w[0];
        assert!((ratio - 4.0).abs() < 0.2, "{d:?}");
    }
    // And it is small: at angles of ~100 µrad and arms of ~0.5 m,
    // about ε²·r ≈ 1e-8 · 500 mm = 5 nm.
    assert!(d[1] < 0.05, "{d:?}");
    // The explicit 4×4 product gives the same as the displacement form.
    let m = busy(16.0);
    let v = m.values(q, s).unwrap();
    let a = m.kinematics.htm_um(&v, q, tool);
    let b = m.kinematics.htm_product_um(&v, q, tool);
    assert!((a - b).max_abs() < 1e-6, "{a:?} {b:?}");
}

#[test]
fn the_tool_offset_comes_from_the_caller() {
    let m = angular_only(2, Vec3::new(20.0, 0.0, 0.0));
    let q = Vec3::new(1.0, 2.0, 3.0);
    let tool = WithTool {
        model: &m,
        tool_length_offset_mm: Vec3::new(0.0, 0.0, 150.0),
    };
    let e = tool.deviation_um(q, ALL_FORWARD, Components::All).unwrap();
    assert!((e.y - 3.0).abs() < 1e-6, "{e:?}");
    assert!(
        m.deviation_um(q, ALL_FORWARD, Components::All)
            .unwrap()
            .y
            .abs()
            < 1e-12
    );
    assert!(tool.uses_tool_offset());
}

#[test]
fn out_of_range_names_the_axis_and_clamp_holds_the_end() {
    let mut m = busy(1.0);
    let e = m
        .deviation_um(Vec3::new(0.0, 600.0, 0.0), ALL_FORWARD, Components::All)
        .unwrap_err();
    assert!(matches!(e, ModelError::OutOfRange { axis: 'Y', .. }), "{e}");
    m.clamp = true;
    let at_y = |y: f64| {
        let q = Vec3::new(0.0, y, 0.0);
        m.deviation_um(q, ALL_FORWARD, Components::PositioningOnly)
            .unwrap()
    };
    assert_eq!(at_y(600.0), at_y(500.0));
}

#[test]
fn axis_tables_from_the_model() {
    let m = busy(10.0);
    // At X's measuring point and tool (0, 150, 200), L = 100, X's Abbe arm
    // is zero, so its positioning column is exactly the model's EXX (in
    // first order; HTM adds products of X's angles and the other axes'
    // linear errors, below a nanometre).
    let mx = m.kinematics.measuring[0];
    let map = m
        .to_axis_tables(mx.point_mm, mx.tool_offset_mm, Form::FirstOrder)
        .unwrap();
    for d in [F, R] {
        let t = m.axes[0].table(d);
        let mt = match d {
            F => &map.axes[0].forward,
            R => &map.axes[0].reverse,
        };
        assert_eq!(mt.positions_mm, t.positions_mm());
        for (k, e) in mt.errors_um.iter().enumerate() {
            assert!((e.x - t.linear_um.errors_um[k].x).abs() < 1e-9);
        }
    }
    // On the lines through a reference point the tables reproduce the
    // model: exactly in first order; with HTM up to the products of two
    // axes' errors, here (angles up to ~100 µrad, arms ~600 mm) at most
    // (1e-4)² · 600 mm ≈ 6e-6 mm = 0.006 µm.
    let r = Vec3::new(200.0, 100.0, 50.0);
    let tool = Vec3::new(0.0, 0.0, 160.0);
    for (form, tol) in [(Form::FirstOrder, 1e-9), (Form::Htm, 1e-2)] {
        let map = m.to_axis_tables(r, tool, form).unwrap();
        for a in 0..3 {
            for x in [-100.0, 17.0, 333.3, 500.0] {
                let mut q = r;
                q[a] = x;
                for s in [[F, F, F], [R, F, R]] {
                    let e = m.deviation_form_um(q, s, tool, form).unwrap();
                    let t = map.deviation_um(q, s, Components::All).unwrap();
                    assert!((e - t).max_abs() < tol, "{form:?} {a} {x}: {e:?} {t:?}");
                }
            }
        }
    }
    // And back: a model from axis tables has the same deviations.
    let map = m.to_axis_tables(r, tool, Form::Htm).unwrap();
    let back = KinematicModel::from_axis_tables(&map, Topology::SEED);
    let q = Vec3::new(10.0, 20.0, 30.0);
    assert_eq!(
        back.deviation_um(q, [F, R, F], Components::All).unwrap(),
        map.deviation_um(q, [F, R, F], Components::All).unwrap()
    );
}

#[test]
fn axis_contributions_add_up_to_first_order() {
    let m = busy(10.0);
    let q = Vec3::new(100.0, 200.0, 150.0);
    let tool = Vec3::new(0.0, 0.0, 90.0);
    let s = [R, F, R];
    let total = m.deviation_form_um(q, s, tool, Form::FirstOrder).unwrap();
    let mut sum = Vec3::ZERO;
    for (a, d) in s.into_iter().enumerate() {
        sum += m
            .axis_contribution_um(a, q, d, tool, Form::FirstOrder)
            .unwrap();
    }
    assert!((total - sum).max_abs() < 1e-12);
}

#[test]
fn a_computed_position_at_the_range_end_is_in_range() {
    // Z measured up to 181.5362 mm; a Z computed as a length added and taken
    // off again, (181.5362 + 128.1) − 128.1, lands 4·10⁻¹⁴ mm beyond it:
    // still the end, for the axis tables and the model made of them. A
    // real 0.1 µm beyond is refused.
    let csv = format!(
        "{CSV_HEADER}\nX,both,0,0,0,0\nX,both,100,1,0,0\nY,both,0,0,0,0\nY,both,100,0,0,0\n\
         Z,both,0,0,0,0\nZ,both,181.5362,0,0,3\n"
    );
    let map = AxisTableMap::from_csv(&csv, "m.csv").unwrap();
    let model = KinematicModel::from_axis_tables(&map, crate::model::topology::Topology::SEED);
    let z = (181.5362 + 128.1) - 128.1;
    assert!(z > 181.5362);
    let models: [&dyn ErrorModel; 2] = [&map, &model];
    for m in models {
        let at = |z: f64| {
            m.deviation_um(
                Vec3::new(50.0, 50.0, z),
                ALL_FORWARD,
                crate::model::Components::All,
            )
        };
        assert_eq!(at(z).unwrap(), at(181.5362).unwrap());
        let e = at(181.5363).unwrap_err();
        assert!(matches!(e, ModelError::OutOfRange { axis: 'Z', .. }), "{e}");
    }
}
