//! The artifacts a shop probes and where they sit: a TOML description
//! (docs/probing.md, "Artifacts"), read with every error located.
//!
//! ```toml
//! artifact = "spheres"            # reference-sphere | spheres | gauge | square
//! name = "plate"                  # the label in the probing log
//! sphere_diameter_mm = 25         # spheres: nominal diameter of each
//! spheres_mm = [[0, 0, 0], [150, 0, 0], [0, 150, 0], [150, 150, 0]]
//! [certificate]                   # optional: calibrated values and their uncertainty
//! spheres_mm = [[0, 0, 0], [150.0012, 0, 0], [0, 149.9991, 0], [150.0003, 150.0008, 0]]
//! u_um = 0.5
//! [[placements]]
//! name = "p1"
//! origin_mm = [120, 80, 40]       # machine coordinates of the artifact's origin
//! x_axis = [1, 0, 0]              # its x and y directions in machine coordinates
//! y_axis = [0, 1, 0]
//! ```
//!
//! Positions are *machine coordinates of the probe tip centre*: the axis
//! positions the DRO shows (in machine coordinates, with the probe's tool
//! length offset applied) when the tip's centre is at that point — the axis
//! frame of docs/design.md, "Frames".
//!
//! Every artifact lives in its own frame: spheres have their free side
//! (the pole, away from the stem or plate) towards the frame's +z; a gauge
//! has its faces on the frame's x axis, a square its two measured edges
//! along +x and +y from the corner at the origin (outer faces, looking
//! towards −y and −x), both touched in the frame's z = 0 plane with the
//! clearance above them along machine +Z. A placement maps the frame into
//! the machine: `origin_mm`, `x_axis`, `y_axis` (z = x × y); a square turned
//! over is a placement with `y_axis` reversed.

use crate::error::MapFileError;
use std::ops::Range;
use toml::Spanned;
use volcomp_gcode::Vec3;

/// What an artifact is.
#[derive(Debug, Clone, PartialEq)]
pub enum Kind {
    /// One calibrated sphere for the probe's calibration: effective tip
    /// radius, pre-travel per direction, and the axes' reversal values.
    ReferenceSphere {
        /// Certified diameter (mm).
        diameter_mm: f64,
        /// Its standard uncertainty (µm).
        u_diameter_um: f64,
    },
    /// Spheres at fixed positions: one sphere, a ball array, a ball plate.
    Spheres {
        /// Nominal diameter of every sphere (mm).
        diameter_mm: f64,
        /// Nominal (or certified) centres in the artifact's frame (mm).
        centres_mm: Vec<Vec3>,
        /// Certificate: standard uncertainty of each certified coordinate
        /// (µm); `None` when the centres are nominal only.
        certified_u_um: Option<f64>,
        /// Certified diameters (mm) and their uncertainty (µm), if given.
        certified_diameter: Option<(f64, f64)>,
    },
    /// Faces along the artifact's x axis: a gauge block (two faces) or a
    /// step gauge.
    Gauge {
        /// Nominal (or certified) face positions along x (mm).
        faces_mm: Vec<f64>,
        /// Which way each face looks along x: `+1.0` (+x) or `-1.0` (−x).
        facing: Vec<f64>,
        /// Where each face is touched across x: `(y, z)` in the artifact
        /// frame (mm), e.g. the table beside a gauge block standing on it.
        offsets_mm: Vec<[f64; 2]>,
        /// Certificate: standard uncertainty of each face position
        /// relative to the first (µm).
        certified_u_um: Option<f64>,
        /// How far the artifact rises above its touch points (machine +Z, mm).
        height_above_mm: f64,
    },
    /// A square: two edges at right angles.
    Square {
        /// Lengths of the two measured edges from the corner (mm).
        legs_mm: [f64; 2],
        /// Inner faces measured (looking +y and +x) instead of the outer
        /// ones (looking −y and −x).
        inner: bool,
        /// How far the artifact rises above its touch points (machine +Z, mm).
        height_above_mm: f64,
        /// Certified deviation from 90° (µrad, positive when the angle
        /// between the edges is larger than 90°) and its uncertainty (µrad).
        certified: Option<(f64, f64)>,
    },
}

impl Kind {
    /// The `artifact = "…"` word.
    pub fn word(&self) -> &'static str {
        match self {
            Kind::ReferenceSphere { .. } => "reference-sphere",
            Kind::Spheres { .. } => "spheres",
            Kind::Gauge { .. } => "gauge",
            Kind::Square { .. } => "square",
        }
    }
}

/// Where an artifact sits for one set of measurements.
#[derive(Debug, Clone, PartialEq)]
pub struct Placement {
    /// Its name (letters, digits, `-`, `_`).
    pub name: String,
    /// Machine coordinates of the artifact frame's origin (mm).
    pub origin_mm: Vec3,
    /// The frame's x, y, z directions in machine coordinates (orthonormal).
    pub axes: [Vec3; 3],
}

impl Placement {
    /// Machine coordinates of a point given in the artifact's frame.
    pub fn to_machine(&self, p: Vec3) -> Vec3 {
        self.origin_mm + self.direction(p)
    }

    /// A direction of the artifact's frame in machine coordinates.
    pub fn direction(&self, v: Vec3) -> Vec3 {
        self.axes[0] * v.x + self.axes[1] * v.y + self.axes[2] * v.z
    }
}

/// An artifact and its placements.
#[derive(Debug, Clone, PartialEq)]
pub struct Artifact {
    /// The name used in the log.
    pub name: String,
    /// What it is.
    pub kind: Kind,
    /// Where it is measured, in order.
    pub placements: Vec<Placement>,
}

/// A feature of an artifact: what one group of touches measures.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Feature {
    /// Sphere `index` (0-based), centre in the artifact's frame.
    Sphere {
        /// 0-based index.
        index: usize,
        /// Centre in the artifact frame (mm).
        centre_mm: Vec3,
        /// Nominal radius (mm).
        radius_mm: f64,
    },
    /// Face `index` of a gauge: at `x_mm` on the frame's x axis, looking
    /// towards `facing` (±1) along x.
    Face {
        /// 0-based index.
        index: usize,
        /// Position along x (mm).
        x_mm: f64,
        /// `+1.0` or `-1.0`.
        facing: f64,
    },
    /// Edge `index` (0: along +x, face looking −y; 1: along +y, face
    /// looking −x) of a square, `length_mm` long.
    Edge {
        /// 0 or 1.
        index: usize,
        /// Length (mm).
        length_mm: f64,
    },
}

impl Feature {
    /// The feature's label in logs: `s1`, `f2`, `e1` (1-based).
    pub fn label(&self) -> String {
        match self {
            Feature::Sphere { index, .. } => format!("s{}", index + 1),
            Feature::Face { index, .. } => format!("f{}", index + 1),
            Feature::Edge { index, .. } => format!("e{}", index + 1),
        }
    }
}

impl Artifact {
    /// The artifact's features, in order.
    pub fn features(&self) -> Vec<Feature> {
        match &self.kind {
            Kind::ReferenceSphere { diameter_mm, .. } => vec![Feature::Sphere {
                index: 0,
                centre_mm: Vec3::ZERO,
                radius_mm: diameter_mm / 2.0,
            }],
            Kind::Spheres {
                diameter_mm,
                centres_mm,
                ..
            } => centres_mm
                .iter()
                .enumerate()
                .map(|(index, &centre_mm)| Feature::Sphere {
                    index,
                    centre_mm,
                    radius_mm: diameter_mm / 2.0,
                })
                .collect(),
            Kind::Gauge {
                faces_mm, facing, ..
            } => faces_mm
                .iter()
                .zip(facing)
                .enumerate()
                .map(|(index, (&x_mm, &facing))| Feature::Face {
                    index,
                    x_mm,
                    facing,
                })
                .collect(),
            Kind::Square { legs_mm, .. } => (0..2)
                .map(|index| Feature::Edge {
                    index,
                    length_mm: legs_mm[index],
                })
                .collect(),
        }
    }

    /// The feature labelled `label` (`s3`, `f1`, `e2`).
    pub fn feature(&self, label: &str) -> Option<Feature> {
        self.features().into_iter().find(|f| f.label() == label)
    }

    /// The placement named `name`.
    pub fn placement(&self, name: &str) -> Option<&Placement> {
        self.placements.iter().find(|p| p.name == name)
    }

    /// Whether this is the reference sphere.
    pub fn is_reference(&self) -> bool {
        matches!(self.kind, Kind::ReferenceSphere { .. })
    }
}

// ---------------------------------------------------------------------------
// Reading

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCertificate {
    spheres_mm: Option<Spanned<Vec<[f64; 3]>>>,
    faces_mm: Option<Spanned<Vec<f64>>>,
    u_um: Option<Spanned<f64>>,
    diameter_mm: Option<Spanned<f64>>,
    u_diameter_um: Option<Spanned<f64>>,
    squareness_urad: Option<Spanned<f64>>,
    u_urad: Option<Spanned<f64>>,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPlacement {
    name: Spanned<String>,
    origin_mm: Spanned<[f64; 3]>,
    x_axis: Option<Spanned<[f64; 3]>>,
    y_axis: Option<Spanned<[f64; 3]>>,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct RawArtifact {
    artifact: Spanned<String>,
    name: Spanned<String>,
    description: Option<String>,
    sphere_diameter_mm: Option<Spanned<f64>>,
    spheres_mm: Option<Spanned<Vec<[f64; 3]>>>,
    faces_mm: Option<Spanned<Vec<f64>>>,
    facing: Option<Spanned<Vec<String>>>,
    legs_mm: Option<Spanned<[f64; 2]>>,
    faces: Option<Spanned<String>>,
    offsets_mm: Option<Spanned<Vec<[f64; 2]>>>,
    height_above_mm: Option<Spanned<f64>>,
    certificate: Option<Spanned<RawCertificate>>,
    placements: Option<Vec<Spanned<RawPlacement>>>,
}

/// Largest number of features and of placements of one artifact: a ball
/// plate has tens of spheres, a shop never hundreds of placements; the
/// bound keeps the work of a plan and a fit known before it starts.
pub const MAX_FEATURES: usize = 400;
/// See [`MAX_FEATURES`].
pub const MAX_PLACEMENTS: usize = 100;

struct At<'a> {
    text: &'a str,
    file: &'a str,
}

impl At<'_> {
    fn error(&self, span: Range<usize>, message: impl Into<String>, help: &str) -> MapFileError {
        let before = &self.text[..span.start.min(self.text.len())];
        let row = before.matches('\n').count() + 1;
        let line_start = before.rfind('\n').map_or(0, |i| i + 1);
        let line = self.text[line_start..].lines().next().unwrap_or("");
        let col = before[line_start..].chars().count() + 1;
        MapFileError::new(self.file, row, col, message, help)
            .with_source(line, span.start.saturating_sub(line_start).min(line.len()))
    }
}

fn vec3(a: [f64; 3]) -> Vec3 {
    Vec3::new(a[0], a[1], a[2])
}

fn finite_mm(at: &At, v: &Spanned<f64>, what: &str, positive: bool) -> Result<f64, MapFileError> {
    let x = *v.get_ref();
    if !x.is_finite() || (positive && x <= 0.0) || (!positive && x < 0.0) {
        let want = if positive {
            "positive"
        } else {
            "zero or positive"
        };
        return Err(at.error(
            v.span(),
            format!("{what} = {x}: not a {want} finite number"),
            &format!("write {what} as a {want} number"),
        ));
    }
    Ok(x)
}

fn name_ok(s: &str) -> bool {
    !s.is_empty()
        && s.len() <= 32
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
}

/// Reads an artifact description (`file` names it in errors).
pub fn parse_artifact(text: &str, file: &str) -> Result<Artifact, MapFileError> {
    let at = At { text, file };
    let raw: RawArtifact = toml::from_str(text).map_err(|e| {
        at.error(
            e.span().unwrap_or(0..0),
            e.message().to_string(),
            "see docs/probing.md, \"Artifacts\", for the keys (lengths carry _mm, uncertainties _um or _urad)",
        )
    })?;
    let name = raw.name.get_ref().clone();
    if !name_ok(&name) {
        return Err(at.error(
            raw.name.span(),
            format!("name = \"{name}\": use 1–32 letters, digits, '-' or '_'"),
            "the name is written into the probing log, where spaces and parentheses would end a field",
        ));
    }
    let cert = raw.certificate.as_ref().map(|c| c.get_ref());
    let cert_span = raw.certificate.as_ref().map_or(0..0, |c| c.span());
    let word = raw.artifact.get_ref().as_str();
    let missing = |key: &str, help: &str| {
        at.error(
            raw.artifact.span(),
            format!("artifact = \"{word}\" needs `{key}`"),
            help,
        )
    };
    let refuse_key = |present: bool, key: &str, span: Range<usize>| -> Result<(), MapFileError> {
        if present {
            return Err(at.error(
                span,
                format!("`{key}` does not belong to artifact = \"{word}\""),
                "remove it, or change the artifact kind",
            ));
        }
        Ok(())
    };
    let span_of = |o: &Option<Spanned<Vec<[f64; 3]>>>| o.as_ref().map_or(0..0, |s| s.span());
    let kind = match word {
        "reference-sphere" => {
            refuse_key(raw.spheres_mm.is_some(), "spheres_mm", span_of(&raw.spheres_mm))?;
            refuse_key(
                raw.faces_mm.is_some() || raw.legs_mm.is_some() || raw.facing.is_some(),
                "faces_mm/legs_mm/facing",
                raw.artifact.span(),
            )?;
            let c = cert.ok_or_else(|| {
                missing(
                    "[certificate] diameter_mm and u_diameter_um",
                    "the probe is calibrated against the sphere's certified diameter: copy it and its standard uncertainty from the certificate",
                )
            })?;
            let d = c.diameter_mm.as_ref().ok_or_else(|| {
                at.error(
                    cert_span.clone(),
                    "the certificate of a reference sphere needs diameter_mm",
                    "copy the certified diameter (mm)",
                )
            })?;
            let u = c.u_diameter_um.as_ref().ok_or_else(|| {
                at.error(
                    cert_span.clone(),
                    "the certificate of a reference sphere needs u_diameter_um",
                    "copy the standard uncertainty of the diameter (µm; an expanded uncertainty U with k = 2 is twice it)",
                )
            })?;
            Kind::ReferenceSphere {
                diameter_mm: finite_mm(&at, d, "diameter_mm", true)?,
                u_diameter_um: finite_mm(&at, u, "u_diameter_um", false)?,
            }
        }
        "spheres" => {
            let d = raw.sphere_diameter_mm.as_ref().ok_or_else(|| {
                missing("sphere_diameter_mm", "give the nominal diameter of the spheres (mm)")
            })?;
            let d = finite_mm(&at, d, "sphere_diameter_mm", true)?;
            let nominal = raw.spheres_mm.as_ref().ok_or_else(|| {
                missing(
                    "spheres_mm",
                    "list the sphere centres in the artifact's frame, e.g. spheres_mm = [[0, 0, 0], [150, 0, 0]]",
                )
            })?;
            let mut centres: Vec<Vec3> = nominal.get_ref().iter().map(|&a| vec3(a)).collect();
            check_points(&at, nominal.span(), &centres, d)?;
            let mut certified_u_um = None;
            let mut certified_diameter = None;
            if let Some(c) = cert {
                if let Some(cs) = &c.spheres_mm {
                    let list: Vec<Vec3> = cs.get_ref().iter().map(|&a| vec3(a)).collect();
                    if list.len() != centres.len() {
                        return Err(at.error(
                            cs.span(),
                            format!(
                                "the certificate lists {} spheres, spheres_mm {}",
                                list.len(),
                                centres.len()
                            ),
                            "give the certified centre of every sphere, in the same order",
                        ));
                    }
                    check_points(&at, cs.span(), &list, d)?;
                    for (k, (a, b)) in list.iter().zip(&centres).enumerate() {
                        if (*a - *b).norm() > 1.0 {
                            return Err(at.error(
                                cs.span(),
                                format!(
                                    "certified sphere {} lies {:.3} mm from its nominal centre",
                                    k + 1,
                                    (*a - *b).norm()
                                ),
                                "check the order and the frame of the certificate's centres (they may differ from nominal by µm, not mm)",
                            ));
                        }
                    }
                    let u = c.u_um.as_ref().ok_or_else(|| {
                        at.error(
                            cs.span(),
                            "certified centres need u_um",
                            "give the standard uncertainty of a certified coordinate (µm)",
                        )
                    })?;
                    certified_u_um = Some(finite_mm(&at, u, "u_um", false)?);
                    centres = list;
                }
                if let Some(dc) = &c.diameter_mm {
                    let u = c.u_diameter_um.as_ref().ok_or_else(|| {
                        at.error(
                            dc.span(),
                            "a certified diameter needs u_diameter_um",
                            "give its standard uncertainty (µm)",
                        )
                    })?;
                    certified_diameter = Some((
                        finite_mm(&at, dc, "diameter_mm", true)?,
                        finite_mm(&at, u, "u_diameter_um", false)?,
                    ));
                }
            }
            Kind::Spheres {
                diameter_mm: certified_diameter.map_or(d, |c| c.0),
                centres_mm: centres,
                certified_u_um,
                certified_diameter,
            }
        }
        "gauge" => {
            let faces = raw.faces_mm.as_ref().ok_or_else(|| {
                missing(
                    "faces_mm",
                    "list the face positions along the artifact's x axis, e.g. faces_mm = [0, 100] for a 100 mm gauge block",
                )
            })?;
            let facing_raw = raw.facing.as_ref().ok_or_else(|| {
                missing(
                    "facing",
                    "say which way each face looks along x: facing = [\"-\", \"+\"] for a gauge block (outer faces)",
                )
            })?;
            let mut x: Vec<f64> = faces.get_ref().clone();
            if x.len() < 2 || x.len() > MAX_FEATURES {
                return Err(at.error(
                    faces.span(),
                    format!("{} faces: a gauge has 2 … {MAX_FEATURES}", x.len()),
                    "list at least the two faces of a gauge block",
                ));
            }
            if x.iter().any(|v| !v.is_finite()) || x.windows(2).any(|w| w[1] <= w[0]) {
                return Err(at.error(
                    faces.span(),
                    "face positions must be finite and strictly increasing",
                    "list the faces in order along x",
                ));
            }
            let facing: Vec<f64> = facing_raw
                .get_ref()
                .iter()
                .map(|s| match s.as_str() {
                    "+" => Ok(1.0),
                    "-" => Ok(-1.0),
                    o => Err(at.error(
                        facing_raw.span(),
                        format!("facing \"{o}\": write \"+\" or \"-\""),
                        "\"+\": the face looks towards +x (probed moving −x); \"-\": towards −x",
                    )),
                })
                .collect::<Result<_, _>>()?;
            if facing.len() != x.len() {
                return Err(at.error(
                    facing_raw.span(),
                    format!("{} facings for {} faces", facing.len(), x.len()),
                    "give one facing per face",
                ));
            }
            let mut certified_u_um = None;
            if let Some(c) = cert {
                if let Some(cf) = &c.faces_mm {
                    if cf.get_ref().len() != x.len()
                        || cf.get_ref().iter().zip(&x).any(|(a, b)| (a - b).abs() > 1.0 || !a.is_finite())
                    {
                        return Err(at.error(
                            cf.span(),
                            "the certified faces do not match faces_mm (one per face, within 1 mm of nominal)",
                            "copy the certified position of every face, in order",
                        ));
                    }
                    let u = c.u_um.as_ref().ok_or_else(|| {
                        at.error(
                            cf.span(),
                            "certified faces need u_um",
                            "give the standard uncertainty of a certified face position (µm)",
                        )
                    })?;
                    certified_u_um = Some(finite_mm(&at, u, "u_um", false)?);
                    x = cf.get_ref().clone();
                }
            }
            let offsets_mm = match &raw.offsets_mm {
                Some(o) => {
                    let v = o.get_ref().clone();
                    if v.len() != x.len() || v.iter().flatten().any(|c| !c.is_finite()) {
                        return Err(at.error(
                            o.span(),
                            format!("{} offsets for {} faces", v.len(), x.len()),
                            "give one [y, z] (mm, artifact frame) per face",
                        ));
                    }
                    v
                }
                None => vec![[0.0, 0.0]; x.len()],
            };
            Kind::Gauge {
                faces_mm: x,
                facing,
                offsets_mm,
                certified_u_um,
                height_above_mm: height_above(&at, &raw, word)?,
            }
        }
        "square" => {
            let legs = raw.legs_mm.as_ref().ok_or_else(|| {
                missing(
                    "legs_mm",
                    "give the lengths of the two measured edges from the corner, e.g. legs_mm = [300, 300]",
                )
            })?;
            let l = *legs.get_ref();
            if l.iter().any(|v| !v.is_finite() || *v <= 10.0) {
                return Err(at.error(
                    legs.span(),
                    "each leg must be longer than 10 mm",
                    "give the usable lengths of the two edges (mm)",
                ));
            }
            let mut certified = None;
            if let Some(c) = cert {
                if let Some(s) = &c.squareness_urad {
                    let u = c.u_urad.as_ref().ok_or_else(|| {
                        at.error(
                            s.span(),
                            "a certified squareness needs u_urad",
                            "give its standard uncertainty (µrad)",
                        )
                    })?;
                    if !s.get_ref().is_finite() {
                        return Err(at.error(s.span(), "squareness_urad is not finite", "write a number"));
                    }
                    certified = Some((*s.get_ref(), finite_mm(&at, u, "u_urad", false)?));
                }
            }
            let inner = match raw.faces.as_ref() {
                None => false,
                Some(f) => match f.get_ref().as_str() {
                    "outer" => false,
                    "inner" => true,
                    o => {
                        return Err(at.error(
                            f.span(),
                            format!("faces = \"{o}\""),
                            "write faces = \"outer\" (looking −y and −x) or \"inner\" (looking +y and +x)",
                        ))
                    }
                },
            };
            Kind::Square {
                legs_mm: l,
                inner,
                height_above_mm: height_above(&at, &raw, word)?,
                certified,
            }
        }
        o => {
            return Err(at.error(
                raw.artifact.span(),
                format!("artifact = \"{o}\" is not an artifact volcomp knows"),
                "write reference-sphere, spheres (one sphere, a ball array or plate), gauge (gauge block, step gauge) or square",
            ))
        }
    };
    let _ = raw.description;
    let raw_places = raw.placements.unwrap_or_default();
    if raw_places.is_empty() {
        return Err(at.error(
            raw.name.span(),
            "no [[placements]]: say where the artifact sits",
            "add [[placements]] with name, origin_mm, x_axis and y_axis (machine coordinates)",
        ));
    }
    if raw_places.len() > MAX_PLACEMENTS {
        return Err(at.error(
            raw_places[MAX_PLACEMENTS].span(),
            format!("more than {MAX_PLACEMENTS} placements"),
            "split the measurements into several artifact files",
        ));
    }
    let mut placements: Vec<Placement> = Vec::new();
    for rp in &raw_places {
        let p = rp.get_ref();
        let pname = p.name.get_ref().clone();
        if !name_ok(&pname) {
            return Err(at.error(
                p.name.span(),
                format!("placement name \"{pname}\": use 1–32 letters, digits, '-' or '_'"),
                "the name is written into the probing log",
            ));
        }
        if placements.iter().any(|q| q.name == pname) {
            return Err(at.error(
                p.name.span(),
                format!("placement \"{pname}\" twice"),
                "give every placement its own name",
            ));
        }
        let origin = vec3(*p.origin_mm.get_ref());
        if !origin.is_finite() {
            return Err(at.error(
                p.origin_mm.span(),
                "origin_mm is not finite",
                "write three numbers (mm)",
            ));
        }
        let x = p
            .x_axis
            .as_ref()
            .map_or(Vec3::new(1.0, 0.0, 0.0), |v| vec3(*v.get_ref()));
        let y = p
            .y_axis
            .as_ref()
            .map_or(Vec3::new(0.0, 1.0, 0.0), |v| vec3(*v.get_ref()));
        let span = p
            .y_axis
            .as_ref()
            .or(p.x_axis.as_ref())
            .map_or(rp.span(), |s| s.span());
        let (Some(xn), Some(yn)) = (x.normalized(), y.normalized()) else {
            return Err(at.error(
                span,
                "x_axis and y_axis must be non-zero vectors",
                "give the artifact's x and y directions in machine coordinates",
            ));
        };
        if xn.dot(yn).abs() > 1e-3 {
            return Err(at.error(
                span,
                format!(
                    "x_axis and y_axis are {:.2}° from perpendicular",
                    (xn.dot(yn).acos().to_degrees() - 90.0).abs()
                ),
                "give perpendicular directions (the artifact's own axes)",
            ));
        }
        // Gram–Schmidt: y made exactly perpendicular to x.
        let yo = (yn - xn * xn.dot(yn)).normalized().unwrap_or(yn);
        let z = xn.cross(yo);
        placements.push(Placement {
            name: pname,
            origin_mm: origin,
            axes: [xn, yo, z],
        });
    }
    let art = Artifact {
        name,
        kind,
        placements,
    };
    // Spheres need their free side up or sideways: the probe cannot reach
    // under a sphere from the spindle.
    if matches!(
        art.kind,
        Kind::ReferenceSphere { .. } | Kind::Spheres { .. }
    ) {
        for (p, rp) in art.placements.iter().zip(&raw_places) {
            if super::geometry::axis_direction(p.axes[2]).is_none() {
                return Err(at.error(
                    rp.span(),
                    format!(
                        "placement \"{}\": the spheres' free side (the artifact's z = x × y) points along ({:.3}, {:.3}, {:.3}), not along a machine axis",
                        p.name, p.axes[2].x, p.axes[2].y, p.axes[2].z
                    ),
                    "the probe touches along the machine axes: place the plate with its normal along X, Y or +Z (and give x_axis, y_axis so)",
                ));
            }
            if p.axes[2].z < -0.5 {
                return Err(at.error(
                    rp.span(),
                    format!("placement \"{}\": the spheres' free side faces down (−Z)", p.name),
                    "a probe in the spindle cannot reach under a sphere: turn the artifact so that its z axis points up or sideways",
                ));
            }
        }
    }
    if art.is_reference() && art.placements.len() != 1 {
        return Err(at.error(
            raw_places[1].span(),
            "a reference sphere has one placement",
            "describe another place of the sphere as a second reference-sphere file",
        ));
    }
    Ok(art)
}

fn height_above(at: &At, raw: &RawArtifact, word: &str) -> Result<f64, MapFileError> {
    let h = raw.height_above_mm.as_ref().ok_or_else(|| {
        at.error(
            raw.artifact.span(),
            format!("artifact = \"{word}\" needs `height_above_mm`"),
            "give how far the artifact rises above the points it is touched at (mm): the program travels above it",
        )
    })?;
    finite_mm(at, h, "height_above_mm", false)
}

fn check_points(
    at: &At,
    span: Range<usize>,
    pts: &[Vec3],
    diameter: f64,
) -> Result<(), MapFileError> {
    if pts.is_empty() || pts.len() > MAX_FEATURES {
        return Err(at.error(
            span,
            format!("{} spheres: give 1 … {MAX_FEATURES}", pts.len()),
            "list the sphere centres",
        ));
    }
    for (i, p) in pts.iter().enumerate() {
        if !p.is_finite() {
            return Err(at.error(
                span,
                format!("sphere {} has a coordinate that is not finite", i + 1),
                "write numbers (mm)",
            ));
        }
        for (j, q) in pts[..i].iter().enumerate() {
            if (*p - *q).norm() < diameter {
                return Err(at.error(
                    span.clone(),
                    format!(
                        "spheres {} and {} are {:.3} mm apart, closer than a diameter",
                        j + 1,
                        i + 1,
                        (*p - *q).norm()
                    ),
                    "check the centres (mm, in the artifact's frame)",
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const PLATE: &str = r#"
artifact = "spheres"
name = "plate"
sphere_diameter_mm = 25
spheres_mm = [[0, 0, 0], [150, 0, 0], [0, 150, 0]]
[[placements]]
name = "p1"
origin_mm = [100, 50, 20]
[[placements]]
name = "p2"
origin_mm = [400, 50, 20]
x_axis = [0, 1, 0]
y_axis = [-1, 0, 0]
"#;

    #[test]
    fn a_plate_in_two_placements() {
        let a = parse_artifact(PLATE, "plate.toml").unwrap();
        assert_eq!(a.name, "plate");
        assert_eq!(a.placements.len(), 2);
        let f = a.features();
        assert_eq!(f.len(), 3);
        assert_eq!(f[2].label(), "s3");
        // p2 turned 90° about Z: sphere 2 (150, 0, 0) lies along +Y.
        let p2 = &a.placements[1];
        let s2 = p2.to_machine(Vec3::new(150.0, 0.0, 0.0));
        assert!((s2 - Vec3::new(400.0, 200.0, 20.0)).norm() < 1e-12);
        assert_eq!(p2.axes[2], Vec3::new(0.0, 0.0, 1.0));
    }

    #[test]
    fn bad_descriptions_are_located() {
        let cases = [
            (
                PLATE.replace("sphere_diameter_mm = 25", "sphere_diameter_mm = -25"),
                4,
                "not a positive",
            ),
            (
                PLATE.replace("[150, 0, 0], [0, 150, 0]", "[10, 0, 0], [0, 150, 0]"),
                5,
                "closer than a diameter",
            ),
            (PLATE.replace("name = \"p2\"", "name = \"p1\""), 10, "twice"),
            (
                PLATE.replace("y_axis = [-1, 0, 0]", "y_axis = [-1, 0.5, 0]"),
                13,
                "from perpendicular",
            ),
            (
                PLATE.replace(
                    "x_axis = [0, 1, 0]\ny_axis = [-1, 0, 0]",
                    "x_axis = [1, 0, 0]\ny_axis = [0, -1, 0]",
                ),
                0,
                "faces down",
            ),
            (
                PLATE.replace("artifact = \"spheres\"", "artifact = \"ball\""),
                2,
                "not an artifact",
            ),
            (
                PLATE.replace("origin_mm = [100, 50, 20]", "origin = [100, 50, 20]"),
                8,
                "unknown field",
            ),
        ];
        for (text, row, want) in cases {
            let e = parse_artifact(&text, "a.toml").unwrap_err();
            assert!(row == 0 || e.row == row, "{e}");
            assert!(e.to_string().contains(want), "{e}");
            assert!(e.to_string().starts_with("a.toml:"), "{e}");
        }
    }

    #[test]
    fn a_reference_sphere_needs_its_certificate() {
        let text = "artifact = \"reference-sphere\"\nname = \"ref\"\n[[placements]]\nname = \"r\"\norigin_mm = [10, 10, 10]\n";
        let e = parse_artifact(text, "r.toml").unwrap_err();
        assert!(e.to_string().contains("[certificate] diameter_mm"), "{e}");
        let ok = format!("{text}[certificate]\ndiameter_mm = 25.0004\nu_diameter_um = 0.1\n");
        let a = parse_artifact(&ok, "r.toml").unwrap();
        assert!(a.is_reference());
        assert_eq!(
            a.kind,
            Kind::ReferenceSphere {
                diameter_mm: 25.0004,
                u_diameter_um: 0.1
            }
        );
    }

    #[test]
    fn gauges_and_squares() {
        let g = "artifact = \"gauge\"\nname = \"b100\"\nfaces_mm = [0, 100]\nfacing = [\"-\", \"+\"]\nheight_above_mm = 5\n[certificate]\nfaces_mm = [0, 100.0003]\nu_um = 0.05\n[[placements]]\nname = \"x\"\norigin_mm = [50, 100, 10]\n";
        let a = parse_artifact(g, "g.toml").unwrap();
        assert_eq!(
            a.kind,
            Kind::Gauge {
                faces_mm: vec![0.0, 100.0003],
                facing: vec![-1.0, 1.0],
                offsets_mm: vec![[0.0, 0.0]; 2],
                certified_u_um: Some(0.05),
                height_above_mm: 5.0,
            }
        );
        let s = "artifact = \"square\"\nname = \"sq\"\nlegs_mm = [300, 250]\nheight_above_mm = 10\n[[placements]]\nname = \"a\"\norigin_mm = [50, 50, 10]\n[[placements]]\nname = \"b\"\norigin_mm = [50, 350, 10]\ny_axis = [0, -1, 0]\n";
        let a = parse_artifact(s, "s.toml").unwrap();
        // Turned over: z = x × (−y) = −z.
        assert_eq!(a.placements[1].axes[2], Vec3::new(0.0, 0.0, -1.0));
        assert_eq!(a.features()[1].label(), "e2");
    }
}
