//! The tissue table: per-tissue label, colour and mechanics, defaults from `tissues.toml`.
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// Mechanical and display properties of one tissue (units in the field names).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TissueProps {
    pub name: String,
    pub label: u8,
    pub colour: [f32; 3],
    pub opacity: f32,
    pub stiffness_n_per_mm: f64,
    pub damping_n_s_per_mm: f64,
    pub removal_rate_mm3_per_n_s: f64,
}

impl TissueProps {
    /// The rules every source of properties keeps (a TOML table, a .vdb grid's metadata); the
    /// error names the tissue and field.
    pub fn check(&self) -> std::result::Result<(), String> {
        let field = |f: &str| format!("tissue '{}' field {f}", self.name);
        let non_negative = [
            ("stiffness_n_per_mm", self.stiffness_n_per_mm),
            ("damping_n_s_per_mm", self.damping_n_s_per_mm),
            ("removal_rate_mm3_per_n_s", self.removal_rate_mm3_per_n_s),
        ];
        for (name, v) in non_negative {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("{} is {v}, expected a finite number >= 0", field(name)));
            }
        }
        if !(0.0..=1.0).contains(&self.opacity) || self.colour.iter().any(|c| !(0.0..=1.0).contains(c)) {
            return Err(format!("{} and colour must lie in 0..1", field("opacity")));
        }
        Ok(())
    }
}

/// All tissues dentsim knows, in label order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TissueTable {
    #[serde(rename = "tissue")]
    pub tissues: Vec<TissueProps>,
}

/// A user's override file: any subset of tissues, any subset of their fields.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Overrides {
    #[serde(default, rename = "tissue")]
    tissues: Vec<TissueOverride>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct TissueOverride {
    name: String,
    label: Option<u8>,
    colour: Option<[f32; 3]>,
    opacity: Option<f32>,
    stiffness_n_per_mm: Option<f64>,
    damping_n_s_per_mm: Option<f64>,
    removal_rate_mm3_per_n_s: Option<f64>,
}

const DEFAULTS: &str = include_str!("../../tissues.toml");

impl Default for TissueTable {
    fn default() -> Self {
        Self::parse(DEFAULTS, "built-in").expect("built-in tissue table is valid")
    }
}

impl TissueTable {
    /// Parses a complete table.
    pub fn parse(text: &str, source_name: &str) -> Result<Self> {
        let table: TissueTable = toml::from_str(text).map_err(|e| Error::TissueTable {
            source_name: source_name.into(),
            message: e.to_string(),
        })?;
        table.validate(source_name)?;
        Ok(table)
    }

    /// The defaults with a user's file applied on top (fields it names replace the defaults).
    pub fn with_overrides(mut self, text: &str, source_name: &str) -> Result<Self> {
        let err = |message: String| Error::TissueTable { source_name: source_name.into(), message };
        let overrides: Overrides = toml::from_str(text).map_err(|e| err(e.to_string()))?;
        // A second entry would silently replace the first's values.
        for (i, o) in overrides.tissues.iter().enumerate() {
            if overrides.tissues[..i].iter().any(|p| p.name == o.name) {
                return Err(err(format!("tissue '{}' appears twice ([[tissue]] entries {} and {})", o.name, overrides.tissues[..i].iter().position(|p| p.name == o.name).unwrap_or(0) + 1, i + 1)));
            }
        }
        for o in overrides.tissues {
            let t = match self.tissues.iter_mut().position(|t| t.name == o.name) {
                Some(i) => &mut self.tissues[i],
                None => return Err(err(format!("unknown tissue '{}'", o.name))),
            };
            t.label = o.label.unwrap_or(t.label);
            t.colour = o.colour.unwrap_or(t.colour);
            t.opacity = o.opacity.unwrap_or(t.opacity);
            t.stiffness_n_per_mm = o.stiffness_n_per_mm.unwrap_or(t.stiffness_n_per_mm);
            t.damping_n_s_per_mm = o.damping_n_s_per_mm.unwrap_or(t.damping_n_s_per_mm);
            t.removal_rate_mm3_per_n_s = o.removal_rate_mm3_per_n_s.unwrap_or(t.removal_rate_mm3_per_n_s);
        }
        self.validate(source_name)?;
        Ok(self)
    }

    pub fn get(&self, name: &str) -> Option<&TissueProps> {
        self.tissues.iter().find(|t| t.name == name)
    }

    fn validate(&self, source_name: &str) -> Result<()> {
        let err = |message: String| Error::TissueTable { source_name: source_name.into(), message };
        for (i, t) in self.tissues.iter().enumerate() {
            t.check().map_err(err)?;
            if let Some(other) = self.tissues[..i].iter().find(|o| o.name == t.name || o.label == t.label) {
                return Err(err(format!("tissues '{}' and '{}' share a name or label", other.name, t.name)));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_hold_every_segmented_tissue() {
        let table = TissueTable::default();
        for name in ["soft_tissue", "bone_cancellous", "bone_cortical", "dentin", "enamel", "pulp", "caries"] {
            assert!(table.get(name).is_some(), "{name}");
        }
        let (enamel, dentin, pulp) = (table.get("enamel").unwrap(), table.get("dentin").unwrap(), table.get("pulp").unwrap());
        assert!(enamel.stiffness_n_per_mm > dentin.stiffness_n_per_mm);
        assert!(dentin.stiffness_n_per_mm > pulp.stiffness_n_per_mm);
        assert!(enamel.removal_rate_mm3_per_n_s < dentin.removal_rate_mm3_per_n_s);
    }

    #[test]
    fn overrides_replace_only_named_fields() {
        let table = TissueTable::default()
            .with_overrides("[[tissue]]\nname = \"dentin\"\nstiffness_n_per_mm = 0.6\n", "user.toml")
            .unwrap();
        let dentin = table.get("dentin").unwrap();
        assert_eq!(dentin.stiffness_n_per_mm, 0.6);
        assert_eq!(dentin.label, TissueTable::default().get("dentin").unwrap().label);
    }

    #[test]
    fn bad_overrides_name_the_field() {
        let e = TissueTable::default()
            .with_overrides("[[tissue]]\nname = \"enamel\"\nstiffness_n_per_mm = -1\n", "user.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("user.toml") && e.contains("stiffness_n_per_mm"), "{e}");
        let e = TissueTable::default()
            .with_overrides("[[tissue]]\nname = \"tongue\"\n", "user.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("tongue"), "{e}");
        let e = TissueTable::default()
            .with_overrides("[[tissue]]\nname = \"enamel\"\nstifness = 1\n", "user.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("stifness"), "{e}");
    }

    #[test]
    fn a_tissue_named_twice_is_refused_in_overrides_and_whole_tables() {
        let twice = "[[tissue]]\nname = \"enamel\"\nstiffness_n_per_mm = 5\n[[tissue]]\nname = \"enamel\"\nstiffness_n_per_mm = 9\n";
        let e = TissueTable::default().with_overrides(twice, "user.toml").unwrap_err().to_string();
        assert!(e.contains("user.toml") && e.contains("'enamel' appears twice"), "{e}");
        let mut whole = toml::to_string(&TissueTable::default()).unwrap();
        let enamel = toml::to_string(&TissueTable { tissues: vec![TissueTable::default().get("enamel").unwrap().clone()] }).unwrap();
        whole.push_str(&enamel);
        let e = TissueTable::parse(&whole, "full.toml").unwrap_err().to_string();
        assert!(e.contains("full.toml") && e.contains("enamel"), "{e}");
    }
}
