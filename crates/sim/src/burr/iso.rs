//! ISO 6360 burr numbers: material-shank-shape-grit-size, five groups of three digits
//! (`806 314 243 524 016`). Only the codes REFERENCE.md ("Burrs") lists are accepted; the
//! standard's shape numbers for cylinder, taper, wheel, needle and X-mas heads are not in our
//! reference, so those burrs are named by shorthand or catalogue entry instead of guessed codes.
use serde::Serialize;

use super::Shape;
use crate::error::{invalid, Result};

/// A parsed ISO 6360 number.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct IsoNumber {
    pub material: u16,
    pub shank: u16,
    pub shape: Shape,
    pub shape_code: u16,
    pub grit: u16,
    /// Largest head diameter in 0.1 mm.
    pub size: u16,
}

/// Materials: 500 tungsten carbide, 806/807 diamond (REFERENCE.md "Burrs").
const MATERIALS: [(u16, &str); 3] = [(500, "carbide"), (806, "diamond"), (807, "diamond")];
/// Shanks and their diameters: 314 FG 1.6 mm, 204 RA 2.35 mm, 103 HP (2.35 mm, the handpiece
/// shank's usual diameter; REFERENCE.md gives none for HP).
const SHANKS: [(u16, &str, f64); 3] = [(314, "FG", 1.6), (204, "RA", 2.35), (103, "HP", 2.35)];
/// Shape codes from REFERENCE.md only.
const SHAPES: [(u16, Shape); 4] = [(1, Shape::Round), (10, Shape::InvertedCone), (237, Shape::Pear), (243, Shape::Flame)];
/// Grit codes run from 494 (15 µm) to 544 (180 µm); carbide burrs use other finish codes, which we
/// accept as long as they have three digits.
const DIAMOND_GRITS: std::ops::RangeInclusive<u16> = 494..=544;

impl IsoNumber {
    pub fn diameter_mm(&self) -> f64 {
        f64::from(self.size) / 10.0
    }

    pub fn shank_diameter_mm(&self) -> f64 {
        SHANKS.iter().find(|s| s.0 == self.shank).map_or(1.6, |s| s.2)
    }
}

impl std::fmt::Display for IsoNumber {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{:03} {:03} {:03} {:03} {:03}", self.material, self.shank, self.shape_code, self.grit, self.size)
    }
}

/// Parses `806 314 243 524 016` (spaces, dots or dashes between groups, or 15 digits together).
pub fn parse_iso(text: &str) -> Result<IsoNumber> {
    let what = || format!("ISO burr number '{text}'");
    let compact: String = text.chars().filter(|c| !matches!(c, ' ' | '.' | '-')).collect();
    let groups: Vec<&str> = if compact.len() == 15 && compact.chars().all(|c| c.is_ascii_digit()) {
        (0..5).map(|i| &compact[3 * i..3 * i + 3]).collect()
    } else {
        text.split([' ', '.', '-']).filter(|g| !g.is_empty()).collect()
    };
    if groups.len() != 5 {
        return Err(invalid(what(), format!("has {} groups, expected 5 (material shank shape grit size)", groups.len())));
    }
    let names = ["material", "shank", "shape", "grit", "size"];
    let mut codes = [0u16; 5];
    for (i, g) in groups.iter().enumerate() {
        if g.len() != 3 || !g.chars().all(|c| c.is_ascii_digit()) {
            return Err(invalid(what(), format!("{} '{g}' is not a three-digit code", names[i])));
        }
        codes[i] = g.parse().map_err(|_| invalid(what(), format!("{} '{g}' is not a number", names[i])))?;
    }
    let [material, shank, shape_code, grit, size] = codes;
    if !MATERIALS.iter().any(|m| m.0 == material) {
        return Err(invalid(what(), format!("material '{}' is not known (known: 500 carbide, 806/807 diamond)", groups[0])));
    }
    if !SHANKS.iter().any(|s| s.0 == shank) {
        return Err(invalid(what(), format!("shank '{}' is not known (known: 314 FG, 204 RA, 103 HP)", groups[1])));
    }
    let shape = SHAPES.iter().find(|s| s.0 == shape_code).map(|s| s.1).ok_or_else(|| {
        invalid(
            what(),
            format!(
                "shape '{}' is not one we know (001 round, 010 inverted cone, 237 pear, 243 flame); name other shapes by shorthand, e.g. cylinder_flat:1.2:4",
                groups[2]
            ),
        )
    })?;
    if material != 500 && !DIAMOND_GRITS.contains(&grit) {
        return Err(invalid(what(), format!("grit '{}' is outside the diamond grits 494..544", groups[3])));
    }
    if !(1..=100).contains(&size) {
        return Err(invalid(what(), format!("size '{}' is not a head diameter of 0.1 to 10 mm", groups[4])));
    }
    Ok(IsoNumber { material, shank, shape, shape_code, grit, size })
}
