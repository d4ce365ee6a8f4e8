//! A catalogue of common burrs by name, from `burrs.toml` (or a user's file of the same form).
use serde::Deserialize;

use super::{parse_iso, Burr, Shape};
use crate::error::{invalid, Error, Result};

/// One catalogue row: either an ISO number, or a shape with diameter (and length).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Entry {
    pub name: String,
    pub iso: Option<String>,
    pub shape: Option<Shape>,
    pub diameter_mm: Option<f64>,
    pub length_mm: Option<f64>,
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Catalogue {
    #[serde(rename = "burr")]
    pub burrs: Vec<Entry>,
}

const BUILTIN: &str = include_str!("../../burrs.toml");

impl Entry {
    pub fn burr(&self) -> Result<Burr> {
        let what = || format!("burr '{}'", self.name);
        match (&self.iso, self.shape, self.diameter_mm) {
            (Some(iso), None, None) => {
                let mut b = Burr::from_iso(&parse_iso(iso)?)?;
                if let Some(l) = self.length_mm {
                    let iso = b.iso;
                    b = Burr::with_shank(b.shape, b.diameter_mm, Some(l), b.shank_diameter_mm)?;
                    b.iso = iso;
                }
                Ok(b)
            }
            (None, Some(shape), Some(d)) => Burr::new(shape, d, self.length_mm).map_err(|e| invalid(what(), e.to_string())),
            _ => Err(invalid(what(), "needs either `iso`, or `shape` and `diameter_mm`")),
        }
    }
}

impl Catalogue {
    /// The built-in catalogue (checked by a test, so parsing cannot fail at run time).
    pub fn builtin() -> &'static Catalogue {
        static CAT: std::sync::OnceLock<Catalogue> = std::sync::OnceLock::new();
        CAT.get_or_init(|| Catalogue::parse(BUILTIN, "built-in burrs.toml").unwrap_or(Catalogue { burrs: Vec::new() }))
    }

    pub fn parse(text: &str, source_name: &str) -> Result<Self> {
        let cat: Catalogue = toml::from_str(text).map_err(|e| Error::Invalid { what: source_name.into(), message: e.to_string() })?;
        for e in &cat.burrs {
            e.burr().map_err(|err| invalid(source_name, err.to_string()))?;
        }
        Ok(cat)
    }

    pub fn get(&self, name: &str) -> Option<&Entry> {
        self.burrs.iter().find(|e| e.name == name)
    }
}
