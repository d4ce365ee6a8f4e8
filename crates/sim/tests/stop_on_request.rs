//! Segmentation asked to stop (a GUI's abort) stops before its next step with an error saying
//! so, one tooth or every tooth.
use dentsim_cbct::{Phantom, PhantomSpec};
use dentsim_sim::error::STOPPED;
use dentsim_sim::tissues::from_scan::TissuesFromScan;
use dentsim_sim::tissues::table::TissueTable;

#[test]
fn segmentation_stops_at_the_step_it_is_asked_to() {
    let phantom = Phantom::new(&PhantomSpec::default());
    let scan = phantom.scan();
    let request = TissuesFromScan { seed_mm: phantom.tooth_seed(36), voxel_size_mm: 0.1, ..Default::default() };
    let table = TissueTable::default();
    let mut steps = Vec::new();
    request
        .run_until(&scan, &table, &mut |step, f| {
            steps.push((step.to_owned(), f));
            true
        })
        .unwrap();
    let names: Vec<&str> = steps.iter().map(|(s, _)| s.as_str()).collect();
    assert!(names.contains(&"segmenting") && names.contains(&"level set: dentin") && names.last() == Some(&"done"), "{names:?}");
    assert!(steps.windows(2).all(|w| w[0].1 <= w[1].1), "progress only grows: {steps:?}");

    // Before segmenting, and between two tissues' level sets.
    for stop_at in ["segmenting", "level set: dentin"] {
        let mut seen = Vec::new();
        let err = request
            .run_until(&scan, &table, &mut |step, _| {
                seen.push(step.to_owned());
                step != stop_at
            })
            .err()
            .unwrap_or_else(|| panic!("stopped at {stop_at}"));
        assert!(err.to_string().contains(STOPPED) && err.to_string().contains("segmentation"), "{err}");
        assert_eq!(seen.last().map(String::as_str), Some(stop_at), "nothing after the stop: {seen:?}");
    }
}

#[test]
fn every_tooth_segmentation_stops_between_teeth() {
    let scan = Phantom::new(&PhantomSpec::default()).scan();
    let request = TissuesFromScan { voxel_size_mm: 0.1, ..Default::default() };
    let mut seen = Vec::new();
    let err = request
        .run_all_until(&scan, &TissueTable::default(), &mut |step, _| {
            seen.push(step.to_owned());
            !step.starts_with("tooth 2:")
        })
        .err()
        .expect("stopped at the second tooth");
    assert!(err.to_string().contains(STOPPED), "{err}");
    assert!(seen.iter().any(|s| s == "tooth 1: done"), "the first tooth was finished: {seen:?}");
    assert_eq!(seen.iter().filter(|s| s.starts_with("tooth 2:")).count(), 1, "nothing after the stop: {seen:?}");
}
