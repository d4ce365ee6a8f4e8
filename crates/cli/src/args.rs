//! Argument parsers shared by the subcommands.
use std::path::Path;

use anyhow::{Context, Result};
use dentsim_sim::tissues::table::TissueTable;

/// The memory cap every command that reads tissues or scans takes (one definition).
#[derive(clap::Args, Clone, Copy)]
pub struct MemoryArgs {
    /// Refuse inputs whose data would need more memory than this (GiB), checked before allocating.
    #[arg(long, allow_negative_numbers = true, default_value_t = dentsim_sim::limits::DEFAULT_MAX_MEMORY_GIB)]
    pub max_memory_gib: f64,
}

/// How long a session may run (session and replay).
#[derive(clap::Args, Clone, Copy)]
pub struct DurationArgs {
    /// Refuse devices and logs that run longer than this (s of session time).
    #[arg(long, allow_negative_numbers = true, default_value_t = dentsim_sim::limits::DEFAULT_MAX_SESSION_S)]
    pub max_duration_s: f64,
}

/// The limits of a command from its options; errors name the option.
pub fn limits(memory: MemoryArgs, duration: Option<DurationArgs>) -> Result<dentsim_sim::Limits> {
    let seconds = duration.map_or(dentsim_sim::limits::DEFAULT_MAX_SESSION_S, |d| d.max_duration_s);
    Ok(dentsim_sim::Limits::new(memory.max_memory_gib, seconds)?)
}

/// "X,Y,Z" in mm.
pub fn parse_xyz(text: &str) -> Result<[f64; 3], String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| match v.trim().parse::<f64>() {
            Ok(x) if x.is_finite() => Ok(x),
            Ok(x) => Err(format!("'{v}' is {x}, expected a finite number of mm")),
            Err(e) => Err(format!("'{v}': {e}")),
        })
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
