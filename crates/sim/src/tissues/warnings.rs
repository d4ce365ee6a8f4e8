//! What a segmentation could not read and says so (`ScanReport::warnings`): a pulp missing or
//! implausibly small, one whose canals end short of the root's apex, one whose surface could not
//! follow the scan's grey, enamel and dentin beside a restoration the scanner clipped or whose
//! metal hardened its beam. Each
//! result is kept and never silent: the warning says what was found and what to try.
use dentsim_cbct::volume::face_neighbours;
use dentsim_cbct::bloom::Cupping;
use dentsim_cbct::{Calibration, Label, PartialVolume, Volume};
use glam::DVec3;

/// A tooth's pulp below this share of the tooth (enamel, dentin and pulp) is implausibly small:
/// a pulp is 2–5 % of a tooth (an old tooth's, narrowed by secondary dentin, ~1 %), so less is
/// more likely a pulp cavity the segmentation lost (opened to the outside at a thin apex, or
/// its canals read as dentin) than anatomy.
pub const MIN_PULP_SHARE: f64 = 0.004;

/// A warning when the tooth (`tooth` mm³ of enamel, dentin and pulp) has no pulp or an
/// implausibly small one ([`MIN_PULP_SHARE`]), saying what to try: the result is kept (a tooth
/// may have lost its pulp to calcification), never silently.
pub fn pulp_warning(pulp: f64, tooth: f64, calibration: &Calibration) -> Option<String> {
    if tooth <= 0.0 || pulp >= MIN_PULP_SHARE * tooth {
        return None;
    }
    let found = if pulp <= 0.0 { "no pulp was found".to_string() } else { format!("the pulp is {pulp:.2} mm³, {:.2} % of the tooth (a pulp is 2–5 %)", 100.0 * pulp / tooth) };
    Some(format!(
        "{found}: the pulp cavity may have been lost (opened to the outside at a thin apex, or its canals read as dentin). \
         Check the grey values (calibration: dentin {:.1}, enamel {:.1}, tooth/outside threshold {:.1}) and try --thresholds \
         with the grey of the medium around the tooth, the dentin and the enamel (e.g. --thresholds air={:.1},dentin={:.1},enamel={:.1})",
        calibration.peak(Label::Dentin),
        calibration.peak(Label::Enamel),
        calibration.hard_cut(),
        calibration.peak(Label::Air),
        calibration.peak(Label::Dentin),
        calibration.peak(Label::Enamel),
    ))
}

/// Where the pulp's surface and its partial-volume measure still differ by more than this share
/// after the fit, the surface could not follow the scan (on the family they differ by ≤ 0.4 %).
pub const MAX_PULP_FIT_GAP: f64 = 0.03;

/// A warning when the pulp's surface could not be moved to its partial-volume measure (the fit
/// stops at half a voxel): canals or horns about a voxel wide, which the scan's grey shows but a
/// smooth surface at its resolution cannot hold. Which volume is right is then unknown, and the
/// user is told so rather than given either one silently. `pulp`: the surface's volume (mm³)
/// after the fit moved it `offset_mm`. `per_voxel`: where the surface was fitted through the
/// scan's blur, what the surface read voxel by voxel could enclose (`SegmentedTissue::per_voxel_mm3`):
/// the fit can reach the measure where that could not, but then the volume rests on the fit and
/// the pulp's grey (a nibabel incisor at 0.4 mm in a jaw: −24 % read voxel by voxel, −11.7 %
/// fitted on a pulp's grey bounded at 171 where it is 300, −5.7 % on the 271 its voxels 2 deep
/// read), so the warning stands.
pub fn pulp_fit_warning(pulp: f64, measure: &PartialVolume, offset_mm: f64, per_voxel: Option<f64>, calibration: &Calibration, scan_voxel_mm: f64) -> Option<String> {
    let apart = |v: f64| (v / measure.volume_mm3 - 1.0).abs() > MAX_PULP_FIT_GAP;
    if measure.volume_mm3 <= 0.0 || !(apart(pulp) || per_voxel.is_some_and(apart)) {
        return None;
    }
    let suggestion = |pulp: &str| {
        format!(
            "--thresholds beside the others (e.g. --thresholds air={:.1},pulp={pulp},dentin={:.1},enamel={:.1})",
            calibration.peak(Label::Air),
            calibration.peak(Label::Dentin),
            calibration.peak(Label::Enamel),
        )
    };
    let grey = if measure.tissue_grey_measured && per_voxel.is_some() {
        format!("the pulp's grey {:.1} measured in its deepest voxels, on which the fit rests: where it is known, give it to {}", measure.tissue_grey, suggestion("GREY"))
    } else if measure.tissue_grey_measured {
        format!("the pulp's grey {:.1} measured in its deepest voxels", measure.tissue_grey)
    } else if calibration.shows(Label::Pulp) {
        format!("the pulp's grey {:.1} as given", measure.tissue_grey)
    } else {
        format!(
            "the pulp's grey {:.1} predicted by the calibration's line, since no pulp voxel lies deep enough to show it; \
             where it is known, give it to {}",
            measure.tissue_grey,
            suggestion("GREY"),
        )
    };
    let (encloses, moved) = match per_voxel {
        Some(read) => (format!("encloses {read:.2} mm³ read voxel by voxel and {pulp:.2} mm³ fitted through the scan's blur"), String::new()),
        None => (format!("encloses {pulp:.2} mm³"), format!("; the surface was moved {offset_mm:+.3} mm, the most it may")),
    };
    Some(format!(
        "the pulp's surface {encloses} where the scan's grey measures {:.2} mm³ ({grey}{moved}): the pulp has canals or horns \
         about a voxel wide that a {scan_voxel_mm:.2} mm scan does not resolve, so its volume is uncertain. A scan with voxels \
         about a third of the canals' width resolves them",
        measure.volume_mm3,
    ))
}

/// How far (mm) from a clipped restoration the enamel and dentin are in doubt: a dental CBCT's
/// blur (σ 0.15–0.25 mm) leaves a metal's bloom over 0.5 % of its lift within 2.5 σ.
pub const SATURATED_METAL_REACH_MM: f64 = 0.5;

/// How [`saturated_metal_warning`]'s text starts (the plugin puts it on the enamel's surface).
pub const SATURATED_METAL: &str = "a metal restoration saturates the scan";

/// A warning when a restoration the scanner clipped (`voxels` at its maximum `grey`: with its
/// grey `estimated`, the metal within its end as read, raised to the ceiling) lies within
/// [`SATURATED_METAL_REACH_MM`] of `near_mm3` of the tooth's enamel and dentin (of `tooth_mm3`;
/// measured from the metal's grey, whose bloom lies beyond its labels). Its own grey, its end
/// and its bloom's reach were either read from the bloom's tail below the ceiling (`estimated`,
/// the metal's grey so read: less certain than an unclipped metal's, it reads low the more the
/// scan clips) or not at all, so that much of the tooth may be read as the wrong tissue (the
/// foreign sweep's clipped fillings unread: enamel +7…+8 %, dentin −5…−6.5 %).
pub fn saturated_metal_warning(grey: f64, voxels: usize, near_mm3: f64, tooth_mm3: f64, estimated: Option<f64>) -> Option<String> {
    (near_mm3 > 0.0 && tooth_mm3 > 0.0).then(|| {
        let read = match estimated {
            Some(metal) => format!(
                "at its maximum grey {grey:.0}, so the metal's own grey (about {metal:.0}) and its end ({voxels} voxels) were read from the bloom's tail below that ceiling, less surely than in a core"
            ),
            None => format!("({voxels} voxels at its maximum grey {grey:.0}), so the metal's own grey and its blur's reach cannot be measured"),
        };
        format!(
            "{SATURATED_METAL} {read}: \
             {near_mm3:.1} mm³ of enamel and dentin ({:.1} % of the tooth's) lie within {SATURATED_METAL_REACH_MM} mm of it, where the blur may have \
             made dentin enamel or tooth metal, and their volumes are uncertain by up to that much. A scan that does not clip the metal \
             (a wider grey range) lets its bloom be measured in its core and taken off",
            100.0 * near_mm3 / tooth_mm3
        )
    })
}

/// How [`hardened_metal_warning`]'s text starts (the plugin puts it on the enamel's surface, as a
/// clipped restoration's).
pub const HARDENED_METAL: &str = "a metal restoration hardens the scanner's beam";

/// The least cupping ([`Cupping::share`]) that says a restoration hardens the beam. Fillings
/// made without hardening read 0.1–1 % (their middle is their brightest part, less the noise);
/// with `foreign_tooth.py`'s STREAKS (each ray's attenuation read short by that times its
/// square) a 12000 HU one at 0.2 / 0.5 read 3.4 / 22–23 %, a 30000 HU one at 0.2 8 %. The
/// 12000 HU one at 0.5 cost its incisor 4 % more of its enamel beside it (−8.4 % in all), the
/// 30000 HU one at 0.2 its molar 2 % of its dentin.
pub const HARDENED_SHARE: f64 = 0.05;

/// A warning when the largest unclipped restoration reads darker in its middle than at its
/// brightest by [`HARDENED_SHARE`] or more of its lift over the enamel: the beam hardened through
/// it, and its streaks cross the tissue within the bloom's reach, `near_mm3` of enamel and dentin
/// (of `tooth_mm3`), whose volumes are uncertain by up to that much.
pub fn hardened_metal_warning(cupping: &Cupping, enamel: f64, reach_mm: f64, near_mm3: f64, tooth_mm3: f64) -> Option<String> {
    (cupping.share(enamel) >= HARDENED_SHARE && near_mm3 > 0.0 && tooth_mm3 > 0.0).then(|| {
        format!(
            "{HARDENED_METAL}: it reads {:.0} in its middle against {:.0} at its brightest, and its streaks cross the tissue about it: \
             {near_mm3:.1} mm³ of enamel and dentin ({:.1} % of the tooth's) lie within {reach_mm:.2} mm of it, where their volumes are \
             uncertain by up to that much. A scan reconstructed with the scanner's metal artifact reduction reads them more surely",
            cupping.middle,
            cupping.brightest,
            100.0 * near_mm3 / tooth_mm3
        )
    })
}

/// How [`shading_warning`]'s text starts (the plugin puts it on the dentin's surface: it
/// concerns the whole tooth).
pub const SHADING: &str = "the scan's grey values drift by";

/// What was done with a shading found over the tooth.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Unshading {
    TakenOff,
    /// The user asked for the scan's grey values as they are.
    KeptAsAsked,
    /// The box with the field taken off held no tooth to read.
    KeptUnreadable,
}

/// Said where the scan's shading ([`dentsim_cbct::Shading`], `span` grey values over the tooth
/// against its enamel–dentin `contrast`) was found: taken off, its tissues rest on a smooth
/// field fitted to their grey values, which a scan with flat grey values (a CT's HU) would not
/// need; left on, one set of thresholds is read across grey values that drift by it.
pub fn shading_warning(span: f64, contrast: f64, done: Unshading) -> String {
    let what = match done {
        Unshading::TakenOff => "a smooth field fitted to the tissues' grey values was taken off and the tooth's box calibrated again before it was read",
        Unshading::KeptAsAsked => "it was left on as asked, so the tissues' borders move with it where it runs far from the tooth's middle",
        Unshading::KeptUnreadable => "it was left on, for the box with a field fitted to it taken off held no tooth to read: the tissues' borders move with it",
    };
    format!("{SHADING} {span:.0} over the tooth ({:.0} % of its enamel–dentin contrast: a cone-beam scanner's shading); {what}", 100.0 * span / contrast)
}

/// A canal normally runs to within 1–2 mm of its root's apex; a pulp ending farther short than
/// this share of the dentin's length (apex to crown) has lost its canals: a pulp ending at the
/// crown's base, not an apex narrowed by age (the family: 10–20 %; its canals lost: 55–65 %).
pub const MAX_CANAL_SHORTFALL: f64 = 0.33;

/// A warning when the pulp ends `short_mm` short of the root's apex, more than
/// [`MAX_CANAL_SHORTFALL`] of the dentin's `length_mm`: its canals were not found.
pub fn canal_warning(short_mm: f64, length_mm: f64, scan_voxel_mm: f64) -> Option<String> {
    if !(short_mm > MAX_CANAL_SHORTFALL * length_mm) {
        return None;
    }
    Some(format!(
        "the pulp ends {short_mm:.1} mm short of the root's apex, on a dentin {length_mm:.1} mm long from apex to crown (a canal runs to within 1–2 mm of the apex): \
         the root canals were not found, as canals about two voxels wide (at {scan_voxel_mm:.2} mm, {:.1} mm) often are not, \
         so the pulp's volume leaves them out. Check the canals in the scan; a scan with voxels about a third of their width resolves them",
        2.0 * scan_voxel_mm
    ))
}

/// Where along the tooth's long axis its pulp ends against its root: (mm from the pulp's
/// deepest voxel to the root's apex, the dentin's length in mm from the apex to the crown's
/// dentin–enamel junction). The axis is the dentin and pulp's principal one, its crown end the
/// junction's side; `None` without pulp, dentin or enamel.
pub(crate) fn canal_shortfall(scan: &Volume, labels: &dentsim_cbct::LabelVolume) -> Option<(f64, f64)> {
    let (d, p, e) = (Label::Dentin as u8, Label::Pulp as u8, Label::Enamel as u8);
    let [nx, ny, nz] = scan.dims;
    let at = |n: usize| DVec3::from(scan.voxel_center(n % nx, (n / nx) % ny, n / (nx * ny)));
    let body: Vec<usize> = (0..labels.labels.len()).filter(|&n| labels.labels[n] == d || labels.labels[n] == p).collect();
    // The junction: enamel voxels with a dentin face neighbour (enamel alone may be a neighbour's).
    let junction: Vec<usize> = (0..labels.labels.len())
        .filter(|&n| labels.labels[n] == e && face_neighbours(n, [nx, ny, nz]).into_iter().flatten().any(|m| labels.labels[m] == d))
        .collect();
    if body.is_empty() || junction.is_empty() || !labels.labels.contains(&p) {
        return None;
    }
    let centre = body.iter().map(|&n| at(n)).sum::<DVec3>() / body.len() as f64;
    let mut spread = glam::DMat3::ZERO;
    for &n in &body {
        let r = at(n) - centre;
        spread += glam::DMat3::from_cols(r * r.x, r * r.y, r * r.z);
    }
    // The principal axis by power iteration (the long axis dominates a tooth's spread).
    let mut axis = DVec3::new(0.3, 0.5, 0.8);
    for _ in 0..64 {
        axis = (spread * axis).normalize_or_zero();
    }
    if axis == DVec3::ZERO {
        return None;
    }
    let crown = junction.iter().map(|&n| at(n)).sum::<DVec3>() / junction.len() as f64;
    if (crown - centre).dot(axis) < 0.0 {
        axis = -axis;
    }
    let along = |n: usize| (at(n) - centre).dot(axis);
    let (lo, hi) = body.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &n| (lo.min(along(n)), hi.max(along(n))));
    let top = junction.iter().map(|&n| along(n)).fold(hi, f64::max);
    let pulp_end = body.iter().filter(|&&n| labels.labels[n] == p).map(|&n| along(n)).fold(f64::INFINITY, f64::min);
    Some((pulp_end - lo, top - lo))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn enamel_and_dentin_beside_a_clipped_restoration_are_never_silent() {
        let w = saturated_metal_warning(32767.0, 412, 18.4, 640.0, None).expect("warned");
        assert!(w.starts_with(SATURATED_METAL) && w.contains("32767") && w.contains("18.4 mm³") && w.contains("2.9 %"), "{w}");
        assert!(w.contains("cannot be measured"), "{w}");
        // With the metal's grey read from its bloom's tail, the warning says so and its figure.
        let w = saturated_metal_warning(32767.0, 412, 18.4, 640.0, Some(41250.4)).expect("warned");
        assert!(w.starts_with(SATURATED_METAL) && w.contains("about 41250") && w.contains("tail") && w.contains("18.4 mm³"), "{w}");
        assert_eq!(saturated_metal_warning(32767.0, 412, 0.0, 640.0, None), None, "no tooth near the metal, nothing to say");
    }

    #[test]
    fn a_metal_darker_in_its_middle_is_said_to_harden_the_beam() {
        let hardened = Cupping { brightest: 7505.0, middle: 6565.0 };
        let w = hardened_metal_warning(&hardened, 2886.0, 0.82, 21.3, 480.0).expect("warned");
        assert!(w.starts_with(HARDENED_METAL) && w.contains("6565") && w.contains("7505") && w.contains("21.3 mm³") && w.contains("0.82 mm"), "{w}");
        let flat = Cupping { brightest: 12090.0, middle: 12000.0 };
        assert_eq!(hardened_metal_warning(&flat, 2886.0, 0.82, 21.3, 480.0), None, "an unhardened metal's middle is its brightest");
        assert_eq!(hardened_metal_warning(&hardened, 2886.0, 0.82, 0.0, 480.0), None, "no tooth near the metal, nothing to say");
    }

    /// A tooth without a pulp, or with a speck of one, is reported with what to try; a tooth
    /// with a pulp of a tooth's share is not.
    #[test]
    fn a_tooth_without_a_pulp_is_never_silent() {
        let cal = Calibration::manual(&[(Label::Air, 0.0), (Label::Dentin, 2000.0), (Label::Enamel, 3000.0)]).unwrap();
        let none = pulp_warning(0.0, 700.0, &cal).expect("no pulp: a warning");
        assert!(none.starts_with("no pulp was found") && none.contains("--thresholds air=") && none.contains("dentin=2000.0"), "{none}");
        let speck = pulp_warning(1.0, 701.0, &cal).expect("a speck of pulp: a warning");
        assert!(speck.contains("the pulp is 1.00 mm³") && speck.contains("--thresholds"), "{speck}");
        assert_eq!(pulp_warning(20.0, 720.0, &cal), None);
        assert_eq!(pulp_warning(0.0, 0.0, &cal), None);
    }

    #[test]
    fn a_pulp_its_surface_cannot_follow_is_never_silent() {
        let cal = Calibration::manual(&[(Label::Air, -1000.0), (Label::Dentin, 1800.0), (Label::Enamel, 2900.0)]).unwrap();
        let measure = |volume_mm3: f64, measured: bool| PartialVolume { volume_mm3, tissue_grey: 136.0, surround_grey: 1784.0, tissue_grey_measured: measured, voxels: 1473, near_pure: Vec::new() };
        let lost = pulp_fit_warning(12.2, &measure(14.53, false), 0.2, None, &cal, 0.4).expect("16 % apart: a warning");
        assert!(lost.contains("encloses 12.20 mm³") && lost.contains("measures 14.53 mm³") && lost.contains("0.40 mm scan") && lost.contains("+0.200 mm"), "{lost}");
        assert!(lost.contains("predicted") && lost.contains("--thresholds air=-1000.0,pulp=GREY,dentin=1800.0,enamel=2900.0"), "{lost}");
        let measured = pulp_fit_warning(12.2, &measure(14.53, true), 0.2, None, &cal, 0.4).expect("a warning");
        assert!(measured.contains("measured in its deepest voxels") && !measured.contains("--thresholds"), "{measured}");
        let given = Calibration::manual(&[(Label::Air, -1000.0), (Label::Pulp, 300.0), (Label::Dentin, 1800.0), (Label::Enamel, 2900.0)]).unwrap();
        let as_given = pulp_fit_warning(12.2, &measure(14.53, false), 0.2, None, &given, 0.4).expect("a warning");
        assert!(as_given.contains("as given") && !as_given.contains("--thresholds"), "{as_given}");
        // Within the fit's reach: nothing to say.
        assert_eq!(pulp_fit_warning(14.2, &measure(14.53, false), 0.1, None, &cal, 0.4), None);
        // Fitted through the blur to the measure, where the surface read voxel by voxel could
        // not reach it: the volume rests on the fit and the pulp's grey, and that is said.
        let fitted = pulp_fit_warning(14.4, &measure(14.53, true), 0.05, Some(12.2), &cal, 0.4).expect("the voxels' surface 16 % apart: a warning");
        assert!(fitted.contains("encloses 12.20 mm³ read voxel by voxel and 14.40 mm³ fitted through the scan's blur") && fitted.contains("0.40 mm scan"), "{fitted}");
        assert!(fitted.contains("measured in its deepest voxels, on which the fit rests") && fitted.contains("--thresholds air=-1000.0,pulp=GREY,dentin=1800.0,enamel=2900.0"), "{fitted}");
        assert_eq!(pulp_fit_warning(14.4, &measure(14.53, true), 0.05, Some(14.3), &cal, 0.4), None, "the voxels' surface within reach");
    }

    /// A tooth lying along a tilted axis (crown toward +x+y): dentin a bar, enamel capping its
    /// crown end, the pulp a chamber under it with or without its canal.
    fn tilted_tooth(canal: bool) -> (Volume, dentsim_cbct::LabelVolume) {
        let dims = [40usize, 40, 12];
        let (c, s) = (std::f64::consts::FRAC_1_SQRT_2, std::f64::consts::FRAC_1_SQRT_2);
        let direction = [[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]];
        let scan = Volume { dims, spacing: [0.25, 0.25, 0.4], origin: [10.0, -5.0, 3.0], direction, values: vec![0.0; dims.iter().product()], source: Default::default() };
        let mut labels = scan.label_volume();
        for n in 0..labels.labels.len() {
            let (i, j, k) = (n % dims[0], (n / dims[0]) % dims[1], n / (dims[0] * dims[1]));
            let (across, deep) = ((j as f64 - 20.0).hypot((k as f64 - 6.0) * 1.6), i as f64);
            labels.labels[n] = if (2.0..=34.0).contains(&deep) && across <= 5.0 {
                if deep >= 31.0 {
                    Label::Enamel
                } else if across <= 1.2 && (deep >= 24.0 || (canal && deep >= 4.0)) {
                    Label::Pulp
                } else {
                    Label::Dentin
                }
            } else {
                Label::Air
            } as u8;
        }
        (scan, labels)
    }

    #[test]
    fn a_pulp_ending_at_the_crowns_base_is_said() {
        // Along the tooth's tilted axis (index x, 0.25 mm): apex at 2, pulp from 24 (or 4), the
        // dentin–enamel junction at 31.
        let (scan, without) = tilted_tooth(false);
        let (short, length) = canal_shortfall(&scan, &without).expect("a tooth with a pulp");
        assert!((short - 22.0 * 0.25).abs() < 0.01 && (length - 29.0 * 0.25).abs() < 0.01, "short {short} of {length} mm");
        let said = canal_warning(short, length, 0.25).expect("canals lost: a warning");
        assert!(said.contains("5.5 mm short of the root's apex") && (said.contains("dentin 7.2 mm long") || said.contains("dentin 7.3 mm long")), "{said}");
        let (_, with) = tilted_tooth(true);
        let (short, length) = canal_shortfall(&scan, &with).unwrap();
        assert!((short - 0.5).abs() < 0.01, "short {short} of {length} mm");
        assert_eq!(canal_warning(short, length, 0.25), None);
        let mut no_pulp = with;
        no_pulp.labels.iter_mut().filter(|l| **l == Label::Pulp as u8).for_each(|l| *l = Label::Dentin as u8);
        assert_eq!(canal_shortfall(&scan, &no_pulp), None);
    }
}
