//! Removal rate: in a session, tissue recedes no faster than its rate from the tissue table
//! (mm³ per second per newton of applied force) scaled by handpiece speed relative to a reference.
//!
//! Each tick earns every tissue a budget `rate · F · (rpm / reference) · dt`, banked up to
//! `MAX_BANKED_S` seconds' worth so an idle pause cannot store up a sudden plunge. A tick whose
//! geometric cut would remove more than the bank shrinks the tool by the smallest sampled offset
//! whose dry-run removal fits, so the surface recedes a partial depth toward the burr; the bank
//! carries over, so even a tiny budget makes steady progress. An unlimited feed (`Feed::geometric`)
//! cuts the whole swept volume, as planning does.

/// Reference handpiece speed for the tissue table's rates: the devices' default, an electric
/// handpiece at 200 k rpm (REFERENCE.md "Handpieces": electric 40–200 k rpm, turbines 180–250 k
/// under load).
pub const REFERENCE_RPM: f64 = dentsim_devices::DEFAULT_RPM;
/// Bank at most this much cutting time.
pub const MAX_BANKED_S: f64 = 0.05;
/// Offsets sampled per rate-limited tick.
pub const OFFSET_SAMPLES: usize = 16;

/// What drives the cut during one tick.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Feed {
    /// Remove the whole swept volume (planning, `prepare`).
    Geometric,
    /// Rate-limited: applied force along the burr (N), handpiece speed (rpm), tick length (s).
    Limited { force_n: f64, rpm: f64, dt_s: f64 },
}

impl Feed {
    pub fn geometric() -> Self {
        Feed::Geometric
    }

    /// Volume (mm³) a tissue of `rate` may lose in this tick, or `None` for no limit.
    pub fn budget(&self, rate_mm3_per_n_s: f64) -> Option<f64> {
        match *self {
            Feed::Geometric => None,
            Feed::Limited { force_n, rpm, dt_s } => {
                Some(rate_mm3_per_n_s * force_n.max(0.0) * (rpm.max(0.0) / REFERENCE_RPM) * dt_s.max(0.0))
            }
        }
    }

    pub fn validate(&self) -> crate::Result<()> {
        if let Feed::Limited { force_n, rpm, dt_s } = *self {
            for (name, v) in [("feed force_n", force_n), ("feed rpm", rpm), ("feed dt_s", dt_s)] {
                if !(v.is_finite() && v >= 0.0) {
                    return Err(crate::error::invalid(name, format!("is {v}, expected a finite number >= 0")));
                }
            }
        }
        Ok(())
    }
}

/// Per-tissue banked removal allowance (mm³), fixed-size so ticks never allocate.
#[derive(Clone, Debug, Default)]
pub struct RemovalBank {
    banked: Vec<f64>,
}

impl RemovalBank {
    /// Adds this tick's allowance for tissue `t` and returns what it may remove now.
    pub fn earn(&mut self, t: usize, budget: f64, rate_cap: f64) -> f64 {
        if self.banked.len() <= t {
            self.banked.resize(t + 1, 0.0);
        }
        let b = &mut self.banked[t];
        *b = (*b + budget).min(rate_cap.max(budget));
        *b
    }

    /// Charges what was actually removed (it may run slightly negative; later ticks repay it).
    pub fn spend(&mut self, t: usize, removed: f64, budget: f64) {
        if let Some(b) = self.banked.get_mut(t) {
            *b = (*b - removed).max(-budget);
        }
    }

    pub fn reset(&mut self) {
        self.banked.iter_mut().for_each(|b| *b = 0.0);
    }
}

/// The smallest sampled tool offset whose dry-run removal fits `allowed`.
pub fn pick_offset(offsets: &[f32], removed: &[f64], allowed: f64) -> f32 {
    offsets
        .iter()
        .zip(removed)
        .find(|(_, r)| **r <= allowed)
        .map(|(o, _)| *o)
        .unwrap_or_else(|| offsets.last().copied().unwrap_or(0.0))
}
