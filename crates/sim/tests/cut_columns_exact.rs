//! The haptic tick's sweep in columns along z (`Sweep::set_columns`) leaves every grid bit for
//! bit as the rows along x leave it: every burr family, haptic-tick paths (passes and plunges,
//! a slight turn now and then; or one rotation held) at tilts from near vertical to past 45°,
//! through three nested tissues, the same voxels changed on every tick. And where both sweeps evaluated a voxel (its
//! value below the cut-off in both) the values are the same bits: a column's point is its row's.
mod common;

use dentsim_sim::burr::Shape;
use dentsim_sim::cutting::sweep::{CutBall, CutHead, Done, Sweep};
use dentsim_vdb::Measure;
use glam::{DAffine3, DQuat, DVec3};

const H: f64 = common::VOXEL;

#[test]
fn columns_leave_the_grids_rows_leave() {
    let mut unit = common::unit_random(0x6a09_e667_f3bc_c908);
    let band = 3.0 * H;
    let cutoff = (band + 1.5 * H) as f32;
    let (mut column_ticks, mut row_ticks, mut compared) = (0usize, 0usize, 0usize);
    for shape in Shape::ALL {
        for tilted in [false, true] {
            let burr = common::random_burr(shape, &mut unit);
            let mut path = common::haptic_tick_path(&mut unit);
            if tilted {
                // The same path turned about a random horizontal axis by up to 60°, its head
                // held at the first pose's rotation (the path's own rotations drift by rounding
                // from tick to tick, and a turning head is swept by the general path).
                let turn = DQuat::from_axis_angle(DVec3::new(unit() - 0.5, unit() - 0.5, 0.0).normalize_or(DVec3::X), 1.05 * unit());
                let rotation = DAffine3::from_quat(turn) * DAffine3::from_mat3(path[0].matrix3);
                path.iter_mut().for_each(|p| *p = DAffine3 { matrix3: rotation.matrix3, translation: turn * p.translation });
            }
            let (mut by_rows, mut by_columns) = (common::nested_balls_model(), common::nested_balls_model());
            let (mut rows, mut columns) = (Sweep::default(), Sweep::default());
            rows.set_unmeasured(true);
            columns.set_unmeasured(true);
            columns.set_columns(true);
            let mut log = Vec::new();
            let mut done: Option<Done> = None;
            for (tick, poses) in path.windows(2).enumerate() {
                let (pose, next) = (poses[0], poses[1]);
                for (sweep, model) in [(&mut rows, &by_rows), (&mut columns, &by_columns)] {
                    let grids = &model.tissues;
                    sweep
                        .build_in(&burr, pose, next, H, band, done, |lo, dims, blocks| {
                            grids.iter().try_for_each(|t| t.grid.mark_material_blocks(lo, dims, blocks).map_err(Into::into))
                        })
                        .unwrap();
                }
                assert!(!rows.built_in_columns());
                column_ticks += usize::from(columns.built_in_columns());
                row_ticks += 1;
                let (r, c) = (&rows.patch, &columns.patch);
                assert_eq!((r.index_min, r.dims), (c.index_min, c.dims), "{shape:?} tick {tick}");
                for (n, (a, b)) in r.values.iter().zip(&c.values).enumerate() {
                    if *a < cutoff && *b < cutoff {
                        assert_eq!(a.to_bits(), b.to_bits(), "{shape:?} tilted {tilted} tick {tick} voxel {n}: {a} vs {b}");
                        compared += 1;
                    }
                }
                for t in 0..3 {
                    let a = by_rows.tissues[t].grid.subtract_logged(&rows.patch, 0.0, Measure::Skip, &mut log).unwrap();
                    let b = by_columns.tissues[t].grid.subtract_logged(&columns.patch, 0.0, Measure::Skip, &mut log).unwrap();
                    assert_eq!(a.changed_voxels, b.changed_voxels, "{shape:?} tilted {tilted} tick {tick} tissue {t}: changed voxels");
                }
                done = Some(match burr.ball_radius() {
                    Some(r) => Done::Ball(CutBall { centre: next.transform_point3(DVec3::new(0.0, 0.0, r)), radius: r }),
                    None => Done::Head(CutHead { to_tool: next.inverse(), offset: 0.0 }),
                });
            }
            for t in 0..3 {
                let (a, b) = (common::nested_balls_dense(&by_rows, t), common::nested_balls_dense(&by_columns, t));
                for (n, (x, y)) in a.iter().zip(&b).enumerate() {
                    assert_eq!(x.to_bits(), y.to_bits(), "{shape:?} tilted {tilted} tissue {t} voxel {n}: {x} vs {y}");
                }
                assert_eq!(by_rows.tissues[t].grid.content_hash(), by_columns.tissues[t].grid.content_hash(), "{shape:?} tissue {t}");
            }
            assert!(common::nested_balls_dense(&by_columns, 0) != common::nested_balls_dense(&common::nested_balls_model(), 0), "{shape:?}: nothing cut");
        }
    }
    eprintln!("{column_ticks} of {row_ticks} ticks in columns, {compared} voxels compared");
    // Many ticks went by columns (never the round burr's: it has no slabs).
    assert!(column_ticks * 3 >= row_ticks, "{column_ticks} of {row_ticks} ticks in columns");
    assert!(compared > 100_000, "{compared} voxels compared");
}
