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
    build_reader(&vdb.join("read_child.cc"));
    println!("cargo:rerun-if-changed=src/sys.rs");
    println!("cargo:rerun-if-changed=src/peer.rs");
    println!("cargo:rerun-if-changed={}", vdb.display());
    for entry in std::fs::read_dir(&vdb).expect("cpp/vdb exists") {
        println!("cargo:rerun-if-changed={}", entry.expect("readable dir").path().display());
    }
}

/// The reader program `read_file` runs for each hostile read (`src/reader_process.rs` embeds it),
/// linked into OUT_DIR with the same compiler. Sanitizer flags meant for the library's objects are
/// left out: the reader is a program of its own, and the library's guard is what they test.
fn build_reader(source: &Path) {
    let out = Path::new(&std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR")).join("dentsim-vdb-reader");
    let compiler = cc::Build::new().cpp(true).cargo_warnings(false).get_compiler();
    let mut cmd = std::process::Command::new(compiler.path());
    cmd.args(compiler.args().iter().filter(|a| {
        let a = a.to_string_lossy();
        !a.starts_with("-fsanitize") && !a.starts_with("-fno-sanitize") && a != "-c"
    }));
    cmd.args(["-std=c++17", "-O2", "-g0", "-Wno-deprecated-declarations", "-o"])
        .arg(&out)
        .arg(source)
        .args(["-lopenvdb", "-ltbb", "-lImath-3_1", "-lpthread"]);
    let status = cmd.status().unwrap_or_else(|e| panic!("running {cmd:?}: {e}"));
    assert!(status.success(), "building the reader program failed: {cmd:?}");
}
