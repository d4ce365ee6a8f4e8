//! Tool paths: timed burr poses read from CSV (`t,x,y,z,qw,qx,qy,qz`, optional `rpm` and `cut`).
//!
//! Seconds and millimetres; the unit quaternion takes the burr's frame (tip at the origin, axis
//! +Z toward the handpiece) into the scan's frame. A quaternion whose norm is off by more than
//! `QUAT_TOLERANCE` (1e-3) is refused rather than silently normalised: it usually means columns
//! were swapped or truncated; within the tolerance it is normalised. Errors name the row (1 = the
//! first data row; the header is row 0) and the column.
use glam::{DAffine3, DQuat, DVec3};

use crate::error::{invalid, Result};

pub const QUAT_TOLERANCE: f64 = 1e-3;

/// Bounds between consecutive samples beyond which a row is a jump, not a motion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathLimits {
    pub max_step_mm: f64,
    pub max_step_deg: f64,
}

impl Default for PathLimits {
    /// 5 mm or 45° between samples: far beyond any hand motion at haptic or planning rates.
    fn default() -> Self {
        PathLimits { max_step_mm: 5.0, max_step_deg: 45.0 }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathSample {
    pub t: f64,
    pub pose: DAffine3,
    pub rpm: Option<f64>,
    /// Whether the burr cuts on the way to this sample from the previous one.
    pub cut: bool,
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct ToolPath {
    pub samples: Vec<PathSample>,
}

const REQUIRED: [&str; 8] = ["t", "x", "y", "z", "qw", "qx", "qy", "qz"];

impl ToolPath {
    pub fn parse_csv(text: &str, source: &str, limits: PathLimits) -> Result<Self> {
        let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
        let Some((_, header)) = lines.next() else {
            return Err(invalid(source, "is empty, expected a header t,x,y,z,qw,qx,qy,qz[,rpm][,cut]"));
        };
        let names: Vec<String> = header.split(',').map(|s| s.trim().to_ascii_lowercase()).collect();
        let col = |n: &str| names.iter().position(|c| c == n);
        let mut idx = [0usize; 8];
        for (i, n) in REQUIRED.iter().enumerate() {
            idx[i] = col(n).ok_or_else(|| invalid(source, format!("header has no column '{n}' (expected t,x,y,z,qw,qx,qy,qz[,rpm][,cut])")))?;
        }
        for n in &names {
            if !REQUIRED.contains(&n.as_str()) && n != "rpm" && n != "cut" {
                return Err(invalid(source, format!("header column '{n}' is not known")));
            }
        }
        let (rpm_col, cut_col) = (col("rpm"), col("cut"));
        let mut samples: Vec<PathSample> = Vec::new();
        for (row, (_, line)) in lines.enumerate() {
            let row = row + 1;
            let cells: Vec<&str> = line.split(',').map(str::trim).collect();
            let where_ = |c: &str| format!("{source} row {row} column {c}");
            let number = |c: usize| -> Result<f64> {
                let name = &names[c];
                let cell = cells.get(c).ok_or_else(|| invalid(where_(name), "is missing"))?;
                let v: f64 = cell.parse().map_err(|_| invalid(where_(name), format!("'{cell}' is not a number")))?;
                if !v.is_finite() {
                    return Err(invalid(where_(name), format!("is {v}, expected a finite number")));
                }
                Ok(v)
            };
            if cells.len() != names.len() {
                return Err(invalid(format!("{source} row {row}"), format!("has {} cells, the header {}", cells.len(), names.len())));
            }
            let v: Vec<f64> = idx.iter().map(|&c| number(c)).collect::<Result<_>>()?;
            let (t, pos) = (v[0], DVec3::new(v[1], v[2], v[3]));
            let q = DQuat::from_xyzw(v[5], v[6], v[7], v[4]);
            let norm = q.length();
            if (norm - 1.0).abs() > QUAT_TOLERANCE {
                return Err(invalid(where_("qw,qx,qy,qz"), format!("quaternion norm is {norm:.6}, expected 1 within {QUAT_TOLERANCE}")));
            }
            let q = q / norm;
            let rpm = rpm_col.map(&number).transpose()?;
            if let Some(r) = rpm {
                if r < 0.0 {
                    return Err(invalid(where_("rpm"), format!("is {r}, expected >= 0")));
                }
            }
            let cut = match cut_col.map(&number).transpose()? {
                None => true,
                Some(c) if c == 0.0 => false,
                Some(c) if c == 1.0 => true,
                Some(c) => return Err(invalid(where_("cut"), format!("is {c}, expected 0 or 1"))),
            };
            if let Some(prev) = samples.last() {
                if t < prev.t {
                    return Err(invalid(where_("t"), format!("time goes backwards ({t} s after {} s)", prev.t)));
                }
                let step = (pos - prev.pose.translation).length();
                if step > limits.max_step_mm {
                    return Err(invalid(where_("x,y,z"), format!("jumps {step:.3} mm from the previous row (limit {} mm)", limits.max_step_mm)));
                }
                let prev_q = DQuat::from_mat3(&prev.pose.matrix3);
                let turn = prev_q.angle_between(q).to_degrees();
                if turn > limits.max_step_deg {
                    return Err(invalid(where_("qw,qx,qy,qz"), format!("turns {turn:.1}° from the previous row (limit {}°)", limits.max_step_deg)));
                }
            }
            samples.push(PathSample { t, pose: DAffine3::from_rotation_translation(q, pos), rpm, cut });
        }
        if samples.is_empty() {
            return Err(invalid(source, "has a header but no rows"));
        }
        Ok(ToolPath { samples })
    }

    pub fn read(path: &std::path::Path, limits: PathLimits) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|e| crate::Error::File { path: path.to_owned(), message: e.to_string() })?;
        Self::parse_csv(&text, &path.display().to_string(), limits)
    }

    pub fn duration_s(&self) -> f64 {
        match (self.samples.first(), self.samples.last()) {
            (Some(a), Some(b)) => b.t - a.t,
            _ => 0.0,
        }
    }
}
