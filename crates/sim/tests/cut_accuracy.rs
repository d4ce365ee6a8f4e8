//! Removed volume against closed forms at 0.05 mm voxels, for ball, cylinder and taper strokes
//! (straight, curved, rotating), cut wholly inside one smooth block of tissue.
use std::f64::consts::{FRAC_PI_2, PI};

use dentsim_sim::burr::{Burr, Shape};
use dentsim_sim::cutting::cutter::Cutter;
use dentsim_sim::tissues::model::TissueModel;
use dentsim_sim::tissues::table::TissueTable;
use dentsim_vdb::LevelSet;
use glam::{DAffine3, DQuat, DVec3};

const VOXEL: f64 = 0.05;
const BLOCK_RADIUS: f64 = 4.0;

/// One tissue: a ball of dentin of radius 4 mm about the origin.
fn block() -> TissueModel {
    let r = BLOCK_RADIUS;
    let grid = LevelSet::from_sdf(VOXEL, 3.0, DVec3::splat(-r), DVec3::splat(r), |p| p.length() - r).unwrap();
    let mut model = TissueModel::new("test block", None);
    model.push(TissueTable::default().get("dentin").unwrap().clone(), grid).unwrap();
    model
}

/// Cuts through `poses` one segment at a time; returns (reported removed, volume drop).
fn cut_path(burr: &Burr, poses: &[DAffine3]) -> (f64, f64) {
    let mut model = block();
    let before = model.tissues[0].grid.volume();
    let mut cutter = Cutter::default();
    let mut reported = 0.0;
    for w in poses.windows(2) {
        reported += cutter.cut(&mut model, burr, w[0], w[1]).unwrap().removed("dentin");
    }
    (reported, before - model.tissues[0].grid.volume())
}

fn check(name: &str, burr: &Burr, poses: &[DAffine3], exact: f64) {
    let (reported, drop) = cut_path(burr, poses);
    let err = reported / exact - 1.0;
    println!("{name:<28} exact {exact:8.4} mm³  removed {reported:8.4}  error {:+.3} %", err * 100.0);
    assert!(err.abs() < 0.01, "{name}: {reported} vs {exact}");
    assert!((drop - reported).abs() < 1e-6 * drop.max(1.0), "{name}: bookkeeping {drop} vs {reported}");
}

fn at(p: DVec3) -> DAffine3 {
    DAffine3::from_translation(p)
}

/// Poses along a circular arc in the XY plane about (0, 0, z): radius `rp`, angle `phi`.
fn arc(rp: f64, phi: f64, z: f64, n: usize) -> Vec<DAffine3> {
    (0..=n)
        .map(|i| {
            let a = phi * i as f64 / n as f64 - phi / 2.0;
            at(DVec3::new(rp * a.cos() - rp, rp * a.sin(), z))
        })
        .collect()
}

fn frustum(r0: f64, r1: f64, l: f64) -> f64 {
    PI * l / 3.0 * (r0 * r0 + r0 * r1 + r1 * r1)
}

fn taper_radii(b: &Burr) -> (f64, f64) {
    let p = b.head_profile();
    (p.pieces[0].end().x, b.diameter_mm / 2.0)
}

#[test]
fn ball_straight() {
    let b = Burr::round(1.0).unwrap();
    let (r, l) = (0.5, 2.0);
    check("ball straight", &b, &[at(DVec3::new(-1.0, 0.0, -0.5)), at(DVec3::new(1.0, 0.0, -0.5))], PI * r * r * l + 4.0 / 3.0 * PI * r.powi(3));
}

#[test]
fn ball_curved() {
    let b = Burr::round(1.0).unwrap();
    let (r, rp, phi) = (0.5, 1.5, FRAC_PI_2);
    check("ball curved (arc, 60 poses)", &b, &arc(rp, phi, -0.5, 60), PI * r * r * rp * phi + 4.0 / 3.0 * PI * r.powi(3));
}

#[test]
fn ball_rotating_about_its_tip() {
    // The ball's centre circles the tip at radius r: a horn-torus quarter plus the two end balls.
    let b = Burr::round(1.0).unwrap();
    let r = 0.5;
    let from = at(DVec3::new(0.0, 0.0, -0.5));
    let to = DAffine3::from_rotation_translation(DQuat::from_rotation_x(FRAC_PI_2), DVec3::new(0.0, 0.0, -0.5));
    check("ball rotating 90° (1 stroke)", &b, &[from, to], PI * r * r * r * FRAC_PI_2 + 4.0 / 3.0 * PI * r.powi(3));
}

#[test]
fn cylinder_straight_sideways() {
    let b = Burr::new(Shape::CylinderFlat, 1.0, Some(2.0)).unwrap();
    let (r, l, d) = (0.5, 2.0, 1.5);
    check("cylinder straight", &b, &[at(DVec3::new(-0.75, 0.0, -1.0)), at(DVec3::new(0.75, 0.0, -1.0))], PI * r * r * l + 2.0 * r * d * l);
}

#[test]
fn cylinder_curved() {
    let b = Burr::new(Shape::CylinderFlat, 1.0, Some(2.0)).unwrap();
    let (r, l, rp, phi) = (0.5, 2.0, 1.5, FRAC_PI_2);
    check("cylinder curved (arc)", &b, &arc(rp, phi, -1.0, 60), (2.0 * r * rp * phi + PI * r * r) * l);
}

#[test]
fn cylinder_spinning_while_plunging() {
    // Rotation about its own axis adds nothing: a longer cylinder.
    let b = Burr::new(Shape::CylinderFlat, 1.0, Some(2.0)).unwrap();
    let (r, l, d) = (0.5, 2.0, 1.0);
    let from = at(DVec3::new(0.0, 0.0, -1.0));
    let to = DAffine3::from_rotation_translation(DQuat::from_rotation_z(1.2), DVec3::new(0.0, 0.0, -1.0 - d));
    check("cylinder spin + plunge", &b, &[from, to], PI * r * r * (l + d));
}

#[test]
fn taper_straight_sideways() {
    let b = Burr::new(Shape::TaperFlat, 1.2, Some(3.0)).unwrap();
    let (r0, r1) = taper_radii(&b);
    let (l, d) = (3.0, 1.0);
    check("taper straight", &b, &[at(DVec3::new(-0.5, 0.0, -1.5)), at(DVec3::new(0.5, 0.0, -1.5))], frustum(r0, r1, l) + d * l * (r0 + r1));
}

#[test]
fn taper_plunging() {
    let b = Burr::new(Shape::TaperFlat, 1.2, Some(3.0)).unwrap();
    let (r0, r1) = taper_radii(&b);
    let (l, d) = (3.0, 0.8);
    check("taper plunge", &b, &[at(DVec3::new(0.0, 0.0, -1.8)), at(DVec3::new(0.0, 0.0, -1.8 + d))], frustum(r0, r1, l) + PI * r1 * r1 * d);
}

#[test]
fn taper_curved() {
    let b = Burr::new(Shape::TaperFlat, 1.2, Some(3.0)).unwrap();
    let (r0, r1) = taper_radii(&b);
    let (l, rp, phi) = (3.0, 1.5, FRAC_PI_2);
    check("taper curved (arc)", &b, &arc(rp, phi, -1.5, 60), rp * phi * l * (r0 + r1) + frustum(r0, r1, l));
}
