//! Times a head's distance one point at a time and a row at a time (profiling the sweep's
//! kernel): `cargo run --release --example sdf_speed [burr spec] [row length]`.
use std::time::Instant;

use dentsim_sim::burr::Burr;
use glam::{DVec3, Vec3};

fn main() {
    let spec = std::env::args().nth(1).unwrap_or_else(|| "cylinder_flat_012".into());
    let burr = Burr::parse(&spec).expect("burr spec");
    let rows = 20_000;
    let len: usize = std::env::args().nth(2).map_or(32, |a| a.parse().unwrap());
    let origin = |r: usize| {
        let f = r as f64;
        DVec3::new(-0.8, (f * 0.11).cos() * 0.8, (f * 0.013).sin() * 2.0 + 1.5)
    };
    let step = DVec3::new(0.05, 0.0, 0.0);
    let mut sink = 0.0f64;
    let t = Instant::now();
    for r in 0..rows {
        for i in 0..len {
            sink += burr.sdf(origin(r) + step * i as f64);
        }
    }
    let point = t.elapsed().as_nanos() as f64 / (rows * len) as f64;
    let mut out = vec![0f32; len];
    let t = Instant::now();
    for r in 0..rows {
        burr.sdf_row(origin(r).as_vec3(), Vec3::new(0.05, 0.0, 0.0), &mut out);
        sink += f64::from(out.iter().sum::<f32>());
    }
    let row = t.elapsed().as_nanos() as f64 / (rows * len) as f64;
    println!("{spec}: {point:.1} ns a point alone, {row:.1} ns a point in rows of {len} ({sink:.0})");
}
