//! A SpaceMouse is a rate device: deflecting the cap moves the tool at a speed. This maps raw
//! counts to a 6-DOF tool pose: dead zone, gains, axis map, integration over time, kept inside
//! a workspace sphere around the start, and buttons to actions.
//!
//! Defaults (`spacemouse:` with no keys): dead zone 15 counts of ±350; full deflection moves the
//! tip 10 mm/s and turns it 45°/s (fine enough for a 0.1 mm cut at 62 reports/s); axis map
//! `x,-y,-z`, the HID axes (x right, y toward the user, z pushed down) to the scan frame (z up,
//! occlusal), as spacenavd swaps them; workspace radius 15 mm; button 1 (left) holds cut mode,
//! button 2 (right) puts the tool back at the start.
use glam::{DAffine3, DQuat, DVec3};

use super::reports::SpaceMouseRaw;
use crate::BUTTON_CUT;

/// Counts at full deflection (Blender scales by 1/350).
pub const FULL_SCALE: f64 = 350.0;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RateMap {
    /// Counts below this (per axis) are noise: zero.
    pub dead_zone: f64,
    /// Tip speed at full deflection (mm/s).
    pub translate_mm_s: f64,
    /// Turn rate at full deflection (°/s).
    pub rotate_deg_s: f64,
    /// World axis i takes HID axis `axes[i].0` times `axes[i].1` (translation and rotation alike).
    pub axes: [(usize, f64); 3],
    /// The tip stays within this distance of the start (mm).
    pub workspace_mm: f64,
    /// Button bits (HID report 3) that hold cut mode, and that recentre.
    pub cut_buttons: u32,
    pub recentre_buttons: u32,
}

impl Default for RateMap {
    fn default() -> Self {
        RateMap {
            dead_zone: 15.0,
            translate_mm_s: 10.0,
            rotate_deg_s: 45.0,
            axes: [(0, 1.0), (1, -1.0), (2, -1.0)],
            workspace_mm: 15.0,
            cut_buttons: 1,
            recentre_buttons: 2,
        }
    }
}

/// Parses an axis map such as `x,-y,-z` or `y,x,-z`.
pub fn parse_axes(text: &str) -> Option<[(usize, f64); 3]> {
    let parts: Vec<(usize, f64)> = text
        .split(',')
        .map(|p| {
            let p = p.trim();
            let (sign, axis) = match p.strip_prefix('-') {
                Some(a) => (-1.0, a),
                None => (1.0, p.strip_prefix('+').unwrap_or(p)),
            };
            let i = ["x", "y", "z"].iter().position(|n| n.eq_ignore_ascii_case(axis))?;
            Some((i, sign))
        })
        .collect::<Option<_>>()?;
    let axes: [(usize, f64); 3] = parts.try_into().ok()?;
    let mut seen = [false; 3];
    axes.iter().for_each(|(i, _)| seen[*i] = true);
    seen.iter().all(|s| *s).then_some(axes)
}

impl RateMap {
    fn axis(&self, raw: [i16; 3]) -> DVec3 {
        let v = |i: usize| {
            let (src, sign) = self.axes[i];
            let c = f64::from(raw[src]);
            // Past the dead zone the speed starts from zero, so motion does not jump.
            let c = (c.abs() - self.dead_zone).max(0.0).copysign(c);
            sign * (c / (FULL_SCALE - self.dead_zone)).clamp(-1.0, 1.0)
        };
        DVec3::new(v(0), v(1), v(2))
    }

    /// Tip velocity (mm/s) and angular velocity (rad/s, world frame) for these counts.
    pub fn velocity(&self, raw: &SpaceMouseRaw) -> (DVec3, DVec3) {
        (self.axis(raw.translation) * self.translate_mm_s, self.axis(raw.rotation) * self.rotate_deg_s.to_radians())
    }

    /// The pose after `dt` s at these counts, from `pose`, kept within the workspace around
    /// `start`; the recentre buttons put it back at `start`. Allocation-free.
    pub fn step(&self, pose: DAffine3, start: DAffine3, raw: &SpaceMouseRaw, dt: f64) -> DAffine3 {
        if raw.buttons & self.recentre_buttons != 0 {
            return start;
        }
        let (v, w) = self.velocity(raw);
        let mut tip = pose.translation + v * dt;
        let off = tip - start.translation;
        if off.length() > self.workspace_mm {
            tip = start.translation + off.normalize() * self.workspace_mm;
        }
        let turn = if w.length() > 0.0 { DQuat::from_scaled_axis(w * dt) } else { DQuat::IDENTITY };
        let rot = (turn * DQuat::from_mat3(&pose.matrix3.into())).normalize();
        DAffine3::from_rotation_translation(rot, tip)
    }

    pub fn buttons(&self, raw: &SpaceMouseRaw) -> u32 {
        if raw.buttons & self.cut_buttons != 0 { BUTTON_CUT } else { 0 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hid::reports::apply_spacemouse_report;

    #[test]
    fn recorded_reports_move_the_tool_as_documented() {
        let map = RateMap::default();
        let start = DAffine3::from_translation(DVec3::new(1.0, 2.0, 10.0));
        // The newer layout: cap pushed down by 300 counts → tool goes down (−z) at
        // (300−15)/(350−15) of 10 mm/s; rx and rz of 5 counts are inside the dead zone.
        let mut raw = SpaceMouseRaw::default();
        apply_spacemouse_report(&mut raw, &[0x01, 0, 0, 0, 0, 0x2c, 0x01, 0x05, 0, 0, 0, 0xfb, 0xff]);
        let (v, w) = map.velocity(&raw);
        assert!((v - DVec3::new(0.0, 0.0, -10.0 * 285.0 / 335.0)).length() < 1e-12, "{v}");
        assert_eq!(w, DVec3::ZERO);
        let mut pose = start;
        for _ in 0..1000 {
            pose = map.step(pose, start, &raw, 1e-3);
        }
        assert!((pose.translation.z - (10.0 - 10.0 * 285.0 / 335.0)).abs() < 1e-9);
        // Held far longer, the tip stops at the workspace's edge.
        for _ in 0..10_000 {
            pose = map.step(pose, start, &raw, 1e-3);
        }
        assert!(((pose.translation - start.translation).length() - 15.0).abs() < 1e-9);
        // The older layout: rz = −350 (full twist) → +45°/s about world z (axis map −z).
        let mut raw = SpaceMouseRaw::default();
        apply_spacemouse_report(&mut raw, &[0x02, 0, 0, 0, 0, 0xa2, 0xfe]);
        let turned = map.step(start, start, &raw, 1.0);
        let (axis, angle) = DQuat::from_mat3(&turned.matrix3.into()).to_axis_angle();
        assert!((angle - 45f64.to_radians()).abs() < 1e-9 && (axis - DVec3::Z).length() < 1e-9, "{axis} {angle}");
        // Buttons: left holds cut, right recentres.
        apply_spacemouse_report(&mut raw, &[0x03, 0x01, 0x00]);
        assert_eq!(map.buttons(&raw), BUTTON_CUT);
        apply_spacemouse_report(&mut raw, &[0x03, 0x02, 0x00]);
        assert_eq!((map.buttons(&raw), map.step(turned, start, &raw, 1e-3)), (0, start));
    }

    #[test]
    fn axis_maps_parse_and_bad_ones_are_refused() {
        assert_eq!(parse_axes("x,-y,-z"), Some(RateMap::default().axes));
        assert_eq!(parse_axes("y,+x,-z"), Some([(1, 1.0), (0, 1.0), (2, -1.0)]));
        assert_eq!(parse_axes("x,x,z"), None);
        assert_eq!(parse_axes("x,y"), None);
        assert_eq!(parse_axes("x,y,w"), None);
    }
}
