//! The haptic tick's subtract along the patch's row spans and along its column runs
//! (`LevelSet::subtract_logged_runs`), alternated tick by tick on two copies of the bench tooth
//! (the cut_stroke rows' stroke, `Measure::Skip`): the voxels each reads and each one's thread CPU
//! time over the three tissues, p50 / p99, so the two compare under the same load.
//!
//! `cargo run --release -p dentsim-bench --example subtract_runs [SPEC...]`
use cpu_time::ThreadTime;
use dentsim_bench::{bench_stroke_tip, bench_tooth};
use dentsim_sim::burr::Burr;
use dentsim_sim::cutting::sweep::{CutHead, Done, Sweep};
use dentsim_vdb::Measure;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let specs: Vec<&str> = if args.is_empty() { vec!["taper_flat_012", "flame_016", "cylinder_flat_012"] } else { args.iter().map(|s| s.as_str()).collect() };
    let tooth = bench_tooth()?;
    let tip = |i| bench_stroke_tip(tooth.occlusal, i);
    for spec in specs {
        let burr = Burr::parse(spec)?;
        let mut by_spans = tooth.model.clone();
        by_spans.voxelize_for_cutting()?;
        let mut by_runs = by_spans.clone();
        let h = by_spans.voxel_size().ok_or("no voxel size")?;
        let band = by_spans.tissues.iter().map(|t| f64::from(t.grid.background())).fold(0.0, f64::max);
        let mut sweep = Sweep::default();
        sweep.set_unmeasured(true);
        sweep.set_columns(true);
        let mut log = Vec::new();
        let (mut spans_us, mut runs_us, mut spans_read, mut runs_read) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut done = None;
        for i in 0..400 {
            let grids = &by_spans.tissues;
            sweep.build_in(&burr, tip(i), tip(i + 1), h, band, done, |lo, dims, blocks| {
                grids.iter().try_for_each(|t| t.grid.mark_material_blocks(lo, dims, blocks).map_err(Into::into))
            })?;
            done = Some(Done::Head(CutHead { to_tool: tip(i + 1).inverse(), offset: 0.0 }));
            if !sweep.built_in_columns() {
                continue;
            }
            spans_read.push(sweep.patch.spans.chunks_exact(2).map(|s| s[1] - s[0]).sum::<u32>() as f64);
            runs_read.push(sweep.column_runs().runs.chunks_exact(4).map(|r| r[2] - r[1]).sum::<u32>() as f64);
            // Which goes first alternates, so neither always finds the caches the other left.
            for turn in 0..2 {
                let runs_now = (turn + i) % 2 == 0;
                let start = ThreadTime::now();
                for t in 0..3 {
                    log.clear();
                    if runs_now {
                        by_runs.tissues[t].grid.subtract_logged_runs(&sweep.patch, sweep.column_runs(), 0.0, Measure::Skip, &mut log)?;
                    } else {
                        by_spans.tissues[t].grid.subtract_logged(&sweep.patch, 0.0, Measure::Skip, &mut log)?;
                    }
                }
                let us = start.elapsed().as_secs_f64() * 1e6;
                if runs_now { runs_us.push(us) } else { spans_us.push(us) }
            }
        }
        let same = by_spans.tissues.iter().zip(&by_runs.tissues).all(|(a, b)| a.grid.content_hash() == b.grid.content_hash());
        for v in [&mut spans_us, &mut runs_us, &mut spans_read, &mut runs_read] {
            v.sort_by(f64::total_cmp);
        }
        let at = |v: &[f64], q: f64| v.get(((v.len() as f64 - 1.0) * q).round() as usize).copied().unwrap_or(f64::NAN);
        println!(
            "{spec:<18} {} ticks in columns | voxels read p50 {:6.0} / {:6.0} p99 {:6.0} / {:6.0} | cpu p50 {:6.1} / {:6.1} us p99 {:6.1} / {:6.1} us (spans / runs) | grids {}",
            spans_us.len(),
            at(&spans_read, 0.5),
            at(&runs_read, 0.5),
            at(&spans_read, 0.99),
            at(&runs_read, 0.99),
            at(&spans_us, 0.5),
            at(&runs_us, 0.5),
            at(&spans_us, 0.99),
            at(&runs_us, 0.99),
            if same { "the same" } else { "DIFFER" }
        );
    }
    Ok(())
}
