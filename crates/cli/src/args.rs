//! Argument parsers shared by the subcommands.
use std::path::Path;

use anyhow::{Context, Result};
use dentsim_sim::tissues::table::TissueTable;

/// "X,Y,Z" in mm.
pub fn parse_xyz(text: &str) -> Result<[f64; 3], String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| v.trim().parse::<f64>().map_err(|e| format!("'{v}': {e}")))
        .collect::<Result<_, _>>()?;
    values.try_into().map_err(|v: Vec<f64>| format!("expected X,Y,Z (3 numbers), got {}", v.len()))
}

/// The built-in tissue table, with a user's TOML file applied on top when given.
pub fn tissue_table(path: Option<&Path>) -> Result<TissueTable> {
    match path {
        Some(path) => {
            let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
            Ok(TissueTable::default().with_overrides(&text, &path.display().to_string())?)
        }
        None => Ok(TissueTable::default()),
    }
}
