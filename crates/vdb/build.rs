// Compiles cpp/vdb against Debian's OpenVDB 10 (see REFERENCE.md "Building on Debian 12").
use std::path::Path;

const SOURCES: [&str; 7] = ["level_set.cc", "reader.cc", "cut.cc", "mesh.cc", "files.cc", "sample.cc", "offset.cc"];

fn main() {
    // Read when the script runs, not baked in when it is compiled: a build script compiled for
    // one checkout and reused from a shared target folder by another read the first one's files.
    let manifest = std::env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR");
    let cpp = Path::new(&manifest).join("../../cpp");
    let vdb = cpp.join("vdb");
    // The benchmark peers (feature `peer`) are compiled only for the bench crate.
    let peer = std::env::var_os("CARGO_FEATURE_PEER").is_some();
    let bridges: &[&str] = if peer { &["src/sys.rs", "src/peer.rs"] } else { &["src/sys.rs"] };
    let peer_sources = if peer { &["peer.cc"][..] } else { &[] };
    cxx_build::bridges(bridges)
        .files(SOURCES.iter().chain(peer_sources).map(|s| vdb.join(s)))
        .include(&cpp)
        .std("c++17")
        // OpenVDB's templates are far too slow unoptimised, even in test builds.
        .opt_level(2)
        .flag_if_supported("-Wno-deprecated-declarations")
        .flag_if_supported("-Wno-unused-parameter")
        .compile("dentsim-vdb-cpp");
    for lib in ["openvdb", "tbb", "Imath-3_1"] {
        println!("cargo:rustc-link-lib={lib}");
    }
    println!("cargo:rerun-if-changed=src/sys.rs");
    println!("cargo:rerun-if-changed=src/peer.rs");
    for entry in std::fs::read_dir(&vdb).expect("cpp/vdb exists") {
        println!("cargo:rerun-if-changed={}", entry.expect("readable dir").path().display());
    }
}
