//! A tool path played back as a device: the CSV of the preparation issue (header, then
//! `t,x,y,z,qw,qx,qy,qz` with optional `rpm` and `cut`), read and checked by [`ToolPath`] as
//! `dentsim prepare` reads it, interpolated between rows by [`ToolPath::state_at`].
use std::path::Path;

use glam::DVec3;

use crate::error::Result;
use crate::path::{PathLimits, ToolPath};
use crate::{Device, DeviceState, Fault, BUTTON_CUT};

/// Handpiece speed assumed where a path or hand gives none (an electric handpiece under load,
/// REFERENCE.md "Devices"); the tissue table's removal rates are quoted at this speed.
pub const DEFAULT_RPM: f64 = 200_000.0;

/// A scripted tool path; `send_force` only records the last force (the path ignores it).
#[derive(Clone, Debug)]
pub struct ScriptedPath {
    path: ToolPath,
    name: String,
    /// The last force and torque the session sent, for tests and displays.
    pub last_force: (DVec3, DVec3),
}

impl ScriptedPath {
    /// Plays `path` (already checked by its constructor).
    pub fn new(path: ToolPath, name: impl Into<String>) -> Self {
        ScriptedPath { path, name: name.into(), last_force: (DVec3::ZERO, DVec3::ZERO) }
    }

    pub fn read(path: &Path) -> Result<Self> {
        Ok(Self::new(ToolPath::read(path, PathLimits::default())?, path.display().to_string()))
    }

    /// Parses the CSV text; errors name the source, the data row (from 1) and the column.
    pub fn parse(text: &str, source_name: &str) -> Result<Self> {
        Ok(Self::new(ToolPath::parse_csv(text, source_name, PathLimits::default())?, source_name))
    }

    pub fn path(&self) -> &ToolPath {
        &self.path
    }

    /// Session time of the last row (s): the device is finished after it.
    pub fn duration(&self) -> f64 {
        self.path.samples.last().map_or(0.0, |r| r.t)
    }

    /// The interpolated state at `t` (held at the ends); without an `rpm` column the handpiece
    /// runs at [`DEFAULT_RPM`]. Allocation-free.
    pub fn state_at(&self, t: f64) -> DeviceState {
        let s = self.path.state_at(t);
        DeviceState { pose: s.pose, buttons: if s.cut { BUTTON_CUT } else { 0 }, rpm: s.rpm.unwrap_or(DEFAULT_RPM) }
    }
}

impl Device for ScriptedPath {
    fn poll(&mut self, t: f64) -> std::result::Result<DeviceState, Fault> {
        Ok(self.state_at(t))
    }

    fn send_force(&mut self, force: DVec3, torque: DVec3) {
        self.last_force = (force, torque);
    }

    fn finished(&self, t: f64) -> bool {
        t > self.duration()
    }

    fn name(&self) -> &str {
        &self.name
    }
}

#[cfg(test)]
mod tests {
    use glam::DQuat;

    use super::*;

    const CSV: &str = "t,x,y,z,qw,qx,qy,qz,rpm,cut\n0,0,0,0,1,0,0,0,0,0\n1,2,0,0,0.7071067811865476,0.7071067811865476,0,0,100000,1\n";

    #[test]
    fn interpolates_position_rotation_and_speed() {
        let p = ScriptedPath::parse(CSV, "p.csv").unwrap();
        let s = p.state_at(0.5);
        assert!((s.pose.translation - DVec3::new(1.0, 0.0, 0.0)).length() < 1e-12);
        let (axis, angle) = DQuat::from_affine3(&s.pose).to_axis_angle();
        assert!((angle - std::f64::consts::FRAC_PI_4).abs() < 1e-9 && (axis - DVec3::X).length() < 1e-9);
        assert_eq!(s.rpm, 50_000.0);
        assert_eq!(s.buttons, 0);
        assert_eq!(p.state_at(7.0).buttons, BUTTON_CUT);
        assert!(p.finished(1.01) && !p.finished(0.99));
    }

    #[test]
    fn errors_name_row_and_column() {
        let e = |text: &str| ScriptedPath::parse(text, "p.csv").unwrap_err().to_string();
        let m = e("t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n1,0,abc,0,1,0,0,0\n");
        assert!(m.contains("row 2") && m.contains("'y'") && m.contains("abc"), "{m}");
        let m = e("t,x,y,z,qw,qx,qy,qz\n0,0,0,0,2,0,0,0\n");
        assert!(m.contains("row 1") && m.contains("unit quaternion"), "{m}");
        let m = e("t,x,y,z,qw,qx,qy,qz\n1,0,0,0,1,0,0,0\n0.5,0,0,0,1,0,0,0\n");
        assert!(m.contains("row 2") && m.contains("'t'"), "{m}");
        let m = e("t,x,y,z,qw,qx,qy\n");
        assert!(m.contains("qz"), "{m}");
        let m = e("t,x,y,z,qw,qx,qy,qz,cut\n0,0,0,0,1,0,0,0,2\n");
        assert!(m.contains("'cut'"), "{m}");
        let m = e("t,x,y,z,qw,qx,qy,qz\n0,NaN,0,0,1,0,0,0\n");
        assert!(m.contains("'x'"), "{m}");
    }
}
