//! Prints the haptics benchmark rows (until `dentsim bench` calls them).
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut rows = vec![dentsim_sim::bench::force_query(256, 2000)?];
    rows.extend(dentsim_sim::bench::loop_period(2.0)?);
    for r in rows {
        println!("{:<55} ours p50 {:>10.2} µs  p99 {:>10.2} µs | {} {:>10.2} µs", r.name, r.ours_median_us, r.ours_p99_us, r.peer, r.peer_median_us);
    }
    Ok(())
}
