//! The first end-to-end preparation: build the capsule phantom and cut one straight stroke with a
//! round burr held upright. Shared by `dentsim demo` and the ParaView source.
use glam::{DAffine3, DVec3};
use serde::{Deserialize, Serialize};

use crate::burr::Burr;
use crate::cutting::cutter::Cutter;
use crate::error::{invalid, Result};
use crate::tissues::capsule::CapsuleTooth;
use crate::tissues::model::{TissueModel, TissueVolumes};
use crate::tissues::table::TissueTable;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PhantomStroke {
    pub voxel_size_mm: f64,
    pub burr_diameter_mm: f64,
    /// Burr tip at the start and end of the stroke (world mm).
    pub start_mm: [f64; 3],
    pub end_mm: [f64; 3],
}

impl Default for PhantomStroke {
    /// A groove opening at the occlusal surface and deepening through the enamel into dentin.
    fn default() -> Self {
        PhantomStroke {
            voxel_size_mm: crate::tissues::model::DEFAULT_VOXEL_MM,
            burr_diameter_mm: crate::burr::DEFAULT_ROUND_DIAMETER_MM,
            start_mm: [-2.0, 0.0, 4.2], end_mm: [1.0, 0.0, 2.9] }
    }
}

pub struct Outcome {
    pub model: TissueModel,
    pub tissues: Vec<TissueVolumes>,
}

impl PhantomStroke {
    pub fn validate(&self) -> Result<()> {
        crate::tissues::model::check_voxel_mm("voxel size", self.voxel_size_mm)?;
        Burr::round(self.burr_diameter_mm)?;
        for (which, p) in [("stroke start", self.start_mm), ("stroke end", self.end_mm)] {
            if p.iter().any(|v| !v.is_finite() || v.abs() > 100.0) {
                return Err(invalid(which, format!("{p:?} mm, expected finite coordinates within 100 mm")));
            }
        }
        Ok(())
    }

    /// Builds the phantom and cuts the stroke; `progress(step, fraction)` follows the work.
    pub fn run(&self, table: &TissueTable, progress: &mut dyn FnMut(&str, f64)) -> Result<Outcome> {
        self.validate()?;
        progress("building phantom", 0.0);
        let mut model = CapsuleTooth::default().build(self.voxel_size_mm, table)?;
        let before = model.volumes();
        progress("cutting", 0.6);
        let burr = Burr::round(self.burr_diameter_mm)?;
        let pose = |p: [f64; 3]| DAffine3::from_translation(DVec3::from_array(p));
        let report = Cutter::default().cut(&mut model, &burr, pose(self.start_mm), pose(self.end_mm))?;
        progress("measuring", 0.8);
        let tissues = TissueVolumes::of(&model, &before, |name| report.removed(name));
        progress("done", 1.0);
        Ok(Outcome { model, tissues })
    }
}
