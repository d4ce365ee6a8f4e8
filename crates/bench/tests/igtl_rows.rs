//! The OpenIGTLink rows run end to end: a real-time session fed by the reference library's
//! server, and the reference library at both ends, in the same run. Figures are printed, not
//! asserted (speed goals are `dentsim bench`'s); the counts and values are checked.
#[test]
fn igtl_round_trip_rows_measure_both_sides() {
    // the tissues' voxel does not matter here; a coarse tooth starts the session sooner
    let tooth = dentsim_bench::bench_tooth_at(dentsim_bench::QUICK_VOXEL_MM).unwrap();
    let poses: usize = std::env::var("DENTSIM_IGTL_POSES").ok().and_then(|v| v.parse().ok()).unwrap_or(300);
    let rows = dentsim_bench::igtl::igtl_round_trip(&tooth, poses).unwrap();
    for r in &rows {
        println!("{:<18} p50 {:>9.1} µs  p99 {:>9.1} µs  p99.9 {:>9.1?}  peer p50 {:>9.1} µs  {}", r.name, r.ours_median_us, r.ours_p99_us, r.ours_p999_us, r.peer_median_us, r.peer);
    }
    assert_eq!(rows.iter().map(|r| r.name.as_str()).collect::<Vec<_>>(), ["igtl_round_trip", "loop_period_igtl"]);
    let rt = &rows[0];
    assert!(rt.ours_median_us > 0.0 && rt.ours_p99_us >= rt.ours_median_us && rt.peer_median_us > 0.0 && rt.ratio.is_finite());
    // Beside its goal, the loop row gives the empty loop's periods (the machine's floor).
    let lp = &rows[1];
    assert!(lp.ours_median_us > 0.0 && lp.ours_p999_us.is_some_and(|p| p >= lp.ours_p99_us));
    assert!(lp.peer.contains("empty 1 kHz loop") && lp.peer.contains("p99.9"), "{}", lp.peer);
}
