//! The causes a service engineer reads from a ballbar trace, fitted by
//! least squares with their standard uncertainties.
//!
//! Each cause leaves a *signature* on the radial deviation `Δr(θ)` of a
//! run of sense `σ` (+1 ccw, −1 cw), derived to first order in the error
//! (`Δr = e·r̂`, the error projected on the radius; the neglected terms are
//! `|e|²/2R`, 5·10⁻⁴ µm for 10 µm on R = 100 mm) [Kakino et al. 1993]
//! [Knapp 1983]. With `u = R cos θ`, `v = R sin θ` about the pivot
//! (docs/ballbar.md, "Signatures", derives each):
//!
//! | cause | parameter | `Δr(θ)` (µm) |
//! |---|---|---|
//! | centre offset | `c_u`, `c_v` (µm) | `c_u cos θ + c_v sin θ` |
//! | radius (ballbar length, mean scale) | `ΔR` (µm) | `ΔR` |
//! | scale mismatch | `m = s_u − s_v` (µm/m) | `(R/1000)(m/2) cos 2θ` |
//! | squareness (docs/design.md sign) | `S` (µrad) | `(R/1000)(S/2) sin 2θ` |
//! | servo mismatch (`v` lags `u` by `τ`) | `τ` (ms) | `−σ τ F/120 · sin 2θ` (F mm/min) |
//! | backlash of axis `a` at its `±` reversal | `b_a±` (µm) | `−d_a b_a(θ)/2 · p_a(θ)`, taken up as a dead band |
//! | lateral play of axis `a` | `l_a` (µm) | `−d_a l_a/2 · p_ā(θ)`, fading with `a`'s band |
//! | reversal spike of axis `a` at `±` | `k_a±` (µm) | `k · exp(−φ_a/φ_s)` after the reversal |
//! | cyclic error of axis `a`, pitch `P` | `A_a`, `B_a` (µm) | `(A sin 2πx_a/P + B cos 2πx_a/P) p_a(θ)` |
//!
//! `p_u = cos θ`, `p_v = sin θ` project an axis' error on the radius;
//! `d_a = ±1` is the axis' direction (forward +1); `b_a(θ)` interpolates
//! `b_a+` and `b_a−` linearly along the axis; `φ_a` is the angle travelled
//! since the axis last reversed. Backlash is the model's dead band
//! (docs/design.md, "Direction state and backlash"): the reverse table lies
//! `b` above the forward one; after a reversal the tool stands while the
//! axis travels `t = R(1 − cos φ)` across the band, so for `t < b` the
//! axis' error is `d (b/2 − t)` instead of `−d b/2`. The band's width
//! depends on `b`, so the fit iterates: the bands of the last estimate
//! fix which samples lie inside one, every parameter is then linear.
//!
//! Uncertainties are those of linear least squares with white noise:
//! `cov = σ̂² (JᵀJ)⁻¹`, `σ̂² = RSS/(N − p)`. What a cause explains is the
//! RMS of its fitted signature over the trace and its share of the sum of
//! squares of all signatures.

use super::{figures, BallbarError, Figures, Run, Trace};
use crate::linalg::{least_squares, Cholesky, Matrix};
use std::f64::consts::PI;

/// What the fit includes beyond the always-fitted causes.
#[derive(Debug, Clone, PartialEq)]
pub struct FitOptions {
    /// Lead-screw pitch of X, Y, Z (mm) for the cyclic error; `None`: no
    /// cyclic error of that axis.
    pub pitch_mm: [Option<f64>; 3],
    /// The decay angle of a reversal spike (degrees).
    pub spike_width_deg: f64,
}

impl Default for FitOptions {
    fn default() -> Self {
        Self {
            pitch_mm: [None; 3],
            spike_width_deg: 2.0,
        }
    }
}

/// One fitted cause.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Cause {
    /// Its identifier (`backlash_X+`, `squareness_XY`, …).
    pub id: String,
    /// What it is, for a person.
    pub label: String,
    /// The value's unit.
    pub unit: &'static str,
    /// The fitted value.
    pub value: f64,
    /// Its standard uncertainty (same unit).
    pub std: f64,
    /// The RMS of its signature over the trace (µm).
    pub rms_um: f64,
    /// Its share of the sum of squares of all signatures (%).
    pub share_pct: f64,
}

/// The fit of a trace.
#[derive(Debug, Clone, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct TraceFit {
    /// The ISO 230-4 figures of the trace.
    pub figures: Figures,
    /// The causes, in the order of the table above.
    pub causes: Vec<Cause>,
    /// RMS of what no cause explains (µm).
    pub residual_rms_um: f64,
    /// The samples fitted.
    pub samples: usize,
    /// What no cause explains, as a trace (the same angles).
    pub residual: Trace,
}

impl TraceFit {
    /// The cause `id`, if fitted.
    pub fn cause(&self, id: &str) -> Option<&Cause> {
        self.causes.iter().find(|c| c.id == id)
    }
}

/// One sample: its angle (rad), the run's sense (±1), the deviation (µm).
#[derive(Clone, Copy)]
struct Sample {
    theta: f64,
    sense: f64,
    y: f64,
}

/// Where one axis stands at a sample: angle since its last reversal, the
/// end it reversed at (±1), its direction (+1 forward), its travel since
/// (µm), its projection on the radius and on the other axis' radius part.
struct AxisState {
    phi: f64,
    end: f64,
    dir: f64,
    travel_um: f64,
    along: f64,
    across: f64,
    cos: f64,
}

fn axis_state(s: &Sample, axis: usize, radius_mm: f64) -> AxisState {
    let theta0 = if axis == 0 { 0.0 } else { PI / 2.0 };
    let phi = (s.sense * (s.theta - theta0)).rem_euclid(PI);
    let at = s.theta - s.sense * phi - theta0;
    let end = if at.cos() >= 0.0 { 1.0 } else { -1.0 };
    let (along, across) = if axis == 0 {
        (s.theta.cos(), s.theta.sin())
    } else {
        (s.theta.sin(), s.theta.cos())
    };
    AxisState {
        phi,
        end,
        dir: -end,
        travel_um: radius_mm * 1e3 * (1.0 - phi.cos()),
        along,
        across,
        cos: (s.theta - theta0).cos(),
    }
}

/// The fitted parameters' columns: each knows its signature.
#[derive(Clone, Copy, Debug)]
enum Param {
    CentreU,
    CentreV,
    Radius,
    Scale,
    Squareness,
    Servo,
    /// Axis (0 = u, 1 = v), end (+1, −1).
    Backlash(usize, i8),
    Lateral(usize),
    Spike(usize, i8),
    /// Axis, sine (true) or cosine.
    Cyclic(usize, bool),
}

struct Model<'a> {
    trace: &'a Trace,
    params: Vec<Param>,
    pitch: [Option<f64>; 2],
    spike_rad: f64,
}

impl Model<'_> {
    /// The band width (µm) at each axis' ends, `[axis][end +, end −]`.
    fn bands(&self, p: &[f64]) -> [[f64; 2]; 2] {
        let mut b = [[0.0; 2]; 2];
        for (k, par) in self.params.iter().enumerate() {
            if let Param::Backlash(a, e) = *par {
                b[a][usize::from(e < 0)] = p[k];
            }
        }
        b
    }

    /// The row of the design matrix and the constant part of one sample,
    /// the constant split by parameter (for what each cause explains).
    fn row(&self, s: &Sample, bands: &[[f64; 2]; 2], row: &mut [f64], constant: &mut [f64]) {
        let r = self.trace.radius_mm;
        let st = [axis_state(s, 0, r), axis_state(s, 1, r)];
        let band = |a: usize| bands[a][usize::from(st[a].end < 0.0)];
        let inside = |a: usize| band(a) > 0.0 && st[a].travel_um < band(a);
        let f = self.trace.feed_mm_per_min;
        for (k, par) in self.params.iter().enumerate() {
            constant[k] = 0.0;
            row[k] = match *par {
                Param::CentreU => s.theta.cos(),
                Param::CentreV => s.theta.sin(),
                Param::Radius => 1.0,
                Param::Scale => r / 1000.0 / 2.0 * (2.0 * s.theta).cos(),
                Param::Squareness => r / 1000.0 / 2.0 * (2.0 * s.theta).sin(),
                Param::Servo => -s.sense * f / 120.0 * (2.0 * s.theta).sin(),
                Param::Backlash(a, e) => {
                    let x = &st[a];
                    let this_end = (x.end > 0.0) == (e > 0);
                    if inside(a) {
                        if this_end {
                            constant[k] = -x.dir * x.travel_um * x.along;
                            x.dir / 2.0 * x.along
                        } else {
                            0.0
                        }
                    } else {
                        let w = if e > 0 {
                            (1.0 + x.cos) / 2.0
                        } else {
                            (1.0 - x.cos) / 2.0
                        };
                        -x.dir / 2.0 * w * x.along
                    }
                }
                Param::Lateral(a) => {
                    let x = &st[a];
                    let left = if inside(a) {
                        1.0 - x.travel_um / band(a)
                    } else {
                        0.0
                    };
                    x.dir * (left - 0.5) * x.across
                }
                Param::Spike(a, e) => {
                    let x = &st[a];
                    if (x.end > 0.0) == (e > 0) {
                        (-x.phi / self.spike_rad).exp()
                    } else {
                        0.0
                    }
                }
                Param::Cyclic(a, sine) => {
                    let (ui, vi) = self.trace.plane.axes();
                    let c = self.trace.centre_mm[if a == 0 { ui } else { vi }];
                    let pos = c + r * st[a].cos;
                    let w = 2.0 * PI * pos / self.pitch[a].unwrap_or(1.0);
                    (if sine { w.sin() } else { w.cos() }) * st[a].along
                }
            };
        }
    }
}

fn samples(trace: &Trace) -> Vec<Sample> {
    trace
        .runs
        .iter()
        .flat_map(|run: &Run| {
            let sense = run.sense.sign();
            run.angle_deg
                .iter()
                .zip(&run.deviation_um)
                .map(move |(a, y)| Sample {
                    theta: a.to_radians(),
                    sense,
                    y: *y,
                })
        })
        .collect()
}

fn describe(p: Param, trace: &Trace) -> (String, String, &'static str) {
    let (u, v) = trace.plane.axis_names();
    let name = |a: usize| if a == 0 { u } else { v };
    let end = |e: i8| if e > 0 { '+' } else { '-' };
    let pl = trace.plane.name();
    match p {
        Param::CentreU => (
            format!("centre_{u}"),
            format!("centre offset along {u}"),
            "µm",
        ),
        Param::CentreV => (
            format!("centre_{v}"),
            format!("centre offset along {v}"),
            "µm",
        ),
        Param::Radius => (
            "radius".into(),
            "radius (ballbar length and mean scale)".into(),
            "µm",
        ),
        Param::Scale => (
            format!("scale_mismatch_{pl}"),
            format!("scale mismatch {u} − {v}"),
            "µm/m",
        ),
        Param::Squareness => (
            format!("squareness_{pl}"),
            format!("squareness {pl}"),
            "µrad",
        ),
        Param::Servo => (
            format!("servo_mismatch_{pl}"),
            format!("servo mismatch ({v} lags {u})"),
            "ms",
        ),
        Param::Backlash(a, e) => (
            format!("backlash_{}{}", name(a), end(e)),
            format!("backlash {} at its {} reversal", name(a), end(e)),
            "µm",
        ),
        Param::Lateral(a) => (
            format!("lateral_play_{}", name(a)),
            format!("lateral play of {} (across it)", name(a)),
            "µm",
        ),
        Param::Spike(a, e) => (
            format!("reversal_spike_{}{}", name(a), end(e)),
            format!("reversal spike {} at its {} reversal", name(a), end(e)),
            "µm",
        ),
        Param::Cyclic(a, s) => (
            format!("cyclic_{}_{}", name(a), if s { "sin" } else { "cos" }),
            format!(
                "cyclic error of {} ({} term)",
                name(a),
                if s { "sine" } else { "cosine" }
            ),
            "µm",
        ),
    }
}

/// Fits the causes to `trace` (both senses: every cause; one sense: no
/// servo mismatch, which it cannot tell from squareness).
pub fn fit(trace: &Trace, options: &FitOptions) -> Result<TraceFit, BallbarError> {
    if !(options.spike_width_deg.is_finite() && options.spike_width_deg > 0.0) {
        return Err(BallbarError::new(format!(
            "{{spike_width_deg}} must be an angle > 0°; got {}",
            options.spike_width_deg
        )));
    }
    let (ui, vi) = trace.plane.axes();
    let pitch = [options.pitch_mm[ui], options.pitch_mm[vi]];
    for p in pitch.iter().flatten() {
        if !(p.is_finite() && *p > 0.0) {
            return Err(BallbarError::new(format!(
                "{{pitch_mm}} must be lengths > 0 mm (0: no cyclic error); got {p}"
            )));
        }
    }
    let mut params = vec![
        Param::CentreU,
        Param::CentreV,
        Param::Radius,
        Param::Scale,
        Param::Squareness,
    ];
    let both = trace.runs.len() == 2;
    if both {
        params.push(Param::Servo);
    }
    for a in 0..2 {
        params.extend([Param::Backlash(a, 1), Param::Backlash(a, -1)]);
    }
    params.extend([Param::Lateral(0), Param::Lateral(1)]);
    for a in 0..2 {
        params.extend([Param::Spike(a, 1), Param::Spike(a, -1)]);
    }
    for (a, p) in pitch.iter().enumerate() {
        if p.is_some() {
            params.extend([Param::Cyclic(a, true), Param::Cyclic(a, false)]);
        }
    }
    let model = Model {
        trace,
        params,
        pitch,
        spike_rad: options.spike_width_deg.to_radians(),
    };
    let data = samples(trace);
    let (n, np) = (data.len(), model.params.len());
    if n < 2 * np {
        return Err(BallbarError::new(format!(
            "the trace has {n} samples: the fit of {np} causes needs at least {}",
            2 * np
        )));
    }
    let figures = figures(trace).ok_or_else(|| {
        BallbarError::new(
            "the trace's least-squares circle is undetermined: its samples lie on a line",
        )
    })?;
    let mut p = vec![0.0; np];
    let mut j = Matrix::zeros(n, np);
    let mut constants = Matrix::zeros(n, np);
    let mut row = vec![0.0; np];
    let mut constant = vec![0.0; np];
    for _ in 0..30 {
        let bands = model.bands(&p);
        let mut rhs = Matrix::zeros(n, 1);
        for (i, s) in data.iter().enumerate() {
            model.row(s, &bands, &mut row, &mut constant);
            for k in 0..np {
                j[(i, k)] = row[k];
                constants[(i, k)] = constant[k];
            }
            rhs[(i, 0)] = s.y - constant.iter().sum::<f64>();
        }
        let x = least_squares(&j, &rhs).ok_or_else(|| {
            BallbarError::new(
                "the causes cannot be told apart on this trace (too few samples, or a partial arc)",
            )
        })?;
        let change = (0..np)
            .map(|k| (x[(k, 0)] - p[k]).abs())
            .fold(0.0, f64::max);
        p = (0..np).map(|k| x[(k, 0)]).collect();
        if change < 1e-6 {
            break;
        }
    }
    // Contributions and residual with the final bands.
    let bands = model.bands(&p);
    let mut contrib = vec![0.0; np];
    let mut residual: Vec<f64> = Vec::with_capacity(n);
    for (i, s) in data.iter().enumerate() {
        model.row(s, &bands, &mut row, &mut constant);
        let mut fitted = 0.0;
        for k in 0..np {
            j[(i, k)] = row[k];
            let c = row[k] * p[k] + constant[k];
            contrib[k] += c * c;
            fitted += c;
        }
        residual.push(s.y - fitted);
    }
    let rss: f64 = residual.iter().map(|r| r * r).sum();
    let sigma2 = rss / (n - np) as f64;
    let jtj = j.transpose() * &j;
    let inv = Cholesky::new(jtj)
        .ok_or_else(|| BallbarError::new("the causes cannot be told apart on this trace"))?
        .inverse();
    let total: f64 = contrib.iter().sum();
    let causes = model
        .params
        .iter()
        .enumerate()
        .map(|(k, par)| {
            let (id, label, unit) = describe(*par, trace);
            Cause {
                id,
                label,
                unit,
                value: p[k],
                std: (sigma2 * inv[(k, k)]).sqrt(),
                rms_um: (contrib[k] / n as f64).sqrt(),
                share_pct: if total > 0.0 {
                    100.0 * contrib[k] / total
                } else {
                    0.0
                },
            }
        })
        .collect();
    let mut left = trace.clone();
    let mut it = residual.iter();
    for run in &mut left.runs {
        for d in &mut run.deviation_um {
            *d = *it.next().expect("one residual per sample");
        }
    }
    Ok(TraceFit {
        figures,
        causes,
        residual_rms_um: (rss / n as f64).sqrt(),
        samples: n,
        residual: left,
    })
}
