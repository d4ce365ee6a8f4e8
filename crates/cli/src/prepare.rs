use std::path::PathBuf;

use anyhow::{bail, Result};
use dentsim_sim::plan::prepare::{prepare_to_dir, PrepareOptions};

#[derive(clap::Args)]
pub struct Args {
    /// A .vdb whose level-set grids are named by tissue (from `dentsim segment`, or OpenVDB's tools).
    tissues: PathBuf,
    /// Tool path CSV: t,x,y,z,qw,qx,qy,qz[,rpm][,cut] (s, mm, unit quaternion: burr frame to scan).
    #[arg(long)]
    path: PathBuf,
    /// Burr: a catalogue name, an ISO 6360 number ("806 314 001 524 010"), or SHAPE:DIAMETER_MM[:LENGTH_MM].
    #[arg(long)]
    burr: String,
    /// Output folder: prepared tissues.vdb, <tissue>.vtp/.stl, prepare.json.
    #[arg(long)]
    out: PathBuf,
    /// Cut at the tissues' removal rates under this applied force (N) instead of purely geometrically.
    #[arg(long)]
    force: Option<f64>,
    /// Tissue table overrides (TOML), for grids without dentsim metadata.
    #[arg(long)]
    tissues_table: Option<PathBuf>,
    #[command(flatten)]
    memory: crate::args::MemoryArgs,
}

pub fn run(args: &Args) -> Result<()> {
    if let Some(f) = args.force {
        if !(f.is_finite() && f > 0.0) {
            bail!("--force: {f} N is not a positive force");
        }
    }
    let table = crate::args::tissue_table(args.tissues_table.as_deref())?;
    let limits = crate::args::limits(args.memory, None)?;
    let options = PrepareOptions { force_n: args.force, limits, ..PrepareOptions::default() };
    let bar = crate::progress::bar(100);
    let summary = prepare_to_dir(&args.tissues, &args.path, &args.burr, &options, &table, &args.out, &mut |step, f| {
        bar.set_message(step.to_owned());
        bar.set_position((f * 100.0) as u64);
    })?;
    bar.finish_and_clear();
    println!("burr {}: {} strokes", summary.report.burr, summary.report.strokes.len());
    for (name, removed) in &summary.report.removed_mm3 {
        println!("{name:<16} removed {removed:>9.3} mm³");
    }
    println!("wrote {}", args.out.display());
    Ok(())
}
