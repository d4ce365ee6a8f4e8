//! `dentsim session` and `dentsim replay` end to end: files, figures, bit-exact replay, bad input.
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use dentsim_sim::tissues::model::TissueModel;
use dentsim_sim::tissues::capsule::CapsuleTooth;
use dentsim_sim::tissues::table::TissueTable;

fn dentsim() -> Command {
    Command::new(env!("CARGO_BIN_EXE_dentsim"))
}

/// The capsule phantom at 0.08 mm (fast to build), saved as the session's start.
fn phantom(dir: &Path) -> PathBuf {
    let path = dir.join("start.vdb");
    let mut model = CapsuleTooth::default().build(0.08, &TissueTable::default()).unwrap();
    model.save(&path).unwrap();
    path
}

/// Down onto the top (z = 5.0) cutting, sideways, and up.
const PATH_CSV: &str = "t,x,y,z,qw,qx,qy,qz,rpm,cut\n\
                        0,0,0,5.8,1,0,0,0,200000,1\n\
                        0.3,0,0,4.6,1,0,0,0,200000,1\n\
                        0.6,0.6,0.2,4.5,0.9961947,0.0871557,0,0,200000,1\n\
                        0.8,0.6,0.2,5.8,1,0,0,0,0,0\n";

fn ok(run: &Output) -> String {
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    String::from_utf8_lossy(&run.stdout).into_owned()
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))).unwrap()
}

fn tissue<'a>(summary: &'a serde_json::Value, name: &str) -> &'a serde_json::Value {
    summary["tissues"].as_array().unwrap().iter().find(|t| t["name"] == name).unwrap_or_else(|| panic!("{name}"))
}

#[test]
fn scripted_session_writes_everything_and_replay_is_bit_exact() {
    let dir = tempfile::tempdir().unwrap();
    let start = phantom(dir.path());
    std::fs::write(dir.path().join("path.csv"), PATH_CSV).unwrap();
    let out = dir.path().join("session");
    let device = format!("scripted:{}", dir.path().join("path.csv").display());
    let run = dentsim().arg("session").arg("--tissues").arg(&start).args(["--device", &device]).arg("--out").arg(&out).output().unwrap();
    let text = ok(&run);
    println!("{text}");

    let summary = json(&out.join("summary.json"));
    // 0.8 s at 1 kHz: ticks 0..=800 plus the one that sees the path finished.
    let ticks = summary["ticks"].as_u64().unwrap();
    assert!((800..=802).contains(&ticks), "{ticks}");
    assert_eq!(summary["missed_deadlines"], 0, "not real time: no deadlines to miss");
    let max_force = summary["max_force_n"].as_f64().unwrap();
    assert!(max_force > 0.0 && max_force <= 7.9, "within the desktop profile: {max_force}");
    let enamel = tissue(&summary, "enamel");
    let removed = enamel["removed_mm3"].as_f64().unwrap();
    // At enamel's removal rate, 0.5 mm³/(N·s) × a few tenths of a newton × ~0.5 s in contact.
    assert!(removed > 0.02, "the path cuts enamel: {removed}");
    let (before, after) = (enamel["volume_before_mm3"].as_f64().unwrap(), enamel["volume_after_mm3"].as_f64().unwrap());
    // The cut reports count voxels the smoothed volume integral sees differently: agree to 15%.
    assert!(((before - after) - removed).abs() < 0.15 * removed, "{before} - {after} vs {removed}");
    assert!(enamel["contact_s"].as_f64().unwrap() > 0.01);
    assert_eq!(tissue(&summary, "pulp")["removed_mm3"], 0.0);

    // The log has a record per tick; the prepared tissues load back with the summary's hashes.
    let log = dentsim_sim::session::log::SessionLog::read(&out.join("session.dslog")).unwrap();
    assert_eq!(log.records.len() as u64, ticks);
    let prepared = TissueModel::load(&out.join("tissues.vdb"), &TissueTable::default()).unwrap();
    for t in &prepared.tissues {
        assert_eq!(format!("{:016x}", t.grid.content_hash()), tissue(&summary, &t.props.name)["content_hash"], "{}", t.props.name);
        let triangles = tissue(&summary, &t.props.name)["triangles"].as_u64().unwrap();
        let stl = std::fs::metadata(out.join(format!("{}.stl", t.props.name))).unwrap().len();
        assert_eq!(stl, 84 + 50 * triangles);
        assert!(out.join(format!("{}.vtp", t.props.name)).is_file());
    }
    assert_no_temporaries(&out);

    // Replay: same hashes, zero force difference, forces.csv with a row per tick, a PNG.
    let again = dir.path().join("replay");
    let run = dentsim().arg("replay").arg(out.join("session.dslog")).arg("--tissues").arg(&start).arg("--out").arg(&again).output().unwrap();
    let text = ok(&run);
    println!("{text}");
    assert!(text.contains("bit-exact"), "{text}");
    let replayed = json(&again.join("replay.json"));
    assert_eq!(replayed["hashes_match_session"], true);
    assert_eq!(replayed["max_force_difference_n"], 0.0);
    assert_eq!(replayed["ticks_cut_differently"], 0);
    for t in summary["tissues"].as_array().unwrap() {
        let name = t["name"].as_str().unwrap();
        assert_eq!(tissue(&replayed, name)["content_hash"], t["content_hash"], "{name}");
    }
    let csv = std::fs::read_to_string(again.join("forces.csv")).unwrap();
    assert_eq!(csv.lines().count() as u64, ticks + 1, "header + a row per tick");
    assert!(csv.lines().skip(1).any(|l| l.ends_with(",enamel")), "contact tissue named");
    let png = std::fs::read(again.join("forces.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    assert_no_temporaries(&again);
}

#[test]
fn simulated_hand_session_cuts_enamel_then_dentin() {
    let dir = tempfile::tempdir().unwrap();
    let start = phantom(dir.path());
    let out = dir.path().join("hand");
    let device = "hand:start=0:0:5.6,target=0:0:2.5,push=2,pedal=1,rpm=400000,duration=4";
    let run = dentsim().arg("session").arg("--tissues").arg(&start).args(["--device", device, "--profile", "omega", "--filter", "biquad"]).arg("--out").arg(&out).output().unwrap();
    println!("{}", ok(&run));
    let summary = json(&out.join("summary.json"));
    assert_eq!(summary["ticks"].as_u64().unwrap(), 4002);
    let enamel = tissue(&summary, "enamel")["removed_mm3"].as_f64().unwrap();
    assert!(enamel > 0.3, "{enamel}");
    let dentin = tissue(&summary, "dentin");
    assert!(dentin["removed_mm3"].as_f64().unwrap() > 0.1 && dentin["contact_s"].as_f64().unwrap() > 0.0, "{dentin}");
    assert_eq!(tissue(&summary, "pulp")["removed_mm3"], 0.0);
    let max_force = summary["max_force_n"].as_f64().unwrap();
    // The hand's spring toward its target 2.5 mm below the top balances ≈ 0.5 N once the burr is
    // a millimetre in (the buried ball's contact gives ≈ k/2); the first touch sinks fast (a small
    // contact area at the removal rate), so the force builds up no higher.
    assert!(max_force > 0.3 && max_force <= 12.0, "{max_force}");
}

#[test]
fn bad_input_names_file_and_field_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let start = phantom(dir.path());
    let csv = dir.path().join("bad.csv");
    std::fs::write(&csv, "t,x,y,z,qw,qx,qy,qz\n0,0,0,5,1,0,0,0\n0.1,0,zz,5,1,0,0,0\n").unwrap();
    let not_vdb = dir.path().join("not.vdb");
    std::fs::write(&not_vdb, "hello").unwrap();
    let good = format!("scripted:{}", dir.path().join("none.csv").display());
    let bad_csv = format!("scripted:{}", csv.display());
    let cases: Vec<(Vec<String>, Vec<String>)> = vec![
        (vec!["--tissues".into(), not_vdb.display().to_string(), "--device".into(), bad_csv.clone()], vec![not_vdb.display().to_string()]),
        (vec!["--tissues".into(), start.display().to_string(), "--device".into(), bad_csv.clone()], vec![csv.display().to_string(), "row 2".into(), "'y'".into()]),
        (vec!["--tissues".into(), start.display().to_string(), "--device".into(), good.clone()], vec!["none.csv".into()]),
        (vec!["--tissues".into(), start.display().to_string(), "--device".into(), "hand:push=lots".into()], vec!["device".into(), "field 'push'".into()]),
        (vec!["--tissues".into(), start.display().to_string(), "--device".into(), bad_csv.clone(), "--profile".into(), "wii".into()], vec!["profile".into(), "wii".into()]),
        (vec!["--tissues".into(), start.display().to_string(), "--device".into(), bad_csv, "--filter".into(), "kalman".into()], vec!["filter".into(), "kalman".into()]),
    ];
    for (i, (args, expected)) in cases.iter().enumerate() {
        let out = dir.path().join(format!("out{i}"));
        let run = dentsim().arg("session").args(args).arg("--out").arg(&out).output().unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{args:?} accepted");
        for e in expected {
            assert!(stderr.contains(e.as_str()), "{args:?}: expected '{e}' in {stderr}");
        }
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(!out.exists(), "nothing written for {args:?}");
    }

    // Replay: a log that is not one, and a start model that is not the session's.
    let garbage = dir.path().join("garbage.dslog");
    std::fs::write(&garbage, "not a log at all").unwrap();
    let out = dir.path().join("r0");
    let run = dentsim().arg("replay").arg(&garbage).arg("--tissues").arg(&start).arg("--out").arg(&out).output().unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success() && stderr.contains("garbage.dslog") && stderr.contains("magic"), "{stderr}");
    assert!(!out.exists());

    std::fs::write(dir.path().join("path.csv"), PATH_CSV).unwrap();
    let session = dir.path().join("s");
    let device = format!("scripted:{}", dir.path().join("path.csv").display());
    ok(&dentsim().arg("session").arg("--tissues").arg(&start).args(["--device", &device]).arg("--out").arg(&session).output().unwrap());
    let out = dir.path().join("r1");
    // The prepared tissues are not what the session started from.
    let run = dentsim().arg("replay").arg(session.join("session.dslog")).arg("--tissues").arg(session.join("tissues.vdb")).arg("--out").arg(&out).output().unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success() && stderr.contains("tissues.vdb") && stderr.contains("content hash"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(!out.exists());
}

fn assert_no_temporaries(dir: &Path) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().into_owned();
        assert!(!name.ends_with(".tmp") && !name.contains(".tmp."), "left behind: {name}");
    }
}
