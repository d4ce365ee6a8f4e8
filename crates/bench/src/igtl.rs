//! `igtl_round_trip`: a pose message in, the force message out, on loopback. The timing end is
//! the same for both sides: a server on the OpenIGTLink reference library (Debian's
//! libopenigtlink-dev; crates/devices/peers/igtl_peer.cxx, built here) that sends TRANSFORM poses
//! at 1 kHz and times each SENSOR answer. Ours: a real-time dentsim session (mesher on, cutting
//! with the pedal held) reading those poses through its OpenIGTLink device. Peer: the same
//! reference library answering at the other end too (`igtl_peer echo`). The session's tick
//! periods give `loop_period_igtl`: the loop's deadlines with device I/O running.
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use dentsim_devices::igtl::{IgtlDevice, IgtlOptions};
use dentsim_sim::error::{invalid, Result};
use dentsim_sim::haptics::tick::HapticParams;
use dentsim_sim::session::threads::{run_session, SessionOptions, DEFAULT_MESHER_HZ};
use glam::DVec3;

use crate::{BenchRow, BenchTooth, Timings};

const PEER_SOURCE: &str = include_str!("../../devices/peers/igtl_peer.cxx");

/// Builds the reference peer into `dir` (c++ and libopenigtlink-dev, scripts/setup.sh).
pub fn build_reference_peer(dir: &Path) -> Result<PathBuf> {
    let src = dir.join("igtl_peer.cxx");
    let exe = dir.join("igtl_peer");
    std::fs::write(&src, PEER_SOURCE).map_err(|e| invalid("igtl peer source", e.to_string()))?;
    let out = Command::new("c++")
        .args(["-O2", "-std=c++14", "-I/usr/include/openigtlink"])
        .arg(&src)
        .arg("-o")
        .arg(&exe)
        .args(["-L/usr/lib", "-lOpenIGTLink"])
        .output()
        .map_err(|e| invalid("igtl reference peer", format!("cannot run c++: {e} (scripts/setup.sh installs build-essential)")))?;
    if !out.status.success() {
        return Err(invalid(
            "igtl reference peer",
            format!("build failed (needs libopenigtlink-dev, scripts/setup.sh): {}", String::from_utf8_lossy(&out.stderr)),
        ));
    }
    Ok(exe)
}

fn free_port() -> Result<u16> {
    let l = std::net::TcpListener::bind("127.0.0.1:0").map_err(|e| invalid("loopback port", e.to_string()))?;
    l.local_addr().map(|a| a.port()).map_err(|e| invalid("loopback port", e.to_string()))
}

fn spawn_server(peer: &Path, port: u16, count: usize, a: DVec3, b: DVec3) -> Result<std::process::Child> {
    let mut args = vec!["server".to_string(), port.to_string(), count.to_string(), "1000".into()];
    args.extend([a.x, a.y, a.z, b.x, b.y, b.z].iter().map(|v| format!("{v}")));
    Command::new(peer)
        .args(&args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| invalid("igtl reference peer", e.to_string()))
}

/// The server's round trips (µs), after checking it ran to the end: the first (it waits for the
/// session to start) and the stream's.
fn round_trips(child: std::process::Child, count: usize) -> Result<(f64, Vec<f64>)> {
    let out = child.wait_with_output().map_err(|e| invalid("igtl reference peer", e.to_string()))?;
    if !out.status.success() {
        return Err(invalid("igtl reference peer", String::from_utf8_lossy(&out.stderr).into_owned()));
    }
    let text = String::from_utf8_lossy(&out.stdout);
    let rt: Vec<f64> = text.lines().filter_map(|l| l.split_whitespace().next()?.parse().ok()).collect();
    if rt.len() != count || count < 2 {
        return Err(invalid("igtl reference peer", format!("{} answers to {count} poses (at least 2 needed)", rt.len())));
    }
    Ok((rt[0], rt[1..].to_vec()))
}

/// The two rows; `poses` at 1 kHz (3000 = 3 s for the full run).
pub fn igtl_round_trip(tooth: &BenchTooth, poses: usize) -> Result<Vec<BenchRow>> {
    let dir = std::env::temp_dir().join(format!("dentsim-bench-igtl-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| invalid("bench temp dir", e.to_string()))?;
    let peer = build_reference_peer(&dir)?;
    let (a, b) = (tooth.occlusal + DVec3::new(0.0, 0.0, 0.6), tooth.occlusal + DVec3::new(0.3, 0.0, -1.0));

    let raise_priority = std::env::var("DENTSIM_NO_FIFO").is_err();
    // Ours: the session as `dentsim session --device igtl://...?pedal=1 --realtime` runs it.
    let port = free_port()?;
    let server = spawn_server(&peer, port, poses, a, b)?;
    let device = IgtlDevice::connect(IgtlOptions { port, pedal: true, ..IgtlOptions::default() })
        .map_err(|e| invalid("igtl device", e.to_string()))?;
    let counters = device.counters_handle();
    let options = SessionOptions {
        params: HapticParams::default(),
        realtime: true,
        // The peer ends the session; this only bounds a broken run.
        max_duration_s: poses as f64 * 1e-3 + 60.0,
        raise_priority,
        mesher_hz: Some(DEFAULT_MESHER_HZ),
        log_path: None,
        ..Default::default()
    };
    let outcome = run_session(tooth.model.clone(), device, options)?;
    let c = counters.get();
    let (ours_first, ours) = round_trips(server, poses).map_err(|e| {
        let n = |a: &std::sync::atomic::AtomicU64| a.load(std::sync::atomic::Ordering::Relaxed);
        invalid("igtl_round_trip", format!("{e}; client saw {} poses, {} dropped, {} reconnects ({} for silence)", n(&c.poses), n(&c.dropped), n(&c.reconnects), n(&c.silences)))
    })?;
    let ours = Timings(ours);

    // Peer: the reference library at both ends.
    let port = free_port()?;
    let server = spawn_server(&peer, port, poses, a, b)?;
    let echo = Command::new(&peer)
        .args(["echo", "127.0.0.1", &port.to_string()])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .map_err(|e| invalid("igtl reference peer", e.to_string()))?;
    let (_, theirs) = round_trips(server, poses)?;
    let theirs = Timings(theirs);
    let _ = echo.wait_with_output();
    let _ = std::fs::remove_dir_all(&dir);

    let peer = format!(
        "reference C++ OpenIGTLink at both ends (igtl_peer echo; its p99 {:.1} us); goal: p99 <= 500 us; the first pose, answered once the session ran, after {:.1} ms (not counted)",
        theirs.quantile(0.99),
        ours_first * 1e-3
    );
    let mut rt = BenchRow::new("igtl_round_trip", &ours, &peer, &theirs);
    rt.ours_p999_us = Some(ours.quantile(0.999));
    let periods = crate::deadline_row("loop_period_igtl", &Timings(outcome.periods_us), raise_priority, "goal: p99.9 <= 1100 us, OpenIGTLink I/O at 1 kHz and the mesher running")?;
    Ok(vec![rt, periods])
}
