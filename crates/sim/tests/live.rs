//! The display-side session: polls never block, the final state is the session's result.
use dentsim_sim::session::live::{LiveRequest, LiveSession};

/// Down into the phantom's top (z = 5.0) with the pedal held, held 0.3 mm deep while the burr
/// cuts its way down at the enamel's removal rate, then pedal up and pressing 0.2 mm further: the
/// cut stops and the burr rests on the enamel it cut, pushed back.
const PATH: &str = "t,x,y,z,qw,qx,qy,qz,rpm,cut\n0,0,0,6.0,1,0,0,0,200000,1\n0.4,0,0,4.7,1,0,0,0,200000,1\n1.0,0,0,4.7,1,0,0,0,200000,1\n1.05,0,0,4.7,1,0,0,0,200000,0\n1.2,0,0,4.5,1,0,0,0,200000,0\n";

fn request(dir: &std::path::Path) -> LiveRequest {
    let csv = dir.join("path.csv");
    std::fs::write(&csv, PATH).unwrap();
    LiveRequest {
        tissues: None,
        phantom_voxel_mm: 0.08,
        device: format!("scripted:{}", csv.display()),
        profile: "desktop".into(),
        filter: "none".into(),
        realtime: false,
        mesher_hz: 30.0,
    }
}

#[test]
fn scripted_live_session_ends_in_contact_with_enamel() {
    let dir = tempfile::tempdir().unwrap();
    let mut live = LiveSession::start(&request(dir.path())).unwrap();
    let names: Vec<&str> = live.tissues().iter().map(|t| t.name.as_str()).collect();
    assert_eq!(names, ["enamel", "dentin", "pulp"]);
    let mut state = live.poll().unwrap();
    let mut polls = 1;
    while state.running {
        std::thread::sleep(std::time::Duration::from_millis(10));
        state = live.poll().unwrap();
        polls += 1;
    }
    println!("{polls} polls; final tick {}, proxy {}, force {} N, tissue {:?}", state.tick, state.proxy, state.force, state.tissue);
    assert_eq!(state.tick, 1201, "ticks 0..=1201: the path ends at 1.2 s");
    assert!(state.proxy.z < 4.95 && state.proxy.z > 4.6, "the burr went down into the top: {}", state.proxy);
    assert_eq!(state.tissue.as_deref(), Some("enamel"));
    assert!(state.force.z > 0.1, "pushes the tool back up: {}", state.force);
    // The final meshes show the cut: the enamel surface reaches below the original top.
    let enamel = &live.meshes()[0];
    let lowest_near_axis = enamel
        .points
        .iter()
        .filter(|p| p.x.hypot(p.y) < 0.2 && p.z > 4.0)
        .map(|p| p.z)
        .fold(f32::MAX, f32::min);
    assert!(lowest_near_axis < 4.9, "{lowest_near_axis}");
    let burr = live.burr_at(&state);
    let centre = burr.points.iter().map(|p| p.as_dvec3()).sum::<glam::DVec3>() / burr.points.len() as f64;
    assert!((centre - (state.proxy + glam::DVec3::new(0.0, 0.0, 0.5))).length() < 0.02, "{centre}");
    // Polling after the end is cheap and stable.
    assert_eq!(live.poll().unwrap(), state);
}

#[test]
fn bad_inputs_are_refused_before_starting() {
    let dir = tempfile::tempdir().unwrap();
    let good = request(dir.path());
    let e = |r: LiveRequest| LiveSession::start(&r).err().expect("refused").to_string();
    assert!(e(LiveRequest { profile: "wii".into(), ..good.clone() }).contains("profile"));
    assert!(e(LiveRequest { filter: "kalman".into(), ..good.clone() }).contains("filter"));
    assert!(e(LiveRequest { device: "hand:mass=0".into(), ..good.clone() }).contains("field 'mass'"));
    assert!(e(LiveRequest { phantom_voxel_mm: -1.0, ..good.clone() }).contains("voxel"));
    assert!(e(LiveRequest { tissues: Some("/nonexistent/t.vdb".into()), ..good }).contains("/nonexistent/t.vdb"));
}

/// The volumes a display shows come from the grids, as every other removed volume: at the end,
/// before − now is what the session's grids lost.
#[test]
fn final_volumes_are_the_grids() {
    use dentsim_sim::tissues::capsule::CapsuleTooth;
    use dentsim_sim::tissues::table::TissueTable;
    let dir = tempfile::tempdir().unwrap();
    let mut live = LiveSession::start(&request(dir.path())).unwrap();
    let start = CapsuleTooth::default().build(0.08, &TissueTable::default()).unwrap();
    while live.poll().unwrap().running {
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    let volumes = live.volumes_mm3();
    for (t, (before, now)) in start.tissues.iter().zip(&volumes) {
        assert_eq!(before.to_bits(), t.grid.volume().to_bits(), "{}", t.props.name);
        assert!(now <= before, "{}: {now} > {before}", t.props.name);
    }
    let (before, now) = volumes[0];
    println!("enamel {before:.4} -> {now:.4} mm³");
    assert!(before - now > 1e-3, "the session removed enamel");
}
