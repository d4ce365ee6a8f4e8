//! Session-side cutting: undo/redo, incremental meshing, removal rate, bad poses.
mod common;

use common::triangle_set;
use dentsim_sim::burr::{Burr, Shape};
use dentsim_sim::cutting::cutter::Cutter;
use dentsim_sim::tissues::surface::Mesher;
use dentsim_sim::tissues::model::TissueModel;
use dentsim_sim::tissues::capsule::CapsuleTooth;
use dentsim_sim::cutting::removal::Feed;
use dentsim_sim::tissues::table::TissueTable;
use glam::{DAffine3, DMat3, DQuat, DVec3, IVec3};

fn tooth(voxel: f64) -> TissueModel {
    CapsuleTooth::default().build(voxel, &TissueTable::default()).unwrap()
}

fn at(x: f64, y: f64, z: f64) -> DAffine3 {
    DAffine3::from_translation(DVec3::new(x, y, z))
}

fn values(model: &TissueModel, lo: IVec3, n: u32) -> Vec<Vec<f32>> {
    model
        .tissues
        .iter()
        .map(|t| {
            let mut v = vec![0f32; (n * n * n) as usize];
            t.grid.read_dense(lo, [n; 3], &mut v).unwrap();
            v
        })
        .collect()
}

#[test]
fn undo_and_redo_restore_every_voxel() {
    let mut model = tooth(0.1);
    let (lo, n) = (IVec3::new(-35, -35, 5), 70);
    let original = values(&model, lo, n);
    let burr = Burr::parse("cylinder_round:1.0:2").unwrap();
    let mut cutter = Cutter::default();
    // Stroke 1: three ticks grouped; stroke 2: one call.
    cutter.begin_stroke();
    for i in 0..3 {
        let x = -1.0 + 0.5 * f64::from(i);
        cutter.cut(&mut model, &burr, at(x, 0.0, 4.0), at(x + 0.5, 0.0, 3.9)).unwrap();
    }
    cutter.end_stroke();
    let after_one = values(&model, lo, n);
    let r = cutter.cut(&mut model, &burr, at(0.0, -1.0, 4.2), at(0.0, 1.0, 4.2)).unwrap();
    assert!(r.total_mm3() > 0.1);
    let after_two = values(&model, lo, n);
    assert_eq!(cutter.history.undo_depth(), 2);
    assert!(cutter.undo(&mut model));
    assert_eq!(values(&model, lo, n), after_one, "undo takes back exactly the last stroke");
    assert!(cutter.undo(&mut model));
    assert_eq!(values(&model, lo, n), original, "undo restores every value");
    assert!(!cutter.undo(&mut model));
    assert!(cutter.redo(&mut model));
    assert_eq!(values(&model, lo, n), after_one);
    assert!(cutter.redo(&mut model));
    assert_eq!(values(&model, lo, n), after_two);
    assert!(!cutter.redo(&mut model));
    println!("journal holds {} bytes for 2 strokes", cutter.history.bytes());
}

#[test]
fn history_memory_is_bounded_and_drops_the_oldest() {
    let mut model = tooth(0.1);
    let burr = Burr::round(1.0).unwrap();
    let cap = 64 * 1024;
    let mut cutter = Cutter::with_history_bytes(cap);
    for i in 0..12 {
        let x = -2.0 + 0.35 * f64::from(i);
        cutter.cut(&mut model, &burr, at(x, 0.0, 4.3), at(x + 0.3, 0.0, 4.3)).unwrap();
        assert!(cutter.history.bytes() <= cap);
    }
    assert!(cutter.history.undo_depth() < 12, "older strokes were dropped");
    assert!(cutter.history.undo_depth() > 0);
    while cutter.undo(&mut model) {}
}

#[test]
fn patched_meshes_equal_a_full_remesh() {
    let mut model = tooth(0.05);
    let mut mesher = Mesher::full(&model).unwrap();
    let enamel_volume = mesher.mesh(0).volume();
    let exact = CapsuleTooth::default().volume("enamel").unwrap();
    assert!((enamel_volume / exact - 1.0).abs() < 0.01, "chunk mesh volume {enamel_volume} vs {exact}");
    let mut cutter = Cutter::default();
    let burrs = [Burr::round(1.0).unwrap(), Burr::parse("taper_round:1.4:4").unwrap(), Burr::parse("wheel:2.5:0.8").unwrap()];
    let mut dirty = Vec::new();
    let tilt = DQuat::from_rotation_y(0.4);
    for (i, burr) in burrs.iter().enumerate() {
        let y = -1.0 + f64::from(i as u32);
        let from = DAffine3::from_rotation_translation(tilt, DVec3::new(-1.5, y, 3.6));
        let to = DAffine3::from_rotation_translation(tilt * DQuat::from_rotation_x(0.3), DVec3::new(1.0, y + 0.3, 3.2));
        cutter.cut(&mut model, burr, from, to).unwrap();
        dirty.clear();
        cutter.take_dirty(&mut dirty);
        assert!(!dirty.is_empty());
        mesher.update(&model, &dirty).unwrap();
    }
    cutter.undo(&mut model);
    dirty.clear();
    cutter.take_dirty(&mut dirty);
    mesher.update(&model, &dirty).unwrap();
    let full = Mesher::full(&model).unwrap();
    for t in 0..model.tissues.len() {
        let (a, b) = (triangle_set(&mesher.mesh(t)), triangle_set(&full.mesh(t)));
        assert_eq!(a.len(), b.len(), "tissue {t}");
        assert!(a == b, "tissue {t}: patched mesh differs from a full re-mesh");
    }
}

#[test]
fn removal_rate_limits_each_tick_and_unlimited_is_geometric() {
    let table = TissueTable::default();
    let enamel_rate = table.get("enamel").unwrap().removal_rate_mm3_per_n_s;
    let burr = Burr::round(1.0).unwrap();
    // Plunge 0.4 mm into the occlusal enamel over 40 ticks of 1 ms, at 1 N and reference speed.
    let top = CapsuleTooth::default().outer.top();
    let tip = |i: usize| at(0.0, 0.0, top - 0.01 * i as f64);
    let (force_n, rpm, dt_s) = (1.0, dentsim_sim::cutting::removal::REFERENCE_RPM, 0.001);
    let mut limited = tooth(0.05);
    let mut geometric = tooth(0.05);
    let (mut cut_limited, mut cut_geometric) = (Cutter::default(), Cutter::default());
    let (mut total_limited, mut total_geometric) = (0.0, 0.0);
    for i in 0..40 {
        let r = cut_limited.cut_with(&mut limited, &burr, tip(i), tip(i + 1), Feed::Limited { force_n, rpm, dt_s }).unwrap();
        total_limited += r.removed("enamel");
        total_geometric += cut_geometric.cut(&mut geometric, &burr, tip(i), tip(i + 1)).unwrap().removed("enamel");
    }
    let allowance = enamel_rate * force_n * dt_s * 40.0;
    println!("40 ticks at 1 N: limited {total_limited:.4} mm³ (allowance {allowance:.4}), geometric {total_geometric:.4} mm³");
    assert!(total_limited <= allowance * 1.05 + 1e-4, "{total_limited} > {allowance}");
    assert!(total_limited > 0.3 * allowance.min(total_geometric), "progress is made: {total_limited}");
    assert!(total_geometric > total_limited);
    // Half the speed removes about half as much.
    let mut slow = tooth(0.05);
    let mut cut_slow = Cutter::default();
    let mut total_slow = 0.0;
    for i in 0..40 {
        total_slow += cut_slow.cut_with(&mut slow, &burr, tip(i), tip(i + 1), Feed::Limited { force_n, rpm: rpm / 2.0, dt_s }).unwrap().removed("enamel");
    }
    assert!(total_slow <= 0.5 * allowance * 1.05 + 1e-4, "{total_slow}");
    // Dentin recedes faster than enamel at the same force.
    assert!(table.get("dentin").unwrap().removal_rate_mm3_per_n_s > enamel_rate);
}

#[test]
fn bad_poses_are_refused_naming_the_pose() {
    let mut model = tooth(0.1);
    let burr = Burr::round(1.0).unwrap();
    let mut cutter = Cutter::default();
    let good = at(0.0, 0.0, 4.0);
    let nan = at(f64::NAN, 0.0, 4.0);
    let e = cutter.cut(&mut model, &burr, nan, good).unwrap_err().to_string();
    assert!(e.contains("stroke start pose") && e.contains("finite"), "{e}");
    let skew = DAffine3 { matrix3: DMat3::from_diagonal(DVec3::new(1.1, 1.0, 1.0)), translation: DVec3::new(0.0, 0.0, 4.0) };
    let e = cutter.cut(&mut model, &burr, good, skew).unwrap_err().to_string();
    assert!(e.contains("stroke end pose") && e.contains("orthonormal"), "{e}");
    let e = cutter.cut(&mut model, &burr, good, at(5000.0, 0.0, 0.0)).unwrap_err().to_string();
    assert!(e.contains("stroke") && e.contains("too far apart"), "{e}");
    let e = cutter.cut(&mut model, &Burr::parse("needle:1.0:8").unwrap(), good, at(3000.0, 0.0, 4.0)).unwrap_err().to_string();
    assert!(e.contains("stroke") && e.contains("too far apart"), "{e}");
    let e = cutter
        .cut_with(&mut model, &burr, good, good, Feed::Limited { force_n: f64::NAN, rpm: 1.0, dt_s: 0.001 })
        .unwrap_err()
        .to_string();
    assert!(e.contains("force_n"), "{e}");
    assert!(Burr::parse("806 314 777 524 010").unwrap_err().to_string().contains("'777'"));
    let _ = Shape::ALL;
}

/// Ticks that continue the previous stroke skip what its end ball already took; the grids and
/// removed volumes must match cutting every tick from scratch (a fresh cutter per tick never
/// skips), to the skip's 1e-5 mm margin.
#[test]
fn continued_strokes_match_strokes_cut_from_scratch() {
    let burr = Burr::round(1.0).unwrap();
    let (lo, n) = (IVec3::new(-40, -20, 60), 60);
    // A curved, descending path of 0.02-0.04 mm ticks, as a haptic session produces.
    let tip = |i: usize| {
        let s = i as f64 * 0.03;
        at(-1.2 + s, 0.4 * (s * 2.0).sin(), 4.6 - 0.15 * s)
    };
    let mut skipping = tooth(0.05);
    let mut fresh = skipping.clone();
    let mut cutter = Cutter::default();
    let mut total = 0.0;
    for i in 0..60 {
        let a = cutter.cut_with(&mut skipping, &burr, tip(i), tip(i + 1), Feed::Geometric).unwrap().total_mm3();
        let b = Cutter::default().cut(&mut fresh, &burr, tip(i), tip(i + 1)).unwrap().total_mm3();
        assert!((a - b).abs() <= 1e-6 + 1e-4 * b, "tick {i}: removed {a} vs {b} mm3");
        total += a;
    }
    assert!(total > 0.2, "the path cuts into the tooth ({total} mm3)");
    let (ours, theirs) = (values(&skipping, lo, n), values(&fresh, lo, n));
    let worst = ours.iter().flatten().zip(theirs.iter().flatten()).map(|(a, b)| (a - b).abs()).fold(0f32, f32::max);
    assert!(worst <= 2e-5, "largest voxel difference {worst} mm");
    assert!(skipping.tissues[0].grid.volume() < fresh.tissues[0].grid.volume() + 1e-3);
}

/// Anything that edits the grids between strokes (here an undo) makes the next stroke cut its
/// start ball again instead of trusting the last one.
#[test]
fn an_edit_between_strokes_stops_the_skip() {
    let burr = Burr::round(1.0).unwrap();
    let mut model = tooth(0.05);
    let mut cutter = Cutter::default();
    cutter.cut(&mut model, &burr, at(-1.0, 0.0, 4.5), at(-0.5, 0.0, 4.5)).unwrap();
    assert!(cutter.undo(&mut model));
    let again = cutter.cut(&mut model, &burr, at(-0.5, 0.0, 4.5), at(-0.48, 0.0, 4.5)).unwrap().total_mm3();
    let mut reference = tooth(0.05);
    let expected = Cutter::default().cut(&mut reference, &burr, at(-0.5, 0.0, 4.5), at(-0.48, 0.0, 4.5)).unwrap().total_mm3();
    assert!(expected > 0.1, "the stroke cuts a whole ball ({expected} mm3)");
    assert!((again - expected).abs() < 1e-9 + 1e-6 * expected, "after undo: {again} vs {expected} mm3");
}
