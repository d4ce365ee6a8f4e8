//! A device that drops out mid-session (unplugged, a stalled link): zero force from the tick it
//! faults, the proxy held, the session goes on and takes the device back when it answers.
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use dentsim_devices::{Device, DeviceState, Fault, HandParams, SimulatedHand};
use dentsim_sim::session::log::{SessionLog, FLAG_DEVICE_FAULT, FLAG_MISSED};
use dentsim_sim::session::threads::{run_session, SessionOptions};
use dentsim_sim::tissues::capsule::CapsuleTooth;
use dentsim_sim::tissues::table::TissueTable;
use glam::DVec3;

/// The sessions here run one at a time: beside another session on a 2-core machine, a real-time
/// one's deadlines would be late for reasons the test does not make.
static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Faults from `from_s` to `to_s`; counts the forces it is sent while faulted that are not zero.
/// Its poll stalls once for 6 ms at `stall_at_s`, as the OS preempting the haptic thread would.
struct Flaky {
    hand: SimulatedHand,
    from_s: f64,
    to_s: f64,
    faulted: bool,
    nonzero_in_fault: Arc<AtomicU64>,
    sends_in_fault: Arc<AtomicU64>,
    stall_at_s: f64,
    stalled: bool,
}

impl Flaky {
    fn new(hand: SimulatedHand, from_s: f64, to_s: f64) -> Self {
        Flaky { hand, from_s, to_s, faulted: false, nonzero_in_fault: Arc::default(), sends_in_fault: Arc::default(), stall_at_s: f64::INFINITY, stalled: false }
    }
}

impl Device for Flaky {
    fn poll(&mut self, t: f64) -> Result<DeviceState, Fault> {
        if t >= self.stall_at_s && !self.stalled {
            self.stalled = true;
            std::thread::sleep(std::time::Duration::from_millis(6));
        }
        self.faulted = t >= self.from_s && t < self.to_s;
        if self.faulted {
            return Err(Fault::Disconnected);
        }
        self.hand.poll(t)
    }
    fn send_force(&mut self, force: DVec3, torque: DVec3) {
        if self.faulted {
            self.sends_in_fault.fetch_add(1, Ordering::Relaxed);
            if force != DVec3::ZERO || torque != DVec3::ZERO {
                self.nonzero_in_fault.fetch_add(1, Ordering::Relaxed);
            }
        }
        self.hand.send_force(force, torque)
    }
    fn finished(&self, t: f64) -> bool {
        self.hand.finished(t)
    }
    fn name(&self) -> &str {
        "flaky hand"
    }
}

#[test]
fn a_fault_sends_zero_force_that_tick_and_the_session_goes_on() {
    let _one_at_a_time = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let model = CapsuleTooth::default().build(0.05, &TissueTable::default()).unwrap();
    // Touch mode: the hand presses on the enamel (top at z = 5) with 1 N.
    let hand = SimulatedHand::new(HandParams { start: DVec3::new(0.0, 0.0, 5.3), target: DVec3::new(0.0, 0.0, 3.0), duration_s: 1.5, ..Default::default() });
    let dev = Flaky::new(hand, 0.8, 0.9);
    let (nonzero, sends) = (dev.nonzero_in_fault.clone(), dev.sends_in_fault.clone());
    let log = dir.path().join("s.dslog");
    let options = SessionOptions { realtime: false, log_path: Some(log.clone()), mesher_hz: None, raise_priority: false, ..Default::default() };
    let out = run_session(model, dev, options).unwrap();
    assert_eq!(out.device_faults, 100);
    assert_eq!((sends.load(Ordering::Relaxed), nonzero.load(Ordering::Relaxed)), (100, 0), "every faulted tick sent zero force");
    let log = SessionLog::read(&log).unwrap();
    let at = |t: f64| log.records.iter().find(|r| r.t_s >= t - 1e-9).unwrap();
    assert!(at(0.79).force.length() > 0.5, "pressing before: {}", at(0.79).force);
    let faulted: Vec<_> = log.records.iter().filter(|r| r.flags & FLAG_DEVICE_FAULT != 0).collect();
    assert_eq!(faulted.len(), 100);
    assert!(faulted.iter().all(|r| r.force == DVec3::ZERO && r.tissue == -1));
    assert!(at(0.95).force.length() > 0.5, "pressing again after: {}", at(0.95).force);
    assert!(log.records.last().unwrap().t_s > 1.4, "the session went on to the hand's end");
}

/// A session with a dropout, replayed: the faulted ticks ran no tick, and the replay runs none
/// either, so every force and every cut comes out as logged.
#[test]
fn a_session_with_a_dropout_replays_bit_for_bit() {
    let _one_at_a_time = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let model = CapsuleTooth::default().build(0.08, &TissueTable::default()).unwrap();
    let start = model.clone();
    // Cut mode: the pedal held, the hand drilling down through the dropout.
    let hand = SimulatedHand::new(HandParams {
        start: DVec3::new(0.0, 0.0, 5.6),
        target: DVec3::new(0.0, 0.0, 3.0),
        push_n: 2.0,
        pedal: true,
        rpm: 400_000.0,
        duration_s: 1.5,
        ..Default::default()
    });
    let dev = Flaky::new(hand, 0.6, 0.75);
    let path = dir.path().join("f.dslog");
    let options = SessionOptions { realtime: false, log_path: Some(path.clone()), mesher_hz: None, raise_priority: false, ..Default::default() };
    let out = run_session(model, dev, options).unwrap();
    assert_eq!(out.device_faults, 150);
    let log = SessionLog::read(&path).unwrap();
    let again = dentsim_sim::session::replay::replay(&log, start).unwrap();
    assert_eq!((again.max_force_difference_n, again.ticks_cut_differently, again.ticks_guided_differently), (0.0, 0, Some(0)));
    for (a, b) in again.model.tissues.iter().zip(&out.model.tissues) {
        assert_eq!(a.grid.content_hash(), b.grid.content_hash(), "{}", a.props.name);
    }
    assert!(out.removed_mm3.iter().any(|(_, v)| *v > 0.1), "it cut: {:?}", out.removed_mm3);
}

#[test]
fn a_paused_session_renders_no_force_and_logs_nothing_then_resumes() {
    let _one_at_a_time = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    use dentsim_sim::session::threads::Session;
    let dir = tempfile::tempdir().unwrap();
    let model = CapsuleTooth::default().build(0.08, &TissueTable::default()).unwrap();
    let hand = SimulatedHand::new(HandParams { start: DVec3::new(0.0, 0.0, 5.3), target: DVec3::new(0.0, 0.0, 3.0), duration_s: 1.0, ..Default::default() });
    // Never faults: counts nothing; the pause is what is tested.
    let dev = Flaky::new(hand, -1.0, -1.0);
    let log = dir.path().join("p.dslog");
    let options = SessionOptions { realtime: true, log_path: Some(log.clone()), mesher_hz: None, raise_priority: false, ..Default::default() };
    let session = Session::start(model, dev, options).unwrap();
    // Pressing on the enamel first, then paused mid-session.
    let pressing = |s: &Session| s.latest().is_some_and(|r| r.force.length() >= 0.1);
    while session.is_running() && !pressing(&session) {
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    assert!(pressing(&session), "the hand pressed on the enamel before its end: {:?}", session.latest().map(|r| r.force));
    session.set_paused(true);
    assert!(session.is_paused());
    std::thread::sleep(std::time::Duration::from_millis(200));
    session.set_paused(false);
    while session.is_running() {
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let out = session.stop().unwrap();
    let log = SessionLog::read(&log).unwrap();
    let skipped = out.ticks - log.records.len() as u64;
    println!("{} ticks, {} logged, {} paused", out.ticks, log.records.len(), skipped);
    assert!(skipped > 0, "the paused ticks are not logged");
    assert!(log.records.windows(2).all(|w| w[1].tick > w[0].tick));
    // The gap is the pause; after it the session renders force again.
    let gap = log.records.windows(2).position(|w| w[1].tick > w[0].tick + 1).expect("a gap where the pause was");
    let after = log.records[gap + 1..].iter().map(|r| r.force.length()).fold(0.0, f64::max);
    assert!(after > 0.1, "pressing again after the pause: max {after} N");
}

/// A 6 ms stall in real time: the loop runs the ticks it owes back to back, each late but less
/// late than the last. The log holds them as missed, the watchdog takes them as the one miss (no
/// trip unless the machine made other misses beside them), and replay, fed each tick's lateness
/// from the log, renders every force as the session did.
#[test]
fn a_stalls_catch_up_is_one_miss_and_replays_bit_for_bit() {
    let _one_at_a_time = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let model = CapsuleTooth::default().build(0.08, &TissueTable::default()).unwrap();
    let start = model.clone();
    let hand = SimulatedHand::new(HandParams { start: DVec3::new(0.0, 0.0, 5.3), target: DVec3::new(0.0, 0.0, 3.0), duration_s: 0.8, ..Default::default() });
    // Never faults; stalls once at 0.5 s.
    let dev = Flaky { stall_at_s: 0.5, ..Flaky::new(hand, -1.0, -1.0) };
    let path = dir.path().join("stall.dslog");
    let options = SessionOptions { realtime: true, log_path: Some(path.clone()), mesher_hz: None, raise_priority: false, ..Default::default() };
    let out = run_session(model, dev, options).unwrap();
    let log = SessionLog::read(&path).unwrap();
    let missed = |r: &dentsim_sim::session::log::TickRecord| r.flags & FLAG_MISSED != 0;
    let stalled = log.records.iter().position(|r| r.t_s >= 0.5 - 1e-9).unwrap();
    let run: Vec<f64> = log.records[stalled + 1..].iter().take_while(|r| missed(r)).map(|r| r.wall_s - r.t_s).collect();
    assert!(run.len() >= 3, "the stall left at least three ticks late in a row: {run:?}");
    let others = log.records.iter().enumerate().filter(|(i, r)| missed(r) && !(stalled + 1..=stalled + run.len()).contains(i)).count();
    println!("catch-up {} ticks late {:.2}..{:.2} ms; {others} other missed ticks; {} trips", run.len(), 1e3 * run[0], 1e3 * run[run.len() - 1], out.watchdog_trips);
    // Tripped, the force would ramp to zero over 50 ticks and stay there 200 more while the hand
    // presses on; one miss leaves it as the contact makes it.
    let force = |i: usize| log.records[i].force.length();
    let (before, after) = (force(stalled - 1), (stalled + run.len() + 1..stalled + run.len() + 150).map(force).fold(f64::INFINITY, f64::min));
    println!("force {before:.2} N before the stall, at least {after:.2} N the 150 ticks after");
    assert!(after > 0.5 * before && before > 0.3, "the force held through the catch-up: {before} N before, {after} N after");
    let again = dentsim_sim::session::replay::replay(&log, start).unwrap();
    assert_eq!((again.max_force_difference_n, again.ticks_cut_differently), (0.0, 0));
}
