//! A patch built in columns (`Sweep::set_columns`) subtracted along its column runs
//! (`LevelSet::subtract_logged_runs`) changes the voxels its row spans change, to the same
//! values: every burr family on haptic-tick paths at tilts from vertical to past 45°, through
//! three nested tissues, measured and not; each tick the same changes (as sets, old and new
//! values) and the same removed volume (to the rounding of another order), and at the end the same grids bit for bit.
//! A sweep that builds the runs alone (`Sweep::set_runs_only`, a cutter's) builds the same runs.
mod common;

use dentsim_sim::burr::Shape;
use dentsim_sim::cutting::sweep::{Done, Sweep};
use dentsim_vdb::{Measure, VoxelChange};
use glam::{DAffine3, DQuat, DVec3};

/// The changes as sortable tuples (values by their bits).
fn change_set(log: &[VoxelChange]) -> Vec<(i32, i32, i32, u32)> {
    let mut set: Vec<_> = log.iter().map(|c| (c.i, c.j, c.k, c.value.to_bits())).collect();
    set.sort_unstable();
    set
}

#[test]
fn column_runs_change_what_row_spans_change() {
    let mut unit = common::unit_random(0x3c6e_f372_fe94_f82b);
    let band = 3.0 * common::VOXEL;
    let cutoff = (band + 1.5 * common::VOXEL) as f32;
    let (mut run_ticks, mut changed) = (0usize, 0u64);
    for shape in Shape::ALL {
        for (case, measure) in [Measure::Skip, Measure::Volume].into_iter().enumerate() {
            let burr = common::random_burr(shape, &mut unit);
            let mut path = common::haptic_tick_path(&mut unit);
            if case == 1 {
                // Turned about a horizontal axis by up to 60°, the head held at one rotation.
                let turn = DQuat::from_axis_angle(DVec3::new(unit() - 0.5, unit() - 0.5, 0.0).normalize_or(DVec3::X), 1.05 * unit());
                let rotation = DAffine3::from_quat(turn) * DAffine3::from_mat3(path[0].matrix3);
                path.iter_mut().for_each(|p| *p = DAffine3 { matrix3: rotation.matrix3, translation: turn * p.translation });
            }
            let (mut by_spans, mut by_runs) = (common::nested_balls_model(), common::nested_balls_model());
            let (mut sweep, mut runs_only) = (Sweep::default(), Sweep::default());
            for s in [&mut sweep, &mut runs_only] {
                s.set_unmeasured(true);
                s.set_columns(true);
            }
            runs_only.set_runs_only(true);
            let (mut spans_log, mut runs_log, mut new_values) = (Vec::new(), Vec::new(), Vec::new());
            let mut done: Option<Done> = None;
            for (tick, poses) in path.windows(2).enumerate() {
                let (pose, next) = (poses[0], poses[1]);
                // Both models hold the same grids (checked below): one patch serves both.
                common::build_marked(&mut sweep, &burr, (pose, next), band, done, &by_spans);
                assert!(sweep.built_in_columns() || sweep.column_runs().is_empty(), "{shape:?} tick {tick}: runs from rows");
                run_ticks += usize::from(!sweep.column_runs().is_empty());
                // Built for the runs alone: the same runs and values, the patch left at the cut-off.
                common::build_marked(&mut runs_only, &burr, (pose, next), band, done, &by_spans);
                let (a, b) = (sweep.column_runs(), runs_only.column_runs());
                assert_eq!(a.runs, b.runs, "{shape:?} tick {tick}: runs");
                assert!(a.runs.chunks_exact(4).all(|r| {
                    let (x, y) = (&a.values[r[3] as usize..][..(r[2] - r[1]) as usize], &b.values[r[3] as usize..][..(r[2] - r[1]) as usize]);
                    x.iter().zip(y).all(|(p, q)| p.to_bits() == q.to_bits())
                }), "{shape:?} tick {tick}: run values");
                if runs_only.built_in_columns() {
                    assert!(runs_only.patch.values.iter().all(|v| *v == cutoff) && runs_only.patch.spans.iter().all(|s| *s == 0), "{shape:?} tick {tick}: patch written");
                }
                for t in 0..3 {
                    spans_log.clear();
                    runs_log.clear();
                    let a = by_spans.tissues[t].grid.subtract_logged(&sweep.patch, 0.0, measure, &mut spans_log).unwrap();
                    let b = by_runs.tissues[t].grid.subtract_logged_runs(&sweep.patch, sweep.column_runs(), 0.0, measure, &mut runs_log).unwrap();
                    let what = format!("{shape:?} {measure:?} tick {tick} tissue {t}");
                    assert_eq!(a.changed_voxels, b.changed_voxels, "{what}: changed voxels");
                    // (Summed in another order: the same to rounding.)
                    assert!((a.removed_mm3 - b.removed_mm3).abs() <= 1e-9 * a.removed_mm3.abs().max(1e-6), "{what}: removed {} vs {}", a.removed_mm3, b.removed_mm3);
                    assert_eq!(change_set(&spans_log), change_set(&runs_log), "{what}: old values");
                    new_values.clear();
                    by_runs.tissues[t].grid.last_cut_values(&mut new_values);
                    let mut spans_new = Vec::new();
                    by_spans.tissues[t].grid.last_cut_values(&mut spans_new);
                    assert_eq!(change_set(&spans_new), change_set(&new_values), "{what}: new values");
                    changed += a.changed_voxels;
                }
                done = Some(common::done_at(&burr, next));
            }
            common::assert_same_nested_balls(&by_spans, &by_runs, &format!("{shape:?} {measure:?}"));
        }
    }
    eprintln!("{run_ticks} ticks along column runs, {changed} voxels changed");
    // Many ticks went by the runs (never the round burr's: it is not built in columns).
    assert!(run_ticks >= 300 && changed > 100_000, "{run_ticks} ticks along runs, {changed} changed");
}
