use anyhow::Result;
use dentsim_bench::{run_all, segment_scan, BenchConfig, BenchRow};

#[derive(clap::Args)]
pub struct Args {
    /// Print the rows as a JSON array instead of a table.
    #[arg(long)]
    json: bool,
    /// A few repetitions only: checks that every row runs, figures are not meaningful.
    #[arg(long)]
    quick: bool,
    /// Run only the segmentation row, in this process (how `bench` measures its peak memory).
    #[arg(long, hide = true)]
    segment_scan_only: bool,
}

pub fn run(args: &Args) -> Result<()> {
    if args.segment_scan_only {
        println!("{}", serde_json::to_string(&segment_scan(args.quick)?)?);
        return Ok(());
    }
    let cfg = if args.quick { BenchConfig::quick() } else { BenchConfig::full() };
    let bar = crate::progress::bar(0);
    bar.set_message("segment_scan (own process)");
    let mut rows = vec![segment_scan_in_child(args.quick)?];
    rows.extend(run_all(cfg, &mut |step| bar.set_message(step.to_owned()))?);
    bar.finish_and_clear();
    if args.json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
    } else {
        print_table(&rows);
    }
    Ok(())
}

/// The segmentation row in a fresh process, so that its peak memory is its own.
fn segment_scan_in_child(quick: bool) -> Result<BenchRow> {
    let mut command = std::process::Command::new(std::env::current_exe()?);
    command.args(["bench", "--segment-scan-only"]);
    if quick {
        command.arg("--quick");
    }
    let out = command.output()?;
    if !out.status.success() {
        anyhow::bail!("segment_scan: {}", String::from_utf8_lossy(&out.stderr));
    }
    Ok(serde_json::from_slice(&out.stdout)?)
}

fn print_table(rows: &[BenchRow]) {
    println!(
        "{:<24} {:>12} {:>12} {:>12} {:>12} {:>8}  peer (or goal where no peer runs)",
        "operation", "ours p50 µs", "ours p99 µs", "ours p99.9", "peer p50 µs", "ratio"
    );
    let cell = |v: Option<f64>, width: usize| match v {
        Some(v) if v.is_finite() => format!("{v:>width$.3}"),
        _ => format!("{:>width$}", "-"),
    };
    for r in rows {
        println!(
            "{:<24} {} {} {} {} {}  {}",
            r.name,
            cell(Some(r.ours_median_us), 12),
            cell(Some(r.ours_p99_us), 12),
            cell(r.ours_p999_us, 12),
            cell(Some(r.peer_median_us), 12),
            if r.ratio.is_finite() { format!("{:>7.2}×", r.ratio) } else { format!("{:>8}", "-") },
            r.peer
        );
        if let Some(mb) = r.peak_memory_mb {
            println!("{:<24} peak memory {mb:.0} MB", "");
        }
    }
}
