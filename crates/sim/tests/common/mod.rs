//! Helpers shared by the haptics and cutting tests: one-tissue models from analytic SDFs, a device
//! driver, mesh comparison.
#![allow(dead_code)]
use dentsim_devices::DeviceState;
use dentsim_sim::haptics::tick::{HapticCore, TickOutput};
use dentsim_sim::tissues::model::TissueModel;
use dentsim_sim::tissues::table::TissueTable;
use dentsim_vdb::{LevelSet, TriMesh};
use dentsim_sim::burr::{Burr, Shape};
use glam::{DAffine3, DQuat, DVec3, IVec3};

pub const VOXEL: f64 = 0.05;

/// Uniform numbers in [0, 1) from a fixed seed (xorshift64): random cases, the same every run.
pub fn unit_random(mut seed: u64) -> impl FnMut() -> f64 {
    move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Exact signed distance of an axis-aligned box.
pub fn box_sdf(p: DVec3, lo: DVec3, hi: DVec3) -> f64 {
    let c = (lo + hi) / 2.0;
    let h = (hi - lo) / 2.0;
    let q = (p - c).abs() - h;
    q.max(DVec3::ZERO).length() + q.max_element().min(0.0)
}

/// A model with one tissue (props from the default table) filling `lo..hi`.
pub fn box_model(tissue: &str, lo: DVec3, hi: DVec3) -> TissueModel {
    let table = TissueTable::default();
    let grid = LevelSet::from_sdf(VOXEL, 3.0, lo, hi, |p| box_sdf(p, lo, hi)).unwrap();
    let mut m = TissueModel::new("test box", None);
    m.push(table.get(tissue).unwrap().clone(), grid).unwrap();
    m
}

pub fn sphere_model(tissue: &str, radius: f64) -> TissueModel {
    let table = TissueTable::default();
    let r = DVec3::splat(radius);
    let grid = LevelSet::from_sdf(VOXEL, 3.0, -r, r, |p| p.length() - radius).unwrap();
    let mut m = TissueModel::new("test sphere", None);
    m.push(table.get(tissue).unwrap().clone(), grid).unwrap();
    m
}

pub fn touch(tip: DVec3) -> DeviceState {
    DeviceState { pose: DAffine3::from_translation(tip), buttons: 0, rpm: 0.0 }
}

/// Moves the device tip along a straight line in `ticks` ticks, then holds it `hold` ticks.
pub fn drive(core: &mut HapticCore, model: &mut TissueModel, from: DVec3, to: DVec3, ticks: usize, hold: usize) -> Vec<TickOutput> {
    let mut out = Vec::new();
    for k in 0..=ticks {
        let p = from.lerp(to, k as f64 / ticks.max(1) as f64);
        out.push(core.tick(model, &touch(p), false).unwrap());
    }
    for _ in 0..hold {
        out.push(core.tick(model, &touch(to), false).unwrap());
    }
    out
}

/// Triangles as sorted, rotation-normalised vertex triples (bit patterns), for set comparison.
pub fn triangle_set(m: &TriMesh) -> Vec<[[u32; 3]; 3]> {
    let mut out: Vec<[[u32; 3]; 3]> = m
        .triangles
        .iter()
        .map(|t| {
            let v = t.map(|i| m.points[i as usize].to_array().map(f32::to_bits));
            let k = (0..3).min_by_key(|&k| v[k]).unwrap();
            [v[k], v[(k + 1) % 3], v[(k + 2) % 3]]
        })
        .collect();
    out.sort_unstable();
    out
}

/// Enamel, dentin and pulp as nested balls (radii 1.6, 1.1, 0.45 mm), made ready for cutting as
/// a session makes them.
pub fn nested_balls_model() -> TissueModel {
    let mut m = TissueModel::new("nested balls", None);
    let table = TissueTable::default();
    for (name, r) in [("enamel", 1.6), ("dentin", 1.1), ("pulp", 0.45)] {
        let grid = LevelSet::from_sdf(VOXEL, 3.0, DVec3::splat(-r - 0.3), DVec3::splat(r + 0.3), |p| p.length() - r).unwrap();
        m.push(table.get(name).unwrap().clone(), grid).unwrap();
    }
    m.voxelize_for_cutting().unwrap();
    m
}

/// Tissue `t` of [`nested_balls_model`] read densely over its whole box (89³ voxels).
pub fn nested_balls_dense(model: &TissueModel, t: usize) -> Vec<f32> {
    let mut v = vec![0f32; 89 * 89 * 89];
    model.tissues[t].grid.read_dense(IVec3::splat(-44), [89u32; 3], &mut v).unwrap();
    v
}

/// A burr of `shape` with a random head diameter of 0.8–1.4 mm and a length fitting the shape.
pub fn random_burr(shape: Shape, unit: &mut impl FnMut() -> f64) -> Burr {
    let d = 0.8 + 0.6 * unit();
    let len = match shape {
        Shape::Wheel => 0.4 * d,
        Shape::Round => d,
        _ => (1.5 * d).max(1.0),
    };
    Burr::new(shape, d, Some(len)).unwrap()
}

/// A haptic session's tick poses (91 poses, 90 ticks) through [`nested_balls_model`]: a head
/// tilted at random entering the enamel from above on a pass across, a plunge along its axis,
/// a pass back with a slight turn every 7th tick; 0.02 mm a tick (20 mm/s at 1 kHz).
pub fn haptic_tick_path(unit: &mut impl FnMut() -> f64) -> Vec<DAffine3> {
    let axis = DVec3::new(unit() - 0.5, unit() - 0.5, 2.0).normalize();
    let tilt = DQuat::from_rotation_arc(DVec3::Z, axis);
    let across = axis.any_orthonormal_vector();
    let mut poses = vec![DAffine3::from_rotation_translation(tilt, axis * 1.2 - across * 0.5)];
    for tick in 0..90 {
        let (step, turn) = match tick {
            0..=29 => (across * 0.02 - axis * 0.01, 0.0),
            30..=59 => (-axis * 0.02, 0.0),
            _ => (-across * 0.02, if tick % 7 == 0 { 0.01 } else { 0.0 }),
        };
        let pose = poses[tick];
        let rotation = DQuat::from_axis_angle(axis, turn) * DQuat::from_mat3(&pose.matrix3);
        poses.push(DAffine3::from_rotation_translation(rotation, pose.translation + step));
    }
    poses
}

/// Builds `sweep`'s patch for the stroke, marking the blocks where `model` has material (as a
/// cutter does), at VOXEL.
pub fn build_marked(sweep: &mut dentsim_sim::cutting::sweep::Sweep, burr: &Burr, stroke: (DAffine3, DAffine3), band: f64, done: Option<dentsim_sim::cutting::sweep::Done>, model: &TissueModel) {
    let grids = &model.tissues;
    sweep
        .build_in(burr, stroke.0, stroke.1, VOXEL, band, done, |lo, dims, blocks| {
            grids.iter().try_for_each(|t| t.grid.mark_material_blocks(lo, dims, blocks).map_err(Into::into))
        })
        .unwrap();
}

/// What a stroke of `burr` ending at `pose` leaves done: its ball, or its head there.
pub fn done_at(burr: &Burr, pose: DAffine3) -> dentsim_sim::cutting::sweep::Done {
    use dentsim_sim::cutting::sweep::{CutBall, CutHead, Done};
    match burr.ball_radius() {
        Some(r) => Done::Ball(CutBall { centre: pose.transform_point3(DVec3::new(0.0, 0.0, r)), radius: r }),
        None => Done::Head(CutHead { to_tool: pose.inverse(), offset: 0.0 }),
    }
}

/// Asserts two nested-balls models hold every tissue's grid bit for bit alike.
pub fn assert_same_nested_balls(a: &TissueModel, b: &TissueModel, what: &str) {
    for t in 0..3 {
        let (x, y) = (nested_balls_dense(a, t), nested_balls_dense(b, t));
        for (n, (p, q)) in x.iter().zip(&y).enumerate() {
            assert_eq!(p.to_bits(), q.to_bits(), "{what} tissue {t} voxel {n}: {p} vs {q}");
        }
        assert_eq!(a.tissues[t].grid.content_hash(), b.tissues[t].grid.content_hash(), "{what} tissue {t}");
    }
}
