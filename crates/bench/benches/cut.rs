//! Criterion timings of one haptic tick's cut and of the re-mesh after it (no peer here; the
//! peer comparison lives in `dentsim bench`, see `dentsim_bench`).
use criterion::{criterion_group, criterion_main, Criterion};
use dentsim_bench::{bench_stroke_tip, bench_tooth};
use dentsim_sim::burr::Burr;
use dentsim_sim::cutting::cutter::Cutter;
use dentsim_sim::tissues::surface::Mesher;
use dentsim_sim::cutting::removal::Feed;



fn ticks(c: &mut Criterion) {
    let tooth = bench_tooth().unwrap();
    let (model, tip) = (&tooth.model, |i: usize| bench_stroke_tip(tooth.occlusal, i % 400));
    for spec in ["round:1.0", "cylinder_round:1.0:3", "flame_016"] {
        let burr = Burr::parse(spec).unwrap();
        let mut m = model.clone();
        m.voxelize_for_cutting().unwrap();
        let mut cutter = Cutter::default();
        let mut i = 0;
        c.bench_function(&format!("cut tick {spec}"), |b| {
            b.iter(|| {
                cutter.cut_with(&mut m, &burr, tip(i), tip(i + 1), Feed::Geometric).unwrap();
                i += 1;
            })
        });
    }
    let burr = Burr::round(1.0).unwrap();
    let mut m = model.clone();
    let mut mesher = Mesher::full(&m).unwrap();
    let mut cutter = Cutter::default();
    let mut dirty = Vec::new();
    let mut i = 0;
    c.bench_function("cut tick + remesh round:1.0", |b| {
        b.iter(|| {
            cutter.cut_with(&mut m, &burr, tip(i), tip(i + 1), Feed::Geometric).unwrap();
            dirty.clear();
            cutter.take_dirty(&mut dirty);
            mesher.update(&m, &dirty).unwrap();
            i += 1;
        })
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(30);
    targets = ticks
}
criterion_main!(benches);
