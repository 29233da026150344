//! Evaluates a model at many points and reports the time: the Rust side of
//! the Python binding's benchmark (`crates/volcomp-py/bench/eval_points.py`
//! runs both in one go; figures in BENCHMARKS.md).
//!
//! `cargo run --release -p volcomp-core --example eval_points -- [N] [MAP]`
//! (default 1 000 000 points on `examples/data/map.csv`). The points are the
//! additive recurrence `frac(i·α_k)` scaled to the map's ranges (the same
//! formula the Python side uses), every axis moving forward; prints the best
//! of five runs in ns per point and the sum of all components, so both
//! sides can be seen to compute the same numbers.

use std::path::PathBuf;
use std::time::Instant;
use volcomp_core::model::{Components, ALL_FORWARD};
use volcomp_core::prelude::*;

/// Irrational steps of the recurrence (fractional parts of the inverse
/// golden ratio and of the plastic number's powers).
pub const ALPHA: [f64; 3] = [
    0.618_033_988_749_894_8,
    0.754_877_666_246_692_7,
    0.569_840_290_998_053_3,
];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let n: usize = args
        .next()
        .map(|a| a.parse())
        .transpose()?
        .unwrap_or(1_000_000);
    let map = args.next().map(PathBuf::from).unwrap_or_else(|| {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/data/map.csv")
    });
    let model = load_model(&map, &LoadOptions::default())?.into_model();
    let r = model.range_mm();
    let q: Vec<Vec3> = (0..n)
        .map(|i| {
            let c = |k: usize| r[k][0] + (i as f64 * ALPHA[k]).fract() * (r[k][1] - r[k][0]);
            Vec3::new(c(0), c(1), c(2))
        })
        .collect();
    let mut out = vec![Vec3::ZERO; n];
    let mut best = f64::INFINITY;
    for _ in 0..5 {
        let t = Instant::now();
        for (o, p) in out.iter_mut().zip(&q) {
            *o = model.deviation_um(*p, ALL_FORWARD, Components::All)?;
        }
        best = best.min(t.elapsed().as_secs_f64());
    }
    let sum: f64 = out.iter().map(|e| e.x + e.y + e.z).sum();
    println!(
        "rust: {n} points, best of 5 {:.1} ms ({:.1} ns/point), sum {sum:.9e} µm",
        best * 1e3,
        best * 1e9 / n as f64
    );
    Ok(())
}
