//! The contact force law between the proxy and the device (god-object coupling):
//! F = Σᵢ kₜ·dᵢ·nᵢ·wᵢ − b·(v·n̄)n̄, with dᵢ = max(0, (x_proxy − x_device)·nᵢ) the device's depth
//! beyond the tissue surface the proxy rests on at contact point i, nᵢ the tissue normal there,
//! wᵢ = areaᵢ / Σ area the point's share of the contact area, kₜ, b the stiffness (clamped to the
//! device) and damping of the tissue containing the point. A burr pressed d into a flat tissue
//! gets exactly k·d. The damping never pulls the tool into the tissue.
use glam::DVec3;

use crate::haptics::contact::{BurrSamples, ContactPoint};

/// Per-tissue numbers the tick uses, indexed like the model's tissues.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Mechanics {
    /// N/mm, already clamped to the device profile.
    pub stiffness: f64,
    /// N·s/mm.
    pub damping: f64,
    /// mm³ per N·s at the reference handpiece speed.
    pub removal_rate: f64,
}

/// What the contact does to the tool this tick.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactForce {
    /// N, world.
    pub force: DVec3,
    /// Spring part only (no damping): drives the removal budget, so cutting does not depend on
    /// velocity noise.
    pub spring: DVec3,
    /// N·mm about the handpiece axis point.
    pub torque: DVec3,
    /// Area-weighted mean tissue normal of the contact.
    pub normal: DVec3,
    /// Tissue holding the largest share of the contact area.
    pub tissue: Option<u16>,
    /// Area-weighted removal rate of the contact (mm³/(N·s)).
    pub removal_rate: f64,
    /// Area-weighted stiffness of the contact (N/mm).
    pub stiffness: f64,
    /// Contact area (mm²).
    pub area: f64,
}

/// Largest tissue count the per-tick tally supports without allocating.
pub const MAX_TISSUES: usize = 32;

/// Evaluates the force law. `contacts` are the proxy's contact points (positions on the proxy's
/// burr), `offset` = x_proxy − x_device, `axis_point` the world point torques are taken about.
pub fn contact_force(
    contacts: &[ContactPoint],
    samples: &BurrSamples,
    mechanics: &[Mechanics],
    offset: DVec3,
    device_velocity: DVec3,
    axis_point: DVec3,
) -> ContactForce {
    let mut out = ContactForce::default();
    // Weights: area × spring extension, so points the offset does not press (walls parallel to
    // the motion) do not dilute the ones it does; a flat contact still gives exactly k·d.
    let weight = |c: &ContactPoint| samples.areas[c.sample as usize] * offset.dot(c.normal).max(0.0);
    let total: f64 = contacts.iter().map(weight).sum();
    if contacts.is_empty() || !(total > 0.0) {
        return out;
    }
    let mut share = [0.0f64; MAX_TISSUES];
    let mut damping = 0.0;
    let mut normal = DVec3::ZERO;
    for c in contacts {
        let w = weight(c) / total;
        let m = mechanics.get(c.tissue as usize).copied().unwrap_or_default();
        let depth = offset.dot(c.normal).max(0.0);
        let f = c.normal * (m.stiffness * depth * w);
        out.spring += f;
        // The point on the device's burr that this contact point stands for.
        out.torque += (c.position - offset - axis_point).cross(f);
        normal += c.normal * w;
        damping += m.damping * w;
        out.removal_rate += m.removal_rate * w;
        out.stiffness += m.stiffness * w;
        if let Some(s) = share.get_mut(c.tissue as usize) {
            *s += w;
        }
    }
    out.area = contacts.iter().map(|c| samples.areas[c.sample as usize]).sum();
    out.normal = normal.try_normalize().unwrap_or(DVec3::ZERO);
    out.tissue = share
        .iter()
        .enumerate()
        .filter(|(_, s)| **s > 0.0)
        .max_by(|a, b| a.1.total_cmp(b.1))
        .map(|(t, _)| t as u16);
    let n = out.normal;
    let mut force = out.spring - n * (damping * device_velocity.dot(n));
    // No sticky wall: the damper may slow an escape but never pull the tool in.
    let pushing = force.dot(n);
    if pushing < 0.0 {
        force -= n * pushing;
    }
    out.force = force;
    out
}
