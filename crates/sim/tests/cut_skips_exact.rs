//! What the cut leaves out changes no grid: the sweep skips the blocks no grid can lose anything
//! in (outside tiles, and leaves a cut left all at the background, which the old rule took in),
//! and an unmeasured subtract reads no voxel past the band. Haptic-tick paths of every burr family (passes and plunges,
//! tilted heads) through three nested tissues, cut both ways, must leave every grid bit for bit
//! the same, with the same changes and (measured) the same removed volume to the bit.
mod common;

use dentsim_sim::burr::Shape;
use dentsim_sim::cutting::sweep::{CutBall, CutHead, Done, Sweep};
use dentsim_sim::tissues::model::TissueModel;
use dentsim_vdb::Measure;
use glam::DVec3;

const H: f64 = common::VOXEL;

#[test]
fn skipped_blocks_and_unread_voxels_change_no_grid() {
    let mut unit = common::unit_random(0x9e37_79b9_7f4a_7c15);
    let band = 3.0 * H;
    let cutoff = (band + 1.5 * H) as f32;
    let (mut skipped_blocks, mut ticks) = (0usize, 0usize);
    for shape in Shape::ALL {
        let burr = common::random_burr(shape, &mut unit);
        let (mut skipping, mut reference, mut unmeasured) = (common::nested_balls_model(), common::nested_balls_model(), common::nested_balls_model());
        let (mut marked, mut every) = (Sweep::default(), Sweep::default());
        let mut log = Vec::new();
        let path = common::haptic_tick_path(&mut unit);
        let mut done: Option<Done> = None;
        for (tick, poses) in path.windows(2).enumerate() {
            let (pose, next) = (poses[0], poses[1]);
            let grids = &skipping.tissues;
            marked
                .build_in(&burr, pose, next, H, band, done, |lo, dims, blocks| {
                    grids.iter().try_for_each(|t| t.grid.mark_material_blocks(lo, dims, blocks).map_err(Into::into))
                })
                .unwrap();
            // The old rule: every block with a leaf or an inside tile in some grid.
            let grids = &reference.tissues;
            every
                .build_in(&burr, pose, next, H, band, done, |lo, dims, blocks| {
                    grids.iter().try_for_each(|t| t.grid.mark_material_blocks(lo, dims, blocks))?;
                    blocks.iter_mut().filter(|m| **m != 0).for_each(|m| *m = 2);
                    Ok(())
                })
                .unwrap();
            let handed = |s: &Sweep| s.patch.values.iter().filter(|v| **v < cutoff).count();
            skipped_blocks += usize::from(handed(&marked) < handed(&every));
            ticks += 1;
            for t in 0..3 {
                let a = skipping.tissues[t].grid.subtract_logged(&marked.patch, 0.0, Measure::Volume, &mut log).unwrap();
                let b = reference.tissues[t].grid.subtract_logged(&every.patch, 0.0, Measure::Volume, &mut log).unwrap();
                let c = unmeasured.tissues[t].grid.subtract_logged(&marked.patch, 0.0, Measure::Skip, &mut log).unwrap();
                assert_eq!(a.changed_voxels, b.changed_voxels, "{shape:?} tick {tick} tissue {t}: changed voxels");
                assert_eq!(a.changed_voxels, c.changed_voxels, "{shape:?} tick {tick} tissue {t}: changed voxels unmeasured");
                assert_eq!(a.removed_mm3.to_bits(), b.removed_mm3.to_bits(), "{shape:?} tick {tick} tissue {t}: removed volume");
            }
            done = Some(match burr.ball_radius() {
                Some(r) => Done::Ball(CutBall { centre: next.transform_point3(DVec3::new(0.0, 0.0, r)), radius: r }),
                None => Done::Head(CutHead { to_tool: next.inverse(), offset: 0.0 }),
            });
        }
        for t in 0..3 {
            let (a, b, c) = (common::nested_balls_dense(&skipping, t), common::nested_balls_dense(&reference, t), common::nested_balls_dense(&unmeasured, t));
            for (n, ((x, y), z)) in a.iter().zip(&b).zip(&c).enumerate() {
                assert_eq!(x.to_bits(), y.to_bits(), "{shape:?} tissue {t} voxel {n}: {x} vs {y}");
                assert_eq!(x.to_bits(), z.to_bits(), "{shape:?} tissue {t} voxel {n}: {x} vs {z} unmeasured");
            }
            let hash = |m: &TissueModel| m.tissues[t].grid.content_hash();
            assert_eq!(hash(&skipping), hash(&reference), "{shape:?} tissue {t}: grids differ");
            assert_eq!(hash(&skipping), hash(&unmeasured), "{shape:?} tissue {t}: grids differ unmeasured");
        }
        // The path cut something in every tissue it reached.
        assert!(common::nested_balls_dense(&skipping, 0) != common::nested_balls_dense(&common::nested_balls_model(), 0), "{shape:?}: nothing cut");
    }
    // The skip was taken: some ticks handed the subtract fewer voxels than the old rule did.
    assert!(skipped_blocks * 10 >= ticks, "{skipped_blocks} of {ticks} ticks skipped a block");
}
