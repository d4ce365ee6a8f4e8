//! `dentsim segment --all-teeth`: every tooth of the phantom's scan as its own files, the
//! tooth at the point the same as `--point` segments it.
use std::process::{Command, Output};

fn dentsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_dentsim")).args(args).env("RUST_BACKTRACE", "0").output().unwrap()
}

fn ok(out: &Output) -> String {
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn volumes(report: &std::path::Path) -> Vec<f64> {
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(report).unwrap()).unwrap();
    json["tissues"].as_array().unwrap().iter().map(|t| t["volume_mm3"].as_f64().unwrap()).collect()
}

// At 0.1 mm tissues: what is tested is which teeth are written and that both ways agree.
#[test]
fn all_teeth_writes_each_tooth_and_the_pointed_one_matches() {
    let dir = tempfile::tempdir().unwrap();
    let scan = dir.path().join("scan.mha");
    let made = ok(&dentsim(&["phantom", "--format", "mha", "--out", scan.to_str().unwrap()]));
    let point = made.split("near ").nth(1).unwrap().split(" mm").next().unwrap().to_owned();
    let all = ok(&dentsim(&["segment", scan.to_str().unwrap(), "--out", dir.path().join("t.vdb").to_str().unwrap(), "--all-teeth", "--voxel", "0.1"]));
    assert!(all.contains("not identified"), "{all}");
    // the phantom's field of view holds 36 whole and its neighbours 35 and 37 (one cut)
    for n in 1..=3 {
        let report = dir.path().join(format!("t_tooth{n}.vdb.json"));
        assert!(report.exists(), "tooth {n}: {all}");
        let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
        assert_eq!(json["fdi"], 0);
        assert_eq!(json["found"][0], n);
    }
    assert!(!dir.path().join("t_tooth4.vdb").exists(), "{all}");
    // Every tooth closes, the one the field of view cuts too (at the scan's edge): each tissue's
    // volume is about its voxels' (a level set open at the edge read 4888 mm³ of dentin for 308).
    for n in 1..=3 {
        let json: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.path().join(format!("t_tooth{n}.vdb.json"))).unwrap()).unwrap();
        let voxel: f64 = json["scan_spacing_mm"].as_array().unwrap().iter().map(|s| s.as_f64().unwrap()).product();
        for t in json["tissues"].as_array().unwrap() {
            let (volume, voxels) = (t["volume_mm3"].as_f64().unwrap(), t["scan_voxels"].as_f64().unwrap() * voxel);
            assert!((volume / voxels - 1.0).abs() < 0.15, "tooth {n} {}: {volume:.1} mm³ against {voxels:.1} mm³ of voxels (cut: {})", t["name"], json["found"][1]["cut_by_field_of_view"]);
        }
    }
    let one = dir.path().join("one.vdb");
    ok(&dentsim(&["segment", scan.to_str().unwrap(), "--out", one.to_str().unwrap(), "--point", &point, "--voxel", "0.1"]));
    let single = volumes(&dir.path().join("one.vdb.json"));
    let first = volumes(&dir.path().join("t_tooth1.vdb.json"));
    for (a, b) in single.iter().zip(&first) {
        assert!((a / b - 1.0).abs() < 1e-3, "--point {single:?} vs --all-teeth tooth 1 {first:?}");
    }
}
