//! Splits one tick's cut into its parts (sweep fill, per-tissue subtract) for profiling.
use std::time::Instant;

use dentsim_sim::bench::bench_tooth;
use dentsim_sim::burr::Burr;
use dentsim_sim::sweep::Sweep;
use glam::{DAffine3, DVec3};

fn main() {
    let mut model = bench_tooth().unwrap();
    let burr = Burr::round(1.0).unwrap();
    let tip = |i: usize| DAffine3::from_translation(DVec3::new(-1.5 + (i % 150) as f64 * 0.02, 0.0, 5.0 - 0.6 - 0.1 * (i / 150) as f64));
    let mut sweep = Sweep::default();
    let mut log = Vec::new();
    let (mut t_sweep, mut t_sub) = (0.0, vec![0.0; 3]);
    let n: usize = std::env::var("TICKS").ok().and_then(|v| v.parse().ok()).unwrap_or(200);
    let mut changed = 0;
    for i in 0..n {
        let s = Instant::now();
        sweep.build(&burr, tip(i), tip(i + 1), 0.05, 0.15).unwrap();
        t_sweep += s.elapsed().as_secs_f64();
        for (k, t) in model.tissues.iter_mut().enumerate() {
            log.clear();
            let s = Instant::now();
            let st = t.grid.subtract_logged(&sweep.patch, 0.0, &mut log).unwrap();
            t_sub[k] += s.elapsed().as_secs_f64();
            changed += st.changed_voxels;
        }
    }
    println!("patch {:?} = {} voxels", sweep.patch.dims, sweep.patch.values.len());
    println!("sweep {:.1} µs, subtract {:?} µs, changed/tick {}", t_sweep / n as f64 * 1e6, t_sub.iter().map(|t| t / n as f64 * 1e6).collect::<Vec<_>>(), changed / n as u64);
}
