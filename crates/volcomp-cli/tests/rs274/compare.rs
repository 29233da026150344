//! Motion-by-motion comparison of rs274's and volcomp's motions, with
//! resynchronisation after a difference.

use super::*;

pub fn fmt3(v: [f64; 3]) -> String {
    format!("({:.6}, {:.6}, {:.6})", v[0], v[1], v[2])
}

pub fn describe_ref(m: &RefMotion) -> String {
    let mut s = format!("{} to {}", m.kind.name(), fmt3(m.end));
    if let Some(c) = m.center {
        let axis = ["x", "y", "z"];
        write!(
            s,
            " centre {}={:.6} {}={:.6}",
            axis[c[0].0], c[0].1, axis[c[1].0], c[1].1
        )
        .unwrap();
    }
    write!(s, " [rs274: {}]", m.call).unwrap();
    s
}

pub fn describe_vol(m: &VolMotion) -> String {
    let mut s = format!("{} to {}", m.kind.name(), fmt3(m.end));
    if let Some(c) = m.center {
        write!(s, " centre {}", fmt3(c)).unwrap();
    }
    write!(s, " (line {})", m.line).unwrap();
    s
}

/// Why a pair differs, or `None`.
pub fn differ(r: &RefMotion, v: &VolMotion) -> Option<String> {
    if r.kind != v.kind {
        return Some(format!(
            "kind differs: rs274 {}, volcomp {}",
            r.kind.name(),
            v.kind.name()
        ));
    }
    if matches!(r.kind, Kind::Other(_)) {
        // A motion rs274 prints without coordinates (NURBS_FEED).
        return None;
    }
    let axis = ["X", "Y", "Z"];
    let mut why = Vec::new();
    for (a, name) in ["A", "B", "C"].iter().enumerate() {
        let d = (r.abc[a] - v.abc[a]).abs();
        if d.is_nan() || d > r.abc_tol[a] + SLACK_MM {
            why.push(format!("end {name} off by {d:.6} degrees"));
        }
    }
    for (a, name) in axis.iter().enumerate() {
        let d = (r.end[a] - v.end[a]).abs();
        if d.is_nan() || d > r.tol[a] {
            why.push(format!(
                "end {name} off by {d:.6} mm (tolerance {:.6})",
                r.tol[a]
            ));
        }
    }
    match (r.center, v.center) {
        (Some(rc), Some(vc)) => {
            for (a, value) in rc {
                let d = (value - vc[a]).abs();
                if d.is_nan() || d > r.tol[a] {
                    why.push(format!(
                        "centre {} off by {:.6} mm (tolerance {:.6})",
                        axis[a], d, r.tol[a]
                    ));
                }
            }
        }
        (Some(_), None) => why.push("volcomp gives no arc centre".into()),
        _ => {}
    }
    if why.is_empty() {
        None
    } else {
        Some(why.join("; "))
    }
}

/// Whether the two sequences agree for the next few motions from `i`, `j`
/// (or both end there).
pub fn aligned(reference: &[RefMotion], i: usize, volcomp: &[VolMotion], j: usize) -> bool {
    if i >= reference.len() || j >= volcomp.len() {
        return i >= reference.len() && j >= volcomp.len();
    }
    reference[i..]
        .iter()
        .zip(&volcomp[j..])
        .take(RESYNC_WINDOW)
        .all(|(r, v)| differ(r, v).is_none())
}

/// Largest coordinate difference of a pair that agrees, mm.
pub fn deviation(r: &RefMotion, v: &VolMotion) -> f64 {
    let mut d = (0..3)
        .map(|a| (r.end[a] - v.end[a]).abs())
        .fold(0.0, f64::max);
    if let (Some(rc), Some(vc)) = (r.center, v.center) {
        for (a, value) in rc {
            d = d.max((value - vc[a]).abs());
        }
    }
    d
}

/// `motions`, numbered from `first` in `side`'s sequence, one per line.
fn listed<M>(side: &str, motions: &[M], first: usize, describe: fn(&M) -> String) -> String {
    let lines = motions.iter().enumerate();
    lines
        .map(|(n, m)| format!("\n    {side} #{}: {}", first + n, describe(m)))
        .collect()
}

/// The result of comparing one program.
pub struct Comparison {
    /// Pairs of motions compared.
    pub pairs: usize,
    /// Largest difference among the pairs that agree, mm.
    pub max_dev_mm: f64,
    pub failures: Vec<String>,
}

/// Motions compared and failure messages.
///
/// The sequences are compared in order. Where they stop agreeing, a few
/// motions of look-ahead tell an extra motion on one side (reported as such,
/// then skipped) from a motion that differs.
pub fn compare(label: &str, reference: &[RefMotion], volcomp: &[VolMotion]) -> Comparison {
    let mut failures = Vec::new();
    let (mut i, mut j, mut pairs, mut problems) = (0, 0, 0, 0);
    let mut max_dev_mm = 0.0_f64;
    let mut report = |msg: String| {
        problems += 1;
        if problems <= MAX_REPORTS_PER_FILE {
            failures.push(msg);
        }
    };
    // Where, in volcomp's sequence, a motion volcomp lacks would go.
    let between = |j: usize| match (
        j.checked_sub(1).and_then(|p| volcomp.get(p)),
        volcomp.get(j),
    ) {
        (Some(a), Some(b)) => format!(
            "between volcomp motion #{} (line {}) and #{j} (line {})",
            j - 1,
            a.line,
            b.line
        ),
        (None, Some(b)) => format!("before volcomp's first motion (line {})", b.line),
        (Some(a), None) => format!("after volcomp's last motion (line {})", a.line),
        (None, None) => "volcomp has no motion at all".to_string(),
    };
    while i < reference.len() && j < volcomp.len() {
        let Some(why) = differ(&reference[i], &volcomp[j]) else {
            max_dev_mm = max_dev_mm.max(deviation(&reference[i], &volcomp[j]));
            i += 1;
            j += 1;
            pairs += 1;
            continue;
        };
        if let Some(k) = (1..=MAX_EXTRA).find(|&k| aligned(reference, i + k, volcomp, j)) {
            let extra = listed("rs274", &reference[i..i + k], i, describe_ref);
            report(
                format!(
                    "{label}: rs274 emits {k} motion(s) that volcomp does not, {}:{extra}\n    volcomp #{j}: {}",
                    between(j),
                    describe_vol(&volcomp[j])
                ),
            );
            i += k;
        } else if let Some(k) = (1..=MAX_EXTRA).find(|&k| aligned(reference, i, volcomp, j + k)) {
            let extra = listed("volcomp", &volcomp[j..j + k], j, describe_vol);
            report(
                format!(
                    "{label}: volcomp emits {k} motion(s) that rs274 does not, before rs274 motion #{i}:{extra}\n    rs274 #{i}: {}",
                    describe_ref(&reference[i])
                ),
            );
            j += k;
        } else {
            report(
                format!(
                    "{label}: motion #{i} (volcomp #{j}, volcomp line {}): {why}\n    rs274:   {}\n    volcomp: {}",
                    volcomp[j].line,
                    describe_ref(&reference[i]),
                    describe_vol(&volcomp[j])
                ),
            );
            i += 1;
            j += 1;
            pairs += 1;
        }
    }
    if i < reference.len() {
        report(format!(
            "{label}: rs274 has {} more motion(s) at the end, {}; the first is rs274 #{i}: {}",
            reference.len() - i,
            between(j),
            describe_ref(&reference[i])
        ));
    }
    if j < volcomp.len() {
        report(format!(
            "{label}: volcomp has {} more motion(s) at the end; the first is volcomp #{j}: {}",
            volcomp.len() - j,
            describe_vol(&volcomp[j])
        ));
    }
    if problems > MAX_REPORTS_PER_FILE {
        failures.push(format!(
            "{label}: … and {} more disagreements (rs274 {} motions, volcomp {})",
            problems - MAX_REPORTS_PER_FILE,
            reference.len(),
            volcomp.len()
        ));
    }
    Comparison {
        pairs,
        max_dev_mm,
        failures,
    }
}
