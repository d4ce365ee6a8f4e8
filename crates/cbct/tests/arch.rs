//! The whole-arch phantom (16 teeth, each turned along the curve) and segmentation's search box
//! around a seed.
use dentsim_cbct::*;
use glam::DVec3;

/// With a seed alone, markers are sought in a box around it: on a scan much larger than that box,
/// the labels are the same as with the whole scan as the selection's box (markers everywhere).
#[test]
fn a_tooth_segmented_around_its_seed_is_the_one_segmented_in_the_whole_scan() {
    let spec = PhantomSpec { dims: [260, 260, 170], ..Default::default() };
    let ph = Phantom::new(&spec);
    let scan = ph.scan();
    let cal = calibrate(&scan).unwrap();
    let seed = ph.tooth_seed(36).unwrap();
    let around = segment(&scan, &cal, &SegmentOptions { tooth: Some(ToothSelect { fdi: 36, seed, bounds: None }), ..Default::default() }).unwrap();
    let corner = |i: usize, j: usize, k: usize| scan.voxel_center(i, j, k);
    let (lo, hi) = (corner(0, 0, 0), corner(spec.dims[0] - 1, spec.dims[1] - 1, spec.dims[2] - 1));
    let whole = segment(&scan, &cal, &SegmentOptions { tooth: Some(ToothSelect { fdi: 36, seed, bounds: Some((lo, hi)) }), ..Default::default() }).unwrap();
    let differ = around.labels.iter().zip(&whole.labels).filter(|(a, b)| a != b).count();
    assert_eq!(differ, 0, "{differ} voxels differ");
    assert!(around.volume_mm3(Label::Enamel) > 100.0 && around.volume_mm3(Label::Pulp) > 10.0);
}

/// Every tooth of the arch is found, once, as its own object near its true place.
#[test]
fn every_tooth_of_the_arch_is_found_once() {
    let ph = Phantom::new(&PhantomSpec::arch(36));
    assert_eq!(ph.teeth().len(), 16);
    let scan = ph.scan();
    let cal = calibrate(&scan).unwrap();
    let found = find_teeth(&scan, &cal).unwrap();
    let mut hits = std::collections::BTreeMap::new();
    for f in &found {
        let seed = DVec3::from_array(f.seed);
        // the tooth whose outline holds the seed (its SDF below zero there)
        let inside: Vec<u8> = ph.teeth().into_iter().filter(|&t| ph.tooth_sdf(t, Label::Air, seed).unwrap() < 0.0).collect();
        assert_eq!(inside.len(), 1, "seed {seed} in {inside:?}");
        let (lo, hi) = ph.tooth_bounds(inside[0]).unwrap();
        // its box inside the true tooth's (padded) box: nothing of a neighbour or the bone
        for c in 0..3 {
            assert!(f.min[c] > lo[c] - 0.3 && f.max[c] < hi[c] + 0.3, "{}: {f:?} vs {lo:?} {hi:?}", inside[0]);
        }
        *hits.entry(inside[0]).or_insert(0) += 1;
    }
    println!("{} found: {hits:?}", found.len());
    assert_eq!(found.len(), 16, "{hits:?}");
    assert!(hits.values().all(|&n| n == 1), "{hits:?}");
}
