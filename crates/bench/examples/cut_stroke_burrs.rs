//! Times `dentsim bench`'s cut_stroke rows for every burr family alone (for profiling the cut of
//! one shape without the rest of the bench): `cargo run --release --example cut_stroke_burrs [reps]`.
use dentsim_bench::{bench_tooth, cut_stroke, cut_stroke_burr, BenchConfig, CUT_STROKE_FAMILIES};

fn main() {
    let reps = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(100);
    let cfg = BenchConfig { repetitions: reps, ..BenchConfig::quick() };
    let tooth = bench_tooth().expect("bench tooth");
    let mut rows = cut_stroke(&tooth, cfg).expect("round");
    for (row, spec) in CUT_STROKE_FAMILIES {
        rows.push(cut_stroke_burr(&tooth, cfg, row, spec).expect(spec));
    }
    for r in rows {
        println!("{:<26} p50 {:>9.1} µs  p99 {:>9.1} µs  peer p50 {:>10.1} µs  {:>7.1}×  {}", r.name, r.ours_median_us, r.ours_p99_us, r.peer_median_us, r.ratio, r.peer);
    }
}
