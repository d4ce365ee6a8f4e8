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

/// Live guidance reads the pulp's field at the burr's samples every tick: nothing allocates
/// either, in touch and in cut mode, while the burr is within the field's reach of the pulp.
#[test]
fn guided_ticks_near_the_pulp_do_not_allocate() {
    use dentsim_devices::{DeviceState, BUTTON_CUT};
    use dentsim_sim::tissues::capsule::CapsuleTooth;
    use dentsim_sim::tissues::table::TissueTable;
    use glam::DAffine3;
    let _serial = alloc_counter::exclusive();
    // The capsule tooth: pulp top at z = 2.0 under dentin from z = 3.5.
    let mut model = CapsuleTooth::default().build(0.08, &TissueTable::default()).unwrap();
    let mut core = HapticCore::new(HapticParams::default(), &model).unwrap();
    core.prepare_guidance(&model).unwrap();
    core.prepare_cutting(&mut model).unwrap();
    assert!(core.guides());
    let at = |z: f64, buttons| DeviceState { pose: DAffine3::from_translation(DVec3::new(0.0, 0.0, z)), buttons, rpm: 200_000.0 };
    // Warm up by cutting a shaft toward the pulp (the proxy stops about 0.5 mm over it), then
    // count touch and cut ticks there.
    let mut proxy = DVec3::ZERO;
    for k in 0..6000 {
        proxy = core.tick(&mut model, &at((5.6 - k as f64 * 0.001).max(2.3), BUTTON_CUT), false).unwrap().proxy;
    }
    println!("proxy at z = {:.3} after the warm-up", proxy.z);
    let before = alloc_counter::allocations();
    let mut near = 0;
    for k in 0..1000 {
        let buttons = if k % 2 == 0 { BUTTON_CUT } else { 0 };
        let out = core.tick(&mut model, &at(2.3, buttons), false).unwrap();
        near += usize::from(out.clearance_mm < 1.0);
    }
    let after = alloc_counter::allocations();
    println!("1000 guided ticks, {near} within 1 mm of the pulp, {} allocations", after - before);
    assert!(near > 900, "{near}");
    assert_eq!(after - before, 0);
}
