use std::path::PathBuf;

use anyhow::Result;
use dentsim_sim::plan::batch::{merge, run_shard, Manifest, Shard, REPORT_CSV};

#[derive(clap::Args)]
pub struct Args {
    /// Manifest (JSON): {"scans": [...], "preparations": [...]}; every scan is prepared every way.
    manifest: PathBuf,
    /// Output folder: cases/<scan>__<preparation>/ (tissues.vdb, case.json), report.csv, report.json.
    #[arg(long)]
    out: PathBuf,
    /// Run only shard I of N (from 0), e.g. --shard $SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT;
    /// merge afterwards with --merge.
    #[arg(long)]
    shard: Option<String>,
    /// Only merge the cases already run into report.csv/report.json (errors name missing cases;
    /// with --shard I/N, the shard of N that should have run each).
    #[arg(long)]
    merge: bool,
    /// Tissue table overrides (TOML), for grids without dentsim metadata.
    #[arg(long)]
    tissues_table: Option<PathBuf>,
}

pub fn run(args: &Args) -> Result<()> {
    let manifest = Manifest::read(&args.manifest)?;
    let table = crate::args::tissue_table(args.tissues_table.as_deref())?;
    let shard = args.shard.as_deref().map(Shard::parse).transpose()?;
    if !args.merge {
        let shard = shard.unwrap_or(Shard::WHOLE);
        let bar = crate::progress::bar(100);
        let reports = run_shard(&manifest, &args.out, shard, &table, &mut |case, f| {
            bar.set_message(case.to_owned());
            bar.set_position((f * 100.0) as u64);
        })?;
        bar.finish_and_clear();
        for r in &reports {
            let removed: f64 = r.tissues.iter().map(|t| t.removed_mm3).sum();
            println!("{:<40} removed {removed:>9.3} mm³ in {:.2} s", r.case, r.seconds);
        }
        if args.shard.is_some() {
            println!("shard {}/{}: {} cases; merge with --merge when every shard is done", shard.index, shard.count, reports.len());
            return Ok(());
        }
    }
    let shards = shard.map_or(1, |s| s.count);
    let reports = merge(&manifest, &args.out, shards)?;
    println!("{} cases; wrote {}", reports.len(), args.out.join(REPORT_CSV).display());
    Ok(())
}
