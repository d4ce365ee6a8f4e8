// Generates the C++ side of the bridge; its header lands in target/cxxbridge/dentsim-ffi/src/
// where cmake/DentsimRust.cmake points the plugin.
fn main() {
    cxx_build::bridge("src/lib.rs").std("c++17").compile("dentsim-ffi-bridge");
    println!("cargo:rerun-if-changed=src/lib.rs");
}
