use std::time::Instant;
use dentsim_sim::burr::Burr;
use glam::DVec3;
fn main() {
    let burr = Burr::parse("cylinder_flat_012").unwrap();
    let pts: Vec<DVec3> = (0..100_000).map(|i| { let f = i as f64; DVec3::new((f * 0.37).sin() * 0.8, (f * 0.11).cos() * 0.8, (f * 0.013).sin() * 2.0 + 1.5) }).collect();
    let mut s = 0.0;
    for _ in 0..3 {
        let t = Instant::now();
        for p in &pts { s += burr.sdf(*p); }
        println!("{:.1} ns/eval", t.elapsed().as_nanos() as f64 / pts.len() as f64);
    }
    println!("{s}");
}
