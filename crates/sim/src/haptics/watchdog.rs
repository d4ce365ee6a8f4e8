//! Ramps the rendered force to zero after repeated missed deadlines (a late tick renders a stale,
//! possibly deep penetration: a kick), and back up once ticks are on time again.
//!
//! After one stall of the OS (a few ms), the loop runs the ticks it owes back to back until it
//! is on time again: each starts late, but later by less than the one before. Those are the one
//! miss, counted once; only a tick that starts no less late than the last late one (the loop
//! falling behind) counts again. Counting each catch-up tick tripped the watchdog on every stall
//! over three periods, and the force took 0.45 s to come back.
use serde::{Deserialize, Serialize};

/// When a tick started against its deadline.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Deadline {
    OnTime,
    /// Late by this many seconds (NaN: by an amount not known, which always counts).
    Late(f64),
}

impl From<bool> for Deadline {
    /// A miss of unknown lateness, or none.
    fn from(missed: bool) -> Self {
        if missed {
            Deadline::Late(f64::NAN)
        } else {
            Deadline::OnTime
        }
    }
}

impl Deadline {
    /// The deadline of a tick that started `late_s` after it, `missed` when that was late by the
    /// loop's measure (a session's log holds both, so replay feeds the same).
    pub fn of(missed: bool, late_s: f64) -> Self {
        if missed {
            Deadline::Late(late_s)
        } else {
            Deadline::OnTime
        }
    }
}

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
    /// How late the last tick started, while ticks are late.
    late_s: Option<f64>,
    tripped: bool,
    gain: f64,
    /// Times it tripped.
    pub trips: u32,
}

impl Watchdog {
    pub fn new(params: WatchdogParams) -> Self {
        Watchdog { params, misses: 0, on_time: 0, late_s: None, tripped: false, gain: 1.0, trips: 0 }
    }

    /// Feeds one tick; returns the force gain in [0, 1].
    pub fn update(&mut self, deadline: impl Into<Deadline>) -> f64 {
        let p = self.params;
        let missed = deadline.into();
        if let Deadline::Late(late_s) = missed {
            // Catching up (less late than the last late tick) is the last miss still.
            let catching_up = self.late_s.is_some_and(|last| late_s < last);
            self.late_s = Some(late_s);
            self.on_time = 0;
            if !catching_up {
                self.misses += 1;
            }
            if self.misses >= p.misses_to_trip.max(1) && !self.tripped {
                self.tripped = true;
                self.trips += 1;
            }
        } else {
            self.late_s = None;
            self.misses = 0;
            self.on_time = self.on_time.saturating_add(1);
            if self.tripped && self.on_time >= p.recover_after_ticks {
                self.tripped = false;
            }
        }
        if self.tripped {
            self.gain = (self.gain - 1.0 / f64::from(p.ramp_down_ticks.max(1))).max(0.0);
        } else if self.gain < 1.0 && missed == Deadline::OnTime {
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

    /// A 5 ms stall: the ticks owed run back to back, each less late than the last, and the
    /// watchdog sees one miss; a loop falling behind (each tick later) trips it at the third.
    #[test]
    fn a_stalls_catch_up_is_one_miss_and_falling_behind_trips() {
        let params = WatchdogParams { misses_to_trip: 3, ramp_down_ticks: 10, recover_after_ticks: 5, ramp_up_ticks: 10 };
        let mut w = Watchdog::new(params);
        for _ in 0..3 {
            w.update(Deadline::OnTime);
            // Each catch-up tick takes 0.2 ms of its 1 ms period: 0.8 ms less late each.
            let gains: Vec<f64> = (0..7).map(|k| w.update(Deadline::Late(5e-3 - k as f64 * 0.8e-3))).collect();
            assert!(!w.tripped() && gains.iter().all(|g| *g == 1.0), "{gains:?}");
        }
        assert_eq!(w.trips, 0);
        // Each tick 0.3 ms later than the last: the third trips it.
        w.update(Deadline::OnTime);
        let late: Vec<bool> = (0..3).map(|k| {
            w.update(Deadline::Late(1e-3 + k as f64 * 0.3e-3));
            w.tripped()
        }).collect();
        assert_eq!(late, [false, false, true]);
        // A stall during the catch-up (later again) counts too.
        let mut w = Watchdog::new(params);
        for late_s in [5e-3, 4e-3, 6e-3, 5e-3, 7e-3] {
            w.update(Deadline::Late(late_s));
        }
        assert!(w.tripped());
        // A miss of unknown lateness always counts, as before.
        let mut w = Watchdog::new(params);
        (0..3).for_each(|_| {
            w.update(true);
        });
        assert!(w.tripped());
    }
}
