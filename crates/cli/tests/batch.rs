//! `dentsim batch`: a cohort run whole, and as two shards then --merge, give one report.
mod common;
use common::{dentsim, GROOVE};

#[test]
fn shards_and_merge_give_the_whole_runs_report_and_errors_name_what_is_missing() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("groove.csv"), GROOVE).unwrap();
    let manifest = dir.path().join("manifest.json");
    std::fs::write(
        &manifest,
        r#"{"scans": [{"name": "fine", "phantom": true, "voxel_mm": 0.1}, {"name": "coarse", "phantom": true, "voxel_mm": 0.15}],
            "preparations": [{"name": "round", "path": "groove.csv", "burr": "round:1.0"},
                             {"name": "at2N", "path": "groove.csv", "burr": "round:1.0", "force_n": 2}]}"#,
    )
    .unwrap();
    let (m, p) = (manifest.to_str().unwrap(), |d: &std::path::Path| d.to_str().unwrap().to_owned());
    let whole = dir.path().join("whole");
    let run = dentsim(&["batch", m, "--out", &p(&whole)]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    assert!(String::from_utf8_lossy(&run.stdout).contains("4 cases"));

    let sharded = dir.path().join("sharded");
    let run = dentsim(&["batch", m, "--out", &p(&sharded), "--shard", "1/2"]);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let early = dentsim(&["batch", m, "--out", &p(&sharded), "--merge", "--shard", "0/2"]);
    let err = String::from_utf8_lossy(&early.stderr);
    assert!(!early.status.success() && err.contains("fine__round (shard 0/2)") && !err.contains("coarse__"), "{err}");
    assert!(dentsim(&["batch", m, "--out", &p(&sharded), "--shard", "0/2"]).status.success());
    assert!(dentsim(&["batch", m, "--out", &p(&sharded), "--merge", "--shard", "0/2"]).status.success());

    let rows = |d: &std::path::Path| -> Vec<String> {
        let text = std::fs::read_to_string(d.join("report.csv")).unwrap();
        text.lines().map(|l| l.rsplit_once(',').unwrap().0.to_owned()).collect() // less seconds
    };
    assert_eq!(rows(&whole), rows(&sharded));
    assert_eq!(rows(&whole).len(), 1 + 4 * 3, "a header and a row per case and tissue");
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(sharded.join("report.json")).unwrap()).unwrap();
    assert_eq!(json.as_array().unwrap().len(), 4);

    let bad = dentsim(&["batch", m, "--out", &p(&whole), "--shard", "2/2"]);
    assert!(!bad.status.success() && String::from_utf8_lossy(&bad.stderr).contains("shard"));
}
