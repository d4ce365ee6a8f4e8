//! Our mesher (chunked surface nets, seams joined) beside OpenVDB's volumeToMesh on the bench's
//! segmented molar: time, triangle count, closedness, how far vertices lie off the zero level
//! set, triangle shape, and enclosed volume against the grid's own volume measure.
//!   cargo run --release -p dentsim-sim --example mesher_quality
use std::collections::HashMap;
use std::time::Instant;

use dentsim_bench::bench_tooth;
use dentsim_sim::tissues::surface::surface;
use dentsim_vdb::{LevelSet, TriMesh};

fn open_edges(m: &TriMesh) -> usize {
    let mut edges: HashMap<(u32, u32), i64> = HashMap::new();
    for t in &m.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *edges.entry((a.min(b), a.max(b))).or_default() += if a < b { 1 } else { -1 };
        }
    }
    edges.values().filter(|v| **v != 0).count()
}

fn quantile(v: &mut [f64], q: f64) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[((v.len() - 1) as f64 * q).round() as usize]
}

fn report(name: &str, grid: &LevelSet, m: &TriMesh, ms: f64) {
    let h = grid.voxel_size();
    let mut reader = grid.reader();
    let mut off: Vec<f64> = m.points.iter().map(|p| f64::from(reader.value(p.as_dvec3())).abs() / h).collect();
    let mut min_angle: Vec<f64> = m
        .triangles
        .iter()
        .map(|t| {
            let p = t.map(|i| m.points[i as usize].as_dvec3());
            (0..3)
                .map(|k| {
                    let (a, b) = (p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]);
                    a.angle_between(b).to_degrees()
                })
                .fold(180.0, f64::min)
        })
        .collect();
    let slivers = min_angle.iter().filter(|a| **a < 10.0).count() as f64 / min_angle.len() as f64;
    println!(
        "{name:<22} {ms:>8.1} ms {:>8} tris {:>8} verts  open edges {:>5}  |sdf| at vertices mean {:.4} p99 {:.4} max {:.4} voxel  min angle p1 {:>5.1}°, <10°: {:.3}%  volume {:+.3}% vs grid",
        m.triangles.len(),
        m.points.len(),
        open_edges(m),
        off.iter().sum::<f64>() / off.len() as f64,
        quantile(&mut off, 0.99),
        quantile(&mut off, 1.0),
        quantile(&mut min_angle, 0.01),
        slivers * 100.0,
        (m.volume() / grid.volume() - 1.0) * 100.0,
    );
}

fn main() {
    let tooth = bench_tooth().expect("bench tooth");
    for t in &tooth.model.tissues {
        let grid = &t.grid;
        let start = Instant::now();
        let ours = surface(grid).expect("mesh");
        let ours_ms = start.elapsed().as_secs_f64() * 1e3;
        let start = Instant::now();
        let peer = grid.to_mesh();
        let peer_ms = start.elapsed().as_secs_f64() * 1e3;
        println!("{}:", t.props.name);
        report("  ours (surface nets)", grid, &ours, ours_ms);
        report("  volumeToMesh", grid, &peer, peer_ms);
    }
}
