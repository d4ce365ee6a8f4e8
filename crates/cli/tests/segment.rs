//! `dentsim phantom` and `dentsim segment` end to end, in every format, on real package files and
//! on bad input.
use std::path::Path;
use std::process::{Command, Output};

fn dentsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_dentsim")).args(args).env("RUST_BACKTRACE", "0").output().unwrap()
}

fn ok(out: &Output) -> String {
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn volumes(report: &Path) -> Vec<(String, f64)> {
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(report).unwrap()).unwrap();
    json["tissues"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| (t["name"].as_str().unwrap().to_owned(), t["volume_mm3"].as_f64().unwrap()))
        .collect()
}

#[test]
fn the_phantom_segments_alike_from_every_format() {
    let dir = tempfile::tempdir().unwrap();
    let d = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let mut results = Vec::new();
    for (format, input) in [("nifti", d("scan.nii.gz")), ("mha", d("scan.mha")), ("dicom", d("series"))] {
        ok(&dentsim(&["phantom", "--format", format, "--out", &input]));
        let vdb = d(&format!("{format}.vdb"));
        let stdout = ok(&dentsim(&["segment", &input, "--out", &vdb, "--tooth", "36"]));
        assert!(stdout.contains("calibration"), "{stdout}");
        let report = dir.path().join(format!("{format}.vdb.json"));
        let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
        assert_eq!(json["fdi"], 36);
        assert!(json["calibration"]["method"].as_str().is_some_and(|m| !m.is_empty()));
        let listing = Command::new("vdb_print").arg("-l").arg(&vdb).output().unwrap();
        let listing = String::from_utf8_lossy(&listing.stdout);
        for name in ["enamel", "dentin", "pulp"] {
            assert!(listing.contains(name), "{listing}");
        }
        results.push((format, volumes(&report)));
    }
    // The molar's tissues, whatever the file format (DICOM stores int16, hence the tolerance).
    let (_, reference) = &results[0];
    let names: Vec<_> = reference.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["enamel", "dentin", "pulp"]);
    for (format, found) in &results[1..] {
        for ((name, a), (_, b)) in reference.iter().zip(found) {
            assert!((a / b - 1.0).abs() < 1e-3, "{format} {name}: {b} vs {a}");
        }
    }
    // Enamel 374.5, dentin 441.2 mm³ in the phantom's ground truth (crates/sim/tests/scan_accuracy.rs).
    assert!((reference[0].1 / 375.69 - 1.0).abs() < 0.02, "{reference:?}");
    assert!((reference[1].1 / 441.98 - 1.0).abs() < 0.02, "{reference:?}");
}

#[test]
fn real_scans_without_a_tooth_fail_clearly() {
    let dir = tempfile::tempdir().unwrap();
    for input in [
        "/usr/lib/python3/dist-packages/pydicom/data/test_files/CT_small.dcm",
        "/usr/lib/python3/dist-packages/nibabel/tests/data/standard.nii.gz",
    ] {
        assert!(Path::new(input).exists(), "{input} missing: install python3-pydicom and python3-nibabel");
        let out = dir.path().join("out.vdb");
        let run = dentsim(&["segment", input, "--out", out.to_str().unwrap()]);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{input}: a scan without teeth gave tissues");
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(stderr.contains(input), "the error names the scan: {stderr}");
        assert!(!out.exists(), "nothing written for {input}");
    }
}

#[test]
fn bad_input_names_the_file_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let scan = dir.path().join("scan.nii");
    ok(&dentsim(&["phantom", "--format", "nifti", "--out", scan.to_str().unwrap()]));
    let bytes = std::fs::read(&scan).unwrap();
    let truncated = dir.path().join("truncated.nii");
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
    let empty = dir.path().join("empty_folder");
    std::fs::create_dir(&empty).unwrap();
    let out = dir.path().join("out.vdb");
    let out_arg = out.to_str().unwrap();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["segment", truncated.to_str().unwrap(), "--out", out_arg], "truncated.nii"),
        (vec!["segment", empty.to_str().unwrap(), "--out", out_arg], "empty_folder"),
        (vec!["segment", scan.to_str().unwrap(), "--out", out_arg, "--max-memory-gib", "0.001"], "scan.nii"),
        (vec!["segment", scan.to_str().unwrap(), "--out", out_arg, "--tooth", "19"], "19"),
        (vec!["segment", scan.to_str().unwrap(), "--out", out_arg, "--thresholds", "tongue=3"], "tongue"),
        (vec!["segment", scan.to_str().unwrap(), "--out", out_arg, "--voxel", "0"], "voxel size"),
    ];
    for (args, expected) in cases {
        let run = dentsim(&args);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{args:?} accepted");
        assert!(stderr.contains(expected), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(!out.exists(), "nothing written for {args:?}");
    }
}

/// The feature's name elsewhere (sim's TissuesFromScan, the plugin's "Tissues From Scan") is an
/// alias of `segment`.
#[test]
fn tissues_from_scan_is_segment() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_dentsim")).args(["tissues-from-scan", "--help"]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(help.contains("--voxel") && help.contains("--tooth"), "{help}");
}
