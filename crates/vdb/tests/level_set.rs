//! Level sets of analytic shapes checked against their closed forms.
use std::f64::consts::PI;
use std::process::Command;

use dentsim_vdb::{read_file, write_file, DensePatch, DenseVolume, Error, LevelSet, MetaValue, TriMesh};
use glam::{DVec3, IVec3, Vec3};

const H: f64 = 0.05;
const HALF_WIDTH: f64 = 3.0;

fn sphere(center: DVec3, r: f64) -> LevelSet {
    LevelSet::from_sdf(H, HALF_WIDTH, center - r, center + r, |p| (p - center).length() - r).unwrap()
}

#[test]
fn sphere_sdf_values_are_distances() {
    let c = DVec3::new(0.3, -0.2, 0.1);
    let ls = sphere(c, 2.0);
    let mut reader = ls.reader();
    for &(p, expected) in &[
        (c + DVec3::X * 2.0, 0.0),
        (c + DVec3::Y * 1.9, -0.1),
        (c - DVec3::Z * 2.07, 0.07),
        (c + DVec3::new(1.0, 1.0, 1.0).normalize() * 1.95, -0.05),
    ] {
        let v = f64::from(reader.value(p));
        assert!((v - expected).abs() < 0.01 * H + 1e-3, "sdf at {p}: {v} vs {expected}");
    }
    // Far inside and far outside read the background with the right sign.
    assert_eq!(reader.value(c), -ls.background());
    assert_eq!(reader.value(c + DVec3::X * 5.0), ls.background());
    let (v, g) = reader.value_gradient(c + DVec3::new(0.0, 0.0, 2.0));
    assert!(v.abs() < 1e-3);
    assert!((g - Vec3::Z).length() < 0.02, "gradient {g}");
}

#[test]
fn sphere_volume_from_mesh_within_one_percent() {
    let r = 2.0;
    let ls = sphere(DVec3::ZERO, r);
    let exact = 4.0 / 3.0 * PI * r.powi(3);
    let mesh = ls.to_mesh();
    let mesh_volume = mesh.volume();
    assert!((mesh_volume / exact - 1.0).abs() < 0.01, "mesh volume {mesh_volume} vs {exact}");
    let grid_volume = ls.volume();
    assert!((grid_volume / exact - 1.0).abs() < 0.01, "grid volume {grid_volume} vs {exact}");
    // Outward normals: each agrees with the radial direction.
    for (p, n) in mesh.points.iter().zip(&mesh.normals).step_by(97) {
        assert!(p.normalize().dot(*n) > 0.99, "normal {n} at {p}");
    }
    let area = mesh.area();
    assert!((area / (4.0 * PI * r * r) - 1.0).abs() < 0.01, "area {area}");
}

#[test]
fn total_mean_curvature_of_a_sphere_and_a_torus() {
    // ∫H dA: 4πr for a sphere; 2π²R for a torus, whose inner half (concave across) takes away.
    let r = 2.0;
    let sphere = sphere(DVec3::ZERO, r).to_mesh().total_mean_curvature();
    assert!((sphere / (4.0 * PI * r) - 1.0).abs() < 0.01, "sphere {sphere} vs {}", 4.0 * PI * r);
    let (major, minor) = (2.0, 0.6);
    let torus = LevelSet::from_sdf(H, HALF_WIDTH, DVec3::new(-2.7, -2.7, -0.7), DVec3::new(2.7, 2.7, 0.7), |p| {
        (DVec3::new(p.x, p.y, 0.0).length() - major).hypot(p.z) - minor
    })
    .unwrap()
    .to_mesh()
    .total_mean_curvature();
    let exact = 2.0 * PI * PI * major;
    assert!((torus / exact - 1.0).abs() < 0.01, "torus {torus} vs {exact}");
}

#[test]
fn the_largest_body_leaves_the_specks_and_their_curvature() {
    // A ball of radius 2 and five specks of 0.15 mm: each speck adds 4π·0.15 to ∫H dA, nearly a
    // quarter of the ball's.
    let specks: Vec<DVec3> = (0..5).map(|i| DVec3::new(3.0, -2.0 + f64::from(i), 0.0)).collect();
    let mesh = LevelSet::from_sdf(0.05, HALF_WIDTH, DVec3::splat(-2.6), DVec3::new(3.6, 2.6, 2.6), |p| {
        specks.iter().map(|&c| (p - c).length() - 0.15).fold(p.length() - 2.0, f64::min)
    })
    .unwrap()
    .to_mesh();
    let body = mesh.largest_body();
    let ball = 4.0 * PI * 2.0;
    assert!(mesh.total_mean_curvature() > ball * 1.15, "the specks' share: {} vs the ball's {ball}", mesh.total_mean_curvature());
    assert!((body.total_mean_curvature() / ball - 1.0).abs() < 0.01, "the body's {} vs {ball}", body.total_mean_curvature());
    assert!((body.volume() / (4.0 / 3.0 * PI * 8.0) - 1.0).abs() < 0.01, "volume {}", body.volume());
    assert!(body.triangles.len() < mesh.triangles.len() && body.points.len() < mesh.points.len());
    assert!(body.triangles.iter().flatten().all(|&i| (i as usize) < body.points.len()));
    assert_eq!(TriMesh::default().largest_body(), TriMesh::default());
}

#[test]
fn our_sdf_builder_matches_openvdb_sphere() {
    let ours = sphere(DVec3::new(1.0, 0.0, 0.0), 1.5);
    let theirs = LevelSet::sphere(DVec3::new(1.0, 0.0, 0.0), 1.5, H, HALF_WIDTH).unwrap();
    let ratio = ours.active_voxel_count() as f64 / theirs.active_voxel_count() as f64;
    assert!((ratio - 1.0).abs() < 0.02, "active voxels {ratio}");
    assert!((ours.volume() / theirs.volume() - 1.0).abs() < 1e-3);
}

#[test]
fn local_subtract_removes_a_ball() {
    let mut block = LevelSet::from_sdf(H, HALF_WIDTH, DVec3::splat(-2.0), DVec3::splat(2.0), |p| {
        let q = p.abs() - DVec3::splat(2.0);
        q.max(DVec3::ZERO).length() + q.max_element().min(0.0)
    })
    .unwrap();
    let before = block.volume();
    // A ball of radius 0.5 centred on the top face: half of it lies inside the block.
    let (c, r) = (DVec3::new(0.0, 0.0, 2.0), 0.5);
    let lo = block.world_to_index(c - (r + 0.2));
    let hi = block.world_to_index(c + (r + 0.2));
    let dims = (hi - lo + IVec3::ONE).as_uvec3().to_array();
    let mut values = Vec::new();
    for k in lo.z..=hi.z {
        for j in lo.y..=hi.y {
            for i in lo.x..=hi.x {
                let p = block.index_to_world(IVec3::new(i, j, k));
                values.push(((p - c).length() - r) as f32);
            }
        }
    }
    let stats = block.subtract(&DensePatch { index_min: lo, dims, values, spans: Vec::new() }).unwrap();
    let after = block.volume();
    let expected = 2.0 / 3.0 * PI * r.powi(3);
    assert!(stats.changed_voxels > 0);
    assert!((stats.removed_mm3 - (before - after)).abs() < 1e-9 * before, "bookkeeping");
    assert!((stats.removed_mm3 / expected - 1.0).abs() < 0.03, "{} vs {expected}", stats.removed_mm3);
    let mut reader = block.reader();
    // Inside the cut, 0.1 mm from the ball's surface, is now outside by 0.1 mm.
    assert!((reader.value(c - DVec3::Z * 0.4) - 0.1).abs() < 0.01, "inside the cut is outside");
    // Deeper than the band, it reads the background with the outside sign.
    assert_eq!(reader.value(c - DVec3::Z * 0.2), block.background());
}

#[test]
fn csg_difference_agrees_with_local_subtract() {
    let mut a = sphere(DVec3::ZERO, 1.5);
    let tool = LevelSet::sphere(DVec3::new(1.5, 0.0, 0.0), 0.6, H, HALF_WIDTH).unwrap();
    let before = a.volume();
    a.csg_difference(&tool).unwrap();
    assert!(tool.active_voxel_count() > 0, "the tool is copied, not emptied");
    let removed = before - a.volume();
    // Lens volume of two spheres (R = 1.5, r = 0.6, d = 1.5).
    let (big_r, r, d): (f64, f64, f64) = (1.5, 0.6, 1.5);
    let lens = PI * (big_r + r - d).powi(2)
        * (d * d + 2.0 * d * r - 3.0 * r * r + 2.0 * d * big_r + 6.0 * r * big_r - 3.0 * big_r * big_r)
        / (12.0 * d);
    assert!((removed / lens - 1.0).abs() < 0.03, "{removed} vs {lens}");
}

#[test]
fn offset_moves_the_surface_along_its_normals() {
    let r = 1.0;
    for d in [0.01, -0.02, -0.03, 0.12] {
        let mut ls = sphere(DVec3::ZERO, r);
        ls.offset(d).unwrap();
        let mut reader = ls.reader();
        let v = f64::from(reader.value(DVec3::new(r + d, 0.0, 0.0)));
        assert!(v.abs() < 0.1 * H, "offset {d}: sdf on the new surface {v}");
        let expected = 4.0 / 3.0 * PI * (r + d).powi(3);
        assert!((ls.volume() / expected - 1.0).abs() < 0.005, "offset {d}: {} vs {expected}", ls.volume());
    }
    assert!(sphere(DVec3::ZERO, r).offset(f64::NAN).is_err());
}

#[test]
fn a_wide_band_moves_by_its_values_then_narrows_to_the_usual_band() {
    let (r, d) = (1.0, 2.0 * H);
    // The usual band, moved by re-tracking: the reference.
    let mut tracked = sphere(DVec3::ZERO, r);
    tracked.offset(d).unwrap();
    let mut wide = LevelSet::sphere(DVec3::ZERO, r, H, HALF_WIDTH + 2.0).unwrap();
    // Two voxels in two steps, each kept 2.5 voxels of band each side: both shift the values.
    wide.offset(0.5 * d).unwrap();
    wide.offset(0.5 * d).unwrap();
    wide.narrow_band(HALF_WIDTH).unwrap();
    assert!((f64::from(wide.background()) - HALF_WIDTH * H).abs() < 1e-6, "background {}", wide.background());
    let expected = 4.0 / 3.0 * PI * (r + d).powi(3);
    for grid in [&wide, &tracked] {
        assert!((grid.volume() / expected - 1.0).abs() < 0.005, "{} vs {expected}", grid.volume());
    }
    // The same band as the tracked grid's: every value within it, within a tenth of a voxel of
    // the moved sphere's distance.
    let (mut a, mut b) = (wide.reader(), tracked.reader());
    let mut worst = 0.0f64;
    for i in -40..=40 {
        for j in [-3, 0, 5] {
            let p = DVec3::new(f64::from(i) * 0.5 * H + r + d - 0.5, f64::from(j) * H, 0.25 * H);
            let exact = (p.length() - (r + d)).clamp(-HALF_WIDTH * H, HALF_WIDTH * H);
            let (va, vb) = (f64::from(a.value(p)), f64::from(b.value(p)));
            assert!(va.abs() <= HALF_WIDTH * H + 1e-6, "{p}: {va} beyond the band");
            if exact.abs() < (HALF_WIDTH - 0.5) * H {
                worst = worst.max((va - exact).abs());
                assert!((vb - exact).abs() < 0.2 * H, "{p}: tracked {vb}, exact {exact}");
            }
        }
    }
    assert!(worst < 0.1 * H, "shifted values off the moved sphere's distance by {worst}");
    assert!(wide.narrow_band(0.5).is_err());
}

#[test]
fn mismatched_transforms_are_refused() {
    let mut a = sphere(DVec3::ZERO, 1.0);
    let b = LevelSet::sphere(DVec3::ZERO, 1.0, 0.1, HALF_WIDTH).unwrap();
    let err = a.csg_difference(&b).unwrap_err();
    assert!(err.to_string().contains("different transforms"), "{err}");
}

#[test]
fn mesh_round_trip_through_mesh_to_level_set() {
    let original = sphere(DVec3::ZERO, 1.2);
    let mesh: TriMesh = original.to_mesh();
    let rebuilt = LevelSet::from_mesh(&mesh, H, HALF_WIDTH).unwrap();
    assert!((rebuilt.volume() / original.volume() - 1.0).abs() < 0.005);
}

#[test]
fn dense_volume_at_a_finer_voxel_size() {
    // A ball as a smooth 0..1 indicator on a 0.2 mm grid, rebuilt at 0.05 mm.
    let (n, spacing, r) = (40u32, 0.2, 2.5);
    let centre = DVec3::splat(f64::from(n - 1) * spacing / 2.0) + DVec3::new(10.0, -5.0, 3.0);
    let origin = DVec3::new(10.0, -5.0, 3.0);
    let mut values = Vec::new();
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let p = origin + DVec3::new(i.into(), j.into(), k.into()) * spacing;
                let d = (p - centre).length() - r;
                values.push((0.5 - 0.5 * (d / 0.15).tanh()) as f32);
            }
        }
    }
    #[rustfmt::skip]
    let index_to_world = [
        spacing, 0.0, 0.0, origin.x,
        0.0, spacing, 0.0, origin.y,
        0.0, 0.0, spacing, origin.z,
        0.0, 0.0, 0.0, 1.0,
    ];
    let volume = DenseVolume { dims: [n; 3], index_to_world, values: &values };
    let ls = LevelSet::from_dense(&volume, 0.5, true, H, HALF_WIDTH).unwrap();
    let exact = 4.0 / 3.0 * PI * r.powi(3);
    assert!((ls.volume() / exact - 1.0).abs() < 0.01, "{} vs {exact}", ls.volume());
    let mut reader = ls.reader();
    assert!(reader.value(centre + DVec3::X * r).abs() < 0.03);
    let short = DenseVolume { dims: [n; 3], index_to_world, values: &values[1..] };
    assert!(LevelSet::from_dense(&short, 0.5, true, H, HALF_WIDTH).is_err());
}

#[test]
fn file_round_trip_with_metadata_and_vdb_print() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("two.vdb");
    let mut a = sphere(DVec3::ZERO, 1.0);
    a.set_name("enamel");
    a.set_meta("tissue", &MetaValue::String("enamel".into()));
    a.set_meta("stiffness_n_per_mm", &MetaValue::F64(0.8));
    a.set_meta("label", &MetaValue::I64(5));
    a.set_meta("colour", &MetaValue::Vec3(Vec3::new(0.9, 0.9, 0.85)));
    let mut b = sphere(DVec3::X * 3.0, 0.5);
    b.set_name("pulp");
    write_file(&path, &[&a, &b]).unwrap();
    let leftovers: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(leftovers.len(), 1, "no temporary file left behind");

    let grids = read_file(&path).unwrap();
    assert_eq!(grids.iter().map(|g| g.name.as_str()).collect::<Vec<_>>(), ["enamel", "pulp"]);
    assert_eq!(grids[0].grid_class, "level set");
    let enamel = grids[0].level_set.as_ref().unwrap();
    assert_eq!(enamel.active_voxel_count(), a.active_voxel_count());
    assert!((enamel.volume() - a.volume()).abs() < 1e-9);
    assert_eq!(enamel.meta("tissue").unwrap(), MetaValue::String("enamel".into()));
    assert_eq!(enamel.meta("stiffness_n_per_mm").unwrap(), MetaValue::F64(0.8));
    assert_eq!(enamel.meta("label").unwrap(), MetaValue::I64(5));
    assert_eq!(enamel.meta("colour").unwrap(), MetaValue::Vec3(Vec3::new(0.9, 0.9, 0.85)));
    assert!(enamel.meta("missing").is_err());

    // OpenVDB's own tool reads what we wrote.
    let out = Command::new("vdb_print")
        .arg("-l")
        .arg(&path)
        .output()
        .expect("vdb_print runs (Debian package libopenvdb-tools)");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("enamel") && text.contains("pulp"), "{text}");
    assert!(text.contains("stiffness_n_per_mm"), "{text}");
}

#[test]
fn bad_files_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("none.vdb");
    let err = read_file(&missing).unwrap_err();
    assert!(matches!(err, Error::File { .. }) && err.to_string().contains("none.vdb"), "{err}");

    let good = dir.path().join("good.vdb");
    write_file(&good, &[&sphere(DVec3::ZERO, 1.0)]).unwrap();
    let bytes = std::fs::read(&good).unwrap();
    for cut in [0, 8, bytes.len() / 3, bytes.len() - 100] {
        let truncated = dir.path().join(format!("truncated{cut}.vdb"));
        std::fs::write(&truncated, &bytes[..cut]).unwrap();
        let result = read_file(&truncated);
        // OpenVDB reads grids lazily from a stream; a truncated file must fail, not crash.
        assert!(result.is_err(), "truncated at {cut} bytes was accepted");
        assert!(result.unwrap_err().to_string().contains(&format!("truncated{cut}.vdb")));
    }
    let not_vdb = dir.path().join("text.vdb");
    std::fs::write(&not_vdb, "this is not a vdb file at all, just text").unwrap();
    assert!(read_file(&not_vdb).is_err());

    let unwritable = dir.path().join("no_such_dir").join("out.vdb");
    assert!(write_file(&unwritable, &[&sphere(DVec3::ZERO, 1.0)]).is_err());
    assert!(LevelSet::new(-0.1, 3.0).is_err());
    assert!(LevelSet::new(f64::NAN, 3.0).is_err());
}
