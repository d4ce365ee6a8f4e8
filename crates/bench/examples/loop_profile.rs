//! Runs the bench's real-time cutting session on the molar and prints its tick periods (for
//! profiling the haptic thread; `dentsim bench` is the reference).
use dentsim_bench::{bench_tooth, loop_period};

fn main() {
    let tooth = bench_tooth().unwrap();
    let seconds = std::env::args().nth(1).map_or(3.0, |a| a.parse().unwrap());
    for row in loop_period(&tooth, seconds).unwrap() {
        println!("{:<14} p50 {:>9.1}  p99 {:>9.1}  p99.9 {:?}", row.name, row.ours_median_us, row.ours_p99_us, row.ours_p999_us);
    }
}
