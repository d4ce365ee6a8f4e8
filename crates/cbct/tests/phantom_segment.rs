//! Phantom geometry, calibration, segmentation accuracy and regions of interest.

use dentsim_cbct::*;
use glam::DVec3;
use proptest::prelude::*;

const TISSUES: [Label; 9] = Label::ALL;

fn select(ph: &Phantom) -> SegmentOptions {
    SegmentOptions { tooth: Some(ToothSelect { fdi: 36, seed: ph.tooth_seed(36).unwrap(), bounds: None }), ..Default::default() }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]
    /// Every label SDF is Lipschitz ≤ 1, and exactly one label is negative at any point: the one
    /// `label_at` reports (tissues nest without overlap or gaps).
    #[test]
    fn sdfs_are_lipschitz_and_partition_space(x in -12.0f64..12.0, y in -14.0f64..14.0, z in -16.0f64..10.0,
                                               dx in -1.0f64..1.0, dy in -1.0f64..1.0, dz in -1.0f64..1.0) {
        let ph = Phantom::new(&PhantomSpec { caries: true, restoration: true, ..Default::default() });
        let (lo, hi) = ph.tooth_bounds(36).unwrap();
        let c = DVec3::from_array(lo).lerp(DVec3::from_array(hi), 0.5);
        let p = c + DVec3::new(x, y, z);
        let q = p + DVec3::new(dx, dy, dz) * 0.5;
        let inside: Vec<Label> = TISSUES.iter().copied().filter(|&l| ph.sdf(l, p) < 0.0).collect();
        prop_assert_eq!(inside.len(), 1, "labels inside at {:?}: {:?}", p, inside);
        prop_assert_eq!(inside[0], ph.label_at(p));
        for l in TISSUES {
            let (a, b) = (ph.sdf(l, p), ph.sdf(l, q));
            if a.is_finite() && b.is_finite() {
                prop_assert!((a - b).abs() <= (p - q).length() * (1.0 + 1e-9) + 1e-12, "{:?}: |{} - {}| > {}", l, a, b, (p - q).length());
            }
        }
    }
}

#[test]
fn scan_is_deterministic_from_the_seed_and_not_hu() {
    let spec = PhantomSpec { dims: [40, 40, 40], spacing_mm: 0.5, ..Default::default() };
    let a = Phantom::new(&spec).scan();
    let b = Phantom::new(&spec).scan();
    assert_eq!(a.values, b.values);
    let c = Phantom::new(&PhantomSpec { seed: 7, ..spec.clone() }).scan();
    assert_ne!(a.values, c.values);
    // grey = 0.9 HU + 1100: air reads about 200, not -1000
    let (lo, _) = a.min_max();
    assert!(lo > 0.0, "min grey {lo}");
    assert!(a.origin.iter().all(|&o| o.abs() > 1.0), "origin {:?} is a patient position", a.origin);
}

#[test]
fn true_volumes_add_up_and_match_the_grid() {
    let ph = Phantom::new(&PhantomSpec { caries: true, ..Default::default() });
    let fine = ph.tooth_volumes_mm3(36);
    let finer = ph.tooth_volumes_at(36, 0.025);
    let labels = ph.tooth_labels(36);
    println!("tissue     octree 0.05  octree 0.025  voxel count 0.2 mm");
    for l in [Label::Enamel, Label::Dentin, Label::Pulp, Label::Caries] {
        let (a, b, c) = (fine[l as usize], finer[l as usize], labels.volume_mm3(l));
        println!("{:10} {a:10.3} {b:12.3} {c:12.3}", l.name());
        assert!((a - b).abs() <= 0.005 * b, "{}: {a} vs {b}", l.name());
        assert!((c - b).abs() <= 0.03 * b, "{}: grid {c} vs {b}", l.name());
    }
    // anatomy in the ranges we modelled: enamel ~1-2 mm over the crown, pulp tens of mm³
    assert!(fine[Label::Enamel as usize] > 250.0 && fine[Label::Dentin as usize] > 350.0 && fine[Label::Pulp as usize] > 20.0);
}

#[test]
fn calibration_recovers_the_scans_grey_mapping() {
    let spec = PhantomSpec { scale: 1.3, offset: -250.0, ..Default::default() };
    let scan = Phantom::new(&spec).scan();
    let cal = calibrate(&scan).unwrap();
    println!("{}", serde_json::to_string_pretty(&cal).unwrap());
    assert_eq!(cal.method, "histogram-peaks+linear-fit");
    assert!((cal.hu_scale - 1.3).abs() < 0.03, "scale {}", cal.hu_scale);
    assert!((cal.hu_offset + 250.0).abs() < 15.0, "offset {}", cal.hu_offset);
    for l in [Label::Air, Label::Dentin, Label::Enamel] {
        assert!(cal.measured.contains(&l.name().to_string()), "{} not measured", l.name());
    }
    let back: Calibration = serde_json::from_str(&serde_json::to_string(&cal).unwrap()).unwrap();
    assert_eq!(back, cal);
    let manual = Calibration::manual(&[(Label::Air, -1050.0), (Label::Enamel, 3000.0)]).unwrap();
    assert_eq!(manual.method, "manual");
    assert!((manual.peak(Label::Enamel) - 3000.0).abs() < 1e-9);
}

#[test]
fn a_reading_without_bone_has_no_bone_class_and_its_hard_cut_is_the_mediums_midpoint() {
    // A tooth alone in air: air, dentin and enamel given; the fit predicts bone's grey.
    let cal = Calibration::manual(&[(Label::Air, -1000.0), (Label::Dentin, 1650.0), (Label::Enamel, 2500.0)]).unwrap();
    assert_eq!(cal.hard_cut(), cal.mid(Label::BoneCortical, Label::Dentin));
    let bone_free = cal.without_bone();
    assert!(bone_free.thresholds.iter().all(|t| !t.below.starts_with("bone") && !t.above.starts_with("bone")), "{:?}", bone_free.thresholds);
    assert_eq!(bone_free.hard_cut(), bone_free.mid(Label::SoftTissue, Label::Dentin));
    assert!(bone_free.hard_cut() < cal.hard_cut());
    // Voxels of bone's predicted greys are the blur's mix: the darker (cancellous) the
    // outside's, the brighter (cortical, past the medium's midpoint) the tooth's. The grey
    // values themselves do not change, and the reading says what it did.
    assert_eq!(cal.classify(cal.peak(Label::BoneCancellous)), Label::BoneCancellous);
    assert_eq!(bone_free.classify(cal.peak(Label::BoneCancellous)), Label::SoftTissue);
    assert_eq!(cal.classify(cal.peak(Label::BoneCortical)), Label::BoneCortical);
    assert_eq!(bone_free.classify(cal.peak(Label::BoneCortical)), Label::Dentin);
    assert_eq!(bone_free.classify(cal.peak(Label::Dentin)), Label::Dentin);
    assert_eq!(bone_free.peaks, cal.peaks);
    assert!(bone_free.evidence.last().is_some_and(|e| e.contains("without bone")), "{:?}", bone_free.evidence);
}

#[test]
fn segmentation_accuracy_at_default_noise() {
    let ph = Phantom::new(&PhantomSpec::default());
    let scan = ph.scan();
    let cal = calibrate(&scan).unwrap();
    let seg = segment(&scan, &cal, &select(&ph)).unwrap();
    let truth = ph.tooth_labels(36);
    let vols = ph.tooth_volumes_mm3(36);
    println!("tissue       true mm3   seg mm3   error    Dice");
    for (l, tol) in [(Label::Enamel, 0.03), (Label::Dentin, 0.03), (Label::Pulp, 0.04)] {
        let (t, s) = (vols[l as usize], seg.volume_mm3(l));
        let d = dice(&seg, &truth, l);
        println!("{:10} {t:10.2} {s:9.2} {:+6.2}% {d:7.4}", l.name(), 100.0 * (s - t) / t);
        assert!((s - t).abs() <= tol * t, "{}: {s} vs {t}", l.name());
        assert!(d > 0.95, "{}: Dice {d}", l.name());
    }
    // one tooth only: nothing labelled as tooth near 35 or 37
    for fdi in [35, 37] {
        let seed = ph.tooth_seed(fdi).unwrap();
        let i = scan.world_to_index(seed).unwrap();
        let l = seg.labels[scan.index(i[0].round() as usize, i[1].round() as usize, i[2].round() as usize)];
        assert!(l != Label::Enamel as u8 && l != Label::Dentin as u8 && l != Label::Pulp as u8, "tooth {fdi} labelled {l}");
    }
}

#[test]
fn caries_and_metal_are_labelled() {
    let ph = Phantom::new(&PhantomSpec { caries: true, restoration: true, ..Default::default() });
    let scan = ph.scan();
    let cal = calibrate(&scan).unwrap();
    let seg = segment(&scan, &cal, &select(&ph)).unwrap();
    let truth = ph.labels();
    let teeth = ph.tooth_labels(36);
    let dc = dice(&seg, &teeth, Label::Caries);
    let (vc, tc) = (seg.volume_mm3(Label::Caries), teeth.volume_mm3(Label::Caries));
    let dm = dice(&seg, &truth, Label::Metal);
    println!("caries Dice {dc:.3} ({vc:.2} of {tc:.2} mm3), metal Dice {dm:.3} ({:.2} of {:.2} mm3)", seg.volume_mm3(Label::Metal), truth.volume_mm3(Label::Metal));
    // The lesion's border at the midpoint between its grey and its neighbour's (enamel, dentin):
    // measured Dice 0.85, +0.9 %; the enamel roof over the hidden lesion, one voxel thick between
    // air and lesion, reads as lesion.
    assert!(dc > 0.8, "caries Dice {dc}");
    assert!((vc / tc - 1.0).abs() < 0.1, "caries {vc} vs {tc} mm3");
    // Metal: the saturated voxels opened by 0.4 mm, so the streaks (+-900 HU bands) that lift
    // enamel past the metal threshold drop out (Dice was 0.54); what remains is the blur's bloom,
    // ~0.2 mm around the metal: measured 0.77.
    assert!(dm > 0.7, "metal Dice {dm}");
    // streaks saturate: the brightest voxels sit at the detector's top
    let top = 0.9 * 3071.0 + 1100.0;
    assert!(scan.min_max().1 >= top - 1.0);
    // The restored tooth itself: its metal stays metal (the refinement of the tooth's surface no
    // longer swallows the restoration, nor reads its bloom as tooth; 5 % of the metal, the thin
    // rim the opening cuts, goes to the enamel); enamel or dentin voxels off the tooth: 56, where
    // streaks cross the contact with 36 (73 before; none without the restoration).
    let sel37 = SegmentOptions { tooth: Some(ToothSelect { fdi: 37, seed: ph.tooth_seed(37).unwrap(), bounds: None }), ..Default::default() };
    let seg37 = segment(&scan, &cal, &sel37).unwrap();
    let d37 = dice(&seg37, &truth, Label::Metal);
    let swallowed = seg37.labels.iter().zip(&truth.labels).filter(|(s, t)| **t == Label::Metal as u8 && (**s == Label::Enamel as u8 || **s == Label::Dentin as u8)).count();
    let strays = off_tooth(&seg37, &ph.tooth_labels(37));
    println!("tooth 37: metal Dice {d37:.3}, metal voxels taken for enamel or dentin {swallowed}, enamel or dentin voxels off the tooth {strays}");
    assert!(d37 > 0.7, "metal Dice with 37 selected {d37}");
    assert!(swallowed * 10 < truth.count(Label::Metal), "{swallowed} metal voxels taken for tooth");
    assert!(strays < 73, "{strays} enamel or dentin voxels off tooth 37");
}

/// Voxels labelled enamel or dentin with no voxel of the true tooth among their 26 neighbours.
fn off_tooth(seg: &LabelVolume, truth: &LabelVolume) -> usize {
    let [nx, ny, nz] = seg.dims;
    let tooth = |l: u8| l == Label::Enamel as u8 || l == Label::Dentin as u8 || l == Label::Pulp as u8 || l == Label::Caries as u8;
    (0..seg.labels.len())
        .filter(|&n| seg.labels[n] == Label::Enamel as u8 || seg.labels[n] == Label::Dentin as u8)
        .filter(|&n| {
            let (i, j, k) = ((n % nx) as i64, ((n / nx) % ny) as i64, (n / (nx * ny)) as i64);
            !(-1..=1).any(|dk| {
                (-1..=1).any(|dj| {
                    (-1..=1).any(|di| {
                        let (a, b, c) = (i + di, j + dj, k + dk);
                        (0..nx as i64).contains(&a) && (0..ny as i64).contains(&b) && (0..nz as i64).contains(&c) && tooth(truth.labels[(a + nx as i64 * (b + ny as i64 * c)) as usize])
                    })
                })
            })
        })
        .count()
}

/// Over scan blur 0.10–0.25 mm the pulp is found as pulp and the occlusal lesion as caries (a
/// cavity's median grey, which the blur pulls toward the dentin's, made the whole pulp caries
/// from 0.18 mm on), and a sound tooth gets no caries. Truth: the phantom's voxel labels.
#[test]
fn pulp_and_caries_are_told_apart_over_blur_levels() {
    println!("blur  tissue   true mm3  seg mm3   error    Dice");
    for blur in [0.10, 0.15, 0.20, 0.25] {
        let ph = Phantom::new(&PhantomSpec { caries: true, blur_sigma_mm: blur, ..Default::default() });
        let scan = ph.scan();
        let seg = segment(&scan, &calibrate(&scan).unwrap(), &select(&ph)).unwrap();
        let truth = ph.tooth_labels(36);
        for l in [Label::Pulp, Label::Caries] {
            let (t, s, d) = (truth.volume_mm3(l), seg.volume_mm3(l), dice(&seg, &truth, l));
            println!("{blur:.2}  {:8} {t:8.2} {s:8.2} {:+7.2}% {d:7.4}", l.name(), 100.0 * (s / t - 1.0));
        }
        let swapped = seg.labels.iter().zip(&truth.labels).filter(|(s, t)| (**s, **t) == (Label::Caries as u8, Label::Pulp as u8) || (**s, **t) == (Label::Pulp as u8, Label::Caries as u8)).count();
        assert_eq!(swapped, 0, "blur {blur}: {swapped} voxels of pulp taken for caries or of caries for pulp");
        let (dp, dc) = (dice(&seg, &truth, Label::Pulp), dice(&seg, &truth, Label::Caries));
        assert!(dp > 0.85, "blur {blur}: pulp Dice {dp}");
        assert!(dc > 0.75, "blur {blur}: caries Dice {dc}");
        let (s, t) = (seg.volume_mm3(Label::Caries), truth.volume_mm3(Label::Caries));
        assert!((s / t - 1.0).abs() < 0.15, "blur {blur}: caries {s} vs {t} mm3");
    }
    // Fissures' partial volume (air and enamel) has the lesion's grey at a high blur; it is no
    // lesion.
    let ph = Phantom::new(&PhantomSpec { blur_sigma_mm: 0.25, ..Default::default() });
    let scan = ph.scan();
    let seg = segment(&scan, &calibrate(&scan).unwrap(), &select(&ph)).unwrap();
    assert_eq!(seg.count(Label::Caries), 0, "caries in a sound tooth");
    assert!(dice(&seg, &ph.tooth_labels(36), Label::Pulp) > 0.85);
}

#[test]
fn tooth_box_crop_and_planes() {
    let ph = Phantom::new(&PhantomSpec::default());
    let scan = ph.scan();
    let cal = calibrate(&scan).unwrap();
    let seg = segment(&scan, &cal, &select(&ph)).unwrap();
    let b = tooth_box(&seg, 36, None, 1.0).unwrap();
    let (lo, hi) = ph.tooth_bounds(36).unwrap();
    let c = crop(&scan, &b).unwrap();
    let cl = crop_labels(&seg, &b).unwrap();
    assert_eq!(cl.count(Label::Enamel), seg.count(Label::Enamel), "the box holds the whole tooth");
    // the box lies within the tooth's modelled bounds plus the margin
    let first = c.voxel_center(0, 0, 0);
    let last = c.voxel_center(c.dims[0] - 1, c.dims[1] - 1, c.dims[2] - 1);
    for k in 0..3 {
        assert!(first[k] >= lo[k] - 1.5 && last[k] <= hi[k] + 1.5, "axis {k}: {first:?}..{last:?} vs {lo:?}..{hi:?}");
    }
    assert!(tooth_box(&seg, 19, None, 1.0).is_err(), "19 is not an ISO 3950 tooth");
    // slab between two axial planes 4 mm apart through the crown
    let seed = ph.tooth_seed(36).unwrap();
    let pa = Plane { point: [seed[0], seed[1], seed[2] - 2.0], normal: [0.0, 0.0, 1.0] };
    let pb = Plane { point: [seed[0], seed[1], seed[2] + 2.0], normal: [0.0, 0.0, -1.0] };
    let slab = crop_between_planes(&scan, &pa, &pb).unwrap();
    assert_eq!(slab.dims[0], scan.dims[0]);
    assert_eq!(slab.dims[2], 20, "4 mm at 0.2 mm");
    // an oblique slab sets voxels outside to air
    let pc = Plane { point: seed, normal: [0.0, 1.0, 1.0] };
    let slab2 = crop_between_planes(&scan, &pa, &pc).unwrap();
    let air = scan.min_max().0;
    assert!(slab2.values.iter().any(|&v| v == air));
}

#[test]
fn tissue_field_is_a_smooth_indicator() {
    let ph = Phantom::new(&PhantomSpec::default());
    let scan = ph.scan();
    let labels = ph.tooth_labels(36);
    let f = tissue_field(&scan, &labels, Label::Enamel);
    assert!(f.iter().all(|&v| (0.0..=1.0 + 1e-6).contains(&v)));
    let inside = f.iter().filter(|&&v| v >= 0.5).count() as f64;
    let count = labels.count(Label::Enamel) as f64;
    assert!((inside - count).abs() < 0.06 * count, "iso-0.5 voxels {inside} vs labelled {count}");
    assert!(f.iter().any(|&v| v > 0.1 && v < 0.9), "blurred, not binary");
}
