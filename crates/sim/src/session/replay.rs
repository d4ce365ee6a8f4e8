//! Replay: redo a logged session's ticks on the tissues it started from. The tick is
//! deterministic (session time, not wall clock; same proxy, same strokes), so the final grids
//! equal the session's bit for bit; check with [`dentsim_vdb::LevelSet::content_hash`].
use std::path::Path;

use dentsim_devices::DeviceState;
use glam::DVec3;

use crate::error::{invalid, Result};
use crate::haptics::tick::HapticCore;
use crate::haptics::watchdog::Deadline;
use crate::haptics::guidance::GUIDANCE_FLAGS;
use crate::session::guidance::{GuidanceReport, GuidanceTracker};
use crate::session::log::{SessionLog, FLAG_DEVICE_FAULT, FLAG_MISSED};
use crate::tissues::model::TissueModel;

/// The rendered force at one tick, as logged.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForceSample {
    pub t_s: f64,
    pub force: DVec3,
    /// Tissue index in contact, −1 for none.
    pub tissue: i32,
    /// Volume the replayed tick removed (mm³, all tissues): live ticks do not measure it.
    pub removed_mm3: f64,
    /// The replayed tick's clearance over the pulp (mm; infinite when far).
    pub clearance_mm: f64,
}

pub struct ReplayOutcome {
    pub model: TissueModel,
    /// The force series as the session rendered it (from the log).
    pub forces: Vec<ForceSample>,
    /// Largest difference between the logged force and the replay's (N); 0 for a faithful replay.
    pub max_force_difference_n: f64,
    /// Ticks whose replayed cut changed another number of voxels than logged; 0 for a faithful replay.
    pub ticks_cut_differently: u64,
    pub removed_mm3: Vec<(String, f64)>,
    /// Guidance events of the replayed ticks.
    pub guidance: GuidanceReport,
    /// Ticks whose replayed guidance (flags, clearance) differs from the log's; `None` for logs
    /// written before guidance was logged (version < 5).
    pub ticks_guided_differently: Option<u64>,
}

/// Replays `log` on `model`, which must be the session's starting tissues (checked by hash).
pub fn replay(log: &SessionLog, model: TissueModel) -> Result<ReplayOutcome> {
    replay_with_progress(log, model, &mut |_| {})
}

/// [`replay`], calling `progress(fraction)` every 1000 ticks.
pub fn replay_with_progress(log: &SessionLog, model: TissueModel, progress: &mut dyn FnMut(f64)) -> Result<ReplayOutcome> {
    replay_until(log, model, None, progress)
}

/// [`replay_with_progress`] up to and including tick `until` (all ticks for `None`): the tissues
/// as they were at that tick. A tick past the log's last is an error naming the last.
pub fn replay_until(log: &SessionLog, mut model: TissueModel, until: Option<u64>, progress: &mut dyn FnMut(f64)) -> Result<ReplayOutcome> {
    if let Some(tick) = until {
        let last = log.records.last().map(|r| r.tick);
        if last.is_none_or(|l| tick > l) {
            let logged = last.map_or("no ticks".to_string(), |l| format!("ticks 0 to {l}"));
            return Err(invalid("replay tick", format!("{tick}, the log has {logged}")));
        }
    }
    let names: Vec<String> = model.tissues.iter().map(|t| t.props.name.clone()).collect();
    if names != log.header.tissues {
        return Err(invalid("replay model", format!("tissues {names:?}, the log has {:?}", log.header.tissues)));
    }
    for (t, want) in model.tissues.iter().zip(&log.header.start_hashes) {
        if t.grid.content_hash() != *want {
            return Err(invalid(
                "replay model",
                format!("tissue '{}' differs from the one the session started with (content hash)", t.props.name),
            ));
        }
    }
    let mut core = HapticCore::new(log.header.params.clone(), &model)?;
    // As the session did, so the trees (not only the values) come out the same.
    core.prepare_guidance(&model)?;
    core.prepare_cutting(&mut model)?;
    let mut guidance = GuidanceTracker::new(&log.header.params.guidance, log.header.params.period_s);
    let logs_guidance = log.version >= 5;
    let mut guided_differently = 0u64;
    let mut max_diff = 0.0f64;
    let mut cut_differently = 0u64;
    let mut forces = Vec::with_capacity(log.records.len());
    let records = match until {
        Some(tick) => &log.records[..log.records.partition_point(|r| r.tick <= tick)],
        None => &log.records[..],
    };
    let total = records.len().max(1) as f64;
    for (i, r) in records.iter().enumerate() {
        if i % 1000 == 0 {
            progress(i as f64 / total);
        }
        if r.flags & FLAG_DEVICE_FAULT != 0 {
            // The session ran no tick while the device was gone: zero force, nothing cut.
            max_diff = max_diff.max(r.force.length());
            cut_differently += u64::from(r.changed_voxels != 0);
            forces.push(ForceSample { t_s: r.t_s, force: r.force, tissue: r.tissue, removed_mm3: 0.0, clearance_mm: f64::INFINITY });
            continue;
        }
        let state = DeviceState { pose: r.pose, buttons: r.buttons, rpm: r.rpm };
        let out = core.tick(&mut model, &state, Deadline::of(r.flags & FLAG_MISSED != 0, r.wall_s - r.t_s))?;
        max_diff = max_diff.max((out.force - r.force).length());
        cut_differently += u64::from(out.changed_voxels != r.changed_voxels);
        let same_clearance = out.clearance_mm.to_bits() == r.clearance_mm.to_bits();
        guided_differently += u64::from(out.guidance != r.flags & GUIDANCE_FLAGS || !same_clearance);
        guidance.push(r.tick, r.t_s, out.guidance, out.clearance_mm, out.cut.is_some());
        forces.push(ForceSample { t_s: r.t_s, force: r.force, tissue: r.tissue, removed_mm3: out.removed_mm3, clearance_mm: out.clearance_mm });
    }
    model.compact();
    let removed_mm3 = names.into_iter().zip(core.removed_mm3.iter().copied()).collect();
    Ok(ReplayOutcome {
        model,
        forces,
        max_force_difference_n: max_diff,
        ticks_cut_differently: cut_differently,
        removed_mm3,
        guidance: guidance.finish(),
        ticks_guided_differently: logs_guidance.then_some(guided_differently),
    })
}

/// `t_s,fx_n,fy_n,fz_n,f_n,removed_mm3,remaining_dentin_mm,tissue` with the tissue by name and
/// the remaining dentin (the clearance over the pulp) empty where none or far, written whole or
/// not at all.
pub fn write_force_csv(path: &Path, forces: &[ForceSample], tissues: &[String]) -> Result<()> {
    Ok(dentsim_atomic::write(path, |w| {
        writeln!(w, "t_s,fx_n,fy_n,fz_n,f_n,removed_mm3,remaining_dentin_mm,tissue")?;
        for s in forces {
            let name = usize::try_from(s.tissue).ok().and_then(|i| tissues.get(i)).map_or("", String::as_str);
            let f = s.force;
            let dentin = if s.clearance_mm.is_finite() { s.clearance_mm.to_string() } else { String::new() };
            writeln!(w, "{},{},{},{},{},{},{dentin},{}", s.t_s, f.x, f.y, f.z, f.length(), s.removed_mm3, name)?;
        }
        Ok(())
    })?)
}
