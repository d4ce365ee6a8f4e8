//! Live guidance end to end: a simulated hand drills down the capsule tooth's axis toward its pulp
//! (top at z = 2.0). The session warns of thin dentin before it opens the pulp; its replay warns
//! at the same ticks; `dentsim assess` grades the session's folder, at its end and at any tick,
//! and agrees with the live figure.
mod common;

use std::path::Path;

use dentsim_sim::session::log::{SessionLog, FLAG_PULP_EXPOSED, FLAG_THIN_DENTIN};
use dentsim_sim::tissues::capsule::CapsuleTooth;
use dentsim_sim::tissues::table::TissueTable;

use common::dentsim;

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))).unwrap()
}

fn ok(run: &std::process::Output) -> String {
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    String::from_utf8_lossy(&run.stdout).into_owned()
}

fn p(x: &Path) -> String {
    x.to_str().unwrap().to_owned()
}

/// The capsule phantom at 0.08 mm and a session of the hand pushing toward `target_z`.
fn session(dir: &Path, name: &str, target_z: f64, duration_s: f64) -> std::path::PathBuf {
    let start = dir.join("start.vdb");
    if !start.exists() {
        CapsuleTooth::default().build(0.08, &TissueTable::default()).unwrap().save(&start).unwrap();
    }
    let out = dir.join(name);
    let device = format!("hand:start=0:0:5.6,target=0:0:{target_z},push=2,pedal=1,rpm=400000,duration={duration_s}");
    println!("{}", ok(&dentsim(&["session", "--tissues", &p(&start), "--device", &device, "--out", &p(&out)])));
    out
}

#[test]
fn drilling_into_the_pulp_warns_first_of_thin_dentin_and_replay_warns_at_the_same_ticks() {
    let dir = tempfile::tempdir().unwrap();
    let out = session(dir.path(), "deep", 1.0, 6.0);
    let summary = json(&out.join("summary.json"));
    let g = &summary["guidance"];
    println!("{g:#}");
    assert_eq!(g["thin_dentin_mm"], 0.5);
    assert_eq!(g["pulp_exposed"], true);
    assert!(g["min_remaining_dentin_mm"].as_f64().unwrap() < 0.0);
    let events = g["events"].as_array().unwrap();
    let first = |kind: &str| events.iter().find(|e| e["kind"] == kind).unwrap_or_else(|| panic!("no {kind} event in {events:?}"));
    let (thin, exposed) = (first("thin_dentin"), first("pulp_exposure"));
    assert!(thin["tick"].as_u64() < exposed["tick"].as_u64(), "thin dentin is warned of before the pulp opens");
    let thin_left = thin["min_remaining_dentin_mm"].as_f64().unwrap();
    assert!((0.0..0.5).contains(&thin_left), "{thin_left}");
    assert_eq!(g["pulp_exposure_events"].as_u64().unwrap() as usize, events.iter().filter(|e| e["kind"] == "pulp_exposure").count());

    // The log carries the flags and clearances at those ticks.
    let log = SessionLog::read(&out.join("session.dslog")).unwrap();
    let at = |tick: u64| log.records.iter().find(|r| r.tick == tick).unwrap();
    let t = at(thin["tick"].as_u64().unwrap());
    assert!(t.flags & FLAG_THIN_DENTIN != 0 && (0.0..0.5).contains(&t.clearance_mm), "{t:?}");
    let e = at(exposed["tick"].as_u64().unwrap());
    assert!(e.flags & FLAG_PULP_EXPOSED != 0 && e.clearance_mm < 0.0, "{e:?}");
    // Before the first warning no tick cut closer than the threshold.
    assert!(log.records.iter().take_while(|r| r.tick < t.tick).all(|r| r.flags & (FLAG_THIN_DENTIN | FLAG_PULP_EXPOSED) == 0));

    // Replay: the same events at the same ticks, every tick's guidance as logged.
    let again = dir.path().join("again");
    let text = ok(&dentsim(&["replay", &p(&out.join("session.dslog")), "--tissues", &p(&dir.path().join("start.vdb")), "--out", &p(&again)]));
    assert!(text.contains("PULP EXPOSED") && text.contains("every replayed tick warned as logged"), "{text}");
    let replayed = json(&again.join("replay.json"));
    assert_eq!(replayed["guidance"], *g);
    assert_eq!(replayed["ticks_guided_differently"], 0);
    let csv = std::fs::read_to_string(again.join("forces.csv")).unwrap();
    assert!(csv.starts_with("t_s,fx_n,fy_n,fz_n,f_n,removed_mm3,remaining_dentin_mm,tissue\n"));
    let dentin_column: Vec<f64> = csv.lines().skip(1).filter_map(|l| l.split(',').nth(6).and_then(|v| v.parse().ok())).collect();
    assert!(dentin_column.iter().any(|d| *d < 0.0) && dentin_column.iter().any(|d| (0.0..0.5).contains(d)));

    // Assessed at its end without --original (the summary names the start): the pulp is open.
    let graded = dir.path().join("graded");
    let text = ok(&dentsim(&["assess", &p(&out), "--out", &p(&graded)]));
    assert!(text.contains("at its end"), "{text}");
    let a = json(&graded.join("assessment.json"));
    assert_eq!(a["pulp_exposed"], true);
    assert_eq!(a["session"]["guidance"], *g);
}

#[test]
fn assessing_a_session_at_a_tick_agrees_with_the_live_warning_and_with_a_replay_to_that_tick() {
    let dir = tempfile::tempdir().unwrap();
    let out = session(dir.path(), "deep", 1.0, 6.0);
    let summary = json(&out.join("summary.json"));
    let events = summary["guidance"]["events"].as_array().unwrap().clone();
    let thin = events.iter().find(|e| e["kind"] == "thin_dentin").expect("a thin-dentin event");
    let tick = thin["tick"].as_u64().unwrap();
    let log = SessionLog::read(&out.join("session.dslog")).unwrap();
    let live = log.records.iter().find(|r| r.tick == tick).unwrap().clearance_mm;

    // At the first warning: the dentin the cut left, from the cut surface and the pulp's mesh,
    // is what the live field read at the burr (within a voxel: two independent measures).
    let at_tick = dir.path().join("at_tick");
    let text = ok(&dentsim(&["assess", &p(&out), "--tick", &tick.to_string(), "--out", &p(&at_tick)]));
    assert!(text.contains(&format!("at tick {tick}")), "{text}");
    let a = json(&at_tick.join("assessment.json"));
    let graded = a["min_remaining_dentin_mm"].as_f64().unwrap();
    println!("tick {tick}: live {live:.4} mm, assessed {graded:.4} mm");
    assert!((graded - live).abs() < 0.08, "live {live} vs assessed {graded}");
    assert_eq!(a["pulp_exposed"], false);
    assert_eq!(a["session"]["tick"], tick);
    // Guidance up to the tick: the first warning is its last event.
    assert_eq!(a["session"]["guidance"]["events"].as_array().unwrap().len(), 1);

    // A replay stopped at that tick holds the same tissues.
    let replayed = dir.path().join("replayed");
    ok(&dentsim(&["replay", &p(&out.join("session.dslog")), "--tissues", &p(&dir.path().join("start.vdb")), "--until-tick", &tick.to_string(), "--out", &p(&replayed)]));
    let r = json(&replayed.join("replay.json"));
    assert_eq!(r["until_tick"], tick);
    assert_eq!(r["ticks"], tick + 1);
    let from_replay = dir.path().join("from_replay");
    ok(&dentsim(&["assess", &p(&replayed), "--out", &p(&from_replay)]));
    let b = json(&from_replay.join("assessment.json"));
    assert_eq!(a["tissues"], b["tissues"]);
    assert_eq!(a["min_remaining_dentin_mm"], b["min_remaining_dentin_mm"]);

    // Past the log's end, and a folder that is no session: errors that say so, nothing written.
    let last = log.records.last().unwrap().tick;
    let bad = dentsim(&["assess", &p(&out), "--tick", &(last + 5).to_string(), "--out", &p(&dir.path().join("nothing"))]);
    let e = String::from_utf8_lossy(&bad.stderr);
    assert!(!bad.status.success() && e.contains("session.dslog") && e.contains(&format!("0 to {last}")), "{e}");
    assert!(!dir.path().join("nothing").exists());
    let bad = dentsim(&["assess", &p(&dir.path().join("start.vdb")), "--out", &p(&dir.path().join("nothing"))]);
    let e = String::from_utf8_lossy(&bad.stderr);
    assert!(!bad.status.success() && e.contains("--original"), "{e}");
}

#[test]
fn a_shallow_cut_warns_of_nothing() {
    let dir = tempfile::tempdir().unwrap();
    // Into the dentin (top at z = 3.5) with the hand's target 0.7 mm above the pulp.
    let out = session(dir.path(), "shallow", 2.7, 4.0);
    let g = &json(&out.join("summary.json"))["guidance"];
    println!("{g:#}");
    assert_eq!(g["events"].as_array().unwrap().len(), 0);
    assert_eq!(g["pulp_exposed"], false);
    // The cut came within the field's reach (1 mm plus rounding), no closer than 0.5 mm.
    let left = g["min_remaining_dentin_mm"].as_f64().unwrap();
    assert!((0.5..1.2).contains(&left), "{g}");
}
