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
        "{:<18} {:>12} {:>12} {:>12} {:>12} {:>8}  peer (or goal where no peer runs)",
        "operation", "ours p50 µs", "ours p99 µs", "ours p99.9", "peer p50 µs", "ratio"
    );
    let cell = |v: Option<f64>, width: usize| match v {
        Some(v) if v.is_finite() => format!("{v:>width$.3}"),
        _ => format!("{:>width$}", "-"),
    };
    for r in rows {
        println!(
            "{:<18} {} {} {} {} {}  {}",
            r.name,
            cell(Some(r.ours_median_us), 12),
            cell(Some(r.ours_p99_us), 12),
            cell(r.ours_p999_us, 12),
            cell(Some(r.peer_median_us), 12),
            if r.ratio.is_finite() { format!("{:>7.2}×", r.ratio) } else { format!("{:>8}", "-") },
            r.peer
        );
    }
}
