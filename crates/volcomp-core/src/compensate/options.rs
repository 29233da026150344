//! Options and results of a program compensation.

use crate::compensate::joins::PlannerLimits;
use crate::compensate::solve::Method;
use volcomp_gcode::{PathMode, Vec3};

/// How feed moves are split into target points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Segmentation {
    /// One target per move (arcs are still linearised).
    Off,
    /// This many segments per block (as the papers do).
    Count(u32),
    /// Segments no longer than this (mm).
    MaxLength(f64),
    /// As many segments as the map needs: a segment is halved while the
    /// error's departure from a straight line between its ends (which is what
    /// compensating only the ends leaves on the path) exceeds the tolerance
    /// at its quarter points, down to `min_length_mm`.
    Adaptive {
        /// Contour tolerance (mm).
        tolerance_mm: f64,
        /// Shortest segment (mm).
        min_length_mm: f64,
    },
}

/// Which direction state chooses the error tables.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DirectionPolicy {
    /// The direction of the command actually sent (docs/design.md, "Direction state and backlash"; default).
    Commanded,
    /// The direction of the nominal move, as the papers do (for comparison).
    Nominal,
}

/// Options of [`compensate_program`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompensateOptions {
    /// Point solver.
    pub method: Method,
    /// Splitting of feed moves.
    pub segmentation: Segmentation,
    /// Chord tolerance for arcs (mm), when they are linearised.
    pub chord_tolerance_mm: f64,
    /// Write compensated arcs as arcs (pieces of the original arc, each
    /// compensated at its ends and middle; docs/compensation.md, "Arcs as
    /// arcs"); `false` linearises them within the chord tolerance.
    pub arcs_as_arcs: bool,
    /// Written decimals; `None`: [`DEFAULT_DECIMALS_MM`] in mm,
    /// [`DEFAULT_DECIMALS_INCH`] in inch, or more where the program writes
    /// more. A rewritten word never has fewer decimals than
    /// the word it replaces.
    pub decimals: Option<u8>,
    /// Largest accepted correction (mm).
    pub max_correction_mm: f64,
    /// Table choice.
    pub directions: DirectionPolicy,
    /// Insert take-up moves at reversals on feed moves.
    pub take_up: bool,
    /// Fold a take-up into the move that reverses (write no separate block)
    /// where the dead band leaves the tool within the contour tolerance of
    /// the path while the axis takes up its reversal value: where the
    /// reversing axis hardly moves on that move (docs/compensation.md,
    /// "Take-ups folded into the move"). A separate take-up block forces the
    /// controller's planner to stop; a folded one does not.
    pub fold_take_ups: bool,
    /// The contour error a folded take-up may leave (mm), for the whole
    /// program; `None`: the program's path-control mode decides every
    /// reversal ([`TakeUpRule`]). A larger one trades accuracy at reversals
    /// for fewer stops: at a corner where the reversing axis moves on both
    /// sides, the tool leaves the path by up to the reversal value.
    pub take_up_tolerance_mm: Option<f64>,
    /// Adaptive segmentation's contour tolerance under G61 and G61.1 (mm),
    /// where it is tighter than [`Segmentation::Adaptive`]'s; `None`: the
    /// same everywhere. The default, [`DEFAULT_EXACT_CONTOUR_TOLERANCE_UM`],
    /// is dropped when a contour tolerance is given.
    pub exact_contour_tolerance_mm: Option<f64>,
    /// The error a drilling cycle (G73, G81, G82, G83) kept as a cycle may
    /// leave along its stroke (mm): the map's drift across the stroke and
    /// the peck levels inside the hole; the hole's position at the bottom
    /// and its depth are compensated exactly either way. Never below the
    /// contour tolerance; the boring cycles keep the contour tolerance.
    pub drill_tolerance_mm: f64,
    /// The machine's limits that decide how its planner joins the pieces
    /// written ([`PlannerLimits`]).
    pub planner: PlannerLimits,
    /// Tag inserted lines with `(volcomp Ln)`.
    pub trace_comments: bool,
    /// Largest model residual `‖t − (q + e(q))‖` accepted at a point (µm),
    /// for the solvers that aim at the target (exact, ILC; direct and pitch
    /// are checked for finiteness only); `None` checks only finiteness. A point past it is an error at its
    /// line: a program whose points do not reach their targets is never
    /// written as a success. Points with a held axis are exempt (their
    /// residual is the reversal value the take-up cannot cover,
    /// docs/compensation.md).
    pub max_residual_um: Option<f64>,
    /// Write a feed move made while an axis has never been set (by the
    /// program, or by the set-up's `start`) as it is, counted in
    /// [`CompensateSummary::uncompensated_moves`], instead of refusing the
    /// program at it.
    pub allow_uncompensated_axes: bool,
}

impl Default for CompensateOptions {
    fn default() -> Self {
        Self {
            method: Method::Exact,
            segmentation: Segmentation::Adaptive {
                tolerance_mm: DEFAULT_CONTOUR_TOLERANCE_UM * 1e-3,
                min_length_mm: DEFAULT_MIN_SEGMENT_LENGTH_MM,
            },
            chord_tolerance_mm: 1e-4,
            arcs_as_arcs: true,
            decimals: None,
            max_correction_mm: 0.1,
            directions: DirectionPolicy::Commanded,
            take_up: true,
            fold_take_ups: true,
            take_up_tolerance_mm: None,
            exact_contour_tolerance_mm: Some(DEFAULT_EXACT_CONTOUR_TOLERANCE_UM * 1e-3),
            drill_tolerance_mm: DEFAULT_DRILL_TOLERANCE_UM * 1e-3,
            planner: PlannerLimits::default(),
            trace_comments: true,
            max_residual_um: Some(DEFAULT_MAX_RESIDUAL_UM),
            allow_uncompensated_axes: false,
        }
    }
}

/// How the take-up at a reversal is written, from the program's
/// path-control mode (docs/compensation.md, "Reversals by path-control
/// mode"), unless [`CompensateOptions::take_up_tolerance_mm`] sets one
/// tolerance for the whole program.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TakeUpRule {
    /// G61 and G61.1: exactly, the tool within the contour tolerance: a
    /// take-up folded where that holds, else a block where the machine
    /// stops anyway (a corner, every block end under G61.1); under G61
    /// (`smooth`) where the path runs on through the reversal, a take-up
    /// piece the planner joins without a stop, else a block.
    Exact {
        /// Take up on pieces the planner joins as tangent where the path is
        /// smooth (G61); `false`: blocks (G61.1 stops at every block end).
        smooth: bool,
    },
    /// G64 P p (or the take-up tolerance): folded where the tool stays
    /// within this distance (mm) of the path, else on a lead piece within
    /// it, else a block (the machine stops, the tool stays on the path).
    Within(f64),
    /// G64 without P: every take-up folded, never a block; the tool may
    /// leave the path at the reversal by up to the reversal value. A lead
    /// piece keeps the excursion within the contour tolerance where one
    /// fits.
    Always,
}

impl CompensateOptions {
    /// The rule for a take-up on a motion run in `mode`.
    pub fn take_up_rule(&self, mode: PathMode) -> TakeUpRule {
        if let Some(t) = self.take_up_tolerance_mm {
            return TakeUpRule::Within(t);
        }
        match mode {
            PathMode::ExactPath => TakeUpRule::Exact { smooth: true },
            PathMode::ExactStop => TakeUpRule::Exact { smooth: false },
            PathMode::Blend { tolerance_mm, .. } if tolerance_mm > 0.0 => {
                TakeUpRule::Within(tolerance_mm)
            }
            PathMode::Blend { .. } => TakeUpRule::Always,
        }
    }

    /// The contour error (mm) a folded take-up may leave: the take-up
    /// tolerance if given, else the adaptive segmentation's tolerance, or
    /// its default under a fixed segmentation.
    pub fn fold_tolerance_mm(&self) -> f64 {
        if let Some(t) = self.take_up_tolerance_mm {
            return t;
        }
        match self.segmentation {
            Segmentation::Adaptive { tolerance_mm, .. } => tolerance_mm,
            _ => DEFAULT_CONTOUR_TOLERANCE_UM * 1e-3,
        }
    }

    /// The error (mm) an axis held instead of a reversal smaller than its
    /// band may leave at a point under `rule` (docs/compensation.md, "Small
    /// reversals held"), or `None` where no axis is held so. The held
    /// axis' own error stays below its band in every case (beyond it the
    /// carriage would move: the reversal is real):
    ///
    /// * G64 P p (or the take-up tolerance p): p less the contour
    ///   tolerance the pieces between the points may add, so every
    ///   excursion stays within p (the program bounds the path by p, and
    ///   nothing more).
    /// * G64 without P: none here: an axis is held there (within its band
    ///   alone) only where the take-up it replaces would turn the path by
    ///   more than the planner takes as tangent, which the solving of the
    ///   targets decides (compensate/points.rs); a hold at every small
    ///   reversal cost the chord circles up to 6 points of their RMS
    ///   reduction for no time (docs/compensation.md, "Small reversals
    ///   held").
    /// * G61/G61.1: none (exactness first: every reversal taken up).
    ///
    /// `None` too where take-ups are off or the tables follow the nominal
    /// direction (no reversal of the command is looked at).
    pub fn hold_tolerance_mm(&self, rule: TakeUpRule) -> Option<f64> {
        if !self.take_up || self.directions != DirectionPolicy::Commanded {
            return None;
        }
        let contour = match self.segmentation {
            Segmentation::Adaptive { tolerance_mm, .. } => tolerance_mm,
            _ => DEFAULT_CONTOUR_TOLERANCE_UM * 1e-3,
        };
        let bound = match rule {
            TakeUpRule::Exact { .. } | TakeUpRule::Always => return None,
            TakeUpRule::Within(p) => p - contour,
        };
        (bound > 0.0).then_some(bound)
    }

    /// Contour tolerance and shortest piece (mm) of arcs written as arcs
    /// in path-control mode `mode`: those of adaptive segmentation, or its
    /// defaults under another segmentation; under G61/G61.1 the tighter
    /// [`Self::exact_contour_tolerance_mm`] where it is set.
    pub(crate) fn arc_tolerances_mm(&self, mode: PathMode) -> (f64, f64) {
        let (tolerance_mm, min_length_mm) = match self.segmentation {
            Segmentation::Adaptive {
                tolerance_mm,
                min_length_mm,
            } => (tolerance_mm, min_length_mm),
            _ => (
                DEFAULT_CONTOUR_TOLERANCE_UM * 1e-3,
                DEFAULT_MIN_SEGMENT_LENGTH_MM,
            ),
        };
        (self.contour_tolerance_in(tolerance_mm, mode), min_length_mm)
    }

    /// The segmentation of a feed move in path-control mode `mode`:
    /// adaptive segmentation's tolerance tightened under G61/G61.1
    /// ([`Self::exact_contour_tolerance_mm`]); the others as they are.
    pub(crate) fn segmentation_in(&self, mode: PathMode) -> Segmentation {
        match self.segmentation {
            Segmentation::Adaptive {
                tolerance_mm,
                min_length_mm,
            } => Segmentation::Adaptive {
                tolerance_mm: self.contour_tolerance_in(tolerance_mm, mode),
                min_length_mm,
            },
            other => other,
        }
    }

    /// `tolerance_mm`, or the exact-path one under G61/G61.1 where that is
    /// tighter.
    fn contour_tolerance_in(&self, tolerance_mm: f64, mode: PathMode) -> f64 {
        match (mode, self.exact_contour_tolerance_mm) {
            (PathMode::ExactPath | PathMode::ExactStop, Some(t)) => t.min(tolerance_mm),
            _ => tolerance_mm,
        }
    }
}

/// Default contour tolerance of adaptive segmentation (µm): 0.1 µm, the
/// largest error a piece may leave between its compensated points — a
/// few per cent of a micrometre map's error in the worst piece, far less on
/// average. The pieces needed grow as `1/√tol` (the remainder is second
/// order in a piece's length), so a tenth of it costs three times the
/// blocks. The written step ([`DEFAULT_DECIMALS_MM`]) is ten times finer,
/// so the rounding does not add to it (docs/compensation.md, "Adaptive
/// segmentation").
pub const DEFAULT_CONTOUR_TOLERANCE_UM: f64 = 0.1;

/// Default contour tolerance of adaptive segmentation under G61 and G61.1
/// (µm; [`CompensateOptions::exact_contour_tolerance_mm`]): 0.05 µm, half
/// of [`DEFAULT_CONTOUR_TOLERANCE_UM`]. The program asked for the exact
/// path, and the goal there is a dense contour RMS of at most 1 % of the
/// map's: a piece's chord leaves up to the tolerance between its
/// compensated ends, about 0.4 of it in RMS, which on a 3 µm ripple is
/// 1.2 % at 0.1 µm. Under G61 the pieces of a block join tangent or run
/// under the blend the block's own mode allows, so more of them cost no
/// cutting time on LinuxCNC's planner (docs/compensation.md, "Adaptive
/// segmentation").
pub const DEFAULT_EXACT_CONTOUR_TOLERANCE_UM: f64 = 0.05;

/// Default drill tolerance (µm; [`CompensateOptions::drill_tolerance_mm`]):
/// 5 µm. A twist drill's hole is straight and placed to tens of µm (its own
/// run-out and wander), so a few µm of the map's drift along the stroke do
/// not show in the hole, while writing the hole as its moves makes a peck
/// cycle ten times longer and stops the machine at every peck; the bottom
/// stays compensated exactly.
pub const DEFAULT_DRILL_TOLERANCE_UM: f64 = 5.0;

/// Decimals written in mm by default: 5, a step of 0.01 µm. The written
/// step must sit well below the contour tolerance (0.1 µm), or the
/// rounding of every written point, not the map, is what is left on the
/// path: with 4 decimals (0.1 µm step, up to 0.087 µm in space) the dense
/// contour RMS after compensation stayed at about 0.03 µm, 1 % of a 3 µm
/// map (tiger.nc on the ripple map of BENCHMARKS.md: 0.034 µm with 4,
/// 0.004 µm with 5). LinuxCNC reads any number of decimals and
/// interpolates in double precision; a controller with a coarser input
/// increment, or a limit on digits (Fanuc: 8), takes `--decimals`.
pub const DEFAULT_DECIMALS_MM: u8 = 5;

/// Decimals written in inch by default: 6, a step of 0.0254 µm, as fine as
/// the mm default's (see [`DEFAULT_DECIMALS_MM`]); 5 would be a step of
/// 0.254 µm, its rounding up to 0.22 µm in space.
pub const DEFAULT_DECIMALS_INCH: u8 = 6;

/// Default shortest segment of adaptive segmentation (mm): 10 µm, a hundred
/// times the written step, so a segment never degenerates into a
/// micrometre block.
pub const DEFAULT_MIN_SEGMENT_LENGTH_MM: f64 = 0.01;

/// Default of [`CompensateOptions::max_residual_um`]: 1 µm, ten times the
/// solver's own tolerance plus the rounding of a written coordinate on
/// three axes (half a step: 0.005 µm at the default decimals, still only
/// 0.05 µm with 4 decimals in mm, 0.127 µm with 5 in inch), so a converged
/// point always passes and an unconverged one (ILC stopped early, a map the
/// solver cannot invert) never does.
pub const DEFAULT_MAX_RESIDUAL_UM: f64 = 1.0;

/// One compensated target point, for the per-point report.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct PointRecord {
    /// Source line.
    pub line: u64,
    /// Nominal target (axis frame, mm).
    pub target_mm: Vec3,
    /// Command written (axis frame, mm).
    pub command_mm: Vec3,
    /// Solver iterations.
    pub iterations: u32,
    /// Model residual at the command (µm).
    pub residual_um: f64,
    /// Axes reversed on this move.
    pub reversed: [bool; 3],
    /// Axes held (no consistent reversal).
    pub held: [bool; 3],
    /// A take-up move was written before this point.
    pub take_up: bool,
    /// The point ends a rapid (measured by no metric: rapids do not cut).
    pub rapid: bool,
}

/// What a compensation run did.
#[derive(Debug, Clone, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct CompensateSummary {
    /// Where the provenance header went into the written program (none
    /// where [`compensate_program`](crate::compensate::compensate_program)
    /// wrote it without one): lines of the program as made (the copy a
    /// machining-time estimate reads while it is written) map to the
    /// written file's by
    /// [`HeaderPlace::written_line`](crate::io::provenance::HeaderPlace::written_line).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub header: crate::io::provenance::HeaderPlace,
    /// Lines read.
    pub lines_in: u64,
    /// Lines written.
    pub lines_out: u64,
    /// Bytes read.
    pub bytes_in: u64,
    /// Bytes written (with the provenance header when
    /// [`crate::compensate::Compensator`] writes one).
    pub bytes_out: u64,
    /// Blocks read: lines with more than comments, blanks and `%`.
    pub blocks_in: u64,
    /// Blocks written, counted alike.
    pub blocks_out: u64,
    /// The largest contour error (µm) the adaptive segmentation estimates
    /// it leaves on a feed move (docs/compensation.md, "Adaptive
    /// segmentation", "Arcs as arcs"; without the rounding of the written
    /// numbers); `None` under a fixed segmentation, which estimates nothing.
    pub max_estimated_contour_um: Option<f64>,
    /// Target points compensated.
    pub points: u64,
    /// Largest model residual (µm).
    pub max_residual_um: f64,
    /// Largest correction `‖q − t‖` (µm).
    pub max_correction_um: f64,
    /// Take-up moves written.
    pub take_ups: u64,
    /// Take-ups folded into the move that reverses (no block written).
    pub take_ups_folded: u64,
    /// Lines written so that each axis approaches from one side before the
    /// first cut (docs/compensation.md, "Each axis approaches from one side
    /// before the first cut"): 0 or 2.
    pub approach_lines: u64,
    /// Take-ups made during the move before the one that reverses, where
    /// the reversing axis stands still (docs/compensation.md, "Take-ups
    /// ahead in an idle move"): no block, no fold.
    pub take_ups_idle: u64,
    /// The largest excursion from the path a folded take-up may leave
    /// (µm): the bound of docs/compensation.md, "Take-ups folded into the
    /// move", at most the reversal value.
    pub max_fold_excursion_um: f64,
    /// Points where an axis was held instead of a reversal smaller than
    /// its band ([`CompensateOptions::hold_tolerance_mm`]).
    pub small_reversals_held: u64,
    /// The largest error such a held point leaves (µm).
    pub max_hold_error_um: f64,
    /// Lines where an axis was held, with the axis letter (first 100).
    pub held: Vec<(u64, char)>,
    /// Total number of holds.
    pub held_count: u64,
    /// Feed moves (G1, arcs, cycles, splines) written without compensation
    /// because an axis had never been set when they ran (only with
    /// [`CompensateOptions::allow_uncompensated_axes`]; otherwise the
    /// program is refused at the first).
    pub uncompensated_moves: u64,
    /// The first of them: line and 1-based column.
    pub first_uncompensated: Option<(u64, usize)>,
    /// The axes never set at the first of them.
    pub unset_axes: [bool; 3],
    /// Canned-cycle holes written as compensated cycle blocks
    /// (docs/compensation.md, "Canned cycles").
    pub cycle_holes_kept: u64,
    /// Canned-cycle holes written as their moves (the map varies too much
    /// over the hole, or the segmentation is fixed).
    pub cycle_holes_expanded: u64,
    /// The largest error a hole kept as a cycle leaves on its cut (µm):
    /// across the stroke or at a feed end.
    pub max_cycle_error_um: f64,
    /// Blocks under G61/G61.1 written as several pieces that run under
    /// `G64 P p Q0`, the program's mode restored on their last piece
    /// (docs/compensation.md, "Pieces of a block under G61").
    pub pieces_blended_blocks: u64,
    /// Lines written for the path-control words alone (where the block's
    /// first piece is an arc, which cannot carry P).
    pub path_mode_lines: u64,
    /// The largest `p` (µm) of those `G64 P p` words.
    pub piece_blend_tolerance_um: f64,
    /// Arcs under `G64 P p Q q` written as arc pieces that run under
    /// `G64 P p Q0`, the program's words written again after them
    /// (docs/compensation.md, "Arc pieces under G64 P").
    pub naive_cam_off_blocks: u64,
}

impl CompensateSummary {
    /// Counts a point held instead of a reversal smaller than its band,
    /// leaving `residual_um` (µm).
    pub(crate) fn count_hold(&mut self, residual_um: f64) {
        self.small_reversals_held += 1;
        self.max_hold_error_um = self.max_hold_error_um.max(residual_um);
    }

    /// What was not compensated, in one line (no parentheses: it is also a
    /// comment of the header); `None` when every feed move was compensated.
    pub fn uncompensated_text(&self) -> Option<String> {
        let (line, _) = self.first_uncompensated?;
        let axes = unset_axes_text(self.unset_axes);
        Some(format!(
            "{} NOT compensated, the first on line {line}: the program never set {axes} before {} and the set-up gives no start",
            count_text(self.uncompensated_moves, "feed move", "feed moves"),
            if self.uncompensated_moves == 1 { "it" } else { "them" },
        ))
    }

    /// What the compensation did at reversals, in one line (no
    /// parentheses: it is also a comment of the header): how many take-ups
    /// were folded into their moves and the largest excursion from the path
    /// that leaves (µm), how many were written as take-up blocks (the
    /// machine stops for each).
    pub fn reversals_text(&self) -> String {
        let held = if self.small_reversals_held > 0 {
            format!(
                "; {} held instead, up to {:.3} um off",
                count_text(
                    self.small_reversals_held,
                    "reversal smaller than its band",
                    "reversals smaller than their band"
                ),
                self.max_hold_error_um
            )
        } else {
            String::new()
        };
        let idle = if self.take_ups_idle > 0 {
            format!("; {} taken up ahead in an idle move", self.take_ups_idle)
        } else {
            String::new()
        };
        format!(
            "reversals: {} folded, up to {:.3} um off the path; {} take-up {}{idle}{held}",
            self.take_ups_folded,
            self.max_fold_excursion_um,
            self.take_ups,
            if self.take_ups == 1 {
                "block"
            } else {
                "blocks"
            }
        )
    }

    /// What the path-control words inside G61/G61.1 blocks do, in one
    /// line (no parentheses; the header labels it "path mode:"); `None`
    /// where none were written.
    pub fn path_mode_text(&self) -> Option<String> {
        let g61 = (self.pieces_blended_blocks > 0).then(|| {
            format!(
                "the pieces of {} G61/G61.1 {} run under G64 P Q0 (joins blended within P = {:.3} um, Q0: no naive-CAM merging) and each block's last piece restores the program's mode, so the machine stops only where the original does{}",
                self.pieces_blended_blocks,
                if self.pieces_blended_blocks == 1 { "block" } else { "blocks" },
                self.piece_blend_tolerance_um,
                if self.path_mode_lines > 0 {
                    format!(
                        "; {} only these words",
                        count_text(self.path_mode_lines, "line carries", "lines carry")
                    )
                } else {
                    String::new()
                }
            )
        });
        let g64 = (self.naive_cam_off_blocks > 0).then(|| {
            format!(
                "the arc pieces of {} G64 P {} run under G64 P Q0 (no naive-CAM: LinuxCNC would write a short arc piece as two lines) and the program's G64 P Q is written again after each",
                self.naive_cam_off_blocks,
                if self.naive_cam_off_blocks == 1 { "block" } else { "blocks" },
            )
        });
        match (g61, g64) {
            (Some(a), Some(b)) => Some(format!("{a}; {b}")),
            (a, b) => a.or(b),
        }
    }
}

/// `n` with the noun in the singular or plural.
fn count_text(n: u64, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

/// The axes flagged, as `Z` or `Y and Z` or `X, Y and Z`.
pub fn unset_axes_text(axes: [bool; 3]) -> String {
    let names: Vec<&str> = ["X", "Y", "Z"]
        .into_iter()
        .zip(axes)
        .filter_map(|(n, b)| b.then_some(n))
        .collect();
    match names.as_slice() {
        [] => String::new(),
        [one] => (*one).to_string(),
        [rest @ .., last] => format!("{} and {last}", rest.join(", ")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn what_a_held_axis_may_leave_in_each_path_control_mode() {
        // G64 P0.005: 5 µm less the default contour tolerance (0.1 µm) =
        // 4.9 µm; G64 without P, G61/G61.1: no hold; take-ups off: no hold
        // either.
        let o = CompensateOptions::default();
        assert_eq!(o.hold_tolerance_mm(TakeUpRule::Always), None);
        let p = o.hold_tolerance_mm(TakeUpRule::Within(0.005)).unwrap();
        assert!((p - 0.0049).abs() < 1e-15, "{p}");
        assert_eq!(o.hold_tolerance_mm(TakeUpRule::Within(0.0001)), None);
        for smooth in [true, false] {
            assert_eq!(o.hold_tolerance_mm(TakeUpRule::Exact { smooth }), None);
        }
        let off = CompensateOptions {
            take_up: false,
            ..CompensateOptions::default()
        };
        assert_eq!(off.hold_tolerance_mm(TakeUpRule::Within(0.005)), None);
    }
}
