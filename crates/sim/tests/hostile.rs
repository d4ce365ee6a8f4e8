//! Issue 11's hostile session, replay and preparation inputs: refused before the work starts
//! (nothing written), within one memory cap and one session-length cap; outputs appear whole
//! or not at all; a damaged log is an error naming the tick.
use dentsim_sim::plan::prepare::{prepare_to_dir, PrepareOptions};
use dentsim_sim::session::outputs::{replay_to_dir, run_session_to_dir, run_session_to_dir_with, SessionRequest};
use dentsim_sim::tissues::capsule::CapsuleTooth;
use dentsim_sim::tissues::export::{all_or_nothing, LOG_NAME, SUMMARY_NAME, TISSUES_NAME};
use dentsim_sim::tissues::model::TissueModel;
use dentsim_sim::tissues::table::TissueTable;
use dentsim_sim::{Error, Limits};
use std::path::Path;

fn capsule(dir: &Path) -> std::path::PathBuf {
    let path = dir.join("start.vdb");
    CapsuleTooth::default().build(0.08, &TissueTable::default()).unwrap().save(&path).unwrap();
    path
}

fn request(tissues: &Path, out: &Path, device: &str) -> SessionRequest {
    SessionRequest {
        tissues: tissues.to_owned(),
        device: device.into(),
        out: out.to_owned(),
        profile: "desktop".into(),
        filter: "delta".into(),
        realtime: false,
        burr: "round:1.0".into(),
    }
}

fn names(dir: &Path) -> Vec<String> {
    let mut n: Vec<String> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    n.sort();
    n
}

#[test]
fn sessions_longer_than_the_cap_are_refused_before_anything_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let start = capsule(dir.path());
    let out = dir.path().join("out");
    let e = run_session_to_dir(&request(&start, &out, "hand:start=0:0:5.6,target=0:0:2,duration=1e12"), &mut |_, _| {}).unwrap_err().to_string();
    assert!(e.contains("1000000000000 s") && e.contains("--max-duration-s"), "{e}");
    let csv = dir.path().join("long.csv");
    std::fs::write(&csv, "t,x,y,z,qw,qx,qy,qz\n0,0,0,6,1,0,0,0\n1e12,0,0,6,1,0,0,0\n").unwrap();
    let e = run_session_to_dir(&request(&start, &out, &format!("scripted:{}", csv.display())), &mut |_, _| {}).unwrap_err().to_string();
    assert!(e.contains("long.csv") && e.contains("session cap"), "{e}");
    // Asked for, a longer session is allowed: the cap is a default, not a wall.
    let limits = Limits::new(4.0, 7200.0).unwrap();
    let e = run_session_to_dir_with(&request(&start, &out, "hand:duration=5000,pedal=0"), &Limits::new(4.0, 60.0).unwrap(), &mut |_, _| {}).unwrap_err();
    assert!(e.to_string().contains("5000 s"), "{e}");
    assert!(limits.check_session("hand", 5000.0).is_ok());
    assert!(!out.exists(), "nothing written");
}

#[test]
fn tissues_with_absurdly_fine_voxels_are_refused_by_session_and_prepare_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    // A 0.05 mm ball at 0.001 mm voxels: a small file, but a 1 mm burr spans a thousand voxels
    // and its cut buffers would need tens of GiB. The reader refuses the voxel size first.
    let mut model = TissueModel::new("fine", None);
    let props = TissueTable::default().get("enamel").unwrap().clone();
    model.push(props, dentsim_vdb::LevelSet::sphere(glam::DVec3::ZERO, 0.05, 0.001, 3.0).unwrap()).unwrap();
    let fine = dir.path().join("fine.vdb");
    model.save(&fine).unwrap();
    let out = dir.path().join("out");
    let e = run_session_to_dir(&request(&fine, &out, "hand:start=0:0:5,target=0:0:2,duration=0.2"), &mut |_, _| {}).unwrap_err().to_string();
    assert!(e.contains("fine.vdb") && e.contains("voxel size 0.001"), "{e}");
    assert!(!out.exists(), "nothing written");
    // Voxels the reader takes but a cap cannot hold: the session's memory check, before
    // allocating, names the file, the voxel size and the cap.
    let start = capsule(dir.path());
    let e = run_session_to_dir_with(&request(&start, &out, "hand:start=0:0:5,target=0:0:2,duration=0.2"), &Limits::new(1e-4, 60.0).unwrap(), &mut |_, _| {})
        .unwrap_err()
        .to_string();
    assert!(e.contains("start.vdb") && e.contains("0.08 mm voxels") && e.contains("memory cap"), "{e}");
    assert!(!out.exists(), "nothing written");
    // prepare: the same check.
    let csv = dir.path().join("p.csv");
    std::fs::write(&csv, "t,x,y,z,qw,qx,qy,qz,cut\n0,0,0,6,1,0,0,0,1\n0.5,0,0,4.5,1,0,0,0,1\n").unwrap();
    let options = PrepareOptions { limits: Limits::new(1e-4, 3600.0).unwrap(), ..PrepareOptions::default() };
    let e = prepare_to_dir(&start, &csv, "round:1.0", &options, &TissueTable::default(), &out, &mut |_, _| {}).unwrap_err().to_string();
    assert!(e.contains("start.vdb") && e.contains("memory cap"), "{e}");
    assert!(!out.exists(), "nothing written");
}

#[test]
fn a_failed_write_leaves_the_folder_as_it_was_and_names_the_final_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join(TISSUES_NAME), b"the old tissues").unwrap();
    let e = all_or_nothing(&out, |staged| -> dentsim_sim::Result<()> {
        std::fs::write(staged.join(TISSUES_NAME), b"new").unwrap();
        std::fs::write(staged.join("enamel.vtp"), b"new").unwrap();
        Err(Error::File { path: staged.join("enamel.stl"), message: "No space left on device (os error 28)".into() })
    })
    .unwrap_err();
    match &e {
        Error::File { path, .. } => assert_eq!(path, &out.join("enamel.stl")),
        other => panic!("{other:?}"),
    }
    assert_eq!(names(&out), [TISSUES_NAME]);
    assert_eq!(std::fs::read(out.join(TISSUES_NAME)).unwrap(), b"the old tissues");
    // A folder the call created goes again.
    let fresh = dir.path().join("fresh");
    let r = all_or_nothing(&fresh, |staged| -> dentsim_sim::Result<()> {
        std::fs::write(staged.join("a.json"), b"{}").unwrap();
        Err(dentsim_sim::error::invalid("test", "failed"))
    });
    assert!(r.is_err() && !fresh.exists());
}

#[test]
fn a_session_writes_a_checksummed_log_and_a_flipped_byte_stops_the_replay_at_its_tick() {
    let dir = tempfile::tempdir().unwrap();
    let start = capsule(dir.path());
    let out = dir.path().join("out");
    let summary = run_session_to_dir(&request(&start, &out, "hand:start=0:0:5.6,target=0:0:3,push=1,pedal=1,duration=0.3"), &mut |_, _| {}).unwrap();
    assert_eq!(names(&out).iter().filter(|n| n.starts_with('.')).count(), 0, "no staging left: {:?}", names(&out));
    assert!(out.join(SUMMARY_NAME).exists() && out.join(TISSUES_NAME).exists());
    let log_path = out.join(LOG_NAME);
    let log = dentsim_sim::SessionLog::read(&log_path).unwrap();
    assert_eq!(log.records.len() as u64, summary.ticks);
    assert!(log.header.started_unix_s > 0.0);
    let bytes = std::fs::read(&log_path).unwrap();
    // A byte of the record of tick 100 (records are at the end, fixed size).
    let size = dentsim_sim::session::log::CHECKED_RECORD_BYTES;
    let at = bytes.len() - (summary.ticks as usize - 100) * size + 30;
    let mut bad = bytes.clone();
    bad[at] ^= 0x04;
    let damaged = dir.path().join("damaged");
    std::fs::create_dir(&damaged).unwrap();
    std::fs::write(damaged.join(LOG_NAME), &bad).unwrap();
    let e = replay_to_dir(&damaged.join(LOG_NAME), &start, &dir.path().join("r1"), &mut |_, _| {}).unwrap_err().to_string();
    assert!(e.contains("tick 100 expected") && e.contains("checksum"), "{e}");
    // Garbage appended: a whole record's worth is an error at the tick after the last.
    let mut appended = bytes.clone();
    appended.extend(std::iter::repeat_n(b'x', size + 3));
    std::fs::write(damaged.join(LOG_NAME), &appended).unwrap();
    let e = replay_to_dir(&damaged.join(LOG_NAME), &start, &dir.path().join("r2"), &mut |_, _| {}).unwrap_err().to_string();
    assert!(e.contains(&format!("tick {} expected", summary.ticks)), "{e}");
    assert!(!dir.path().join("r1").exists() && !dir.path().join("r2").exists(), "a refused replay writes nothing");
}

#[test]
fn a_non_finite_point_is_refused_before_segmenting() {
    let request = dentsim_sim::TissuesFromScan { seed_mm: Some([f64::NAN, 0.0, 0.0]), ..Default::default() };
    let e = request.validate().unwrap_err().to_string();
    assert!(e.starts_with("point") && e.contains("NaN"), "{e}");
    let request = dentsim_sim::TissuesFromScan { bounds_mm: Some(([0.0; 3], [f64::INFINITY, 1.0, 1.0])), ..Default::default() };
    assert!(request.validate().unwrap_err().to_string().starts_with("bounds"));
}
