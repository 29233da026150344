//! What a report keeps of a simulated program, in bounded memory whatever
//! its length: the path in plan view and the error along it, decimated so
//! that every peak survives (the colour of a merged piece and the band of a
//! merged bin are their largest, and smallest, values), and the
//! distribution of the contour error by path length on bins that double in
//! width as larger values arrive.
//!
//! Decimation keeps every bin (and plan piece) the same number of commands:
//! commands fill the last bin up to the current span; when the bins pass
//! their limit, neighbours merge in pairs and the span doubles, so early
//! and late parts of a long program are drawn at the same resolution.

use crate::simulate::SegmentError;

/// Pieces of the plan view kept at most (the path is merged in pairs
/// beyond this).
pub const PLAN_PIECES: usize = 4096;
/// Bins of the error along the path kept at most.
pub const PATH_BINS: usize = 2048;
/// Bins of the length histogram.
pub const HISTOGRAM_BINS: usize = 64;
/// Points kept per plan piece before every other interior point is dropped.
const PIECE_POINTS: usize = 9;
/// Largest angle between drawn points of an arc (rad): 10°.
const ARC_STEP_RAD: f64 = 10.0 * std::f64::consts::PI / 180.0;

/// A stretch of the path in plan view (X, Y in mm) and the largest
/// contour error along it (µm). A NaN point lifts the pen (a rapid or an
/// unmeasured move lies between).
#[derive(Debug, Clone, PartialEq)]
pub struct PlanRun {
    /// The points.
    pub points: Vec<[f64; 2]>,
    /// Largest contour error along it (µm).
    pub max_um: f64,
    /// Commands merged into it.
    pub commands: u64,
}

/// A bin of the error along the path: commanded path length from `s0_mm`
/// to `s1_mm`, and the extremes of the largest contour error per command
/// and of the point error within it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathBin {
    /// Start (mm of commanded feed path).
    pub s0_mm: f64,
    /// End (mm).
    pub s1_mm: f64,
    /// Smallest per-command largest contour error (µm).
    pub contour_min_um: f64,
    /// Largest contour error (µm).
    pub contour_max_um: f64,
    /// Largest point error in the bin (µm), if a point ends there.
    pub point_max_um: Option<f64>,
    /// Commands merged into it.
    pub commands: u64,
}

impl PathBin {
    /// The middle of the bin (mm of commanded feed path), where a chart
    /// draws it.
    pub fn mid_mm(&self) -> f64 {
        (self.s0_mm + self.s1_mm) / 2.0
    }
}

/// Path length by contour error on bins `[k w, (k + 1) w)` whose width `w`
/// doubles (neighbours merged) when a larger value arrives, so that
/// [`HISTOGRAM_BINS`] bins always cover every value.
#[derive(Debug, Clone, PartialEq)]
pub struct LengthHistogram {
    /// Bin width (µm): `BASE_WIDTH_UM · 2ᵏ`.
    pub width_um: f64,
    /// Path length per bin (mm).
    pub length_mm: Vec<f64>,
}

/// The narrowest bin (µm).
pub const BASE_WIDTH_UM: f64 = 1.0 / 1024.0;

impl Default for LengthHistogram {
    fn default() -> Self {
        Self {
            width_um: BASE_WIDTH_UM,
            length_mm: vec![0.0; HISTOGRAM_BINS],
        }
    }
}

impl LengthHistogram {
    /// Adds `length_mm` of path at error `value_um` (finite, ≥ 0; others
    /// are not counted).
    pub fn add(&mut self, value_um: f64, length_mm: f64) {
        if !(value_um.is_finite() && value_um >= 0.0 && length_mm.is_finite()) {
            return;
        }
        while value_um >= self.width_um * HISTOGRAM_BINS as f64 {
            self.coarsen();
        }
        let k = ((value_um / self.width_um) as usize).min(HISTOGRAM_BINS - 1);
        self.length_mm[k] += length_mm;
    }

    /// Doubles the bin width, merging neighbours.
    pub fn coarsen(&mut self) {
        let n = self.length_mm.len();
        let mut merged = vec![0.0; n];
        for (i, v) in self.length_mm.iter().enumerate() {
            merged[i / 2] += v;
        }
        self.length_mm = merged;
        self.width_um *= 2.0;
    }

    /// Coarsened to `width_um` (a power-of-two multiple of this width).
    pub fn at_width(&self, width_um: f64) -> Self {
        let mut h = self.clone();
        while h.width_um < width_um * (1.0 - 1e-12) {
            h.coarsen();
        }
        h
    }

    /// Total path length (mm).
    pub fn total_mm(&self) -> f64 {
        self.length_mm.iter().sum()
    }
}

/// What a report keeps of one simulated program.
#[derive(Debug, Clone, PartialEq)]
pub struct PathTrace {
    /// The plan view, in order.
    pub plan: Vec<PlanRun>,
    /// The error along the path, in order.
    pub bins: Vec<PathBin>,
    /// Contour error by path length.
    pub histogram: LengthHistogram,
    /// Commanded feed path length so far (mm).
    pub travelled_mm: f64,
    /// Commands per plan piece (a power of two).
    pub plan_span: u64,
    /// Commands per bin (a power of two).
    pub bin_span: u64,
}

fn merge_runs(a: PlanRun, b: PlanRun) -> PlanRun {
    let mut points = a.points;
    let continuous = matches!((points.last(), b.points.first()), (Some(p), Some(q)) if p == q);
    if continuous {
        points.extend_from_slice(&b.points[1..]);
    } else {
        points.push([f64::NAN, f64::NAN]);
        points.extend_from_slice(&b.points);
    }
    // Thin long polylines: keep the ends and pen lifts, every other point.
    if points.len() > PIECE_POINTS {
        let last = points.len() - 1;
        points = points
            .iter()
            .enumerate()
            .filter(|(i, p)| *i == 0 || *i == last || i % 2 == 0 || !p[0].is_finite())
            .map(|(_, p)| *p)
            .collect();
    }
    PlanRun {
        points,
        max_um: a.max_um.max(b.max_um),
        commands: a.commands + b.commands,
    }
}

fn merge_bins(a: PathBin, b: PathBin) -> PathBin {
    PathBin {
        s0_mm: a.s0_mm,
        s1_mm: b.s1_mm,
        contour_min_um: a.contour_min_um.min(b.contour_min_um),
        contour_max_um: a.contour_max_um.max(b.contour_max_um),
        point_max_um: match (a.point_max_um, b.point_max_um) {
            (Some(x), Some(y)) => Some(x.max(y)),
            (x, y) => x.or(y),
        },
        commands: a.commands + b.commands,
    }
}

/// Appends `item` (one command) to `items`, kept at most `limit` long
/// (module documentation): merged into the last entry while that holds
/// fewer than `span` commands; past the limit, neighbours merge in pairs
/// and the span doubles.
fn push_decimated<T>(
    items: &mut Vec<T>,
    span: &mut u64,
    limit: usize,
    item: T,
    commands: impl Fn(&T) -> u64,
    merge: impl Fn(T, T) -> T + Copy,
) {
    match items.pop() {
        Some(last) if commands(&last) < *span => items.push(merge(last, item)),
        Some(last) => {
            items.push(last);
            items.push(item);
        }
        None => items.push(item),
    }
    if items.len() > limit {
        halve(items, merge);
        *span *= 2;
    }
}

/// Merges neighbours in pairs (the last one alone if odd).
fn halve<T>(items: &mut Vec<T>, merge: impl Fn(T, T) -> T) {
    let old = std::mem::take(items);
    let mut it = old.into_iter();
    while let Some(a) = it.next() {
        match it.next() {
            Some(b) => items.push(merge(a, b)),
            None => items.push(a),
        }
    }
}

impl Default for PathTrace {
    fn default() -> Self {
        Self {
            plan: Vec::new(),
            bins: Vec::new(),
            histogram: LengthHistogram::default(),
            travelled_mm: 0.0,
            plan_span: 1,
            bin_span: 1,
        }
    }
}

impl PathTrace {
    /// Adds one measured feed command (in program order).
    pub fn push(&mut self, s: &SegmentError) {
        let s0 = self.travelled_mm;
        let length = if s.length_mm.is_finite() {
            s.length_mm
        } else {
            0.0
        };
        self.travelled_mm += length;
        // A piece that does not start where the last one ended (a rapid lies
        // between) is joined to it by a pen lift when the two are merged.
        let mut points = vec![[s.start_mm.x, s.start_mm.y]];
        if let Some(arc) = s.arc {
            let steps = ((arc.sweep_rad.abs() / ARC_STEP_RAD).ceil() as usize).clamp(1, 72);
            for k in 1..steps {
                let p = arc.point_at(k as f64 / steps as f64);
                points.push([p.x, p.y]);
            }
        }
        points.push([s.command_mm.x, s.command_mm.y]);
        let run = PlanRun {
            points,
            max_um: s.contour_max_um,
            commands: 1,
        };
        push_decimated(
            &mut self.plan,
            &mut self.plan_span,
            PLAN_PIECES,
            run,
            |r| r.commands,
            merge_runs,
        );
        let bin = PathBin {
            s0_mm: s0,
            s1_mm: self.travelled_mm,
            contour_min_um: s.contour_max_um,
            contour_max_um: s.contour_max_um,
            point_max_um: s.point_um,
            commands: 1,
        };
        push_decimated(
            &mut self.bins,
            &mut self.bin_span,
            PATH_BINS,
            bin,
            |b| b.commands,
            merge_bins,
        );
        self.histogram.add(s.contour_max_um, length);
    }

    /// The largest contour error kept (µm).
    pub fn max_um(&self) -> f64 {
        self.bins
            .iter()
            .map(|b| b.contour_max_um)
            .fold(0.0, f64::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use volcomp_gcode::Vec3;

    fn seg(x0: f64, x1: f64, err: f64, point: Option<f64>) -> SegmentError {
        SegmentError {
            line: 1,
            nominal_line: 1,
            start_mm: Vec3::new(x0, 0.0, 0.0),
            command_mm: Vec3::new(x1, 0.0, 0.0),
            actual_mm: Vec3::new(x1, 0.0, 0.0),
            arc: None,
            length_mm: (x1 - x0).abs(),
            target_mm: None,
            point_um: point,
            contour_max_um: err,
        }
    }

    #[test]
    fn a_long_path_stays_bounded_and_keeps_its_single_peak() {
        // 100 000 unit moves along X, error 1 µm except one 50 µm spike.
        let mut t = PathTrace::default();
        for i in 0..100_000 {
            let e = if i == 77_777 { 50.0 } else { 1.0 };
            t.push(&seg(i as f64, i as f64 + 1.0, e, None));
        }
        assert!(t.bins.len() <= PATH_BINS && t.plan.len() <= PLAN_PIECES);
        assert!(t.plan.iter().all(|r| r.points.len() <= PIECE_POINTS + 2));
        assert_eq!(t.max_um(), 50.0);
        assert_eq!(t.plan.iter().map(|r| r.max_um).fold(0.0, f64::max), 50.0);
        // The spike's bin contains path length 77 777…77 778 mm.
        let b = t.bins.iter().find(|b| b.contour_max_um == 50.0).unwrap();
        assert!(b.s0_mm <= 77_777.0 && b.s1_mm >= 77_778.0);
        assert!((t.travelled_mm - 100_000.0).abs() < 1e-6);
        // The histogram holds the whole length: 99 999 mm at 1 µm, 1 mm at 50.
        assert!((t.histogram.total_mm() - 100_000.0).abs() < 1e-6);
        let w = t.histogram.width_um;
        assert!((t.histogram.length_mm[(1.0 / w) as usize] - 99_999.0).abs() < 1e-6);
        assert!((t.histogram.length_mm[(50.0 / w) as usize] - 1.0).abs() < 1e-9);
    }

    #[test]
    fn early_and_late_parts_keep_the_same_resolution() {
        let mut t = PathTrace::default();
        for i in 0..100_000 {
            t.push(&seg(i as f64, i as f64 + 1.0, 1.0, None));
        }
        // 100 000 commands in at most 2048 bins: 64 per bin (2¹⁶ / 2048 · 2
        // would be too few, 128 too many), every bin but the last full.
        assert_eq!(t.bin_span, 64);
        let full = &t.bins[..t.bins.len() - 1];
        assert!(full.iter().all(|b| b.commands == 64));
        assert!(full.iter().all(|b| (b.s1_mm - b.s0_mm - 64.0).abs() < 1e-9));
        assert_eq!(t.bins.iter().map(|b| b.commands).sum::<u64>(), 100_000);
        let pieces = &t.plan[..t.plan.len() - 1];
        assert!(pieces.iter().all(|r| r.commands == t.plan_span));
    }

    #[test]
    fn histogram_bins_double_until_the_largest_value_fits() {
        let mut h = LengthHistogram::default();
        h.add(0.01, 2.0);
        // 0.01 µm in bins of 1/1024 µm: bin 10.
        assert_eq!(h.length_mm[10], 2.0);
        h.add(3.0, 1.0);
        // 3 µm < 64 w needs w ≥ 3/64 = 0.047: 1/1024 · 2⁶ = 0.0625.
        assert_eq!(h.width_um, 0.0625);
        assert_eq!(h.length_mm[0], 2.0);
        assert_eq!(h.length_mm[48], 1.0);
        let c = h.at_width(0.25);
        assert_eq!(c.length_mm[0], 2.0);
        assert_eq!(c.length_mm[12], 1.0);
    }

    #[test]
    fn a_gap_lifts_the_pen() {
        let mut t = PathTrace::default();
        t.push(&seg(0.0, 1.0, 1.0, Some(0.5)));
        t.push(&seg(5.0, 6.0, 2.0, None));
        let merged = merge_runs(t.plan[0].clone(), t.plan[1].clone());
        assert_eq!(merged.points.iter().filter(|p| p[0].is_nan()).count(), 1);
        assert_eq!(merged.max_um, 2.0);
    }
}
