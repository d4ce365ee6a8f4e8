//! `kill -9` during a real `dentsim session`: the log is under its final name from the start and
//! holds every tick flushed before the kill; `dentsim replay` replays them all. The ticks lost
//! (kill time less the last logged tick's time) are printed, not asserted (no timed assertions).
#![cfg(unix)]
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use dentsim_sim::session::log::{SessionLog, CHECKED_RECORD_BYTES};
use dentsim_sim::tissues::capsule::CapsuleTooth;
use dentsim_sim::tissues::table::TissueTable;

fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_dentsim")
}

/// Waits until the log of a session started after `after_unix_s` holds at least `records` whole
/// records past its header (the session is ticking), polling the file.
fn wait_for_ticks(log: &Path, records: u64, after_unix_s: f64) {
    loop {
        if let Ok(bytes) = std::fs::read(log) {
            if bytes.len() >= 16 {
                let header = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
                let started = bytes
                    .get(16..16 + header)
                    .and_then(|json| serde_json::from_slice::<serde_json::Value>(json).ok())
                    .and_then(|h| h["started_unix_s"].as_f64())
                    .unwrap_or(0.0);
                if started >= after_unix_s && bytes.len() >= 16 + header + 4 + records as usize * CHECKED_RECORD_BYTES {
                    return;
                }
            }
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn sessions_killed_with_sigkill_leave_a_log_that_replays_every_logged_tick() {
    let dir = tempfile::tempdir().unwrap();
    let start = dir.path().join("start.vdb");
    CapsuleTooth::default().build(0.08, &TissueTable::default()).unwrap().save(&start).unwrap();
    let mut lost_ms = Vec::new();
    // Kills at different moments of the cut: after 50 to 1250 logged ticks, then a little more.
    for (i, (ticks, extra_ms)) in [(50u64, 0u64), (200, 37), (400, 113), (800, 271), (1250, 5)].into_iter().enumerate() {
        let out = dir.path().join(format!("out{i}"));
        if i == 2 {
            // A folder holding a finished session: the killed one replaces its log, and its
            // summary (which describes the old log) must not be compared with the new log.
            let run = Command::new(bin())
                .args(["session", "--tissues", start.to_str().unwrap(), "--out", out.to_str().unwrap()])
                .args(["--device", "hand:start=0:0:5.6,target=0:0:2.5,push=1.5,pedal=1,duration=0.2"])
                .output()
                .unwrap();
            assert!(run.status.success() && out.join("summary.json").exists(), "{}", String::from_utf8_lossy(&run.stderr));
        }
        let spawned_at = SystemTime::now().duration_since(UNIX_EPOCH).unwrap().as_secs_f64();
        let mut child = Command::new(bin())
            .args(["session", "--tissues", start.to_str().unwrap(), "--out", out.to_str().unwrap(), "--realtime"])
            .args(["--device", "hand:start=0:0:5.6,target=0:0:2.5,push=1.5,pedal=1,duration=30"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let log_path = out.join("session.dslog");
        wait_for_ticks(&log_path, ticks, spawned_at);
        std::thread::sleep(Duration::from_millis(extra_ms));
        let killed_at = SystemTime::now().duration_since(UNIX_EPOCH).unwrap().as_secs_f64();
        child.kill().unwrap(); // SIGKILL
        let status = child.wait().unwrap();
        assert!(!status.success(), "the session was killed");

        if i == 2 {
            assert!(!out.join("summary.json").exists(), "the old summary went with the old log");
        }
        let log = SessionLog::read(&log_path).unwrap();
        assert!(log.records.len() as u64 >= ticks, "kill {i}: {} records", log.records.len());
        assert!(log.records.iter().enumerate().all(|(k, r)| r.tick == k as u64), "kill {i}: ticks 0.. in order");
        assert!(log.truncated_bytes < CHECKED_RECORD_BYTES);
        let last = log.records.last().unwrap();
        lost_ms.push((killed_at - (log.header.started_unix_s + last.wall_s)) * 1e3);

        let replay_out = dir.path().join(format!("replay{i}"));
        let run = Command::new(bin())
            .args(["replay", log_path.to_str().unwrap(), "--tissues", start.to_str().unwrap(), "--out", replay_out.to_str().unwrap()])
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&run.stdout);
        assert!(run.status.success(), "kill {i}: {}", String::from_utf8_lossy(&run.stderr));
        assert!(stdout.contains(&format!("{} ticks replayed; largest force difference from the log 0 N", log.records.len())), "kill {i}: {stdout}");
        let replay: serde_json::Value = serde_json::from_slice(&std::fs::read(replay_out.join("replay.json")).unwrap()).unwrap();
        assert_eq!(replay["ticks"], log.records.len() as u64);
        assert_eq!(replay["ticks_cut_differently"], 0);
    }
    println!("kill -9: session time lost after the last logged tick, ms: {lost_ms:.2?}");
}
