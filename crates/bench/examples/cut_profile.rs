//! Times the bench's cut_stroke ticks over several fresh copies of the tooth and keeps each tick's
//! fastest run, so the figures hold on a busy machine (for profiling; `dentsim bench` is the
//! reference).
use dentsim_bench::{bench_stroke_tip, bench_tooth};
use dentsim_sim::burr::Burr;
use dentsim_sim::cutting::cutter::Cutter;
use dentsim_sim::cutting::removal::Feed;

use std::time::Instant;


fn main() {
    let tooth = bench_tooth().unwrap();
    let (model, tip) = (&tooth.model, |i| bench_stroke_tip(tooth.occlusal, i));
    let burr = Burr::round(1.0).unwrap();
    let rounds: usize = std::env::args().nth(1).map_or(10, |a| a.parse().unwrap());
    let mut best = vec![f64::INFINITY; 400];
    let mut voxels = 0u64;
    let mut per_tick = vec![0u64; 400];
    let mut removed = vec![0.0; model.tissues.len()];
    for _ in 0..rounds {
        let mut m = model.clone();
        m.voxelize_for_cutting().unwrap();
        let mut cutter = Cutter::default();
        // SKIP=1: unmeasured cuts, as a session's haptic ticks make.
        if std::env::var("SKIP").is_ok() {
            cutter.set_measure(dentsim_vdb::Measure::Skip);
        }
        cutter.prepare(&mut m, &burr, 0.02);
        cutter.cut_with(&mut m, &burr, tip(0), tip(0), Feed::Geometric).unwrap();
        for (i, b) in best.iter_mut().enumerate() {
            let t = Instant::now();
            let r = cutter.cut_with(&mut m, &burr, tip(i), tip(i + 1), Feed::Geometric).unwrap();
            *b = b.min(t.elapsed().as_secs_f64() * 1e6);
            voxels += r.changed_voxels;
            per_tick[i] = r.changed_voxels;
            for (k, (_, v)) in r.removed_mm3.iter().enumerate() {
                removed[k] += v / rounds as f64;
            }
        }
    }
    if std::env::var("SLOWEST").is_ok() {
        let mut order: Vec<usize> = (0..best.len()).collect();
        order.sort_by(|a, b| best[*b].total_cmp(&best[*a]));
        for &i in &order[..12] {
            println!("tick {i:>3}: {:>6.1} us, {} changed", best[i], per_tick[i]);
        }
    }
    best.sort_by(f64::total_cmp);
    let q = |p: f64| best[((best.len() - 1) as f64 * p) as usize];
    let names: Vec<&str> = model.tissues.iter().map(|t| t.props.name.as_str()).collect();
    println!("removed per run: {:?} mm3 ({names:?})", removed);
    println!("fastest of {rounds}: p50 {:.1} p99 {:.1} max {:.1} us; changed voxels/tick {}", q(0.5), q(0.99), q(1.0), voxels / (400 * rounds) as u64);
}
