//! Tool paths: timed burr poses, from a CSV (`t,x,y,z,qw,qx,qy,qz`, optional `rpm` and `cut`) or
//! a VTK polyline's arrays. One type and one set of checks for every user: the scripted device
//! (`dentsim session`), `dentsim prepare`, the demo and the plugin's polyline input, so a file
//! one of them accepts, all accept.
//!
//! Seconds and millimetres; the unit quaternion takes the burr's frame (tip at the origin, axis
//! +Z toward the handpiece) into the scan's frame. A quaternion whose norm is off by more than
//! [`QUAT_TOLERANCE`] is refused rather than silently normalised: it usually means columns were
//! swapped or truncated; within the tolerance it is normalised. Times strictly increase; every
//! value is finite; a row that jumps further than [`PathLimits`] allow is refused. Errors name
//! the source, the row (1 = the first data row; the header is row 0) and the column, or for a
//! polyline the point (VTK's id, from 0) and the array.
//!
//! Between samples the two users still read the `cut` and `rpm` flags differently, as they did
//! before they shared this type: a scripted device holds a sample's pedal until the next sample
//! ([`ToolPath::state_at`], pinned by devices' `interpolates_position_rotation_and_speed`), while
//! `prepare` cuts the segment *to* a sample whose flag is set ([`ToolPath::segments`], as its
//! documentation and users' files expect). Both readings live here, side by side, so one
//! decision can make them one.
use glam::{DAffine3, DQuat, DVec3};

use crate::error::{Error, Result};

/// How far a quaternion's norm may be from 1 before the row is refused.
pub const QUAT_TOLERANCE: f64 = 1e-3;

/// Largest tool path file read (bytes): about 2.5 million rows, 40 minutes sampled at 1 kHz.
pub const MAX_PATH_FILE_BYTES: u64 = 256 << 20;

/// Spacing of polyline points that carry no `Time` array (one haptic tick).
pub const POLYLINE_DEFAULT_DT_S: f64 = crate::HAPTIC_PERIOD_S;

/// What the CSV header must name, in the order of [`Field::VALUES`].
const REQUIRED: [&str; 8] = ["t", "x", "y", "z", "qw", "qx", "qy", "qz"];
const HEADER_HELP: &str = "t,x,y,z,qw,qx,qy,qz[,rpm][,cut]";

/// Bounds between consecutive samples beyond which a row is a jump, not a motion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathLimits {
    pub max_step_mm: f64,
    pub max_step_deg: f64,
}

impl Default for PathLimits {
    /// 5 mm between samples: far beyond any hand motion at haptic or planning rates. 120°: well
    /// short of the half turn at which the shorter arc between two orientations is ambiguous.
    fn default() -> Self {
        PathLimits { max_step_mm: 5.0, max_step_deg: 120.0 }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathSample {
    pub t: f64,
    pub pose: DAffine3,
    /// Handpiece speed; `None` when the path gives none (the user's default applies).
    pub rpm: Option<f64>,
    /// Pedal down (see the module notes for how devices and `prepare` read it between samples).
    pub cut: bool,
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct ToolPath {
    pub samples: Vec<PathSample>,
}

/// The path at one instant (see [`ToolPath::state_at`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathState {
    pub pose: DAffine3,
    pub rpm: Option<f64>,
    pub cut: bool,
}

/// Two consecutive samples and what the path does between them.
#[derive(Clone, Copy, Debug)]
pub struct Segment<'a> {
    /// The index of `from` in [`ToolPath::samples`].
    pub index: usize,
    pub from: &'a PathSample,
    pub to: &'a PathSample,
    /// Whether `prepare` cuts the segment: `to.cut` ("cut on the way to this sample").
    pub cut: bool,
    /// The handpiece speed `prepare` cuts the segment at: `to.rpm`.
    pub rpm: Option<f64>,
}

impl ToolPath {
    /// Parses CSV text; `source` (usually the file name) begins every error.
    pub fn parse_csv(text: &str, source: &str, limits: PathLimits) -> Result<Self> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let whole = |message: String| Error::Invalid { what: source.into(), message };
        let mut lines = text.lines().filter(|l| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
        let Some(header) = lines.next() else {
            return Err(whole(format!("is empty, expected a header {HEADER_HELP}")));
        };
        let names: Vec<String> = header.split(',').map(|s| s.trim().to_ascii_lowercase()).collect();
        let header_err = |message: String| Error::path(source, "header", message);
        for (i, n) in names.iter().enumerate() {
            if !REQUIRED.contains(&n.as_str()) && n != "rpm" && n != "cut" {
                return Err(header_err(format!("column '{n}' is not one of t,x,y,z,qw,qx,qy,qz,rpm,cut")));
            }
            if names[..i].contains(n) {
                return Err(header_err(format!("column '{n}' appears twice")));
            }
        }
        let col = |n: &str| names.iter().position(|c| c == n);
        let mut idx = [0usize; 8];
        for (i, n) in REQUIRED.iter().enumerate() {
            idx[i] = col(n).ok_or_else(|| header_err(format!("no column '{n}' (expected {HEADER_HELP})")))?;
        }
        let (rpm_col, cut_col) = (col("rpm"), col("cut"));
        let mut checker = Checker::new(limits);
        for (row, line) in lines.enumerate() {
            let row = row + 1;
            let cells: Vec<&str> = line.split(',').map(str::trim).collect();
            if cells.len() != names.len() {
                let message = format!("has {} cells, the header {}", cells.len(), names.len());
                return Err(Error::path(source, format!("row {row}"), message));
            }
            let at = |f: Field, message: String| Error::path(source, format!("row {row} column {}", f.csv_column()), message);
            let number = |c: usize, f: Field| -> Result<f64> {
                cells[c].parse().map_err(|_| at(f, format!("'{}' is '{}', not a number", f.csv_column(), cells[c])))
            };
            let mut v = [0.0; 8];
            for ((slot, &c), f) in v.iter_mut().zip(&idx).zip(Field::VALUES) {
                *slot = number(c, f)?;
            }
            let rpm = rpm_col.map(|c| number(c, Field::Rpm)).transpose()?;
            let cut = cut_col.map(|c| number(c, Field::Cut)).transpose()?;
            checker.push(&at, &Field::csv_column, v, rpm, cut)?;
        }
        if checker.samples.is_empty() {
            return Err(whole("has a header but no rows".into()));
        }
        Ok(ToolPath { samples: checker.samples })
    }

    /// Reads and parses a CSV file; errors name the file. At most [`MAX_PATH_FILE_BYTES`] are
    /// read: a path that names an endless stream (`/dev/zero`, a pipe) or a runaway export is
    /// refused rather than read into memory whole.
    pub fn read(path: &std::path::Path, limits: PathLimits) -> Result<Self> {
        use std::io::Read;
        let file_err = |message: String| Error::File { path: path.to_owned(), message };
        let file = std::fs::File::open(path).map_err(|e| file_err(e.to_string()))?;
        let mut bytes = Vec::new();
        file.take(MAX_PATH_FILE_BYTES + 1).read_to_end(&mut bytes).map_err(|e| file_err(e.to_string()))?;
        if bytes.len() as u64 > MAX_PATH_FILE_BYTES {
            return Err(file_err(format!("longer than {} MiB, the most a tool path may be", MAX_PATH_FILE_BYTES >> 20)));
        }
        let text = String::from_utf8(bytes).map_err(|e| file_err(format!("not UTF-8 text (byte {})", e.utf8_error().valid_up_to())))?;
        Self::parse_csv(&text, &path.display().to_string(), limits)
    }

    /// A path from a polyline's arrays, checked as a CSV is; errors name the point (VTK's id,
    /// from 0) and the array, e.g. `tool path point 3 array Orientation: quaternion norm is …`.
    pub fn from_polyline(a: &PolylineArrays, source: &str, limits: PathLimits) -> Result<Self> {
        let n = a.points.len() / 3;
        if a.points.len() % 3 != 0 || n == 0 {
            let message = format!("{} coordinates, expected 3 per point and at least one point", a.points.len());
            return Err(Error::path(source, "points", message));
        }
        let sized = |name: &str, values: &[f64], per: usize, required: bool| -> Result<()> {
            if (required || !values.is_empty()) && values.len() != per * n {
                let message = format!("has {} values, expected {per} per point for {n} points", values.len());
                return Err(Error::path(source, format!("array {name}"), message));
            }
            Ok(())
        };
        sized("Orientation", a.orientation, 4, true)?;
        sized("Time", a.time, 1, false)?;
        sized("RPM", a.rpm, 1, false)?;
        sized("Cut", a.cut, 1, false)?;
        let mut checker = Checker::new(limits);
        for i in 0..n {
            let t = if a.time.is_empty() { i as f64 * POLYLINE_DEFAULT_DT_S } else { a.time[i] };
            let p = &a.points[3 * i..3 * i + 3];
            let q = &a.orientation[4 * i..4 * i + 4];
            let at = |f: Field, message: String| {
                let what = match f {
                    Field::X | Field::Y | Field::Z => format!("coordinate {}", f.csv_column()),
                    Field::Position => "position".to_string(),
                    other => format!("array {}", other.vtk_name()),
                };
                Error::path(source, format!("point {i} {what}"), message)
            };
            let v = [t, p[0], p[1], p[2], q[0], q[1], q[2], q[3]];
            checker.push(&at, &Field::vtk_name, v, a.rpm.get(i).copied(), a.cut.get(i).copied())?;
        }
        Ok(ToolPath { samples: checker.samples })
    }

    /// A path from samples built in code (the demo's), checked as a CSV is; errors name the
    /// sample (from 0).
    pub fn from_samples(samples: &[PathSample], source: &str, limits: PathLimits) -> Result<Self> {
        if samples.is_empty() {
            return Err(Error::Invalid { what: source.into(), message: "has no samples".into() });
        }
        let mut checker = Checker::new(limits);
        for (i, s) in samples.iter().enumerate() {
            let q = DQuat::from_mat3(&s.pose.matrix3);
            let p = s.pose.translation;
            let v = [s.t, p.x, p.y, p.z, q.w, q.x, q.y, q.z];
            let at = |f: Field, message: String| Error::path(source, format!("sample {i} {}", f.csv_column()), message);
            checker.push(&at, &Field::csv_column, v, s.rpm, Some(if s.cut { 1.0 } else { 0.0 }))?;
        }
        Ok(ToolPath { samples: checker.samples })
    }

    /// Time from the first sample to the last (s).
    pub fn duration_s(&self) -> f64 {
        match (self.samples.first(), self.samples.last()) {
            (Some(a), Some(b)) => b.t - a.t,
            _ => 0.0,
        }
    }

    /// The pose (lerp of positions, slerp of orientations), speed (lerp) and pedal (held from
    /// the earlier sample) at `t` as a scripted device plays it, held at the ends. Allocation-free
    /// (a scripted device calls it per tick).
    pub fn state_at(&self, t: f64) -> PathState {
        let s = &self.samples;
        let Some(last) = s.last() else {
            return PathState { pose: DAffine3::IDENTITY, rpm: None, cut: false };
        };
        let i = s.partition_point(|r| r.t <= t);
        let (a, b) = match i {
            0 => (&s[0], &s[0]),
            n if n >= s.len() => (last, last),
            n => (&s[n - 1], &s[n]),
        };
        let f = if b.t > a.t { ((t - a.t) / (b.t - a.t)).clamp(0.0, 1.0) } else { 0.0 };
        let rotation = DQuat::from_mat3(&a.pose.matrix3).slerp(DQuat::from_mat3(&b.pose.matrix3), f);
        let position = a.pose.translation.lerp(b.pose.translation, f);
        let rpm = a.rpm.zip(b.rpm).map(|(x, y)| x + (y - x) * f);
        PathState { pose: DAffine3::from_rotation_translation(rotation, position), rpm, cut: a.cut }
    }

    /// Each pair of consecutive samples as `prepare` cuts it (see the module notes).
    pub fn segments(&self) -> impl Iterator<Item = Segment<'_>> {
        self.samples.windows(2).enumerate().map(|(index, w)| Segment { index, from: &w[0], to: &w[1], cut: w[1].cut, rpm: w[1].rpm })
    }
}

/// A tool path as VTK holds it: a polyline's points in order with point arrays (ParaView's
/// "Dental Preparation" filter). Empty optional arrays are absent.
#[derive(Clone, Copy, Debug, Default)]
pub struct PolylineArrays<'a> {
    /// x, y, z per point (mm).
    pub points: &'a [f64],
    /// `Orientation`: w, x, y, z per point (unit quaternion, burr frame into the scan's).
    pub orientation: &'a [f64],
    /// `Time` (s); absent: points are one haptic tick apart ([`POLYLINE_DEFAULT_DT_S`]).
    pub time: &'a [f64],
    /// `RPM`; absent: the user's default.
    pub rpm: &'a [f64],
    /// `Cut` (0/1) on the way to each point from the previous; absent: every segment cuts.
    pub cut: &'a [f64],
}

/// What a sample's value is, so an error can name it as its source calls it (a CSV column, a
/// VTK array).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Field {
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

    fn vtk_name(self) -> &'static str {
        match self {
            Field::T => "Time",
            Field::Qw | Field::Qx | Field::Qy | Field::Qz | Field::Orientation => "Orientation",
            Field::Rpm => "RPM",
            Field::Cut => "Cut",
            other => other.csv_column(),
        }
    }
}

/// Checks samples one by one against the rules and the previous sample.
struct Checker {
    limits: PathLimits,
    samples: Vec<PathSample>,
}

impl Checker {
    fn new(limits: PathLimits) -> Self {
        Checker { limits, samples: Vec::new() }
    }

    /// Checks one sample `[t, x, y, z, qw, qx, qy, qz]` and appends it. `at(field, message)`
    /// makes the error naming where the field came from (row and column, point and array);
    /// `name(field)` is the field's name there.
    fn push(
        &mut self,
        at: &dyn Fn(Field, String) -> Error,
        name: &dyn Fn(Field) -> &'static str,
        v: [f64; 8],
        rpm: Option<f64>,
        cut: Option<f64>,
    ) -> Result<()> {
        let values = v.iter().zip(Field::VALUES).chain(rpm.iter().map(|r| (r, Field::Rpm))).chain(cut.iter().map(|c| (c, Field::Cut)));
        for (value, field) in values {
            if !value.is_finite() {
                return Err(at(field, format!("'{}' is {value}, expected a finite number", name(field))));
            }
        }
        let (t, pos) = (v[0], DVec3::new(v[1], v[2], v[3]));
        let q = DQuat::from_xyzw(v[5], v[6], v[7], v[4]);
        let norm = q.length();
        if (norm - 1.0).abs() > QUAT_TOLERANCE {
            let message = format!("quaternion norm is {norm:.6}, expected a unit quaternion (norm 1 within {QUAT_TOLERANCE})");
            return Err(at(Field::Orientation, message));
        }
        let q = q / norm;
        if let Some(r) = rpm.filter(|r| *r < 0.0) {
            return Err(at(Field::Rpm, format!("'{}' is {r}, expected >= 0", name(Field::Rpm))));
        }
        let cut = match cut {
            None => true,
            Some(c) if c == 0.0 => false,
            Some(c) if c == 1.0 => true,
            Some(c) => return Err(at(Field::Cut, format!("'{}' is {c}, expected 0 or 1", name(Field::Cut)))),
        };
        if let Some(prev) = self.samples.last() {
            let when = name(Field::T);
            if t < prev.t {
                return Err(at(Field::T, format!("'{when}' goes backwards: {t} s after {} s", prev.t)));
            }
            if t == prev.t {
                return Err(at(Field::T, format!("'{when}' stands still at {t} s: times must increase")));
            }
            let step = (pos - prev.pose.translation).length();
            if step > self.limits.max_step_mm {
                let message = format!("jumps {step:.3} mm from the previous sample (limit {} mm)", self.limits.max_step_mm);
                return Err(at(Field::Position, message));
            }
            let turn = DQuat::from_mat3(&prev.pose.matrix3).angle_between(q).to_degrees();
            if turn > self.limits.max_step_deg {
                let message = format!("turns {turn:.1}° from the previous sample (limit {}°)", self.limits.max_step_deg);
                return Err(at(Field::Orientation, message));
            }
        }
        self.samples.push(PathSample { t, pose: DAffine3::from_rotation_translation(q, pos), rpm, cut });
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> std::result::Result<ToolPath, String> {
        ToolPath::parse_csv(text, "p.csv", PathLimits::default()).map_err(|e| e.to_string())
    }

    #[test]
    fn a_byte_order_mark_is_accepted() {
        let p = parse("\u{feff}t,x,y,z,qw,qx,qy,qz\n0,1,2,3,1,0,0,0\n").unwrap();
        assert_eq!(p.samples[0].pose.translation, DVec3::new(1.0, 2.0, 3.0));
    }

    #[test]
    fn a_duplicate_column_is_refused() {
        let e = parse("t,x,y,z,qw,qx,qy,qz,X\n0,1,2,3,1,0,0,0,4\n").unwrap_err();
        assert!(e.contains("p.csv header") && e.contains("'x' appears twice"), "{e}");
    }

    #[test]
    fn times_must_strictly_increase() {
        let e = parse("t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1,0,0,0\n0,0.1,0,0,1,0,0,0\n").unwrap_err();
        assert!(e.contains("row 2 column t") && e.contains("stands still"), "{e}");
    }

    #[test]
    fn near_unit_quaternions_are_normalised() {
        let p = parse("t,x,y,z,qw,qx,qy,qz\n0,0,0,0,1.0005,0,0,0\n").unwrap();
        let q = DQuat::from_mat3(&p.samples[0].pose.matrix3);
        assert!((q.length() - 1.0).abs() < 1e-12 && q.w.abs() > 0.999_999, "{q}");
    }

    #[test]
    fn rpm_must_not_be_negative_and_cut_may_be_written_as_a_number() {
        let e = parse("t,x,y,z,qw,qx,qy,qz,rpm\n0,0,0,0,1,0,0,0,-5\n").unwrap_err();
        assert!(e.contains("row 1 column rpm") && e.contains(">= 0"), "{e}");
        let p = parse("t,x,y,z,qw,qx,qy,qz,cut\n0,0,0,0,1,0,0,0,1.0\n1,0,0,0,1,0,0,0,0.0\n").unwrap();
        assert!(p.samples[0].cut && !p.samples[1].cut);
    }

    #[test]
    fn devices_hold_the_pedal_from_a_sample_and_prepare_cuts_the_segment_to_it() {
        let p = parse("t,x,y,z,qw,qx,qy,qz,rpm,cut\n0,0,0,0,1,0,0,0,100,0\n1,1,0,0,1,0,0,0,300,1\n2,2,0,0,1,0,0,0,300,0\n").unwrap();
        let segments: Vec<(bool, Option<f64>)> = p.segments().map(|s| (s.cut, s.rpm)).collect();
        assert_eq!(segments, [(true, Some(300.0)), (false, Some(300.0))]);
        for (t, cut) in [(0.5, false), (1.5, true), (2.5, false)] {
            assert_eq!(p.state_at(t).cut, cut, "t = {t}");
        }
        assert_eq!(p.state_at(0.5).rpm, Some(200.0));
        assert!((p.state_at(1.25).pose.translation.x - 1.25).abs() < 1e-12);
    }

    #[test]
    fn code_built_samples_are_checked_as_csv_rows_are() {
        let s = |t: f64, x: f64| PathSample { t, pose: DAffine3::from_translation(DVec3::new(x, 0.0, 0.0)), rpm: None, cut: true };
        assert_eq!(ToolPath::from_samples(&[s(0.0, 0.0), s(1.0, 1.0)], "demo", PathLimits::default()).unwrap().samples.len(), 2);
        let e = ToolPath::from_samples(&[s(0.0, 0.0), s(1.0, 9.0)], "demo", PathLimits::default()).unwrap_err().to_string();
        assert!(e.contains("demo sample 1") && e.contains("jumps"), "{e}");
        let e = ToolPath::from_samples(&[s(1.0, 0.0), s(0.5, 0.1)], "demo", PathLimits::default()).unwrap_err().to_string();
        assert!(e.contains("demo sample 1 t") && e.contains("backwards"), "{e}");
        assert!(ToolPath::from_samples(&[], "demo", PathLimits::default()).is_err());
    }
}
