//! Every tooth in the field of view, each its own object: three teeth in contact, in the jaw and
//! in air, each found once and segmented near its own true tissues; every tooth of an arch under
//! a cone-beam shading.
use dentsim_cbct::phantom::Medium;
use dentsim_cbct::{Label, Phantom, PhantomSpec};
use dentsim_sim::tissues::from_scan::{ScanReport, TissuesFromScan};
use dentsim_sim::tissues::model::TissueModel;
use dentsim_sim::tissues::table::TissueTable;

/// Which of `phantom`'s teeth each of `all` is (the one holding its seed), each tooth's enamel
/// and dentin within `hard` of its truth and its pulp within `pulp` (`what` names the scan).
fn teeth_as_themselves(what: &str, phantom: &Phantom, all: &[(TissueModel, ScanReport)], hard: f64, pulp: f64) -> Vec<u8> {
    let mut seen = Vec::new();
    for (model, report) in all {
        let (n, found) = report.found.as_ref().unwrap();
        assert_eq!(report.fdi, 0, "not identified, so no number");
        let fdi = phantom.teeth().into_iter().find(|&f| phantom.tooth_sdf(f, Label::Air, glam::DVec3::from_array(found.seed)).unwrap() < 0.0);
        let fdi = fdi.unwrap_or_else(|| panic!("{what}: tooth {n} at {:?} lies in no tooth", found.seed));
        let truth = phantom.tooth_volumes_mm3(fdi);
        print!("{what} tooth {n} = {fdi}:");
        for label in [Label::Enamel, Label::Dentin, Label::Pulp] {
            let ours = model.get(label.name()).map_or(0.0, |t| t.grid.volume());
            let err = ours / truth[label as usize] - 1.0;
            print!(" {} {:+.1}%", label.name(), 100.0 * err);
            let tol = if label == Label::Pulp { pulp } else { hard };
            assert!(err.abs() < tol, "{what} tooth {fdi} {}: {ours:.1} vs {:.1}", label.name(), truth[label as usize]);
        }
        println!();
        seen.push(fdi);
    }
    seen.sort();
    seen
}

#[test]
fn every_tooth_is_found_once_and_segmented_as_itself() {
    for medium in [Medium::Jaw, Medium::Air] {
        let mut spec = PhantomSpec { tooth: 45, medium, neighbours: true, spacing_mm: 0.3, ..Default::default() };
        spec.dims = [(22.0 / 0.3) as usize, (44.0 / 0.3) as usize, (29.0 / 0.3) as usize];
        let phantom = Phantom::new(&spec);
        let scan = phantom.scan();
        let all = TissuesFromScan::default().run_all(&scan, &TissueTable::default(), &mut |_, _| {}).unwrap();
        // measured at 0.3 mm: enamel ≤ 5.9 % (in the jaw), dentin ≤ 2.0 %, pulp ≤ 21.2 %
        let seen = teeth_as_themselves(&format!("{medium:?}"), &phantom, &all, 0.07, 0.25);
        assert_eq!(seen, vec![44, 45, 46], "{medium:?}: each tooth once");
    }
}

#[test]
fn every_tooth_of_an_arch_under_a_cone_beam_shading_is_found_and_read_through_it() {
    // The 16-tooth arch at 0.3 mm under 450 grey values of cupping and ramp over its field
    // (157–198 over each tooth): every tooth found once, its shading taken off in its box and
    // said, its tissues near its own truth. Left on (--keep-shading), tooth 36's pulp read
    // −21.5 %.
    let spec = PhantomSpec { shading_hu: 450.0, ..PhantomSpec::arch(36) };
    let phantom = Phantom::new(&spec);
    let scan = phantom.scan();
    let all = TissuesFromScan { voxel_size_mm: 0.1, ..Default::default() }.run_all(&scan, &TissueTable::default(), &mut |_, _| {}).unwrap();
    for (_, report) in &all {
        assert_eq!(report.shading_taken_off, Some(true), "tooth at {:?}", report.found.as_ref().map(|f| f.1.seed));
        let span = report.shading_span.unwrap();
        assert!(report.warnings.iter().any(|w| w.contains(&format!("drift by {span:.0} over the tooth"))), "{:?}", report.warnings);
    }
    // measured: enamel ≤ 2.2 %, dentin ≤ 1.3 %, pulp ≤ 7.0 % (the third molars'), each within
    // 0.5 % of the same tooth in the arch unshaded
    let seen = teeth_as_themselves("shaded arch", &phantom, &all, 0.03, 0.08);
    let mut teeth = phantom.teeth();
    teeth.sort();
    assert_eq!(seen, teeth, "each tooth once");
}
