//! Splits the bench's cut ticks into sweep and per-tissue subtract (fastest of several runs), for
//! profiling (`dentsim bench` is the reference). `BURR=spec` for another burr (default the round
//! 1 mm); `SKIP=1` for unmeasured cuts, as a session's haptic ticks make (then swept as the
//! haptic cutter sweeps: in columns where it can, subtracted along their runs).
/// This thread's CPU time since `start` (µs): unlike the wall clock, not inflated while other
/// work holds the cores.
fn cpu_us(start: ThreadTime) -> f64 {
    start.elapsed().as_secs_f64() * 1e6
}

use cpu_time::ThreadTime;
use dentsim_bench::{bench_stroke_tip, bench_tooth};
use dentsim_sim::burr::Burr;
use dentsim_sim::cutting::sweep::{CutBall, CutHead, Done, Sweep};
use dentsim_vdb::Measure;
use glam::DVec3;

fn main() {
    let tooth = bench_tooth().unwrap();
    let burr = Burr::parse(&std::env::var("BURR").unwrap_or_else(|_| "round:1".into())).unwrap();
    let tip = |i| bench_stroke_tip(tooth.occlusal, i);
    let rounds = 4;
    // STROKES=N: how many ticks (instruction counts of two runs differ by the strokes alone).
    let n = std::env::var("STROKES").ok().and_then(|s| s.parse().ok()).unwrap_or(400);
    let tissues = tooth.model.tissues.len();
    let mut sweep_t = vec![f64::INFINITY; n];
    let mut sub_t = vec![vec![f64::INFINITY; n]; tissues];
    let mut changed = vec![0u64; tissues];
    let (mut within, mut spanned) = (0usize, 0usize);
    let measure = if std::env::var("SKIP").is_ok() { Measure::Skip } else { Measure::Volume };
    let (h, band) = (0.05, 0.15);
    let cutoff = (band + 1.5 * h) as f32;
    for _ in 0..rounds {
        let mut model = tooth.model.clone();
        model.voxelize_for_cutting().unwrap();
        let mut sweep = Sweep::default();
        let skip = measure == Measure::Skip;
        sweep.set_unmeasured(skip);
        sweep.set_columns(skip);
        sweep.set_runs_only(skip);
        let mut log = Vec::new();
        for i in 0..n {
            let done = (i > 0).then(|| match burr.ball_radius() {
                Some(r) => Done::Ball(CutBall { centre: tip(i).transform_point3(DVec3::new(0.0, 0.0, r)), radius: r }),
                None => Done::Head(CutHead { to_tool: tip(i).inverse(), offset: 0.0 }),
            });
            let grids = &model.tissues;
            let s = ThreadTime::now();
            sweep
                .build_in(&burr, tip(i), tip(i + 1), h, band, done, |lo, dims, blocks| {
                    grids.iter().try_for_each(|t| t.grid.mark_material_blocks(lo, dims, blocks).map_err(Into::into))
                })
                .unwrap();
            sweep_t[i] = sweep_t[i].min(cpu_us(s));
            within += sweep.patch.values.iter().filter(|v| **v < cutoff).count();
            spanned += sweep.patch.spans.chunks(2).map(|s| (s[1] - s[0]) as usize).sum::<usize>();
            for (k, t) in model.tissues.iter_mut().enumerate() {
                log.clear();
                let s = ThreadTime::now();
                let st = t.grid.subtract_logged_runs(&sweep.patch, sweep.column_runs(), 0.0, measure, &mut log).unwrap();
                sub_t[k][i] = sub_t[k][i].min(cpu_us(s));
                changed[k] += st.changed_voxels;
            }
        }
    }
    let med = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        (v[v.len() / 2], v[v.len() * 99 / 100])
    };
    let (p50, p99) = med(&mut sweep_t);
    println!("{}: sweep p50 {p50:.1} us p99 {p99:.1} us, voxels below the cut-off {}/tick, spanned {}/tick", burr.spec(), within / (n * rounds), spanned / (n * rounds));
    for (k, t) in tooth.model.tissues.iter().enumerate() {
        let (p50, p99) = med(&mut sub_t[k]);
        println!("{:<7} subtract p50 {p50:.1} us p99 {p99:.1} us, changed {}/tick", t.props.name, changed[k] / (n * rounds) as u64);
    }
}
