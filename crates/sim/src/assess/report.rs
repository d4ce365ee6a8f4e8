//! `dentsim assess`'s outputs: assessment.json, the prepared tooth's surface with its deviation
//! and cut depth per point (tooth.vtp), and assessment.png (an occlusal map of the deviation, or
//! of the cut depth without a reference, beside the table of graded criteria).
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};

use crate::assess::session::{SessionFolder, SessionPoint};
use crate::assess::{assess_as, Assessment, Kind};
use crate::error::{Error, Result};
use crate::limits::Limits;
use crate::tissues::export::{all_or_nothing, write_vtp_with, REPLAY_SUMMARY_NAME, SUMMARY_NAME, TISSUES_NAME};
use crate::tissues::model::TissueModel;
use crate::tissues::table::TissueTable;

pub const ASSESSMENT_JSON: &str = "assessment.json";
pub const ASSESSMENT_PNG: &str = "assessment.png";
pub const ASSESSED_SURFACE: &str = "tooth.vtp";

/// A tissues file, or an output folder holding one (`segment`, `prepare`, `session`, `replay`).
pub fn tissues_file(path: &Path) -> PathBuf {
    if path.is_dir() {
        path.join(TISSUES_NAME)
    } else {
        path.to_owned()
    }
}

/// Loads the three models, assesses, and writes the outputs into `out` (created if missing), all
/// or nothing. The models' grids, their copies for the set operations and their surfaces must fit
/// in `limits`.
pub fn assess_to_dir(prepared: &Path, original: &Path, reference: Option<&Path>, kind: Kind, table: &TissueTable, limits: &Limits, out: &Path) -> Result<Assessment> {
    let load = |p: &Path| TissueModel::load(&tissues_file(p), table);
    let (prepared, original) = (load(prepared)?, load(original)?);
    let reference = reference.map(load).transpose()?;
    assess_models_to_dir(&prepared, &original, reference.as_ref(), kind, table, limits, out, None)
}

/// [`assess_to_dir`] of a session's or replay's output folder: the starting tissues default to
/// the ones its summary names, and at `tick` the preparation is the log replayed through that
/// tick. `assessment.json` then says which session and tick, with its guidance events.
#[allow(clippy::too_many_arguments)]
pub fn assess_session_to_dir(
    folder: &Path,
    original: Option<&Path>,
    reference: Option<&Path>,
    tick: Option<u64>,
    kind: Kind,
    table: &TissueTable,
    limits: &Limits,
    out: &Path,
) -> Result<Assessment> {
    let session = SessionFolder::open(folder)?.ok_or_else(|| Error::File {
        path: folder.to_owned(),
        message: format!("not a session or replay output folder (no {SUMMARY_NAME} or {REPLAY_SUMMARY_NAME})"),
    })?;
    let original = original.map(tissues_file).unwrap_or_else(|| session.original.clone());
    if !original.is_file() {
        return Err(Error::File { path: original, message: format!("the starting tissues of {} are not there: pass --original", folder.display()) });
    }
    if tick.is_some() {
        // The replay holds the log and a second model.
        let log_bytes = std::fs::metadata(&session.log).map_err(|e| Error::File { path: session.log.clone(), message: e.to_string() })?.len();
        limits.check_memory(&format!("session log {}", session.log.display()), log_bytes.saturating_mul(3))?;
    }
    let (prepared, point) = session.prepared(&original, tick, table)?;
    let original = TissueModel::load(&original, table)?;
    let reference = reference.map(|p| TissueModel::load(&tissues_file(p), table)).transpose()?;
    assess_models_to_dir(&prepared, &original, reference.as_ref(), kind, table, limits, out, Some(point))
}

#[allow(clippy::too_many_arguments)]
fn assess_models_to_dir(
    prepared: &TissueModel,
    original: &TissueModel,
    reference: Option<&TissueModel>,
    kind: Kind,
    table: &TissueTable,
    limits: &Limits,
    out: &Path,
    session: Option<SessionPoint>,
) -> Result<Assessment> {
    // Each grid once more for the set operations and about as much again for its surface.
    let bytes: u64 = [Some(prepared), Some(original), reference].into_iter().flatten().flat_map(|m| &m.tissues).map(|t| 3 * t.grid.mem_bytes()).sum();
    limits.check_memory("assessing the three tissue models", bytes)?;
    let mut assessment = assess_as(prepared, original, reference, kind)?;
    assessment.session = session;
    all_or_nothing(out, |staged| {
        let json = serde_json::to_string_pretty(&assessment).map_err(|e| crate::error::invalid(ASSESSMENT_JSON, e.to_string()))?;
        dentsim_atomic::write(&staged.join(ASSESSMENT_JSON), |w| w.write_all(json.as_bytes()))?;
        let s = &assessment.surface;
        let props = table.get("enamel").cloned().unwrap_or_else(|| table.tissues[0].clone());
        write_vtp_with(&staged.join(ASSESSED_SURFACE), &s.mesh, &props, &[("DeviationMm", &s.deviation_mm), ("CutDepthMm", &s.cut_depth_mm)])?;
        draw_report(&staged.join(ASSESSMENT_PNG), &assessment, reference.is_some())
    })?;
    Ok(assessment)
}

/// DejaVu Sans from the system (Debian's fonts-dejavu-core), registered once; false without it
/// (the picture is then drawn without text: the JSON carries the numbers).
fn font_ready() -> bool {
    static READY: OnceLock<bool> = OnceLock::new();
    *READY.get_or_init(|| match std::fs::read("/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf") {
        Ok(bytes) => register_font("sans-serif", FontStyle::Normal, Box::leak(bytes.into_boxed_slice())).is_ok(),
        Err(_) => false,
    })
}

/// Blue (−) through white (0) to red (+), saturating at ±`range`.
fn diverging(v: f64, range: f64) -> RGBColor {
    let t = (v / range.max(1e-9)).clamp(-1.0, 1.0);
    let fade = |c: u8, t: f64| (255.0 + (f64::from(c) - 255.0) * t.abs()) as u8;
    if t >= 0.0 {
        RGBColor(fade(200, t), fade(30, t), fade(30, t))
    } else {
        RGBColor(fade(30, t), fade(70, t), fade(200, t))
    }
}

fn draw_report(path: &Path, a: &Assessment, with_reference: bool) -> Result<()> {
    let err = |m: String| Error::File { path: path.to_owned(), message: m };
    let text = font_ready();
    let s = &a.surface;
    let values: Vec<f64> = if with_reference { s.deviation_mm.iter().map(|v| f64::from(*v)).collect() } else { s.cut_depth_mm.iter().map(|v| f64::from(*v)).collect() };
    let range = values.iter().fold(0.05f64, |m, v| m.max(v.abs()));
    // Tall enough for a crown's table (about 30 rows).
    let (w, h) = (1200u32, 1000u32);
    dentsim_atomic::write_via(path, |tmp| -> Result<()> {
        let root = BitMapBackend::new(tmp, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let (map, side) = root.split_horizontally(680);
        // The occlusal view: looking down −z, far triangles first.
        let pts = &s.mesh.points;
        let (lo, hi) = pts.iter().fold((glam::Vec3::splat(f32::MAX), glam::Vec3::splat(f32::MIN)), |(l, u), p| (l.min(*p), u.max(*p)));
        let scale = 640.0 / (hi - lo).truncate().max_element().max(1e-3);
        let at = |p: glam::Vec3| (20 + ((p.x - lo.x) * scale) as i32, 720 - ((p.y - lo.y) * scale) as i32);
        let mut order: Vec<usize> = (0..s.mesh.triangles.len()).collect();
        let height = |t: &[u32; 3]| t.iter().map(|i| pts[*i as usize].z).sum::<f32>();
        order.sort_by(|a, b| height(&s.mesh.triangles[*a]).total_cmp(&height(&s.mesh.triangles[*b])));
        for i in order {
            let t = s.mesh.triangles[i];
            let [p0, p1, p2] = t.map(|k| pts[k as usize]);
            let normal = (p1 - p0).cross(p2 - p0).normalize_or_zero();
            if normal.z <= 0.0 {
                continue;
            }
            let v = t.iter().map(|k| values[*k as usize]).sum::<f64>() / 3.0;
            // Shade by the normal so the relief shows; colour by the value where it is not 0.
            let base = if v.abs() > 1e-3 { diverging(v, range) } else { RGBColor(215, 210, 195) };
            let light = 0.45 + 0.55 * f64::from(normal.z);
            let shaded = RGBColor((f64::from(base.0) * light) as u8, (f64::from(base.1) * light) as u8, (f64::from(base.2) * light) as u8);
            map.draw(&Polygon::new(vec![at(p0), at(p1), at(p2)], shaded.filled())).map_err(|e| err(e.to_string()))?;
        }
        // The colour bar, then the table.
        for k in 0..200 {
            let v = range * (1.0 - 2.0 * f64::from(k) / 199.0);
            side.draw(&Rectangle::new([(20, 60 + k), (60, 61 + k)], diverging(v, range).filled())).map_err(|e| err(e.to_string()))?;
        }
        if text {
            let font = ("sans-serif", 16).into_font();
            let what = if with_reference { "deviation from the reference (mm, + deeper)" } else { "depth cut below the original surface (mm)" };
            side.draw(&Text::new(what.to_owned(), (20, 30), font.clone())).map_err(|e| err(e.to_string()))?;
            side.draw(&Text::new(format!("{:+.2}", range), (70, 55), font.clone())).map_err(|e| err(e.to_string()))?;
            side.draw(&Text::new("0", (70, 152), font.clone())).map_err(|e| err(e.to_string()))?;
            side.draw(&Text::new(format!("{:+.2}", -range), (70, 250), font.clone())).map_err(|e| err(e.to_string()))?;
            let mut y = 290;
            let mut line = |s: String, colour: RGBColor| -> Result<()> {
                side.draw(&Text::new(s, (20, y), font.clone().color(&colour))).map_err(|e| err(e.to_string()))?;
                y += 22;
                Ok(())
            };
            // The figures as the table has them (one listing for the picture, ParaView and JSON
            // readers): graded rows coloured by their verdict.
            for row in a.rows() {
                let colour = match row.verdict.as_str() {
                    "ideal" => RGBColor(0, 130, 0),
                    "acceptable" => RGBColor(200, 130, 0),
                    "out_of_range" => RED,
                    _ => BLACK,
                };
                let range = if row.range.is_empty() { String::new() } else { format!(" ({})", row.range) };
                line(format!("{}: {:.3} {}{range}", row.criterion, row.value, row.unit), colour)?;
            }
        }
        root.present().map_err(|e| err(e.to_string()))
    })
}
