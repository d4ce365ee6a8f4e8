//! Runs the bench's force_query row many times over, for profiling the contact query
//! (`dentsim bench` is the reference).
use dentsim_bench::{bench_tooth, force_query};

fn main() {
    let tooth = bench_tooth().unwrap();
    let iterations: usize = std::env::args().nth(1).map_or(20_000, |a| a.parse().unwrap());
    let row = force_query(&tooth, 256, iterations).unwrap();
    println!("force_query p50 {:.1} us, p99 {:.1} us", row.ours_median_us, row.ours_p99_us);
}
