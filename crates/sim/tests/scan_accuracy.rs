//! The molar phantom's scan through calibration, segmentation and level sets, measured against the
//! phantom's continuous ground truth (issue 3's accuracy table).
use dentsim_cbct::{dice, Label, Phantom, PhantomSpec};
use dentsim_sim::tissues::from_scan::TissuesFromScan;
use dentsim_sim::tissues::table::TissueTable;
use dentsim_vdb::LevelSet;
use glam::DVec3;

#[test]
fn phantom_tissues_match_ground_truth() {
    let phantom = Phantom::new(&PhantomSpec::default());
    let scan = phantom.scan();
    let request = TissuesFromScan { seed_mm: phantom.tooth_seed(36), ..Default::default() };
    let (model, report) = request.run(&scan, &TissueTable::default(), &mut |_, _| {}).unwrap();
    let scan_voxel = scan.spacing[0];
    let (lo, hi) = phantom.tooth_bounds(36).unwrap();
    let (lo, hi) = (DVec3::from_array(lo) - 1.0, DVec3::from_array(hi) + 1.0);

    let mut failures = Vec::new();
    println!("tissue   true mm3  ours mm3   error   MSD ours->true  MSD true->ours  (mm)");
    for label in [Label::Enamel, Label::Dentin, Label::Pulp] {
        let tissue = model.get(label.name()).unwrap_or_else(|| panic!("{} built", label.name()));
        let truth = phantom.true_volume_mm3(label);
        let ours = tissue.grid.volume();
        let error = ours / truth - 1.0;

        // Mean surface distance, both ways: our surface against the true SDF, and the true
        // surface (its own level set, meshed) against our level set.
        let mesh = tissue.grid.to_mesh();
        let step = (mesh.points.len() / 4000).max(1);
        let ours_to_truth = mean(mesh.points.iter().step_by(step).map(|p| {
            phantom.tooth_sdf(36, label, p.as_dvec3()).unwrap().abs()
        }));
        let true_grid = LevelSet::from_sdf(0.05, 3.0, lo, hi, |p| phantom.tooth_sdf(36, label, p).unwrap()).unwrap();
        let true_mesh = true_grid.to_mesh();
        let mut reader = tissue.grid.reader();
        let step = (true_mesh.points.len() / 4000).max(1);
        let truth_to_ours = mean(true_mesh.points.iter().step_by(step).map(|p| f64::from(reader.value(p.as_dvec3())).abs()));
        println!(
            "{:<8} {truth:>8.2} {ours:>9.2} {:>+7.2}%  {ours_to_truth:>14.4}  {truth_to_ours:>14.4}",
            label.name(),
            100.0 * error
        );
        // Issue 3: every tissue within 2 % of its volume, surfaces within half a scan voxel.
        if error.abs() > 0.02 {
            failures.push(format!("{} volume {ours:.2} vs {truth:.2} mm3", label.name()));
        }
        if ours_to_truth.max(truth_to_ours) > 0.5 * scan_voxel {
            failures.push(format!("{} mean surface distance {ours_to_truth:.4} / {truth_to_ours:.4} mm", label.name()));
        }
    }
    let pulp = report.tissues.iter().find(|t| t.name == "pulp").unwrap();
    let measure = pulp.partial_volume.as_ref().expect("the pulp's surface is fitted to its partial-volume measure");
    println!("pulp: partial-volume measure {:.2} mm3 (grey {:.0} in dentin {:.0}), surface moved {:+.4} mm", measure.volume_mm3, measure.tissue_grey, measure.surround_grey, pulp.surface_offset_mm);
    println!("seconds {:?}", report.seconds);
    assert!(failures.is_empty(), "{failures:?}");
    // Dice of the segmentation itself at the scan's resolution.
    let truth_labels = phantom.tooth_labels(36);
    let segmented = dentsim_cbct::segment(&scan, &report.calibration, &dentsim_cbct::SegmentOptions {
        tooth: Some(dentsim_cbct::ToothSelect { fdi: 36, seed: phantom.tooth_seed(36).unwrap(), bounds: None }),
        ..Default::default()
    })
    .unwrap();
    for label in [Label::Enamel, Label::Dentin, Label::Pulp] {
        let d = dice(&segmented, &truth_labels, label);
        println!("Dice {:<8} {d:.3}", label.name());
        assert!(d > 0.9, "{} Dice {d}", label.name());
    }
    assert_eq!(model.fdi_tooth, Some(36));
}

/// A scan blurred past the 0.18 mm point spread at which the whole pulp used to be labelled
/// caries (and no pulp built), of the phantom with its occlusal lesion: the model holds both,
/// each near its true volume, the lesion's surface near the true one.
#[test]
fn blurred_scan_with_caries_keeps_pulp_and_lesion() {
    let phantom = Phantom::new(&PhantomSpec { caries: true, blur_sigma_mm: 0.2, ..Default::default() });
    let scan = phantom.scan();
    let request = TissuesFromScan { seed_mm: phantom.tooth_seed(36), ..Default::default() };
    let (model, _) = request.run(&scan, &TissueTable::default(), &mut |_, _| {}).unwrap();
    let truth = phantom.tooth_volumes_mm3(36);
    println!("tissue   true mm3  ours mm3   error");
    let mut failures = Vec::new();
    // Measured: enamel -1.4 %, dentin +0.6 %, pulp -1.8 %, caries -3.6 % (caries was the whole
    // pulp, +234 %, and the pulp missing).
    for (label, tolerance) in [(Label::Enamel, 0.02), (Label::Dentin, 0.03), (Label::Pulp, 0.03), (Label::Caries, 0.05)] {
        let tissue = model.get(label.name()).unwrap_or_else(|| panic!("{} built", label.name()));
        let (t, ours) = (truth[label as usize], tissue.grid.volume());
        println!("{:<8} {t:8.2} {ours:9.2} {:+7.2}%", label.name(), 100.0 * (ours / t - 1.0));
        if (ours / t - 1.0).abs() > tolerance {
            failures.push(format!("{} volume {ours:.2} vs {t:.2} mm3", label.name()));
        }
    }
    let mesh = model.get("caries").unwrap().grid.to_mesh();
    let step = (mesh.points.len() / 4000).max(1);
    let distance = mean(mesh.points.iter().step_by(step).map(|p| phantom.tooth_sdf(36, Label::Caries, p.as_dvec3()).unwrap().abs()));
    println!("caries surface: mean distance to the true one {distance:.4} mm");
    // Measured 0.108 mm (0.098 at the default blur): the lesion's sides and floor lie within
    // 0.1 mm, but the phantom's enamel roof over the hidden lesion, 0.25 mm thick between air and
    // lesion, has the lesion's grey and is taken with it.
    if distance > 0.75 * scan.spacing[0] {
        failures.push(format!("caries mean surface distance {distance:.4} mm"));
    }
    assert!(failures.is_empty(), "{failures:?}");
}

#[test]
fn the_tooth_is_found_from_the_scan_centre_without_a_seed() {
    let phantom = Phantom::new(&PhantomSpec::default());
    let (model, report) = TissuesFromScan::default().run(&phantom.scan(), &TissueTable::default(), &mut |_, _| {}).unwrap();
    assert!(model.get("enamel").is_some() && model.get("dentin").is_some());
    assert!(report.calibration.method.contains("peaks") || report.calibration.method.contains("otsu"));
}

fn mean(values: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = values.fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    sum / n.max(1) as f64
}

/// A tooth without a pulp (a solid tooth-like body in air: a dentin ball on a root, an enamel cap
/// over its upper half) is segmented all the same, and its report says there is no pulp and what
/// to try (`--thresholds`), never silently.
#[test]
fn a_tooth_without_a_pulp_is_reported() {
    let scan = dentsim_cbct::phantom::layered_ball(3000.0, 2200.0, &|_, _, _| None).unwrap();
    let (n, h) = (60usize, 0.25);
    let c = (n as f64 - 1.0) / 2.0;
    // the ball's centre: index c, c, c - 2 mm
    let request = TissuesFromScan { seed_mm: Some([c * h, c * h, c * h - 2.0]), ..Default::default() };
    let (_, report) = request.run(&scan, &TissueTable::default(), &mut |_, _| {}).unwrap();
    let names: Vec<&str> = report.tissues.iter().map(|t| t.name.as_str()).collect();
    assert!(names.contains(&"enamel") && names.contains(&"dentin") && !names.contains(&"pulp"), "{names:?}");
    assert_eq!(report.warnings.len(), 1, "{:?}", report.warnings);
    assert!(report.warnings[0].starts_with("no pulp was found") && report.warnings[0].contains("--thresholds"), "{}", report.warnings[0]);
    // The molar phantom, pulp found: no warning.
    let phantom = Phantom::new(&PhantomSpec::default());
    let request = TissuesFromScan { seed_mm: phantom.tooth_seed(36), ..Default::default() };
    let (_, report) = request.run(&phantom.scan(), &TissueTable::default(), &mut |_, _| {}).unwrap();
    assert!(report.warnings.is_empty(), "{:?}", report.warnings);
}
