//! A first analytic phantom: three nested capsules along +Z (enamel over dentin over pulp).
//! Each tissue's signed distance is exact, so its level set and volume are known in closed form.
use std::f64::consts::PI;

use dentsim_vdb::LevelSet;
use glam::DVec3;

use crate::error::Result;
use crate::tissues::model::TissueModel;
use crate::tissues::table::TissueTable;

/// A capsule: the points within `radius` of the segment from −`half_length` to +`half_length` on Z.
#[derive(Clone, Copy, Debug)]
pub struct Capsule {
    pub radius: f64,
    pub half_length: f64,
}

impl Capsule {
    pub fn sdf(&self, p: DVec3) -> f64 {
        let z = p.z.clamp(-self.half_length, self.half_length);
        (p - DVec3::new(0.0, 0.0, z)).length() - self.radius
    }

    pub fn volume(&self) -> f64 {
        PI * self.radius.powi(2) * 2.0 * self.half_length + 4.0 / 3.0 * PI * self.radius.powi(3)
    }

    pub fn top(&self) -> f64 {
        self.half_length + self.radius
    }
}

/// Enamel 1.0 mm thick at the sides and 1.5 mm at the top, dentin 1.2 mm around a 0.8 mm pulp.
#[derive(Clone, Copy, Debug)]
pub struct CapsuleTooth {
    pub outer: Capsule,
    pub dentin: Capsule,
    pub pulp: Capsule,
}

impl Default for CapsuleTooth {
    fn default() -> Self {
        CapsuleTooth {
            outer: Capsule { radius: 3.0, half_length: 2.0 },
            dentin: Capsule { radius: 2.0, half_length: 1.5 },
            pulp: Capsule { radius: 0.8, half_length: 1.2 },
        }
    }
}

impl CapsuleTooth {
    /// Signed distance of each tissue's own material: shells are exact as the shapes nest.
    pub fn sdf(&self, tissue: &str, p: DVec3) -> Option<f64> {
        match tissue {
            "enamel" => Some(self.outer.sdf(p).max(-self.dentin.sdf(p))),
            "dentin" => Some(self.dentin.sdf(p).max(-self.pulp.sdf(p))),
            "pulp" => Some(self.pulp.sdf(p)),
            _ => None,
        }
    }

    pub fn volume(&self, tissue: &str) -> Option<f64> {
        match tissue {
            "enamel" => Some(self.outer.volume() - self.dentin.volume()),
            "dentin" => Some(self.dentin.volume() - self.pulp.volume()),
            "pulp" => Some(self.pulp.volume()),
            _ => None,
        }
    }

    /// One level set per tissue at `voxel_size` mm with a 3-voxel half band.
    pub fn build(&self, voxel_size: f64, table: &TissueTable) -> Result<TissueModel> {
        let mut model = TissueModel::new("dentsim capsule phantom", None);
        let r = self.outer.radius;
        let (lo, hi) = (DVec3::new(-r, -r, -self.outer.top()), DVec3::new(r, r, self.outer.top()));
        for name in ["enamel", "dentin", "pulp"] {
            let props = table.get(name).cloned().ok_or_else(|| {
                crate::error::invalid("tissue table", format!("has no '{name}'"))
            })?;
            let grid = LevelSet::from_sdf(voxel_size, 3.0, lo, hi, |p| {
                self.sdf(name, p).unwrap_or(f64::MAX)
            })?;
            model.push(props, grid)?;
        }
        Ok(model)
    }
}
