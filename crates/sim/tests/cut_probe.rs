//! Cut mode against a flat enamel block: the proxy advances at the removal rate and the force
//! stays continuous (no jumps beyond the delta filter's step).
mod common;

use common::*;
use dentsim_devices::{DeviceState, BUTTON_CUT};
use dentsim_sim::haptics::{HapticCore, HapticParams};
use glam::{DAffine3, DVec3};

#[test]
fn cut_mode_advances_at_the_removal_rate_with_continuous_force() {
    for interval in [1u32] {
        let mut model = box_model("enamel", DVec3::new(-2.0, -2.0, -2.0), DVec3::new(2.0, 2.0, 0.0));
        let params = HapticParams { cut_interval_ticks: interval, ..HapticParams::default() };
        let mut core = HapticCore::new(params, &model).unwrap();
        drive(&mut core, &mut model, DVec3::new(0.0, 0.0, 0.5), DVec3::new(0.0, 0.0, -1.0), 300, 0);
        let cut = DeviceState { pose: DAffine3::from_translation(DVec3::new(0.0, 0.0, -1.0)), buttons: BUTTON_CUT, rpm: 200_000.0 };
        let mut removed = 0.0;
        let mut last = core.tick(&mut model, &cut, false).unwrap();
        let mut max_jump: f64 = 0.0;
        for k in 0..1000 {
            let out = core.tick(&mut model, &cut, false).unwrap();
            removed += out.removed_mm3;
            max_jump = max_jump.max((out.force - last.force).length());
            last = out;
            if k % 250 == 0 {
                println!("interval {interval} tick {k}: proxy z {:.5}, |F| {:.4}, removed {removed:.5}", out.proxy.z, out.force.length());
            }
        }
        // 0.5 mm³/(N·s) × ~0.8 N (k·d, shrinking as the proxy sinks) × 1 s.
        println!("interval {interval}: removed {removed:.4} mm³ in 1 s, proxy z {:.4}, max force step {max_jump:.4} N", last.proxy.z);
        assert!(removed > 0.2, "{removed}");
        assert!(max_jump <= 0.05 + 1e-9);
    }
}
