//! The touch-mode haptic tick allocates nothing: a counting global allocator around the tick.
mod common;

mod alloc_counter;

use common::*;
use dentsim_sim::haptics::tick::{HapticCore, HapticParams};
use glam::DVec3;

#[test]
fn touch_mode_tick_does_not_allocate() {
    let _serial = alloc_counter::exclusive();
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

/// Cut mode too, once warmed up: the proxy follow, the contact query at rest, the removal law and
/// the stroke allocate nothing on the Rust side. The cutter's buffers grow to the largest stroke
/// so far (see tick_allocations.rs; OpenVDB allocates a leaf the first time a cut enters an
/// interior tile), so the warm-up holds the device where the counted ticks hold it.
#[test]
fn cut_mode_tick_does_not_allocate() {
    use dentsim_devices::{DeviceState, BUTTON_CUT};
    use glam::DAffine3;
    let _serial = alloc_counter::exclusive();
    let mut model = box_model("enamel", DVec3::new(-2.0, -2.0, -2.0), DVec3::new(2.0, 2.0, 0.0));
    let mut core = HapticCore::new(HapticParams::default(), &model).unwrap();
    let cut = |z: f64| DeviceState { pose: DAffine3::from_translation(DVec3::new(0.0, 0.0, z)), buttons: BUTTON_CUT, rpm: 200_000.0 };
    for k in 0..300 {
        core.tick(&mut model, &cut(0.5 - k as f64 * 0.005), false).unwrap();
    }
    for _ in 0..500 {
        core.tick(&mut model, &cut(-1.0), false).unwrap();
    }
    let before = alloc_counter::allocations();
    let (mut removed, mut contacts) = (0.0, 0);
    for _ in 0..500 {
        let out = core.tick(&mut model, &cut(-1.0), false).unwrap();
        removed += out.removed_mm3;
        contacts += usize::from(out.raw.tissue.is_some());
    }
    let after = alloc_counter::allocations();
    println!("500 cut ticks, {contacts} in contact, removed {removed:.4} mm³, {} allocations", after - before);
    assert!(contacts == 500 && removed > 0.01);
    assert_eq!(after - before, 0);
}
