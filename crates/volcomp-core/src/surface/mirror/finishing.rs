//! The finishing program: the ball-end tool, the contact of each CL point
//! with the nominal surface, and the rewrite of the program through
//! [`compensate_program`].

use super::method::DeviationField;
use super::nominal::NominalSurface;
use super::{advice, fmt_point, method_error, MirrorError};
use crate::compensate::solve::Method;
use crate::compensate::{
    compensate_program, CompensateOptions, CompensateSummary, DirectionPolicy, ProgramStyle,
    Segmentation,
};
use crate::error::MapFileError;
use crate::error::ModelError;
use crate::model::{Components, Directions, ErrorModel};
use std::io::{BufRead, Write};
use std::sync::Mutex;
use volcomp_gcode::{MotionKind, MotionSource, Vec3, Walker};

/// Which point of the ball-end mill the program's coordinates give.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ClPoint {
    /// The tool tip (most CAM posts): the ball centre is `r` above it (+Z).
    Tip,
    /// The ball centre.
    Centre,
}

/// A ball-end mill.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BallTool {
    /// Ball radius (mm).
    pub radius_mm: f64,
    /// Which point the program's coordinates give.
    pub cl: ClPoint,
}

/// A CL point that touches the nominal surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// Parameter u of the contact point.
    pub u: f64,
    /// Parameter v of the contact point.
    pub v: f64,
    /// Contact point on `S_F` (mm).
    pub point: Vec3,
    /// Outward normal there.
    pub normal: Vec3,
    /// How far the ball stands off `S_F` as commanded (mm; 0 for an exact CL point).
    pub standoff_mm: f64,
    /// `δ` at the contact point (µm).
    pub offset_um: f64,
    /// Whether the contact point lies in the probed rectangle.
    pub inside_field: bool,
}

/// The finishing-pass displacement `δ·n` at each CL point, as an
/// [`ErrorModel`] so that [`compensate_program`] writes it: with the direct
/// method the command is `q = t − e(t)`, and `e(t) = −δ·n` at the contact
/// point of `t` (zero when `t` does not touch the surface).
pub struct SurfaceModel<'a> {
    nominal: &'a NominalSurface,
    field: &'a DeviationField,
    tool: BallTool,
    frame_offset_mm: Vec3,
    contact_tolerance_mm: f64,
    hint: Mutex<Option<(f64, f64)>>,
}

impl<'a> SurfaceModel<'a> {
    /// A model for a program whose program frame is the axis frame minus
    /// `frame_offset_mm` (see [`program_frame_offset`]). A CL point is in
    /// contact when its ball is within `contact_tolerance_mm` of `S_F`.
    pub fn new(
        nominal: &'a NominalSurface,
        field: &'a DeviationField,
        tool: BallTool,
        frame_offset_mm: Vec3,
        contact_tolerance_mm: f64,
    ) -> Result<Self, MirrorError> {
        let r = tool.radius_mm;
        if !(r.is_finite() && r > 0.0) {
            return Err(method_error(
                format!("the tool radius must be positive; got {r} mm"),
                advice::TOOL_RADIUS_POSITIVE,
            ));
        }
        if !(contact_tolerance_mm.is_finite() && contact_tolerance_mm > 0.0) {
            return Err(method_error(
                format!("the contact tolerance must be positive; got {contact_tolerance_mm} mm"),
                advice::CONTACT_TOLERANCE_POSITIVE,
            ));
        }
        if let Some((rho, at)) = nominal.min_concave_radius() {
            if r >= rho {
                return Err(method_error(
                    format!(
                        "the ball radius {r} mm exceeds the nominal surface's smallest concave radius of curvature, {rho:.4} mm at {}: the ball cannot touch the surface there, so CL points have no single contact point",
                        fmt_point(at)
                    ),
                    advice::BALL_TOO_LARGE,
                ));
            }
        }
        Ok(Self {
            nominal,
            field,
            tool,
            frame_offset_mm,
            contact_tolerance_mm,
            hint: Mutex::new(None),
        })
    }

    /// The contact of the CL point `p` (program frame, mm), if it touches `S_F`.
    pub fn contact(&self, p: Vec3) -> Option<Contact> {
        let r = self.tool.radius_mm;
        let centre = match self.tool.cl {
            ClPoint::Tip => p + Vec3::new(0.0, 0.0, r),
            ClPoint::Centre => p,
        };
        let mut hint = self.hint.lock().unwrap_or_else(|e| e.into_inner());
        let foot = self
            .nominal
            .project(centre, r + self.contact_tolerance_mm, *hint)?;
        *hint = Some((foot.u, foot.v));
        let standoff = foot.height_mm - r;
        if !foot.orthogonal || standoff.abs() > self.contact_tolerance_mm {
            return None;
        }
        Some(Contact {
            u: foot.u,
            v: foot.v,
            point: foot.point,
            normal: foot.normal,
            standoff_mm: standoff,
            offset_um: self.field.offset_um(foot.u, foot.v),
            inside_field: self.field.contains(foot.u, foot.v),
        })
    }

    /// The displacement of the CL point `p` (program frame, mm).
    pub fn displacement_mm(&self, p: Vec3) -> Vec3 {
        self.contact(p)
            .map_or(Vec3::ZERO, |c| c.normal * (c.offset_um * 1e-3))
    }

    /// Program frame of axis-frame `q`.
    pub fn program_point(&self, q: Vec3) -> Vec3 {
        q - self.frame_offset_mm
    }
}

impl ErrorModel for SurfaceModel<'_> {
    fn deviation_um(&self, q_mm: Vec3, _s: Directions, _c: Components) -> Result<Vec3, ModelError> {
        Ok(self.displacement_mm(self.program_point(q_mm)) * -1e3)
    }

    fn range_mm(&self) -> [[f64; 2]; 3] {
        [[-1e9, 1e9]; 3]
    }
}

/// The frame offset (axis − program frame, mm) of a program's feed moves,
/// which must not change: the surface is given in one program frame.
pub fn program_frame_offset<R: BufRead>(
    walker: &mut Walker<R>,
    file: &str,
) -> Result<Vec3, MirrorError> {
    let mut first: Option<(Vec3, u64)> = None;
    while let Some(ev) = walker.next_line()? {
        if ev.after_end {
            continue;
        }
        let cuts = ev
            .motions
            .iter()
            .any(|m| m.source == MotionSource::Program && !matches!(m.kind, MotionKind::Rapid));
        if !cuts {
            continue;
        }
        let o = ev.interp.frame_offset_mm();
        if ev.interp.rotation_deg() != 0.0 {
            return Err(MirrorError::File(MapFileError {
                file: file.into(),
                row: ev.number as usize,
                column: 1,
                message: format!(
                    "this cut is in a rotated coordinate system (G10 L2 R{}); the surface mirror relates program and axis frames by a translation only",
                    ev.interp.rotation_deg()
                ),
                help: "post the finishing program without the rotation".into(),
                source_line: String::new(),
                caret_byte: 0,
            }));
        }
        match first {
            None => first = Some((o, ev.number)),
            Some((f, line)) if (f - o).norm() > 1e-9 => {
                return Err(MirrorError::File(MapFileError {
                    file: file.into(),
                    row: ev.number as usize,
                    column: 1,
                    message: format!(
                        "the program frame changes here (work offset, tool length or G92 differ from line {line}'s)"
                    ),
                    help: "the surface and the points are in one program frame: compensate each setup's part of the program separately".into(),
                    source_line: String::new(),
                    caret_byte: 0,
                }));
            }
            _ => {}
        }
    }
    Ok(first.map_or(Vec3::ZERO, |f| f.0))
}

/// Options of [`compensate_finishing`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FinishingOptions {
    /// Split feed moves into pieces of at most this length (mm); `None`: do
    /// not split (arcs are still linearised).
    pub segment_length_mm: Option<f64>,
    /// Chord tolerance for linearising arcs (mm).
    pub chord_tolerance_mm: f64,
    /// Written decimals (`None`: 5 in mm, 6 in inch).
    pub decimals: Option<u8>,
    /// Tag inserted lines with `(volcomp Ln)`.
    pub trace_comments: bool,
}

impl Default for FinishingOptions {
    fn default() -> Self {
        Self {
            segment_length_mm: Some(2.0),
            chord_tolerance_mm: 1e-3,
            decimals: None,
            trace_comments: true,
        }
    }
}

/// What [`compensate_finishing`] did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FinishingSummary {
    /// Lines and points of the rewrite.
    pub program: CompensateSummary,
    /// Feed-move points (CL points and split points).
    pub feed_points: u64,
    /// Of those, the ones touching the nominal surface (moved).
    pub in_contact: u64,
    /// Of those, the ones outside the probed rectangle (moved by the edge value).
    pub outside_field: u64,
    /// Largest `δ` applied (µm).
    pub max_offset_um: f64,
    /// Smallest `δ` applied (µm).
    pub min_offset_um: f64,
}

/// Rewrites a ball-end finishing program so that every CL point touching the
/// nominal surface moves by `δ·n` at its contact point; every other byte is
/// kept (the rewrite is [`compensate_program`]'s, with the direct method and
/// no backlash take-up). Fails when no CL point touches the surface; on any
/// failure what was written to `out` is incomplete (write to a temporary
/// file and keep it only on success).
pub fn compensate_finishing<R: BufRead>(
    walker: &mut Walker<R>,
    file: &str,
    style: &ProgramStyle,
    model: &SurfaceModel<'_>,
    options: &FinishingOptions,
    out: &mut dyn Write,
) -> Result<FinishingSummary, MirrorError> {
    let segmentation = match options.segment_length_mm {
        Some(l) if l.is_finite() && l > 0.0 => Segmentation::MaxLength(l),
        Some(l) => {
            return Err(method_error(
                format!("the segment length must be positive; got {l} mm"),
                advice::SEGMENT_LENGTH_POSITIVE,
            ))
        }
        None => Segmentation::Off,
    };
    let copts = CompensateOptions {
        method: Method::Direct,
        segmentation,
        chord_tolerance_mm: options.chord_tolerance_mm,
        // The mirrored surface is followed along chords, as before.
        arcs_as_arcs: false,
        decimals: options.decimals,
        // |δ| never exceeds the largest control coefficient (convex hull).
        max_correction_mm: model.field.max_abs_um() * 1e-3 + 1e-3,
        directions: DirectionPolicy::Commanded,
        take_up: false,
        fold_take_ups: false,
        take_up_tolerance_mm: None,
        // Fixed segmentation and chords: no contour tolerance to tighten.
        exact_contour_tolerance_mm: None,
        drill_tolerance_mm: crate::compensate::DEFAULT_DRILL_TOLERANCE_UM * 1e-3,
        planner: Default::default(),
        trace_comments: options.trace_comments,
        // The direct step is exact for a displacement field (no iteration).
        max_residual_um: None,
        // A feed move on an axis never set is refused, as in compensation.
        allow_uncompensated_axes: false,
    };
    let mut s = FinishingSummary {
        min_offset_um: f64::INFINITY,
        max_offset_um: f64::NEG_INFINITY,
        ..FinishingSummary::default()
    };
    let program = compensate_program(walker, file, model, style, &copts, out, |rec| {
        if rec.rapid {
            return;
        }
        s.feed_points += 1;
        if let Some(c) = model.contact(model.program_point(rec.target_mm)) {
            s.in_contact += 1;
            s.outside_field += u64::from(!c.inside_field);
            s.max_offset_um = s.max_offset_um.max(c.offset_um);
            s.min_offset_um = s.min_offset_um.min(c.offset_um);
        }
    })?;
    if s.in_contact == 0 {
        return Err(MirrorError::InFile {
            file: file.into(),
            message: format!(
                "none of the program's {} feed points touches the nominal surface (ball radius {} mm, CL point at the {})",
                s.feed_points,
                model.tool.radius_mm,
                match model.tool.cl {
                    ClPoint::Tip => "tip",
                    ClPoint::Centre => "ball centre",
                }
            ),
            help: advice::NO_CONTACT.into(),
        });
    }
    s.program = program;
    Ok(s)
}
