//! `dentsim session --burr`: the session cuts with the burr named (any ISO shape, as `prepare`
//! takes it), records it in the log and summary, replays bit for bit, and refuses a bad spec.
use std::path::Path;
use std::process::Command;

use dentsim_sim::tissues::capsule::CapsuleTooth;
use dentsim_sim::tissues::table::TissueTable;

fn dentsim() -> Command {
    Command::new(env!("CARGO_BIN_EXE_dentsim"))
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))).unwrap()
}

#[test]
fn session_cuts_with_the_burr_named_and_replays_it() {
    let dir = tempfile::tempdir().unwrap();
    let start = dir.path().join("start.vdb");
    CapsuleTooth::default().build(0.08, &TissueTable::default()).unwrap().save(&start).unwrap();
    let out = dir.path().join("session");
    let device = "hand:start=0:0:5.8,target=0:0:4.0,push=1,pedal=1,duration=0.5";
    let run = dentsim().arg("session").arg("--tissues").arg(&start).args(["--device", device, "--burr", "taper_flat:1.2:3"]).arg("--out").arg(&out).output().unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let summary = json(&out.join("summary.json"));
    assert_eq!(summary["burr"], "taper_flat:1.2:3");
    let enamel = summary["tissues"].as_array().unwrap().iter().find(|t| t["name"] == "enamel").unwrap().clone();
    assert!(enamel["removed_mm3"].as_f64().unwrap() > 0.005, "{enamel}");
    let log = dentsim_sim::session::log::SessionLog::read(&out.join("session.dslog")).unwrap();
    assert_eq!(log.header.params.burr, "taper_flat:1.2:3");

    let again = dir.path().join("replay");
    let run = dentsim().arg("replay").arg(out.join("session.dslog")).arg("--tissues").arg(&start).arg("--out").arg(&again).output().unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let replayed = json(&again.join("replay.json"));
    assert_eq!(replayed["hashes_match_session"], true);
    assert_eq!(replayed["ticks_cut_differently"], 0);

    // A bad spec: refused, naming the burr and what is wrong, nothing written.
    let bad = dir.path().join("bad");
    let run = dentsim().arg("session").arg("--tissues").arg(&start).args(["--device", device, "--burr", "cylinder_flat:1.2:x"]).arg("--out").arg(&bad).output().unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert!(stderr.contains("burr 'cylinder_flat:1.2:x'") && stderr.contains("length 'x'"), "{stderr}");
    assert!(!bad.exists());
}
