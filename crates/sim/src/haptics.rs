//! One haptic tick, deterministic and allocation-free in touch mode: device state → proxy →
//! contact force → removal budget → cut → filter, watchdog and clamp → force for the device.
//! The session thread calls it at 1 kHz; replay calls it again on the logged device states.
use dentsim_devices::{DeviceProfile, DeviceState};
use glam::{DAffine3, DVec3};
use serde::{Deserialize, Serialize};

use crate::burr::Burr;
use crate::contact::{BurrSamples, ContactQuery};
use crate::cut::Cutter;
use crate::removal::Feed;
use crate::error::{invalid, Result};
use crate::filter::{clamp_length, FilterSpec, ForceFilter};
use crate::force::{contact_force, ContactForce, Mechanics, MAX_TISSUES};
use crate::model::TissueModel;
use crate::proxy::Proxy;
use crate::watchdog::{Watchdog, WatchdogParams};

/// How deep (in voxels) the proxy may rest in the stroke it cuts (see [`Proxy::follow`]).
pub const CUT_TOLERANCE_VOXELS: f64 = 0.25;

/// Everything that shapes the tick; stored in the log header so a replay redoes the same ticks.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HapticParams {
    pub burr_diameter_mm: f64,
    /// Points on the burr head (≥ 256 gives the contact resolution the benchmarks use).
    pub samples: usize,
    pub profile: DeviceProfile,
    pub filter: FilterSpec,
    /// Tick period (s); the physics uses it, not the wall clock, so runs are reproducible.
    pub period_s: f64,
    /// Longest proxy sub-step (mm). Must stay below half the thinnest wall to hold (0.3 mm).
    pub max_step_mm: f64,
    /// The torque reference point on the tool axis (mm along +Z from the tip): where the FG
    /// shank (≈19 mm) enters the handpiece head.
    pub axis_point_mm: f64,
    /// Handpiece speed at which the tissue table's removal rates hold (rev/min).
    pub reference_rpm: f64,
    /// Cut once every this many ticks with the advance accumulated meanwhile (1 = every tick).
    /// 1 by default. Batching (e.g. 10) would amortise a stroke's cost (~1–5 ms today: 3 tissues ×
    /// ~24 k voxels for a 1 mm ball) but currently stalls the proxy's advance (cut_probe test
    /// measured 0.04 vs 0.44 mm³/s): not yet understood, see the issue note.
    pub cut_interval_ticks: u32,
    pub watchdog: WatchdogParams,
}

impl Default for HapticParams {
    fn default() -> Self {
        HapticParams {
            burr_diameter_mm: 1.0,
            samples: 256,
            profile: DeviceProfile::named("desktop").expect("built-in profile"),
            filter: FilterSpec::default_delta(),
            period_s: 1e-3,
            max_step_mm: 0.05,
            axis_point_mm: 19.0,
            reference_rpm: 200_000.0,
            cut_interval_ticks: 1,
            watchdog: WatchdogParams::default(),
        }
    }
}

/// What one tick produced.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TickOutput {
    /// Force and torque sent to the device (filtered, ramped by the watchdog, clamped).
    pub force: DVec3,
    pub torque: DVec3,
    /// The contact force before filter and clamp.
    pub raw: ContactForce,
    pub proxy: DVec3,
    /// The stroke cut this tick, if any.
    pub cut: Option<(DAffine3, DAffine3)>,
    /// Volume removed this tick (mm³, all tissues).
    pub removed_mm3: f64,
    /// Watchdog gain applied (1 = normal).
    pub gain: f64,
}

/// The haptic state that lives across ticks.
pub struct HapticCore {
    pub params: HapticParams,
    burr: Burr,
    query: ContactQuery,
    proxy: Proxy,
    mechanics: Vec<Mechanics>,
    filter: ForceFilter,
    watchdog: Watchdog,
    cutter: Cutter,
    last_device: Option<DVec3>,
    pending_advance: f64,
    ticks: u64,
    /// Volume removed per tissue so far (mm³), model order.
    pub removed_mm3: Vec<f64>,
}

impl HapticCore {
    pub fn new(params: HapticParams, model: &TissueModel) -> Result<Self> {
        params.filter.validate().map_err(|m| invalid("force filter", m))?;
        let positive = |v: f64| v.is_finite() && v > 0.0;
        if !positive(params.period_s) || !positive(params.max_step_mm) || !positive(params.reference_rpm) {
            return Err(invalid("haptic parameters", "period_s, max_step_mm and reference_rpm must be > 0"));
        }
        if params.max_step_mm > 0.15 {
            return Err(invalid("max_step_mm", format!("{} mm lets the proxy cross a 0.3 mm wall; use <= 0.15", params.max_step_mm)));
        }
        if model.tissues.len() > MAX_TISSUES {
            return Err(invalid("tissue model", format!("{} tissues, at most {MAX_TISSUES}", model.tissues.len())));
        }
        let burr = Burr::round(params.burr_diameter_mm)?;
        let samples = BurrSamples::new(&burr, params.samples)?;
        let n = samples.len();
        let k_max = params.profile.max_stiffness_n_per_mm;
        let mechanics = model
            .tissues
            .iter()
            .map(|t| Mechanics {
                stiffness: t.props.stiffness_n_per_mm.min(k_max),
                damping: t.props.damping_n_s_per_mm,
                removal_rate: t.props.removal_rate_mm3_per_n_s,
            })
            .collect();
        Ok(HapticCore {
            query: ContactQuery::with_bounds(samples, model),
            proxy: Proxy::new(n),
            mechanics,
            filter: ForceFilter::new(params.filter),
            watchdog: Watchdog::new(params.watchdog),
            cutter: Cutter::default(),
            last_device: None,
            pending_advance: 0.0,
            ticks: 0,
            removed_mm3: vec![0.0; model.tissues.len()],
            burr,
            params,
        })
    }

    pub fn burr(&self) -> &Burr {
        &self.burr
    }

    pub fn samples(&self) -> &BurrSamples {
        &self.query.samples
    }

    pub fn watchdog_trips(&self) -> u32 {
        self.watchdog.trips
    }

    pub fn proxy(&self) -> DVec3 {
        self.proxy.position
    }

    /// One tick. `missed_deadline` feeds the watchdog. Touch mode never allocates; cut mode calls
    /// [`Cutter::cut`], whose report allocates (see the session notes).
    pub fn tick(&mut self, model: &mut TissueModel, state: &DeviceState, missed_deadline: bool) -> Result<TickOutput> {
        self.ticks += 1;
        let dt = self.params.period_s;
        let pose = if state.pose.is_finite() { state.pose } else { DAffine3::from_translation(self.proxy.position) };
        let device = pose.translation;
        let velocity = self.last_device.map_or(DVec3::ZERO, |p| (device - p) / dt);
        self.last_device = Some(device);

        let tolerance = if state.cutting() { CUT_TOLERANCE_VOXELS * model.voxel_size().unwrap_or(0.05) } else { 0.0 };
        self.proxy.follow(&mut self.query, model, &pose, self.params.max_step_mm, tolerance);
        let proxy = self.proxy.position;
        let axis_point = pose.transform_point3(DVec3::new(0.0, 0.0, self.params.axis_point_mm));
        let raw = contact_force(
            self.proxy.contacts(),
            &self.query.samples,
            &self.mechanics,
            proxy - device,
            velocity,
            axis_point,
        );
        let mut out = TickOutput { raw, proxy, gain: 1.0, ..Default::default() };

        if state.cutting() && raw.tissue.is_some() {
            self.accumulate_advance(&pose, &raw, state.rpm);
        }
        let interval = u64::from(self.params.cut_interval_ticks.max(1));
        if self.pending_advance > 0.0 && self.ticks % interval == 0 {
            out.removed_mm3 = self.cut(model, &pose, &mut out)?;
        }

        let max_force = self.params.profile.max_force_n;
        let filtered = self.filter.apply(clamp_length(raw.force, max_force));
        out.gain = self.watchdog.update(missed_deadline);
        out.force = clamp_length(filtered * out.gain, max_force);
        // Torque: same gain; bounded by the force limit times the lever arm.
        let lever = self.params.axis_point_mm.abs() + self.params.burr_diameter_mm;
        out.torque = clamp_length(raw.torque * out.gain, max_force * lever);
        Ok(out)
    }

    /// Seed 003's intermediate surface: the proxy may enter the tissue only as fast as the tissue
    /// is removed: advance = rate·|F|·(rpm/ref)·dt / frontal area of the burr.
    fn accumulate_advance(&mut self, pose: &DAffine3, raw: &ContactForce, rpm: f64) {
        let dir = -raw.normal;
        let tool_dir = pose.inverse().transform_vector3(dir).try_normalize().unwrap_or(DVec3::NEG_Z);
        let area = self.query.samples.frontal_area(tool_dir).max(1e-6);
        let speed = (rpm / self.params.reference_rpm).clamp(0.0, 4.0);
        let budget_mm3 = raw.removal_rate * raw.spring.length() * speed * self.params.period_s;
        self.pending_advance = (self.pending_advance + budget_mm3 / area).min(self.params.max_step_mm);
    }

    /// Cuts the burr from the proxy forward by the pending advance, toward the device.
    fn cut(&mut self, model: &mut TissueModel, pose: &DAffine3, out: &mut TickOutput) -> Result<f64> {
        let toward = pose.translation - self.proxy.position;
        let Some(dir) = toward.try_normalize() else {
            self.pending_advance = 0.0;
            return Ok(0.0);
        };
        let advance = self.pending_advance.min(toward.length());
        self.pending_advance = 0.0;
        let mut from = *pose;
        from.translation = self.proxy.position;
        let mut to = from;
        to.translation += dir * advance;
        // The borrowed report: `Cutter::cut` would clone it (tissue names) every cut tick.
        let report = self.cutter.cut_with(model, &self.burr, from, to, Feed::Geometric)?;
        let mut total = 0.0;
        for (i, (_, v)) in report.removed_mm3.iter().enumerate() {
            if let Some(r) = self.removed_mm3.get_mut(i) {
                *r += v;
            }
            total += v;
        }
        out.cut = Some((from, to));
        Ok(total)
    }
}
