//! Contact and force against analytic tissues: F = k·d, direction, tissue boundaries, thin walls,
//! passivity, device limits.
mod common;

use common::*;
use dentsim_devices::DeviceProfile;
use dentsim_sim::burr::Burr;
use dentsim_sim::cutting::cutter::Cutter;
use dentsim_sim::haptics::filter::FilterSpec;
use dentsim_sim::haptics::tick::{HapticCore, HapticParams};
use dentsim_sim::tissues::capsule::CapsuleTooth;
use dentsim_sim::tissues::table::TissueTable;
use glam::{DAffine3, DVec3};
use proptest::prelude::*;

fn params(filter: FilterSpec) -> HapticParams {
    HapticParams { filter, ..HapticParams::default() }
}

#[test]
fn plane_contact_force_is_k_times_depth() {
    // Dentin 0.8 N/mm (under the Desktop's 1.0 N/mm limit), flat top at z = 0.
    let mut model = box_model("dentin", DVec3::new(-3.0, -3.0, -2.0), DVec3::new(3.0, 3.0, 0.0));
    for d in [0.02, 0.05, 0.1, 0.3, 1.0] {
        let mut core = HapticCore::new(params(FilterSpec::None), &model).unwrap();
        let out = drive(&mut core, &mut model, DVec3::new(0.3, 0.2, 1.0), DVec3::new(0.3, 0.2, -d), 300, 20);
        let f = out.last().unwrap().force;
        let expect = 0.8 * d;
        println!("plane d = {d} mm: |F| = {:.6} N, k·d = {expect:.6} N, error {:.3}%", f.length(), 100.0 * (f.length() - expect).abs() / expect);
        assert!((f.length() - expect).abs() <= 0.02 * expect, "d {d}: {f}");
        assert!(f.normalize().dot(DVec3::Z) > 0.9999, "{f}");
    }
}

#[test]
fn force_direction_follows_the_analytic_normal() {
    let mut model = sphere_model("dentin", 3.0);
    let r = 0.5; // 1.0 mm round burr: the ball centre sits 0.5 mm above the tip
    let dirs = [DVec3::Z, DVec3::new(1.0, 0.0, 1.0), DVec3::new(-1.0, 2.0, 0.5), DVec3::new(0.3, -1.0, -0.2), DVec3::new(1.0, 1.0, 1.0)];
    for u in dirs.map(|d| d.normalize()) {
        let tangent = u.any_orthonormal_vector();
        let ball = |c: DVec3| c - DVec3::new(0.0, 0.0, r);
        let start = ball(u * (3.0 + r + 1.0) + tangent * 0.6);
        let end = ball(u * (3.0 + r - 0.2));
        let mut core = HapticCore::new(params(FilterSpec::None), &model).unwrap();
        let out = drive(&mut core, &mut model, start, end, 400, 30);
        let last = out.last().unwrap();
        let normal = (last.proxy + DVec3::new(0.0, 0.0, r)).normalize();
        let angle = last.force.angle_between(normal).to_degrees();
        println!("sphere dir {u:.3}: |F| {:.4} N, angle to analytic normal {angle:.3}°", last.force.length());
        assert!(angle < 2.0, "{u}: {angle}°");
        assert!(last.force.length() > 0.1);
    }
}

#[test]
fn stiffness_changes_at_the_dentin_enamel_junction_and_drops_at_the_pulp() {
    let table = TissueTable::default();
    let tooth = CapsuleTooth::default();
    let base = tooth.build(VOXEL, &table).unwrap();
    // A wide drill leaves a shallow bowl, so the 1 mm probe touches only its bottom.
    let drill = Burr::round(2.4).unwrap();
    let probe_depth = 0.1;
    let mut measured = Vec::new();
    // Hole bottoms on the axis: in enamel (3.5..5.0), dentin (2.0..3.5), pulp (below 2.0).
    for (bottom, expect) in [(4.3, "enamel"), (2.9, "dentin"), (1.4, "pulp")] {
        let mut model = TissueModel_clone(&base);
        let at = |z: f64| DAffine3::from_translation(DVec3::new(0.0, 0.0, z));
        Cutter::default().cut(&mut model, &drill, at(6.5), at(bottom)).unwrap();
        let mut core = HapticCore::new(params(FilterSpec::None), &model).unwrap();
        let out = drive(&mut core, &mut model, DVec3::new(0.0, 0.0, 6.5), DVec3::new(0.0, 0.0, bottom - probe_depth), 600, 30);
        let last = out.last().unwrap();
        let tissue = model.tissues[last.raw.tissue.expect("in contact") as usize].props.clone();
        let k = last.force.length() / probe_depth;
        println!("hole bottom z = {bottom}: contact {}, k = {k:.4} N/mm (table {})", tissue.name, tissue.stiffness_n_per_mm);
        assert_eq!(tissue.name, expect);
        let k_max = HapticParams::default().profile.max_stiffness_n_per_mm;
        measured.push((k, tissue.stiffness_n_per_mm.min(k_max)));
    }
    // The bowl's curvature scales every k alike (the patch's normals tilt), so compare ratios.
    for (i, j) in [(0, 1), (2, 1)] {
        let (got, want) = (measured[i].0 / measured[j].0, measured[i].1 / measured[j].1);
        println!("stiffness ratio {i}/{j}: {got:.4} (table {want:.4})");
        assert!((got - want).abs() <= 0.03 * want, "{measured:?}");
    }
    let geometric = measured[1].0 / measured[1].1;
    println!("bowl factor (measured/table k) {geometric:.4}");
    assert!(geometric > 0.9 && geometric <= 1.02);
}

#[allow(non_snake_case)]
fn TissueModel_clone(m: &dentsim_sim::tissues::model::TissueModel) -> dentsim_sim::tissues::model::TissueModel {
    let mut out = dentsim_sim::tissues::model::TissueModel::new(m.source.clone(), m.fdi_tooth);
    for t in &m.tissues {
        out.push(t.props.clone(), t.grid.clone()).unwrap();
    }
    out
}

#[test]
fn a_thin_wall_holds_at_50_and_500_mm_per_s_in_touch_mode() {
    // Enamel wall 0.3 mm thick: |z| <= 0.15.
    let mut model = box_model("enamel", DVec3::new(-3.0, -3.0, -0.15), DVec3::new(3.0, 3.0, 0.15));
    for speed in [50.0, 500.0] {
        let mut core = HapticCore::new(HapticParams::default(), &model).unwrap();
        let (from, to) = (DVec3::new(0.1, 0.0, 1.5), DVec3::new(0.1, 0.0, -3.0));
        let ticks = ((from - to).length() / speed / 1e-3).round() as usize;
        let out = drive(&mut core, &mut model, from, to, ticks, 50);
        let lowest = out.iter().map(|o| o.proxy.z).fold(f64::MAX, f64::min);
        let last = out.last().unwrap();
        println!("wall at {speed} mm/s: lowest proxy tip z = {lowest:.5} mm (wall top 0.15), final |F| {:.3} N", last.force.length());
        assert!(lowest > 0.15 - 0.01, "{speed} mm/s: proxy reached z {lowest}");
        assert!(last.force.z > 0.0 && last.raw.tissue == Some(0));
    }
}

/// Energy the contact hands back to the user over closed paths through a surface never exceeds
/// the energy the user put in (zero-order hold: force of tick k acts over the step to k + 1).
#[test]
fn closed_paths_are_passive() {
    let mut model = box_model("dentin", DVec3::new(-3.0, -3.0, -2.0), DVec3::new(3.0, 3.0, 0.0));
    for filter in [FilterSpec::None, FilterSpec::default_delta(), FilterSpec::seed001_biquad()] {
        for (name, path) in [("vertical", 0), ("circle", 1)] {
            let mut core = HapticCore::new(params(filter), &model).unwrap();
            let pos = |k: usize| {
                let s = k as f64 / 500.0 * std::f64::consts::TAU;
                match path {
                    0 => DVec3::new(0.0, 0.0, 0.4 * s.cos()),
                    _ => DVec3::new(0.6 * s.sin(), 0.1, 0.4 * s.cos()),
                }
            };
            let (mut put_in, mut returned) = (0.0, 0.0);
            let mut f_prev = core.tick(&mut model, &touch(pos(0)), false).unwrap().force;
            for k in 1..=1500 {
                let dx = pos(k) - pos(k - 1);
                let w = f_prev.dot(dx);
                if w > 0.0 { returned += w } else { put_in -= w }
                f_prev = core.tick(&mut model, &touch(pos(k)), false).unwrap().force;
            }
            println!("passivity {filter:?} {name}: in {put_in:.6} N·mm, returned {returned:.6} N·mm");
            if !matches!(filter, FilterSpec::Biquad { .. }) {
                assert!(returned <= put_in, "{name} {filter:?}: {returned} > {put_in}");
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, .. ProptestConfig::default() })]
    #[test]
    fn rendered_force_never_exceeds_the_device(
        profile in 0usize..6,
        filter in 0usize..3,
        stiffness in 0.1f64..500.0,
        jumps in proptest::collection::vec((-2.0f64..2.0, -2.0f64..2.0, -3.0f64..2.0), 1..12),
    ) {
        let mut model = model_with_stiffness(stiffness);
        let profile = DeviceProfile::all()[profile].clone();
        let filter = [FilterSpec::None, FilterSpec::default_delta(), FilterSpec::seed001_biquad()][filter];
        let max = profile.max_force_n;
        let mut core = HapticCore::new(HapticParams { filter, profile, ..HapticParams::default() }, &model).unwrap();
        for (x, y, z) in jumps {
            for _ in 0..5 {
                let out = core.tick(&mut model, &touch(DVec3::new(x, y, z)), false).unwrap();
                prop_assert!(out.force.is_finite() && out.force.length() <= max, "{} > {max}", out.force.length());
            }
        }
    }
}

fn model_with_stiffness(k: f64) -> dentsim_sim::tissues::model::TissueModel {
    let mut m = box_model("enamel", DVec3::new(-1.5, -1.5, -1.0), DVec3::new(1.5, 1.5, 0.0));
    m.tissues[0].props.stiffness_n_per_mm = k;
    m
}
