//! The local-cut primitives: logged and offset subtraction, journal replay, dense reads, and the
//! curvature-corrected volume measure.
use std::f64::consts::PI;

use dentsim_vdb::{DensePatch, LevelSet, Measure, VoxelChange};
use glam::{DVec3, IVec3};

const H: f64 = 0.05;

fn ball(r: f64) -> LevelSet {
    LevelSet::from_sdf(H, 3.0, DVec3::splat(-r), DVec3::splat(r), |p| p.length() - r).unwrap()
}

/// A tool ball of radius `r` about `c`, sampled over its box plus a margin.
fn tool(c: DVec3, r: f64) -> DensePatch {
    let lo = ((c - r - 0.3) / H).floor().as_ivec3();
    let hi = ((c + r + 0.3) / H).ceil().as_ivec3();
    let dims = (hi - lo + IVec3::ONE).as_uvec3();
    let mut values = Vec::new();
    for k in lo.z..=hi.z {
        for j in lo.y..=hi.y {
            for i in lo.x..=hi.x {
                values.push(((IVec3::new(i, j, k).as_dvec3() * H - c).length() - r) as f32);
            }
        }
    }
    DensePatch { index_min: lo, dims: dims.to_array(), values, spans: Vec::new() }
}

#[test]
fn corrected_volume_is_second_order_for_small_balls() {
    for r in [0.3, 0.5, 1.0, 2.0] {
        let v = ball(r).volume();
        let exact = 4.0 / 3.0 * PI * r * r * r;
        println!("ball r = {r}: volume {v:.5} vs {exact:.5} ({:+.3} %)", (v / exact - 1.0) * 100.0);
        assert!((v / exact - 1.0).abs() < 0.001, "r = {r}: {v} vs {exact}");
    }
}

#[test]
fn logged_cut_replays_back_exactly() {
    let mut g = ball(1.5);
    let patch = tool(DVec3::new(1.2, 0.0, 0.3), 0.5);
    let lo = patch.index_min;
    let dims = patch.dims;
    let n = patch.values.len();
    let mut before = vec![0f32; n];
    g.read_dense(lo, dims, &mut before).unwrap();
    let v0 = g.volume();
    let mut log: Vec<VoxelChange> = Vec::with_capacity(1 << 16);
    let stats = g.subtract_logged(&patch, 0.0, Measure::Volume, &mut log).unwrap();
    assert_eq!(stats.changed_voxels as usize, log.len());
    assert!((v0 - g.volume() - stats.removed_mm3).abs() < 1e-9 * v0.max(1.0) + 1e-7, "bookkeeping");
    // Every changed voxel's new value is max(old, -tool).
    let mut now: Vec<VoxelChange> = log.clone();
    g.read_voxels(&mut now);
    for (old, new) in log.iter().zip(&now) {
        assert!(new.value > old.value);
    }
    log.reverse();
    g.write_voxels(&log);
    let mut after = vec![0f32; n];
    g.read_dense(lo, dims, &mut after).unwrap();
    assert_eq!(before, after);
    assert_eq!(g.volume(), v0);
}

#[test]
fn an_unmeasured_cut_changes_the_same_voxels_to_the_same_values() {
    let patch = tool(DVec3::new(1.2, 0.3, -0.2), 0.5);
    let (mut measured, mut skipped) = (ball(1.5), ball(1.5));
    let (mut log_m, mut log_s) = (Vec::new(), Vec::new());
    let m = measured.subtract_logged(&patch, 0.05, Measure::Volume, &mut log_m).unwrap();
    let s = skipped.subtract_logged(&patch, 0.05, Measure::Skip, &mut log_s).unwrap();
    assert!(m.removed_mm3 > 0.01, "{}", m.removed_mm3);
    assert_eq!(s.removed_mm3, 0.0);
    assert_eq!(m.changed_voxels, s.changed_voxels);
    assert_eq!(log_m, log_s);
    assert_eq!(measured.content_hash(), skipped.content_hash());
}

#[test]
fn an_offset_shrinks_the_tool_and_the_dry_run_predicts_it() {
    let patch = tool(DVec3::new(1.5, 0.0, 0.0), 0.6);
    let offsets = [0.0f32, 0.1, 0.2, 0.3, 0.7];
    let mut predicted = [0f64; 5];
    ball(1.5).removal_by_offset(&patch, &offsets, &mut predicted).unwrap();
    assert!(predicted.windows(2).all(|w| w[0] >= w[1]), "{predicted:?}");
    assert_eq!(predicted[4], 0.0);
    for (o, p) in offsets.iter().zip(predicted) {
        let mut g = ball(1.5);
        let s = g.subtract_logged(&patch, *o, Measure::Volume, &mut Vec::new()).unwrap();
        // The dry run leaves out the curvature term: within a few per cent of the real cut.
        assert!((s.removed_mm3 - p).abs() <= 0.05 * p + 1e-4, "offset {o}: {} vs {p}", s.removed_mm3);
    }
}

#[test]
fn leaf_origins_and_dense_reads_agree_with_the_reader() {
    let g = ball(0.8);
    let leaves = g.leaf_origins();
    assert_eq!(leaves.len() as u64, g.leaf_count());
    assert!(leaves.iter().all(|o| o.x % 8 == 0 && o.y % 8 == 0 && o.z % 8 == 0));
    let mut v = vec![0f32; 27];
    g.read_dense(IVec3::new(15, -1, -1), [3, 3, 3], &mut v).unwrap();
    let mut r = g.reader();
    assert_eq!(v[13], r.value(DVec3::new(16.0 * H, 0.0, 0.0)));
    assert!(g.read_dense(IVec3::ZERO, [3, 3, 3], &mut v[..5]).is_err());
}

#[test]
fn a_copy_follows_a_cut_by_writing_its_new_values() {
    let mut g = ball(1.5);
    let mut copy = g.clone();
    let patch = tool(DVec3::new(1.1, -0.2, 0.4), 0.6);
    let mut log = Vec::new();
    let stats = g.subtract_logged(&patch, 0.0, Measure::Skip, &mut log).unwrap();
    let mut handed = Vec::new();
    g.last_cut_values(&mut handed);
    assert_eq!(handed.len() as u64, stats.changed_voxels);
    assert!(handed.len() > 100, "the cut changed {} voxels", handed.len());
    // Same voxels as the log, each with the value the grid now holds.
    let mut now = log.clone();
    g.read_voxels(&mut now);
    assert_eq!(handed, now);
    assert_ne!(copy.content_hash(), g.content_hash());
    copy.write_voxels(&handed);
    assert_eq!(copy.content_hash(), g.content_hash());
}
