//! Replays the kept corpus (fuzz/corpus/TARGET) and the crashers found (fuzz/crashers/TARGET)
//! through each target: seconds, with plain stable cargo. Crashers of `vdb_unguarded` crash
//! OpenVDB's own reader in-process; they go through the guarded reader and must be errors.
use std::path::Path;

fn files(dir: &Path) -> Vec<std::path::PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else { return Vec::new() };
    let mut out: Vec<_> = entries.map(|e| e.unwrap().path()).filter(|p| p.is_file()).collect();
    out.sort();
    out
}

#[test]
fn corpus_replays_through_every_target() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut total = 0;
    for (name, target) in dentsim_fuzz::TARGETS {
        let corpus = files(&root.join("corpus").join(name));
        assert!(!corpus.is_empty(), "no corpus for target {name}");
        for f in &corpus {
            let guarded: fn(&[u8]) = if *name == "vdb_unguarded" { dentsim_fuzz::vdb } else { *target };
            guarded(&std::fs::read(f).unwrap());
        }
        total += corpus.len();
    }
    println!("{total} corpus files replayed");
}

#[test]
fn crashers_found_by_fuzzing_stay_fixed() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    // A fuzz_vdb crasher: an error quoting 300 characters of a garbage grid name (over 600 bytes).
    let vdb = files(&root.join("crashers/vdb"));
    assert!(!vdb.is_empty(), "the kept crashers of the vdb target");
    for f in vdb {
        dentsim_fuzz::vdb(&std::fs::read(f).unwrap());
    }
}

#[test]
fn openvdb_crashers_are_errors_through_the_guarded_reader() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let crashers = files(&root.join("crashers/vdb_unguarded"));
    assert!(!crashers.is_empty(), "the kept crashers of OpenVDB's reader");
    for f in crashers {
        let bytes = std::fs::read(&f).unwrap();
        let limits = dentsim_vdb::ReadLimits { max_bytes: 512 << 20, ..Default::default() };
        // Each overflows a heap buffer in OpenVDB's bloscFromStream: 7 of the 9 kept abort or
        // segfault a plain build, 2 overflow silently and then throw. All are one-line errors.
        let e = dentsim_vdb::read_bytes(&bytes, &limits).expect_err(&format!("{} was read", f.display()));
        assert!(!e.contains('\n') && e.chars().count() <= 301, "{}: {e:.300}", f.display());
    }
}

/// fuzz_scan's crashers: DICOM files whose garbled headers made dicom-rs allocate gigabytes (an
/// abort under a memory limit). Each is now refused before dicom-rs reads it, naming the element
/// whose length runs past the end of the file.
#[test]
fn dicom_headers_stating_lengths_past_the_file_are_refused_before_reading() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let found = files(&root.join("crashers/scan"));
    assert!(!found.is_empty(), "the kept crashers of the scan target");
    let dir = tempfile::tempdir().unwrap();
    for f in found {
        let data = std::fs::read(&f).unwrap();
        // The target's first byte picks the reader; these are DICOM (0).
        assert_eq!(data[0] % 4, 0, "{}", f.display());
        let path = dir.path().join("input.dcm");
        std::fs::write(&path, &data[1..]).unwrap();
        let e = dentsim_cbct::read(&path, &dentsim_cbct::ReadOptions::default()).unwrap_err().to_string();
        assert!(e.contains("input.dcm") && e.contains("states a length"), "{}: {e}", f.display());
        dentsim_fuzz::scan(&data);
    }
}
