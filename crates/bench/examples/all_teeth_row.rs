//! The `all_teeth_arch` row alone (`quick`: the 3-tooth scan), as JSON, with each tooth's timings.
fn main() {
    let quick = std::env::args().any(|a| a == "quick");
    match dentsim_bench::all_teeth(quick) {
        Ok(row) => println!("{}", serde_json::to_string(&row).unwrap_or_default()),
        Err(e) => eprintln!("{e}"),
    }
}
