//! Cut mode against a flat enamel block: the proxy advances at the removal rate and the force
//! stays continuous (no jumps beyond the delta filter's step), whether the tick cuts every tick or
//! batches its advance over 10 ticks.
mod common;

use common::*;
use dentsim_devices::{DeviceState, BUTTON_CUT};
use dentsim_sim::haptics::tick::{HapticCore, HapticParams};
use glam::{DAffine3, DVec3};

#[test]
fn cut_mode_advances_at_the_removal_rate_with_continuous_force() {
    for interval in [1u32, 10] {
        let mut model = box_model("enamel", DVec3::new(-2.0, -2.0, -2.0), DVec3::new(2.0, 2.0, 0.0));
        let params = HapticParams { cut_interval_ticks: interval, ..HapticParams::default() };
        let mut core = HapticCore::new(params.clone(), &model).unwrap();
        drive(&mut core, &mut model, DVec3::new(0.0, 0.0, 0.5), DVec3::new(0.0, 0.0, -1.0), 300, 0);
        let cut = DeviceState { pose: DAffine3::from_translation(DVec3::new(0.0, 0.0, -1.0)), buttons: BUTTON_CUT, rpm: 200_000.0 };
        let (mut removed, mut law) = (0.0, 0.0);
        let mut last = core.tick(&mut model, &cut, false).unwrap();
        let mut max_jump: f64 = 0.0;
        let mut no_force = 0;
        for k in 0..1000 {
            let out = core.tick(&mut model, &cut, false).unwrap();
            removed += out.removed_mm3;
            law += out.raw.removal_rate * out.raw.spring.length() * params.period_s;
            max_jump = max_jump.max((out.force - last.force).length());
            no_force += usize::from(out.raw.force.length() < 1e-9);
            last = out;
            if k % 250 == 0 {
                println!("interval {interval} tick {k}: proxy z {:.5}, |F| {:.4}, removed {removed:.5}", out.proxy.z, out.force.length());
            }
        }
        // 0.5 mm³/(N·s) × 0.95 → 0.3 N (k·d, shrinking as the proxy sinks toward the held
        // device) × 1 s ≈ 0.22 mm³.
        println!(
            "interval {interval}: removed {removed:.4} mm³ in 1 s (rate law {law:.4}, ratio {:.3}), proxy z {:.4}, max force step {max_jump:.4} N",
            removed / law,
            last.proxy.z
        );
        assert!(removed > 0.15, "{removed}");
        assert!((0.95..=1.1).contains(&(removed / law)), "removed {removed}, rate law {law}");
        assert_eq!(no_force, 0);
        assert!(max_jump <= 0.05 + 1e-9);
    }
}
