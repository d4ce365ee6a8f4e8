//! The god-object proxy: a copy of the burr that follows the device but never enters tissue.
//!
//! Each tick the proxy moves toward the device in sub-steps no longer than `max_step` (below
//! half the thinnest wall we promise to hold, 0.3 mm, and below the narrow band), and after each
//! sub-step is pushed back out along the contact normal, keeping only the motion tangent to the
//! surface. A fast device cannot drag it through a thin wall: every position it takes was checked.
//! Orientation follows the device (the proxy is translational only).
//!
//! Cut mode uses [`Proxy::follow_cut`]: the same sub-steps and push-out, but each sub-step aims at
//! the device again and a sub-step that ends farther from it is taken back and halved, so the
//! proxy settles in the hollow it cuts instead of swinging across it.
use glam::{DAffine3, DVec3};

use crate::haptics::contact::{ContactPoint, ContactQuery};
use crate::tissues::model::TissueModel;

/// Sub-steps per tick at most; beyond that the proxy lags (800 mm/s at 0.05 mm steps ×16).
pub const MAX_SUBSTEPS: usize = 16;
/// Push-out iterations per sub-step (a flat contact needs one).
const RESOLVE_ITERATIONS: usize = 4;
/// Cut mode: a sub-step counts as progress when it brings the proxy this much closer (mm).
const PROGRESS_MM: f64 = 1e-7;
/// Cut mode: a sub-step pushed back to within this distance of where it started (mm) made no
/// way: the push-out's resolution in a hollow the burr's own size (the grids round its walls
/// inward by ≈ h²/4r ≈ 1.2 µm at 0.05 mm voxels).
const SETTLE_MM: f64 = 1e-3;
/// Cut mode: halved sub-steps stop below this length (mm).
const MIN_STEP_MM: f64 = 1e-3;

#[derive(Clone, Debug)]
pub struct Proxy {
    pub position: DVec3,
    initialized: bool,
    /// The penetrating points of the last blocked sub-step, moved onto the proxy.
    contacts: Vec<ContactPoint>,
    /// Cut mode: the contacts of a sub-step not yet accepted.
    candidate: Vec<ContactPoint>,
}

impl Proxy {
    pub fn new(capacity: usize) -> Self {
        Proxy {
            position: DVec3::ZERO,
            initialized: false,
            contacts: Vec::with_capacity(capacity),
            candidate: Vec::with_capacity(capacity),
        }
    }

    /// The proxy's contact points after the last [`Proxy::follow`] or [`Proxy::follow_cut`].
    pub fn contacts(&self) -> &[ContactPoint] {
        &self.contacts
    }

    /// Puts the proxy at the device without checks (session start: the tool must start in free
    /// space; if it starts inside tissue the proxy is pushed out on the next tick).
    pub fn reset(&mut self, position: DVec3) {
        self.position = position;
        self.initialized = true;
        self.contacts.clear();
    }

    /// Moves the proxy toward `device` (rotation from `device`). Allocation-free.
    ///
    /// `tolerance` (mm): how deep the proxy may rest inside tissue; the haptic tick passes 0
    /// (touch mode). Cut mode uses [`Proxy::follow_cut`].
    pub fn follow(&mut self, query: &mut ContactQuery, model: &TissueModel, device: &DAffine3, max_step: f64, tolerance: f64) {
        if !self.initialized {
            self.reset(device.translation);
        }
        self.contacts.clear();
        let mut remaining = device.translation - self.position;
        let mut pose = *device;
        for _ in 0..MAX_SUBSTEPS {
            let len = remaining.length();
            if !(len > 1e-9) {
                break;
            }
            let step = if len > max_step { remaining * (max_step / len) } else { remaining };
            self.position += step;
            pose.translation = self.position;
            remaining -= step;
            if let Some(n) = resolve(&mut self.position, &mut self.contacts, query, model, &mut pose, tolerance) {
                // Blocked: what is left of the motion may slide along the surface, not press in.
                let into = remaining.dot(n);
                if into < 0.0 {
                    remaining -= n * into;
                }
            }
        }
    }

    /// Cut mode: moves the proxy toward `device` like [`Proxy::follow`] (same sub-step length,
    /// same push-out, `tolerance` likewise), but as a descent on the distance to the device: each
    /// sub-step aims at the device again, sliding along the last contact's tangent plane, and
    /// one that leaves the proxy farther from the device than it started is taken back and
    /// halved (down to [`MIN_STEP_MM`]); one pushed back to where it started ends the motion. A
    /// proxy that starts inside tissue is still pushed out by the first sub-step. Allocation-free.
    ///
    /// Why not `follow`: it spends what is left of the device offset after a contact as one slide
    /// along that contact's tangent plane. In cut mode the proxy sits in a hollow of its own
    /// radius r with the device a spring stretch F/k beyond (≈ 1 mm at 1 N on a 1 N/mm device),
    /// so the slide overshoots the hollow's bottom by ≈ (F/k)/r, over 2 for a 1 mm ball: the proxy
    /// swung from wall to wall every tick, the force jumped with it, and cuts started from the
    /// swinging proxy widened the hollow instead of deepening it.
    pub fn follow_cut(&mut self, query: &mut ContactQuery, model: &TissueModel, device: &DAffine3, max_step: f64, tolerance: f64) {
        if !self.initialized {
            self.reset(device.translation);
        }
        self.contacts.clear();
        let target = device.translation;
        let mut pose = *device;
        let mut normal: Option<DVec3> = None;
        let mut limit = max_step;
        for k in 0..MAX_SUBSTEPS {
            let mut goal = target - self.position;
            if let Some(n) = normal {
                let into = goal.dot(n);
                if into < 0.0 {
                    goal -= n * into;
                }
            }
            let len = goal.length();
            if !(len > 1e-9) || limit < MIN_STEP_MM {
                break;
            }
            let start = self.position;
            let before = target.distance(start);
            let stepped = start + goal * (limit.min(len) / len);
            self.position = stepped;
            pose.translation = stepped;
            let blocked = resolve(&mut self.position, &mut self.candidate, query, model, &mut pose, tolerance).is_some();
            let after = target.distance(self.position);
            let moved = self.position.distance(start);
            if after < before - PROGRESS_MM || (k == 0 && moved > SETTLE_MM) {
                // Progress (or, first, a proxy that started inside tissue pushed out). The
                // constraint met is the way the sub-step was pushed back: the last push-out
                // iteration's normal may only be a sideways correction.
                normal = if blocked { (self.position - stepped).try_normalize() } else { None };
                if blocked {
                    std::mem::swap(&mut self.contacts, &mut self.candidate);
                }
            } else if moved <= SETTLE_MM {
                // Pushed back to where it started, to the push-out's resolution: no way on. The
                // proxy stays put (it would otherwise wander by that resolution every tick); if
                // nothing holds it yet, this sub-step's contacts do.
                self.position = start;
                if blocked && self.contacts.is_empty() {
                    std::mem::swap(&mut self.contacts, &mut self.candidate);
                }
                break;
            } else {
                // Overshot (e.g. across the hollow and up its far side): take back, try shorter.
                self.position = start;
                limit = limit.min(len) * 0.5;
            }
        }
    }
}

/// Pushes the burr at `pose` (translation `position`) out of tissue, moving `position` with it;
/// returns the contact normal if it had to. `contacts` gets the penetrating points found first,
/// moved onto the pushed-out burr; it is left alone when nothing penetrates.
fn resolve(
    position: &mut DVec3,
    contacts: &mut Vec<ContactPoint>,
    query: &mut ContactQuery,
    model: &TissueModel,
    pose: &mut DAffine3,
    tolerance: f64,
) -> Option<DVec3> {
    let mut normal = None;
    let recorded_at = *position;
    for iteration in 0..RESOLVE_ITERATIONS {
        let found = query.query(model, pose, -tolerance as f32);
        if found.is_empty() {
            break;
        }
        let mut n = DVec3::ZERO;
        for c in found {
            n += c.normal * c.depth;
        }
        let Some(n) = n.try_normalize() else { break };
        let mut push = found.iter().map(|c| (c.depth - tolerance) * c.normal.dot(n).max(0.0)).fold(0.0, f64::max);
        if iteration == 0 {
            contacts.clear();
            contacts.extend_from_slice(found);
        }
        // Close the gap between samples: the burr's own deepest point along −n.
        let tool_dir = (pose.matrix3.transpose() * -n).normalize_or_zero();
        let support = pose.transform_point3(query.samples.support(tool_dir));
        push = push.max(-f64::from(query.value_at(model, support)) - tolerance);
        *position += n * push;
        pose.translation = *position;
        normal = Some(n);
        if push <= 1e-9 {
            break;
        }
    }
    // The recorded points now sit on the pushed-out proxy.
    let shift = *position - recorded_at;
    for c in contacts.iter_mut() {
        c.position += shift;
    }
    normal
}

