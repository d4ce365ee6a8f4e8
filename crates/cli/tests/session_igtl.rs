//! `dentsim session --device igtl://...` end to end against peers no one here wrote: a server on
//! the OpenIGTLink reference library moves the tool into the phantom and reads the forces back;
//! the session ends when it closes and writes every output. A pyigtl server that never closes
//! is ended with Ctrl-C (SIGINT), and the outputs are still written.
#![cfg(unix)]
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use dentsim_sim::session::log::{SessionLog, TickRecord, FLAG_DEVICE_FAULT};
use dentsim_sim::tissues::capsule::CapsuleTooth;
use dentsim_sim::tissues::table::TissueTable;

fn phantom(dir: &Path) -> PathBuf {
    let path = dir.join("start.vdb");
    CapsuleTooth::default().build(0.08, &TissueTable::default()).unwrap().save(&path).unwrap();
    path
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()
}

fn reference_peer() -> PathBuf {
    let out = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("igtl_peer_cli");
    let src = concat!(env!("CARGO_MANIFEST_DIR"), "/../devices/peers/igtl_peer.cxx");
    let status = Command::new("c++").args(["-O2", "-std=c++14", "-I/usr/include/openigtlink", src, "-o"]).arg(&out).args(["-L/usr/lib", "-lOpenIGTLink"]).status().unwrap();
    assert!(status.success(), "building the reference peer needs libopenigtlink-dev (scripts/setup.sh)");
    out
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))).unwrap()
}

#[test]
fn a_reference_library_arm_cuts_the_phantom_and_gets_forces_back() {
    let dir = tempfile::tempdir().unwrap();
    let start = phantom(dir.path());
    let port = free_port();
    // 1500 poses at 1 kHz from above the top (z = 5.0) to 0.4 mm into the enamel, pedal held.
    let server = Command::new(reference_peer())
        .args(["server", &port.to_string(), "1500", "1000", "0", "0", "5.8", "0", "0", "4.6"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let out = dir.path().join("igtl");
    let run = Command::new(env!("CARGO_BIN_EXE_dentsim"))
        .arg("session")
        .arg("--tissues")
        .arg(&start)
        .args(["--device", &format!("igtl://127.0.0.1:{port}?pose=Stylus&pedal=1+reg:offset=0:0:0")])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let peer = server.wait_with_output().unwrap();
    assert!(peer.status.success(), "{}", String::from_utf8_lossy(&peer.stderr));
    // Every pose answered with six values (SENSOR carries f64; the peer prints them exactly).
    let answers: Vec<[f64; 6]> = String::from_utf8_lossy(&peer.stdout)
        .lines()
        .filter(|l| *l != "listening")
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().skip(1).map(|v| v.parse().unwrap()).collect();
            v.try_into().unwrap_or_else(|v| panic!("six values per answer: {v:?}"))
        })
        .collect();
    assert_eq!(answers.len(), 1500);
    let summary = json(&out.join("summary.json"));
    let enamel = summary["tissues"].as_array().unwrap().iter().find(|t| t["name"] == "enamel").unwrap();
    assert_eq!(summary["realtime"], true, "a live device ticks on the wall clock");
    assert!(enamel["removed_mm3"].as_f64().unwrap() > 0.0 && enamel["contact_s"].as_f64().unwrap() > 0.0, "{enamel}");
    let log = SessionLog::read(&out.join("session.dslog")).unwrap();
    assert!(log.header.device.starts_with("igtl://127.0.0.1:"), "{}", log.header.device);
    // What the arm got is what the session rendered, in order: a tick that takes a new pose
    // pushes its force, and the I/O thread answers the next pose with the newest one pushed.
    let rendered = |r: &TickRecord| [r.force.x, r.force.y, r.force.z, r.torque.x, r.torque.y, r.torque.z];
    let mut pushed: Vec<[f64; 6]> = Vec::new();
    // The peer's last pose (an f32 matrix): its force, if a tick took it, answers nothing.
    let mut answered = Vec::new();
    for (i, r) in log.records.iter().enumerate() {
        let new_pose = i == 0 || r.pose != log.records[i - 1].pose;
        if new_pose && r.flags & FLAG_DEVICE_FAULT == 0 {
            pushed.push(rendered(r));
            if r.pose.translation.z != f64::from(4.6f32) {
                answered.push(rendered(r));
            }
        }
    }
    // Faults while the arm was still sending (the link's close at the end faults the last ticks).
    let fault = |r: &TickRecord| r.flags & FLAG_DEVICE_FAULT != 0;
    let live = log.records.iter().rposition(|r| !fault(r)).map_or(0, |i| i + 1);
    let faults = log.records[..live].iter().any(fault);
    let mut at = 0;
    for (i, a) in answers.iter().enumerate().filter(|(_, a)| **a != [0.0; 6]) {
        let found = pushed[at..].iter().position(|p| p == a);
        at += found.unwrap_or_else(|| panic!("answer {i} {a:?} is not a force the session rendered after answer {at}"));
    }
    // None is lost for good: the I/O thread answers with the newest force pushed, so a force for
    // an answered pose reached the arm, or one pushed right after it did (a tick that ran late,
    // after the next pose was answered); a device fault's zero may overtake it, and the last
    // answered pose's force may come after the arm's last pose.
    let got = |f: &[f64; 6]| answers.contains(f);
    if !faults {
        for k in 0..answered.len().saturating_sub(1) {
            let next = &answered[k + 1..(k + 3).min(answered.len())];
            assert!(got(&answered[k]) || next.iter().any(got), "the force for answered pose {k} {:?} never reached the arm", answered[k]);
        }
    }
    let fz_max = |f: &[[f64; 6]]| f.iter().map(|f| f[2]).fold(0.0, f64::max);
    let (felt, sent) = (fz_max(&answers), fz_max(&answered));
    assert!(felt <= sent, "the arm felt {felt} N, more than the session rendered ({sent} N)");
    // Pressing down on the top pushes back up (+z), unless the machine could not keep the tick's
    // deadlines and the watchdog ramped the force down (a loaded machine without SCHED_FIFO).
    let trips = summary["watchdog_trips"].as_u64().unwrap();
    assert!(
        felt > 0.1 || trips > 0,
        "the arm felt the tooth: max fz {felt} N, {} missed deadlines, no watchdog trip",
        summary["missed_deadlines"]
    );
    assert!(out.join("tissues.vdb").exists());
}

const PYIGTL_FOREVER: &str = r#"
import sys, time
import numpy as np
import pyigtl
server = pyigtl.OpenIGTLinkServer(port=int(sys.argv[1]), local_server=True)
while not server.is_connected():
    time.sleep(0.01)
m = np.eye(4)
m[2, 3] = 7.0
while server.is_connected():
    server.send_message(pyigtl.TransformMessage(m, device_name="Stylus"), wait=True)
    time.sleep(0.01)
"#;

#[test]
fn ctrl_c_ends_a_live_session_and_writes_its_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let start = phantom(dir.path());
    let port = free_port();
    let mut server = Command::new("/usr/bin/python3").args(["-c", PYIGTL_FOREVER, &port.to_string()]).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap();
    let out = dir.path().join("live");
    let session = Command::new(env!("CARGO_BIN_EXE_dentsim"))
        .arg("session")
        .arg("--tissues")
        .arg(&start)
        .args(["--device", &format!("igtl://127.0.0.1:{port}")])
        .arg("--out")
        .arg(&out)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Ticking once the log holds records (the pyigtl poses arrive every 10 ms).
    let log = out.join("session.dslog");
    while SessionLog::read(&log).map_or(true, |l| l.records.len() < 50) {
        std::thread::sleep(Duration::from_millis(20));
    }
    let kill = Command::new("kill").args(["-INT", &session.id().to_string()]).status().unwrap();
    assert!(kill.success());
    let run = session.wait_with_output().unwrap();
    let _ = server.kill();
    let _ = server.wait();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let summary = json(&out.join("summary.json"));
    assert!(summary["ticks"].as_u64().unwrap() >= 50);
    assert!(out.join("tissues.vdb").exists());
}
