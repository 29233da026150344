//! What every error model gives: the deviation `e(q, s) = actual − commanded`
//! (docs/design.md, "Deviation sign") at an axis position `q` with motion-direction state `s`.
//!
//! Compensation and simulation only talk to [`ErrorModel`], so richer models
//! (21-component kinematic, thermal, grids) plug in without touching them.

pub mod arrays;
pub mod axis_table;
pub mod controller;
pub mod kinematic;
pub mod positioning;
pub mod query;
pub mod setup;
pub mod straightness;
pub mod topology;

use crate::error::ModelError;
use volcomp_gcode::Vec3;

/// Direction of the most recent commanded motion of one axis (docs/design.md, "Direction state and backlash").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Direction {
    /// Increasing position.
    Forward,
    /// Decreasing position.
    Reverse,
}

impl Direction {
    /// The other direction.
    pub fn flipped(self) -> Direction {
        match self {
            Direction::Forward => Direction::Reverse,
            Direction::Reverse => Direction::Forward,
        }
    }

    /// `+1` forward, `−1` reverse.
    pub fn sign(self) -> f64 {
        match self {
            Direction::Forward => 1.0,
            Direction::Reverse => -1.0,
        }
    }

    /// The direction of a change `delta`, or `None` when it is zero.
    pub fn of_delta(delta: f64) -> Option<Direction> {
        if delta > 0.0 {
            Some(Direction::Forward)
        } else if delta < 0.0 {
            Some(Direction::Reverse)
        } else {
            None
        }
    }
}

/// Direction state of the three axes.
pub type Directions = [Direction; 3];

/// All axes forward: the state before any motion (docs/design.md, "Direction state and backlash").
pub const ALL_FORWARD: Directions = [Direction::Forward; 3];

/// The direction state after a move by `dq` (axes that do not move keep theirs).
pub fn next_state(s: Directions, dq: volcomp_gcode::Vec3) -> Directions {
    let mut out = s;
    for a in 0..3 {
        if let Some(d) = Direction::of_delta(dq[a]) {
            out[a] = d;
        }
    }
    out
}

/// Relative tolerance of a model's range check: a position computed from
/// others (a work offset or tool length added and taken off again, a
/// conversion) can land a few units in the last place beyond a table's end
/// where the input was exactly at it (`(181.5362 + 128.1) − 128.1` is
/// `181.53620000000004`). A position within `RANGE_TOLERANCE · max(1 mm,
/// |lo|, |hi|)` of the range (10⁻⁷ mm on a 1 m axis) is taken at the end;
/// anything farther out is out of range, never clamped silently.
pub const RANGE_TOLERANCE: f64 = 1e-10;

/// `x_mm` if it lies in `[lo_mm, hi_mm]`, the nearer end if it lies within
/// the rounding of a computed position of it ([`RANGE_TOLERANCE`]), else
/// `None`.
///
/// ```
/// use volcomp_core::model::within_range;
/// assert_eq!(within_range((181.5362 + 128.1) - 128.1, 0.0, 181.5362), Some(181.5362));
/// assert_eq!(within_range(181.5363, 0.0, 181.5362), None);
/// ```
pub fn within_range(x_mm: f64, lo_mm: f64, hi_mm: f64) -> Option<f64> {
    if (lo_mm..=hi_mm).contains(&x_mm) {
        return Some(x_mm);
    }
    let tol = RANGE_TOLERANCE * lo_mm.abs().max(hi_mm.abs()).max(1.0);
    if x_mm < lo_mm && lo_mm - x_mm <= tol {
        Some(lo_mm)
    } else if x_mm > hi_mm && x_mm - hi_mm <= tol {
        Some(hi_mm)
    } else {
        None
    }
}

/// Which error components a model evaluation includes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Components {
    /// Every component of the model.
    All,
    /// Only the positioning errors E_XX, E_YY, E_ZZ: what an ordinary
    /// controller's pitch compensation already covers.
    PositioningOnly,
}

/// A volumetric error model of a 3-axis machine.
pub trait ErrorModel: Send + Sync {
    /// Deviation `e(q, s)` in µm at axis position `q_mm` (axis frame).
    fn deviation_um(
        &self,
        q_mm: Vec3,
        s: Directions,
        components: Components,
    ) -> Result<Vec3, ModelError>;

    /// The axis ranges the model is defined on, `[min, max]` per axis (mm).
    fn range_mm(&self) -> [[f64; 2]; 3];

    /// Deviation `e(q, s)` in µm with the active tool's length offset
    /// `tool_length_offset_mm`: the vector the controller adds to a programmed
    /// position (G43: `(0, 0, L)`; G43.1: any vector), so the tool tip lies at
    /// `−tool_length_offset_mm` from the spindle's gauge point.
    ///
    /// Models whose error does not depend on the tool (the axis tables) keep
    /// this default, which ignores the offset. Models with Abbe terms (the
    /// 21-component kinematic model) use it for the arms of the angular errors.
    fn deviation_with_tool_um(
        &self,
        q_mm: Vec3,
        s: Directions,
        components: Components,
        tool_length_offset_mm: Vec3,
    ) -> Result<Vec3, ModelError> {
        let _ = tool_length_offset_mm;
        self.deviation_um(q_mm, s, components)
    }

    /// Whether [`ErrorModel::deviation_with_tool_um`] depends on the tool offset.
    fn uses_tool_offset(&self) -> bool {
        false
    }

    /// Axis positions (mm, increasing) where the error of axis `axis`
    /// (0 = X, 1 = Y, 2 = Z) moving in direction `d` may change slope: the
    /// points of a linearly interpolated table. Between two of them, with the
    /// other axes still, the error is affine in the position, so a compensated
    /// chord between two solved points follows the target line exactly
    /// (docs/compensation.md, "Adaptive segmentation"). Models that are not
    /// piecewise linear keep the default (none); compensation then relies on
    /// bisection alone.
    fn knots_mm(&self, axis: usize, d: Direction) -> &[f64] {
        let _ = (axis, d);
        &[]
    }

    /// The table cells that hold `q_mm` for direction state `s`, where
    /// the model is a sum of per-axis tables interpolated linearly: inside
    /// them [`Cells::deviation_um`] gives [`ErrorModel::deviation_um`]'s
    /// value to the bit, without looking the cells up again. An iteration
    /// whose points stay in one cell per axis (a solve's steps of a few
    /// micrometres) evaluates the map once. Models that are not such a sum
    /// keep the default (`None`).
    fn deviation_cells(&self, q_mm: Vec3, s: Directions, components: Components) -> Option<Cells> {
        let _ = (q_mm, s, components);
        None
    }

    /// The cell of axis `axis`'s table for direction `d` that holds
    /// `x_mm`, where the model is a sum of per-axis tables interpolated
    /// linearly (one axis of [`ErrorModel::deviation_cells`]): the cells
    /// [`AxisCells`] keeps between evaluations. `None` outside the table,
    /// and for models that are not such a sum (the default).
    fn axis_cell(&self, axis: usize, d: Direction, x_mm: f64) -> Option<Cell> {
        let _ = (axis, d, x_mm);
        None
    }

    /// Whether the error, with the direction state fixed, is the sum of
    /// per-axis functions each linear between its [`ErrorModel::knots_mm`]
    /// (and constant outside a clamped range): then `e` is affine along a
    /// straight move between two knot crossings, exactly, and adaptive
    /// segmentation needs to look at the knots only.
    fn piecewise_linear(&self) -> bool {
        false
    }
}

/// One axis' table cell: positions `p[0] < p[1]` (mm) and the errors at
/// them (µm); `upper` when the cell holds its upper end too (the table's
/// last cell: any other cell's upper end is the next cell's start). A table
/// of one point is a cell with `p[0] == p[1]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cell {
    /// The cell's ends (mm).
    pub p: [f64; 2],
    /// The errors at them (µm).
    pub e: [Vec3; 2],
    /// The upper end belongs to the cell.
    pub upper: bool,
}

/// The cells of the three axes' tables around a point, for one direction
/// state and set of components ([`ErrorModel::deviation_cells`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cells {
    /// X, Y and Z's cells.
    pub axes: [Cell; 3],
    /// The components summed.
    pub components: Components,
}

impl Cells {
    /// The model's deviation (µm) at `q_mm`, computed as the table model
    /// computes it (linear interpolation in each axis' cell, summed X, Y,
    /// Z), so the same to the bit; `None` where `q_mm` lies outside a cell.
    #[inline]
    pub fn deviation_um(&self, q_mm: Vec3) -> Option<Vec3> {
        let mut e = Vec3::ZERO;
        for a in 0..3 {
            let v = self.axes[a].value_at(q_mm[a])?;
            match self.components {
                Components::All => e += v,
                Components::PositioningOnly => e[a] += v[a],
            }
        }
        Some(e)
    }
}

impl Cell {
    /// The table's value (µm) at `x_mm`, computed as [`axis_table::Table::eval`]
    /// computes it (linear interpolation between the cell's ends), so the
    /// same to the bit; `None` where `x_mm` lies outside the cell.
    #[inline]
    pub fn value_at(&self, x_mm: f64) -> Option<Vec3> {
        if self.p[0] == self.p[1] {
            // A table of one point: its value itself (the sign of a zero kept).
            return (self.upper && x_mm == self.p[0]).then_some(self.e[0]);
        }
        KeptCell::of(self).value_at(x_mm)
    }
}

/// The table cells last used, one per axis and direction, kept between
/// evaluations of one model: the points a compensation evaluates follow
/// each other micrometres to millimetres apart, so an axis whose direction
/// did not change finds its point in the cell it used last, and the table
/// is searched again only when the point leaves it. The value is
/// [`ErrorModel::deviation_um`]'s to the bit (the model's per-axis sum,
/// [`Cells::deviation_um`]); a model without table cells
/// ([`ErrorModel::axis_cell`]) is evaluated itself.
///
/// The cells belong to the model they were taken from: one cache serves
/// one model (a model seen with different tools, [`WithTool`], is one
/// model where its error does not depend on the tool, and gives no cells
/// where it does).
///
/// It also remembers the last few values asked for again
/// ([`AxisCells::deviation_again_um`]): at a reversal the point the last
/// command reached is evaluated under its old state and with the
/// reversing axes switched by the hold, the take-up and the lags in turn.
/// And it keeps the value at the last end of a move its split evaluated
/// ([`AxisCells::deviation_end_um`]): the solve of the move's last target
/// starts there, and the next move's split at the same point.
///
/// Two cells are kept per axis and direction, the last two used: a split
/// evaluates a move at a table point, which opens the next cell, and then
/// again inside the cell before it.
#[derive(Debug, Clone, Default)]
pub struct AxisCells {
    cells: [[KeptCells; 2]; 3],
    again: [Again; AGAIN],
    next_again: usize,
    end: Again,
}

/// The two cells [`AxisCells`] keeps for one axis and direction, the one
/// used last first.
type KeptCells = [KeptCell; 2];

/// A [`Cell`] as [`AxisCells`] keeps it: with the two differences its
/// linear interpolation takes, `p[1] − p[0]` and `e[1] − e[0]`, computed
/// once; [`Cell::value_at`] takes them on every call, through this one
/// interpolation (`e₀ + (e₁ − e₀)·t`, [`Vec3::lerp`]'s operations), so a
/// value is the same to the bit.
///
/// Its bounds are one comparison each: the upper one is exclusive, the
/// next `f64` above the upper end where the cell holds that end
/// ([`Cell::upper`]; `x < next_up(p₁)` is `x ≤ p₁` for every `x`). A
/// table of one point is a cell of no rise and width 1, whose value at its
/// point is `e₀ + 0`: `e₀` but for the sign of a zero, which the sums
/// that take it ([`AxisCells::deviation_um`], onto `+0`) lose anyway.
#[derive(Debug, Clone, Copy)]
struct KeptCell {
    /// The cell's lower end (mm); NaN for no cell (no point is inside).
    p0_mm: f64,
    /// Its upper end (mm), exclusive: the next `f64` above the table's
    /// upper end where the cell holds it.
    below_mm: f64,
    /// `p[1] − p[0]` (1 for a table of one point).
    width_mm: f64,
    /// The error at the lower end (µm).
    e0_um: Vec3,
    /// The error at the upper end less the one at the lower end (µm; 0
    /// for a table of one point).
    rise_um: Vec3,
}

impl Default for KeptCell {
    fn default() -> Self {
        Self {
            p0_mm: f64::NAN,
            below_mm: f64::NAN,
            width_mm: f64::NAN,
            e0_um: Vec3::ZERO,
            rise_um: Vec3::ZERO,
        }
    }
}

/// The least `f64` above `x` (`f64::next_up`, which this crate's minimum
/// Rust does not have): `x` itself for NaN and +∞.
fn next_up(x: f64) -> f64 {
    if x.is_nan() || x == f64::INFINITY {
        return x;
    }
    if x == 0.0 {
        return f64::from_bits(1);
    }
    let bits = x.to_bits();
    f64::from_bits(if x > 0.0 { bits + 1 } else { bits - 1 })
}

impl KeptCell {
    fn of(c: &Cell) -> Self {
        let point = c.p[0] == c.p[1];
        Self {
            p0_mm: c.p[0],
            below_mm: if c.upper { next_up(c.p[1]) } else { c.p[1] },
            width_mm: if point { 1.0 } else { c.p[1] - c.p[0] },
            e0_um: c.e[0],
            rise_um: if point { Vec3::ZERO } else { c.e[1] - c.e[0] },
        }
    }

    /// The value at `x_mm` where it lies in the cell: the error at the
    /// lower end plus the rise times the share of the width (linear
    /// interpolation, [`Vec3::lerp`]'s operations); at a table of one point
    /// its one value plus zero.
    #[inline(always)]
    fn value_at(&self, x_mm: f64) -> Option<Vec3> {
        let x = x_mm;
        if !(self.p0_mm <= x && x < self.below_mm) {
            return None;
        }
        Some(self.e0_um + self.rise_um * ((x - self.p0_mm) / self.width_mm))
    }

    /// Whether the cell holds the whole closed interval `[lo, hi]` with
    /// `lo < hi`: then no table point lies strictly between them (the
    /// cell's ends are two neighbouring table points).
    #[inline(always)]
    fn spans(&self, lo_mm: f64, hi_mm: f64) -> bool {
        self.p0_mm <= lo_mm && hi_mm < self.below_mm
    }
}

/// How many values [`AxisCells::deviation_again_um`] remembers: the old
/// state and the states with one reversing axis switched, at one point,
/// and the point solved after it.
const AGAIN: usize = 4;

/// A value [`AxisCells::deviation_again_um`] remembers: `e(q, s)` (µm,
/// every component), computed in the kept cells, for `q`'s bits and `s`
/// (a bit per reversing axis; [`Again::NONE`] for no value).
#[derive(Debug, Clone, Copy)]
struct Again {
    q_bits: [u64; 3],
    s_bits: u8,
    e_um: Vec3,
}

impl Again {
    /// No value: a state no [`Directions`] has.
    const NONE: u8 = u8::MAX;

    /// The key of `q` and `s`.
    #[inline(always)]
    fn key(q_mm: Vec3, s: Directions) -> ([u64; 3], u8) {
        let bit = |a: usize| u8::from(s[a] == Direction::Reverse) << a;
        (
            [q_mm.x.to_bits(), q_mm.y.to_bits(), q_mm.z.to_bits()],
            bit(0) | bit(1) | bit(2),
        )
    }

    /// Whether this is the value of the key.
    #[inline(always)]
    fn holds(&self, (q_bits, s_bits): ([u64; 3], u8)) -> bool {
        self.s_bits == s_bits
            && self.q_bits[0] == q_bits[0]
            && self.q_bits[1] == q_bits[1]
            && self.q_bits[2] == q_bits[2]
    }
}

impl Default for Again {
    fn default() -> Self {
        Self {
            q_bits: [0; 3],
            s_bits: Self::NONE,
            e_um: Vec3::ZERO,
        }
    }
}

impl AxisCells {
    /// `e(q, s)` in µm: [`ErrorModel::deviation_um`]'s value to the bit
    /// (the axes' values summed in the model's order, X, Y, Z, onto zero).
    /// Inlined into its callers (the solves' loops call it about two
    /// million times a CAM program of 70,000 lines, and a call's saving
    /// and restoring of registers cost a third of its own instructions).
    #[inline(always)]
    pub fn deviation_um(
        &mut self,
        model: &dyn ErrorModel,
        q_mm: Vec3,
        s: Directions,
        components: Components,
    ) -> Result<Vec3, ModelError> {
        let [x, y, z] = &mut self.cells;
        let values = (
            Self::value(x, model, 0, s[0], q_mm.x),
            Self::value(y, model, 1, s[1], q_mm.y),
            Self::value(z, model, 2, s[2], q_mm.z),
        );
        let (Some(vx), Some(vy), Some(vz)) = values else {
            // Outside a table, or no cells: the model itself.
            return model.deviation_um(q_mm, s, components);
        };
        Ok(match components {
            Components::All => Vec3::ZERO + vx + vy + vz,
            Components::PositioningOnly => Vec3::new(0.0 + vx.x, 0.0 + vy.y, 0.0 + vz.z),
        })
    }

    /// [`Self::deviation_um`] with every component, for a point and state
    /// likely asked for again: the value is remembered (the last
    /// [`AGAIN`] of them) and given back for the same bits of `q_mm` and
    /// the same `s` without evaluating the cells. Only values the cells
    /// gave are remembered; they do not depend on the tool, as the cells
    /// do not ([`AxisCells`]), so a value is the model's to the bit
    /// whichever line asks. Anything else (outside a table, a model
    /// without cells) is the model's own evaluation each time.
    #[inline(always)]
    pub fn deviation_again_um(
        &mut self,
        model: &dyn ErrorModel,
        q_mm: Vec3,
        s: Directions,
    ) -> Result<Vec3, ModelError> {
        let key = Again::key(q_mm, s);
        for kept in &self.again {
            if kept.holds(key) {
                return Ok(kept.e_um);
            }
        }
        let (e_um, from_cells) = self.all_components_um(model, q_mm, s)?;
        if from_cells {
            self.again[self.next_again] = Again {
                q_bits: key.0,
                s_bits: key.1,
                e_um,
            };
            self.next_again = (self.next_again + 1) % AGAIN;
        }
        Ok(e_um)
    }

    /// [`Self::deviation_um`] with every component at an end of a move
    /// (evaluated by its split): the last such value is kept and given back
    /// for the same bits of `q_mm` and the same `s`, as
    /// [`Self::deviation_again_um`] gives its values back; the solve of
    /// the move's last target starts there ([`Self::end_um`]).
    pub fn deviation_end_um(
        &mut self,
        model: &dyn ErrorModel,
        q_mm: Vec3,
        s: Directions,
    ) -> Result<Vec3, ModelError> {
        let key = Again::key(q_mm, s);
        if self.end.holds(key) {
            return Ok(self.end.e_um);
        }
        let (e_um, from_cells) = self.all_components_um(model, q_mm, s)?;
        if from_cells {
            self.end = Again {
                q_bits: key.0,
                s_bits: key.1,
                e_um,
            };
        }
        Ok(e_um)
    }

    /// The value [`Self::deviation_end_um`] keeps, where it is the one of
    /// `q_mm` and `s` (µm, every component: the map's to the bit).
    #[inline]
    pub fn end_um(&self, q_mm: Vec3, s: Directions) -> Option<Vec3> {
        self.end.holds(Again::key(q_mm, s)).then_some(self.end.e_um)
    }

    /// [`Self::deviation_um`] with every component, and whether the cells
    /// gave it (not the model itself).
    #[inline(always)]
    fn all_components_um(
        &mut self,
        model: &dyn ErrorModel,
        q_mm: Vec3,
        s: Directions,
    ) -> Result<(Vec3, bool), ModelError> {
        let [x, y, z] = &mut self.cells;
        let values = (
            Self::value(x, model, 0, s[0], q_mm.x),
            Self::value(y, model, 1, s[1], q_mm.y),
            Self::value(z, model, 2, s[2], q_mm.z),
        );
        let (Some(vx), Some(vy), Some(vz)) = values else {
            return Ok((model.deviation_um(q_mm, s, Components::All)?, false));
        };
        Ok((Vec3::ZERO + vx + vy + vz, true))
    }

    /// `q + e(q, s)` with every component ([`actual_mm`]'s value to the
    /// bit), remembered as [`Self::deviation_again_um`] remembers it.
    #[inline]
    pub fn actual_again_mm(
        &mut self,
        model: &dyn ErrorModel,
        q_mm: Vec3,
        s: Directions,
    ) -> Result<Vec3, ModelError> {
        Ok(q_mm + self.deviation_again_um(model, q_mm, s)? * 1e-3)
    }

    /// Whether a cell kept for axis `axis` and direction `d` holds the
    /// whole interval `[lo_mm, hi_mm]` (`lo_mm < hi_mm`): then no point of
    /// that table lies strictly between them, which a move's adaptive split
    /// needs to know, without searching the table
    /// ([`ErrorModel::knots_mm`]: the cells' ends are its neighbouring
    /// points). `false` where no kept cell holds it (not known).
    #[inline]
    pub fn spans_mm(&self, axis: usize, d: Direction, lo_mm: f64, hi_mm: f64) -> bool {
        let kept = &self.cells[axis][match d {
            Direction::Forward => 0,
            Direction::Reverse => 1,
        }];
        kept[0].spans(lo_mm, hi_mm) || kept[1].spans(lo_mm, hi_mm)
    }

    /// Axis `axis`'s table value at `x_mm` for direction `d`, in the cell
    /// kept for them, or in the cell looked up when `x_mm` left it.
    #[inline(always)]
    fn value(
        cells: &mut [KeptCells; 2],
        model: &dyn ErrorModel,
        axis: usize,
        d: Direction,
        x_mm: f64,
    ) -> Option<Vec3> {
        let kept = match d {
            Direction::Forward => &mut cells[0],
            Direction::Reverse => &mut cells[1],
        };
        match kept[0].value_at(x_mm) {
            Some(v) => Some(v),
            None => Self::refill(kept, model, axis, d, x_mm),
        }
    }

    /// [`Self::value`] where `x_mm` left the cell used last: in the other
    /// cell kept (which becomes the one used last), or in the cell looked
    /// up (the one used last becomes the other).
    #[cold]
    #[inline(never)]
    fn refill(
        kept: &mut KeptCells,
        model: &dyn ErrorModel,
        axis: usize,
        d: Direction,
        x_mm: f64,
    ) -> Option<Vec3> {
        if let Some(v) = kept[1].value_at(x_mm) {
            kept.swap(0, 1);
            return Some(v);
        }
        let cell = model.axis_cell(axis, d, x_mm)?;
        kept[1] = kept[0];
        kept[0] = KeptCell::of(&cell);
        kept[0].value_at(x_mm)
    }

    /// `q + e(q, s)` ([`actual_mm`]'s value to the bit).
    #[inline(always)]
    pub fn actual_mm(
        &mut self,
        model: &dyn ErrorModel,
        q_mm: Vec3,
        s: Directions,
        components: Components,
    ) -> Result<Vec3, ModelError> {
        Ok(q_mm + self.deviation_um(model, q_mm, s, components)? * 1e-3)
    }
}

/// A model seen with a fixed tool length offset: what compensation and
/// simulation evaluate for the tool that is active on a program line.
///
/// ```
/// use volcomp_core::model::{ErrorModel, WithTool, Components, ALL_FORWARD};
/// use volcomp_core::model::axis_table::AxisTableMap;
/// use volcomp_gcode::Vec3;
/// let csv = "axis,direction,position_mm,ex_um,ey_um,ez_um\n\
///            X,both,0,0,0,0\nX,both,10,2,0,0\nY,both,0,0,0,0\nY,both,10,0,0,0\n\
///            Z,both,0,0,0,0\nZ,both,10,0,0,0\n";
/// let map = AxisTableMap::from_csv(csv, "m.csv").unwrap();
/// let tool = WithTool { model: &map, tool_length_offset_mm: Vec3::new(0.0, 0.0, 100.0) };
/// let q = Vec3::new(5.0, 1.0, 1.0);
/// // Axis tables do not depend on the tool.
/// assert_eq!(tool.deviation_um(q, ALL_FORWARD, Components::All).unwrap(),
///            map.deviation_um(q, ALL_FORWARD, Components::All).unwrap());
/// ```
#[derive(Clone, Copy)]
pub struct WithTool<'a> {
    /// The model.
    pub model: &'a dyn ErrorModel,
    /// Tool length offset of the active tool (mm, as the controller applies it).
    pub tool_length_offset_mm: Vec3,
}

impl ErrorModel for WithTool<'_> {
    fn deviation_um(
        &self,
        q_mm: Vec3,
        s: Directions,
        components: Components,
    ) -> Result<Vec3, ModelError> {
        self.model
            .deviation_with_tool_um(q_mm, s, components, self.tool_length_offset_mm)
    }

    fn range_mm(&self) -> [[f64; 2]; 3] {
        self.model.range_mm()
    }

    fn deviation_with_tool_um(
        &self,
        q_mm: Vec3,
        s: Directions,
        components: Components,
        tool_length_offset_mm: Vec3,
    ) -> Result<Vec3, ModelError> {
        self.model
            .deviation_with_tool_um(q_mm, s, components, tool_length_offset_mm)
    }

    fn uses_tool_offset(&self) -> bool {
        self.model.uses_tool_offset()
    }

    /// The model's cells where its error does not depend on the tool
    /// (they are the model's without one).
    fn deviation_cells(&self, q_mm: Vec3, s: Directions, components: Components) -> Option<Cells> {
        if self.model.uses_tool_offset() {
            return None;
        }
        self.model.deviation_cells(q_mm, s, components)
    }

    /// The model's cell where its error does not depend on the tool.
    fn axis_cell(&self, axis: usize, d: Direction, x_mm: f64) -> Option<Cell> {
        if self.model.uses_tool_offset() {
            return None;
        }
        self.model.axis_cell(axis, d, x_mm)
    }

    fn knots_mm(&self, axis: usize, d: Direction) -> &[f64] {
        self.model.knots_mm(axis, d)
    }

    fn piecewise_linear(&self) -> bool {
        self.model.piecewise_linear()
    }
}

/// A boxed model is the model (every method forwarded), so wrappers such as
/// [`controller::ControllerResidual`] take a model loaded at run time.
impl<M: ErrorModel + ?Sized> ErrorModel for Box<M> {
    fn deviation_um(
        &self,
        q_mm: Vec3,
        s: Directions,
        components: Components,
    ) -> Result<Vec3, ModelError> {
        (**self).deviation_um(q_mm, s, components)
    }

    fn range_mm(&self) -> [[f64; 2]; 3] {
        (**self).range_mm()
    }

    fn deviation_with_tool_um(
        &self,
        q_mm: Vec3,
        s: Directions,
        components: Components,
        tool_length_offset_mm: Vec3,
    ) -> Result<Vec3, ModelError> {
        (**self).deviation_with_tool_um(q_mm, s, components, tool_length_offset_mm)
    }

    fn uses_tool_offset(&self) -> bool {
        (**self).uses_tool_offset()
    }

    fn deviation_cells(&self, q_mm: Vec3, s: Directions, components: Components) -> Option<Cells> {
        (**self).deviation_cells(q_mm, s, components)
    }

    fn axis_cell(&self, axis: usize, d: Direction, x_mm: f64) -> Option<Cell> {
        (**self).axis_cell(axis, d, x_mm)
    }
}

/// `q + e(q, s)`: where the tool actually is when commanded to `q_mm`.
pub fn actual_mm(
    model: &dyn ErrorModel,
    q_mm: Vec3,
    s: Directions,
    components: Components,
) -> Result<Vec3, ModelError> {
    Ok(q_mm + model.deviation_um(q_mm, s, components)? * 1e-3)
}

/// A direction state that could not be read (see [`parse_directions`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("a direction state is forward, reverse or one letter per axis (f/r or +/-) like frf; got `{text}`")]
pub struct DirectionsError {
    /// The text as given.
    pub text: String,
}

/// Reads a direction state: `forward` (`fwd`, `+`), `reverse` (`rev`, `-`)
/// for all three axes, or one letter per axis X, Y, Z (`f`/`+` forward,
/// `r`/`-` reverse), case-insensitive.
///
/// ```
/// use volcomp_core::model::{parse_directions, Direction::{Forward as F, Reverse as R}};
/// assert_eq!(parse_directions("frf").unwrap(), [F, R, F]);
/// assert!(parse_directions("fr").is_err());
/// ```
pub fn parse_directions(text: &str) -> Result<Directions, DirectionsError> {
    let lower = text.trim().to_ascii_lowercase();
    let one = |c: char| match c {
        'f' | '+' => Some(Direction::Forward),
        'r' | '-' => Some(Direction::Reverse),
        _ => None,
    };
    match lower.as_str() {
        "forward" | "fwd" | "+" => Ok([Direction::Forward; 3]),
        "reverse" | "rev" | "-" => Ok([Direction::Reverse; 3]),
        _ => {
            let v: Vec<Option<Direction>> = lower.chars().map(one).collect();
            match v.as_slice() {
                [Some(x), Some(y), Some(z)] => Ok([*x, *y, *z]),
                _ => Err(DirectionsError {
                    text: text.to_string(),
                }),
            }
        }
    }
}

/// A direction state as three signs, X Y Z: `+` forward, `-` reverse.
///
/// ```
/// use volcomp_core::model::{direction_letters, Direction::{Forward as F, Reverse as R}};
/// assert_eq!(direction_letters([F, R, F]), "+-+");
/// ```
pub fn direction_letters(s: Directions) -> String {
    s.iter()
        .map(|d| match d {
            Direction::Forward => '+',
            Direction::Reverse => '-',
        })
        .collect()
}

/// A test model whose error depends on the axes' directions only, over
/// ±1 m: the dead bands that the solver's and the simulator's tests work
/// out by hand.
#[cfg(test)]
pub(crate) struct ByDirection<F>(pub F);

#[cfg(test)]
impl<F: Fn(Directions) -> Vec3 + Send + Sync> ErrorModel for ByDirection<F> {
    fn deviation_um(&self, _q: Vec3, s: Directions, _c: Components) -> Result<Vec3, ModelError> {
        Ok((self.0)(s))
    }
    fn range_mm(&self) -> [[f64; 2]; 3] {
        [[-1e3, 1e3]; 3]
    }
}

#[cfg(test)]
mod direction_tests {
    use super::*;
    use Direction::{Forward as F, Reverse as R};

    #[test]
    fn directions_parse() {
        assert_eq!(parse_directions("forward").unwrap(), [F, F, F]);
        assert_eq!(parse_directions(" FWD ").unwrap(), [F, F, F]);
        assert_eq!(parse_directions("-").unwrap(), [R, R, R]);
        assert_eq!(parse_directions("rev").unwrap(), [R, R, R]);
        assert_eq!(parse_directions("frf").unwrap(), [F, R, F]);
        assert_eq!(parse_directions("+-+").unwrap(), [F, R, F]);
        assert_eq!(parse_directions("RRF").unwrap(), [R, R, F]);
        let e = parse_directions("fr").unwrap_err();
        assert_eq!(e.text, "fr");
        assert!(parse_directions("frx").is_err());
        assert!(parse_directions("frfr").is_err());
    }

    #[test]
    fn letters_round_trip() {
        for s in [[F, F, F], [R, F, R], [F, R, R]] {
            assert_eq!(parse_directions(&direction_letters(s)).unwrap(), s);
        }
    }
}

#[cfg(test)]
mod axis_cells_tests {
    use super::axis_table::AxisTableMap;
    use super::*;
    use Direction::{Forward as F, Reverse as R};

    /// Uniform numbers in [0, 1) from a xorshift generator (Marsaglia
    /// 2003): reproducible random cases.
    fn uniform(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// Tables of 0 … 100 mm in steps of 10 (X, Y), forward and reverse
    /// different, and a Z reverse table of one point.
    fn map(clamp: bool) -> AxisTableMap {
        let mut csv = String::from("axis,direction,position_mm,ex_um,ey_um,ez_um\n");
        for (axis, dir, k) in [("X", "forward", 1.0), ("X", "reverse", -0.7)] {
            for i in 0..=10 {
                let p = 10.0 * f64::from(i);
                let e = k * (p * 0.031).sin() * 3.0;
                csv += &format!("{axis},{dir},{p},{e},{},{}\n", 0.3 * e, -0.1 * e);
            }
        }
        for (axis, dir, k) in [("Y", "forward", 0.4), ("Y", "reverse", 1.3)] {
            for i in 0..=10 {
                let p = 10.0 * f64::from(i);
                let e = k * (p * 0.017).cos();
                csv += &format!("{axis},{dir},{p},{},{e},{}\n", 0.2 * e, 0.05 * e);
            }
        }
        csv += "Z,forward,0,0.1,0.2,0.3\nZ,forward,100,0.3,0.1,-0.2\n\
                Z,reverse,0,0.5,0.4,0.9\nZ,reverse,100,0.5,0.4,0.9\n";
        let mut m = AxisTableMap::from_csv(&csv, "m.csv").unwrap();
        m.clamp = clamp;
        // A table of one point (the file format asks for two; the type
        // allows it).
        m.axes[2].reverse = axis_table::Table {
            positions_mm: vec![0.0],
            errors_um: vec![Vec3::new(0.5, 0.4, 0.9)],
        };
        m
    }

    /// The next `f64` up, by hand: 1 + 2⁻⁵² above 1, −1 + 2⁻⁵³ above −1
    /// (the spacing halves below 1 in magnitude), the least subnormal
    /// above either zero, +∞ above the largest finite value; NaN and +∞
    /// stay.
    #[test]
    fn next_up_is_the_next_float() {
        assert_eq!(next_up(1.0), 1.0 + f64::EPSILON);
        assert_eq!(next_up(-1.0), -1.0 + f64::EPSILON / 2.0);
        assert_eq!(next_up(0.0), f64::from_bits(1));
        assert_eq!(next_up(-0.0), f64::from_bits(1));
        assert_eq!(next_up(-f64::from_bits(1)), -0.0);
        assert_eq!(next_up(f64::MAX), f64::INFINITY);
        assert_eq!(next_up(f64::NEG_INFINITY), f64::MIN);
        assert_eq!(next_up(f64::INFINITY), f64::INFINITY);
        assert!(next_up(f64::NAN).is_nan());
        assert_eq!(next_up(100.0), 100.0 + 2f64.powi(-46));
    }

    /// Where a kept cell spans an interval no table point lies strictly
    /// inside it (the second method: a scan of the table's points,
    /// [`ErrorModel::knots_mm`]): intervals around a 20,000-point walk in
    /// random states, both directions of every axis, the Z reverse table
    /// of one point (whose cell spans nothing). Asserts that the cells
    /// spanned many intervals (more than 20,000) and left many to the
    /// search (more than 5,000).
    #[test]
    fn a_kept_cell_spans_no_table_point() {
        let m = map(false);
        let mut rnd = uniform(0x5eed_f0ce_1100);
        let mut cells = AxisCells::default();
        let mut q = Vec3::new(50.0, 50.0, 50.0);
        let (mut spanned, mut not) = (0, 0);
        for _ in 0..20_000 {
            for a in 0..3 {
                q[a] = (q[a] + (rnd() - 0.5) * 4.0).clamp(0.0, 100.0);
            }
            let s = [0, 1, 2].map(|_| if rnd() < 0.5 { F } else { R });
            // Keeps the cells of `q` (a point outside a table keeps none).
            let _ = cells.deviation_um(&m, q, s, Components::All);
            for a in 0..3 {
                for d in [F, R] {
                    let x = q[a] + (rnd() - 0.5) * 6.0;
                    let y = x + rnd() * [0.01, 1.0, 8.0][(rnd() * 3.0) as usize % 3];
                    if x >= y {
                        continue;
                    }
                    let inside = m.knots_mm(a, d).iter().any(|k| x < *k && *k < y);
                    if cells.spans_mm(a, d, x, y) {
                        spanned += 1;
                        assert!(!inside, "axis {a} {d:?}: [{x}, {y}]");
                    } else {
                        not += 1;
                    }
                }
            }
        }
        assert!(spanned > 20_000 && not > 5_000, "{spanned} {not}");
    }

    /// A value asked for again is the map's own lookup to the bit (the
    /// second method): on a 20,000-point walk in random states, each point
    /// asked for once or twice more, later, with its state or another,
    /// through the bare map and through [`WithTool`], clamped and not
    /// (errors outside the table are the map's, never remembered). Asserts
    /// that remembered values were given back (more than 10,000 times).
    #[test]
    fn values_asked_again_are_the_maps_to_the_bit() {
        for clamp in [false, true] {
            let m = map(clamp);
            let with_tool = WithTool {
                model: &m,
                tool_length_offset_mm: Vec3::new(0.0, 0.0, 50.0),
            };
            let mut rnd = uniform(0x9e37_79b9_7f4a_7c15);
            let mut cells = AxisCells::default();
            let mut q = Vec3::new(50.0, 50.0, 50.0);
            let mut earlier: Vec<(Vec3, Directions)> = Vec::new();
            let (mut again, mut errors) = (0, 0);
            for k in 0..20_000 {
                let step = [1e-4, 0.3, 20.0][k % 3];
                for a in 0..3 {
                    q[a] = if k % 89 == 0 {
                        [0.0, 10.0, 100.0, -1e-3, 100.001][k % 5]
                    } else {
                        (q[a] + (rnd() - 0.5) * step).clamp(0.0, 100.0)
                    };
                }
                let s = [0, 1, 2].map(|_| if rnd() < 0.5 { F } else { R });
                earlier.push((q, s));
                // The point itself, then some of the last six again, in
                // their own state or with one axis switched.
                let mut asks = vec![(q, s)];
                for _ in 0..3 {
                    let back = (rnd() * 6.0) as usize;
                    if let Some(&(p, mut sp)) = earlier.iter().rev().nth(back) {
                        if rnd() < 0.3 {
                            let a = (rnd() * 3.0) as usize % 3;
                            sp[a] = sp[a].flipped();
                        }
                        asks.push((p, sp));
                    }
                }
                for (p, sp) in asks {
                    let bits = |v: Vec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
                    let known = cells.again.iter().any(|kept| kept.holds(Again::key(p, sp)));
                    let model: &dyn ErrorModel = if k % 2 == 0 { &m } else { &with_tool };
                    let kept = cells.deviation_again_um(model, p, sp);
                    let plain = m.deviation_um(p, sp, Components::All);
                    match (kept, plain) {
                        (Ok(a), Ok(b)) => {
                            again += usize::from(known);
                            assert_eq!(bits(a), bits(b), "{p:?} {sp:?}");
                        }
                        (Err(a), Err(b)) => {
                            errors += 1;
                            assert!(!known);
                            assert_eq!(a, b);
                        }
                        (a, b) => panic!("{p:?} {sp:?}: {a:?} against {b:?}"),
                    }
                }
            }
            assert!(again > 10_000, "{again}");
            assert!(clamp || errors > 100, "{errors}");
        }
    }

    /// The value kept at an end is the map's own lookup to the bit (the
    /// second method): 20,000 points in random states, each asked for
    /// once, twice, or again after another point, through the bare map
    /// and through [`WithTool`], clamped and not. Asserts that the kept
    /// value was given back (more than 2,000 times).
    #[test]
    fn a_value_kept_at_an_end_is_the_maps_to_the_bit() {
        for clamp in [false, true] {
            let m = map(clamp);
            let with_tool = WithTool {
                model: &m,
                tool_length_offset_mm: Vec3::new(0.0, 0.0, 50.0),
            };
            let mut rnd = uniform(0xdead_beef_cafe_f00d);
            let mut cells = AxisCells::default();
            let (mut q, mut s) = (Vec3::new(50.0, 50.0, 50.0), [F; 3]);
            let mut kept_back = 0;
            for k in 0..20_000 {
                let (p, sp) = match k % 4 {
                    // The same point again, or in another state.
                    1 => (q, s),
                    2 if rnd() < 0.5 => (q, [R, F, R]),
                    _ => {
                        for a in 0..3 {
                            q[a] = if k % 89 == 0 {
                                [0.0, 10.0, 100.0, -1e-3, 100.001][k % 5]
                            } else {
                                (q[a] + (rnd() - 0.5) * 5.0).clamp(0.0, 100.0)
                            };
                        }
                        s = [0, 1, 2].map(|_| if rnd() < 0.5 { F } else { R });
                        (q, s)
                    }
                };
                let known = cells.end.holds(Again::key(p, sp));
                let end = cells.end_um(p, sp);
                assert_eq!(end.is_some(), known);
                let model: &dyn ErrorModel = if k % 2 == 0 { &m } else { &with_tool };
                let kept = cells.deviation_end_um(model, p, sp);
                let plain = m.deviation_um(p, sp, Components::All);
                let bits = |v: Vec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
                match (kept, plain) {
                    (Ok(a), Ok(b)) => {
                        kept_back += usize::from(known);
                        assert_eq!(bits(a), bits(b), "{p:?} {sp:?}");
                        assert!(end.is_none_or(|e| bits(e) == bits(b)));
                    }
                    (Err(a), Err(b)) => {
                        assert!(!known);
                        assert_eq!(a, b);
                    }
                    (a, b) => panic!("{p:?} {sp:?}: {a:?} against {b:?}"),
                }
            }
            // A quarter of the asks repeat the point before; unclamped,
            // half the states are outside the Z reverse table (not kept).
            assert!(kept_back > 2_000, "{kept_back}");
        }
    }

    /// The map, counting the cells it is asked for.
    struct Counting<'a> {
        map: &'a AxisTableMap,
        lookups: std::sync::atomic::AtomicUsize,
    }

    impl ErrorModel for Counting<'_> {
        fn deviation_um(&self, q: Vec3, s: Directions, c: Components) -> Result<Vec3, ModelError> {
            self.map.deviation_um(q, s, c)
        }
        fn range_mm(&self) -> [[f64; 2]; 3] {
            self.map.range_mm()
        }
        fn axis_cell(&self, axis: usize, d: Direction, x_mm: f64) -> Option<Cell> {
            self.lookups
                .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            self.map.axis_cell(axis, d, x_mm)
        }
    }

    /// Points that go back and forth across table points (as a split
    /// evaluates a move at a table point, which opens the next cell, and
    /// then inside the cell before it) give the map's own lookup to the
    /// bit (the second method), and each cell is looked up once: X visits
    /// the cells 0 … 10 and 10 … 20 mm, Y 40 … 50 and 50 … 60 mm, Z the
    /// one cell 0 … 100 mm, forward, so 5 lookups by count (a single kept
    /// cell per axis would look one up on most of the 3,000 points).
    #[test]
    fn points_back_and_forth_across_a_table_point_look_each_cell_up_once() {
        let m = map(false);
        let counting = Counting {
            map: &m,
            lookups: std::sync::atomic::AtomicUsize::new(0),
        };
        let mut rnd = uniform(0x0123_4567_89ab_cdef);
        let mut cells = AxisCells::default();
        let bits = |v: Vec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
        for k in 0..3_000 {
            let q = match k % 3 {
                0 => Vec3::new(10.0, 50.0, 50.0),
                1 => Vec3::new(10.0 - rnd(), 50.0 - rnd(), 50.0 - rnd()),
                _ => Vec3::new(10.0 + rnd(), 50.0 + rnd(), 50.0 + rnd()),
            };
            let c = if k % 5 == 0 {
                Components::PositioningOnly
            } else {
                Components::All
            };
            let kept = cells.deviation_um(&counting, q, ALL_FORWARD, c).unwrap();
            let plain = m.deviation_um(q, ALL_FORWARD, c).unwrap();
            assert_eq!(bits(kept), bits(plain), "{q:?} {c:?}");
        }
        let lookups = counting.lookups.load(std::sync::atomic::Ordering::Relaxed);
        assert_eq!(lookups, 5);
    }

    /// By hand: X forward goes 0 → 2 µm (along X) over 0 … 10 mm, so at
    /// 2.5 mm the cell gives 0.5 µm; Y and Z tables are zero.
    #[test]
    fn a_cell_value_is_the_interpolation() {
        let m = AxisTableMap::from_csv(
            "axis,direction,position_mm,ex_um,ey_um,ez_um\n\
             X,both,0,0,0,0\nX,both,10,2,0,0\nY,both,0,0,0,0\nY,both,10,0,0,0\n\
             Z,both,0,0,0,0\nZ,both,10,0,0,0\n",
            "m.csv",
        )
        .unwrap();
        let mut cells = AxisCells::default();
        let e = cells
            .deviation_um(&m, Vec3::new(2.5, 1.0, 1.0), ALL_FORWARD, Components::All)
            .unwrap();
        assert_eq!(e, Vec3::new(0.5, 0.0, 0.0));
    }

    /// The cells kept from point to point give the map's own lookup to the
    /// bit (the second method): on 20,000 points that walk in small and
    /// large steps, land on table points, leave the tables (clamped, or
    /// out of range: the same error), in random direction states, both
    /// component sets; a Z reverse table of one point (its value only at
    /// 0, out of range elsewhere); and through a model without cells.
    #[test]
    fn kept_cells_give_the_maps_values_to_the_bit() {
        for clamp in [false, true] {
            let m = map(clamp);
            let with_tool = WithTool {
                model: &m,
                tool_length_offset_mm: Vec3::new(0.0, 0.0, 50.0),
            };
            let mut rnd = uniform(0x2545_f491_4f6c_dd1d);
            let mut cells = AxisCells::default();
            let mut q = Vec3::new(50.0, 50.0, 50.0);
            let (mut hits, mut errors) = (0, 0);
            for k in 0..20_000 {
                let step = match k % 4 {
                    0 => 1e-3,
                    1 => 0.5,
                    2 => 7.0,
                    _ => 40.0,
                };
                for a in 0..3 {
                    q[a] += (rnd() - 0.5) * step;
                    q[a] = if k % 97 == 0 {
                        // On a table point, or just outside the table.
                        [0.0, 10.0, 100.0, -1e-3, 100.001][k % 5]
                    } else {
                        q[a].clamp(0.0, 100.0)
                    };
                }
                let s = [0, 1, 2].map(|_| if rnd() < 0.5 { F } else { R });
                let c = if k % 3 == 0 {
                    Components::PositioningOnly
                } else {
                    Components::All
                };
                let model: &dyn ErrorModel = if k % 2 == 0 { &m } else { &with_tool };
                let kept = cells.deviation_um(model, q, s, c);
                let plain = m.deviation_um(q, s, c);
                match (kept, plain) {
                    (Ok(a), Ok(b)) => {
                        hits += 1;
                        let bits = |v: Vec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
                        assert_eq!(bits(a), bits(b), "{q:?} {s:?} {c:?}");
                    }
                    (Err(a), Err(b)) => {
                        errors += 1;
                        assert_eq!(a, b);
                    }
                    (a, b) => panic!("{q:?} {s:?}: {a:?} against {b:?}"),
                }
            }
            // Z reverse (half the states) has one point: out of range
            // elsewhere unless clamped.
            assert!(hits > 8_000, "{hits}");
            assert!(clamp || errors > 100, "{errors}");
        }
        // A model without cells is evaluated itself.
        let no_cells = ByDirection(|s: Directions| Vec3::new(s[0].sign(), 0.0, 0.0));
        let mut cells = AxisCells::default();
        let e = cells
            .deviation_um(&no_cells, Vec3::ZERO, [R, F, F], Components::All)
            .unwrap();
        assert_eq!(e, Vec3::new(-1.0, 0.0, 0.0));
    }
}
