//! Guidance events: the ticks that cut too close to the pulp ([`crate::haptics::guidance`]),
//! gathered into events for `summary.json`, `replay.json` and the command's report. A session
//! gathers them from its log records, a replay from its own ticks: the same ticks give the same
//! events.
use serde::{Deserialize, Serialize};

use crate::haptics::guidance::{GuidanceParams, FLAG_PULP_EXPOSED, FLAG_THIN_DENTIN};

/// Flagged ticks of one kind closer than this (s) belong to one event: a cut pauses between
/// strokes for a few ticks, a new approach takes longer.
pub const EVENT_GAP_S: f64 = 0.25;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GuidanceKind {
    /// A cut left less dentin over the pulp than the threshold.
    ThinDentin,
    /// A cut reached into the pulp.
    PulpExposure,
}

impl GuidanceKind {
    fn of(flags: u32) -> Option<Self> {
        if flags & FLAG_PULP_EXPOSED != 0 {
            Some(GuidanceKind::PulpExposure)
        } else if flags & FLAG_THIN_DENTIN != 0 {
            Some(GuidanceKind::ThinDentin)
        } else {
            None
        }
    }
}

/// Consecutive flagged ticks of one kind.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GuidanceEvent {
    pub kind: GuidanceKind,
    /// The first flagged tick and its session time.
    pub tick: u64,
    pub t_s: f64,
    pub last_tick: u64,
    /// The thinnest remaining dentin over the event's ticks (mm; negative: how deep into the pulp).
    pub min_remaining_dentin_mm: f64,
}

/// What guidance saw over a session or replay.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct GuidanceReport {
    /// The threshold (mm); 0 when guidance was off.
    pub thin_dentin_mm: f64,
    /// Thinnest dentin a cut left over the pulp (mm; negative into it), over the ticks that cut
    /// within the field's reach; `None` when no cut came that close.
    pub min_remaining_dentin_mm: Option<f64>,
    pub pulp_exposed: bool,
    pub thin_dentin_events: u64,
    pub pulp_exposure_events: u64,
    pub events: Vec<GuidanceEvent>,
}

/// Gathers a [`GuidanceReport`] tick by tick.
#[derive(Clone, Debug)]
pub struct GuidanceTracker {
    report: GuidanceReport,
    /// [`EVENT_GAP_S`] in ticks.
    gap_ticks: u64,
}

impl GuidanceTracker {
    pub fn new(params: &GuidanceParams, period_s: f64) -> Self {
        let gap_ticks = if period_s > 0.0 { (EVENT_GAP_S / period_s).round() as u64 } else { 0 };
        GuidanceTracker { report: GuidanceReport { thin_dentin_mm: params.thin_dentin_mm, ..GuidanceReport::default() }, gap_ticks }
    }

    /// Adds one tick: its guidance flags, clearance (mm) and whether it cut.
    pub fn push(&mut self, tick: u64, t_s: f64, flags: u32, clearance_mm: f64, cut: bool) {
        let r = &mut self.report;
        if cut && clearance_mm.is_finite() {
            r.min_remaining_dentin_mm = Some(r.min_remaining_dentin_mm.map_or(clearance_mm, |m| m.min(clearance_mm)));
        }
        let Some(kind) = GuidanceKind::of(flags) else { return };
        match r.events.iter_mut().rev().find(|e| e.kind == kind) {
            Some(e) if tick.saturating_sub(e.last_tick) <= self.gap_ticks => {
                e.last_tick = tick;
                e.min_remaining_dentin_mm = e.min_remaining_dentin_mm.min(clearance_mm);
            }
            _ => {
                r.events.push(GuidanceEvent { kind, tick, t_s, last_tick: tick, min_remaining_dentin_mm: clearance_mm });
                match kind {
                    GuidanceKind::ThinDentin => r.thin_dentin_events += 1,
                    GuidanceKind::PulpExposure => {
                        r.pulp_exposure_events += 1;
                        r.pulp_exposed = true;
                    }
                }
            }
        }
    }

    pub fn report(&self) -> &GuidanceReport {
        &self.report
    }

    pub fn finish(self) -> GuidanceReport {
        self.report
    }
}

impl GuidanceReport {
    /// The report as lines for a terminal (the same for a session and its replay).
    pub fn lines(&self) -> Vec<String> {
        if self.thin_dentin_mm <= 0.0 {
            return vec!["guidance: off (no pulp, or a threshold of 0)".into()];
        }
        let mut lines = vec![match self.min_remaining_dentin_mm {
            Some(d) if d < 0.0 => format!("guidance: the cut reached {:.3} mm into the pulp (threshold {} mm)", -d, self.thin_dentin_mm),
            Some(d) => format!("guidance: thinnest dentin left over the pulp {d:.3} mm (threshold {} mm)", self.thin_dentin_mm),
            None => format!("guidance: no cut came within reach of the pulp (threshold {} mm)", self.thin_dentin_mm),
        }];
        for e in &self.events {
            let what = match e.kind {
                GuidanceKind::ThinDentin => format!("thin dentin, {:.3} mm left", e.min_remaining_dentin_mm),
                GuidanceKind::PulpExposure => format!("PULP EXPOSED, {:.3} mm deep", -e.min_remaining_dentin_mm),
            };
            lines.push(format!("  tick {:>7} ({:>8.3} s) to tick {:>7}: {what}", e.tick, e.t_s, e.last_tick));
        }
        lines
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flagged_ticks_within_the_gap_make_one_event_and_a_later_approach_another() {
        let params = GuidanceParams::default();
        let mut t = GuidanceTracker::new(&params, 0.001);
        let tick = |t: &mut GuidanceTracker, k: u64, flags: u32, c: f64| t.push(k, k as f64 * 0.001, flags, c, true);
        tick(&mut t, 10, 0, 0.9);
        tick(&mut t, 11, FLAG_THIN_DENTIN, 0.45);
        tick(&mut t, 200, FLAG_THIN_DENTIN, 0.30); // 189 ticks later: within 250 ms
        tick(&mut t, 600, FLAG_THIN_DENTIN, 0.40); // 400 ticks later: a new event
        tick(&mut t, 601, FLAG_PULP_EXPOSED, -0.05);
        // Not cutting: the clearance is no remaining dentin.
        t.push(602, 0.602, 0, -0.5, false);
        let r = t.finish();
        assert_eq!((r.thin_dentin_events, r.pulp_exposure_events, r.pulp_exposed), (2, 1, true));
        assert_eq!(r.min_remaining_dentin_mm, Some(-0.05));
        let e = &r.events[0];
        assert_eq!((e.kind, e.tick, e.last_tick, e.min_remaining_dentin_mm), (GuidanceKind::ThinDentin, 11, 200, 0.30));
        assert_eq!((r.events[1].tick, r.events[2].kind), (600, GuidanceKind::PulpExposure));
        let lines = r.lines();
        assert!(lines[0].contains("0.050 mm into the pulp") && lines.len() == 4, "{lines:?}");
    }
}
