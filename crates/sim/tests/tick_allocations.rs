//! The haptic tick (`Cutter::cut_with`) allocates nothing once warmed up: nothing on the Rust
//! side (counted), and no OpenVDB leaf once the session has voxelized the grids' insides (a cut
//! entering an inside tile would otherwise allocate a leaf; counted as leaves).
mod alloc_counter;

use dentsim_sim::burr::Burr;
use dentsim_sim::cutting::cutter::Cutter;
use dentsim_sim::tissues::capsule::CapsuleTooth;
use dentsim_sim::cutting::removal::Feed;
use dentsim_sim::tissues::table::TissueTable;
use glam::{DAffine3, DQuat, DVec3};


#[test]
fn warmed_up_ticks_do_not_allocate() {
    let _serial = alloc_counter::exclusive();
    let mut model = CapsuleTooth::default().build(0.05, &TissueTable::default()).unwrap();
    let plain = model.clone();
    model.voxelize_for_cutting().unwrap();
    let top = CapsuleTooth::default().outer.top();
    let tilt = DQuat::from_rotation_y(0.3);
    let pose = |i: usize| DAffine3::from_rotation_translation(tilt * DQuat::from_rotation_z(0.01 * i as f64), DVec3::new(-1.0 + 0.02 * i as f64, 0.0, top - 0.5));
    for (burr, feed) in [
        (Burr::round(1.0).unwrap(), Feed::Geometric),
        (Burr::parse("cylinder_round:1.0:3").unwrap(), Feed::Geometric),
        (Burr::round(1.0).unwrap(), Feed::Limited { force_n: 1.0, rpm: 200_000.0, dt_s: 0.001 }),
    ] {
        let mut cutter = Cutter::default();
        // Warm up over the same motion, on a copy: buffers grow to the largest stroke once.
        let mut warm = model.clone();
        for i in 0..50 {
            cutter.cut_with(&mut warm, &burr, pose(i), pose(i + 1), feed).unwrap();
        }
        let leaves = leaf_count(&model);
        let before = alloc_counter::allocations();
        for i in 0..50 {
            cutter.cut_with(&mut model, &burr, pose(i), pose(i + 1), feed).unwrap();
        }
        let n = alloc_counter::allocations() - before;
        assert_eq!(n, 0, "{} ticks with {:?} allocated {n} times", 50, burr.shape);
        assert_eq!(leaf_count(&model), leaves, "{:?}: OpenVDB allocated leaves", burr.shape);
    }
    // Without voxelizing, the same ticks do enter inside tiles: the leaf check above means something.
    let mut plain = plain;
    let leaves = leaf_count(&plain);
    let mut cutter = Cutter::default();
    for i in 0..50 {
        cutter.cut_with(&mut plain, &Burr::round(1.0).unwrap(), pose(i), pose(i + 1), Feed::Geometric).unwrap();
    }
    assert!(leaf_count(&plain) > leaves, "the path never enters an inside tile");
}

#[test]
fn voxelizing_keeps_every_value_and_compacting_gives_the_tiles_back() {
    let _serial = alloc_counter::exclusive();
    let mut model = CapsuleTooth::default().build(0.05, &TissueTable::default()).unwrap();
    let hashes: Vec<u64> = model.tissues.iter().map(|t| t.grid.content_hash()).collect();
    let volumes: Vec<f64> = model.tissues.iter().map(|t| t.grid.volume()).collect();
    let leaves = leaf_count(&model);
    model.voxelize_for_cutting().unwrap();
    assert!(leaf_count(&model) > leaves, "{} leaves from {leaves}", leaf_count(&model));
    for (t, v) in model.tissues.iter().zip(&volumes) {
        assert_eq!(t.grid.volume(), *v, "{}: values unchanged", t.props.name);
    }
    model.compact();
    assert_eq!(leaf_count(&model), leaves);
    assert_eq!(model.tissues.iter().map(|t| t.grid.content_hash()).collect::<Vec<_>>(), hashes);
}

fn leaf_count(model: &dentsim_sim::tissues::model::TissueModel) -> u64 {
    model.tissues.iter().map(|t| t.grid.leaf_count()).sum()
}
