//! Burr shapes as signed distance functions in the tool frame: tip at the origin, axis +Z toward
//! the handpiece.
use glam::DVec3;

use crate::error::{invalid, Result};

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Burr {
    /// ISO 6360 shape 001: a ball resting on the tip.
    Round { diameter_mm: f64 },
}

impl Burr {
    pub fn round(diameter_mm: f64) -> Result<Self> {
        if !(diameter_mm.is_finite() && diameter_mm > 0.0 && diameter_mm <= 10.0) {
            return Err(invalid("burr diameter", format!("{diameter_mm} mm, expected 0 < d <= 10 mm")));
        }
        Ok(Burr::Round { diameter_mm })
    }

    /// Signed distance (mm) of a tool-frame point to the cutting head.
    pub fn sdf(&self, p: DVec3) -> f64 {
        match *self {
            Burr::Round { diameter_mm } => {
                let r = diameter_mm / 2.0;
                (p - DVec3::new(0.0, 0.0, r)).length() - r
            }
        }
    }

    /// Radius of a ball about the tool origin that holds the cutting head.
    pub fn bounding_radius(&self) -> f64 {
        match *self {
            Burr::Round { diameter_mm } => diameter_mm,
        }
    }
}
