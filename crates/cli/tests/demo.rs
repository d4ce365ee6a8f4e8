//! `dentsim demo` end to end: the files a user gets, and that their figures agree.
use std::path::Path;
use std::process::Command;

fn dentsim() -> Command {
    Command::new(env!("CARGO_BIN_EXE_dentsim"))
}

fn number(v: &serde_json::Value, key: &str) -> f64 {
    v[key].as_f64().unwrap_or_else(|| panic!("{key} in {v}"))
}

#[test]
fn demo_writes_surfaces_vdb_and_a_consistent_summary() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let run = dentsim().args(["demo", "--voxel", "0.08", "--out"]).arg(&out).output().unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));

    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(number(&summary, "voxel_size_mm"), 0.08);
    let strokes: usize = summary["preparation"].as_array().unwrap().iter().map(|r| r["strokes"].as_array().unwrap().len()).sum();
    assert!(strokes >= 2, "two burrs cut: {}", summary["preparation"]);
    let tissues = summary["tissues"].as_array().unwrap();
    let names: Vec<_> = tissues.iter().map(|t| t["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["enamel", "dentin", "pulp"]);
    for t in tissues {
        let (before, after, removed) =
            (number(t, "volume_before_mm3"), number(t, "volume_after_mm3"), number(t, "removed_mm3"));
        assert!((before - after - removed).abs() < 1e-6 * before, "{t}");
    }
    for t in tissues {
        let (truth, segmented) = (number(t, "true_volume_mm3"), number(t, "volume_before_mm3"));
        assert!((segmented / truth - 1.0).abs() < 0.05, "segmented tooth 36 close to the phantom's truth: {t}");
    }
    assert!(number(&tissues[0], "removed_mm3") > 1.0, "the cavity cuts enamel");
    assert!(number(&tissues[1], "removed_mm3") > 0.0, "and dentin");
    assert_eq!(number(&tissues[2], "removed_mm3"), 0.0, "but not pulp");

    for (name, triangles) in summary["triangles"].as_array().unwrap().iter().map(|p| (p[0].as_str().unwrap(), p[1].as_u64().unwrap())) {
        let stl = std::fs::metadata(out.join(format!("{name}.stl"))).unwrap().len();
        assert_eq!(stl, 84 + 50 * triangles, "{name}.stl holds every triangle");
        let vtp = std::fs::read(out.join(format!("{name}.vtp"))).unwrap();
        let head = String::from_utf8_lossy(&vtp[..2000]);
        assert!(head.contains(&format!(r#"NumberOfPolys="{triangles}""#)), "{head}");
    }

    let print = Command::new("vdb_print").arg("-l").arg(out.join("tissues.vdb")).output().unwrap();
    let listing = String::from_utf8_lossy(&print.stdout);
    assert!(print.status.success());
    for name in names {
        assert!(listing.contains(name), "{listing}");
    }
    assert!(listing.contains("stiffness_n_per_mm"), "{listing}");
    assert_no_temporaries(&out);
}

#[test]
fn bad_arguments_fail_clearly_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&[&str], &str); 3] = [
        (&["--voxel", "-0.1"], "voxel size"),
        (&["--voxel", "5"], "voxel size"),
        (&["--tissues", "/nonexistent/table.toml"], "/nonexistent/table.toml"),
    ];
    for (i, (args, expected)) in cases.into_iter().enumerate() {
        let out = dir.path().join(format!("out{i}"));
        let run = dentsim().arg("demo").args(args).arg("--out").arg(&out).output().unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{args:?} accepted");
        assert!(stderr.contains(expected), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(!out.exists(), "nothing written for {args:?}");
    }
}

#[test]
fn bench_quick_prints_every_row_as_json() {
    let run = dentsim().args(["bench", "--quick", "--json"]).output().unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let rows: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    let rows = rows.as_array().unwrap();
    for expected in ["sdf_sample_near", "sdf_sample_random", "cut_stroke", "force_query", "assess"] {
        let row = rows.iter().find(|r| r["name"] == expected).unwrap_or_else(|| panic!("{expected}"));
        for key in ["ours_median_us", "ours_p99_us", "peer_median_us", "ratio"] {
            assert!(number(row, key) > 0.0, "{expected}.{key}");
        }
        assert!(row["peer"].as_str().is_some_and(|p| !p.is_empty()));
    }
    let segment = rows.iter().find(|r| r["name"] == "segment_scan").expect("segment_scan");
    assert!(number(segment, "ours_median_us") > 0.0 && number(segment, "peak_memory_mb") > 10.0, "{segment}");
    for deadline in ["loop_period", "cut_to_visible"] {
        let row = rows.iter().find(|r| r["name"] == deadline).unwrap_or_else(|| panic!("{deadline}"));
        assert!(number(row, "ours_median_us") > 0.0 && number(row, "ours_p999_us") > 0.0, "{row}");
        assert!(row["peer_median_us"].is_null(), "no peer runs for {deadline}: {row}");
    }
}

fn assert_no_temporaries(dir: &Path) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().into_owned();
        assert!(!name.ends_with(".tmp"), "left behind: {name}");
    }
}
