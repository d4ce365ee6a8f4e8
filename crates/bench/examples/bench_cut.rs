//! Prints the cutting and re-meshing rows of `dentsim bench` (peer measured in the same run).
use dentsim_bench::{bench_tooth, cut_stroke, remesh_stroke, BenchConfig};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let cfg = BenchConfig::full();
    let tooth = bench_tooth()?;
    let mut rows = cut_stroke(&tooth, cfg)?;
    rows.push(remesh_stroke(&tooth, cfg)?);
    for row in rows {
        println!(
            "{:<14} ours median {:>9.1} µs  p99 {:>9.1} µs | peer ({}) median {:>9.1} µs | ×{:.1}",
            row.name, row.ours_median_us, row.ours_p99_us, row.peer, row.peer_median_us, row.ratio
        );
    }
    Ok(())
}
