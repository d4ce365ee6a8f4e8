//! The phantom family's fast cases (0.25–0.3 mm scans) through the whole pipeline to 0.05 mm
//! level sets, against the analytic teeth. The goals (2 % / 2 % / 5 %, 0.05 mm, 5°) are
//! printed per tissue (✗ where missed); what is asserted is what the pipeline holds today on
//! every case, so a regression shows. The full family: examples/family_sweep.rs.
mod family;

#[test]
fn every_fast_case_gives_the_tooth_near_its_true_tissues() {
    let mut failures = Vec::new();
    let mut pulp_normals = Vec::new();
    for case in dentsim_cbct::phantom::family(false) {
        let r = family::run(&case, 0.05).unwrap();
        family::print(&r);
        assert!(r.confidence >= dentsim_cbct::calibrate::MIN_CONFIDENCE);
        // The scan's blur as made: a 0.15 mm point spread and each voxel's own averaging,
        // σ = 0.167–0.173 mm on these voxels (read 0.154–0.161 mm).
        let made = (case.spec.blur_sigma_mm.powi(2) + case.spec.spacing().iter().map(|s| s * s).sum::<f64>() / 36.0).sqrt();
        let read = r.edge_blur_mm.unwrap_or(f64::NAN);
        assert!((read / made - 1.0).abs() < 0.15, "{}: blur read {read:.3} mm, made {made:.3} mm", r.name);
        // The phantom's roots sit in bone behind a 0.2 mm ligament (read 0.186–0.208 mm on the
        // jaw cases at 0.3 mm); nothing is read without bone.
        match (case.spec.medium, r.ligament_mm) {
            (dentsim_cbct::phantom::Medium::Jaw, Some(w)) => assert!((w - 0.2).abs() < 0.03, "{}: ligament read {w:.3} mm", r.name),
            (dentsim_cbct::phantom::Medium::Jaw, None) => panic!("{}: no ligament read", r.name),
            (_, read) => assert_eq!(read, None, "{}", r.name),
        }
        // The crown's cervical enamel by the alveolar crest is read through its dentin share
        // (left out beside bone, the jaw incisor's dentin under enamel thinner than 0.3 mm lay
        // 0.080 mm out: enamel 5.16°, dentin 5.01°; read, 2026-12-07: 4.50°, 4.67°).
        if case.name.contains("lower incisor in the jaw") {
            for t in r.tissues.iter().filter(|t| t.label != dentsim_cbct::Label::Pulp) {
                assert!(t.normal_deg <= 5.0, "{}: {} normals {:.2}°", r.name, t.label.name(), t.normal_deg);
            }
        }
        pulp_normals.extend(r.tissues.iter().filter(|t| t.label == dentsim_cbct::Label::Pulp).map(|t| t.normal_deg));
        for t in &r.tissues {
            // measured on these cases (2026-11-28): enamel ≤ 1.8 % (the tilted incisor in the
            // jaw; the canine in water's read 1.9 % while a lobe of its dentin was made enamel),
            // dentin ≤ 1.3 % (the tilted incisor; 2.9 % for the 3-root molar in air before the
            // scanner's blur was undone), pulp ≤ 5.1 % (the premolar in wax;
            // the 8-bit premolar's read 7.6 % while its thin roots' dentin shell fell back on the
            // calibration's crown dentin grey), surfaces ≤ 0.041 mm, normals ≤ 10.5°
            let volume = match t.label {
                dentsim_cbct::Label::Enamel => 0.025,
                dentsim_cbct::Label::Dentin => 0.02,
                _ => 0.065,
            };
            if t.volume_error.abs() > volume || t.surface_mm > 0.05 || t.normal_deg > 11.5 {
                failures.push(format!("{}: {} {:+.1}% {:.3} mm {:.1}°", r.name, t.label.name(), 100.0 * t.volume_error, t.surface_mm, t.normal_deg));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
    // The pulps fitted through the scan's blur (2026-11-29): mean normal error 8.53 → 8.03°
    // over these cases, their surfaces 0.024–0.040 → 0.015–0.034 mm.
    let mean = pulp_normals.iter().sum::<f64>() / pulp_normals.len() as f64;
    println!("pulp normals: mean {mean:.2}° over {} cases", pulp_normals.len());
    assert!(mean <= 8.3, "pulp normals {mean:.2}° on average");
}
