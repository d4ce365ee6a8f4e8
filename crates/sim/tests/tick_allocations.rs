//! The haptic tick (`Cutter::cut_with`) allocates nothing on the Rust side once warmed up.
//! (OpenVDB itself allocates a leaf node the first time a cut enters an interior tile; that is
//! the tree's own storage and happens once per 8³ voxels.)
mod alloc_counter;

use dentsim_sim::burr::Burr;
use dentsim_sim::cut::Cutter;
use dentsim_sim::phantom::CapsuleTooth;
use dentsim_sim::removal::Feed;
use dentsim_sim::tissue::TissueTable;
use glam::{DAffine3, DQuat, DVec3};


#[test]
fn warmed_up_ticks_do_not_allocate() {
    let mut model = CapsuleTooth::default().build(0.05, &TissueTable::default()).unwrap();
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
        let before = alloc_counter::allocations();
        for i in 0..50 {
            cutter.cut_with(&mut model, &burr, pose(i), pose(i + 1), feed).unwrap();
        }
        let n = alloc_counter::allocations() - before;
        assert_eq!(n, 0, "{} ticks with {:?} allocated {n} times", 50, burr.shape);
    }
}
