"""Evaluating a million points: the Python binding against the same loop
in Rust, in one run (figures in BENCHMARKS.md).

    python crates/volcomp-py/bench/eval_points.py [N]

Needs the installed package (pip install ./crates/volcomp-py) and cargo
(it runs `cargo run --release -p volcomp-core --example eval_points`).
The points are frac(i·α_k) scaled to the map's ranges, as in the Rust
example; both print the sum of all components, which must agree.
"""

import pathlib
import subprocess
import sys
import time

import numpy as np

import volcomp

REPO = pathlib.Path(__file__).resolve().parents[3]
ALPHA = np.array([0.6180339887498948, 0.7548776662466927, 0.5698402909980533])


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 1_000_000
    model = volcomp.Model.load(REPO / "examples" / "data" / "map.csv")
    r = model.range_mm
    i = np.arange(n, dtype=np.float64)[:, None]
    q = r[:, 0] + np.modf(i * ALPHA)[0] * (r[:, 1] - r[:, 0])
    best = float("inf")
    for _ in range(5):
        t = time.perf_counter()
        e = model.deviation_um(q)
        best = min(best, time.perf_counter() - t)
    print(f"python: {n} points, best of 5 {best * 1e3:.1f} ms ({best * 1e9 / n:.1f} ns/point), sum {e.sum():.9e} µm")
    rust = subprocess.run(
        ["cargo", "run", "-q", "--release", "-p", "volcomp-core", "--example", "eval_points", "--", str(n)],
        cwd=REPO, check=True, capture_output=True, text=True,
    ).stdout.strip()
    print(rust)
    rust_ms = float(rust.split("best of 5 ")[1].split(" ms")[0])
    print(f"ratio python/rust: {best * 1e3 / rust_ms:.2f}")


if __name__ == "__main__":
    main()
