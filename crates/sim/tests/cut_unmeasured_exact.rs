//! An unmeasured cut (the haptic tick's) lets its sweep leave the voxels from the band up at the
//! cut-off, which no unmeasured subtract reads: haptic-tick paths of every burr family (passes
//! and plunges, tilted heads, a slight turn now and then) through three nested tissues, cut by a
//! cutter that measures and one that does not, must leave every grid bit for bit the same, with
//! the same number of voxels changed on every tick.
mod common;

use dentsim_sim::burr::Shape;
use dentsim_sim::cutting::cutter::Cutter;
use dentsim_sim::cutting::removal::Feed;
use dentsim_vdb::Measure;

#[test]
fn an_unmeasured_cut_leaves_the_grids_a_measured_one_leaves() {
    let mut unit = common::unit_random(0xd1b5_4a32_d192_ed03);
    for shape in Shape::ALL {
        let burr = common::random_burr(shape, &mut unit);
        let (mut measured, mut unmeasured) = (common::nested_balls_model(), common::nested_balls_model());
        let (mut a, mut b) = (Cutter::default(), Cutter::default());
        a.set_measure(Measure::Volume);
        b.set_measure(Measure::Skip);
        let path = common::haptic_tick_path(&mut unit);
        a.prepare(&mut measured, &burr, 0.03);
        b.prepare(&mut unmeasured, &burr, 0.03);
        let mut changed = 0;
        for (tick, poses) in path.windows(2).enumerate() {
            let (pose, next) = (poses[0], poses[1]);
            let ra = a.cut_with(&mut measured, &burr, pose, next, Feed::Geometric).unwrap().changed_voxels;
            let rb = b.cut_with(&mut unmeasured, &burr, pose, next, Feed::Geometric).unwrap().changed_voxels;
            assert_eq!(ra, rb, "{shape:?} tick {tick}: changed voxels");
            changed += ra;
        }
        assert!(changed > 0, "{shape:?}: nothing cut");
        for t in 0..3 {
            let (x, y) = (common::nested_balls_dense(&measured, t), common::nested_balls_dense(&unmeasured, t));
            for (n, (p, q)) in x.iter().zip(&y).enumerate() {
                assert_eq!(p.to_bits(), q.to_bits(), "{shape:?} tissue {t} voxel {n}: {p} vs {q}");
            }
            assert_eq!(measured.tissues[t].grid.content_hash(), unmeasured.tissues[t].grid.content_hash(), "{shape:?} tissue {t}: grids differ");
        }
    }
}
