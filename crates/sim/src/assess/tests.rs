//! Analytic preparations on a block tooth: an enamel cap 1 mm thick over dentin over a pulp box,
//! cut with box cavities whose volumes and distances are known in closed form.
use dentsim_vdb::LevelSet;
use glam::DVec3;

use super::*;
use crate::tissues::table::TissueTable;

const H: f64 = 0.05;
/// The tooth: x, y in [−2, 2], z in [−3, 2]; dentin below z = 1 (and 0.5 in from the sides),
/// the pulp a box whose top lies at z = −1.
const TOP: f64 = 2.0;
const DENTIN_TOP: f64 = 1.0;
const PULP_TOP: f64 = -1.0;

fn box_sdf(p: DVec3, lo: DVec3, hi: DVec3) -> f64 {
    let c = (lo + hi) / 2.0;
    let q = (p - c).abs() - (hi - lo) / 2.0;
    q.max(DVec3::ZERO).length() + q.max_element().min(0.0)
}

fn grid(sdf: impl Fn(DVec3) -> f64) -> LevelSet {
    LevelSet::from_sdf(H, 3.0, DVec3::splat(-3.5), DVec3::splat(3.0), sdf).unwrap()
}

fn outer(p: DVec3) -> f64 {
    box_sdf(p, DVec3::new(-2.0, -2.0, -3.0), DVec3::new(2.0, 2.0, TOP))
}
fn dentin_box(p: DVec3) -> f64 {
    box_sdf(p, DVec3::new(-1.5, -1.5, -2.5), DVec3::new(1.5, 1.5, DENTIN_TOP))
}
fn pulp_box(p: DVec3) -> f64 {
    box_sdf(p, DVec3::new(-0.5, -0.5, -2.0), DVec3::new(0.5, 0.5, PULP_TOP))
}

/// The block tooth with a box cavity `half` mm wide each way about the axis, down to `floor`
/// (None: uncut).
fn tooth(cavity: Option<(f64, f64)>) -> TissueModel {
    let hole = |p: DVec3| cavity.map_or(f64::INFINITY, |(half, floor)| box_sdf(p, DVec3::new(-half, -half, floor), DVec3::new(half, half, TOP + 1.0)));
    let table = TissueTable::default();
    let mut m = TissueModel::new("block tooth", None);
    let cut = |d: f64, p: DVec3| d.max(-hole(p));
    m.push(table.get("enamel").unwrap().clone(), grid(|p| cut(outer(p).max(-dentin_box(p)), p))).unwrap();
    m.push(table.get("dentin").unwrap().clone(), grid(|p| cut(dentin_box(p).max(-pulp_box(p)), p))).unwrap();
    m.push(table.get("pulp").unwrap().clone(), grid(|p| cut(pulp_box(p), p))).unwrap();
    m
}

fn close(got: f64, want: f64, tol: f64, what: &str) {
    assert!((got - want).abs() <= tol, "{what}: {got} vs {want} (± {tol})");
}

#[test]
fn a_box_cavity_measures_its_volume_and_the_dentin_left_over_the_pulp() {
    let original = tooth(None);
    // 2 mm square, 1.5 mm deep: 1 mm of enamel, 0.5 mm into dentin; 1.5 mm of dentin left.
    let prepared = tooth(Some((1.0, 0.5)));
    let a = assess(&prepared, &original, None).unwrap();
    let removed: f64 = a.tissues.values().map(|t| t.removed_mm3).sum();
    close(removed, 2.0 * 2.0 * 1.5, 0.02 * 6.0, "removed volume");
    close(a.tissues["enamel"].removed_mm3, 4.0 * 1.0, 0.02 * 4.0, "enamel removed");
    close(a.tissues["dentin"].removed_mm3, 4.0 * 0.5, 0.02 * 2.0, "dentin removed");
    close(a.min_remaining_dentin_mm.unwrap(), 0.5 - PULP_TOP, 0.05, "remaining dentin");
    assert!(!a.pulp_exposed && a.pulp_exposed_area_mm2 == 0.0);
    assert!(a.cut_surface_points > 0);
    assert_eq!(a.grades[0].verdict, Verdict::Ideal);
    // The deepest cut point lies 1.5 mm below the original surface.
    let deepest = a.surface.cut_depth_mm.iter().fold(0f32, |m, d| m.max(*d));
    close(f64::from(deepest), 1.5, 0.05, "deepest cut");
}

#[test]
fn a_preparation_against_itself_has_no_over_or_undercut() {
    let original = tooth(None);
    let prepared = tooth(Some((1.0, 0.5)));
    let a = assess(&prepared, &original, Some(&prepared)).unwrap();
    for (name, t) in &a.tissues {
        assert!(t.overcut_mm3.unwrap() < 1e-3 && t.undercut_mm3.unwrap() < 1e-3, "{name}: {t:?}");
    }
    let d = a.deviation_mm.unwrap();
    assert!(d.max.abs() < 0.01 && d.min.abs() < 0.01, "{d:?}");
}

#[test]
fn an_overcut_box_measures_its_volume_and_depth() {
    let original = tooth(None);
    let reference = tooth(Some((1.0, 0.8)));
    let prepared = tooth(Some((1.0, 0.3)));
    let a = assess(&prepared, &original, Some(&reference)).unwrap();
    let over: f64 = a.tissues.values().map(|t| t.overcut_mm3.unwrap()).sum();
    let under: f64 = a.tissues.values().map(|t| t.undercut_mm3.unwrap()).sum();
    close(over, 2.0 * 2.0 * 0.5, 0.02 * 2.0, "overcut volume");
    assert!(under < 1e-3, "undercut {under}");
    let d = a.deviation_mm.unwrap();
    close(d.max, 0.5, 0.05, "deepest overcut");
    assert!(d.min > -0.05, "{d:?}");
    // Swapped, the same box is an undercut, and the deviation negative.
    let b = assess(&reference, &original, Some(&prepared)).unwrap();
    let under: f64 = b.tissues.values().map(|t| t.undercut_mm3.unwrap()).sum();
    close(under, 2.0, 0.04, "undercut volume");
    close(b.deviation_mm.unwrap().min, -0.5, 0.05, "undercut depth");
}

#[test]
fn a_cavity_into_the_pulp_exposes_it() {
    let original = tooth(None);
    // 0.6 mm square into the pulp: its floor (0.36 mm²) lies inside the pulp box.
    let prepared = tooth(Some((0.3, -1.4)));
    let a = assess(&prepared, &original, None).unwrap();
    assert!(a.pulp_exposed);
    assert_eq!(a.min_remaining_dentin_mm, Some(0.0));
    assert_eq!(a.grades[0].verdict, Verdict::OutOfRange);
    // Floor plus the walls below the pulp's top: 0.36 + 4 × 0.6 × 0.4 mm².
    close(a.pulp_exposed_area_mm2, 0.36 + 4.0 * 0.6 * 0.4, 0.25, "exposed area");
    assert!(a.tissues["pulp"].removed_mm3 > 0.1);
}

#[test]
fn models_of_other_voxel_sizes_are_refused_naming_the_model() {
    let original = tooth(None);
    let mut other = TissueModel::new("coarse", None);
    let table = TissueTable::default();
    other.push(table.get("enamel").unwrap().clone(), LevelSet::from_sdf(0.1, 3.0, DVec3::splat(-3.0), DVec3::splat(3.0), outer).unwrap()).unwrap();
    let err = assess(&original, &other, None).unwrap_err().to_string();
    assert!(err.contains("original model") && err.contains("voxel size"), "{err}");
}

/// A cylinder tooth (radius 3, z from −6 to 4) prepared for a crown: everything above the margin
/// plane z = −1 cut down to a frustum of the given half-angle standing on a 1 mm shoulder, its top 1.5 mm
/// below the original occlusal surface.
fn crown_models(half_angle_deg: f64) -> (TissueModel, TissueModel) {
    const R: f64 = 3.0;
    const MARGIN: f64 = -1.0;
    const TOP: f64 = 2.5;
    let r0 = R - 1.0;
    let r1 = r0 - (TOP - MARGIN) * half_angle_deg.to_radians().tan();
    let cylinder = |p: DVec3, r: f64, z0: f64, z1: f64| {
        let q = glam::DVec2::new(p.truncate().length() - r, (p.z - (z0 + z1) / 2.0).abs() - (z1 - z0) / 2.0);
        q.max(glam::DVec2::ZERO).length() + q.max_element().min(0.0)
    };
    // The kept region (below the margin plane, or inside the frustum) as an exact signed
    // distance, in the (radius, z) half-plane: outside it, the distance to the frustum or the
    // plane; inside, to the part of the boundary that borders the cut-away region (the plane
    // outside the frustum's base, the frustum's flank and top).
    let segment = |q: glam::DVec2, a: glam::DVec2, b: glam::DVec2| {
        let ab = b - a;
        (q - a - ab * ((q - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0)).length()
    };
    let keep = move |p: DVec3| {
        let q = glam::DVec2::new(p.truncate().length(), p.z);
        let (base, rim, axis_top) = (glam::DVec2::new(r0, MARGIN), glam::DVec2::new(r1, TOP), glam::DVec2::new(0.0, TOP));
        let flank = segment(q, base, rim).min(segment(q, rim, axis_top));
        // Inside the frustum: left of the flank, below the top, above the base.
        let inside_frustum = q.y >= MARGIN && q.y <= TOP && (rim - base).perp_dot(q - base) >= 0.0;
        let plane = segment(q, base, glam::DVec2::new(1e3, MARGIN));
        if q.y < MARGIN {
            -plane
        } else if inside_frustum {
            -flank
        } else {
            flank.min(plane)
        }
    };
    let build = |prepared: bool| {
        let g = |f: &dyn Fn(DVec3) -> f64| LevelSet::from_sdf(H, 3.0, DVec3::new(-3.5, -3.5, -6.5), DVec3::new(3.5, 3.5, 4.5), |p| if prepared { f(p).max(keep(p)) } else { f(p) }).unwrap();
        let table = TissueTable::default();
        let mut m = TissueModel::new("cylinder tooth", None);
        m.push(table.get("enamel").unwrap().clone(), g(&|p| cylinder(p, R, -6.0, 4.0).max(-cylinder(p, 2.2, -5.6, 3.0)))).unwrap();
        m.push(table.get("dentin").unwrap().clone(), g(&|p| cylinder(p, 2.2, -5.6, 3.0).max(-cylinder(p, 0.8, -5.0, 0.0)))).unwrap();
        m.push(table.get("pulp").unwrap().clone(), g(&|p| cylinder(p, 0.8, -5.0, 0.0))).unwrap();
        m
    };
    (build(true), build(false))
}

#[test]
fn a_crown_preparation_measures_its_taper_reductions_and_margin() {
    let (prepared, original) = crown_models(6.0);
    for axis in [Some(DVec3::Z), None] {
        let a = assess_as(&prepared, &original, None, Kind::Crown { axis }).unwrap();
        let c = a.crown.clone().unwrap_or_else(|| panic!("no crown figures with axis {axis:?}"));
        assert!(DVec3::from_array(c.axis).dot(DVec3::Z) > 0.999, "{c:?}");
        close(c.taper_deg, 12.0, 0.5, "total occlusal convergence");
        close(c.occlusal_reduction_mm, 1.5, 0.05, "occlusal reduction");
        let tan = 6f64.to_radians().tan();
        close(c.axial_reduction_mean_mm, 1.0 + tan * 3.5 / 2.0, 0.05, "mean axial reduction");
        close(c.axial_reduction_min_mm, 1.0, 0.05, "least axial reduction");
        close(c.margin_width_mm, 1.0, 0.05, "margin width");
        close(c.height_mm, 3.5, 0.05, "height");
        close(c.width_mm, 4.0, 0.1, "width at the margin");
        assert!(!c.undercut, "{c:?}");
        let taper = a.grades.iter().find(|g| g.criterion == "total occlusal convergence").unwrap();
        assert_eq!(taper.verdict, Verdict::Ideal);
        assert!(!a.pulp_exposed, "{:?} {}", a.tissues, a.pulp_exposed_area_mm2);
    }
}

#[test]
fn walls_that_flare_toward_the_occlusal_end_are_an_undercut() {
    let (prepared, original) = crown_models(-4.0);
    let c = assess_as(&prepared, &original, None, Kind::Crown { axis: Some(DVec3::Z) }).unwrap().crown.unwrap();
    assert!(c.undercut && c.undercut_area_mm2 > 10.0, "{c:?}");
    close(c.taper_deg, -8.0, 0.5, "total occlusal convergence");
}

#[test]
fn an_assessment_reports_its_progress_and_stops_when_asked() {
    let original = tooth(None);
    let prepared = tooth(Some((1.0, 0.5)));
    let mut seen = Vec::new();
    let a = assess_until(&prepared, &original, Some(&prepared), Kind::Cavity, &mut |f| {
        seen.push(f);
        true
    })
    .unwrap();
    assert!(seen.windows(2).all(|w| w[0] < w[1]) && seen.len() >= 5 && seen[0] == 0.0 && seen.last() == Some(&1.0), "progress grows step by step to 1: {seen:?}");
    let whole = assess_as(&prepared, &original, Some(&prepared), Kind::Cavity).unwrap();
    assert_eq!(serde_json::to_string(&a).unwrap(), serde_json::to_string(&whole).unwrap(), "watching changes nothing");

    // Stopped at each step before the end in turn: an error saying so, and no step after it.
    for stop_at in seen.iter().copied().filter(|f| *f < 1.0) {
        let mut after = Vec::new();
        let err = assess_until(&prepared, &original, Some(&prepared), Kind::Cavity, &mut |f| {
            after.push(f);
            f < stop_at
        })
        .err()
        .unwrap_or_else(|| panic!("stopped at {stop_at}"));
        assert!(err.to_string().contains(crate::error::STOPPED), "{err}");
        assert_eq!(after.last(), Some(&stop_at), "nothing after the stop: {after:?}");
    }
}
