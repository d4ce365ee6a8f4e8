//! A tool path played back as a device: the CSV of the preparation issue (header, then
//! `t,x,y,z,qw,qx,qy,qz` with optional `rpm` and `cut`), interpolated between rows
//! (lerp for position and speed, slerp for orientation, the earlier row's pedal).
use std::path::Path;

use glam::{DAffine3, DQuat, DVec3};

use crate::error::{Error, Result};
use crate::{Device, DeviceState, Fault, BUTTON_CUT};

/// Handpiece speed assumed when the path has no `rpm` column (an electric handpiece under load,
/// REFERENCE.md "Devices").
pub const DEFAULT_RPM: f64 = 200_000.0;

/// One row of a tool path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathRow {
    pub t: f64,
    pub position: DVec3,
    pub rotation: DQuat,
    pub rpm: f64,
    pub cut: bool,
}

/// A scripted tool path; `send_force` only records the last force (the path ignores it).
#[derive(Clone, Debug)]
pub struct ScriptedPath {
    rows: Vec<PathRow>,
    name: String,
    /// The last force and torque the session sent, for tests and displays.
    pub last_force: (DVec3, DVec3),
}

const REQUIRED: [&str; 8] = ["t", "x", "y", "z", "qw", "qx", "qy", "qz"];

impl ScriptedPath {
    pub fn from_rows(rows: Vec<PathRow>, name: impl Into<String>) -> Result<Self> {
        let name = name.into();
        if rows.is_empty() {
            return Err(Error::Invalid { what: name, message: "the path has no rows".into() });
        }
        for (i, w) in rows.windows(2).enumerate() {
            if !(w[1].t > w[0].t) {
                return Err(Error::Path {
                    source_name: name,
                    row: i + 2,
                    column: "t".into(),
                    message: format!("{} s does not come after {} s", w[1].t, w[0].t),
                });
            }
        }
        Ok(ScriptedPath { rows, name, last_force: (DVec3::ZERO, DVec3::ZERO) })
    }

    pub fn read(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| Error::File { path: path.to_owned(), message: e.to_string() })?;
        Self::parse(&text, &path.display().to_string())
    }

    /// Parses the CSV text; errors name the data row (from 1) and the column.
    pub fn parse(text: &str, source_name: &str) -> Result<Self> {
        let path_err = |row: usize, column: &str, message: String| Error::Path {
            source_name: source_name.into(),
            row,
            column: column.into(),
            message,
        };
        let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty() && !l.starts_with('#'));
        let Some((_, header)) = lines.next() else {
            return Err(path_err(0, "", "empty file, expected a header t,x,y,z,qw,qx,qy,qz[,rpm][,cut]".into()));
        };
        let columns: Vec<String> = header.split(',').map(|c| c.trim().to_ascii_lowercase()).collect();
        let find = |c: &str| columns.iter().position(|h| h == c);
        let mut index = [0usize; 8];
        for (k, c) in REQUIRED.iter().enumerate() {
            index[k] = find(c).ok_or_else(|| path_err(0, c, format!("missing from the header '{header}'")))?;
        }
        for c in &columns {
            if !REQUIRED.contains(&c.as_str()) && c != "rpm" && c != "cut" {
                return Err(path_err(0, c, "unknown column (expected t,x,y,z,qw,qx,qy,qz,rpm,cut)".into()));
            }
        }
        let (rpm_col, cut_col) = (find("rpm"), find("cut"));
        let mut rows = Vec::new();
        for (row, (_, line)) in lines.enumerate().map(|(i, l)| (i + 1, l)) {
            let fields: Vec<&str> = line.split(',').map(str::trim).collect();
            if fields.len() != columns.len() {
                return Err(path_err(row, "", format!("{} fields, the header has {}", fields.len(), columns.len())));
            }
            let num = |col: usize| -> Result<f64> {
                let name = &columns[col];
                let v: f64 = fields[col]
                    .parse()
                    .map_err(|_| path_err(row, name, format!("'{}' is not a number", fields[col])))?;
                if !v.is_finite() {
                    return Err(path_err(row, name, format!("{v} is not finite")));
                }
                Ok(v)
            };
            let v: Vec<f64> = index.iter().map(|&c| num(c)).collect::<Result<_>>()?;
            let q = DQuat::from_xyzw(v[5], v[6], v[7], v[4]);
            let len = q.length();
            if (len - 1.0).abs() > 1e-3 {
                return Err(path_err(row, "qw", format!("quaternion length {len:.6}, expected a unit quaternion")));
            }
            let rpm = match rpm_col {
                Some(c) => {
                    let r = num(c)?;
                    if r < 0.0 {
                        return Err(path_err(row, "rpm", format!("{r}, expected >= 0")));
                    }
                    r
                }
                None => DEFAULT_RPM,
            };
            let cut = match cut_col {
                Some(c) => match fields[c] {
                    "0" => false,
                    "1" => true,
                    other => return Err(path_err(row, "cut", format!("'{other}', expected 0 or 1"))),
                },
                None => false,
            };
            if let Some(prev) = rows.last().map(|r: &PathRow| r.t) {
                if !(v[0] > prev) {
                    return Err(path_err(row, "t", format!("{} s does not come after {prev} s", v[0])));
                }
            }
            rows.push(PathRow { t: v[0], position: DVec3::new(v[1], v[2], v[3]), rotation: q / len, rpm, cut });
        }
        Self::from_rows(rows, source_name)
    }

    pub fn rows(&self) -> &[PathRow] {
        &self.rows
    }

    pub fn duration(&self) -> f64 {
        self.rows.last().map_or(0.0, |r| r.t)
    }

    /// The interpolated state at `t` (held at the ends). Allocation-free.
    pub fn state_at(&self, t: f64) -> DeviceState {
        let rows = &self.rows;
        let i = rows.partition_point(|r| r.t <= t);
        let (a, b) = match i {
            0 => (rows[0], rows[0]),
            n if n >= rows.len() => (rows[rows.len() - 1], rows[rows.len() - 1]),
            n => (rows[n - 1], rows[n]),
        };
        let s = if b.t > a.t { ((t - a.t) / (b.t - a.t)).clamp(0.0, 1.0) } else { 0.0 };
        let rotation = a.rotation.slerp(b.rotation, s);
        let position = a.position.lerp(b.position, s);
        DeviceState {
            pose: DAffine3::from_rotation_translation(rotation, position),
            buttons: if a.cut { BUTTON_CUT } else { 0 },
            rpm: a.rpm + (b.rpm - a.rpm) * s,
        }
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
