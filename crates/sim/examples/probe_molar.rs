use dentsim_sim::bench::bench_tooth;
use glam::DVec3;
fn main() {
    let tooth = bench_tooth().unwrap();
    println!("occlusal {:?}", tooth.occlusal);
    for dx in [-1.5, -0.75, 0.0, 0.75, 1.5] {
        let mut line = format!("dx {dx:+.2}: ");
        for t in &tooth.model.tissues {
            let mut r = t.grid.reader();
            let first = (0..800).map(|i| tooth.occlusal + DVec3::new(dx, 0.0, 2.0 - 0.005 * i as f64)).find(|p| r.value(*p) <= 0.0);
            line += &format!("{} top {:?}  ", t.props.name, first.map(|p| ((p.z - tooth.occlusal.z) * 100.0).round() / 100.0));
        }
        println!("{line}");
    }
}
