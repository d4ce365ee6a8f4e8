//! The god-object proxy: a copy of the burr that follows the device but never enters tissue.
//!
//! Each tick the proxy moves toward the device in sub-steps no longer than `max_step` (below
//! half the thinnest wall we promise to hold, 0.3 mm, and below the narrow band), and after each
//! sub-step is pushed back out along the contact normal, keeping only the motion tangent to the
//! surface. A fast device cannot drag it through a thin wall: every position it takes was checked.
//! Orientation follows the device (the proxy is translational only).
use glam::{DAffine3, DVec3};

use crate::contact::{ContactPoint, ContactQuery};
use crate::model::TissueModel;

/// Sub-steps per tick at most; beyond that the proxy lags (800 mm/s at 0.05 mm steps ×16).
pub const MAX_SUBSTEPS: usize = 16;
/// Push-out iterations per sub-step (a flat contact needs one).
const RESOLVE_ITERATIONS: usize = 4;

#[derive(Clone, Debug)]
pub struct Proxy {
    pub position: DVec3,
    initialized: bool,
    /// The penetrating points of the last blocked sub-step, moved onto the proxy.
    contacts: Vec<ContactPoint>,
}

impl Proxy {
    pub fn new(capacity: usize) -> Self {
        Proxy { position: DVec3::ZERO, initialized: false, contacts: Vec::with_capacity(capacity) }
    }

    /// The proxy's contact points after the last [`Proxy::follow`].
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
    /// `tolerance` (mm): how deep the proxy may rest inside tissue. 0 in touch mode. In cut mode a
    /// fraction of a voxel, so the proxy sits in the stroke it is cutting: the cut surface of a
    /// sub-voxel advance is only resolved up to the trilinear error of the ball's SDF (≈ h²/8r),
    /// and without the tolerance that error would push the proxy back out of its own cut.
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
            if let Some(n) = self.resolve(query, model, &mut pose, tolerance) {
                // Blocked: what is left of the motion may slide along the surface, not press in.
                let into = remaining.dot(n);
                if into < 0.0 {
                    remaining -= n * into;
                }
            }
        }
    }

    /// Pushes the proxy out of tissue; returns the contact normal if it had to.
    fn resolve(&mut self, query: &mut ContactQuery, model: &TissueModel, pose: &mut DAffine3, tolerance: f64) -> Option<DVec3> {
        let mut normal = None;
        let recorded_at = self.position;
        for iteration in 0..RESOLVE_ITERATIONS {
            let contacts = query.query(model, pose, -tolerance as f32);
            if contacts.is_empty() {
                break;
            }
            let mut n = DVec3::ZERO;
            for c in contacts {
                n += c.normal * c.depth;
            }
            let Some(n) = n.try_normalize() else { break };
            let mut push = contacts.iter().map(|c| (c.depth - tolerance) * c.normal.dot(n).max(0.0)).fold(0.0, f64::max);
            if iteration == 0 {
                self.contacts.clear();
                self.contacts.extend_from_slice(contacts);
            }
            // Close the gap between samples: the burr's own deepest point along −n.
            let tool_dir = (pose.matrix3.transpose() * -n).normalize_or_zero();
            let support = pose.transform_point3(query.samples.support(tool_dir));
            push = push.max(-f64::from(query.value_at(model, support)) - tolerance);
            self.position += n * push;
            pose.translation = self.position;
            normal = Some(n);
            if push <= 1e-9 {
                break;
            }
        }
        // The recorded points now sit on the pushed-out proxy.
        let shift = self.position - recorded_at;
        for c in &mut self.contacts {
            c.position += shift;
        }
        normal
    }
}
