//! Time of a guarded .vdb read (`read_file`: layout check, reader process, in-process parse of
//! its output) against OpenVDB parsing the same bytes in-process (`read_unguarded`), alternated.
//!   cargo run --release -p dentsim-vdb --example read_time -- ROUNDS FILE...
use std::time::Instant;

use dentsim_vdb::{read_file, read_unguarded, ReadLimits};

fn main() {
    let mut args = std::env::args().skip(1);
    let rounds: usize = args.next().and_then(|r| r.parse().ok()).expect("usage: read_time ROUNDS FILE...");
    for path in args {
        let bytes = std::fs::read(&path).expect("readable file");
        let (mut guarded, mut direct) = (Vec::new(), Vec::new());
        for _ in 0..rounds {
            let t = Instant::now();
            read_file(path.as_ref()).expect("a valid file");
            guarded.push(t.elapsed().as_secs_f64() * 1e3);
            let t = Instant::now();
            read_unguarded(&bytes, &ReadLimits::default()).expect("a valid file");
            direct.push(t.elapsed().as_secs_f64() * 1e3);
        }
        let range = |v: &mut Vec<f64>| {
            v.sort_by(f64::total_cmp);
            format!("min {:.1} median {:.1} max {:.1} ms", v[0], v[v.len() / 2], v[v.len() - 1])
        };
        println!(
            "{path} ({:.1} MB, {rounds} rounds): guarded {}; in-process {}",
            bytes.len() as f64 / 1e6,
            range(&mut guarded),
            range(&mut direct)
        );
    }
}
