//! One haptic tick, deterministic and allocation-free in touch mode: device state → proxy →
//! contact force → removal budget → cut → filter, watchdog and clamp → force for the device.
//! The session thread calls it at 1 kHz; replay calls it again on the logged device states.
use dentsim_devices::{DeviceProfile, DeviceState};
use dentsim_vdb::{Measure, VoxelChange};
use glam::{DAffine3, DVec3};
use serde::{Deserialize, Serialize};

use crate::burr::Burr;
use crate::cutting::cutter::{Cutter, Handoff};
use crate::cutting::removal::Feed;
use crate::cutting::sweep::Done;
use crate::error::{invalid, Result};
use crate::haptics::contact::{BurrSamples, ContactQuery};
use crate::haptics::filter::{clamp_length, FilterSpec, ForceFilter};
use crate::haptics::force::{contact_force, ContactForce, Mechanics, MAX_TISSUES};
use crate::haptics::guidance::{GuidanceParams, PulpClearance};
use crate::haptics::proxy::Proxy;
use crate::haptics::watchdog::{Deadline, Watchdog, WatchdogParams};
use crate::tissues::model::TissueModel;

/// How deep (mm) the proxy may rest in tissue in cut mode (see [`Proxy::follow_cut`]): rounding
/// only. The proxy sits in its own cut because the contact query counts the burr at the end of the
/// last stroke as free space ([`ContactQuery::set_freed`]), not through a tolerance: a stroke
/// started from a proxy resting that deep in uncut tissue removes that depth on top of the rate
/// law's advance. The 0.25-voxel tolerance used before did so every cut (12.5 µm per tick, against
/// ≈ 0.6 µm for enamel at 1 N): the proxy ran ahead of the law, caught up with a slowly moving
/// device and lost contact (force on/off every few ticks), or slid into the hollow's walls and
/// widened it (see [`Proxy::follow_cut`]).
pub const CUT_TOLERANCE_MM: f64 = 1e-6;
/// Cut mode: a burr point this close to tissue (voxels; at least the samples' gap depth, see
/// [`BurrSamples::gap_depth`]) touches it: beyond the grids' rounding, small against a cut's depth.
pub const TOUCH_VOXELS: f64 = 0.1;
/// A stroke continues from the end of the last one while the proxy is this close to it (voxels).
pub const STROKE_CONTINUES_VOXELS: f64 = 0.1;
/// Below this area (mm², a hundredth of a sample point on a 1 mm ball) nothing lies ahead.
const MIN_FOOTPRINT_MM2: f64 = 1e-4;

pub use crate::burr::DEFAULT_BURR;

/// Everything that shapes the tick; stored in the log header so a replay redoes the same ticks.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HapticParams {
    /// The burr, as `dentsim prepare` takes it ([`Burr::parse`]): a catalogue name, an ISO 6360
    /// number or `SHAPE:DIAMETER_MM[:LENGTH_MM]`.
    pub burr: String,
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
    /// 1 by default. Batching (e.g. 10) amortises a stroke's cost (~1–5 ms today: 3 tissues ×
    /// ~24 k voxels for a 1 mm ball) and keeps the removal rate (cut_probe, cut_chatter tests); the
    /// force then steps by k × the batched advance every interval (≈ 6 mN at 1 N in enamel for 10).
    /// (It used to stall: the removal came mostly from the cut-mode tolerance, one tolerance
    /// depth per cut, so batching cut it by the interval.)
    pub cut_interval_ticks: u32,
    pub watchdog: WatchdogParams,
    /// Live guidance over the pulp (absent from logs written before it: the default).
    #[serde(default)]
    pub guidance: GuidanceParams,
}

impl Default for HapticParams {
    fn default() -> Self {
        HapticParams {
            burr: DEFAULT_BURR.into(),
            samples: 256,
            profile: DeviceProfile::named(DeviceProfile::DEFAULT_NAME).expect("built-in profile"),
            filter: FilterSpec::default_delta(),
            period_s: dentsim_devices::HAPTIC_PERIOD_S,
            max_step_mm: 0.05,
            axis_point_mm: 19.0,
            reference_rpm: crate::cutting::removal::REFERENCE_RPM,
            cut_interval_ticks: 1,
            watchdog: WatchdogParams::default(),
            guidance: GuidanceParams::default(),
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
    /// Volume removed this tick (mm³, all tissues); 0 when the core does not measure
    /// ([`HapticCore::set_measure`]).
    pub removed_mm3: f64,
    /// Voxels this tick's cut changed (all tissues).
    pub changed_voxels: u64,
    /// Watchdog gain applied (1 = normal).
    pub gain: f64,
    /// Thinnest tissue between the burr head (where it cut, else at the proxy) and the pulp it
    /// started with (mm; negative inside it; infinite when far or without guidance; see
    /// [`PulpClearance`]).
    pub clearance_mm: f64,
    /// [`crate::haptics::guidance::FLAG_THIN_DENTIN`] or `FLAG_PULP_EXPOSED` when this tick cut that close.
    pub guidance: u32,
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
    /// End pose of the last cut stroke: that burr head is free space, whatever the grid reads.
    last_cut: Option<DAffine3>,
    /// Cut mode: how close to tissue (mm) a burr point touches it ([`TOUCH_VOXELS`]).
    touch_mm: f64,
    ticks: u64,
    /// Volume removed per tissue so far (mm³), model order.
    pub removed_mm3: Vec<f64>,
    /// See [`HapticCore::prepare_guidance`].
    clearance: Option<PulpClearance>,
}

impl HapticCore {
    pub fn new(params: HapticParams, model: &TissueModel) -> Result<Self> {
        params.filter.validate().map_err(|m| invalid("force filter", m))?;
        params.guidance.validate()?;
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
        let burr = Burr::parse(&params.burr)?;
        let samples = BurrSamples::new(&burr, params.samples)?;
        let n = samples.len();
        let samples_gap = samples.gap_depth();
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
            last_cut: None,
            touch_mm: (TOUCH_VOXELS * model.voxel_size().unwrap_or(0.05)).max(samples_gap),
            ticks: 0,
            removed_mm3: vec![0.0; model.tissues.len()],
            clearance: None,
            burr,
            params,
        })
    }

    /// Readies `model` for this core's cuts before the first tick: leaves for the grids' insides
    /// and every buffer a stroke needs (strokes are at most one proxy step), so that cut ticks
    /// allocate nothing.
    pub fn prepare_cutting(&mut self, model: &mut TissueModel) -> Result<()> {
        model.voxelize_for_cutting()?;
        self.cutter.prepare(model, &self.burr, self.params.max_step_mm);
        Ok(())
    }

    /// Readies live guidance on `model` as it is now (the session's start): the pulp's distance
    /// field ([`PulpClearance`]). Without it (or without a pulp) ticks report no clearance.
    pub fn prepare_guidance(&mut self, model: &TissueModel) -> Result<()> {
        self.clearance = PulpClearance::new(model, &self.params.guidance, &self.query.samples)?;
        Ok(())
    }

    /// Whether guidance measures clearance (a pulp and a threshold above 0).
    pub fn guides(&self) -> bool {
        self.clearance.is_some()
    }

    /// Whether cuts measure the volume they remove (the default; see [`Cutter::set_measure`]).
    pub fn set_measure(&mut self, measure: Measure) {
        self.cutter.set_measure(measure);
    }

    /// What the core's cuts leave for others (see [`Handoff`]); a session hands its mesher the
    /// changed voxels.
    pub fn set_handoff(&mut self, handoff: Handoff) {
        self.cutter.set_handoff(handoff);
    }

    /// [`Handoff::NewValues`]: the voxels this tick's cut changed in `tissue`, with their new values.
    pub fn last_changes(&self, tissue: usize) -> &[VoxelChange] {
        self.cutter.last_changes(tissue)
    }

    /// The done head this tick's cut skipped (for [`Cutter::recut`]).
    pub fn last_skipped(&self) -> Option<Done> {
        self.cutter.last_skipped()
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

    /// One tick. `deadline` (a [`Deadline`], or whether it was missed) feeds the watchdog.
    /// Allocation-free, in cut mode once [`prepare_cutting`](Self::prepare_cutting) has run.
    pub fn tick(&mut self, model: &mut TissueModel, state: &DeviceState, deadline: impl Into<Deadline>) -> Result<TickOutput> {
        self.ticks += 1;
        let dt = self.params.period_s;
        let pose = if state.pose.is_finite() { state.pose } else { DAffine3::from_translation(self.proxy.position) };
        let device = pose.translation;
        let velocity = self.last_device.map_or(DVec3::ZERO, |p| (device - p) / dt);
        self.last_device = Some(device);

        // Touch mode: the grids alone, no tolerance. Cut mode: the proxy may also rest in the head
        // it cut last (exact), not deeper in uncut tissue than rounding.
        let (tolerance, freed) = if state.cutting() { (CUT_TOLERANCE_MM, self.last_cut) } else { (0.0, None) };
        self.query.set_freed(freed);
        if state.cutting() {
            self.proxy.follow_cut(&mut self.query, model, &pose, self.params.max_step_mm, tolerance);
        } else {
            self.proxy.follow(&mut self.query, model, &pose, self.params.max_step_mm, tolerance);
        }
        let proxy = self.proxy.position;
        let axis_point = pose.transform_point3(DVec3::new(0.0, 0.0, self.params.axis_point_mm));
        let mut at_proxy = pose;
        at_proxy.translation = proxy;
        let contacts = if state.cutting() {
            // The points touching tissue where the proxy came to rest, whichever sub-step found
            // them: the proxy's own record is the last blocked sub-step's alone, and a sideways
            // sub-step that grazes a wall after a head-on one would leave the wall's points only.
            self.query.query(model, &at_proxy, self.touch_mm as f32);
            self.query.contacts()
        } else {
            self.proxy.contacts()
        };
        let raw = contact_force(
            contacts,
            &self.query.samples,
            &self.mechanics,
            proxy - device,
            velocity,
            axis_point,
        );
        let mut out = TickOutput { raw, proxy, gain: 1.0, clearance_mm: f64::INFINITY, ..Default::default() };

        if state.cutting() && raw.tissue.is_some() {
            self.accumulate_advance(model, &pose, &raw, state.rpm);
        }
        let interval = u64::from(self.params.cut_interval_ticks.max(1));
        if self.pending_advance > 0.0 && self.ticks % interval == 0 {
            out.removed_mm3 = self.cut(model, &pose, &mut out)?;
        }
        if let Some(clearance) = self.clearance.as_mut() {
            // Where the head cut to, else where it rests.
            let head = out.cut.map_or(at_proxy, |(_, to)| to);
            out.clearance_mm = clearance.measure(&self.query.samples, &head);
            out.guidance = self.params.guidance.classify(out.clearance_mm, out.cut.is_some());
        }

        let max_force = self.params.profile.max_force_n;
        let filtered = self.filter.apply(clamp_length(raw.force, max_force));
        out.gain = self.watchdog.update(deadline);
        out.force = clamp_length(filtered * out.gain, max_force);
        // Torque: same gain; bounded by the force limit times the lever arm.
        let lever = self.params.axis_point_mm.abs() + self.burr.bounding_radius();
        out.torque = clamp_length(raw.torque * out.gain, max_force * lever);
        Ok(out)
    }

    /// Seed 003's intermediate surface: the proxy may enter the tissue only as fast as the tissue
    /// is removed: advance = rate·|F|·(rpm/ref)·dt / A, with A the area that the burr's points
    /// touching tissue present toward the device ([`BurrSamples::frontal_area_of`]; the contact
    /// query of this tick), so that the stroke [`HapticCore::cut`] makes removes
    /// rate·|F|·(rpm/ref)·dt. (The whole head's frontal area instead held a burr just touching a
    /// surface to a fraction of its removal rate until it had sunk by a radius.) Nothing ahead,
    /// no advance.
    fn accumulate_advance(&mut self, model: &TissueModel, pose: &DAffine3, raw: &ContactForce, rpm: f64) {
        let start = self.stroke_start(model);
        let Some(dir) = (pose.translation - start).try_normalize() else { return };
        let area = self.query.samples.frontal_area_of(self.query.contacts(), pose, dir);
        if !(area > MIN_FOOTPRINT_MM2) {
            return;
        }
        let speed = (rpm / self.params.reference_rpm).clamp(0.0, 4.0);
        let budget_mm3 = raw.removal_rate * raw.spring.length() * speed * self.params.period_s;
        self.pending_advance = (self.pending_advance + budget_mm3 / area).min(self.params.max_step_mm);
    }

    /// Where the next stroke starts: where the last one ended while the proxy is still there (to
    /// the push-out's resolution, [`STROKE_CONTINUES_VOXELS`]), else at the proxy. The push-out
    /// settles the proxy a fraction of a micrometre off the end of its cut (≈ 0.06 µm behind,
    /// a tenth of a tick's advance at 1 N in enamel); strokes started there lost that much of
    /// every advance, and strokes started ahead would add to it.
    fn stroke_start(&self, model: &TissueModel) -> DVec3 {
        let proxy = self.proxy.position;
        let reach = STROKE_CONTINUES_VOXELS * model.voxel_size().unwrap_or(0.05);
        match self.last_cut {
            Some(end) if end.translation.distance(proxy) <= reach => end.translation,
            _ => proxy,
        }
    }

    /// Cuts the burr from the proxy forward by the pending advance, toward the device.
    fn cut(&mut self, model: &mut TissueModel, pose: &DAffine3, out: &mut TickOutput) -> Result<f64> {
        let start = self.stroke_start(model);
        let toward = pose.translation - start;
        let Some(dir) = toward.try_normalize() else {
            self.pending_advance = 0.0;
            return Ok(0.0);
        };
        let advance = self.pending_advance.min(toward.length());
        self.pending_advance = 0.0;
        let mut from = *pose;
        from.translation = start;
        let mut to = from;
        to.translation += dir * advance;
        // The borrowed report: `Cutter::cut` would clone it (tissue names) every cut tick.
        let report = self.cutter.cut_with(model, &self.burr, from, to, Feed::Geometric)?;
        self.last_cut = Some(to);
        let mut total = 0.0;
        for (i, (_, v)) in report.removed_mm3.iter().enumerate() {
            if let Some(r) = self.removed_mm3.get_mut(i) {
                *r += v;
            }
            total += v;
        }
        out.cut = Some((from, to));
        out.changed_voxels = report.changed_voxels;
        Ok(total)
    }
}
