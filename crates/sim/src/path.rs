//! Tool paths: timed burr poses read from CSV (`t,x,y,z,qw,qx,qy,qz`, optional `rpm` and `cut`).
//!
//! Seconds and millimetres; the unit quaternion takes the burr's frame (tip at the origin, axis
//! +Z toward the handpiece) into the scan's frame. A quaternion whose norm is off by more than
//! `QUAT_TOLERANCE` (1e-3) is refused rather than silently normalised: it usually means columns
//! were swapped or truncated; within the tolerance it is normalised. Errors name the row (1 = the
//! first data row; the header is row 0) and the column. The same checks apply to a path given as
//! a VTK polyline ([`ToolPath::from_polyline`]), whose errors name the point and the array.
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
            let rpm = rpm_col.map(&number).transpose()?;
            let cut = cut_col.map(&number).transpose()?;
            let field = |f: Field| match f {
                Field::Position => format!("{source} row {row} column x,y,z"),
                Field::Orientation => format!("{source} row {row} column qw,qx,qy,qz"),
                other => format!("{source} row {row} column {}", other.csv_column()),
            };
            push_sample(&mut samples, limits, &field, [v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7]], rpm, cut)?;
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

/// What a sample's value is, so an error can name it as its source calls it (a CSV column, a
/// VTK array).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Field {
    T,
    X,
    Y,
    Z,
    Qw,
    Qx,
    Qy,
    Qz,
    Rpm,
    Cut,
    /// The step between positions (jumps).
    Position,
    /// The quaternion as a whole (norm, turns).
    Orientation,
}

impl Field {
    const VALUES: [Field; 8] = [Field::T, Field::X, Field::Y, Field::Z, Field::Qw, Field::Qx, Field::Qy, Field::Qz];

    fn csv_column(self) -> &'static str {
        match self {
            Field::T => "t",
            Field::X => "x",
            Field::Y => "y",
            Field::Z => "z",
            Field::Qw => "qw",
            Field::Qx => "qx",
            Field::Qy => "qy",
            Field::Qz => "qz",
            Field::Rpm => "rpm",
            Field::Cut => "cut",
            Field::Position => "x,y,z",
            Field::Orientation => "qw,qx,qy,qz",
        }
    }
}

/// Checks one sample `[t, x, y, z, qw, qx, qy, qz]` against the previous ones and appends it;
/// `at(field)` says where the value came from (row and column, point and array).
fn push_sample(
    samples: &mut Vec<PathSample>,
    limits: PathLimits,
    at: &dyn Fn(Field) -> String,
    v: [f64; 8],
    rpm: Option<f64>,
    cut: Option<f64>,
) -> Result<()> {
    for (value, field) in v.iter().zip(Field::VALUES).chain(rpm.iter().map(|r| (r, Field::Rpm))).chain(cut.iter().map(|c| (c, Field::Cut))) {
        if !value.is_finite() {
            return Err(invalid(at(field), format!("is {value}, expected a finite number")));
        }
    }
    let (t, pos) = (v[0], DVec3::new(v[1], v[2], v[3]));
    let q = DQuat::from_xyzw(v[5], v[6], v[7], v[4]);
    let norm = q.length();
    if (norm - 1.0).abs() > QUAT_TOLERANCE {
        return Err(invalid(at(Field::Orientation), format!("quaternion norm is {norm:.6}, expected 1 within {QUAT_TOLERANCE}")));
    }
    let q = q / norm;
    if let Some(r) = rpm {
        if r < 0.0 {
            return Err(invalid(at(Field::Rpm), format!("is {r}, expected >= 0")));
        }
    }
    let cut = match cut {
        None => true,
        Some(c) if c == 0.0 => false,
        Some(c) if c == 1.0 => true,
        Some(c) => return Err(invalid(at(Field::Cut), format!("is {c}, expected 0 or 1"))),
    };
    if let Some(prev) = samples.last() {
        if t < prev.t {
            return Err(invalid(at(Field::T), format!("time goes backwards ({t} s after {} s)", prev.t)));
        }
        let step = (pos - prev.pose.translation).length();
        if step > limits.max_step_mm {
            return Err(invalid(at(Field::Position), format!("jumps {step:.3} mm from the previous row (limit {} mm)", limits.max_step_mm)));
        }
        let prev_q = DQuat::from_mat3(&prev.pose.matrix3);
        let turn = prev_q.angle_between(q).to_degrees();
        if turn > limits.max_step_deg {
            return Err(invalid(at(Field::Orientation), format!("turns {turn:.1}° from the previous row (limit {}°)", limits.max_step_deg)));
        }
    }
    samples.push(PathSample { t, pose: DAffine3::from_rotation_translation(q, pos), rpm, cut });
    Ok(())
}

/// A tool path as VTK holds it: a polyline's points in order with point arrays (ParaView's
/// "Dental Preparation" filter). Empty optional arrays are absent.
#[derive(Clone, Copy, Debug, Default)]
pub struct PolylineArrays<'a> {
    /// x, y, z per point (mm).
    pub points: &'a [f64],
    /// `Orientation`: w, x, y, z per point (unit quaternion, burr frame into the scan's).
    pub orientation: &'a [f64],
    /// `Time` (s); absent: points are one haptic tick (1 ms) apart.
    pub time: &'a [f64],
    /// `RPM`; absent: the caller's default.
    pub rpm: &'a [f64],
    /// `Cut` (0/1) on the way to each point from the previous; absent: every segment cuts.
    pub cut: &'a [f64],
}

/// Spacing of polyline points that carry no `Time` array (one haptic tick).
pub const POLYLINE_DEFAULT_DT_S: f64 = 1e-3;

impl ToolPath {
    /// A path from a polyline's arrays, checked as a CSV is; errors name the point (VTK's id,
    /// from 0) and the array, e.g. `tool path point 3 array Orientation: quaternion norm is …`.
    pub fn from_polyline(a: &PolylineArrays, source: &str, limits: PathLimits) -> Result<Self> {
        let n = a.points.len() / 3;
        if a.points.len() % 3 != 0 || n == 0 {
            return Err(invalid(format!("{source} points"), format!("{} coordinates, expected 3 per point and at least one point", a.points.len())));
        }
        let sized = |name: &str, values: &[f64], per: usize, required: bool| -> Result<()> {
            if (required || !values.is_empty()) && values.len() != per * n {
                return Err(invalid(format!("{source} array {name}"), format!("has {} values, expected {per} per point for {n} points", values.len())));
            }
            Ok(())
        };
        sized("Orientation", a.orientation, 4, true)?;
        sized("Time", a.time, 1, false)?;
        sized("RPM", a.rpm, 1, false)?;
        sized("Cut", a.cut, 1, false)?;
        let mut samples = Vec::with_capacity(n);
        for i in 0..n {
            let t = if a.time.is_empty() { i as f64 * POLYLINE_DEFAULT_DT_S } else { a.time[i] };
            let p = &a.points[3 * i..3 * i + 3];
            let q = &a.orientation[4 * i..4 * i + 4];
            let at = |f: Field| {
                let what = match f {
                    Field::T => "array Time".to_string(),
                    Field::X | Field::Y | Field::Z => format!("coordinate {}", f.csv_column()),
                    Field::Position => "position".to_string(),
                    Field::Qw | Field::Qx | Field::Qy | Field::Qz | Field::Orientation => "array Orientation".to_string(),
                    Field::Rpm => "array RPM".to_string(),
                    Field::Cut => "array Cut".to_string(),
                };
                format!("{source} point {i} {what}")
            };
            let rpm = a.rpm.get(i).copied();
            let cut = a.cut.get(i).copied();
            push_sample(&mut samples, limits, &at, [t, p[0], p[1], p[2], q[0], q[1], q[2], q[3]], rpm, cut)?;
        }
        Ok(ToolPath { samples })
    }
}
