//! One mesher everywhere: a session's last live frame, the exported surface and a fresh mesh of
//! the final grids are the same triangles; the exported surface is closed, wound outward.
mod common;

use std::collections::HashMap;

use common::triangle_set;
use dentsim_devices::{HandParams, SimulatedHand};
use dentsim_sim::tissues::export::write_model;
use dentsim_sim::tissues::surface::{surface, Mesher};
use dentsim_sim::tissues::capsule::CapsuleTooth;
use dentsim_sim::session::threads::{run_session, SessionOptions};
use dentsim_sim::tissues::table::TissueTable;
use dentsim_vdb::TriMesh;
use glam::{DVec3, Vec3};

/// Every directed edge has its reverse as often: no border, consistent winding.
fn assert_closed(m: &TriMesh, what: &str) {
    let mut edges: HashMap<(u32, u32), i64> = HashMap::new();
    for t in &m.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *edges.entry((a.min(b), a.max(b))).or_default() += if a < b { 1 } else { -1 };
        }
    }
    let open = edges.values().filter(|v| **v != 0).count();
    assert_eq!(open, 0, "{what}: {open} edges without a matching reverse edge");
}

/// Counter-clockwise seen from outside (VTK's order): along each face's right-hand normal the
/// level set rises (inside to outside), and the enclosed volume is positive.
fn assert_outward(m: &TriMesh, grid: &dentsim_vdb::LevelSet, what: &str) {
    let step = 0.5 * grid.voxel_size();
    let mut reader = grid.reader();
    let (mut agree, mut faces) = (0usize, 0usize);
    for t in &m.triangles {
        let [a, b, c] = t.map(|i| m.points[i as usize].as_dvec3());
        let Some(n) = (b - a).cross(c - a).try_normalize() else { continue };
        let centre = (a + b + c) / 3.0;
        faces += 1;
        agree += usize::from(reader.value(centre + n * step) > reader.value(centre - n * step));
    }
    let share = agree as f64 / faces as f64;
    println!("{what}: {share:.5} of {faces} faces wound outward");
    assert!(share > 0.999, "{what}: {share} of the faces wound outward");
    assert!(m.volume() > 0.0, "{what}: volume {}", m.volume());
}

#[test]
fn the_live_frame_the_export_and_a_fresh_mesh_are_the_same_triangles() {
    let model = CapsuleTooth::default().build(0.05, &TissueTable::default()).unwrap();
    let hand = SimulatedHand::new(HandParams {
        start: DVec3::new(0.2, -0.1, 5.8),
        target: DVec3::new(0.2, -0.1, 3.2),
        push_n: 2.0,
        pedal: true,
        rpm: 400_000.0,
        duration_s: 3.0,
        ..Default::default()
    });
    let options = SessionOptions { realtime: false, raise_priority: false, ..Default::default() };
    let mut out = run_session(model, hand, options).unwrap();
    let removed: f64 = out.removed_mm3.iter().map(|(_, v)| v).sum();
    assert!(removed > 0.1, "{:?}", out.removed_mm3);
    let dir = tempfile::tempdir().unwrap();
    write_model(&mut out.model, dir.path(), &mut |_, _| {}).unwrap();
    let full = Mesher::full(&out.model).unwrap();
    for (t, tissue) in out.model.tissues.iter().enumerate() {
        let name = &tissue.props.name;
        let fresh = surface(&tissue.grid).unwrap();
        assert_closed(&fresh, name);
        assert_outward(&fresh, &tissue.grid, name);
        assert_eq!(triangle_set(&fresh), triangle_set(&full.mesh(t)), "{name}: joined vs chunk frame");
        // The exported STL holds the same triangles (its points are f32 too).
        let mut file = std::fs::File::open(dir.path().join(format!("{name}.stl"))).unwrap();
        let stl = stl_io::read_stl(&mut file).unwrap();
        let exported = TriMesh {
            points: stl.vertices.iter().map(|v| Vec3::new(v[0], v[1], v[2])).collect(),
            normals: vec![Vec3::ZERO; stl.vertices.len()],
            triangles: stl.faces.iter().map(|f| f.vertices.map(|i| i as u32)).collect(),
        };
        assert_eq!(triangle_set(&exported), triangle_set(&fresh), "{name}: STL vs surface");
        // The live frame, for every tissue the session cut.
        if let Some(live) = &out.final_meshes[t] {
            println!("{name}: live frame {} triangles, export {}", live.triangles.len(), fresh.triangles.len());
            assert_eq!(triangle_set(live), triangle_set(&fresh), "{name}: live frame vs export");
        }
    }
    assert!(out.final_meshes[0].is_some(), "the session published no enamel frame");
}
