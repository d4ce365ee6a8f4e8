//! Planning: cut a whole tool path into a model (what `dentsim prepare` and the plugin's
//! "Dental Preparation" filter call). Consecutive segments that cut (each ends at a sample whose
//! `cut` flag is set, [`ToolPath::segments`]) form strokes; each segment is one swept cut, so fast
//! or coarse paths never tunnel.
use std::collections::BTreeMap;

use serde::Serialize;

use crate::burr::Burr;
use crate::cutting::cutter::Cutter;
use crate::cutting::removal::Feed;
use crate::error::Result;
use crate::plan::path::{PathLimits, ToolPath};
use crate::tissues::export::PREPARE_SUMMARY_NAME;
use crate::tissues::model::{TissueModel, TissueVolumes};

/// How to cut along the path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrepareOptions {
    /// `None`: the purely geometric cut (planning). `Some(force)`: rate-limited by the tissue
    /// table at this applied force (N), with the path's `rpm` column (or `default_rpm`).
    pub force_n: Option<f64>,
    pub default_rpm: f64,
    /// The memory cap [`prepare_to_dir`] checks the tissues against before cutting.
    pub limits: crate::Limits,
}

impl Default for PrepareOptions {
    fn default() -> Self {
        PrepareOptions { force_n: None, default_rpm: crate::cutting::removal::REFERENCE_RPM, limits: crate::Limits::default() }
    }
}

/// Figures of one stroke (a run of cutting samples).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StrokeSummary {
    pub first_row: usize,
    pub last_row: usize,
    pub t_start_s: f64,
    pub t_end_s: f64,
    pub length_mm: f64,
    pub removed_mm3: BTreeMap<String, f64>,
    pub changed_voxels: u64,
}

#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PrepareReport {
    pub burr: String,
    /// Tissue → volume removed over the whole path (mm³).
    pub removed_mm3: BTreeMap<String, f64>,
    pub strokes: Vec<StrokeSummary>,
    pub segments: usize,
    pub substeps: usize,
}

/// Cuts `path` into `model`; see [`prepare_with_progress`].
pub fn prepare(model: &mut TissueModel, path: &ToolPath, burr: &Burr, options: &PrepareOptions) -> Result<PrepareReport> {
    prepare_with_progress(model, path, burr, options, &mut |_| {})
}

/// Cuts `path` into `model`, calling `progress(fraction)` as it goes.
pub fn prepare_with_progress(
    model: &mut TissueModel,
    path: &ToolPath,
    burr: &Burr,
    options: &PrepareOptions,
    progress: &mut dyn FnMut(f64),
) -> Result<PrepareReport> {
    prepare_until(model, path, burr, options, &mut |f| {
        progress(f);
        true
    })
}

/// What a preparation stopped by its caller returns (the model is then partly cut).
pub const ABORTED: &str = "stopped on request before the end of the tool path";

/// Cuts `path` into `model`, calling `go_on(fraction)` after each segment; when it returns
/// false the cut stops there with an error ([`ABORTED`]): how a GUI's abort reaches the loop.
pub fn prepare_until(
    model: &mut TissueModel,
    path: &ToolPath,
    burr: &Burr,
    options: &PrepareOptions,
    go_on: &mut dyn FnMut(f64) -> bool,
) -> Result<PrepareReport> {
    let mut cutter = Cutter::default();
    let mut report = PrepareReport { burr: burr.spec(), ..Default::default() };
    for t in &model.tissues {
        report.removed_mm3.insert(t.props.name.clone(), 0.0);
    }
    let n = path.samples.len();
    let mut open: Option<StrokeSummary> = None;
    for seg in path.segments() {
        let (a, b, i) = (seg.from, seg.to, seg.index);
        if !seg.cut {
            if let Some(s) = open.take() {
                cutter.end_stroke();
                report.strokes.push(s);
            }
            continue;
        }
        let stroke = open.get_or_insert_with(|| {
            cutter.begin_stroke();
            StrokeSummary {
                first_row: i + 1,
                last_row: i + 1,
                t_start_s: a.t,
                t_end_s: a.t,
                length_mm: 0.0,
                removed_mm3: model.tissues.iter().map(|t| (t.props.name.clone(), 0.0)).collect(),
                changed_voxels: 0,
            }
        });
        let feed = match options.force_n {
            None => Feed::Geometric,
            Some(force_n) => Feed::Limited { force_n, rpm: seg.rpm.unwrap_or(options.default_rpm), dt_s: b.t - a.t },
        };
        let r = cutter.cut_with(model, burr, a.pose, b.pose, feed)?;
        for (name, v) in &r.removed_mm3 {
            *stroke.removed_mm3.entry(name.clone()).or_default() += v;
            *report.removed_mm3.entry(name.clone()).or_default() += v;
        }
        stroke.changed_voxels += r.changed_voxels;
        stroke.last_row = i + 2;
        stroke.t_end_s = b.t;
        stroke.length_mm += (b.pose.translation - a.pose.translation).length();
        report.segments += 1;
        report.substeps += r.substeps;
        if !go_on((i + 1) as f64 / (n - 1).max(1) as f64) {
            return Err(crate::error::invalid("preparation", ABORTED));
        }
    }
    if let Some(s) = open.take() {
        cutter.end_stroke();
        report.strokes.push(s);
    }
    go_on(1.0);
    Ok(report)
}

/// What `prepare.json` holds: the inputs, the report, and each tissue's volumes.
#[derive(Clone, Debug, Serialize)]
pub struct PrepareSummary {
    pub tissues_file: String,
    pub path_file: String,
    pub force_n: Option<f64>,
    #[serde(flatten)]
    pub report: PrepareReport,
    pub tissues: Vec<TissueFigures>,
}

/// One tissue in `prepare.json`: its volumes and its surface's triangle count.
#[derive(Clone, Debug, Serialize)]
pub struct TissueFigures {
    #[serde(flatten)]
    pub volumes: TissueVolumes,
    pub triangles: usize,
}

/// Reads the tissues (.vdb), the tool path (CSV) and the burr, cuts the path, and writes the
/// prepared `tissues.vdb`, `<tissue>.vtp/.stl` and `prepare.json` into `out`. Every input is read
/// and checked before `out` is created, and every file is written whole or not at all.
pub fn prepare_to_dir(
    tissues: &std::path::Path,
    path: &std::path::Path,
    burr_spec: &str,
    options: &PrepareOptions,
    table: &crate::tissues::table::TissueTable,
    out: &std::path::Path,
    progress: &mut dyn FnMut(&str, f64),
) -> Result<PrepareSummary> {
    let burr = Burr::parse(burr_spec)?;
    let tool_path = ToolPath::read(path, PathLimits::default())?;
    let mut model = TissueModel::load(tissues, table)?;
    if model.tissues.is_empty() {
        return Err(crate::Error::File { path: tissues.to_owned(), message: "holds no tissue grids".into() });
    }
    // The cuts' own buffers are bounded per stroke by the sweep; the grids are not.
    let bytes = model.cutting_bytes_estimate();
    // Rounded to a micrometre: grids keep voxel sizes as f32.
    let voxel = (model.voxel_size().unwrap_or(0.0) * 1e6).round() / 1e6;
    options.limits.check_memory(&format!("tissues {} ({voxel} mm voxels, burr {})", tissues.display(), burr.spec()), bytes)?;
    let before = model.volumes();
    progress("cutting", 0.0);
    let report = prepare_with_progress(&mut model, &tool_path, &burr, options, &mut |f| progress("cutting", 0.8 * f))?;
    crate::tissues::export::all_or_nothing(out, |staged| {
        let triangles = crate::tissues::export::write_model(&mut model, staged, &mut |step, f| progress(step, 0.8 + 0.2 * f))?;
        let tissue_figures = TissueVolumes::of(&model, &before, |name| report.removed_mm3.get(name).copied().unwrap_or(0.0))
            .into_iter()
            .zip(triangles)
            .map(|(volumes, (_, triangles))| TissueFigures { volumes, triangles })
            .collect();
        let summary = PrepareSummary {
            tissues_file: tissues.display().to_string(),
            path_file: path.display().to_string(),
            force_n: options.force_n,
            report,
            tissues: tissue_figures,
        };
        let json = serde_json::to_vec_pretty(&summary).map_err(|e| crate::error::invalid(PREPARE_SUMMARY_NAME, e.to_string()))?;
        dentsim_atomic::write(&staged.join(PREPARE_SUMMARY_NAME), |w| w.write_all(&json))?;
        Ok(summary)
    })
}

/// Where a tool path comes from.
#[derive(Clone, Copy, Debug)]
pub enum PathSource<'a> {
    /// A CSV file in the `t,x,y,z,qw,qx,qy,qz[,rpm][,cut]` format.
    Csv(&'a std::path::Path),
    /// A polyline's points and arrays (ParaView).
    Polyline(crate::plan::path::PolylineArrays<'a>),
}

/// A whole preparation as the ParaView "Dental Preparation" filter asks for it: tissues from a
/// .vdb (or the capsule phantom), a tool path, a burr spec, and an applied force (0: geometric).
#[derive(Clone, Debug)]
pub struct PreparationRequest<'a> {
    /// A .vdb of tissues; `None` builds the capsule phantom at `phantom_voxel_mm`.
    pub tissues: Option<&'a std::path::Path>,
    pub phantom_voxel_mm: f64,
    pub path: PathSource<'a>,
    /// A burr spec for [`Burr::parse`].
    pub burr: &'a str,
    /// Applied force (N) for rate-limited cutting; 0 for the purely geometric cut.
    pub force_n: f64,
}

/// The prepared model, each tissue's volumes, and the path's report.
pub struct Prepared {
    pub model: TissueModel,
    pub tissues: Vec<TissueVolumes>,
    pub report: PrepareReport,
}

impl PreparationRequest<'_> {
    /// Checks every input before any work (bad burr, path or force → an error naming it), then
    /// loads or builds the tissues and cuts the path. Cost: one swept cut per path segment.
    pub fn run(&self, table: &crate::tissues::table::TissueTable) -> Result<Prepared> {
        self.run_until(table, None, &mut |_| true)
    }

    /// As [`run`](Self::run), cutting `tissues` when given (a model built elsewhere, e.g. from
    /// an upstream filter's surfaces) instead of `self.tissues`/the phantom, and stopping when
    /// `go_on(fraction)` returns false (see [`prepare_until`]).
    pub fn run_until(
        &self,
        table: &crate::tissues::table::TissueTable,
        tissues: Option<TissueModel>,
        go_on: &mut dyn FnMut(f64) -> bool,
    ) -> Result<Prepared> {
        use crate::error::invalid;
        if !(self.force_n.is_finite() && self.force_n >= 0.0) {
            return Err(invalid("force", format!("{} N, expected 0 (geometric) or a positive force", self.force_n)));
        }
        let burr = Burr::parse(self.burr)?;
        let limits = PathLimits::default();
        let path = match self.path {
            PathSource::Csv(p) => ToolPath::read(p, limits)?,
            PathSource::Polyline(a) => ToolPath::from_polyline(&a, "tool path", limits)?,
        };
        let mut model = match (tissues, self.tissues) {
            (Some(model), _) => model,
            (None, Some(p)) => TissueModel::load(p, table)?,
            (None, None) => {
                crate::tissues::model::check_voxel_mm("phantom voxel size", self.phantom_voxel_mm)?;
                crate::tissues::capsule::CapsuleTooth::default().build(self.phantom_voxel_mm, table)?
            }
        };
        let before = model.volumes();
        let options = PrepareOptions { force_n: (self.force_n > 0.0).then_some(self.force_n), ..Default::default() };
        let report = prepare_until(&mut model, &path, &burr, &options, go_on)?;
        let tissues = TissueVolumes::of(&model, &before, |name| report.removed_mm3.get(name).copied().unwrap_or(0.0));
        Ok(Prepared { model, tissues, report })
    }
}
