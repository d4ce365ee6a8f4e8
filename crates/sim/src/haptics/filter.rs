//! Force filters between the contact model and the device (seeds 000/002 delta limiter, seed 001
//! biquad), and the clamp to what the device can render. State is fixed-size: no allocation.
use glam::DVec3;
use serde::{Deserialize, Serialize};

/// Which filter shapes the rendered force.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum FilterSpec {
    None,
    /// F′ₜ = Fₜ₋₁ + δ·ΔF/‖ΔF‖ if ‖ΔF‖ > δ, else Fₜ (REFERENCE.md "Seed equations"): the force
    /// changes by at most `max_step_n` per tick.
    Delta { max_step_n: f64 },
    /// Up to [`MAX_SECTIONS`] biquads in series, each g·(b₀ + b₁z⁻¹ + b₂z⁻²)/(1 + a₁z⁻¹ + a₂z⁻²).
    Biquad { sections: [Biquad; MAX_SECTIONS], count: usize },
}

pub const MAX_SECTIONS: usize = 4;

/// One second-order section.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Biquad {
    pub g: f64,
    pub b: [f64; 3],
    pub a: [f64; 2],
}

impl Biquad {
    /// Seed 001's tuned section exactly as published: b = (1, −0.1, −0.1), a = (−0.2, −0.798),
    /// g = 0.004. Its DC gain is g·(1 − 0.2)/(1 − 0.2 − 0.798) = 1.6: it would render a 1 N
    /// contact as 1.6 N. [`Biquad::seed001`] therefore rescales g to a unit DC gain.
    pub const SEED001_AS_PUBLISHED: Biquad = Biquad { g: 0.004, b: [1.0, -0.1, -0.1], a: [-0.2, -0.798] };

    /// Seed 001's section with g rescaled (0.0025) so a steady force passes unchanged.
    pub fn seed001() -> Biquad {
        Self::SEED001_AS_PUBLISHED.with_unit_dc_gain()
    }

    /// H(1) = g·Σb / (1 + Σa).
    pub fn dc_gain(&self) -> f64 {
        self.g * (self.b[0] + self.b[1] + self.b[2]) / (1.0 + self.a[0] + self.a[1])
    }

    pub fn with_unit_dc_gain(self) -> Biquad {
        let k = self.dc_gain();
        Biquad { g: self.g / k, ..self }
    }

    /// Poles inside the unit circle (Jury's conditions for a second-order denominator).
    pub fn is_stable(&self) -> bool {
        let [a1, a2] = self.a;
        a2.abs() < 1.0 && (1.0 + a1 + a2) > 0.0 && (1.0 - a1 + a2) > 0.0
    }
}

impl FilterSpec {
    /// The preset sessions use unless told otherwise ([`FilterSpec::default_delta`]).
    pub const DEFAULT_NAME: &'static str = "delta";

    /// The default: seed 002's delta limiter at 0.05 N per tick (50 N/s: a 1 N contact builds up
    /// in 20 ms, a hard wall still feels hard).
    pub fn default_delta() -> Self {
        FilterSpec::Delta { max_step_n: 0.05 }
    }

    pub fn seed001_biquad() -> Self {
        let mut sections = [Biquad::seed001(); MAX_SECTIONS];
        sections[1..].fill(Biquad { g: 1.0, b: [1.0, 0.0, 0.0], a: [0.0, 0.0] });
        FilterSpec::Biquad { sections, count: 1 }
    }

    /// A preset by the name the command line and the plugin use: `delta`, `biquad` or `none`.
    pub fn named(name: &str) -> Result<Self, String> {
        match name.trim() {
            "delta" => Ok(Self::default_delta()),
            "biquad" => Ok(Self::seed001_biquad()),
            "none" => Ok(FilterSpec::None),
            other => Err(format!("'{other}', expected delta, biquad or none")),
        }
    }

    /// Checks the numbers; a bad spec is an error, never a NaN force later.
    pub fn validate(&self) -> Result<(), String> {
        match *self {
            FilterSpec::None => Ok(()),
            FilterSpec::Delta { max_step_n } if max_step_n.is_finite() && max_step_n > 0.0 => Ok(()),
            FilterSpec::Delta { max_step_n } => Err(format!("delta max_step_n {max_step_n}, expected > 0")),
            FilterSpec::Biquad { sections, count } => {
                if count == 0 || count > MAX_SECTIONS {
                    return Err(format!("biquad count {count}, expected 1..={MAX_SECTIONS}"));
                }
                for (i, s) in sections[..count].iter().enumerate() {
                    let finite = s.g.is_finite() && s.b.iter().chain(&s.a).all(|v| v.is_finite());
                    if !finite || !s.is_stable() {
                        return Err(format!("biquad section {i} is not finite and stable: {s:?}"));
                    }
                }
                Ok(())
            }
        }
    }
}

/// A running filter over a 3-vector (force).
#[derive(Clone, Debug)]
pub struct ForceFilter {
    spec: FilterSpec,
    last: DVec3,
    /// Transposed direct form II state per section: (s1, s2) per axis.
    state: [[DVec3; 2]; MAX_SECTIONS],
}

impl ForceFilter {
    pub fn new(spec: FilterSpec) -> Self {
        ForceFilter { spec, last: DVec3::ZERO, state: [[DVec3::ZERO; 2]; MAX_SECTIONS] }
    }

    pub fn spec(&self) -> FilterSpec {
        self.spec
    }

    pub fn reset(&mut self) {
        *self = Self::new(self.spec);
    }

    /// One tick. A non-finite input counts as zero force; a non-finite state is reset.
    pub fn apply(&mut self, input: DVec3) -> DVec3 {
        let x = if input.is_finite() { input } else { DVec3::ZERO };
        let y = match self.spec {
            FilterSpec::None => x,
            FilterSpec::Delta { max_step_n } => {
                let delta = x - self.last;
                let len = delta.length();
                if len > max_step_n {
                    self.last + delta * (max_step_n / len)
                } else {
                    x
                }
            }
            FilterSpec::Biquad { sections, count } => {
                let mut v = x;
                for (s, st) in sections.iter().zip(self.state.iter_mut()).take(count) {
                    let (b0, b1, b2) = (s.g * s.b[0], s.g * s.b[1], s.g * s.b[2]);
                    let out = v * b0 + st[0];
                    st[0] = v * b1 - out * s.a[0] + st[1];
                    st[1] = v * b2 - out * s.a[1];
                    v = out;
                }
                v
            }
        };
        if y.is_finite() {
            self.last = y;
            y
        } else {
            self.reset();
            DVec3::ZERO
        }
    }
}

/// Scales `v` so its length is at most `max` (≥ 0); NaN or infinite becomes zero.
pub fn clamp_length(v: DVec3, max: f64) -> DVec3 {
    if !v.is_finite() || !(max > 0.0) {
        return DVec3::ZERO;
    }
    let len = v.length();
    if len <= max {
        return v;
    }
    // Scale a hair under the limit so rounding can never land above it.
    let out = v * (max / len * (1.0 - 1e-12));
    if out.length() <= max { out } else { DVec3::ZERO }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn delta_step_response_is_the_analytic_ramp() {
        let mut f = ForceFilter::new(FilterSpec::Delta { max_step_n: 0.05 });
        let step = DVec3::new(0.0, 0.6, 0.8); // 1 N
        for n in 1..=30 {
            let y = f.apply(step);
            let expect = step * (0.05 * n as f64).min(1.0);
            assert!((y - expect).length() < 1e-12, "tick {n}: {y} vs {expect}");
        }
    }

    #[test]
    fn seed001_biquad_is_stable_and_rescaled_to_unit_dc_gain() {
        let p = Biquad::SEED001_AS_PUBLISHED;
        assert!((p.dc_gain() - 1.6).abs() < 1e-9, "{}", p.dc_gain());
        assert!(p.is_stable());
        let s = Biquad::seed001();
        assert!((s.dc_gain() - 1.0).abs() < 1e-12);
        assert!((s.g - 0.0025).abs() < 1e-12);
    }

    /// The step response of g·B(z)/A(z) in closed form: y[n] = H(1) + c₁p₁ⁿ + c₂p₂ⁿ with the real
    /// poles p of z² + a₁z + a₂ and residues cᵢ = g·B(pᵢ)/(pᵢ·A′(pᵢ)·(1 − 1/pᵢ))... computed below
    /// by partial fractions of Y(z) = H(z)·z/(z − 1).
    #[test]
    fn biquad_step_response_matches_closed_form() {
        let s = Biquad::seed001();
        let [a1, a2] = s.a;
        let disc = (a1 * a1 - 4.0 * a2).sqrt();
        let (p1, p2) = ((-a1 + disc) / 2.0, (-a1 - disc) / 2.0);
        // Y(z)/z = g(b0 z² + b1 z + b2) / ((z − 1)(z − p1)(z − p2)); residues at 1, p1, p2.
        let num = |z: f64| s.g * (s.b[0] * z * z + s.b[1] * z + s.b[2]);
        let r0 = num(1.0) / ((1.0 - p1) * (1.0 - p2));
        let r1 = num(p1) / ((p1 - 1.0) * (p1 - p2));
        let r2 = num(p2) / ((p2 - 1.0) * (p2 - p1));
        let mut f = ForceFilter::new(FilterSpec::seed001_biquad());
        for n in 0..3000 {
            let y = f.apply(DVec3::X).x;
            let exact = r0 + r1 * p1.powi(n) + r2 * p2.powi(n);
            assert!((y - exact).abs() < 1e-9, "n {n}: {y} vs {exact}");
        }
        assert!((r0 - 1.0).abs() < 1e-12);
    }

    #[test]
    fn bad_input_never_yields_nan() {
        for spec in [FilterSpec::None, FilterSpec::default_delta(), FilterSpec::seed001_biquad()] {
            let mut f = ForceFilter::new(spec);
            assert_eq!(f.apply(DVec3::NAN), DVec3::ZERO);
            assert!(f.apply(DVec3::new(f64::INFINITY, 0.0, 0.0)).is_finite());
            assert!(f.apply(DVec3::ONE).is_finite());
        }
        assert_eq!(clamp_length(DVec3::NAN, 3.3), DVec3::ZERO);
        assert!(clamp_length(DVec3::splat(1e300), 3.3).length() <= 3.3);
    }
}
