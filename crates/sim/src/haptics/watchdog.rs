//! Ramps the rendered force to zero after repeated missed deadlines (a late tick renders a stale,
//! possibly deep penetration: a kick), and back up once ticks are on time again.
use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct WatchdogParams {
    /// Consecutive missed deadlines that trip the watchdog.
    pub misses_to_trip: u32,
    /// Ticks to ramp from full force to zero.
    pub ramp_down_ticks: u32,
    /// On-time ticks needed before ramping back up, and the ramp's length in ticks.
    pub recover_after_ticks: u32,
    pub ramp_up_ticks: u32,
}

impl Default for WatchdogParams {
    fn default() -> Self {
        WatchdogParams { misses_to_trip: 3, ramp_down_ticks: 50, recover_after_ticks: 200, ramp_up_ticks: 200 }
    }
}

#[derive(Clone, Debug)]
pub struct Watchdog {
    params: WatchdogParams,
    misses: u32,
    on_time: u32,
    tripped: bool,
    gain: f64,
    /// Times it tripped.
    pub trips: u32,
}

impl Watchdog {
    pub fn new(params: WatchdogParams) -> Self {
        Watchdog { params, misses: 0, on_time: 0, tripped: false, gain: 1.0, trips: 0 }
    }

    /// Feeds one tick; returns the force gain in [0, 1].
    pub fn update(&mut self, missed: bool) -> f64 {
        let p = self.params;
        if missed {
            self.misses += 1;
            self.on_time = 0;
            if self.misses >= p.misses_to_trip.max(1) && !self.tripped {
                self.tripped = true;
                self.trips += 1;
            }
        } else {
            self.misses = 0;
            self.on_time = self.on_time.saturating_add(1);
            if self.tripped && self.on_time >= p.recover_after_ticks {
                self.tripped = false;
            }
        }
        if self.tripped {
            self.gain = (self.gain - 1.0 / f64::from(p.ramp_down_ticks.max(1))).max(0.0);
        } else if self.gain < 1.0 && !missed {
            self.gain = (self.gain + 1.0 / f64::from(p.ramp_up_ticks.max(1))).min(1.0);
        }
        self.gain
    }

    pub fn tripped(&self) -> bool {
        self.tripped
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ramps_down_after_repeated_misses_and_recovers() {
        let mut w = Watchdog::new(WatchdogParams { misses_to_trip: 3, ramp_down_ticks: 10, recover_after_ticks: 5, ramp_up_ticks: 10 });
        assert_eq!(w.update(true), 1.0);
        assert_eq!(w.update(false), 1.0); // isolated misses do nothing
        let gains: Vec<f64> = (0..15).map(|_| w.update(true)).collect();
        assert!(w.tripped());
        assert!(gains[2] < 1.0 && gains.windows(2).all(|g| g[1] <= g[0]));
        assert_eq!(*gains.last().unwrap(), 0.0);
        for _ in 0..4 {
            assert_eq!(w.update(false), 0.0);
        }
        let up: Vec<f64> = (0..12).map(|_| w.update(false)).collect();
        assert!(!w.tripped() && up[0] > 0.0 && *up.last().unwrap() == 1.0);
        assert_eq!(w.trips, 1);
    }
}
