use anyhow::Result;
use dentsim_sim::bench::{run_all, BenchConfig, BenchRow};

#[derive(clap::Args)]
pub struct Args {
    /// Print the rows as a JSON array instead of a table.
    #[arg(long)]
    json: bool,
    /// A few repetitions only: checks that every row runs, figures are not meaningful.
    #[arg(long)]
    quick: bool,
}

pub fn run(args: &Args) -> Result<()> {
    let cfg = if args.quick { BenchConfig::quick() } else { BenchConfig::full() };
    let bar = crate::progress::bar(0);
    let rows = run_all(cfg, &mut |step| bar.set_message(step.to_owned()))?;
    bar.finish_and_clear();
    if args.json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
    } else {
        print_table(&rows);
    }
    Ok(())
}

fn print_table(rows: &[BenchRow]) {
    println!(
        "{:<18} {:>14} {:>12} {:>14} {:>8}  peer",
        "operation", "ours p50 µs", "ours p99 µs", "peer p50 µs", "ratio"
    );
    for r in rows {
        println!(
            "{:<18} {:>14.3} {:>12.3} {:>14.3} {:>7.2}×  {}",
            r.name, r.ours_median_us, r.ours_p99_us, r.peer_median_us, r.ratio, r.peer
        );
    }
}
