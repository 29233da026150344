//! Synthetic measurement runs of a known 21-component machine, for
//! `volcomp map build` (its documented example and its test): a plan and
//! one ISO 230-2 run file per component, five bidirectional cycles with
//! repeatability noise, the straightness runs taken against squares turned
//! by a misalignment angle, the angular runs against an instrument zero
//! offset.
//!
//! The truth (µm, µrad; mm positions, seed chain, measured at the origin):
//! positioning `E_XX = 0.02·x + 2·sin(2πx/200)` (reverse 2 µm higher),
//! `E_YY = −0.015·y` (reverse +3), `E_ZZ = 0.01·z` (reverse +1.5);
//! straightness half sine waves with their least-squares line removed;
//! angles linear in the position, zero at the origin; squareness
//! `S_xy = 12`, `S_zx = 6`, `S_yz = −8` µrad.

use crate::rng::Rng;
use std::f64::consts::PI;

/// Squareness of the synthetic machine (µrad).
pub const S_XY: f64 = 12.0;
/// Squareness of the synthetic machine (µrad).
pub const S_ZX: f64 = 6.0;
/// Squareness of the synthetic machine (µrad).
pub const S_YZ: f64 = -8.0;

const LENGTH_MM: [f64; 3] = [400.0, 300.0, 200.0];
const STEP_MM: f64 = 50.0;
const CYCLES: usize = 5;
const NOISE_UM: f64 = 0.1;
const NOISE_URAD: f64 = 0.2;

fn targets(a: usize) -> Vec<f64> {
    (0..=(LENGTH_MM[a] / STEP_MM) as usize)
        .map(|k| k as f64 * STEP_MM)
        .collect()
}

/// A half sine of amplitude `amp` over the axis, minus its least-squares
/// line at the targets (so that its straightness reference is itself).
fn bow(a: usize, amp: f64, x: f64) -> f64 {
    let l = LENGTH_MM[a];
    let f = |p: f64| amp * (PI * p / l).sin();
    let t = targets(a);
    let n = t.len() as f64;
    let mx = t.iter().sum::<f64>() / n;
    let mv = t.iter().map(|&p| f(p)).sum::<f64>() / n;
    let sxx: f64 = t.iter().map(|p| (p - mx).powi(2)).sum();
    let sxv: f64 = t.iter().map(|&p| (p - mx) * (f(p) - mv)).sum();
    let slope = sxv / sxx;
    f(x) - (mv + slope * (x - mx))
}

/// The true component `(direction d: X Y Z A B C, axis a)` at `x`:
/// `(forward, reverse)`.
pub fn truth(d: usize, a: usize, x: f64) -> (f64, f64) {
    if d == a {
        return match a {
            0 => {
                let e = 0.02 * x + 2.0 * (2.0 * PI * x / 200.0).sin();
                (e, e + 2.0)
            }
            1 => (-0.015 * x, -0.015 * x + 3.0),
            _ => (0.01 * x, 0.01 * x + 1.5),
        };
    }
    let v = if d < 3 {
        let amp = [[0.0, 1.2, 0.6], [1.5, 0.0, -0.5], [-1.0, 0.8, 0.0]][d][a];
        bow(a, amp, x)
    } else {
        // Angles: µrad per mm, zero at the origin.
        let k = [
            [0.02, -0.01, 0.015],
            [0.012, 0.02, -0.008],
            [-0.01, 0.005, 0.01],
        ][d - 3][a];
        k * x
    };
    (v, v)
}

/// What a run of component `(d, a)` records at `x` before noise: the truth,
/// with the squares' misalignment (φ per plane) and squareness in the
/// straightness runs, and an instrument zero offset in the angular runs.
fn recorded(d: usize, a: usize, x: f64) -> (f64, f64) {
    let (f, r) = truth(d, a, x);
    // Squares turned by φ: XY 30, XZ −20, YZ 15 µrad (µrad·mm = 10⁻³ µm).
    let extra = match (d, a) {
        (1, 0) => -30.0 * x * 1e-3,         // EYX − φ_xy·x
        (0, 1) => (S_XY + 30.0) * x * 1e-3, // EXY + (S_xy + φ_xy)·y
        (2, 0) => 20.0 * x * 1e-3,          // EZX − φ_xz·x
        (0, 2) => (S_ZX - 20.0) * x * 1e-3, // EXZ + (S_zx + φ_xz)·z
        (2, 1) => -15.0 * x * 1e-3,         // EZY − φ_yz·y
        (1, 2) => (S_YZ + 15.0) * x * 1e-3, // EYZ + (S_yz + φ_yz)·z
        (d, _) if d >= 3 => 7.0,            // the level's zero
        _ => 0.0,
    };
    (f + extra, r + extra)
}

/// The plan and the 18 run files, as `(path relative to the data folder, text)`;
/// the plan names the run files relative to itself.
pub fn files() -> Vec<(String, String)> {
    let names = ['X', 'Y', 'Z', 'A', 'B', 'C'];
    let axes = ['X', 'Y', 'Z'];
    let mut plan = String::from(
        "# volcomp map build: which run measures which component (docs/build.md)\nmodel = \"build-plan\"\nchain = \"w X' Y' b Z t\"\nunits = \"mm\"\nmeasuring_point_mm = [0, 0, 0]\nmeasuring_tool_length_mm = 0\nreference_point_mm = [0, 0, 0]\nstraightness_reference = \"least-squares\"\n\n[runs]\n",
    );
    let mut out = Vec::new();
    let mut rng = Rng::new(2301);
    for (a, axis) in axes.iter().enumerate() {
        for (d, dir) in names.iter().enumerate() {
            let name = format!("E{dir}{axis}");
            let file = format!("{}.csv", name.to_ascii_lowercase());
            plan.push_str(&format!("{name} = \"{file}\"\n"));
            let path = format!("build/{file}");
            let column = if d < 3 {
                "deviation_um"
            } else {
                "deviation_urad"
            };
            let noise = if d < 3 { NOISE_UM } else { NOISE_URAD };
            let mut text = format!("# {name}: five bidirectional cycles (synthetic; see crates/volcomp-core/src/example/build.rs)\ntarget_mm,cycle,direction,{column}\n");
            for cycle in 1..=CYCLES {
                for up in [true, false] {
                    let t = targets(a);
                    let order: Vec<f64> = if up { t } else { t.into_iter().rev().collect() };
                    for x in order {
                        let (f, r) = recorded(d, a, x);
                        let v = if up { f } else { r } + noise * rng.normal();
                        text.push_str(&format!(
                            "{x},{cycle},{},{v:.4}\n",
                            if up { "up" } else { "down" }
                        ));
                    }
                }
            }
            out.push((path, text));
        }
    }
    let mut all = vec![("build/plan.toml".to_string(), plan)];
    all.extend(out);
    all
}
