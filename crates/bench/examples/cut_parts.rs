//! Splits the bench's cut ticks into sweep and per-tissue subtract (fastest of several runs), for
//! profiling (`dentsim bench` is the reference).
use std::time::Instant;

use dentsim_bench::{bench_stroke_tip, bench_tooth};
use dentsim_sim::burr::Burr;
use dentsim_sim::cutting::sweep::{CutBall, Sweep};
use dentsim_vdb::Measure;
use glam::DVec3;

fn main() {
    let tooth = bench_tooth().unwrap();
    let burr = Burr::round(1.0).unwrap();
    let tip = |i| bench_stroke_tip(tooth.occlusal, i);
    let rounds = 6;
    let n = 400;
    let tissues = tooth.model.tissues.len();
    let mut sweep_t = vec![f64::INFINITY; n];
    let mut sub_t = vec![vec![f64::INFINITY; n]; tissues];
    let mut changed = vec![0u64; tissues];
    let mut read = 0usize;
    // SKIP=1: unmeasured cuts, as a session's haptic ticks make.
    let measure = if std::env::var("SKIP").is_ok() { Measure::Skip } else { Measure::Volume };
    for _ in 0..rounds {
        let mut model = tooth.model.clone();
        model.voxelize_for_cutting().unwrap();
        let mut sweep = Sweep::default();
        let mut log = Vec::new();
        for i in 0..n {
            let done = (i > 0).then(|| CutBall { centre: tip(i).transform_point3(DVec3::new(0.0, 0.0, 0.5)), radius: 0.5 });
            let s = Instant::now();
            sweep.build(&burr, tip(i), tip(i + 1), 0.05, 0.15, done).unwrap();
            sweep_t[i] = sweep_t[i].min(s.elapsed().as_secs_f64() * 1e6);
            read += sweep.patch.values.iter().filter(|v| **v < 0.2).count();
            for (k, t) in model.tissues.iter_mut().enumerate() {
                log.clear();
                let s = Instant::now();
                let st = t.grid.subtract_logged(&sweep.patch, 0.0, measure, &mut log).unwrap();
                sub_t[k][i] = sub_t[k][i].min(s.elapsed().as_secs_f64() * 1e6);
                changed[k] += st.changed_voxels;
            }
        }
    }
    let med = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    println!("sweep p50 {:.1} us, voxels within reach {}/tick", med(&mut sweep_t), read / (n * rounds));
    for (k, t) in tooth.model.tissues.iter().enumerate() {
        println!("{:<7} subtract p50 {:.1} us, changed {}/tick", t.props.name, med(&mut sub_t[k]), changed[k] / (n * rounds) as u64);
    }
}
