//! A haptic session: three threads joined by wait-free `rtrb` queues.
//!
//! - haptic (1 kHz, raised priority where permitted): owns the [`TissueModel`] while the session
//!   runs; each tick polls the device, runs [`HapticCore::tick`] (proxy, force, cut), sends the
//!   force and pushes a [`TickRecord`] to the logger and what each cut changed to the mesher. No
//!   lock, no I/O, no allocation (tests/no_alloc.rs): before the first tick the grids' insides
//!   become leaves and every cut buffer is grown ([`HapticCore::prepare_cutting`]); cuts skip
//!   measuring removed volume, which follows from the grids at the end.
//! - mesher (frames at most `mesher_hz` apart, as soon as a cut arrives): keeps a copy of the grids
//!   taken at the start and writes into it the voxels each cut changed, with their new values
//!   (one queue per tissue), so it never reads the grids the haptic thread writes and nothing is
//!   cut twice; then re-meshes the chunks those voxels dirtied and publishes the tissues' meshes.
//!   Only when a cut's voxels do not fit the queues does the stroke itself go over, to be cut again
//!   on the copy (strokes are deterministic, so the copy still equals the haptic model up to what
//!   is queued).
//! - logger: drains records to the binary log, flushing at least every 10 ms, and keeps the
//!   latest record for displays (the plugin's live source).
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use dentsim_devices::{Device, DeviceState};
use dentsim_vdb::{Measure, TriMesh, VoxelChange};
use glam::{DAffine3, DVec3};

use crate::burr::Burr;
use crate::cutting::cutter::{Cutter, Handoff};
use crate::cutting::dirty::DirtyLeaves;
use crate::cutting::sweep::Done;
use crate::error::{invalid, Error, Result};
use crate::haptics::force::MAX_TISSUES;
use crate::haptics::tick::{HapticCore, HapticParams};
use crate::haptics::watchdog::Deadline;
use crate::session::guidance::{GuidanceReport, GuidanceTracker};
use crate::session::log::{write_header, write_record, LogHeader, TickRecord, FLAG_CUT, FLAG_DEVICE_FAULT, FLAG_MISSED};
use crate::tissues::model::{TissueModel, TissueVolumes};
use crate::tissues::surface::{Mesher, SurfaceFrame};

/// How a session runs.
#[derive(Clone, Debug)]
pub struct SessionOptions {
    pub params: HapticParams,
    /// Tick on the wall clock (a live device). `false` runs ticks back to back with the same
    /// session time steps (headless, tests): identical physics, no waiting.
    pub realtime: bool,
    /// Stop after this much session time even if the device has not finished (s).
    pub max_duration_s: f64,
    /// Where the binary log goes (written by the logger thread); `None` for no log.
    pub log_path: Option<PathBuf>,
    /// Most mesh frames per second (a frame follows a cut at once when the last is this old);
    /// `None` runs no mesher.
    pub mesher_hz: Option<f64>,
    /// Try SCHED_FIFO for the haptic thread (ignored where not permitted).
    pub raise_priority: bool,
    /// Room for changed voxels in flight to the mesher, per tissue; a cut that does not fit goes
    /// over as its stroke and is cut again on the mesher's copy.
    pub mesher_queue_voxels: usize,
}

impl Default for SessionOptions {
    fn default() -> Self {
        SessionOptions {
            params: HapticParams::default(),
            realtime: true,
            max_duration_s: 600.0,
            log_path: None,
            mesher_hz: Some(DEFAULT_MESHER_HZ),
            raise_priority: true,
            mesher_queue_voxels: QUEUE_CHANGES,
        }
    }
}

/// What a finished session hands back.
pub struct SessionOutcome {
    pub model: TissueModel,
    pub ticks: u64,
    pub missed_deadlines: u64,
    pub watchdog_trips: u32,
    pub device_faults: u64,
    /// Records or strokes the queues could not take (should be 0).
    pub dropped_records: u64,
    pub dropped_strokes: u64,
    /// Cuts whose changed voxels did not fit the mesher's queues, so it cut them again.
    pub strokes_recut: u64,
    /// Volume removed per tissue (mm³): the volume at the start minus the volume at the end.
    pub removed_mm3: Vec<(String, f64)>,
    /// Each tissue's volume at the start and the end and what it lost (model order).
    pub volumes: Vec<TissueVolumes>,
    /// Ticks spent in contact with each tissue.
    pub contact_ticks: Vec<(String, u64)>,
    pub max_force_n: f64,
    /// Intervals between tick starts (µs), from the log records.
    pub periods_us: Vec<f64>,
    /// Stroke cut → mesh showing it published (ms), one per stroke that changed voxels.
    pub cut_to_visible_ms: Vec<f64>,
    pub meshes_published: u64,
    /// The mesher's last published mesh of each tissue (model order; `None` if never cut).
    pub final_meshes: Vec<Option<Arc<TriMesh>>>,
    pub log_path: Option<PathBuf>,
    /// The contact sequence collapsed to its changes: (tissue index or −1, first tick).
    pub contact_changes: Vec<(i32, u64)>,
    /// The last tick logged (what a display should show at the end).
    pub last_record: Option<TickRecord>,
    /// Cuts too close to the pulp, from the logged ticks.
    pub guidance: GuidanceReport,
}

/// Default cap on mesh frames per second: a cut shows within one frame gap plus its meshing,
/// inside the next 60 Hz display frame (`dentsim bench`'s `cut_to_visible`).
pub const DEFAULT_MESHER_HZ: f64 = 120.0;

/// A cut for the mesher: when it was made and how many changed voxels of each tissue follow in
/// the change queues, or, when they did not fit there, the stroke to cut again.
#[derive(Clone, Copy)]
struct StrokeMsg {
    at: Instant,
    counts: [u32; MAX_TISSUES],
    recut: Option<Recut>,
}

/// A stroke to cut again: its poses and the done head its cut skipped.
#[derive(Clone, Copy)]
struct Recut {
    from: DAffine3,
    to: DAffine3,
    skipped: Option<Done>,
}

struct Shared {
    stop: AtomicBool,
    /// Paused by the user: zero force, nothing cut or logged, the clock goes on.
    paused: AtomicBool,
    haptic_done: AtomicBool,
    latest: Mutex<Option<TickRecord>>,
    /// The guidance events so far (the logger's, for displays).
    guidance: Mutex<GuidanceReport>,
    frames: Mutex<Vec<Option<Arc<SurfaceFrame>>>>,
}

struct HapticStats {
    ticks: u64,
    missed: u64,
    faults: u64,
    dropped_records: u64,
    dropped_strokes: u64,
    recut: u64,
    trips: u32,
}

struct LoggerStats {
    periods_us: Vec<f64>,
    contact_ticks: Vec<u64>,
    max_force: f64,
    changes: Vec<(i32, u64)>,
    last: Option<TickRecord>,
    guidance: GuidanceReport,
}

struct MesherStats {
    latencies_ms: Vec<f64>,
    published: u64,
}

/// A running session. Drop without `stop` stops it too (and loses the model).
pub struct Session {
    shared: Arc<Shared>,
    haptic: Option<JoinHandle<(TissueModel, Result<HapticStats>)>>,
    logger: Option<JoinHandle<Result<LoggerStats>>>,
    mesher: Option<JoinHandle<MesherStats>>,
    names: Vec<String>,
    log_path: Option<PathBuf>,
    /// Each tissue's volume at the start: the session's removed volume is what is gone at the end.
    start_volumes: Vec<f64>,
}

const QUEUE_RECORDS: usize = 1 << 14;
const QUEUE_STROKES: usize = 1 << 14;
/// Changed voxels in flight to the mesher, per tissue (8 MiB): a hundred ticks of a typical cut.
pub const QUEUE_CHANGES: usize = 1 << 19;

impl Session {
    /// Starts the threads; the model moves into the haptic thread until [`Session::stop`].
    pub fn start<D: Device + 'static>(model: TissueModel, mut device: D, options: SessionOptions) -> Result<Session> {
        if !(options.max_duration_s.is_finite() && options.max_duration_s > 0.0) {
            return Err(invalid("session max_duration_s", format!("{}, expected > 0", options.max_duration_s)));
        }
        if let Some(hz) = options.mesher_hz {
            if !(hz.is_finite() && hz > 0.0 && hz <= 1000.0) {
                return Err(invalid("mesher_hz", format!("{hz}, expected 0 < hz <= 1000")));
            }
        }
        let mut core = HapticCore::new(options.params.clone(), &model)?;
        let names: Vec<String> = model.tissues.iter().map(|t| t.props.name.clone()).collect();
        let shared = Arc::new(Shared {
            stop: AtomicBool::new(false),
            paused: AtomicBool::new(false),
            haptic_done: AtomicBool::new(false),
            latest: Mutex::new(None),
            guidance: Mutex::new(GuidanceReport::default()),
            frames: Mutex::new(vec![None; names.len()]),
        });
        let (mut rec_tx, rec_rx) = rtrb::RingBuffer::<TickRecord>::new(QUEUE_RECORDS);
        let (mut stroke_tx, stroke_rx) = rtrb::RingBuffer::<StrokeMsg>::new(QUEUE_STROKES);
        let (mut change_tx, change_rx): (Vec<_>, Vec<_>) = match options.mesher_hz {
            Some(_) => (0..names.len()).map(|_| rtrb::RingBuffer::<VoxelChange>::new(options.mesher_queue_voxels.max(1))).unzip(),
            None => (Vec::new(), Vec::new()),
        };

        // Logger: open the file before any work so a bad path fails here.
        let mut writer = match &options.log_path {
            Some(path) => {
                let file = File::create(path).map_err(|e| Error::File { path: path.clone(), message: e.to_string() })?;
                Some((BufWriter::with_capacity(1 << 16, file), path.clone()))
            }
            None => None,
        };
        let header = LogHeader {
            params: options.params.clone(),
            device: device.name().to_string(),
            tissues: names.clone(),
            start_hashes: model.tissues.iter().map(|t| t.grid.content_hash()).collect(),
            source: model.source.clone(),
            started_unix_s: 0.0,
        };
        let mirror = options.mesher_hz.map(|hz| (model.clone(), hz));
        let burr = core.burr().clone();
        // Leaves for the whole interior and the cut buffers now, so the haptic thread's cuts
        // never allocate.
        let mut model = model;
        if mirror.is_some() {
            core.set_handoff(Handoff::NewValues);
        }
        // Guidance reads the pulp as it is now, before any cut (a replay does the same).
        core.prepare_guidance(&model)?;
        core.prepare_cutting(&mut model)?;
        // The haptic ticks skip measuring removed volume (half a cut's cost): it follows from the
        // volumes before and after, and the mesher's mirror and a replay measure every stroke.
        core.set_measure(Measure::Skip);
        let start_volumes = model.tissues.iter().map(|t| t.grid.volume()).collect();

        if let Some((w, path)) = writer.as_mut() {
            // Just before the threads start, so `started_unix_s` is within a thread spawn of
            // tick 0; flushed now, so a session killed before its first tick leaves a readable log.
            let started_unix_s = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0.0, |d| d.as_secs_f64());
            write_header(w, &LogHeader { started_unix_s, ..header })
                .and_then(|()| w.flush())
                .map_err(|e| Error::File { path: path.clone(), message: e.to_string() })?;
        }
        let s = shared.clone();
        let n_tissues = names.len();
        let tracker = GuidanceTracker::new(&options.params.guidance, options.params.period_s);
        let raise = options.raise_priority;
        let logger = std::thread::Builder::new()
            .name("dentsim-logger".into())
            .spawn(move || {
                // Below the haptic thread, above everything else: a busy machine must not hold
                // the log's flushes back (a kill loses what is not flushed).
                if raise {
                    raise_priority(LOGGER_FIFO, LOGGER_NICE);
                }
                logger_loop(rec_rx, writer, &s, n_tissues, tracker)
            })
            .map_err(|e| invalid("logger thread", e.to_string()))?;
        let mesher = match mirror {
            Some((mirror, hz)) => {
                let s = shared.clone();
                Some(
                    std::thread::Builder::new()
                        .name("dentsim-mesher".into())
                        .spawn(move || mesher_loop(stroke_rx, change_rx, mirror, burr, hz, &s))
                        .map_err(|e| invalid("mesher thread", e.to_string()))?,
                )
            }
            None => None,
        };
        let s = shared.clone();
        let log_path = options.log_path.clone();
        let haptic = std::thread::Builder::new()
            .name("dentsim-haptic".into())
            .spawn(move || {
                if options.raise_priority {
                    raise_priority(HAPTIC_FIFO, HAPTIC_NICE);
                }
                let mut model = model;
                let mut core = core;
                let mut mesher = MesherQueues { strokes: &mut stroke_tx, changes: &mut change_tx };
                let r = haptic_loop(&mut core, &mut model, &mut device, &options, &mut rec_tx, &mut mesher, &s);
                device.send_force(DVec3::ZERO, DVec3::ZERO);
                s.haptic_done.store(true, Ordering::Release);
                (model, r)
            })
            .map_err(|e| invalid("haptic thread", e.to_string()))?;
        Ok(Session { shared, haptic: Some(haptic), logger: Some(logger), mesher, names, log_path, start_volumes })
    }

    /// The latest tick the logger has seen (for displays; lags the haptic thread by ≤ 2 ms).
    pub fn latest(&self) -> Option<TickRecord> {
        *self.shared.latest.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// The latest frame of each tissue the mesher published (model order).
    pub fn latest_frames(&self) -> Vec<Option<Arc<SurfaceFrame>>> {
        self.shared.frames.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }

    /// The guidance events the logger has seen so far.
    pub fn guidance(&self) -> GuidanceReport {
        self.shared.guidance.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }

    /// Each tissue's volume when the session started (mm³, model order).
    pub fn start_volumes(&self) -> &[f64] {
        &self.start_volumes
    }

    pub fn tissue_names(&self) -> &[String] {
        &self.names
    }

    /// Pauses or resumes the session: while paused each tick still reads the device but renders
    /// zero force, cuts nothing and logs nothing (the log skips those ticks); the proxy holds.
    pub fn set_paused(&self, paused: bool) {
        self.shared.paused.store(paused, Ordering::Release);
    }

    pub fn is_paused(&self) -> bool {
        self.shared.paused.load(Ordering::Acquire)
    }

    /// True while the haptic thread runs (a scripted device ends it by finishing).
    pub fn is_running(&self) -> bool {
        !self.shared.haptic_done.load(Ordering::Acquire)
    }

    /// Stops the session, joins every thread and returns the model.
    pub fn stop(mut self) -> Result<SessionOutcome> {
        self.shared.stop.store(true, Ordering::Release);
        let joined = self.haptic.take().expect("haptic thread").join();
        let (mut model, haptic) = joined.map_err(|_| invalid("haptic thread", "panicked"))?;
        model.compact();
        let logger = self.logger.take().expect("logger thread").join().map_err(|_| invalid("logger thread", "panicked"))?;
        let mesher = match self.mesher.take() {
            Some(m) => Some(m.join().map_err(|_| invalid("mesher thread", "panicked"))?),
            None => None,
        };
        let haptic = haptic?;
        let logger = logger?;
        let names = self.names.clone();
        // Each grid's volume once: the removed volume is the volume at the start less at the end.
        let volumes: Vec<TissueVolumes> = names
            .iter()
            .zip(&self.start_volumes)
            .zip(&model.tissues)
            .map(|((name, before), t)| {
                let after = t.grid.volume();
                TissueVolumes { name: name.clone(), volume_before_mm3: *before, volume_after_mm3: after, removed_mm3: before - after }
            })
            .collect();
        Ok(SessionOutcome {
            ticks: haptic.ticks,
            missed_deadlines: haptic.missed,
            watchdog_trips: haptic.trips,
            device_faults: haptic.faults,
            dropped_records: haptic.dropped_records,
            dropped_strokes: haptic.dropped_strokes,
            strokes_recut: haptic.recut,
            removed_mm3: volumes.iter().map(|v| (v.name.clone(), v.removed_mm3)).collect(),
            volumes,
            contact_ticks: names.iter().cloned().zip(logger.contact_ticks).collect(),
            max_force_n: logger.max_force,
            periods_us: logger.periods_us,
            cut_to_visible_ms: mesher.as_ref().map_or_else(Vec::new, |m| m.latencies_ms.clone()),
            meshes_published: mesher.map_or(0, |m| m.published),
            final_meshes: self.latest_frames().iter().map(|f| f.as_ref().map(|f| Arc::new(f.to_mesh()))).collect(),
            log_path: self.log_path.clone(),
            contact_changes: logger.changes,
            last_record: logger.last,
            guidance: logger.guidance,
            model,
        })
    }
}

impl Drop for Session {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::Release);
        if let Some(h) = self.haptic.take() {
            let _ = h.join();
        }
        if let Some(h) = self.logger.take() {
            let _ = h.join();
        }
        if let Some(h) = self.mesher.take() {
            let _ = h.join();
        }
    }
}

/// Runs a headless session until the device finishes (or `max_duration_s`), then stops it.
pub fn run_session<D: Device + 'static>(model: TissueModel, device: D, options: SessionOptions) -> Result<SessionOutcome> {
    let session = Session::start(model, device, options)?;
    while session.is_running() {
        std::thread::sleep(Duration::from_millis(2));
    }
    session.stop()
}

/// Priorities (thread_priority's cross-platform 0–99) of the haptic and logger threads, as
/// SCHED_FIFO where permitted, else as raised normal priorities.
const HAPTIC_FIFO: u8 = 50;
const HAPTIC_NICE: u8 = 20;
const LOGGER_FIFO: u8 = 30;
const LOGGER_NICE: u8 = 10;

/// Real-time priority where the system permits it: SCHED_FIFO (root, CAP_SYS_NICE or an rtprio
/// limit), else a raised normal priority; without either the thread keeps its priority and the
/// watchdog covers missed deadlines. The tick sleeps for most of its period, so a FIFO haptic
/// thread leaves the mesher and logger most of a core.
/// The logger, a FIFO thread too, sleeps 2 ms between drains and takes little of it.
fn raise_priority(fifo_value: u8, normal_value: u8) {
    use thread_priority::{
        set_thread_priority_and_policy, thread_native_id, RealtimeThreadSchedulePolicy, ThreadPriority, ThreadPriorityValue,
        ThreadSchedulePolicy,
    };
    let fifo = ThreadSchedulePolicy::Realtime(RealtimeThreadSchedulePolicy::Fifo);
    if let Ok(value) = ThreadPriorityValue::try_from(fifo_value) {
        if set_thread_priority_and_policy(thread_native_id(), ThreadPriority::Crossplatform(value), fifo).is_ok() {
            return;
        }
    }
    if let Ok(value) = ThreadPriorityValue::try_from(normal_value) {
        let _ = thread_priority::set_current_thread_priority(ThreadPriority::Crossplatform(value));
    }
}

/// Sleeps until 200 µs before `deadline`, then spins: the OS sleep alone is ~50–100 µs late.
/// Not longer: a spinning FIFO haptic thread holds its core, and an OpenIGTLink answer whose I/O
/// thread waits behind it was up to the spin late (`igtl_round_trip` p99 551–559 µs in two of
/// seven runs at 300 µs; ≤ 474 µs in eleven at 200, `loop_period` p99.9 unchanged).
fn wait_until(deadline: Instant) {
    const SPIN: Duration = Duration::from_micros(200);
    let now = Instant::now();
    if deadline > now + SPIN {
        std::thread::sleep(deadline - now - SPIN);
    }
    while Instant::now() < deadline {
        std::hint::spin_loop();
    }
}

/// Tick starts (s from the loop's start) of an empty loop: the haptic thread's priority and wait
/// with no work and no other thread of ours, ticks 0..=`ticks` of `period_s`. Their intervals are
/// the floor the machine itself sets under a session's periods (`dentsim bench`'s loop rows).
pub fn idle_loop_starts_s(ticks: usize, period_s: f64, raise: bool) -> Result<Vec<f64>> {
    if !(period_s.is_finite() && period_s > 0.0) {
        return Err(invalid("idle loop period_s", format!("{period_s}, expected > 0")));
    }
    let run = move || {
        if raise {
            raise_priority(HAPTIC_FIFO, HAPTIC_NICE);
        }
        let mut starts = Vec::with_capacity(ticks + 1);
        let start = Instant::now();
        for tick in 0..=ticks {
            wait_until(start + Duration::from_secs_f64(tick as f64 * period_s));
            starts.push(start.elapsed().as_secs_f64());
        }
        starts
    };
    let thread = std::thread::Builder::new().name("dentsim-idle-loop".into()).spawn(run).map_err(|e| invalid("idle loop thread", e.to_string()))?;
    thread.join().map_err(|_| invalid("idle loop thread", "panicked"))
}

fn haptic_loop<D: Device>(
    core: &mut HapticCore,
    model: &mut TissueModel,
    device: &mut D,
    options: &SessionOptions,
    records: &mut rtrb::Producer<TickRecord>,
    mesher: &mut MesherQueues,
    shared: &Shared,
) -> Result<HapticStats> {
    let period = options.params.period_s;
    let mut stats = HapticStats { ticks: 0, missed: 0, faults: 0, dropped_records: 0, dropped_strokes: 0, recut: 0, trips: 0 };
    let mut last: Option<DeviceState> = None;
    let start = Instant::now();
    let mut tick: u64 = 0;
    while !shared.stop.load(Ordering::Acquire) {
        let t = tick as f64 * period;
        let deadline = start + Duration::from_secs_f64(t);
        if options.realtime {
            wait_until(deadline);
        }
        let wall = start.elapsed().as_secs_f64();
        let missed = options.realtime && wall - t > 0.5 * period;
        let mut flags = if missed { FLAG_MISSED } else { 0 };
        if shared.paused.load(Ordering::Acquire) {
            // The device is still read (its queues drained) but renders nothing.
            let _ = device.poll(t);
            device.send_force(DVec3::ZERO, DVec3::ZERO);
            tick += 1;
            if device.finished(t) || t >= options.max_duration_s {
                break;
            }
            continue;
        }
        let state = match device.poll(t) {
            Ok(s) => s,
            Err(_) => {
                // Unplugged, stalled or not yet connected: zero force this very tick, the proxy
                // holds, and the session goes on until the device is back (or ends it).
                stats.faults += 1;
                stats.missed += u64::from(missed);
                device.send_force(DVec3::ZERO, DVec3::ZERO);
                if let Some(s) = last {
                    let record = TickRecord {
                        tick,
                        t_s: t,
                        wall_s: wall,
                        pose: s.pose,
                        buttons: s.buttons,
                        rpm: s.rpm,
                        force: DVec3::ZERO,
                        torque: DVec3::ZERO,
                        proxy: core.proxy(),
                        tissue: -1,
                        flags: flags | FLAG_DEVICE_FAULT,
                        changed_voxels: 0,
                        // No tick ran: no reading.
                        clearance_mm: f64::INFINITY,
                    };
                    if records.push(record).is_err() {
                        stats.dropped_records += 1;
                    }
                }
                tick += 1;
                if device.finished(t) || t >= options.max_duration_s {
                    break;
                }
                continue;
            }
        };
        last = Some(state);
        let out = core.tick(model, &state, Deadline::of(missed, wall - t));
        let out = match out {
            Ok(o) => o,
            Err(e) => return Err(e),
        };
        device.send_force(out.force, out.torque);
        flags |= out.guidance;
        if let Some(stroke) = out.cut {
            flags |= FLAG_CUT;
            match mesher.hand_on(core, model.tissues.len(), stroke) {
                Some(Handed::Voxels) => {}
                Some(Handed::Stroke) => stats.recut += 1,
                None => stats.dropped_strokes += 1,
            }
        }
        stats.missed += u64::from(missed);
        let record = TickRecord {
            tick,
            t_s: t,
            wall_s: wall,
            pose: state.pose,
            buttons: state.buttons,
            rpm: state.rpm,
            force: out.force,
            torque: out.torque,
            proxy: out.proxy,
            tissue: out.raw.tissue.map_or(-1, i32::from),
            flags,
            changed_voxels: out.changed_voxels,
            clearance_mm: out.clearance_mm,
        };
        if records.push(record).is_err() {
            stats.dropped_records += 1;
        }
        tick += 1;
        if device.finished(t) || t >= options.max_duration_s {
            break;
        }
    }
    stats.ticks = tick;
    stats.trips = core.watchdog_trips();
    Ok(stats)
}

fn logger_loop(
    mut rx: rtrb::Consumer<TickRecord>,
    mut writer: Option<(BufWriter<File>, PathBuf)>,
    shared: &Shared,
    tissues: usize,
    mut guidance: GuidanceTracker,
) -> Result<LoggerStats> {
    let mut stats = LoggerStats {
        periods_us: Vec::new(),
        contact_ticks: vec![0; tissues],
        max_force: 0.0,
        changes: Vec::new(),
        last: None,
        guidance: GuidanceReport::default(),
    };
    let mut last_wall: Option<f64> = None;
    let mut last_tissue = i32::MIN;
    let io = |path: &PathBuf, e: std::io::Error| Error::File { path: path.clone(), message: e.to_string() };
    loop {
        let done = shared.haptic_done.load(Ordering::Acquire);
        let mut latest = None;
        while let Ok(r) = rx.pop() {
            if let Some((w, path)) = writer.as_mut() {
                write_record(w, &r).map_err(|e| io(path, e))?;
            }
            if let Some(prev) = last_wall {
                stats.periods_us.push((r.wall_s - prev) * 1e6);
            }
            last_wall = Some(r.wall_s);
            if let Some(c) = usize::try_from(r.tissue).ok().and_then(|t| stats.contact_ticks.get_mut(t)) {
                *c += 1;
            }
            if r.tissue != last_tissue {
                stats.changes.push((r.tissue, r.tick));
                last_tissue = r.tissue;
            }
            stats.max_force = stats.max_force.max(r.force.length());
            guidance.push(r.tick, r.t_s, r.flags, r.clearance_mm, r.flags & FLAG_CUT != 0);
            latest = Some(r);
        }
        if let Some((w, path)) = writer.as_mut() {
            w.flush().map_err(|e| io(path, e))?;
        }
        if latest.is_some() {
            stats.last = latest;
            *shared.latest.lock().unwrap_or_else(|p| p.into_inner()) = latest;
            let report = guidance.report();
            let mut shown = shared.guidance.lock().unwrap_or_else(|p| p.into_inner());
            if *shown != *report {
                *shown = report.clone();
            }
        }
        if done && rx.is_empty() {
            stats.guidance = guidance.finish();
            return Ok(stats);
        }
        // Well inside the 10 ms flush promise.
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// The haptic thread's ends of the mesher's queues (none when the session runs no mesher).
struct MesherQueues<'a> {
    strokes: &'a mut rtrb::Producer<StrokeMsg>,
    changes: &'a mut [rtrb::Producer<VoxelChange>],
}

/// How a cut went to the mesher.
enum Handed {
    Voxels,
    Stroke,
}

impl MesherQueues<'_> {
    /// Hands this tick's cut to the mesher: its changed voxels when every queue has room for them,
    /// else the stroke to cut again. Wait-free, allocation-free. `None` when the stroke queue is
    /// full (the mesher has fallen seconds behind) or there is no mesher.
    fn hand_on(&mut self, core: &HapticCore, tissues: usize, stroke: (DAffine3, DAffine3)) -> Option<Handed> {
        if self.strokes.is_full() || self.changes.len() < tissues {
            return None;
        }
        let mut msg = StrokeMsg { at: Instant::now(), counts: [0; MAX_TISSUES], recut: None };
        let fits = (0..tissues).all(|t| self.changes[t].slots() >= core.last_changes(t).len());
        if fits {
            for (t, queue) in self.changes.iter_mut().enumerate().take(tissues) {
                let changed = core.last_changes(t);
                if let Ok(chunk) = queue.write_chunk_uninit(changed.len()) {
                    msg.counts[t] = chunk.fill_from_iter(changed.iter().copied()) as u32;
                }
            }
        } else {
            msg.recut = Some(Recut { from: stroke.0, to: stroke.1, skipped: core.last_skipped() });
        }
        self.strokes.push(msg).ok()?;
        Some(if fits { Handed::Voxels } else { Handed::Stroke })
    }
}

fn mesher_loop(
    mut strokes: rtrb::Consumer<StrokeMsg>,
    mut changes: Vec<rtrb::Consumer<VoxelChange>>,
    mut copy: TissueModel,
    burr: Burr,
    hz: f64,
    shared: &Shared,
) -> MesherStats {
    let mut stats = MesherStats { latencies_ms: Vec::new(), published: 0 };
    // Only for strokes whose voxels did not fit the queues; the copy needs geometry, not volume.
    let mut recutter = Cutter::default();
    recutter.set_measure(Measure::Skip);
    // Chunked meshing re-meshes only the leaves a cut touched; without it (it failed to start),
    // whole tissues are re-meshed.
    let mut chunks = Mesher::full(&copy).ok();
    let mut dirty = DirtyLeaves::default();
    let mut dirty_chunks = Vec::new();
    let mut dirty_tissues = vec![false; copy.tissues.len()];
    // When each cut since the last published mesh was made (haptic tick time).
    let mut waiting: Vec<Instant> = Vec::new();
    let gap = Duration::from_secs_f64(1.0 / hz);
    let mut last_frame: Option<Instant> = None;
    loop {
        let done = shared.haptic_done.load(Ordering::Acquire);
        while let Ok(msg) = strokes.pop() {
            let changed = match msg.recut {
                Some(r) => recutter.recut(&mut copy, &burr, r.from, r.to, r.skipped).is_ok_and(|r| r.changed_voxels > 0),
                None => follow_cut(&mut copy, &mut changes, &msg.counts, &mut dirty),
            };
            if changed {
                waiting.push(msg.at);
            }
        }
        let now = Instant::now();
        if !waiting.is_empty() && last_frame.is_none_or(|f| now >= f + gap) {
            last_frame = Some(now);
            dirty_chunks.clear();
            dirty.drain_into(&mut dirty_chunks);
            recutter.take_dirty(&mut dirty_chunks);
            for (t, _) in &dirty_chunks {
                if let Some(d) = dirty_tissues.get_mut(*t) {
                    *d = true;
                }
            }
            if let Some(m) = &mut chunks {
                if m.update(&copy, &dirty_chunks).is_err() {
                    chunks = None;
                }
            }
            for (i, d) in dirty_tissues.iter_mut().enumerate() {
                if std::mem::take(d) {
                    let frame = Arc::new(match &chunks {
                        Some(m) => m.frame(i),
                        None => crate::tissues::surface::surface(&copy.tissues[i].grid).unwrap_or_default().into(),
                    });
                    shared.frames.lock().unwrap_or_else(|p| p.into_inner())[i] = Some(frame);
                }
            }
            // Every cut's latency, from its tick to this mesh.
            let shown = Instant::now();
            stats.latencies_ms.extend(waiting.drain(..).map(|at| (shown - at).as_secs_f64() * 1e3));
            stats.published += 1;
        }
        if done && strokes.is_empty() && waiting.is_empty() {
            return stats;
        }
        std::thread::sleep(Duration::from_micros(500));
    }
}

/// Writes one cut's changed voxels (`counts[t]` of tissue `t`, next in its queue) into the copy
/// and marks the chunks they dirty; true when any voxel changed.
fn follow_cut(copy: &mut TissueModel, changes: &mut [rtrb::Consumer<VoxelChange>], counts: &[u32], dirty: &mut DirtyLeaves) -> bool {
    let mut any = false;
    for (t, (queue, tissue)) in changes.iter_mut().zip(&mut copy.tissues).enumerate() {
        let n = counts.get(t).map_or(0, |c| *c as usize);
        if n == 0 {
            continue;
        }
        // The haptic thread queued them before the message: all n are there.
        let Ok(chunk) = queue.read_chunk(n) else { continue };
        let (a, b) = chunk.as_slices();
        for part in [a, b] {
            tissue.grid.write_voxels(part);
            dirty.record(t, part);
        }
        chunk.commit_all();
        any = true;
    }
    any
}
