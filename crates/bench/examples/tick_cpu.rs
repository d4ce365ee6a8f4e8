//! cut_stroke's 400 ticks per burr family through a `Cutter` (`Measure::Skip`, as the
//! `cut_stroke_*` rows cut), each tick's thread CPU time, fastest of 3 rounds; p50 / p99 / max,
//! then the p50 and max of the passes and of the plunges (the worst ticks) apart.
//! Thread CPU time barely moves with the machine's load, so two builds compare in ~10 s where the
//! wall-clock rows' p99 is a preemption.
//!
//! `cargo run --release -p dentsim-bench --example tick_cpu [SPEC...]`; `HANDOFF=new` hands each
//! cut's new values on as a session's haptic core does ([`Handoff::NewValues`]) instead of
//! the `cut_stroke` rows' dirty chunks.
use cpu_time::ThreadTime;
use dentsim_bench::{bench_stroke_tip, bench_tooth};
use dentsim_sim::burr::Burr;
use dentsim_sim::cutting::cutter::{Cutter, Handoff};
use dentsim_sim::cutting::removal::Feed;
use dentsim_vdb::Measure;

const FAMILIES: [&str; 6] = [
    "round:1",
    "cylinder_flat_012",
    "taper_flat_012",
    "inverted_cone_010",
    "flame_016",
    "pear_010",
];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let specs: Vec<&str> = if args.is_empty() { FAMILIES.to_vec() } else { args.iter().map(|s| s.as_str()).collect() };
    let tooth = bench_tooth()?;
    let tip = |i| bench_stroke_tip(tooth.occlusal, i);
    for spec in specs {
        let burr = Burr::parse(spec)?;
        let mut best = vec![f64::INFINITY; 400];
        for _ in 0..3 {
            let mut model = tooth.model.clone();
            model.voxelize_for_cutting()?;
            let mut cutter = Cutter::default();
            cutter.set_measure(Measure::Skip);
            if std::env::var("HANDOFF").is_ok_and(|h| h == "new") {
                cutter.set_handoff(Handoff::NewValues);
            }
            cutter.prepare(&mut model, &burr, tip(0).translation.distance(tip(1).translation));
            cutter.cut_with(&mut model, &burr, tip(0), tip(0), Feed::Geometric)?;
            for (i, b) in best.iter_mut().enumerate() {
                let start = ThreadTime::now();
                cutter.cut_with(&mut model, &burr, tip(i), tip(i + 1), Feed::Geometric)?;
                *b = b.min(start.elapsed().as_secs_f64() * 1e6);
            }
        }
        // A plunge's stroke runs along the tool's axis (z), a pass's across it.
        let plunge = |i: usize| tip(i).translation.z != tip(i + 1).translation.z;
        let (mut passes, mut plunges): (Vec<f64>, Vec<f64>) = (Vec::new(), Vec::new());
        for (i, b) in best.iter().enumerate() {
            if plunge(i) { plunges.push(*b) } else { passes.push(*b) }
        }
        for v in [&mut best, &mut passes, &mut plunges] {
            v.sort_by(f64::total_cmp);
        }
        let mid = |v: &[f64]| v.get(v.len() / 2).copied().unwrap_or(f64::NAN);
        let max = |v: &[f64]| v.last().copied().unwrap_or(f64::NAN);
        println!(
            "{spec:<18} cpu p50 {:7.1} us  p99 {:7.1} us  max {:7.1} us | {} passes p50 {:7.1} max {:7.1} | {} plunges p50 {:7.1} max {:7.1}",
            best[200],
            best[396],
            best[399],
            passes.len(),
            mid(&passes),
            max(&passes),
            plunges.len(),
            mid(&plunges),
            max(&plunges)
        );
    }
    Ok(())
}
