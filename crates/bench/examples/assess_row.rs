//! Times `dentsim bench`'s assess row alone: `cargo run --release --example assess_row [reps]`.
use dentsim_bench::{assess, bench_tooth, BenchConfig};

fn main() {
    let reps = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(150);
    let cfg = BenchConfig { repetitions: reps, ..BenchConfig::quick() };
    let tooth = bench_tooth().expect("bench tooth");
    let r = assess(&tooth, cfg).expect("assess");
    println!("{:<8} p50 {:>10.0} µs  p99 {:>10.0} µs  peer p50 {:>10.0} µs  {:>5.2}×  {}", r.name, r.ours_median_us, r.ours_p99_us, r.peer_median_us, r.ratio, r.peer);
}
