//! A session for displays (the plugin's live source): starts a [`Session`] on a tissues file or
//! the built-in phantom, and hands out its latest state without ever blocking the haptic thread.
//!
//! `poll` reads what the logger and mesher threads last published (two short mutexes the haptic
//! thread never touches). Once the device has finished, `poll` stops the session and meshes the
//! final model itself, so the last state shown is exactly the session's result (a scripted,
//! non-real-time run therefore always ends on the same picture).
use std::path::PathBuf;
use std::sync::Arc;

use dentsim_devices::{DeviceProfile, DeviceSpec};
use dentsim_vdb::TriMesh;
use glam::{DAffine3, DVec3};

use crate::burr::Burr;
use crate::error::{invalid, Result};
use crate::haptics::filter::FilterSpec;
use crate::haptics::tick::{HapticParams, DEFAULT_BURR};
use crate::session::guidance::GuidanceReport;
use crate::session::log::TickRecord;
use crate::session::threads::{Session, SessionOptions};
use crate::tissues::capsule::CapsuleTooth;
use crate::tissues::model::TissueModel;
use crate::tissues::surface::{surface, SurfaceFrame};
use crate::tissues::table::{TissueProps, TissueTable};

/// Where a live device's workspace is centred unless its registration says otherwise: 1 mm
/// above the top of the tissues, over the middle of their bounding box (scan mm), so the
/// device's neutral position holds the burr just above the crown.
pub fn workspace_centre(model: &TissueModel) -> DVec3 {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for t in &model.tissues {
        if let Some(b) = t.grid.index_bbox() {
            // The active voxels reach a narrow band's half width beyond the surface.
            let band = DVec3::splat(f64::from(t.grid.background()));
            lo = lo.min(t.grid.index_to_world(b.min) + band);
            hi = hi.max(t.grid.index_to_world(b.max) - band);
        }
    }
    if !lo.is_finite() || !hi.is_finite() {
        return DVec3::ZERO;
    }
    let mid = (lo + hi) * 0.5;
    DVec3::new(mid.x, mid.y, hi.z + 1.0)
}

/// What to start.
#[derive(Clone, Debug)]
pub struct LiveRequest {
    /// A .vdb of tissues; `None` builds the capsule phantom at `phantom_voxel_mm`.
    pub tissues: Option<PathBuf>,
    pub phantom_voxel_mm: f64,
    /// `scripted:PATH.csv` or `hand:KEY=VAL,...` (see [`DeviceSpec`]).
    pub device: String,
    pub profile: String,
    pub filter: String,
    pub realtime: bool,
    /// How often the mesher refreshes the tissue surfaces (Hz).
    pub mesher_hz: f64,
}

/// The latest state for a display.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LiveState {
    pub tick: u64,
    pub t_s: f64,
    /// Device pose (tool frame → world) and the proxy the burr is drawn at.
    pub pose: DAffine3,
    pub proxy: DVec3,
    /// Force sent to the device (N).
    pub force: DVec3,
    /// Name of the tissue in contact, if any.
    pub tissue: Option<String>,
    /// False once the device has finished and the final model is meshed.
    pub running: bool,
    /// Bumped whenever any tissue surface changes.
    pub mesh_generation: u64,
    /// Thinnest tissue between the burr head and the pulp (mm; negative inside it; infinite
    /// when far or without a pulp).
    pub clearance_mm: f64,
    /// The guidance events so far.
    pub guidance: GuidanceReport,
    /// A live device's workspace on the scan: its centre (mm) and radius (the profile's, times
    /// the registration's scale); `None` for scripted paths and the hand.
    pub workspace: Option<(DVec3, f64)>,
}

impl LiveState {
    /// What a display warns of now: 0 clear, 1 within the thin-dentin threshold of the pulp,
    /// 2 in the pulp.
    pub fn warning_level(&self) -> u8 {
        if self.clearance_mm < 0.0 {
            2
        } else if self.clearance_mm < self.guidance.thin_dentin_mm {
            1
        } else {
            0
        }
    }
}

pub struct LiveSession {
    session: Option<Session>,
    props: Vec<TissueProps>,
    meshes: Vec<Arc<TriMesh>>,
    /// The session's frames `meshes` were flattened from.
    frames: Vec<Option<Arc<SurfaceFrame>>>,
    generation: u64,
    burr_mesh: TriMesh,
    last: Option<TickRecord>,
    /// Each tissue's volume at the start (mm³, from its grid, as every other removed volume).
    start_volumes: Vec<f64>,
    /// Enclosed volume of each tissue's first mesh (mm³): while the grids are the haptic
    /// thread's, what a frame lost against it is the running estimate of the removed volume.
    start_mesh_volumes: Vec<f64>,
    /// Removed volume per tissue from the grids, once the session has ended.
    removed: Option<Vec<f64>>,
    guidance: GuidanceReport,
    workspace: Option<(DVec3, f64)>,
}

impl LiveSession {
    /// Checks every input, builds or loads the tissues, meshes them once and starts the threads,
    /// with the default burr ([`DEFAULT_BURR`]).
    pub fn start(req: &LiveRequest) -> Result<Self> {
        Self::start_with_burr(req, DEFAULT_BURR)
    }

    /// Like [`start`](Self::start), cutting with `burr` (a spec as `dentsim prepare` takes it,
    /// [`Burr::parse`]).
    pub fn start_with_burr(req: &LiveRequest, burr: &str) -> Result<Self> {
        Self::start_logged(req, burr, None)
    }

    /// Like [`start_with_burr`](Self::start_with_burr), writing the session log to `log` (as
    /// `dentsim session` does; a bad path fails here, before any tick).
    pub fn start_logged(req: &LiveRequest, burr: &str, log: Option<PathBuf>) -> Result<Self> {
        // The burr first: a bad spec is reported before any tissue is built.
        let burr_mesh = Burr::parse(burr)?.head_surface()?;
        let profile = DeviceProfile::named(&req.profile).map_err(|e| invalid("profile", e.to_string()))?;
        let filter = FilterSpec::named(&req.filter).map_err(|m| invalid("filter", m))?;
        let spec = DeviceSpec::parse(&req.device).map_err(|e| invalid("device", e.to_string()))?;
        let table = TissueTable::default();
        let model = match &req.tissues {
            Some(path) => TissueModel::load(path, &table)?,
            None => {
                crate::tissues::model::check_voxel_mm("phantom voxel size", req.phantom_voxel_mm)?;
                CapsuleTooth::default().build(req.phantom_voxel_mm, &table)?
            }
        };
        let centre = workspace_centre(&model);
        let workspace = spec.registration().map(|r| (r.offset.unwrap_or(centre), profile.workspace_radius_mm * r.scale));
        let (device, duration_s) = spec.open_on(centre).map_err(|e| invalid("device", e.to_string()))?;
        // A live device runs until it ends the session (or the session cap), on the wall clock.
        let live = spec.is_live();
        let duration_s = if live { crate::limits::DEFAULT_MAX_SESSION_S - 1.0 } else { duration_s };
        let realtime = req.realtime || live;
        let params = HapticParams { profile, filter, ..HapticParams::default() };
        let params = HapticParams { burr: burr.to_owned(), ..params };
        let props = model.tissues.iter().map(|t| t.props.clone()).collect();
        let meshes = model.tissues.iter().map(|t| surface(&t.grid).map(Arc::new)).collect::<Result<Vec<_>>>()?;
        let start_mesh_volumes = meshes.iter().map(|m| m.volume()).collect();
        let options = SessionOptions {
            params,
            realtime,
            max_duration_s: (duration_s + 1.0).max(1.0),
            log_path: log,
            mesher_hz: Some(req.mesher_hz),
            raise_priority: realtime,
            ..SessionOptions::default()
        };
        let session = Session::start(model, device, options)?;
        let frames = vec![None; meshes.len()];
        let start_volumes = session.start_volumes().to_vec();
        Ok(LiveSession {
            session: Some(session),
            props,
            meshes,
            frames,
            generation: 1,
            burr_mesh,
            last: None,
            start_volumes,
            start_mesh_volumes,
            removed: None,
            guidance: GuidanceReport::default(),
            workspace,
        })
    }

    /// The latest state; picks up new meshes. Never waits on the haptic thread; after the device
    /// finished, the first call joins the threads and meshes the final model.
    pub fn poll(&mut self) -> Result<LiveState> {
        if let Some(session) = &self.session {
            if let Some(r) = session.latest() {
                self.last = Some(r);
            }
            self.guidance = session.guidance();
            if session.is_running() {
                for ((mine, seen), new) in self.meshes.iter_mut().zip(&mut self.frames).zip(session.latest_frames()) {
                    let Some(new) = new else { continue };
                    if seen.as_ref().is_none_or(|s| !Arc::ptr_eq(s, &new)) {
                        *mine = Arc::new(new.to_mesh());
                        *seen = Some(new);
                        self.generation += 1;
                    }
                }
            } else {
                self.finish()?;
            }
        }
        Ok(self.state())
    }

    /// Ends the session now (the clinician's Stop): the threads stop, the log is complete and
    /// the final tissues are meshed, as when a device finishes. Nothing happens once it ended.
    pub fn stop(&mut self) -> Result<LiveState> {
        if self.session.is_some() {
            self.finish()?;
        }
        Ok(self.state())
    }

    /// Pauses or resumes a running session (see [`Session::set_paused`]); nothing once it ended.
    pub fn set_paused(&mut self, paused: bool) {
        if let Some(s) = &self.session {
            s.set_paused(paused);
        }
    }

    fn finish(&mut self) -> Result<()> {
        let outcome = self.session.take().expect("checked by the callers").stop()?;
        // The logger has drained every record by now: its last is the session's last tick.
        if outcome.last_record.is_some() {
            self.last = outcome.last_record;
        }
        self.meshes = outcome.model.tissues.iter().map(|t| surface(&t.grid).map(Arc::new)).collect::<Result<Vec<_>>>()?;
        self.removed = Some(outcome.removed_mm3.iter().map(|(_, v)| *v).collect());
        self.guidance = outcome.guidance;
        self.generation += 1;
        Ok(())
    }

    fn state(&self) -> LiveState {
        let r = self.last.unwrap_or_default();
        LiveState {
            tick: r.tick,
            t_s: r.t_s,
            pose: r.pose,
            proxy: r.proxy,
            force: r.force,
            tissue: usize::try_from(r.tissue).ok().and_then(|i| self.props.get(i)).map(|p| p.name.clone()),
            running: self.session.is_some(),
            mesh_generation: self.generation,
            workspace: self.workspace,
            clearance_mm: r.clearance_mm,
            guidance: self.guidance.clone(),
        }
    }

    pub fn tissues(&self) -> &[TissueProps] {
        &self.props
    }

    /// The latest surface of each tissue (model order).
    pub fn meshes(&self) -> &[Arc<TriMesh>] {
        &self.meshes
    }

    /// (at the start, now) volume of each tissue (mm³): from the grids, except that while the
    /// session runs the change since the start is what the live surfaces lost.
    pub fn volumes_mm3(&self) -> Vec<(f64, f64)> {
        let running = self.start_mesh_volumes.iter().zip(&self.meshes).map(|(v0, m)| v0 - m.volume());
        let removed: Vec<f64> = match &self.removed {
            Some(r) => r.clone(),
            None => running.collect(),
        };
        self.start_volumes.iter().zip(removed).map(|(v0, r)| (*v0, v0 - r)).collect()
    }

    /// The burr head at the proxy with the device's orientation (world), as a display draws it.
    pub fn burr_at(&self, state: &LiveState) -> TriMesh {
        let mut pose = state.pose;
        pose.translation = state.proxy;
        let m = &self.burr_mesh;
        TriMesh {
            points: m.points.iter().map(|p| pose.transform_point3(p.as_dvec3()).as_vec3()).collect(),
            normals: m.normals.iter().map(|n| pose.transform_vector3(n.as_dvec3()).normalize_or_zero().as_vec3()).collect(),
            triangles: m.triangles.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_warning_level_follows_the_clearance_against_the_threshold() {
        let state = |clearance_mm: f64, thin_dentin_mm: f64| LiveState {
            clearance_mm,
            guidance: GuidanceReport { thin_dentin_mm, ..GuidanceReport::default() },
            ..LiveState::default()
        };
        assert_eq!(state(f64::INFINITY, 0.5).warning_level(), 0);
        assert_eq!(state(0.6, 0.5).warning_level(), 0);
        assert_eq!(state(0.49, 0.5).warning_level(), 1);
        assert_eq!(state(0.0, 0.5).warning_level(), 1);
        assert_eq!(state(-0.01, 0.5).warning_level(), 2);
        // Guidance off (threshold 0): only a reading inside the pulp would warn, and none is made.
        assert_eq!(state(0.2, 0.0).warning_level(), 0);
    }
}
