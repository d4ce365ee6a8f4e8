//! Haptic sessions with every burr family (issue 10, part 6): each cuts the material the same
//! strokes cut when prepared, a session with a non-round burr replays bit for bit, the log names
//! the burr, and bad specs are refused naming the burr.
use dentsim_devices::{DeviceState, BUTTON_CUT};
use dentsim_sim::burr::Burr;
use dentsim_sim::cutting::cutter::Cutter;
use dentsim_sim::haptics::tick::{HapticCore, HapticParams};
use dentsim_sim::tissues::export::LOG_NAME;
use dentsim_sim::session::outputs::{replay_to_dir, run_session_to_dir, SessionRequest};
use dentsim_sim::session::log::{SessionLog, VERSION};
use dentsim_sim::tissues::model::TissueModel;
use dentsim_sim::tissues::capsule::CapsuleTooth;
use dentsim_sim::tissues::table::TissueTable;
use glam::{DAffine3, DQuat, DVec3};

/// One burr of each family, heads short enough that a test session stays quick.
const FAMILIES: [&str; 6] = ["round:1", "cylinder_flat:1:1.5", "taper_round:1:2", "inverted_cone:1", "flame:1:2", "pear:0.8"];

fn tooth() -> TissueModel {
    CapsuleTooth::default().build(0.08, &TissueTable::default()).unwrap()
}

fn cutting(pose: DAffine3) -> DeviceState {
    DeviceState { pose, buttons: BUTTON_CUT, rpm: 200_000.0 }
}

/// Tilted 0.2 rad about x: down onto the top (z = 5.0) and 0.5 mm sideways, pedal down.
fn device(k: usize) -> DAffine3 {
    let u = (k as f64 / 300.0).min(1.0);
    let v = ((k as f64 - 300.0) / 300.0).clamp(0.0, 1.0);
    DAffine3::from_rotation_translation(DQuat::from_rotation_x(0.2), DVec3::new(0.5 * v, 0.0, 5.8 - 1.2 * u))
}

#[test]
fn every_family_cuts_in_a_session_what_its_strokes_cut_when_prepared() {
    let base = tooth();
    for spec in FAMILIES {
        let mut model = base.clone();
        let mut core = HapticCore::new(HapticParams { burr: spec.into(), ..HapticParams::default() }, &model).unwrap();
        core.prepare_cutting(&mut model).unwrap();
        let (mut strokes, mut removed, mut contacts) = (Vec::new(), 0.0, 0);
        for k in 0..800 {
            let out = core.tick(&mut model, &cutting(device(k)), false).unwrap();
            strokes.extend(out.cut);
            removed += out.removed_mm3;
            contacts += usize::from(out.raw.tissue.is_some());
        }
        let burr = Burr::parse(spec).unwrap();
        assert_eq!(core.burr(), &burr, "{spec}: the core cuts with the burr named");
        // The same strokes cut as `prepare` cuts a path: one cutter, stroke after stroke...
        let mut prepared = base.clone();
        prepared.voxelize_for_cutting().unwrap();
        let mut cutter = Cutter::default();
        let mut prepared_removed = 0.0;
        for (from, to) in &strokes {
            prepared_removed += cutter.cut(&mut prepared, &burr, *from, *to).unwrap().total_mm3();
        }
        // ...and each stroke alone by a fresh cutter (no skipping of what the last one removed).
        let mut alone = base.clone();
        alone.voxelize_for_cutting().unwrap();
        for (from, to) in &strokes {
            Cutter::default().cut(&mut alone, &burr, *from, *to).unwrap();
        }
        let volume = |m: &TissueModel| m.tissues.iter().map(|t| t.grid.volume()).sum::<f64>();
        let (before, after, after_alone) = (volume(&base), volume(&model), volume(&alone));
        println!("{spec:<22} {} strokes, {contacts} ticks in contact, removed {removed:.4} mm³ (prepared {prepared_removed:.4}, volumes {:.4} / alone {:.4})", strokes.len(), before - after, before - after_alone);
        assert!(strokes.len() > 100 && contacts > 300, "{spec}: the burr cut its way in");
        assert!(removed > 0.01, "{spec}: removed {removed} mm³");
        for (t, p) in model.tissues.iter().zip(&prepared.tissues) {
            assert_eq!(t.grid.content_hash(), p.grid.content_hash(), "{spec}: tissue {} differs from the prepared strokes", t.props.name);
        }
        assert!((removed - prepared_removed).abs() <= 1e-9 * removed.max(1.0), "{spec}: {removed} vs {prepared_removed}");
        // Skipping what the last head removed changes no value beyond its slack (1e-5 mm).
        assert!(((before - after) - (before - after_alone)).abs() < 1e-3 * (before - after), "{spec}: {after} vs {after_alone}");
    }
}

fn session(dir: &std::path::Path, start: &std::path::Path, burr: &str) -> dentsim_sim::Result<dentsim_sim::session::outputs::SessionSummary> {
    let request = SessionRequest {
        tissues: start.to_owned(),
        device: "hand:start=0.2:0:5.8,target=0.2:0:4.2,push=1,pedal=1,duration=0.6".into(),
        out: dir.to_owned(),
        profile: "desktop".into(),
        filter: "delta".into(),
        realtime: false,
        burr: burr.into(),
    };
    run_session_to_dir(&request, &mut |_, _| {})
}

#[test]
fn non_round_sessions_replay_bit_for_bit_and_the_log_names_the_burr() {
    let dir = tempfile::tempdir().unwrap();
    let start = dir.path().join("start.vdb");
    tooth().save(&start).unwrap();
    for (name, spec) in [("cylinder", "cylinder_flat:1.2:2"), ("flame", "flame:1.6:3")] {
        let out = dir.path().join(name);
        let summary = session(&out, &start, spec).unwrap();
        assert_eq!(summary.burr, spec);
        let removed: f64 = summary.tissues.iter().map(|t| t.volumes.removed_mm3).sum();
        assert!(removed > 0.01, "{spec}: removed {removed} mm³");
        let log = SessionLog::read(&out.join(LOG_NAME)).unwrap();
        assert_eq!(log.header.params.burr, spec, "the log records the burr");
        let replay = replay_to_dir(&out.join(LOG_NAME), &start, &dir.path().join(format!("{name}-replay")), &mut |_, _| {}).unwrap();
        assert_eq!(replay.hashes_match_session, Some(true), "{spec}");
        assert_eq!((replay.max_force_difference_n, replay.ticks_cut_differently), (0.0, 0), "{spec}");
        for (s, r) in summary.tissues.iter().zip(&replay.tissues) {
            assert_eq!(s.content_hash, r.content_hash, "{spec}: {}", s.volumes.name);
        }
    }
}

#[test]
fn bad_burr_specs_are_refused_naming_the_burr() {
    let mut model = tooth();
    for (spec, names) in [("cone:1", "shape 'cone'"), ("round:x", "diameter 'x'"), ("cylinder_flat:-1", "diameter"), ("inverted_cone:1:9", "too long")] {
        let err = HapticCore::new(HapticParams { burr: spec.into(), ..HapticParams::default() }, &model).err().expect(spec).to_string();
        assert!(err.contains("burr") && err.contains(names), "{spec}: {err}");
    }
    // A session refuses it before writing anything.
    let dir = tempfile::tempdir().unwrap();
    let start = dir.path().join("start.vdb");
    model.save(&start).unwrap();
    let out = dir.path().join("out");
    let err = session(&out, &start, "cone:1").err().expect("refused").to_string();
    assert!(err.contains("burr 'cone:1'"), "{err}");
    assert!(!out.exists(), "nothing written");
}

#[test]
fn an_older_log_names_the_file_and_both_versions() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("old.dslog");
    // A version-2 log: its header held a round burr's diameter, not a spec.
    let header = br#"{"params":{"burr_diameter_mm":1.0}}"#;
    let mut bytes = b"DSIMLOG\0".to_vec();
    bytes.extend_from_slice(&2u32.to_le_bytes());
    bytes.extend_from_slice(&(header.len() as u32).to_le_bytes());
    bytes.extend_from_slice(header);
    std::fs::write(&path, &bytes).unwrap();
    let err = SessionLog::read(&path).err().expect("refused").to_string();
    assert!(err.contains(&path.display().to_string()) && err.contains("version 2") && err.contains(&format!("version {VERSION}")), "{err}");
    assert_eq!(VERSION, 3);
}
