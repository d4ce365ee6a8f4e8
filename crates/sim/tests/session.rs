//! Headless sessions: the simulated hand cuts through enamel into dentin; replay is bit-exact.
mod common;

use common::triangle_set;
use dentsim_devices::{HandParams, ScriptedPath, SimulatedHand};
use dentsim_sim::session::log::SessionLog;
use dentsim_sim::tissues::surface::Mesher;
use dentsim_sim::tissues::model::TissueModel;
use dentsim_sim::tissues::capsule::CapsuleTooth;
use dentsim_sim::session::replay::{replay, write_force_csv};
use dentsim_sim::session::threads::{run_session, SessionOptions};
use dentsim_sim::tissues::table::TissueTable;
use std::path::PathBuf;

use glam::DVec3;

fn tooth() -> TissueModel {
    CapsuleTooth::default().build(0.05, &TissueTable::default()).unwrap()
}

fn copy(m: &TissueModel) -> TissueModel {
    let mut out = TissueModel::new(m.source.clone(), m.fdi_tooth);
    for t in &m.tissues {
        out.push(t.props.clone(), t.grid.clone()).unwrap();
    }
    out
}

fn headless(log: std::path::PathBuf) -> SessionOptions {
    SessionOptions { realtime: false, log_path: Some(log), mesher_hz: Some(60.0), raise_priority: false, ..Default::default() }
}

#[test]
fn simulated_hand_cuts_through_enamel_into_dentin() {
    let dir = tempfile::tempdir().unwrap();
    let model = tooth();
    let enamel0 = model.tissues[0].grid.volume();
    // Top of the tooth at z = 5.0; enamel down to 3.5, dentin to 2.0 on the axis.
    let hand = SimulatedHand::new(HandParams {
        start: DVec3::new(0.0, 0.0, 5.6),
        target: DVec3::new(0.0, 0.0, 2.5),
        push_n: 2.0,
        pedal: true,
        rpm: 400_000.0,
        duration_s: 9.0,
        ..Default::default()
    });
    let out = run_session(model, hand, headless(dir.path().join("hand.dslog"))).unwrap();
    let names: Vec<&str> = out.contact_changes.iter().map(|(t, _)| if *t < 0 { "-" } else { out.model.tissues[*t as usize].props.name.as_str() }).collect();
    println!("ticks {}, removed {:?}, max |F| {:.3} N, contacts {names:?}, meshes {}", out.ticks, out.removed_mm3, out.max_force_n, out.meshes_published);
    let log = SessionLog::read(&dir.path().join("hand.dslog")).unwrap();
    for r in log.records.iter().step_by(1000) {
        println!("t {:.1} s: tip z {:.3}, proxy z {:.3}, |F| {:.3} N, tissue {}", r.t_s, r.pose.translation.z, r.proxy.z, r.force.length(), r.tissue);
    }
    let removed = |n: &str| out.removed_mm3.iter().find(|(t, _)| t == n).unwrap().1;
    assert!(removed("enamel") > 0.5 && removed("dentin") > 0.05, "{:?}", out.removed_mm3);
    let first = |n: &str| names.iter().position(|t| *t == n);
    assert!(first("enamel").unwrap() < first("dentin").unwrap());
    assert!(out.max_force_n <= 7.9 && out.max_force_n > 0.5);
    assert!(out.model.tissues[0].grid.volume() < enamel0);
    assert_eq!((out.dropped_records, out.dropped_strokes), (0, 0));
    assert!(out.meshes_published > 0);
    assert_eq!(log.records.len() as u64, out.ticks);
    // The removed volume is what the grids lost, and the mesher (its own mirror grids, cut by
    // the strokes it was sent) last showed exactly the final geometry.
    assert!((removed("enamel") - (enamel0 - out.model.tissues[0].grid.volume())).abs() < 1e-9);
    let full = Mesher::full(&out.model).unwrap();
    for (t, shown) in out.final_meshes.iter().enumerate().take(2) {
        let shown = shown.as_ref().unwrap_or_else(|| panic!("no mesh published for tissue {t}"));
        assert!(triangle_set(shown) == triangle_set(&full.mesh(t)), "tissue {t}: the mesher's last mesh is not the final geometry");
    }
}

#[test]
fn replay_reproduces_the_session_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let model = tooth();
    let start = copy(&model);
    // Down onto the top, cutting, then a sideways stroke, then up.
    let csv = "t,x,y,z,qw,qx,qy,qz,rpm,cut\n\
               0,0,0,5.8,1,0,0,0,200000,1\n\
               0.3,0,0,4.6,1,0,0,0,200000,1\n\
               0.6,0.6,0.2,4.5,0.9961947,0.0871557,0,0,200000,1\n\
               0.8,0.6,0.2,5.8,1,0,0,0,0,0\n";
    let path = ScriptedPath::parse(csv, "stroke.csv").unwrap();
    let log_path = dir.path().join("s.dslog");
    let out = run_session(model, path, headless(log_path.clone())).unwrap();
    let log = SessionLog::read(&log_path).unwrap();
    let again = replay(&log, start).unwrap();
    for (a, b) in out.model.tissues.iter().zip(&again.model.tissues) {
        println!("{}: session {:.6} mm³ hash {:016x}, replay {:.6} mm³ hash {:016x}", a.props.name, a.grid.volume(), a.grid.content_hash(), b.grid.volume(), b.grid.content_hash());
        assert_eq!(a.grid.content_hash(), b.grid.content_hash(), "{}", a.props.name);
        assert_eq!(a.grid.volume().to_bits(), b.grid.volume().to_bits());
        assert_eq!(a.grid.active_voxel_count(), b.grid.active_voxel_count());
    }
    println!("removed {:?}; replay force difference {} N", again.removed_mm3, again.max_force_difference_n);
    // At enamel's removal rate: 0.5 mm³/(N·s) × a few tenths of a newton × ~0.5 s in contact.
    assert!(again.removed_mm3.iter().map(|(_, v)| v).sum::<f64>() > 0.02);
    assert_eq!(again.max_force_difference_n, 0.0);
    assert_eq!(again.ticks_cut_differently, 0);
    // The replay measures each tick's cut; together they are what the session's grids lost.
    let per_tick: f64 = again.forces.iter().map(|f| f.removed_mm3).sum();
    let total: f64 = again.removed_mm3.iter().map(|(_, v)| v).sum();
    assert!((per_tick - total).abs() < 1e-9 * total.max(1.0), "{per_tick} vs {total}");
    let names: Vec<String> = again.model.tissues.iter().map(|t| t.props.name.clone()).collect();
    let colours: Vec<[f32; 3]> = again.model.tissues.iter().map(|t| t.props.colour).collect();
    write_force_csv(&dir.path().join("forces.csv"), &again.forces, &names).unwrap();
    dentsim_sim::session::plot::plot_forces(&dir.path().join("forces.png"), &again.forces, &colours, 800, 400).unwrap();
    let png = std::fs::read(dir.path().join("forces.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    // A different start model is refused.
    assert!(replay(&log, tooth_cut()).is_err());
}

fn tooth_cut() -> TissueModel {
    let mut m = tooth();
    let at = |z: f64| glam::DAffine3::from_translation(DVec3::new(0.0, 0.0, z));
    dentsim_sim::cutting::cutter::Cutter::default().cut(&mut m, &dentsim_sim::burr::Burr::round(1.0).unwrap(), at(6.0), at(4.8)).unwrap();
    m
}

/// Cuts whose changed voxels do not fit the mesher's queues go over as strokes and are cut again
/// on its copy: the last mesh is still exactly the final geometry.
#[test]
fn a_mesher_short_of_queue_room_cuts_the_overflow_again() {
    let model = tooth();
    let hand = SimulatedHand::new(HandParams {
        start: DVec3::new(0.0, 0.0, 5.8),
        target: DVec3::new(0.0, 0.0, 3.0),
        push_n: 2.0,
        pedal: true,
        rpm: 400_000.0,
        duration_s: 2.0,
        ..Default::default()
    });
    // Room for about one tick's cut: most ticks fit, a large one (or a backlog) does not.
    let options = SessionOptions { mesher_queue_voxels: 3000, log_path: None, ..headless(PathBuf::new()) };
    let out = run_session(model, hand, options).unwrap();
    let removed: f64 = out.removed_mm3.iter().map(|(_, v)| v).sum();
    assert!(removed > 0.1, "{:?}", out.removed_mm3);
    assert_eq!(out.dropped_strokes, 0);
    println!("{} of {} ticks cut again by the mesher", out.strokes_recut, out.ticks);
    assert!(out.strokes_recut > 0);
    let full = Mesher::full(&out.model).unwrap();
    for (t, shown) in out.final_meshes.iter().enumerate().take(1) {
        let shown = shown.as_ref().unwrap_or_else(|| panic!("no mesh published for tissue {t}"));
        assert!(triangle_set(shown) == triangle_set(&full.mesh(t)), "tissue {t}: the mesher's last mesh is not the final geometry");
    }
}

#[test]
fn the_empty_loop_starts_each_tick_at_or_after_its_deadline_and_refuses_a_bad_period() {
    use dentsim_sim::session::threads::idle_loop_starts_s;
    let starts = idle_loop_starts_s(50, 1e-3, false).unwrap();
    assert_eq!(starts.len(), 51);
    // The wait never returns before its deadline (absolute, from the loop's start): late is the
    // machine's, early would be a bug.
    for (k, t) in starts.iter().enumerate() {
        // (A nanosecond's slack: the deadline is a Duration, rounded to whole nanoseconds.)
        assert!(*t >= k as f64 * 1e-3 - 1e-9, "tick {k} started at {t} s");
    }
    for bad in [0.0, -1e-3, f64::NAN] {
        let e = idle_loop_starts_s(5, bad, false).unwrap_err().to_string();
        assert!(e.contains("period_s"), "{e}");
    }
}
