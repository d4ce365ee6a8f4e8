//! Headless sessions and their replays, written to a folder: what `dentsim session` and
//! `dentsim replay` do, kept here so the command stays a thin face.
//!
//! Every input (tissues file, device, profile, filter, log) is read and checked, against the
//! [`Limits`] too, before the output folder is touched, so bad input writes nothing. The outputs
//! are staged and appear together at the end ([`crate::tissues::export::all_or_nothing`]), except
//! the session's log: it is written under its final name from the first tick, so a session that
//! is killed, or fails after ticking (a full disk), leaves every tick it logged for a replay.
use std::path::{Path, PathBuf};
use std::time::Duration;

use dentsim_devices::{DeviceProfile, DeviceSpec};
use serde::{Deserialize, Serialize};

use crate::error::{invalid, Error, Result};
use crate::limits::Limits;
use crate::haptics::filter::FilterSpec;
use crate::haptics::tick::HapticParams;
use crate::session::log::SessionLog;
use crate::session::plot::plot_forces;
use crate::session::guidance::GuidanceReport;
use crate::session::replay::{replay_until, write_force_csv};
use crate::session::threads::{Session, SessionOptions};
use crate::tissues::export::{write_model, FORCES_CSV_NAME, FORCES_PNG_NAME, LOG_NAME, REPLAY_SUMMARY_NAME, SUMMARY_NAME};
use crate::tissues::model::{TissueModel, TissueVolumes};
use crate::tissues::table::TissueTable;

/// What to run.
#[derive(Clone, Debug)]
pub struct SessionRequest {
    pub tissues: PathBuf,
    pub device: String,
    pub out: PathBuf,
    /// Device profile name (`touch`, `omni`, `desktop`, …).
    pub profile: String,
    /// `delta`, `biquad` or `none`.
    pub filter: String,
    /// Tick on the wall clock (1 kHz) instead of back to back.
    pub realtime: bool,
    /// The burr, as `prepare` takes it ([`crate::burr::Burr::parse`]).
    pub burr: String,
}

/// One tissue's figures after a session or replay.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TissueSummary {
    /// Removed: for a session the volume at the start less at the end; for a replay the sum of
    /// the replayed ticks' measured cuts.
    #[serde(flatten)]
    pub volumes: TissueVolumes,
    /// Session time the burr spent in contact with this tissue (s).
    pub contact_s: f64,
    /// [`dentsim_vdb::LevelSet::content_hash`] of the final grid, hex: equal hashes = same grid.
    pub content_hash: String,
    pub triangles: usize,
}

/// `summary.json` of a session.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SessionSummary {
    pub dentsim_version: String,
    pub tissues_file: String,
    pub device: String,
    pub profile: String,
    pub filter: String,
    /// The burr's spec (absent from summaries written before sessions took any burr).
    #[serde(default)]
    pub burr: String,
    pub realtime: bool,
    pub ticks: u64,
    pub duration_s: f64,
    pub missed_deadlines: u64,
    pub watchdog_trips: u32,
    pub device_faults: u64,
    pub max_force_n: f64,
    pub log: String,
    pub tissues: Vec<TissueSummary>,
    /// Cuts too close to the pulp (absent from summaries written before live guidance).
    #[serde(default)]
    pub guidance: GuidanceReport,
}

/// `replay.json`: the replay's figures and whether they equal the session's.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReplaySummary {
    pub log: String,
    pub ticks: u64,
    /// Largest difference between logged and replayed force (N); 0 for a faithful replay.
    pub max_force_difference_n: f64,
    /// Ticks whose replayed cut changed another number of voxels than logged; 0 for a faithful replay.
    pub ticks_cut_differently: u64,
    /// Bytes of a partial last record the log reader dropped (a crash while writing).
    pub truncated_log_bytes: usize,
    /// True/false when the session's `summary.json` sat beside the log; `None` otherwise (or
    /// when the replay stopped early).
    pub hashes_match_session: Option<bool>,
    pub tissues: Vec<TissueSummary>,
    /// The tissues file the replay started from.
    #[serde(default)]
    pub tissues_file: String,
    /// The last tick replayed when the replay stopped early (`--until-tick`).
    #[serde(default)]
    pub until_tick: Option<u64>,
    /// The replayed ticks' guidance events.
    #[serde(default)]
    pub guidance: GuidanceReport,
    /// Ticks whose replayed guidance differs from the log's; 0 for a faithful replay, `None`
    /// for logs written before guidance was logged.
    #[serde(default)]
    pub ticks_guided_differently: Option<u64>,
}

fn hex(hash: u64) -> String {
    format!("{hash:016x}")
}

/// Loads a tissues file; errors name it.
fn load_tissues(path: &Path) -> Result<TissueModel> {
    let model = TissueModel::load(path, &TissueTable::default())?;
    if model.tissues.is_empty() {
        return Err(Error::File { path: path.to_owned(), message: "holds no tissue grids".into() });
    }
    Ok(model)
}

fn create_dir(out: &Path) -> Result<()> {
    std::fs::create_dir_all(out).map_err(|e| Error::File { path: out.to_owned(), message: e.to_string() })
}

/// Meshes, `tissues.vdb` and the per-tissue figures of a finished model.
fn write_tissues(
    model: &mut TissueModel,
    out: &Path,
    volumes: Vec<TissueVolumes>,
    contact_s: &[f64],
    progress: &mut dyn FnMut(&str, f64),
) -> Result<Vec<TissueSummary>> {
    let triangles = write_model(model, out, progress)?;
    let tissues = volumes
        .into_iter()
        .zip(&model.tissues)
        .enumerate()
        .map(|(i, (volumes, t))| TissueSummary {
            volumes,
            contact_s: contact_s.get(i).copied().unwrap_or(0.0),
            content_hash: hex(t.grid.content_hash()),
            triangles: triangles[i].1,
        })
        .collect();
    Ok(tissues)
}

fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<()> {
    let json = serde_json::to_vec_pretty(value).map_err(|e| invalid("summary", e.to_string()))?;
    Ok(dentsim_atomic::write(path, |w| w.write_all(&json))?)
}

/// The tissues ready for cutting plus the cutter's buffers, against the memory cap: a file with
/// absurdly fine voxels is refused here instead of failing to allocate tens of GiB.
fn check_session_memory(limits: &Limits, tissues: &Path, model: &TissueModel, burr: &crate::burr::Burr, params: &HapticParams) -> Result<()> {
    let bytes = model.cutting_bytes_estimate().saturating_add(crate::cutting::Cutter::buffer_bytes_estimate(model, burr, params.max_step_mm));
    // Rounded to a micrometre: grids keep voxel sizes as f32.
    let voxel = (model.voxel_size().unwrap_or(0.0) * 1e6).round() / 1e6;
    limits.check_memory(&format!("tissues {} ({voxel} mm voxels, burr {})", tissues.display(), burr.spec()), bytes)
}

/// Runs a headless session and writes `session.dslog`, `tissues.vdb`, `<tissue>.vtp/.stl` and
/// `summary.json` into `req.out`. `progress(step, fraction)` follows the session time.
pub fn run_session_to_dir(req: &SessionRequest, progress: &mut dyn FnMut(&str, f64)) -> Result<SessionSummary> {
    run_session_to_dir_with(req, &Limits::default(), progress)
}

/// [`run_session_to_dir`] within `limits`: a device that runs longer than the session cap, or
/// tissues that would need more memory than the cap, are refused before anything is written.
pub fn run_session_to_dir_with(req: &SessionRequest, limits: &Limits, progress: &mut dyn FnMut(&str, f64)) -> Result<SessionSummary> {
    let profile = DeviceProfile::named(&req.profile).map_err(|e| invalid("profile", e.to_string()))?;
    let filter = FilterSpec::named(&req.filter).map_err(|m| invalid("filter", m))?;
    let spec = DeviceSpec::parse(&req.device).map_err(|e| invalid("device", e.to_string()))?;
    let model = load_tissues(&req.tissues)?;
    let (device, duration_s) = spec.open_on(crate::session::live::workspace_centre(&model)).map_err(|e| invalid("device", e.to_string()))?;
    // A live device runs until it ends the session, within the cap, on the wall clock.
    let live = spec.is_live();
    let duration_s = if live { limits.max_session_s } else { duration_s };
    let realtime = req.realtime || live;
    limits.check_session(&req.device, duration_s)?;
    let burr = crate::burr::Burr::parse(&req.burr)?;
    let params = HapticParams { profile, filter, burr: req.burr.clone(), ..HapticParams::default() };
    check_session_memory(limits, &req.tissues, &model, &burr, &params)?;
    let existed = req.out.exists();
    create_dir(&req.out)?;
    let period = params.period_s;
    // The log is written under its final name as the session runs (a killed session leaves its
    // ticks there); everything else is staged and appears at the end, all or nothing.
    let log_path = req.out.join(LOG_NAME);
    // An earlier session's log is kept aside until this one has ticked, so a session that fails
    // to start leaves the folder as it was.
    let previous = req.out.join(format!(".{LOG_NAME}.previous"));
    let had_previous = std::fs::rename(&log_path, &previous).is_ok();
    let options = SessionOptions {
        params: params.clone(),
        realtime,
        max_duration_s: if live { duration_s } else { (duration_s + 1.0).max(1.0) },
        log_path: Some(log_path.clone()),
        mesher_hz: None,
        raise_priority: realtime,
        ..SessionOptions::default()
    };
    let session = match Session::start(model, device, options) {
        Ok(s) => s,
        Err(e) => {
            // Not one tick ran: the folder goes back to how it was.
            let _ = std::fs::remove_file(&log_path);
            if had_previous {
                let _ = std::fs::rename(&previous, &log_path);
            }
            if !existed {
                let _ = std::fs::remove_dir(&req.out);
            }
            return Err(e);
        }
    };
    if had_previous {
        let _ = std::fs::remove_file(&previous);
    }
    // An earlier session's summary describes the log just replaced: a replay of this log, after
    // a kill, must not compare itself with it.
    let _ = std::fs::remove_file(req.out.join(SUMMARY_NAME));
    while session.is_running() {
        let t = session.latest().map_or(0.0, |r| r.t_s);
        progress("session", (t / duration_s.max(1e-3)).clamp(0.0, 1.0));
        std::thread::sleep(Duration::from_millis(20));
    }
    let mut outcome = session.stop().map_err(|e| match e {
        Error::File { path, message } if path == log_path => {
            Error::File { path, message: format!("{message} (the ticks logged before it stay in this file)") }
        }
        other => other,
    })?;
    let contact_s: Vec<f64> = outcome.contact_ticks.iter().map(|(_, t)| *t as f64 * period).collect();
    let volumes = outcome.volumes.clone();
    crate::tissues::export::all_or_nothing(&req.out, |staged| {
        let tissues = write_tissues(&mut outcome.model, staged, volumes, &contact_s, progress)?;
        let summary = SessionSummary {
            dentsim_version: env!("CARGO_PKG_VERSION").into(),
            tissues_file: req.tissues.display().to_string(),
            device: req.device.clone(),
            profile: req.profile.clone(),
            filter: req.filter.clone(),
            burr: req.burr.clone(),
            realtime,
            ticks: outcome.ticks,
            duration_s: outcome.ticks as f64 * period,
            missed_deadlines: outcome.missed_deadlines,
            watchdog_trips: outcome.watchdog_trips,
            device_faults: outcome.device_faults,
            max_force_n: outcome.max_force_n,
            log: LOG_NAME.into(),
            tissues,
            guidance: outcome.guidance.clone(),
        };
        write_json(&staged.join(SUMMARY_NAME), &summary)?;
        Ok(summary)
    })
}

/// Replays `log` on the tissues it started from and writes `tissues.vdb`, meshes, `forces.csv`,
/// `forces.png` and `replay.json` into `out`. If the session's `summary.json` lies beside the
/// log, the final content hashes are compared with it; a difference is an error (after writing).
pub fn replay_to_dir(log_path: &Path, tissues: &Path, out: &Path, progress: &mut dyn FnMut(&str, f64)) -> Result<ReplaySummary> {
    replay_to_dir_with(log_path, tissues, out, &Limits::default(), progress)
}

/// [`replay_to_dir`] within `limits`: the log's size (its records are held in memory) and the
/// tissues' are checked against the memory cap before either is read whole.
pub fn replay_to_dir_with(log_path: &Path, tissues: &Path, out: &Path, limits: &Limits, progress: &mut dyn FnMut(&str, f64)) -> Result<ReplaySummary> {
    replay_to_dir_until(log_path, tissues, out, limits, None, progress)
}

/// [`replay_to_dir_with`] up to and including tick `until` (every tick for `None`): the outputs
/// hold the tissues as they were at that tick, e.g. for `dentsim assess`.
pub fn replay_to_dir_until(
    log_path: &Path,
    tissues: &Path,
    out: &Path,
    limits: &Limits,
    until: Option<u64>,
    progress: &mut dyn FnMut(&str, f64),
) -> Result<ReplaySummary> {
    let log_bytes = std::fs::metadata(log_path).map_err(|e| Error::File { path: log_path.to_owned(), message: e.to_string() })?.len();
    // Records decode to about 1.3 times their size, and the replay keeps a force sample per tick.
    limits.check_memory(&format!("session log {}", log_path.display()), log_bytes.saturating_mul(3))?;
    let log = SessionLog::read(log_path)?;
    if let Some(tick) = until {
        let last = log.records.last().map(|r| r.tick);
        if last.is_none_or(|l| tick > l) {
            let logged = last.map_or("no ticks".to_string(), |l| format!("ticks 0 to {l}"));
            return Err(Error::File { path: log_path.to_owned(), message: format!("--until-tick {tick}: the log has {logged}") });
        }
    }
    let model = load_tissues(tissues)?;
    let burr = crate::burr::Burr::parse(&log.header.params.burr).map_err(|e| Error::File { path: log_path.to_owned(), message: e.to_string() })?;
    check_session_memory(limits, tissues, &model, &burr, &log.header.params)?;
    let session: Option<SessionSummary> = match log_path.parent().map(|d| d.join(SUMMARY_NAME)) {
        Some(p) if p.is_file() => {
            let text = std::fs::read(&p).map_err(|e| Error::File { path: p.clone(), message: e.to_string() })?;
            Some(serde_json::from_slice(&text).map_err(|e| Error::File { path: p.clone(), message: format!("not a session summary: {e}") })?)
        }
        _ => None,
    };
    let before = model.volumes();
    let mut again = replay_until(&log, model, until, &mut |f| progress("replay", f))
        .map_err(|e| Error::File { path: tissues.to_owned(), message: e.to_string() })?;

    let summary = crate::tissues::export::all_or_nothing(out, |staged| {
        let period = log.header.params.period_s;
        let mut contact = vec![0.0; again.model.tissues.len()];
        for s in &again.forces {
            if let Some(c) = usize::try_from(s.tissue).ok().and_then(|i| contact.get_mut(i)) {
                *c += period;
            }
        }
        let names: Vec<String> = again.model.tissues.iter().map(|t| t.props.name.clone()).collect();
        let colours: Vec<[f32; 3]> = again.model.tissues.iter().map(|t| t.props.colour).collect();
        let removed = |name: &str| again.removed_mm3.iter().find(|(n, _)| n == name).map_or(0.0, |r| r.1);
        let volumes = TissueVolumes::of(&again.model, &before, removed);
        let tissues_out = write_tissues(&mut again.model, staged, volumes, &contact, progress)?;
        progress("writing forces", 1.0);
        write_force_csv(&staged.join(FORCES_CSV_NAME), &again.forces, &names)?;
        plot_forces(&staged.join(FORCES_PNG_NAME), &again.forces, &colours, 1200, 500)?;
        let hashes_match_session = session.as_ref().filter(|_| until.is_none()).map(|s| {
            s.tissues.len() == tissues_out.len()
                && s.tissues.iter().zip(&tissues_out).all(|(a, b)| a.volumes.name == b.volumes.name && a.content_hash == b.content_hash)
        });
        let summary = ReplaySummary {
            log: log_path.display().to_string(),
            ticks: again.forces.len() as u64,
            max_force_difference_n: again.max_force_difference_n,
            ticks_cut_differently: again.ticks_cut_differently,
            truncated_log_bytes: log.truncated_bytes,
            hashes_match_session,
            tissues: tissues_out,
            tissues_file: tissues.display().to_string(),
            until_tick: until,
            guidance: again.guidance.clone(),
            ticks_guided_differently: again.ticks_guided_differently,
        };
        write_json(&staged.join(REPLAY_SUMMARY_NAME), &summary)?;
        Ok(summary)
    })?;
    if summary.hashes_match_session == Some(false) {
        return Err(invalid(
            "replay",
            format!("final content hashes differ from the session's {} (see {})", SUMMARY_NAME, out.join(REPLAY_SUMMARY_NAME).display()),
        ));
    }
    Ok(summary)
}
