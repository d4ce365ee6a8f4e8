//! The cut-mode haptic tick allocates nothing with a non-round burr either (see no_alloc.rs):
//! the proxy's support point, the freed head and the cutter's done head are all shape-generic.
mod common;

mod alloc_counter;

use common::*;
use dentsim_devices::{DeviceState, BUTTON_CUT};
use dentsim_sim::haptics::tick::{HapticCore, HapticParams};
use glam::{DAffine3, DQuat, DVec3};

#[test]
fn cut_mode_tick_with_non_round_burrs_does_not_allocate() {
    let _serial = alloc_counter::exclusive();
    for spec in ["cylinder_flat:1:1.5", "flame:1:2", "inverted_cone:1"] {
        let mut model = box_model("enamel", DVec3::new(-2.0, -2.0, -2.0), DVec3::new(2.0, 2.0, 0.0));
        let mut core = HapticCore::new(HapticParams { burr: spec.into(), ..HapticParams::default() }, &model).unwrap();
        core.prepare_cutting(&mut model).unwrap();
        let tilt = DQuat::from_rotation_y(0.15);
        let cut = |z: f64| DeviceState { pose: DAffine3::from_rotation_translation(tilt, DVec3::new(0.0, 0.0, z)), buttons: BUTTON_CUT, rpm: 200_000.0 };
        for k in 0..300 {
            core.tick(&mut model, &cut(0.5 - k as f64 * 0.005), false).unwrap();
        }
        for _ in 0..300 {
            core.tick(&mut model, &cut(-1.0), false).unwrap();
        }
        let before = alloc_counter::allocations();
        let (mut removed, mut contacts) = (0.0, 0);
        for _ in 0..300 {
            let out = core.tick(&mut model, &cut(-1.0), false).unwrap();
            removed += out.removed_mm3;
            contacts += usize::from(out.raw.tissue.is_some());
        }
        let after = alloc_counter::allocations();
        println!("{spec}: 300 cut ticks, {contacts} in contact, removed {removed:.4} mm³, {} allocations", after - before);
        assert!(contacts == 300 && removed > 1e-4, "{spec}: {contacts} contacts, {removed} mm³");
        assert_eq!(after - before, 0, "{spec}");
    }
}
