//! The capsule phantom and straight strokes, checked against closed-form volumes.
use std::f64::consts::PI;

use dentsim_sim::burr::Burr;
use dentsim_sim::cutting::cutter::Cutter;
use dentsim_sim::tissues::model::TissueModel;
use dentsim_sim::tissues::capsule::CapsuleTooth;
use dentsim_sim::plan::phantom_stroke::PhantomStroke;
use dentsim_sim::tissues::table::TissueTable;
use glam::{DAffine3, DVec3};

fn phantom(voxel: f64) -> TissueModel {
    CapsuleTooth::default().build(voxel, &TissueTable::default()).unwrap()
}

#[test]
fn tissue_volumes_match_the_closed_form() {
    let tooth = CapsuleTooth::default();
    let model = phantom(0.05);
    for (name, volume) in model.volumes() {
        let exact = tooth.volume(&name).unwrap();
        assert!((volume / exact - 1.0).abs() < 0.01, "{name}: {volume} vs {exact}");
        let mesh = model.get(&name).unwrap().grid.to_mesh().volume();
        assert!((mesh / exact - 1.0).abs() < 0.01, "{name} mesh: {mesh} vs {exact}");
    }
    // Tissues do not overlap: at most one contains any point.
    let grids: Vec<_> = model.tissues.iter().map(|t| &t.grid).collect();
    let mut readers: Vec<_> = grids.iter().map(|g| g.reader()).collect();
    for i in 0..400 {
        let f = f64::from(i);
        let p = DVec3::new((f * 0.37).sin() * 3.2, (f * 0.73).cos() * 3.2, (f * 0.11).sin() * 5.2);
        let inside = readers.iter_mut().map(|r| r.value(p)).filter(|v| *v < -0.03).count();
        assert!(inside <= 1, "{p} lies in {inside} tissues");
    }
}

#[test]
fn a_stroke_inside_enamel_removes_its_capsule() {
    let mut model = phantom(0.05);
    let r = 0.3;
    let burr = Burr::round(2.0 * r).unwrap();
    let tip = |x: f64| DAffine3::from_translation(DVec3::new(x, 0.0, 4.25 - r));
    let report = Cutter::default().cut(&mut model, &burr, tip(-0.5), tip(0.5)).unwrap();
    let exact = PI * r * r * 1.0 + 4.0 / 3.0 * PI * r.powi(3);
    let enamel = report.removed("enamel");
    println!("capsule stroke: removed {enamel:.5} mm³ vs exact {exact:.5} ({:+.3} %)", (enamel / exact - 1.0) * 100.0);
    assert!((enamel / exact - 1.0).abs() < 0.01, "{enamel} vs {exact}");
    assert_eq!(report.removed("dentin"), 0.0);
    assert_eq!(report.removed("pulp"), 0.0);
    let mut reader = model.get("enamel").unwrap().grid.reader();
    assert!(reader.value(DVec3::new(0.0, 0.0, 4.25)) > 0.1, "the stroke's axis is now outside");
    assert!(reader.value(DVec3::new(0.0, 0.0, 4.25 + r + 0.2)) < -0.1, "enamel above the cut stays");
}

#[test]
fn default_stroke_cuts_enamel_and_dentin_with_exact_bookkeeping() {
    let table = TissueTable::default();
    let outcome = PhantomStroke::default().run(&table, &mut |_, _| {}).unwrap();
    let by_name = |n: &str| outcome.tissues.iter().find(|t| t.name == n).unwrap().clone();
    let (enamel, dentin, pulp) = (by_name("enamel"), by_name("dentin"), by_name("pulp"));
    assert!(enamel.removed_mm3 > 1.0, "{enamel:?}");
    assert!(dentin.removed_mm3 > 0.05, "{dentin:?}");
    assert_eq!(pulp.removed_mm3, 0.0);
    for t in &outcome.tissues {
        let diff = t.volume_before_mm3 - t.volume_after_mm3;
        assert!((diff - t.removed_mm3).abs() < 1e-6 * t.volume_before_mm3, "{t:?}");
    }
}

#[test]
fn model_round_trips_through_a_vdb_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("tissues.vdb");
    let mut model = phantom(0.1);
    model.tissues[0].props.stiffness_n_per_mm = 0.77;
    model.fdi_tooth = Some(36);
    model.save(&path).unwrap();
    let back = TissueModel::load(&path, &TissueTable::default()).unwrap();
    assert_eq!(back.tissues.len(), 3);
    assert_eq!(back.fdi_tooth, Some(36));
    for (name, volume) in model.volumes() {
        let t = back.get(&name).unwrap();
        assert_eq!(t.props, model.get(&name).unwrap().props);
        assert_eq!(t.grid.volume(), volume);
    }
    let labels: Vec<u8> = back.tissues.iter().map(|t| t.props.label).collect();
    assert!(labels.windows(2).all(|w| w[0] < w[1]), "label order {labels:?}");
}

#[test]
fn bad_stroke_parameters_are_refused() {
    let table = TissueTable::default();
    let bad = [
        PhantomStroke { voxel_size_mm: 0.0, ..Default::default() },
        PhantomStroke { burr_diameter_mm: f64::NAN, ..Default::default() },
        PhantomStroke { start_mm: [f64::INFINITY, 0.0, 0.0], ..Default::default() },
    ];
    for p in bad {
        let e = p.run(&table, &mut |_, _| {}).err().expect("refused");
        assert!(!e.to_string().is_empty());
    }
}
