//! Cutting a tissue model with a burr swept along a stroke.
use dentsim_vdb::{DensePatch, LevelSet};
use glam::{DAffine3, DVec3, IVec3};
use serde::Serialize;

use crate::burr::Burr;
use crate::error::{invalid, Result};
use crate::model::TissueModel;

/// Volume each tissue lost to one stroke.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct StrokeReport {
    pub removed_mm3: Vec<(String, f64)>,
    pub changed_voxels: u64,
}

impl StrokeReport {
    pub fn removed(&self, tissue: &str) -> f64 {
        self.removed_mm3.iter().find(|(n, _)| n == tissue).map_or(0.0, |(_, v)| *v)
    }
}

/// Reuses its patch buffer from stroke to stroke.
#[derive(Default)]
pub struct Cutter {
    patch: DensePatch,
}

impl Cutter {
    /// Removes the burr's swept volume from `from` to `to` out of every tissue.
    pub fn cut(&mut self, model: &mut TissueModel, burr: &Burr, from: DAffine3, to: DAffine3) -> Result<StrokeReport> {
        for (which, pose) in [("start", from), ("end", to)] {
            if !pose.is_finite() {
                return Err(invalid(format!("stroke {which} pose"), "is not finite"));
            }
        }
        let Some(first) = model.tissues.first() else {
            return Ok(StrokeReport::default());
        };
        self.sweep_patch(&first.grid, burr, from, to);
        let mut report = StrokeReport::default();
        for t in &mut model.tissues {
            let stats = t.grid.subtract(&self.patch)?;
            report.removed_mm3.push((t.props.name.clone(), stats.removed_mm3));
            report.changed_voxels += stats.changed_voxels;
        }
        Ok(report)
    }

    /// Tool distances over the stroke's bounding box plus the narrow band.
    fn sweep_patch(&mut self, grid: &LevelSet, burr: &Burr, from: DAffine3, to: DAffine3) {
        let Burr::Round { diameter_mm } = *burr;
        let r = diameter_mm / 2.0;
        // A ball's swept volume along a straight stroke is the capsule between its centres.
        let a = from.transform_point3(DVec3::new(0.0, 0.0, r));
        let b = to.transform_point3(DVec3::new(0.0, 0.0, r));
        let reach = r + f64::from(grid.background()) + grid.voxel_size();
        let lo = grid.world_to_index(a.min(b) - reach);
        let hi = grid.world_to_index(a.max(b) + reach);
        let dims = (hi - lo + IVec3::ONE).as_uvec3();
        let patch = &mut self.patch;
        patch.index_min = lo;
        patch.dims = dims.to_array();
        patch.values.clear();
        let ab = b - a;
        let len2 = ab.length_squared().max(f64::MIN_POSITIVE);
        for k in lo.z..=hi.z {
            for j in lo.y..=hi.y {
                for i in lo.x..=hi.x {
                    let p = grid.index_to_world(IVec3::new(i, j, k));
                    let t = ((p - a).dot(ab) / len2).clamp(0.0, 1.0);
                    patch.values.push(((p - (a + ab * t)).length() - r) as f32);
                }
            }
        }
    }
}
