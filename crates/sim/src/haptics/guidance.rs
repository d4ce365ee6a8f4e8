//! Live guidance: how much tissue the burr leaves over the pulp, measured every tick.
//!
//! Before the first tick the pulp as it was at the start is turned into a distance field with a
//! band wide enough for the warning ([`PulpClearance`]). The tick reads it at the burr's surface
//! samples (one batched call, no allocation): the smallest value is the thinnest tissue between
//! the burr head and the pulp, negative once the head reaches into the pulp. A cut ends where the
//! head is, so on a tick that cuts it is the dentin the preparation leaves there. The field is of
//! the original pulp and never cut, so the reading depends on the pose alone, and a replay of the
//! same ticks reads the same values.
use dentsim_vdb::LevelSet;
use glam::{DAffine3, DVec3};
use serde::{Deserialize, Serialize};

use crate::error::{invalid, Result};
use crate::haptics::contact::BurrSamples;
use crate::tissues::model::TissueModel;
use crate::tissues::surface::surface;

/// Dentin left over the pulp below this (mm) is too thin (Murray 2003, REFERENCE.md): the live
/// warning's default and `dentsim assess`'s grade.
pub const THIN_DENTIN_MM: f64 = 0.5;

/// Flag bits of a tick (log records carry them beside their own flags).
/// The tick cut and left less than the threshold over the pulp, without opening it.
pub const FLAG_THIN_DENTIN: u32 = 8;
/// The tick cut into the original pulp.
pub const FLAG_PULP_EXPOSED: u32 = 16;
pub const GUIDANCE_FLAGS: u32 = FLAG_THIN_DENTIN | FLAG_PULP_EXPOSED;

/// The guidance settings (stored with the haptic parameters, so a replay warns where the session did).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct GuidanceParams {
    /// Remaining dentin below this (mm) on a cutting tick is a thin-dentin event; 0 turns live
    /// guidance off.
    pub thin_dentin_mm: f64,
}

impl Default for GuidanceParams {
    fn default() -> Self {
        GuidanceParams { thin_dentin_mm: THIN_DENTIN_MM }
    }
}

impl GuidanceParams {
    pub fn validate(&self) -> Result<()> {
        let t = self.thin_dentin_mm;
        if !(t.is_finite() && (0.0..=5.0).contains(&t)) {
            return Err(invalid("guidance thin_dentin_mm", format!("{t}, expected 0 ..= 5 mm (0 turns guidance off)")));
        }
        Ok(())
    }

    /// The flags of a tick that measured `clearance_mm` and did or did not cut.
    pub fn classify(&self, clearance_mm: f64, cut: bool) -> u32 {
        if !cut || self.thin_dentin_mm <= 0.0 {
            0
        } else if clearance_mm < 0.0 {
            FLAG_PULP_EXPOSED
        } else if clearance_mm < self.thin_dentin_mm {
            FLAG_THIN_DENTIN
        } else {
            0
        }
    }
}

/// Voxels of the clearance field per thin-dentin threshold. Readings interpolate an exact
/// distance field, good to far below a voxel along the pulp's smooth walls; the wide band costs
/// the cube of its resolution at every session's start (the tissues' 0.05 mm: 2.3 M voxels and
/// 8 s on a loaded 2-core machine for the bench tooth).
const FIELD_VOXELS_PER_THRESHOLD: f64 = 5.0;

/// The original pulp as a wide-band distance field, with the buffers a reading needs.
pub struct PulpClearance {
    field: LevelSet,
    /// World box of the field's band: a head whose bounding sphere misses it is farther than
    /// `reach_mm` from the pulp.
    lo: DVec3,
    hi: DVec3,
    /// The band's half width (mm): values at or beyond it mean "at least this far".
    reach_mm: f64,
    /// How far the burr's samples lie from its centre (mm): the head's bounding sphere.
    head_radius: f64,
    xyz: Vec<f32>,
    values: Vec<f32>,
}

impl PulpClearance {
    /// The field for `model`'s tissue named `pulp`, reaching twice the threshold (so a display
    /// can show the burr nearing the pulp before it is too close); `None` without a pulp.
    /// The buffers fit `samples` (the burr the tick reads with).
    pub fn new(model: &TissueModel, params: &GuidanceParams, samples: &BurrSamples) -> Result<Option<Self>> {
        params.validate()?;
        let Some(pulp) = model.get("pulp") else { return Ok(None) };
        if params.thin_dentin_mm <= 0.0 {
            return Ok(None);
        }
        let mesh = surface(&pulp.grid)?;
        if mesh.triangles.is_empty() {
            return Ok(None);
        }
        let h = pulp.grid.voxel_size().max(params.thin_dentin_mm / FIELD_VOXELS_PER_THRESHOLD);
        let band_voxels = (2.0 * params.thin_dentin_mm / h).ceil() + 2.0;
        let field = LevelSet::from_mesh(&mesh, h, band_voxels)?;
        let reach_mm = band_voxels * h;
        let (lo, hi) = match field.index_bbox() {
            Some(b) => (field.index_to_world(b.min) - DVec3::splat(h), field.index_to_world(b.max) + DVec3::splat(h)),
            None => return Ok(None),
        };
        let n = samples.len() + 1;
        let head_radius = samples.points.iter().map(|p| p.distance(samples.centre)).fold(0.0, f64::max);
        Ok(Some(PulpClearance { field, lo, hi, reach_mm, head_radius, xyz: vec![0.0; 3 * n], values: vec![0.0; n] }))
    }

    /// How far the field reaches (mm): readings at or beyond it are reported as infinite.
    pub fn reach_mm(&self) -> f64 {
        self.reach_mm
    }

    /// The thinnest tissue (mm) between the burr head at `pose` and the original pulp: negative
    /// when the head reaches into it, infinite when the pulp is farther than [`Self::reach_mm`].
    /// Allocation-free.
    pub fn measure(&mut self, samples: &BurrSamples, pose: &DAffine3) -> f64 {
        let centre = pose.transform_point3(samples.centre);
        let nearest = centre.clamp(self.lo, self.hi);
        if nearest.distance_squared(centre) > self.head_radius * self.head_radius {
            return f64::INFINITY;
        }
        let n = samples.points.len().min(self.values.len().saturating_sub(1));
        // The surface samples find the nearest pulp outside the head; the centre, a pulp horn
        // the head swallowed whole.
        for (i, p) in samples.points.iter().take(n).chain(std::iter::once(&samples.centre)).enumerate() {
            let w = pose.transform_point3(*p);
            self.xyz[3 * i..3 * i + 3].copy_from_slice(&[w.x as f32, w.y as f32, w.z as f32]);
        }
        let m = n + 1;
        self.field.sample_values(&self.xyz[..3 * m], &mut self.values[..m]);
        let min = self.values[..m].iter().copied().fold(f32::INFINITY, f32::min);
        let min = f64::from(min);
        // Within half a voxel of the band's edge the value is the clamped background.
        if min >= self.reach_mm - 0.5 * self.field.voxel_size() {
            f64::INFINITY
        } else {
            min
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::burr::Burr;
    use crate::tissues::table::TissueTable;

    /// A pulp ball of radius 1 mm at the origin inside a dentin ball of 3 mm.
    fn pulp_ball() -> TissueModel {
        let table = TissueTable::default();
        let mut model = TissueModel::new("test", None);
        for (name, r) in [("dentin", 3.0), ("pulp", 1.0)] {
            let grid = LevelSet::sphere(DVec3::ZERO, r, 0.05, 3.0).unwrap();
            model.push(table.get(name).unwrap().clone(), grid).unwrap();
        }
        model
    }

    #[test]
    fn clearance_is_the_gap_between_head_and_pulp_and_negative_inside() {
        let model = pulp_ball();
        let burr = Burr::parse("round:1.0").unwrap();
        let samples = BurrSamples::new(&burr, 256).unwrap();
        let mut c = PulpClearance::new(&model, &GuidanceParams::default(), &samples).unwrap().unwrap();
        // Round burr: head centre 0.5 mm above the tip along +Z; tool axis along +Z.
        let at = |gap: f64| DAffine3::from_translation(DVec3::new(0.0, 0.0, 1.0 + gap));
        for gap in [0.05, 0.2, 0.45, 0.9] {
            let got = c.measure(&samples, &at(gap));
            assert!((got - gap).abs() < 0.02, "gap {gap}: {got}");
        }
        // Sideways: the head's side toward the pulp.
        let side = DAffine3::from_translation(DVec3::new(1.0 + 0.5 + 0.3, 0.0, -0.5));
        let got = c.measure(&samples, &side);
        assert!((got - 0.3).abs() < 0.02, "side: {got}");
        let inside = c.measure(&samples, &at(-0.3));
        assert!((inside + 0.3).abs() < 0.03, "inside: {inside}");
        assert_eq!(c.measure(&samples, &at(1.5)), f64::INFINITY);
        assert_eq!(c.measure(&samples, &DAffine3::from_translation(DVec3::splat(20.0))), f64::INFINITY);
    }

    #[test]
    fn flags_need_a_cut_and_order_exposure_before_thin() {
        let p = GuidanceParams::default();
        assert_eq!(p.classify(0.3, false), 0);
        assert_eq!(p.classify(0.3, true), FLAG_THIN_DENTIN);
        assert_eq!(p.classify(-0.01, true), FLAG_PULP_EXPOSED);
        assert_eq!(p.classify(0.6, true), 0);
        assert_eq!(p.classify(f64::INFINITY, true), 0);
        assert_eq!(GuidanceParams { thin_dentin_mm: 0.0 }.classify(-1.0, true), 0);
        assert!(GuidanceParams { thin_dentin_mm: f64::NAN }.validate().is_err());
        let samples = BurrSamples::new(&Burr::parse("round:1.0").unwrap(), 16).unwrap();
        assert!(PulpClearance::new(&pulp_ball(), &GuidanceParams { thin_dentin_mm: 0.0 }, &samples).unwrap().is_none());
    }
}
