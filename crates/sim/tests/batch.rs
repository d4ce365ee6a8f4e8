//! Batch planning: shards of a cohort merge into the report the whole run writes.
use dentsim_sim::plan::batch::{merge, run_shard, Manifest, Shard, REPORT_CSV};
use dentsim_sim::tissues::table::TissueTable;

fn cohort(dir: &std::path::Path) -> std::path::PathBuf {
    let mut groove = String::from("t,x,y,z,qw,qx,qy,qz,cut\n0,-1.5,0,5.6,1,0,0,0,0\n");
    for i in 0..=20 {
        groove += &format!("{},{},0,4.2,1,0,0,0,1\n", 0.01 * f64::from(i + 1), -1.5 + 0.15 * f64::from(i));
    }
    std::fs::write(dir.join("groove.csv"), groove).unwrap();
    let manifest = r#"{
      "scans": [{"name": "a", "phantom": true, "voxel_mm": 0.1}, {"name": "b", "phantom": true, "voxel_mm": 0.12}],
      "preparations": [{"name": "round", "path": "groove.csv", "burr": "round:1.0"},
                       {"name": "flat", "path": "groove.csv", "burr": "cylinder_flat:1.2:4", "force_n": 2}]
    }"#;
    std::fs::write(dir.join("manifest.json"), manifest).unwrap();
    dir.join("manifest.json")
}

/// The report without its wall times (which differ run to run).
fn without_seconds(csv: &str) -> Vec<String> {
    csv.lines().map(|l| l.rsplit_once(',').unwrap().0.to_string()).collect()
}

#[test]
fn shards_cover_every_case_once_and_merge_into_the_whole_runs_report() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = Manifest::read(&cohort(dir.path())).unwrap();
    let names: Vec<_> = manifest.cases().into_iter().map(|c| c.name).collect();
    assert_eq!(names, ["a__round", "a__flat", "b__round", "b__flat"]);
    let table = TissueTable::default();

    let whole = dir.path().join("whole");
    run_shard(&manifest, &whole, Shard::WHOLE, &table, &mut |_, _| {}).unwrap();
    let whole_reports = merge(&manifest, &whole, 1).unwrap();
    assert!(whole_reports[0].tissues.iter().any(|t| t.name == "enamel" && t.removed_mm3 > 0.5), "{:?}", whole_reports[0]);

    let sharded = dir.path().join("sharded");
    let mut ran = Vec::new();
    for i in 0..3 {
        let shard = Shard::parse(&format!("{i}/3")).unwrap();
        ran.extend(run_shard(&manifest, &sharded, shard, &table, &mut |_, _| {}).unwrap().into_iter().map(|r| r.case));
        if i == 0 {
            let err = merge(&manifest, &sharded, 3).err().unwrap().to_string();
            assert!(err.contains("b__flat (shard 2/3)"), "{err}");
        }
    }
    assert_eq!(ran, names, "every case once, in order");
    merge(&manifest, &sharded, 3).unwrap();
    let read = |d: &std::path::Path| std::fs::read_to_string(d.join(REPORT_CSV)).unwrap();
    assert_eq!(without_seconds(&read(&whole)), without_seconds(&read(&sharded)));
    assert!(sharded.join("cases/b__flat/tissues.vdb").exists());
}

#[test]
fn bad_manifests_and_shards_are_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let path = cohort(dir.path());
    let text = std::fs::read_to_string(&path).unwrap();
    for (broken, expected) in [
        (text.replace("\"phantom\": true, \"voxel_mm\": 0.1}", "\"voxel_mm\": 0.1}"), "scan 'a'"),
        (text.replace("\"name\": \"b\"", "\"name\": \"a\""), "appears twice"),
        (text.replace("\"name\": \"flat\"", "\"name\": \"../flat\""), "preparation '../flat'"),
        (text.replace("\"burr\": \"round:1.0\"", "\"bur\": \"round:1.0\""), "unknown field"),
    ] {
        std::fs::write(&path, broken).unwrap();
        let err = Manifest::read(&path).err().unwrap().to_string();
        assert!(err.contains(expected) && err.contains("manifest.json"), "{err}");
    }
    for bad in ["2/2", "1", "a/3", "0/0"] {
        let err = Shard::parse(bad).err().unwrap().to_string();
        assert!(err.contains("shard") && err.contains(bad), "{err}");
    }
}
