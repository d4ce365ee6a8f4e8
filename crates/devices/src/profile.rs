//! Rendering limits of force-feedback devices, kept as data (`profiles.toml`).
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// What a device can render; the force model clamps to these.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DeviceProfile {
    pub name: String,
    pub label: String,
    pub max_force_n: f64,
    pub max_stiffness_n_per_mm: f64,
    pub workspace_radius_mm: f64,
}

#[derive(Deserialize)]
struct Table {
    device: Vec<DeviceProfile>,
}

const BUILT_IN: &str = include_str!("profiles.toml");

impl DeviceProfile {
    /// The profile sessions use unless told otherwise.
    pub const DEFAULT_NAME: &'static str = "desktop";

    /// Every built-in profile (REFERENCE.md "Devices").
    pub fn all() -> Vec<DeviceProfile> {
        Self::parse(BUILT_IN, "built-in").expect("built-in device table is valid")
    }

    /// A built-in profile by short name (`touch`, `omni`, `desktop`, `premium15`, `falcon`, `omega`).
    pub fn named(name: &str) -> Result<DeviceProfile> {
        let all = Self::all();
        let names: Vec<String> = all.iter().map(|p| p.name.clone()).collect();
        all.into_iter().find(|p| p.name == name).ok_or_else(|| Error::Invalid {
            what: format!("device profile '{name}'"),
            message: format!("unknown; known: {}", names.join(", ")),
        })
    }

    /// Parses a table of `[[device]]` entries; every limit must be finite and positive.
    pub fn parse(text: &str, source_name: &str) -> Result<Vec<DeviceProfile>> {
        let err = |message: String| Error::Profile { source_name: source_name.into(), message };
        let t: Table = toml::from_str(text).map_err(|e| err(e.to_string()))?;
        for p in &t.device {
            for (field, v) in [
                ("max_force_n", p.max_force_n),
                ("max_stiffness_n_per_mm", p.max_stiffness_n_per_mm),
                ("workspace_radius_mm", p.workspace_radius_mm),
            ] {
                if !(v.is_finite() && v > 0.0) {
                    return Err(err(format!("device '{}' field {field} is {v}, expected > 0", p.name)));
                }
            }
        }
        Ok(t.device)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn built_in_table_matches_reference() {
        let touch = DeviceProfile::named("touch").unwrap();
        assert_eq!((touch.max_force_n, touch.max_stiffness_n_per_mm), (3.3, 0.4));
        assert_eq!(DeviceProfile::all().len(), 6);
        assert!(DeviceProfile::named("wii").unwrap_err().to_string().contains("omega"));
    }

    #[test]
    fn bad_limits_name_the_field() {
        let e = DeviceProfile::parse(
            "[[device]]\nname='x'\nlabel='x'\nmax_force_n=-1\nmax_stiffness_n_per_mm=1\nworkspace_radius_mm=1\n",
            "mine.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("mine.toml") && e.contains("max_force_n"), "{e}");
    }
}
