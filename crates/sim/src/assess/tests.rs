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
