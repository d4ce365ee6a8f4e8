//! Burr shapes as exact signed distance functions in the tool frame: tip at the origin, axis +Z
//! toward the handpiece. Every head is a solid of revolution whose half-profile (lines and arcs in
//! the (radial, z) plane) gives the exact distance; the shank and neck are a separate solid that
//! never cuts (contact code may still test it).
mod iso;
pub mod profile;

use dentsim_vdb::{LevelSet, TriMesh};
use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

pub use iso::{parse_iso, IsoNumber};
use profile::{tangent_point, Piece, Profile};

use crate::error::{invalid, Result};

/// The head shapes of ISO 6360 we model.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Shape {
    Round,
    InvertedCone,
    CylinderFlat,
    CylinderRound,
    TaperFlat,
    TaperRound,
    Flame,
    Pear,
    Wheel,
    Needle,
    Xmas,
}

impl Shape {
    pub const ALL: [Shape; 11] = [
        Shape::Round,
        Shape::InvertedCone,
        Shape::CylinderFlat,
        Shape::CylinderRound,
        Shape::TaperFlat,
        Shape::TaperRound,
        Shape::Flame,
        Shape::Pear,
        Shape::Wheel,
        Shape::Needle,
        Shape::Xmas,
    ];

    /// The name used in shorthand specs and the catalogue.
    pub fn name(self) -> &'static str {
        match self {
            Shape::Round => "round",
            Shape::InvertedCone => "inverted_cone",
            Shape::CylinderFlat => "cylinder_flat",
            Shape::CylinderRound => "cylinder_round",
            Shape::TaperFlat => "taper_flat",
            Shape::TaperRound => "taper_round",
            Shape::Flame => "flame",
            Shape::Pear => "pear",
            Shape::Wheel => "wheel",
            Shape::Needle => "needle",
            Shape::Xmas => "xmas",
        }
    }

    pub fn from_name(name: &str) -> Option<Shape> {
        let n = name.trim().to_ascii_lowercase().replace(['-', ' '], "_");
        let n = if n == "x_mas" || n == "christmas_tree" { "xmas".to_owned() } else { n };
        Shape::ALL.into_iter().find(|s| s.name() == n)
    }

    /// Nominal head length (mm) when a spec gives only the diameter. These are typical catalogue
    /// proportions, not figures from the standard.
    pub fn default_length_mm(self, diameter_mm: f64) -> f64 {
        match self {
            Shape::Round => diameter_mm,
            Shape::InvertedCone => diameter_mm,
            Shape::CylinderFlat | Shape::CylinderRound => 4.0,
            Shape::TaperFlat | Shape::TaperRound => 6.0,
            Shape::Flame => 5.0,
            Shape::Pear => 2.0 * diameter_mm,
            Shape::Wheel => 0.4 * diameter_mm,
            Shape::Needle => 8.0,
            Shape::Xmas => 4.0,
        }
    }
}

/// Nominal cone half-angles and ratios. The standard fixes these per size in tables we do not
/// have (REFERENCE.md "Burrs"); these are typical values, documented so nobody mistakes them.
const INVERTED_CONE_HALF_ANGLE_DEG: f64 = 10.0;
const TAPER_HALF_ANGLE_DEG: f64 = 2.0;
const PEAR_TOP_RATIO: f64 = 0.75;
const FLAME_WIDEST_AT: f64 = 0.6;
const FLAME_TOP_RATIO: f64 = 0.35;
const XMAS_CONE_FRACTION: f64 = 0.7;
/// Neck: 2 mm long, at most 0.8 mm wide; FG shank 1.6 mm (REFERENCE.md "Burrs", shank 314).
const NECK_LENGTH_MM: f64 = 2.0;
const SHANK_LENGTH_MM: f64 = 17.0;
pub const FG_SHANK_DIAMETER_MM: f64 = 1.6;
/// The round burr sessions and the phantom stroke use unless told otherwise (ISO size 010).
pub const DEFAULT_ROUND_DIAMETER_MM: f64 = 1.0;
/// The burr of a session or stroke that names none: the round burr above, as a spec.
pub const DEFAULT_BURR: &str = "round:1";

#[derive(Clone, Debug, PartialEq)]
enum Head {
    /// Round burrs: the ball's own distance, the fastest exact case.
    Ball { radius: f64 },
    Revolved(Profile),
}

/// One burr: head shape and size, plus the non-cutting neck and shank.
#[derive(Clone, Debug, PartialEq)]
pub struct Burr {
    pub shape: Shape,
    /// Largest head diameter (ISO size / 10).
    pub diameter_mm: f64,
    pub length_mm: f64,
    pub shank_diameter_mm: f64,
    /// The ISO number the burr was made from, when it was.
    pub iso: Option<IsoNumber>,
    head: Head,
    shank: Profile,
    bounding_radius: f64,
    /// (height, depth inside the head) at evenly spaced points along the axis through the head,
    /// for [`inner_capsule`](Self::inner_capsule).
    axis_depths: Vec<(f64, f64)>,
    /// The head cut across its axis into slabs, each as (lowest, highest height, an upper bound
    /// on the head's radius between them); see [`axis_slabs`](Self::axis_slabs).
    slabs: Vec<(f64, f64, f64)>,
    /// The same slabs, each with a radius bound linear in the height; see
    /// [`axis_frustums`](Self::axis_frustums).
    frustums: Vec<(f64, f64, f64, f64)>,
}

/// Slabs of [`Burr::axis_slabs`]: about this long (mm), at most `MAX_SLABS`. Measured on the
/// bench strokes: 0.25 and 0.5 mm cost more row tests than they save, 2 mm bounds a flame loosely.
const SLAB_MM: f64 = 1.0;
pub const MAX_SLABS: usize = 16;

/// Points along the axis where [`Burr::inner_capsule`] samples the head's depth.
const AXIS_SAMPLES: usize = 400;

impl Burr {
    pub fn round(diameter_mm: f64) -> Result<Self> {
        Self::new(Shape::Round, diameter_mm, None)
    }

    /// A burr of `shape` with head diameter and length (mm; the shape's default length if none).
    pub fn new(shape: Shape, diameter_mm: f64, length_mm: Option<f64>) -> Result<Self> {
        Self::with_shank(shape, diameter_mm, length_mm, FG_SHANK_DIAMETER_MM)
    }

    pub fn with_shank(shape: Shape, diameter_mm: f64, length_mm: Option<f64>, shank_diameter_mm: f64) -> Result<Self> {
        if !(diameter_mm.is_finite() && diameter_mm > 0.0 && diameter_mm <= 10.0) {
            return Err(invalid("burr diameter", format!("{diameter_mm} mm, expected 0 < d <= 10 mm")));
        }
        let length = length_mm.unwrap_or_else(|| shape.default_length_mm(diameter_mm));
        if !(length.is_finite() && length > 0.0 && length <= 25.0) {
            return Err(invalid("burr length", format!("{length} mm, expected 0 < l <= 25 mm")));
        }
        if !(shank_diameter_mm.is_finite() && shank_diameter_mm > 0.0 && shank_diameter_mm <= 5.0) {
            return Err(invalid("shank diameter", format!("{shank_diameter_mm} mm, expected 0 < d <= 5 mm")));
        }
        let r = diameter_mm / 2.0;
        let head = head_profile(shape, r, length)?;
        let (top, head_radius) = match &head {
            Head::Ball { radius } => (2.0 * radius, *radius),
            Head::Revolved(p) => (p.z_max, p.max_radius),
        };
        let bounding_radius = match &head {
            Head::Ball { radius } => 2.0 * radius,
            Head::Revolved(p) => p.max_radius.hypot(p.z_max.max(-p.z_min)),
        };
        // The neck starts halfway up the head (inside it) so the two solids join without a gap.
        let neck = (0.5 * head_radius).min(0.4);
        let (z0, z1) = (0.5 * top, top + NECK_LENGTH_MM);
        let rs = shank_diameter_mm / 2.0;
        let shank = Profile::new(lines(&[(0.0, z0), (neck, z0), (neck, z1), (rs, z1), (rs, z1 + SHANK_LENGTH_MM), (0.0, z1 + SHANK_LENGTH_MM)]));
        let slabs = match &head {
            Head::Ball { .. } => Vec::new(),
            Head::Revolved(p) => {
                let count = ((p.z_max - p.z_min) / SLAB_MM).ceil().clamp(1.0, MAX_SLABS as f64) as usize;
                let at = |i: usize| if i == count { p.z_max } else { p.z_min + (p.z_max - p.z_min) * i as f64 / count as f64 };
                let mut slabs: Vec<(f64, f64, f64)> = Vec::with_capacity(count);
                for i in 0..count {
                    let r = p.max_radius_within(at(i), at(i + 1));
                    match slabs.last_mut() {
                        // A cylinder's slabs are one: fewer to test per row.
                        Some(last) if last.2 == r => last.1 = at(i + 1),
                        _ => slabs.push((at(i), at(i + 1), r)),
                    }
                }
                slabs
            }
        };
        let frustums = match &head {
            Head::Ball { .. } => Vec::new(),
            Head::Revolved(p) => slabs.iter().map(|&(h0, h1, _)| frustum_over(p, h0, h1)).collect(),
        };
        let mut burr = Burr { shape, diameter_mm, length_mm: top, shank_diameter_mm, iso: None, head, shank, bounding_radius, axis_depths: Vec::new(), slabs, frustums };
        let (z_lo, z_hi, _) = burr.axis_extent();
        let (z_lo, z_hi) = if burr.ball_radius().is_some() { (0.0, 2.0 * r) } else { (z_lo, z_hi) };
        burr.axis_depths = (0..AXIS_SAMPLES)
            .map(|i| {
                let z = z_lo + (z_hi - z_lo) * i as f64 / (AXIS_SAMPLES - 1) as f64;
                (z, -burr.sdf(DVec3::new(0.0, 0.0, z)))
            })
            .collect();
        Ok(burr)
    }

    /// A burr from a spec: a catalogue name, an ISO number (`806 314 001 524 010`), or the
    /// shorthand `SHAPE:DIAMETER_MM[:LENGTH_MM]` (`round:1.0`, `cylinder_flat:1.2:4`).
    pub fn parse(spec: &str) -> Result<Self> {
        let s = spec.trim();
        if let Some(entry) = catalogue::Catalogue::builtin().get(s) {
            return entry.burr();
        }
        if s.chars().next().is_some_and(|c| c.is_ascii_digit()) {
            return Self::from_iso(&parse_iso(s)?);
        }
        let mut parts = s.split(':');
        let shape_token = parts.next().unwrap_or("");
        let shape = Shape::from_name(shape_token).ok_or_else(|| {
            let known: Vec<_> = Shape::ALL.iter().map(|s| s.name()).collect();
            invalid(format!("burr '{spec}'"), format!("shape '{shape_token}' is not known (known: {}; or an ISO number or catalogue name)", known.join(", ")))
        })?;
        let number = |field: &str, token: Option<&str>| -> Result<Option<f64>> {
            match token {
                None => Ok(None),
                Some(t) => t.trim().parse::<f64>().map(Some).map_err(|_| {
                    invalid(format!("burr '{spec}'"), format!("{field} '{t}' is not a number of mm"))
                }),
            }
        };
        let diameter = number("diameter", parts.next())?
            .ok_or_else(|| invalid(format!("burr '{spec}'"), "expected SHAPE:DIAMETER_MM[:LENGTH_MM]"))?;
        let length = number("length", parts.next())?;
        if let Some(extra) = parts.next() {
            return Err(invalid(format!("burr '{spec}'"), format!("unexpected '{extra}' after the length")));
        }
        Self::new(shape, diameter, length).map_err(|e| invalid(format!("burr '{spec}'"), e.to_string()))
    }

    pub fn from_iso(iso: &IsoNumber) -> Result<Self> {
        let mut burr = Self::with_shank(iso.shape, iso.diameter_mm(), None, iso.shank_diameter_mm())?;
        burr.iso = Some(*iso);
        Ok(burr)
    }

    /// Signed distance (mm) of a tool-frame point to the cutting head.
    #[inline]
    pub fn sdf(&self, p: DVec3) -> f64 {
        match &self.head {
            Head::Ball { radius } => (p - DVec3::new(0.0, 0.0, *radius)).length() - radius,
            Head::Revolved(profile) => profile.sdf((p.x * p.x + p.y * p.y).sqrt(), p.z),
        }
    }

    /// [`sdf`](Self::sdf) in f32 at the tool-frame points `origin + i·step` for each `out[i]`
    /// (a row of voxels; see [`Profile::sdf_row`]).
    pub fn sdf_row(&self, origin: glam::Vec3, step: glam::Vec3, out: &mut [f32]) {
        self.sdf_row_from(origin, step, 0, out);
    }

    /// [`sdf_row`](Self::sdf_row) at the row's points `first + i` for each `out[i]` (bit for
    /// bit the row's values there, wherever a run of it starts).
    pub fn sdf_row_from(&self, origin: glam::Vec3, step: glam::Vec3, first: usize, out: &mut [f32]) {
        match &self.head {
            Head::Ball { radius } => {
                let c = origin - glam::Vec3::new(0.0, 0.0, *radius as f32);
                for (i, o) in out.iter_mut().enumerate() {
                    *o = (c + step * (first + i) as f32).length() - *radius as f32;
                }
            }
            Head::Revolved(profile) => profile.sdf_row_from(origin.to_array(), step.to_array(), first, out),
        }
    }

    /// [`sdf_row_from`](Self::sdf_row_from) at the first `n` (at most [`profile::LANES`]) of
    /// `lanes`' points, each of its own row (see [`profile::Lanes`]), into `out[..n]`: bit for
    /// bit each row's value there.
    pub fn sdf_lanes(&self, lanes: &profile::Lanes, n: usize, step: glam::Vec3, out: &mut [f32]) {
        match &self.head {
            Head::Ball { radius } => {
                for (l, o) in out[..n].iter_mut().enumerate() {
                    let c = glam::Vec3::new(lanes.x[l], lanes.y[l], lanes.z[l]) - glam::Vec3::new(0.0, 0.0, *radius as f32);
                    *o = (c + step * lanes.t[l]).length() - *radius as f32;
                }
            }
            Head::Revolved(profile) => profile.sdf_lanes(lanes, n, step.to_array(), out),
        }
    }

    /// Signed distance of a tool-frame point to the non-cutting neck and shank.
    pub fn shank_sdf(&self, p: DVec3) -> f64 {
        self.shank.sdf((p.x * p.x + p.y * p.y).sqrt(), p.z)
    }

    /// The ball radius when the head is a ball (the swept cut then has a closed form).
    pub fn ball_radius(&self) -> Option<f64> {
        match self.head {
            Head::Ball { radius } => Some(radius),
            Head::Revolved(_) => None,
        }
    }

    /// The head's bounding ball as (centre height on the axis, radius), tool frame.
    pub fn bound(&self) -> (f64, f64) {
        match &self.head {
            Head::Ball { radius } => (*radius, *radius),
            Head::Revolved(p) => ((p.z_min + p.z_max) / 2.0, p.max_radius.hypot((p.z_max - p.z_min) / 2.0)),
        }
    }

    /// The head's surface in the tool frame, meshed from its SDF over the head's own box at a
    /// twentieth of its diameter (a ball: a few thousand triangles; a long head more, as it
    /// should), by the one mesher: what a display draws and a mesh-based peer cuts with.
    pub fn head_surface(&self) -> Result<TriMesh> {
        let head = self.head_profile();
        let r = head.max_radius;
        let h = (self.diameter_mm / 20.0).max(0.01);
        let pad = DVec3::splat(4.0 * h);
        let lo = DVec3::new(-r, -r, head.z_min) - pad;
        let hi = DVec3::new(r, r, head.z_max) + pad;
        let grid = LevelSet::from_sdf(h, 3.0, lo, hi, |p| self.sdf(p))?;
        crate::tissues::surface(&grid)
    }

    /// Radius of a ball about the tool origin that holds the cutting head.
    pub fn bounding_radius(&self) -> f64 {
        self.bounding_radius
    }

    /// The head's extent along its axis and its widest radius (mm, tool frame): it lies within
    /// the capsule of that radius about the axis from `z_min` to `z_max`, for long heads a far
    /// tighter bound than the ball of [`bound`](Self::bound).
    pub fn axis_extent(&self) -> (f64, f64, f64) {
        match &self.head {
            Head::Ball { radius } => (*radius, *radius, *radius),
            Head::Revolved(p) => (p.z_min, p.z_max, p.max_radius),
        }
    }

    /// The head (not a ball) cut across its axis into slabs: (lowest, highest height, radius),
    /// tool frame, such that every point of the head lies in the cylinder of some slab. For a
    /// head that narrows (taper, cone, flame, pear) a far tighter bound than the one cylinder of
    /// [`axis_extent`](Self::axis_extent). Empty for a ball.
    pub fn axis_slabs(&self) -> &[(f64, f64, f64)] {
        &self.slabs
    }

    /// The slabs of [`axis_slabs`](Self::axis_slabs), each as (lowest, highest height, radius
    /// bound at the lowest, at the highest), tool frame: every point of the head at a height z
    /// between them lies within the radius that runs linearly between the two bounds, a
    /// truncated cone, on average no wider than the slab's cylinder. Where the head narrows (a
    /// taper, a flame's ogive) it hugs the head far closer than the cylinder. Empty for a ball.
    pub fn axis_frustums(&self) -> &[(f64, f64, f64, f64)] {
        &self.frustums
    }

    /// A capsule about the axis (ends' heights and radius, tool frame) every point of which lies
    /// at least `margin` mm inside the head, as large as a few tries find; None when the head is
    /// too thin. The sweep leaves the voxels in it alone (they are deeper than any cut reads).
    pub fn inner_capsule(&self, margin: f64) -> Option<(f64, f64, f64)> {
        let s = &self.axis_depths;
        let (top, deepest) = s.iter().enumerate().max_by(|a, b| a.1 .1.total_cmp(&b.1 .1)).map(|(i, p)| (i, p.1))?;
        // The depth is 1-Lipschitz along the axis: half a sample spacing of slack between samples.
        let half_step = s.get(1).map_or(0.0, |p| (p.0 - s[0].0) / 2.0);
        let reach = deepest - half_step - margin;
        if !(reach > 0.0) {
            return None;
        }
        let mut best: Option<(f64, (f64, f64, f64))> = None;
        for f in [0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0] {
            let radius = reach * f;
            let need = radius + margin + half_step;
            let (mut a, mut b) = (top, top);
            while a > 0 && s[a - 1].1 >= need {
                a -= 1;
            }
            while b + 1 < s.len() && s[b + 1].1 >= need {
                b += 1;
            }
            let volume = radius * radius * (s[b].0 - s[a].0 + 4.0 / 3.0 * radius);
            if best.is_none_or(|(v, _)| volume > v) {
                best = Some((volume, (s[a].0, s[b].0, radius)));
            }
        }
        best.map(|(_, c)| c)
    }

    /// For a convex head, (the highest point of its surface facing down, the lowest facing up)
    /// along the axis (see [`Profile`]); None for a head with a dent.
    pub fn facing_heights(&self) -> Option<(f64, f64)> {
        match &self.head {
            Head::Ball { radius } => Some((*radius, *radius)),
            Head::Revolved(p) => p.convex.then_some((p.facing_down_below, p.facing_up_above)),
        }
    }

    /// The head's half-profile (lines and arcs in (radial, z)); a ball gives its half circle.
    pub fn head_profile(&self) -> Profile {
        match &self.head {
            Head::Ball { radius } => ball_profile(*radius),
            Head::Revolved(p) => p.clone(),
        }
    }

    pub fn shank_profile(&self) -> &Profile {
        &self.shank
    }

    /// A spec that rebuilds this burr: its ISO number when it has one, else the shorthand.
    pub fn spec(&self) -> String {
        match &self.iso {
            Some(iso) => iso.to_string(),
            None => format!("{}:{}:{}", self.shape.name(), self.diameter_mm, self.length_mm),
        }
    }
}

fn lines(points: &[(f64, f64)]) -> Vec<Piece> {
    points
        .windows(2)
        .map(|w| Piece::Line { a: DVec2::new(w[0].0, w[0].1), b: DVec2::new(w[1].0, w[1].1) })
        .collect()
}

fn ball_profile(r: f64) -> Profile {
    Profile::new(vec![Piece::Arc {
        centre: DVec2::new(0.0, r),
        radius: r,
        a: DVec2::new(0.0, 0.0),
        b: DVec2::new(0.0, 2.0 * r),
        ccw: true,
    }])
}

/// The head of each shape with largest radius `r` and length `l`.
fn head_profile(shape: Shape, r: f64, l: f64) -> Result<Head> {
    let shape_err = |why: &str| invalid(format!("burr {}", shape.name()), format!("diameter {} mm, length {l} mm: {why}", 2.0 * r));
    let tan = |deg: f64| deg.to_radians().tan();
    let pieces = match shape {
        Shape::Round => return Ok(Head::Ball { radius: r }),
        Shape::CylinderFlat | Shape::Wheel => lines(&[(0.0, 0.0), (r, 0.0), (r, l), (0.0, l)]),
        Shape::InvertedCone => {
            let top = r - l * tan(INVERTED_CONE_HALF_ANGLE_DEG);
            if top < 0.1 * r {
                return Err(shape_err("too long for its cone angle"));
            }
            lines(&[(0.0, 0.0), (r, 0.0), (top, l), (0.0, l)])
        }
        Shape::TaperFlat => {
            let tip = r - l * tan(TAPER_HALF_ANGLE_DEG);
            if tip < 0.1 * r {
                return Err(shape_err("too long for its taper"));
            }
            lines(&[(0.0, 0.0), (tip, 0.0), (r, l), (0.0, l)])
        }
        Shape::Needle => lines(&[(0.0, 0.0), (r, l), (0.0, l)]),
        Shape::Xmas => {
            let zc = XMAS_CONE_FRACTION * l;
            lines(&[(0.0, 0.0), (r, zc), (r, l), (0.0, l)])
        }
        Shape::CylinderRound => {
            if l <= r {
                return Err(shape_err("a round end needs a length above the radius"));
            }
            let mut p = vec![Piece::Arc { centre: DVec2::new(0.0, r), radius: r, a: DVec2::ZERO, b: DVec2::new(r, r), ccw: true }];
            p.extend(lines(&[(r, r), (r, l), (0.0, l)]));
            p
        }
        Shape::TaperRound | Shape::Pear => {
            // A ball on the tip, a straight flank tangent to it up to the top rim.
            let (a, top) = if shape == Shape::Pear {
                (r, PEAR_TOP_RATIO * r)
            } else {
                ((r - l * tan(TAPER_HALF_ANGLE_DEG)).max(0.1 * r), r)
            };
            let centre = DVec2::new(0.0, a);
            let rim = DVec2::new(top, l);
            let t = tangent_point(centre, a, rim).ok_or_else(|| shape_err("too short for its round end"))?;
            if t.y >= l || t.x <= 0.0 {
                return Err(shape_err("too short for its round end"));
            }
            let mut p = vec![Piece::Arc { centre, radius: a, a: DVec2::ZERO, b: t, ccw: true }];
            p.extend(lines(&[(t.x, t.y), (top, l), (0.0, l)]));
            p
        }
        Shape::Flame => {
            // An ogive from the pointed tip to the widest circle, then a straight neck taper.
            let zm = FLAME_WIDEST_AT * l;
            let big = (r * r + zm * zm) / (2.0 * r);
            let centre = DVec2::new(r - big, zm);
            let mut p = vec![Piece::Arc { centre, radius: big, a: DVec2::ZERO, b: DVec2::new(r, zm), ccw: true }];
            p.extend(lines(&[(r, zm), (FLAME_TOP_RATIO * r, l), (0.0, l)]));
            p
        }
    };
    Ok(Head::Revolved(Profile::new(pieces)))
}

/// The frustum of [`Burr::axis_frustums`] over heights `[h0, h1]` of `profile`: a line
/// `r0 + s·(z − h0)` above the profile's radius bound on each of many windows of the slab (the
/// line's lowest over a window is at one of its ends), with the slope that makes it narrowest on
/// average. That average is convex in the slope (a maximum of lines plus a line), so a ternary
/// search finds it; slope 0 is the slab's cylinder, never narrower than the result.
fn frustum_over(profile: &Profile, h0: f64, h1: f64) -> (f64, f64, f64, f64) {
    const WINDOWS: usize = 128;
    let len = h1 - h0;
    let at = |i: usize| if i == WINDOWS { h1 } else { h0 + len * i as f64 / WINDOWS as f64 };
    let windows: Vec<(f64, f64, f64)> = (0..WINDOWS).map(|i| (at(i) - h0, at(i + 1) - h0, profile.max_radius_within(at(i), at(i + 1)))).collect();
    // The least r0 that holds every window at slope s.
    let base = |s: f64| windows.iter().map(|&(a, b, r)| r - s * if s >= 0.0 { a } else { b }).fold(0f64, f64::max);
    let mean = |s: f64| base(s) + s * len / 2.0;
    // Steeper than this (a flat end's 1/100 of the width per height) bounds nothing better.
    let (mut lo, mut hi) = (-100.0 * profile.max_radius / len.max(1e-9), 100.0 * profile.max_radius / len.max(1e-9));
    for _ in 0..100 {
        let (a, b) = (lo + (hi - lo) / 3.0, hi - (hi - lo) / 3.0);
        if mean(a) <= mean(b) {
            hi = b;
        } else {
            lo = a;
        }
    }
    let s = (lo + hi) / 2.0;
    let s = if mean(s) < mean(0.0) { s } else { 0.0 };
    let r0 = base(s);
    (h0, h1, r0, r0 + s * len)
}

pub mod catalogue;

#[cfg(test)]
mod tests;
