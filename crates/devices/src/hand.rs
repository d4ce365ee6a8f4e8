//! A simulated user for closed-loop tests: a point mass (the hand plus stylus) pulled toward a
//! target by a saturating spring — so it pushes with at most a set force — and pushed back by the
//! force the session renders. Orientation, pedal and handpiece speed are held.
use glam::{DAffine3, DQuat, DVec3};

use crate::{Device, DeviceState, Fault, BUTTON_CUT};

/// The simulated hand's settings (mm, N, s, kg).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HandParams {
    pub start: DVec3,
    pub target: DVec3,
    pub rotation: DQuat,
    /// Largest force the hand applies toward the target (N); clinicians load a bur with ≈1 N.
    pub push_n: f64,
    /// Spring toward the target before it saturates at `push_n` (N/mm).
    pub stiffness_n_per_mm: f64,
    /// Viscous damping of the arm (N·s/mm).
    pub damping_n_s_per_mm: f64,
    /// Moving mass of hand and stylus (kg).
    pub mass_kg: f64,
    /// Pedal held (cut mode) and handpiece speed.
    pub pedal: bool,
    pub rpm: f64,
    /// The hand lets go after this time (s): `finished` turns true.
    pub duration_s: f64,
}

impl Default for HandParams {
    fn default() -> Self {
        HandParams {
            start: DVec3::ZERO,
            target: DVec3::ZERO,
            rotation: DQuat::IDENTITY,
            push_n: 1.0,
            stiffness_n_per_mm: 2.0,
            damping_n_s_per_mm: 0.03,
            mass_kg: 0.1,
            pedal: false,
            rpm: 0.0,
            duration_s: 1.0,
        }
    }
}

/// Integration step: well below the 1 ms tick and the hand's ~100 rad/s dynamics.
const SUBSTEP_S: f64 = 1e-4;

#[derive(Clone, Debug)]
pub struct SimulatedHand {
    pub params: HandParams,
    position: DVec3,
    velocity: DVec3,
    time: f64,
    rendered: DVec3,
}

impl SimulatedHand {
    pub fn new(params: HandParams) -> Self {
        SimulatedHand { params, position: params.start, velocity: DVec3::ZERO, time: 0.0, rendered: DVec3::ZERO }
    }

    /// The force the hand applies now (N): saturating spring toward the target minus arm damping.
    pub fn hand_force(&self) -> DVec3 {
        let p = &self.params;
        let pull = (p.target - self.position) * p.stiffness_n_per_mm;
        pull.clamp_length_max(p.push_n) - self.velocity * p.damping_n_s_per_mm
    }

    pub fn position(&self) -> DVec3 {
        self.position
    }

    /// Semi-implicit Euler up to `t` with the last rendered force held.
    fn advance(&mut self, t: f64) {
        // N / kg = m/s² = 1000 mm/s².
        let inv_mass = 1000.0 / self.params.mass_kg.max(1e-6);
        while self.time + 1e-12 < t {
            let dt = SUBSTEP_S.min(t - self.time);
            let a = (self.hand_force() + self.rendered) * inv_mass;
            self.velocity += a * dt;
            self.position += self.velocity * dt;
            self.time += dt;
        }
    }
}

impl Device for SimulatedHand {
    fn poll(&mut self, t: f64) -> Result<DeviceState, Fault> {
        if t.is_finite() {
            self.advance(t);
        }
        let p = &self.params;
        Ok(DeviceState {
            pose: DAffine3::from_rotation_translation(p.rotation, self.position),
            buttons: if p.pedal { BUTTON_CUT } else { 0 },
            rpm: p.rpm,
        })
    }

    fn send_force(&mut self, force: DVec3, _torque: DVec3) {
        self.rendered = if force.is_finite() { force } else { DVec3::ZERO };
    }

    fn finished(&self, t: f64) -> bool {
        t > self.params.duration_s
    }

    fn name(&self) -> &str {
        "simulated hand"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn free_hand_reaches_target_and_a_wall_force_stops_it() {
        let params = HandParams { start: DVec3::ZERO, target: DVec3::new(0.0, 0.0, -5.0), ..Default::default() };
        let mut hand = SimulatedHand::new(params);
        let s = hand.poll(1.0).unwrap();
        assert!((s.pose.translation.z + 5.0).abs() < 0.05, "{}", s.pose.translation);
        // A rendered force equal and opposite to the push holds the hand still.
        let mut hand = SimulatedHand::new(HandParams { target: DVec3::new(0.0, 0.0, -50.0), ..params });
        hand.send_force(DVec3::new(0.0, 0.0, 1.0), DVec3::ZERO);
        let s = hand.poll(0.5).unwrap();
        assert!(s.pose.translation.length() < 1e-9, "{}", s.pose.translation);
    }
}
