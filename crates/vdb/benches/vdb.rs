//! Criterion benches of the level-set primitives on a 10 mm sphere at 0.05 mm (REFERENCE.md's
//! peer figures use the same grid): SDF samples and one stroke's cut, ours beside OpenVDB's way.
use criterion::{black_box, criterion_group, criterion_main, BatchSize, Criterion};
use dentsim_vdb::{DensePatch, LevelSet};
use glam::{DVec3, IVec3};

const H: f64 = 0.05;
const R: f64 = 10.0;

fn sphere() -> LevelSet {
    LevelSet::from_sdf(H, 3.0, DVec3::splat(-R), DVec3::splat(R), |p| p.length() - R).unwrap()
}

/// Deterministic points: golden-angle spiral over the shell, jittered radially.
fn shell_points(n: usize, radius_jitter: f64) -> Vec<DVec3> {
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let a = i as f64 * 2.399_963;
            let s = (1.0 - z * z).sqrt();
            DVec3::new(s * a.cos(), s * a.sin(), z) * (R + radius_jitter * ((i % 7) as f64 / 3.0 - 1.0))
        })
        .collect()
}

fn sampling(c: &mut Criterion) {
    let grid = sphere();
    let near: Vec<DVec3> = (0..1000).map(|i| DVec3::new(0.0, 0.0, R) + DVec3::splat((i % 10) as f64 * 0.02)).collect();
    let random = shell_points(1000, 0.1);
    for (name, points) in [("near", &near), ("random", &random)] {
        let flat: Vec<f32> = points.iter().flat_map(|p| p.as_vec3().to_array()).collect();
        let mut reader = grid.reader();
        c.bench_function(&format!("sdf_sample_{name}/ours_x1000"), |b| {
            b.iter(|| points.iter().map(|p| f64::from(reader.value(*p))).sum::<f64>())
        });
        c.bench_function(&format!("sdf_sample_{name}/peer_x1000"), |b| b.iter(|| grid.peer_sample_sum(black_box(&flat))));
    }
}

fn ball_patch(grid: &LevelSet, a: DVec3, b: DVec3, r: f64) -> DensePatch {
    let reach = r + f64::from(grid.background()) + H;
    let (lo, hi) = (grid.world_to_index(a.min(b) - reach), grid.world_to_index(a.max(b) + reach));
    let mut values = Vec::new();
    for k in lo.z..=hi.z {
        for j in lo.y..=hi.y {
            for i in lo.x..=hi.x {
                let p = grid.index_to_world(IVec3::new(i, j, k));
                let ab = b - a;
                let t = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
                values.push(((p - (a + ab * t)).length() - r) as f32);
            }
        }
    }
    DensePatch { index_min: lo, dims: (hi - lo + IVec3::ONE).as_uvec3().to_array(), values, spans: Vec::new() }
}

fn stroke_cut(c: &mut Criterion) {
    let grid = sphere();
    let (a, b) = (DVec3::new(0.0, 0.0, R - 0.2), DVec3::new(0.02, 0.0, R - 0.2));
    let patch = ball_patch(&grid, a, b, 0.5);
    c.bench_function("cut_stroke/ours_subtract_patch", |bench| {
        bench.iter_batched_ref(|| grid.clone(), |g| g.subtract(&patch).unwrap(), BatchSize::LargeInput)
    });
    c.bench_function("cut_stroke/ours_patch_and_subtract", |bench| {
        bench.iter_batched_ref(|| grid.clone(), |g| g.subtract(&ball_patch(g, a, b, 0.5)).unwrap(), BatchSize::LargeInput)
    });
    c.bench_function("cut_stroke/peer_sphere_csg", |bench| {
        bench.iter_batched_ref(|| grid.clone(), |g| g.peer_sphere_cut(b, 0.5).unwrap(), BatchSize::LargeInput)
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(30).measurement_time(std::time::Duration::from_secs(3));
    targets = sampling, stroke_cut
}
criterion_main!(benches);
