#[path = "../tests/family/mod.rs"]
mod family;
use dentsim_cbct::{Label, Phantom};
use dentsim_sim::tissues::from_scan::TissuesFromScan;
use dentsim_sim::tissues::table::TissueTable;
use glam::DVec3;
fn angles(mesh: &dentsim_vdb::TriMesh, sdf: &dyn Fn(DVec3) -> f64) -> Vec<(DVec3, f64)> {
    mesh.triangles.iter().filter_map(|tri| {
        let [a, b, c] = tri.map(|i| mesh.points[i as usize].as_dvec3());
        let normal = (b - a).cross(c - a);
        if normal.length() < 1e-12 { return None; }
        let centre = (a + b + c) / 3.0;
        let h = 1e-3;
        let grad = DVec3::new(sdf(centre + DVec3::X * h) - sdf(centre - DVec3::X * h), sdf(centre + DVec3::Y * h) - sdf(centre - DVec3::Y * h), sdf(centre + DVec3::Z * h) - sdf(centre - DVec3::Z * h));
        if grad.length() < 1e-9 || !grad.is_finite() { return None; }
        Some((centre, normal.normalize().dot(grad.normalize()).clamp(-1.0, 1.0).acos().to_degrees()))
    }).collect()
}
fn summary(name: &str, mut v: Vec<f64>) {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    let mean = v.iter().sum::<f64>() / n as f64;
    let tail = |t: f64| v.iter().filter(|&&a| a > t).map(|a| a).sum::<f64>() / n as f64;
    println!("  {name}: n {n} mean {mean:.2} p50 {:.2} p90 {:.2} p99 {:.2}; mean share from >15°: {:.2}, >30°: {:.2}", v[n / 2], v[9 * n / 10], v[99 * n / 100], tail(15.0), tail(30.0));
}
fn main() {
    let only = std::env::args().nth(1).unwrap();
    let label = match std::env::args().nth(2).as_deref() { Some("dentin") => Label::Dentin, Some("enamel") => Label::Enamel, _ => Label::Pulp };
    for case in dentsim_cbct::phantom::family(true) {
        if !case.name.contains(&only) { continue; }
        let phantom = Phantom::new(&case.spec);
        let scan = phantom.scan();
        let fdi = phantom.tooth();
        let request = TissuesFromScan { seed_mm: phantom.tooth_seed(fdi), fdi, voxel_size_mm: 0.05, ..Default::default() };
        let (model, _) = request.run(&scan, &TissueTable::default(), &mut |_, _| {}).unwrap();
        let sdf = |p: DVec3| phantom.tooth_sdf(fdi, label, p).unwrap_or(f64::INFINITY);
        let ours = angles(&model.get(label.name()).unwrap().grid.to_mesh(), &sdf);
        let theirs = if std::env::args().any(|a| a == "analytic") {
            let (lo, hi) = phantom.tooth_bounds(fdi).unwrap();
            let (lo, hi) = (DVec3::from_array(lo) - 1.0, DVec3::from_array(hi) + 1.0);
            let grid = dentsim_vdb::LevelSet::from_sdf(0.05, 3.0, lo, hi, sdf).unwrap();
            angles(&grid.to_mesh(), &sdf)
        } else {
            let floor = family::resolution_floor_grids(&case, 0.05, true);
            angles(&floor.iter().find(|(l, _)| *l == label).unwrap().1.to_mesh(), &sdf)
        };
        println!("{}", case.name);
        summary("ours ", ours.iter().map(|a| a.1).collect());
        summary("floor", theirs.iter().map(|a| a.1).collect());
        // where ours' >30° triangles are: distance from the truth and the pulp's depth
        for (who, set) in [("ours", &ours), ("floor", &theirs)] {
            let mut bins = [(0usize, 0.0f64); 6];
            for (c, a) in set.iter() {
                let own = |p: DVec3| sdf(p);
                let mut deepest = own(*c);
                for i in 1..=24 { for d in [DVec3::X, DVec3::Y, DVec3::Z, -DVec3::X, -DVec3::Y, -DVec3::Z] { deepest = deepest.min(own(*c + d * (i as f64 * 1.2 / 24.0))); } }
                let b = if deepest > -0.1 { 0 } else if deepest > -0.2 { 1 } else if deepest > -0.3 { 2 } else if deepest > -0.45 { 3 } else if deepest > -0.7 { 4 } else { 5 };
                bins[b].0 += 1; bins[b].1 += a;
            }
            let n = set.len() as f64;
            println!("  {who}: by half-width <0.1/<0.2/<0.3/<0.45/<0.7/more: {}", bins.iter().map(|(c, s)| format!("{:.0}% {:.1}° (adds {:.2})", 100.0 * *c as f64 / n, s / (*c).max(1) as f64, s / n)).collect::<Vec<_>>().join(" | "));
        }
        let bad: Vec<&(DVec3, f64)> = ours.iter().filter(|a| a.1 > 30.0).collect();
        let d: f64 = bad.iter().map(|a| sdf(a.0).abs()).sum::<f64>() / bad.len().max(1) as f64;
        println!("  ours >30°: {} triangles, mean |sdf| {d:.3} mm", bad.len());
    }
}
