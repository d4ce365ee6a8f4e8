//! Benchmark functions for `dentsim bench` (not timed assertions): each returns a row with the
//! peer measured in the same run.
use std::time::Instant;

use dentsim_devices::ScriptedPath;
use glam::{DAffine3, DVec3};
use parry3d::math::{Isometry, Point};
use parry3d::query::PointQuery;
use parry3d::shape::TriMesh as ParryMesh;

use crate::burr::Burr;
use crate::contact::{BurrSamples, ContactQuery};
use crate::error::Result;
use crate::phantom::CapsuleTooth;
use crate::session::{run_session, SessionOptions};
use crate::tissue::TissueTable;

/// One benchmark result (µs). Reconcile with main's `BenchRow` when it lands.
#[derive(Clone, Debug, PartialEq)]
pub struct BenchRow {
    pub name: String,
    pub ours_median_us: f64,
    pub ours_p99_us: f64,
    pub peer: String,
    pub peer_median_us: f64,
}

fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    sorted[((sorted.len() - 1) as f64 * q).round() as usize]
}

fn sorted(mut v: Vec<f64>) -> Vec<f64> {
    v.sort_by(f64::total_cmp);
    v
}

/// Contact query of a 1.0 mm round burr (`points` samples) pressed 0.1 mm into the capsule
/// molar's top at 0.05 mm voxels, against all three tissues; peer: parry3d `project_point` of the
/// same points on each tissue's triangle mesh (OpenVDB `volumeToMesh`, BVH built beforehand).
pub fn force_query(points: usize, iterations: usize) -> Result<BenchRow> {
    let model = CapsuleTooth::default().build(0.05, &TissueTable::default())?;
    let burr = Burr::round(1.0)?;
    let samples = BurrSamples::new(&burr, points)?;
    let tool_points = samples.points.clone();
    let mut query = ContactQuery::new(samples, model.tissues.len());
    let pose = DAffine3::from_translation(DVec3::new(0.3, 0.2, 4.9));
    let mut ours = Vec::with_capacity(iterations);
    let mut in_contact = 0;
    for _ in 0..iterations {
        let t = Instant::now();
        in_contact = query.query(&model, &pose, 0.0).len();
        ours.push(t.elapsed().as_secs_f64() * 1e6);
    }
    let meshes: Vec<ParryMesh> = model
        .tissues
        .iter()
        .map(|t| {
            let m = t.grid.to_mesh();
            let v = m.points.iter().map(|p| Point::new(p.x, p.y, p.z)).collect();
            ParryMesh::new(v, m.triangles.clone())
        })
        .collect();
    let world: Vec<Point<f32>> = tool_points
        .iter()
        .map(|p| {
            let w = pose.transform_point3(*p);
            Point::new(w.x as f32, w.y as f32, w.z as f32)
        })
        .collect();
    let mut peer = Vec::with_capacity(iterations);
    let mut sink = 0.0f32;
    for _ in 0..iterations.min(200) {
        let t = Instant::now();
        for mesh in &meshes {
            for p in &world {
                sink += mesh.project_point(&Isometry::identity(), p, false).point.x;
            }
        }
        peer.push(t.elapsed().as_secs_f64() * 1e6);
    }
    std::hint::black_box(sink);
    let (ours, peer) = (sorted(ours), sorted(peer));
    Ok(BenchRow {
        name: format!("force_query ({points} points, {in_contact} in contact, 3 tissues)"),
        ours_median_us: percentile(&ours, 0.5),
        ours_p99_us: percentile(&ours, 0.99),
        peer: "parry3d TriMesh project_point".into(),
        peer_median_us: percentile(&peer, 0.5),
    })
}

/// A real-time session (1 kHz, raised priority where permitted) with a scripted device cutting
/// down into the molar and a mesher at 30 Hz: tick period p50/p99 (row 1), p99.9 (row 2), and
/// cut → published mesh latency (row 3). No peer: the rows give the goal instead.
pub fn loop_period(seconds: f64) -> Result<Vec<BenchRow>> {
    let model = CapsuleTooth::default().build(0.05, &TissueTable::default())?;
    let csv = format!(
        "t,x,y,z,qw,qx,qy,qz,rpm,cut\n0,0,0,5.6,1,0,0,0,200000,1\n{:.3},0.3,0,4.0,1,0,0,0,200000,1\n",
        seconds
    );
    let path = ScriptedPath::parse(&csv, "bench path").map_err(|e| crate::error::invalid("bench path", e.to_string()))?;
    let options = SessionOptions { realtime: true, mesher_hz: Some(30.0), log_path: None, ..Default::default() };
    let out = run_session(model, path, options)?;
    let periods = sorted(out.periods_us.clone());
    let latency = sorted(out.cut_to_visible_ms.iter().map(|m| m * 1e3).collect());
    Ok(vec![
        BenchRow {
            name: format!("loop_period p50/p99 ({} ticks, {} missed)", out.ticks, out.missed_deadlines),
            ours_median_us: percentile(&periods, 0.5),
            ours_p99_us: percentile(&periods, 0.99),
            peer: "goal: 1000 µs".into(),
            peer_median_us: 1000.0,
        },
        BenchRow {
            name: "loop_period p99.9 / max".into(),
            ours_median_us: percentile(&periods, 0.999),
            ours_p99_us: periods.last().copied().unwrap_or(f64::NAN),
            peer: "goal: p99.9 <= 1100 µs".into(),
            peer_median_us: 1100.0,
        },
        BenchRow {
            name: format!("cut_to_visible ({} mesh batches)", out.meshes_published),
            ours_median_us: percentile(&latency, 0.5),
            ours_p99_us: percentile(&latency, 0.99),
            peer: "mesher period at 30 Hz".into(),
            peer_median_us: 1e6 / 30.0,
        },
    ])
}
