//! The touch-mode haptic tick allocates nothing: a counting global allocator around the tick.
mod common;

mod alloc_counter;

use common::*;
use dentsim_sim::haptics::{HapticCore, HapticParams};
use glam::DVec3;


#[test]
fn touch_mode_tick_does_not_allocate() {
    let mut model = box_model("enamel", DVec3::new(-2.0, -2.0, -1.0), DVec3::new(2.0, 2.0, 0.0));
    let mut core = HapticCore::new(HapticParams::default(), &model).unwrap();
    // Warm up: first contact, free space, sliding.
    for k in 0..200 {
        let z = 0.5 - k as f64 * 0.005;
        core.tick(&mut model, &touch(DVec3::new(0.0, 0.0, z)), false).unwrap();
    }
    let states: Vec<_> = (0..2000)
        .map(|k| {
            let s = k as f64 * 0.01;
            touch(DVec3::new(0.8 * s.sin(), 0.5 * s.cos(), -0.3 + 0.5 * (0.3 * s).sin()))
        })
        .collect();
    let before = alloc_counter::allocations();
    let mut contacts = 0;
    for (k, s) in states.iter().enumerate() {
        let out = core.tick(&mut model, s, k % 7 == 0).unwrap();
        contacts += usize::from(out.raw.tissue.is_some());
    }
    let after = alloc_counter::allocations();
    println!("{} ticks, {contacts} in contact, {} allocations", states.len(), after - before);
    assert!(contacts > 500);
    assert_eq!(after - before, 0);
}
