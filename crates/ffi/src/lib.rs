//! The one contract between the ParaView plugin and the Rust core. Plain data crosses as shared
//! structs; every call returns `Result`, which cxx turns into a C++ `rust::Error` exception, and
//! no panic crosses: each call runs under `catch_unwind`.
use std::panic::{catch_unwind, AssertUnwindSafe};

use dentsim_sim::tissues::model::{Tissue, TissueVolumes};
use dentsim_sim::plan::phantom_stroke::PhantomStroke;
use dentsim_sim::session::live::{LiveRequest, LiveSession, LiveState};
use dentsim_sim::tissues::table::{TissueProps, TissueTable};
use dentsim_vdb::TriMesh;

#[cxx::bridge(namespace = "dentsim::ffi")]
mod bridge {
    /// A straight stroke of a round burr over the capsule phantom (mm).
    struct StrokeParams {
        voxel_size_mm: f64,
        burr_diameter_mm: f64,
        start_mm: [f64; 3],
        end_mm: [f64; 3],
    }

    /// One tissue's surface (triangles wound outward) with its properties and volumes.
    struct TissueSurface {
        name: String,
        label: i32,
        colour: [f32; 3],
        opacity: f32,
        stiffness_n_per_mm: f64,
        damping_n_s_per_mm: f64,
        removal_rate_mm3_per_n_s: f64,
        volume_before_mm3: f64,
        volume_after_mm3: f64,
        removed_mm3: f64,
        points: Vec<f32>,
        normals: Vec<f32>,
        triangles: Vec<u32>,
        /// What segmentation found doubtful about this tissue (a pulp it could not resolve or
        /// did not find), each a sentence saying what to try; empty elsewhere.
        warnings: Vec<String>,
    }

    /// One tooth of all those found in a scan, with its tissues.
    struct ToothSurfaces {
        /// 1 = largest; the teeth are numbered by size, not identified.
        tooth: u32,
        /// A point inside it, LPS mm.
        seed_mm: [f64; 3],
        cut_by_field_of_view: bool,
        tissues: Vec<TissueSurface>,
    }

    /// A scalar image as VTK holds it: world = origin + direction · (ijk ∘ spacing), with the
    /// direction matrix row-major (column c is index axis c), x fastest in the values.
    #[derive(Clone)]
    struct ImageGeometry {
        dims: [u32; 3],
        spacing: [f64; 3],
        origin: [f64; 3],
        direction: [f64; 9],
    }

    /// Which tooth to turn into tissues, and how finely.
    #[derive(Clone)]
    struct TissuesFromScanParams {
        voxel_size_mm: f64,
        fdi: u8,
        use_seed: bool,
        seed_mm: [f64; 3],
        /// Leave a cone-beam scanner's shading on the grey values (still measured and said).
        keep_shading: bool,
    }

    /// How to start a live haptic session ("Dental Haptic Session").
    struct SessionParams {
        /// A .vdb of tissues; empty for the built-in capsule phantom.
        tissues_path: String,
        /// Voxel size of the phantom (mm) when no file is given.
        phantom_voxel_mm: f64,
        /// `scripted:PATH.csv`, `hand:KEY=VAL,...`, `spacemouse[:...]` or `igtl://HOST:PORT?...`,
        /// optionally followed by `+pedal[:key=b]`.
        device: String,
        /// Device profile: touch, omni, desktop, premium15, falcon, omega.
        profile: String,
        /// Force filter: delta, biquad or none.
        filter: String,
        /// Tick on the wall clock; false runs ticks back to back (reproducible pictures).
        realtime: bool,
        /// A burr spec as for preparations: catalogue name, ISO number, or
        /// `SHAPE:DIAMETER_MM[:LENGTH_MM]`.
        burr: String,
        /// Where the session log goes (as `dentsim session`'s session.dslog); empty for none.
        log_path: String,
    }

    /// The latest state of a live session.
    struct SessionState {
        tick: u64,
        time_s: f64,
        /// False once the device finished and the final tissues are meshed.
        running: bool,
        /// Where the burr is drawn (the proxy) and where the device is (mm).
        burr_position_mm: [f64; 3],
        device_position_mm: [f64; 3],
        /// Force sent to the device (N).
        force_n: [f64; 3],
        /// Tissue in contact; empty for none.
        contact_tissue: String,
        /// Changes whenever a tissue surface changes.
        mesh_generation: u64,
        /// Live guidance: tissue left between the burr head and the pulp (mm; negative inside
        /// it; NaN when the pulp is far or absent).
        remaining_dentin_mm: f64,
        /// 0 clear, 1 within the thin-dentin threshold of the pulp, 2 in the pulp.
        warning_level: u8,
        /// The threshold (mm; 0 when guidance is off).
        thin_dentin_mm: f64,
        /// Cuts that left too little dentin, and cuts into the pulp, so far (events).
        thin_dentin_events: u64,
        pulp_exposure_events: u64,
        /// A live device's workspace on the scan (registration): centre (mm) and radius (mm,
        /// 0 for scripted paths and the simulated hand).
        workspace_centre_mm: [f64; 3],
        workspace_radius_mm: f64,
    }

    /// A tissue surface from upstream in the pipeline (one block: name, x,y,z per point,
    /// three point ids per triangle).
    struct InputSurface {
        name: String,
        points: Vec<f32>,
        triangles: Vec<u32>,
    }

    /// One row of a batch report: a case's tissue ("Dental Batch Plan"; see `dentsim batch`).
    struct BatchRow {
        case_name: String,
        scan: String,
        preparation: String,
        burr: String,
        tissue: String,
        removed_mm3: f64,
        volume_before_mm3: f64,
        volume_after_mm3: f64,
        seconds: f64,
    }

    /// A planned preparation ("Dental Preparation"): tissues, tool path, burr, force.
    #[derive(Clone)]
    struct PreparationParams {
        /// A .vdb of tissues; empty for the built-in capsule phantom.
        tissues_path: String,
        /// Voxel size of the phantom (mm) when no file is given.
        phantom_voxel_mm: f64,
        /// A burr spec: catalogue name, ISO number, or `SHAPE:DIAMETER_MM[:LENGTH_MM]`.
        burr: String,
        /// Applied force (N) for rate-limited cutting; 0 for the geometric cut.
        force_n: f64,
        /// True: the path is the polyline arrays passed beside; false: the CSV at `path_csv`.
        use_polyline: bool,
        path_csv: String,
    }

    /// What "Dental Preparation Assessment" grades: tissue files (.vdb, or folders holding
    /// tissues.vdb), the reference optional (empty), a crown's path of insertion optional.
    struct AssessmentParams {
        prepared_path: String,
        original_path: String,
        reference_path: String,
        crown: bool,
        use_axis: bool,
        axis: [f64; 3],
    }

    /// One line of the assessment's table; `verdict` empty for an ungraded figure.
    struct AssessmentRow {
        criterion: String,
        value: f64,
        unit: String,
        range: String,
        verdict: String,
        source: String,
    }

    /// The prepared tooth's surface with its deviation from the reference (0 without one) and
    /// the depth cut below the original surface per point, the table, and assessment.json's text.
    struct AssessmentResult {
        points: Vec<f32>,
        triangles: Vec<u32>,
        deviation_mm: Vec<f32>,
        cut_depth_mm: Vec<f32>,
        rows: Vec<AssessmentRow>,
        json: String,
    }

    extern "Rust" {
        /// Cuts the tool path into the tissues; the polyline arrays (x,y,z per point; w,x,y,z
        /// per point; optional time, rpm, cut: empty when absent) are used when
        /// `params.use_polyline`. Surfaces carry each tissue's volumes before and after and the
        /// volume removed.
        fn prepare_tissues(
            params: &PreparationParams,
            points: &[f64],
            orientation: &[f64],
            time: &[f64],
            rpm: &[f64],
            cut: &[f64],
        ) -> Result<Vec<TissueSurface>>;
    }

    extern "Rust" {
        /// Work on a thread of its own that the plugin polls: progress, abort, result.
        type SurfaceJob;
        /// As `prepare_tissues`, on a thread; `tissues` (when not empty) are the tissue surfaces
        /// to cut, rebuilt as level sets at `tissue_voxel_mm`, instead of the file or phantom.
        fn start_preparation(
            params: &PreparationParams,
            tissues: &[InputSurface],
            tissue_voxel_mm: f64,
            points: &[f64],
            orientation: &[f64],
            time: &[f64],
            rpm: &[f64],
            cut: &[f64],
        ) -> Result<Box<SurfaceJob>>;
        /// Fraction done, 0..=1.
        fn progress(self: &SurfaceJob) -> f64;
        fn finished(self: &SurfaceJob) -> bool;
        /// Asks the work to stop at its next check; `wait` then returns an error saying so.
        fn abort(self: &SurfaceJob);
        /// Blocks until the work ends; its surfaces or its error.
        fn wait(self: &mut SurfaceJob) -> Result<Vec<TissueSurface>>;
        /// `tissues_from_scan_source` on a thread (progress follows segmentation's steps; an
        /// abort stops it before its next step).
        fn start_tissues_from_scan(
            geometry: &ImageGeometry,
            values: &[f32],
            params: &TissuesFromScanParams,
            scan_path: &str,
            thresholds: &str,
        ) -> Result<Box<SurfaceJob>>;
        /// `teeth_from_scan_source` on a thread (an abort stops it before its next step).
        type TeethJob;
        fn start_teeth_from_scan(
            geometry: &ImageGeometry,
            values: &[f32],
            params: &TissuesFromScanParams,
            scan_path: &str,
            thresholds: &str,
        ) -> Result<Box<TeethJob>>;
        fn progress(self: &TeethJob) -> f64;
        fn finished(self: &TeethJob) -> bool;
        fn abort(self: &TeethJob);
        fn wait(self: &mut TeethJob) -> Result<Vec<ToothSurfaces>>;
        /// `assess_preparation_from` on a thread (an abort stops it before its next step).
        type AssessmentJob;
        fn start_assessment(
            params: &AssessmentParams,
            prepared: &[InputSurface],
            original: &[InputSurface],
            reference: &[InputSurface],
            voxel_mm: f64,
        ) -> Result<Box<AssessmentJob>>;
        fn progress(self: &AssessmentJob) -> f64;
        fn finished(self: &AssessmentJob) -> bool;
        fn abort(self: &AssessmentJob);
        fn wait(self: &mut AssessmentJob) -> Result<AssessmentResult>;
        /// The tissue table as ParaView settings: a categorical colour map for the cell array
        /// `Tissue` (each tissue's colour, opacity and name), JSON for vtkSMSettings.
        fn tissue_colour_settings() -> String;
        /// The `Tissue` label of the session's burr at a guidance warning level (0 clear, 1 near
        /// the pulp, 2 in it) and of its force arrow: the default colour map colours them.
        fn burr_label(warning_level: u8) -> i32;
        fn force_label() -> i32;
    }

    extern "Rust" {
        /// Runs shard `index` of `count` of the manifest's cases into `out` (as
        /// `dentsim batch --shard`); the rows of the cases it ran.
        fn batch_shard(manifest: &str, out: &str, index: u32, count: u32) -> Result<Vec<BatchRow>>;
        /// Merges every case under `out` into report.csv/report.json (as `dentsim batch --merge`).
        fn batch_merge(manifest: &str, out: &str, shards: u32) -> Result<Vec<BatchRow>>;
        /// Batch work on a thread: as `batch_shard` (abort stops before the next case).
        type RowsJob;
        fn start_batch_shard(manifest: &str, out: &str, index: u32, count: u32) -> Result<Box<RowsJob>>;
        fn progress(self: &RowsJob) -> f64;
        fn finished(self: &RowsJob) -> bool;
        fn abort(self: &RowsJob);
        fn wait(self: &mut RowsJob) -> Result<Vec<BatchRow>>;
    }

    extern "Rust" {
        type HapticSession;
        fn default_session() -> SessionParams;
        fn start_session(params: &SessionParams) -> Result<Box<HapticSession>>;
        fn poll(self: &mut HapticSession) -> Result<SessionState>;
        /// Ends the session now (Stop): the log is completed and the final tissues meshed.
        fn stop(self: &mut HapticSession) -> Result<SessionState>;
        /// Pauses (zero force, nothing cut or logged) or resumes the session.
        fn set_paused(self: &mut HapticSession, paused: bool);
        fn tissue_surfaces(self: &HapticSession) -> Result<Vec<TissueSurface>>;
        fn burr_surface(self: &HapticSession) -> Result<TissueSurface>;
    }

    extern "Rust" {
        fn default_stroke() -> StrokeParams;
        fn phantom_stroke(params: &StrokeParams) -> Result<Vec<TissueSurface>>;
        fn read_tissues(path: &str) -> Result<Vec<TissueSurface>>;
        fn tissues_from_scan(geometry: &ImageGeometry, values: &[f32], params: &TissuesFromScanParams) -> Result<Vec<TissueSurface>>;
        fn tissues_from_scan_source(
            geometry: &ImageGeometry,
            values: &[f32],
            params: &TissuesFromScanParams,
            scan_path: &str,
            thresholds: &str,
        ) -> Result<Vec<TissueSurface>>;
        fn teeth_from_scan_source(
            geometry: &ImageGeometry,
            values: &[f32],
            params: &TissuesFromScanParams,
            scan_path: &str,
            thresholds: &str,
        ) -> Result<Vec<ToothSurfaces>>;
        fn version() -> String;
        fn assess_preparation(params: &AssessmentParams) -> Result<AssessmentResult>;
        /// As `assess_preparation`, with each model taken from tissue surfaces upstream in the
        /// pipeline (rebuilt as level sets at `voxel_mm`) where given, else from its file.
        fn assess_preparation_from(
            params: &AssessmentParams,
            prepared: &[InputSurface],
            original: &[InputSurface],
            reference: &[InputSurface],
            voxel_mm: f64,
        ) -> Result<AssessmentResult>;
    }
}

pub use bridge::{AssessmentParams, AssessmentResult, AssessmentRow, BatchRow, ImageGeometry, InputSurface, PreparationParams, TissuesFromScanParams, SessionParams, SessionState, StrokeParams, TissueSurface, ToothSurfaces};

/// Runs `f`, turning a panic into an error so it never unwinds into C++.
fn guarded<T>(what: &str, f: impl FnOnce() -> Result<T, String>) -> Result<T, String> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(result) => result,
        Err(panic) => {
            let message = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            Err(format!("{what}: internal error: {message}"))
        }
    }
}

/// Prefixes an error about one of the proxy's files with that property's label in ParaView, so
/// the message names both the property to fix and the file (which the error text holds).
fn name_property(message: String, files: &[(&str, &str)]) -> String {
    match files.iter().find(|(_, path)| !path.is_empty() && message.contains(path)) {
        Some((label, _)) => format!("{label}: {message}"),
        None => message,
    }
}

fn default_stroke() -> StrokeParams {
    let d = PhantomStroke::default();
    StrokeParams { voxel_size_mm: d.voxel_size_mm, burr_diameter_mm: d.burr_diameter_mm, start_mm: d.start_mm, end_mm: d.end_mm }
}

pub fn phantom_stroke(params: &StrokeParams) -> Result<Vec<TissueSurface>, String> {
    guarded("phantom stroke", || {
        let stroke = PhantomStroke {
            voxel_size_mm: params.voxel_size_mm,
            burr_diameter_mm: params.burr_diameter_mm,
            start_mm: params.start_mm,
            end_mm: params.end_mm,
        };
        let outcome = stroke.run(&TissueTable::default(), &mut |_, _| {}).map_err(|e| e.to_string())?;
        cut_surfaces(&outcome.model, &outcome.tissues)
    })
}

/// Every tissue of a .vdb whose level-set grids are named by tissue, as surfaces.
pub fn read_tissues(path: &str) -> Result<Vec<TissueSurface>, String> {
    guarded("read tissues", || {
        let model = dentsim_sim::tissues::model::TissueModel::load(std::path::Path::new(path), &TissueTable::default())
            .map_err(|e| name_property(e.to_string(), &[("File Name", path)]))?;
        unchanged_surfaces(&model)
    })
}

/// Grades a preparation against its original and an optional reference (see `dentsim assess`).
pub fn assess_preparation(params: &AssessmentParams) -> Result<AssessmentResult, String> {
    assess_preparation_from(params, &[], &[], &[], 0.0)
}

pub fn assess_preparation_from(
    params: &AssessmentParams,
    prepared: &[InputSurface],
    original: &[InputSurface],
    reference: &[InputSurface],
    voxel_mm: f64,
) -> Result<AssessmentResult, String> {
    guarded("assess preparation", || assess_until(params, prepared, original, reference, voxel_mm, &mut |_| true))
}

/// The assessment; `go_on(fraction)` books progress and says whether to go on.
fn assess_until(
    params: &AssessmentParams,
    prepared: &[InputSurface],
    original: &[InputSurface],
    reference: &[InputSurface],
    voxel_mm: f64,
    go_on: &mut dyn FnMut(f64) -> bool,
) -> Result<AssessmentResult, String> {
    use dentsim_sim::assess::report::tissues_file;
    use dentsim_sim::assess::{assess_until, Kind};
    {
        // The input when connected, else the file: each error names the property.
        let load = |what: &str, input: &[InputSurface], p: &str| {
            if !input.is_empty() {
                return model_from_inputs(what, input, voxel_mm);
            }
            if p.trim().is_empty() {
                return Err(format!("{what}: no input connected and no file given"));
            }
            dentsim_sim::tissues::model::TissueModel::load(&tissues_file(std::path::Path::new(p)), &TissueTable::default()).map_err(|e| format!("{what}: {e}"))
        };
        // Loading (inputs rebuilt as level sets) is the first quarter, grading the rest.
        let mut step = |fraction: f64| if go_on(fraction) { Ok(()) } else { Err(format!("assessment: {}", dentsim_sim::error::STOPPED)) };
        step(0.0)?;
        let prepared = load("Prepared Tissues", prepared, &params.prepared_path)?;
        step(0.1)?;
        let original = load("Original Tissues", original, &params.original_path)?;
        step(0.2)?;
        let reference = if reference.is_empty() && params.reference_path.trim().is_empty() {
            None
        } else {
            Some(load("Reference Preparation", reference, &params.reference_path)?)
        };
        step(0.25)?;
        let kind = match (params.crown, params.use_axis) {
            (false, _) => Kind::Cavity,
            (true, false) => Kind::Crown { axis: None },
            (true, true) => Kind::Crown { axis: Some(glam::DVec3::from_array(params.axis)) },
        };
        let a = assess_until(&prepared, &original, reference.as_ref(), kind, &mut |f| go_on(0.25 + 0.75 * f)).map_err(|e| e.to_string())?;
        let json = serde_json::to_string_pretty(&a).map_err(|e| e.to_string())?;
        let rows = a
            .rows()
            .into_iter()
            .map(|r| AssessmentRow { criterion: r.criterion, value: r.value, unit: r.unit, range: r.range, verdict: r.verdict, source: r.source })
            .collect();
        let s = a.surface;
        Ok(AssessmentResult {
            points: s.mesh.points.iter().flat_map(|p| p.to_array()).collect(),
            triangles: s.mesh.triangles.iter().flatten().copied().collect(),
            deviation_mm: s.deviation_mm,
            cut_depth_mm: s.cut_depth_mm,
            rows,
            json,
        })
    }
}

/// One tooth's tissue surfaces from a scan already in memory (a ParaView reader's output).
pub fn tissues_from_scan(geometry: &ImageGeometry, values: &[f32], params: &TissuesFromScanParams) -> Result<Vec<TissueSurface>, String> {
    tissues_from_scan_source(geometry, values, params, "", "")
}

/// As [`tissues_from_scan`], but from the scan's file through dentsim's reader when `scan_path`
/// is given (ParaView's readers drop what the frame needs: DICOM's sign, origin and axes, the
/// NIfTI/MetaImage orientation), and with grey values overriding the calibration when
/// `thresholds` is given ("TISSUE=GREY,...").
pub fn tissues_from_scan_source(geometry: &ImageGeometry, values: &[f32], params: &TissuesFromScanParams, scan_path: &str, thresholds: &str) -> Result<Vec<TissueSurface>, String> {
    guarded("tissues from scan", || segment_scan(geometry, values.to_vec(), params, scan_path, thresholds, &mut |_| true))
}

/// The scan (the file when `scan_path` is given, else the image) segmented into one tooth's
/// tissue surfaces; `go_on(fraction)` follows the work to 1 and says whether to go on.
fn segment_scan(
    geometry: &ImageGeometry,
    values: Vec<f32>,
    params: &TissuesFromScanParams,
    scan_path: &str,
    thresholds: &str,
    go_on: &mut dyn FnMut(f64) -> bool,
) -> Result<Vec<TissueSurface>, String> {
    let (scan, request) = scan_request(geometry, values, params, scan_path, thresholds)?;
    // Segmentation reports up to 0.9; meshing the surfaces is the rest.
    let (model, report) = request.run_until(&scan, &TissueTable::default(), &mut |_, f| go_on(0.9 * f)).map_err(|e| e.to_string())?;
    let mut surfaces = unchanged_surfaces(&model)?;
    attach_warnings(&mut surfaces, &report.warnings);
    go_on(1.0);
    Ok(surfaces)
}

/// Every tooth in the scan, each its own object with its tissues (the scan as for
/// [`tissues_from_scan_source`]; the seed point and FDI number are not used).
pub fn teeth_from_scan_source(geometry: &ImageGeometry, values: &[f32], params: &TissuesFromScanParams, scan_path: &str, thresholds: &str) -> Result<Vec<ToothSurfaces>, String> {
    guarded("teeth from scan", || segment_teeth(geometry, values.to_vec(), params, scan_path, thresholds, &mut |_| true))
}

/// As [`segment_scan`], every tooth.
fn segment_teeth(
    geometry: &ImageGeometry,
    values: Vec<f32>,
    params: &TissuesFromScanParams,
    scan_path: &str,
    thresholds: &str,
    go_on: &mut dyn FnMut(f64) -> bool,
) -> Result<Vec<ToothSurfaces>, String> {
    let (scan, request) = scan_request(geometry, values, params, scan_path, thresholds)?;
    let teeth = request.run_all_until(&scan, &TissueTable::default(), &mut |_, f| go_on(0.9 * f)).map_err(|e| e.to_string())?;
    teeth
        .iter()
        .map(|(model, report)| {
            let (n, found) = report.found.clone().ok_or("a tooth without its place")?;
            let mut tissues = unchanged_surfaces(model)?;
            attach_warnings(&mut tissues, &report.warnings);
            Ok(ToothSurfaces { tooth: n as u32, seed_mm: found.seed, cut_by_field_of_view: found.cut_by_field_of_view, tissues })
        })
        .collect()
}

/// The scan and what to segment in it (the seed point only when `params.use_seed`).
fn scan_request(
    geometry: &ImageGeometry,
    values: Vec<f32>,
    params: &TissuesFromScanParams,
    scan_path: &str,
    thresholds: &str,
) -> Result<(dentsim_cbct::Volume, dentsim_sim::tissues::from_scan::TissuesFromScan), String> {
    let thresholds = if thresholds.trim().is_empty() { None } else { Some(dentsim_cbct::calibrate::parse_thresholds(thresholds).map_err(|e| e.to_string())?) };
    let scan = scan_of(geometry, values, scan_path)?;
    let request = dentsim_sim::tissues::from_scan::TissuesFromScan {
        voxel_size_mm: params.voxel_size_mm,
        fdi: params.fdi,
        seed_mm: params.use_seed.then_some(params.seed_mm),
        thresholds,
        keep_shading: params.keep_shading,
        ..Default::default()
    };
    Ok((scan, request))
}

/// The scan: its file through dentsim's reader when `scan_path` is given, else the image ParaView
/// passed.
fn scan_of(geometry: &ImageGeometry, values: Vec<f32>, scan_path: &str) -> Result<dentsim_cbct::Volume, String> {
    if !scan_path.is_empty() {
        return dentsim_cbct::read(scan_path, &dentsim_cbct::ReadOptions::default()).map_err(|e| e.to_string());
    }
    let d = geometry.direction;
    let direction = [[d[0], d[3], d[6]], [d[1], d[4], d[7]], [d[2], d[5], d[8]]];
    let source = dentsim_cbct::SourceInfo { format: "vtkImageData".into(), path: "ParaView input".into(), ..Default::default() };
    dentsim_cbct::Volume::new(geometry.dims.map(|n| n as usize), geometry.spacing, geometry.origin, direction, values, source).map_err(|e| format!("input image: {e}"))
}

/// A tool path cut into the tissues (or the phantom); see `sim::prepare::PreparationRequest`.
pub fn prepare_tissues(
    params: &PreparationParams,
    points: &[f64],
    orientation: &[f64],
    time: &[f64],
    rpm: &[f64],
    cut: &[f64],
) -> Result<Vec<TissueSurface>, String> {
    let path = OwnedPath { points: points.to_vec(), orientation: orientation.to_vec(), time: time.to_vec(), rpm: rpm.to_vec(), cut: cut.to_vec() };
    guarded("dental preparation", || prepare_owned(params, None, &path, &mut |_| true))
}

/// A polyline's arrays, owned so that a job's thread can hold them.
#[derive(Default)]
struct OwnedPath {
    points: Vec<f64>,
    orientation: Vec<f64>,
    time: Vec<f64>,
    rpm: Vec<f64>,
    cut: Vec<f64>,
}

fn prepare_owned(
    params: &PreparationParams,
    tissues: Option<dentsim_sim::tissues::model::TissueModel>,
    p: &OwnedPath,
    go_on: &mut dyn FnMut(f64) -> bool,
) -> Result<Vec<TissueSurface>, String> {
    use dentsim_sim::plan::prepare::{PathSource, PreparationRequest};
    let path = if params.use_polyline {
        let arrays = dentsim_sim::plan::path::PolylineArrays { points: &p.points, orientation: &p.orientation, time: &p.time, rpm: &p.rpm, cut: &p.cut };
        PathSource::Polyline(arrays)
    } else if params.path_csv.is_empty() {
        return Err("Tool Path: neither a polyline input nor a Tool Path File (CSV) was given".into());
    } else {
        PathSource::Csv(std::path::Path::new(params.path_csv.as_str()))
    };
    let from_file = tissues.is_none() && !params.tissues_path.is_empty();
    let request = PreparationRequest {
        tissues: from_file.then(|| std::path::Path::new(params.tissues_path.as_str())),
        phantom_voxel_mm: params.phantom_voxel_mm,
        path,
        burr: &params.burr,
        force_n: params.force_n,
    };
    let files = [("Tissues File", params.tissues_path.as_str()), ("Tool Path File (CSV)", params.path_csv.as_str())];
    let prepared = request.run_until(&TissueTable::default(), tissues, go_on).map_err(|e| name_property(e.to_string(), &files))?;
    cut_surfaces(&prepared.model, &prepared.tissues)
}

/// A model rebuilt from the pipeline's tissue surfaces (the "Tissues" input).
/// Tissue surfaces from the pipeline as level sets at `voxel_mm`; errors name the input (`what`).
fn model_from_inputs(what: &str, tissues: &[InputSurface], voxel_mm: f64) -> Result<dentsim_sim::tissues::model::TissueModel, String> {
    let surfaces: Vec<(String, TriMesh)> = tissues
        .iter()
        .map(|s| {
            let points = s.points.chunks_exact(3).map(|p| glam::Vec3::new(p[0], p[1], p[2])).collect::<Vec<_>>();
            if s.points.len() % 3 != 0 || s.triangles.len() % 3 != 0 || s.triangles.iter().any(|&i| i as usize >= points.len()) {
                return Err(format!("{what}: block '{}' is not a triangle surface", s.name));
            }
            let triangles = s.triangles.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
            Ok((s.name.clone(), TriMesh { points, normals: Vec::new(), triangles }))
        })
        .collect::<Result<_, _>>()?;
    dentsim_sim::tissues::model::TissueModel::from_surfaces(what, &surfaces, voxel_mm, &TissueTable::default()).map_err(|e| e.to_string())
}

/// Work on its own thread: the plugin polls `progress`/`finished`, may `abort`, then `wait`s.
pub struct Job<T: Send + 'static> {
    progress: std::sync::Arc<std::sync::atomic::AtomicU64>,
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
    handle: Option<std::thread::JoinHandle<Result<T, String>>>,
}

/// A job whose result is tissue surfaces (a preparation, a segmentation).
pub type SurfaceJob = Job<Vec<TissueSurface>>;
/// A job whose result is batch report rows.
pub type RowsJob = Job<Vec<BatchRow>>;
/// A job whose result is every tooth's tissue surfaces.
pub type TeethJob = Job<Vec<ToothSurfaces>>;
/// A job whose result is an assessment.
pub type AssessmentJob = Job<AssessmentResult>;

impl<T: Send + 'static> Job<T> {
    /// Runs `work(go_on)` on a thread; `go_on(fraction)` books progress and says whether to go on.
    fn spawn(what: &'static str, work: impl FnOnce(&mut dyn FnMut(f64) -> bool) -> Result<T, String> + Send + 'static) -> Result<Box<Self>, String> {
        use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
        let progress = std::sync::Arc::new(AtomicU64::new(0f64.to_bits()));
        let stop = std::sync::Arc::new(AtomicBool::new(false));
        let (p, s) = (progress.clone(), stop.clone());
        let handle = std::thread::Builder::new()
            .name(what.into())
            .spawn(move || {
                guarded(what, move || {
                    let result = work(&mut |f| {
                        p.store(f.clamp(0.0, 1.0).to_bits(), Ordering::Relaxed);
                        !s.load(Ordering::Relaxed)
                    });
                    // Work that cannot stop part-way still ends as aborted when asked to.
                    match result {
                        Ok(_) if s.load(Ordering::Relaxed) => Err(format!("{what}: {}", dentsim_sim::error::STOPPED)),
                        other => other,
                    }
                })
            })
            .map_err(|e| format!("{what}: cannot start a thread: {e}"))?;
        Ok(Box::new(Job { progress, stop, handle: Some(handle) }))
    }

    fn progress(&self) -> f64 {
        f64::from_bits(self.progress.load(std::sync::atomic::Ordering::Relaxed))
    }

    fn finished(&self) -> bool {
        self.handle.as_ref().map_or(true, |h| h.is_finished())
    }

    fn abort(&self) {
        self.stop.store(true, std::sync::atomic::Ordering::Relaxed);
    }

    fn wait(&mut self) -> Result<T, String> {
        match self.handle.take() {
            Some(h) => h.join().unwrap_or_else(|_| Err("job: internal error".into())),
            None => Err("job: already waited for".into()),
        }
    }
}

impl<T: Send + 'static> Drop for Job<T> {
    fn drop(&mut self) {
        self.abort();
        if let Some(h) = self.handle.take() {
            let _ = h.join();
        }
    }
}

/// The segmentation `work` of a scan's arguments (owned, so that the job's thread holds them).
type ScanWork<T> = fn(&ImageGeometry, Vec<f32>, &TissuesFromScanParams, &str, &str, &mut dyn FnMut(f64) -> bool) -> Result<T, String>;

fn scan_job<T: Send + 'static>(what: &'static str, work: ScanWork<T>, geometry: &ImageGeometry, values: &[f32], params: &TissuesFromScanParams, scan_path: &str, thresholds: &str) -> Result<Box<Job<T>>, String> {
    let (geometry, params) = (geometry.clone(), params.clone());
    let (values, scan_path, thresholds) = (values.to_vec(), scan_path.to_owned(), thresholds.to_owned());
    Job::spawn(what, move |go_on| work(&geometry, values, &params, &scan_path, &thresholds, go_on))
}

pub fn start_tissues_from_scan(geometry: &ImageGeometry, values: &[f32], params: &TissuesFromScanParams, scan_path: &str, thresholds: &str) -> Result<Box<SurfaceJob>, String> {
    scan_job("tissues from scan", segment_scan, geometry, values, params, scan_path, thresholds)
}

pub fn start_teeth_from_scan(geometry: &ImageGeometry, values: &[f32], params: &TissuesFromScanParams, scan_path: &str, thresholds: &str) -> Result<Box<TeethJob>, String> {
    scan_job("teeth from scan", segment_teeth, geometry, values, params, scan_path, thresholds)
}

pub fn start_assessment(
    params: &AssessmentParams,
    prepared: &[InputSurface],
    original: &[InputSurface],
    reference: &[InputSurface],
    voxel_mm: f64,
) -> Result<Box<AssessmentJob>, String> {
    let params = AssessmentParams {
        prepared_path: params.prepared_path.clone(),
        original_path: params.original_path.clone(),
        reference_path: params.reference_path.clone(),
        crown: params.crown,
        use_axis: params.use_axis,
        axis: params.axis,
    };
    let [prepared, original, reference] = [prepared, original, reference].map(owned_surfaces);
    Job::spawn("assess preparation", move |go_on| assess_until(&params, &prepared, &original, &reference, voxel_mm, go_on))
}

/// Surfaces passed from C++, owned so that a job's thread can hold them.
fn owned_surfaces(surfaces: &[InputSurface]) -> Vec<InputSurface> {
    surfaces.iter().map(|s| InputSurface { name: s.name.clone(), points: s.points.clone(), triangles: s.triangles.clone() }).collect()
}

pub fn start_batch_shard(manifest: &str, out: &str, index: u32, count: u32) -> Result<Box<RowsJob>, String> {
    let (manifest, out) = (manifest.to_owned(), out.to_owned());
    Job::spawn("batch plan", move |go_on| batch_shard_until(&manifest, &out, index, count, &mut |_, f| go_on(f)))
}

#[allow(clippy::too_many_arguments)]
pub fn start_preparation(
    params: &PreparationParams,
    tissues: &[InputSurface],
    tissue_voxel_mm: f64,
    points: &[f64],
    orientation: &[f64],
    time: &[f64],
    rpm: &[f64],
    cut: &[f64],
) -> Result<Box<SurfaceJob>, String> {
    let params = params.clone();
    let path = OwnedPath { points: points.to_vec(), orientation: orientation.to_vec(), time: time.to_vec(), rpm: rpm.to_vec(), cut: cut.to_vec() };
    let tissues = owned_surfaces(tissues);
    Job::spawn("dental preparation", move |go_on| {
        let model = if tissues.is_empty() { None } else { Some(model_from_inputs("Tissues", &tissues, tissue_voxel_mm)?) };
        prepare_owned(&params, model, &path, go_on)
    })
}

/// Label, name, colour and opacity of every tissue (and the session's burr, label 0) as the
/// `array_lookup_tables` settings ParaView reads when it first colours by an array of that name.
fn tissue_colour_settings() -> String {
    let table = TissueTable::default();
    let (mut annotations, mut colours, mut opacities) = (Vec::new(), Vec::new(), Vec::new());
    for (label, name, colour) in SESSION_LABELS {
        annotations.push(serde_json::json!(label.to_string()));
        annotations.push(serde_json::json!(name));
        colours.extend(colour);
        opacities.push(1.0f32);
    }
    for t in &table.tissues {
        annotations.push(serde_json::json!(t.label.to_string()));
        annotations.push(serde_json::json!(t.name));
        colours.extend(t.colour);
        opacities.push(t.opacity);
    }
    serde_json::json!({
        "array_lookup_tables": { "Tissue": {
            "Title": "Tissue",
            "PVLookupTable": {
                "IndexedLookup": 1,
                "AnnotationsInitialized": 1,
                "Annotations": annotations,
                "IndexedColors": colours,
                "IndexedOpacities": opacities,
                "EnableOpacityMapping": 1,
                // The legend lists the tissues present, not the whole table.
                "ShowIndexedColorActiveValues": 1,
            }
        }}
    })
    .to_string()
}

fn batch_rows(reports: &[dentsim_sim::plan::batch::CaseReport]) -> Vec<BatchRow> {
    let row = |r: &dentsim_sim::plan::batch::CaseReport, t: &TissueVolumes| BatchRow {
        case_name: r.case.clone(),
        scan: r.scan.clone(),
        preparation: r.preparation.clone(),
        burr: r.burr.clone(),
        tissue: t.name.clone(),
        removed_mm3: t.removed_mm3,
        volume_before_mm3: t.volume_before_mm3,
        volume_after_mm3: t.volume_after_mm3,
        seconds: r.seconds,
    };
    reports.iter().flat_map(|r| r.tissues.iter().map(move |t| row(r, t))).collect()
}

fn read_manifest(manifest: &str) -> Result<dentsim_sim::plan::batch::Manifest, String> {
    if manifest.trim().is_empty() {
        return Err("Manifest File: no file given".into());
    }
    dentsim_sim::plan::batch::Manifest::read(std::path::Path::new(manifest)).map_err(|e| format!("Manifest File: {e}"))
}

fn batch_shard(manifest: &str, out: &str, index: u32, count: u32) -> Result<Vec<BatchRow>, String> {
    guarded("batch plan", || batch_shard_until(manifest, out, index, count, &mut |_, _| true))
}

fn batch_shard_until(manifest: &str, out: &str, index: u32, count: u32, go_on: &mut dyn FnMut(&str, f64) -> bool) -> Result<Vec<BatchRow>, String> {
    use dentsim_sim::plan::batch::{run_shard_until, Shard};
    let m = read_manifest(manifest)?;
    if out.trim().is_empty() {
        return Err("Output Directory: no folder given".into());
    }
    let shard = Shard::new(index as usize, count as usize).map_err(|e| e.to_string())?;
    let reports = run_shard_until(&m, std::path::Path::new(out), shard, &TissueTable::default(), go_on).map_err(|e| e.to_string())?;
    Ok(batch_rows(&reports))
}

fn batch_merge(manifest: &str, out: &str, shards: u32) -> Result<Vec<BatchRow>, String> {
    guarded("batch plan", || {
        let m = read_manifest(manifest)?;
        let reports = dentsim_sim::plan::batch::merge(&m, std::path::Path::new(out), shards as usize).map_err(|e| e.to_string())?;
        Ok(batch_rows(&reports))
    })
}

/// The burr's label and colour in the session's output (its `Tissue` cell array).
const BURR_LABEL: i32 = 0;
/// The session's own blocks in the `Tissue` colour map, beside the tissues' labels (1 and up):
/// the burr by live guidance's warning level, then the force arrow.
const SESSION_LABELS: [(i32, &str, [f32; 3]); 4] = [
    (BURR_LABEL, "burr", [0.75, 0.75, 0.8]),
    (-1, "burr near the pulp", [1.0, 0.67, 0.0]),
    (-2, "burr in the pulp", [0.9, 0.0, 0.47]),
    (-3, "force", [0.86, 0.12, 0.12]),
];

fn burr_label(warning_level: u8) -> i32 {
    SESSION_LABELS[usize::from(warning_level.min(2))].0
}

fn force_label() -> i32 {
    SESSION_LABELS[3].0
}

/// Surfaces of a cut model with each tissue's volume figures.
fn cut_surfaces(model: &dentsim_sim::tissues::model::TissueModel, volumes: &[TissueVolumes]) -> Result<Vec<TissueSurface>, String> {
    model.tissues.iter().zip(volumes).map(|(t, v)| surface(t, v)).collect()
}

/// Surfaces of a model nothing has cut yet.
fn unchanged_surfaces(model: &dentsim_sim::tissues::model::TissueModel) -> Result<Vec<TissueSurface>, String> {
    cut_surfaces(model, &TissueVolumes::unchanged(model))
}

/// A tissue's mesh and properties with the volumes the caller measured.
fn surface(t: &Tissue, v: &TissueVolumes) -> Result<TissueSurface, String> {
    let mesh = dentsim_sim::tissues::surface::surface(&t.grid).map_err(|e| e.to_string())?;
    Ok(mesh_surface(&t.props, &mesh, v.volume_before_mm3, v.volume_after_mm3, v.removed_mm3))
}

fn mesh_surface(p: &TissueProps, mesh: &TriMesh, volume_before_mm3: f64, volume_after_mm3: f64, removed_mm3: f64) -> TissueSurface {
    TissueSurface {
        name: p.name.clone(),
        label: p.label.into(),
        colour: p.colour,
        opacity: p.opacity,
        stiffness_n_per_mm: p.stiffness_n_per_mm,
        damping_n_s_per_mm: p.damping_n_s_per_mm,
        removal_rate_mm3_per_n_s: p.removal_rate_mm3_per_n_s,
        volume_before_mm3,
        volume_after_mm3,
        removed_mm3,
        points: mesh.points.iter().flat_map(|v| v.to_array()).collect(),
        normals: mesh.normals.iter().flat_map(|v| v.to_array()).collect(),
        triangles: mesh.triangles.iter().flatten().copied().collect(),
        warnings: Vec::new(),
    }
}

/// A segmentation's warnings on the surfaces they concern: a clipped or beam-hardening
/// restoration's on the enamel's (the enamel and dentin beside it); the others are about the pulp, so on the pulp's,
/// or where none was found, on the dentin's (the tissue the lost pulp was read as).
fn attach_warnings(surfaces: &mut [TissueSurface], warnings: &[String]) {
    let at = |surfaces: &[TissueSurface], name: &str| surfaces.iter().position(|s| s.name == name);
    for w in warnings {
        let holder = if w.starts_with(dentsim_sim::tissues::warnings::SATURATED_METAL) || w.starts_with(dentsim_sim::tissues::warnings::HARDENED_METAL) {
            at(surfaces, "enamel").or_else(|| at(surfaces, "dentin"))
        } else if w.starts_with(dentsim_sim::tissues::warnings::SHADING) {
            at(surfaces, "dentin").or_else(|| at(surfaces, "enamel"))
        } else {
            at(surfaces, "pulp").or_else(|| at(surfaces, "dentin"))
        };
        if let Some(i) = holder.or((!surfaces.is_empty()).then_some(0)) {
            surfaces[i].warnings.push(w.clone());
        }
    }
}

/// A live session behind an opaque box: the plugin polls it; dropping it stops the threads.
pub struct HapticSession {
    live: LiveSession,
    last: LiveState,
}

fn default_session() -> SessionParams {
    SessionParams {
        tissues_path: String::new(),
        phantom_voxel_mm: dentsim_sim::tissues::model::DEFAULT_VOXEL_MM,
        device: String::new(),
        profile: dentsim_sim::devices::DeviceProfile::DEFAULT_NAME.into(),
        filter: dentsim_sim::haptics::filter::FilterSpec::DEFAULT_NAME.into(),
        realtime: true,
        burr: dentsim_sim::haptics::tick::DEFAULT_BURR.into(),
        log_path: String::new(),
    }
}

pub fn start_session(params: &SessionParams) -> Result<Box<HapticSession>, String> {
    guarded("haptic session", || {
        let request = LiveRequest {
            tissues: (!params.tissues_path.is_empty()).then(|| params.tissues_path.clone().into()),
            phantom_voxel_mm: params.phantom_voxel_mm,
            device: params.device.clone(),
            profile: params.profile.clone(),
            filter: params.filter.clone(),
            realtime: params.realtime,
            mesher_hz: dentsim_sim::session::threads::DEFAULT_MESHER_HZ,
        };
        let scripted = params.device.strip_prefix("scripted:").unwrap_or("");
        let files = [("Tissues File", params.tissues_path.as_str()), ("Scripted Path (CSV)", scripted)];
        let log = (!params.log_path.is_empty()).then(|| std::path::PathBuf::from(&params.log_path));
        let files = [files[0], files[1], ("Session Log", params.log_path.as_str())];
        let live = LiveSession::start_logged(&request, &params.burr, log).map_err(|e| name_property(e.to_string(), &files))?;
        Ok(Box::new(HapticSession { live, last: LiveState::default() }))
    })
}

impl HapticSession {
    fn poll(&mut self) -> Result<SessionState, String> {
        guarded("haptic session poll", || {
            let s = self.live.poll().map_err(|e| e.to_string())?;
            Ok(self.state(s))
        })
    }

    fn stop(&mut self) -> Result<SessionState, String> {
        guarded("haptic session stop", || {
            let s = self.live.stop().map_err(|e| e.to_string())?;
            Ok(self.state(s))
        })
    }

    fn set_paused(&mut self, paused: bool) {
        self.live.set_paused(paused);
    }

    fn state(&mut self, s: LiveState) -> SessionState {
        self.last = s.clone();
        SessionState {
            tick: s.tick,
            time_s: s.t_s,
            running: s.running,
            burr_position_mm: s.proxy.to_array(),
            device_position_mm: s.pose.translation.to_array(),
            force_n: s.force.to_array(),
            contact_tissue: s.tissue.clone().unwrap_or_default(),
            mesh_generation: s.mesh_generation,
            remaining_dentin_mm: if s.clearance_mm.is_finite() { s.clearance_mm } else { f64::NAN },
            warning_level: s.warning_level(),
            thin_dentin_mm: s.guidance.thin_dentin_mm,
            thin_dentin_events: s.guidance.thin_dentin_events,
            pulp_exposure_events: s.guidance.pulp_exposure_events,
            workspace_centre_mm: s.workspace.map_or([0.0; 3], |w| w.0.to_array()),
            workspace_radius_mm: s.workspace.map_or(0.0, |w| w.1),
        }
    }

    fn tissue_surfaces(&self) -> Result<Vec<TissueSurface>, String> {
        guarded("haptic session surfaces", || {
            let volumes = self.live.volumes_mm3();
            Ok(self
                .live
                .tissues()
                .iter()
                .zip(self.live.meshes())
                .zip(volumes)
                .map(|((p, m), (before, after))| mesh_surface(p, m, before, after, before - after))
                .collect())
        })
    }

    fn burr_surface(&self) -> Result<TissueSurface, String> {
        guarded("haptic session burr", || {
            let mesh = self.live.burr_at(&self.last);
            let props = TissueProps {
                name: "burr".into(),
                label: 0,
                colour: [0.75, 0.75, 0.8],
                opacity: 1.0,
                stiffness_n_per_mm: 0.0,
                damping_n_s_per_mm: 0.0,
                removal_rate_mm3_per_n_s: 0.0,
            };
            let v = mesh.volume();
            Ok(mesh_surface(&props, &mesh, v, v, 0.0))
        })
    }
}

fn version() -> String {
    env!("CARGO_PKG_VERSION").to_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn assessing_a_missing_file_names_the_property() {
        let params = AssessmentParams {
            prepared_path: "/nonexistent/prepared.vdb".into(),
            original_path: String::new(),
            reference_path: String::new(),
            crown: false,
            use_axis: false,
            axis: [0.0; 3],
        };
        let err = assess_preparation(&params).err().unwrap();
        assert!(err.contains("Prepared Tissues") && err.contains("prepared.vdb"), "{err}");
    }

    #[test]
    fn bad_parameters_come_back_as_errors() {
        let params = StrokeParams { voxel_size_mm: -1.0, ..default_stroke() };
        let err = phantom_stroke(&params).err().expect("refused");
        assert!(err.contains("voxel size"), "{err}");
    }

    #[test]
    fn each_warning_goes_on_the_tissue_it_concerns() {
        let named = |name: &str| TissueSurface {
            name: name.into(),
            label: 0,
            colour: [0.0; 3],
            opacity: 1.0,
            stiffness_n_per_mm: 0.0,
            damping_n_s_per_mm: 0.0,
            removal_rate_mm3_per_n_s: 0.0,
            volume_before_mm3: 0.0,
            volume_after_mm3: 0.0,
            removed_mm3: 0.0,
            points: Vec::new(),
            normals: Vec::new(),
            triangles: Vec::new(),
            warnings: Vec::new(),
        };
        let clipped = dentsim_sim::tissues::warnings::saturated_metal_warning(32767.0, 300, 12.0, 600.0, None).unwrap();
        let mut surfaces = vec![named("enamel"), named("dentin"), named("pulp")];
        let cupping = dentsim_cbct::bloom::Cupping { brightest: 7514.0, middle: 6440.0 };
        let hardened = dentsim_sim::tissues::warnings::hardened_metal_warning(&cupping, 2886.0, 0.82, 27.7, 480.0).unwrap();
        attach_warnings(&mut surfaces, &["the pulp's canals were not found".into(), clipped.clone(), hardened.clone()]);
        assert_eq!(surfaces[0].warnings, vec![clipped, hardened]);
        assert!(surfaces[1].warnings.is_empty());
        assert_eq!(surfaces[2].warnings, vec!["the pulp's canals were not found".to_string()]);
    }

    #[test]
    fn panics_become_errors() {
        let err = guarded::<()>("probe", || panic!("boom")).unwrap_err();
        assert_eq!(err, "probe: internal error: boom");
    }

    #[test]
    fn images_with_bad_geometry_or_values_are_refused() {
        let geometry = ImageGeometry { dims: [4, 4, 4], spacing: [0.2; 3], origin: [0.0; 3], direction: [1., 0., 0., 0., 1., 0., 0., 0., 1.] };
        let params = TissuesFromScanParams { voxel_size_mm: 0.05, fdi: 36, use_seed: false, seed_mm: [0.0; 3], keep_shading: false };
        let err = tissues_from_scan(&geometry, &[0.0; 10], &params).err().expect("refused");
        assert!(err.contains("input image"), "{err}");
        let mut values = vec![0.0f32; 64];
        values[5] = f32::NAN;
        let err = tissues_from_scan(&geometry, &values, &params).err().expect("refused");
        assert!(err.to_lowercase().contains("nan"), "{err}");
        let params = TissuesFromScanParams { fdi: 19, ..params };
        let err = tissues_from_scan(&geometry, &vec![0.0f32; 64], &params).err().expect("refused");
        assert!(err.contains("19"), "{err}");
    }

    #[test]
    fn reading_a_missing_file_names_it() {
        let err = read_tissues("/nonexistent/tissues.vdb").err().expect("refused");
        assert!(err.contains("/nonexistent/tissues.vdb"), "{err}");
    }

    #[test]
    fn live_session_runs_and_reports_bad_devices() {
        let err = start_session(&SessionParams { device: "hand:push=x".into(), ..default_session() }).err().expect("refused");
        assert!(err.contains("field 'push'"), "{err}");
        let (s, state) = run_down_onto_the_phantom(default_session().burr);
        assert_eq!(state.tick, 301);
        assert_eq!(state.contact_tissue, "enamel");
        assert!(state.force_n[2] > 0.1, "{:?}", state.force_n);
        let names: Vec<String> = s.tissue_surfaces().unwrap().into_iter().map(|t| t.name).collect();
        assert_eq!(names, ["enamel", "dentin", "pulp"]);
        let burr = s.burr_surface().unwrap();
        let top = burr.points.chunks(3).map(|p| f64::from(p[2])).fold(f64::MIN, f64::max);
        assert!((top - (state.burr_position_mm[2] + 1.0)).abs() < 0.05, "{top}");
    }

    /// A simulated hand pressing 0.3 s down onto the capsule phantom's top with `burr`, polled
    /// to its end.
    fn run_down_onto_the_phantom(burr: String) -> (Box<HapticSession>, SessionState) {
        let params = SessionParams {
            phantom_voxel_mm: 0.1,
            device: "hand:start=0:0:5.8,target=0:0:4.0,duration=0.3".into(),
            realtime: false,
            burr,
            ..default_session()
        };
        let mut s = start_session(&params).unwrap();
        let mut state = s.poll().unwrap();
        while state.running {
            std::thread::sleep(std::time::Duration::from_millis(5));
            state = s.poll().unwrap();
        }
        (s, state)
    }

    #[test]
    fn live_session_cuts_with_the_burr_it_names() {
        let err = start_session(&SessionParams { burr: "cone:1".into(), ..default_session() }).err().expect("refused");
        assert!(err.contains("burr 'cone:1'") && err.contains("shape 'cone'"), "{err}");
        let (s, state) = run_down_onto_the_phantom("cylinder_flat:1.2:3".into());
        assert_eq!(state.contact_tissue, "enamel");
        // The burr drawn is the cylinder: 3 mm tall and 1.2 mm across.
        let burr = s.burr_surface().unwrap();
        let extent = |axis: usize| {
            let v = burr.points.chunks(3).map(|p| f64::from(p[axis]));
            v.clone().fold(f64::MIN, f64::max) - v.fold(f64::MAX, f64::min)
        };
        assert!((extent(2) - 3.0).abs() < 0.1 && (extent(0) - 1.2).abs() < 0.1, "{} × {}", extent(0), extent(2));
    }

    fn groove_params(burr: &str) -> PreparationParams {
        PreparationParams {
            tissues_path: String::new(),
            phantom_voxel_mm: 0.1,
            burr: burr.into(),
            force_n: 0.0,
            use_polyline: true,
            path_csv: String::new(),
        }
    }

    /// A groove along x 1 mm deep into the top of the capsule phantom (top at z = 5), burr upright.
    fn groove() -> (Vec<f64>, Vec<f64>) {
        let points: Vec<f64> = (0..=20).flat_map(|i| [-1.0 + 0.1 * f64::from(i), 0.0, 4.0]).collect();
        let orientation: Vec<f64> = (0..=20).flat_map(|_| [1.0, 0.0, 0.0, 0.0]).collect();
        (points, orientation)
    }

    #[test]
    fn a_polyline_preparation_removes_enamel_and_books_the_volumes() {
        let (points, orientation) = groove();
        let surfaces = prepare_tissues(&groove_params("round:1.0"), &points, &orientation, &[], &[], &[]).unwrap();
        let names: Vec<_> = surfaces.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names, ["enamel", "dentin", "pulp"]);
        assert!(surfaces[0].removed_mm3 > 1.0, "{}", surfaces[0].removed_mm3);
        assert_eq!(surfaces[2].removed_mm3, 0.0);
        for s in &surfaces {
            let d = s.volume_before_mm3 - s.volume_after_mm3 - s.removed_mm3;
            assert!(d.abs() < 1e-6 * s.volume_before_mm3, "{}: {d}", s.name);
        }
    }

    #[test]
    fn bad_preparation_inputs_name_the_field() {
        let (points, mut orientation) = groove();
        let err = prepare_tissues(&groove_params("oval:1.0"), &points, &orientation, &[], &[], &[]).err().expect("refused");
        assert!(err.contains("burr 'oval:1.0'"), "{err}");
        orientation[4 * 3 + 1] = f64::NAN;
        let err = prepare_tissues(&groove_params("round:1.0"), &points, &orientation, &[], &[], &[]).err().expect("refused");
        assert!(err.contains("point 3 array Orientation"), "{err}");
        let err = prepare_tissues(&groove_params("round:1.0"), &points, &orientation[..8], &[], &[], &[]).err().expect("refused");
        assert!(err.contains("array Orientation") && err.contains("21 points"), "{err}");
        let params = PreparationParams { use_polyline: false, path_csv: "/nonexistent/path.csv".into(), ..groove_params("round:1.0") };
        let err = prepare_tissues(&params, &[], &[], &[], &[], &[]).err().expect("refused");
        assert!(err.contains("/nonexistent/path.csv"), "{err}");
    }

    #[test]
    fn a_preparation_job_cuts_upstream_surfaces_and_stops_when_aborted() {
        let (points, orientation) = groove();
        let upstream = phantom_stroke(&StrokeParams { voxel_size_mm: 0.1, start_mm: [20.0; 3], end_mm: [21.0, 20.0, 20.0], ..default_stroke() }).unwrap();
        let inputs: Vec<InputSurface> =
            upstream.iter().map(|s| InputSurface { name: s.name.clone(), points: s.points.clone(), triangles: s.triangles.clone() }).collect();
        let mut job = start_preparation(&groove_params("round:1.0"), &inputs, 0.1, &points, &orientation, &[], &[], &[]).unwrap();
        let surfaces = job.wait().unwrap();
        assert_eq!(job.progress(), 1.0);
        let direct = prepare_tissues(&groove_params("round:1.0"), &points, &orientation, &[], &[], &[]).unwrap();
        let (ours, theirs) = (surfaces[0].removed_mm3, direct[0].removed_mm3);
        assert!((ours / theirs - 1.0).abs() < 0.05, "enamel removed from rebuilt tissues {ours} vs {theirs}");

        let job = start_preparation(&groove_params("round:1.0"), &inputs, 0.1, &points, &orientation, &[], &[], &[]).unwrap();
        job.abort();
        let mut job = job;
        let err = job.wait().err().expect("aborted");
        assert!(err.contains(dentsim_sim::plan::prepare::ABORTED), "{err}");

        let bad = vec![InputSurface { name: "burr".into(), ..inputs[0].clone_surface() }];
        let err = start_preparation(&groove_params("round:1.0"), &bad, 0.1, &points, &orientation, &[], &[], &[]).unwrap().wait().err().unwrap();
        assert!(err.contains("Tissues block 'burr'"), "{err}");
    }

    #[test]
    fn an_assessment_job_grades_upstream_surfaces_and_stops_when_aborted() {
        let stroke = |start_mm: [f64; 3], end_mm: [f64; 3]| {
            let surfaces = phantom_stroke(&StrokeParams { voxel_size_mm: 0.1, start_mm, end_mm, ..default_stroke() }).unwrap();
            owned_surfaces(&surfaces.iter().map(|s| InputSurface { name: s.name.clone(), points: s.points.clone(), triangles: s.triangles.clone() }).collect::<Vec<_>>())
        };
        let defaults = default_stroke();
        let prepared = stroke(defaults.start_mm, defaults.end_mm);
        // A stroke that starts and ends far from the tooth leaves it as it was.
        let original = stroke([90.0; 3], [91.0, 90.0, 90.0]);
        let params = AssessmentParams { prepared_path: String::new(), original_path: String::new(), reference_path: String::new(), crown: false, use_axis: false, axis: [0.0; 3] };
        let mut job = start_assessment(&params, &prepared, &original, &[], 0.1).unwrap();
        let graded = job.wait().unwrap();
        assert_eq!(job.progress(), 1.0);
        let direct = assess_preparation_from(&params, &prepared, &original, &[], 0.1).unwrap();
        assert_eq!(graded.json, direct.json, "the job grades as the direct call does");
        let removed = graded.rows.iter().find(|r| r.criterion.contains("removed")).map(|r| r.value).unwrap_or_default();
        assert!(removed > 0.0, "the stroke removed tissue: {:?}", graded.rows.iter().map(|r| (&r.criterion, r.value)).collect::<Vec<_>>());

        let mut job = start_assessment(&params, &prepared, &original, &[], 0.1).unwrap();
        job.abort();
        let err = job.wait().err().expect("aborted");
        assert!(err.contains(dentsim_sim::error::STOPPED), "{err}");
    }

    #[test]
    fn a_segmentation_job_stops_when_aborted() {
        use dentsim_cbct::phantom::{Phantom, PhantomSpec};
        let scan = Phantom::new(&PhantomSpec::default()).scan();
        // ImageGeometry's direction is VTK's matrix (row by row, index axes as columns).
        let direction = std::array::from_fn(|i| scan.direction[i % 3][i / 3]);
        let geometry = ImageGeometry { dims: scan.dims.map(|n| n as u32), spacing: scan.spacing, origin: scan.origin, direction };
        let params = TissuesFromScanParams { voxel_size_mm: 0.1, fdi: 36, use_seed: false, seed_mm: [0.0; 3], keep_shading: false };
        let mut job = start_tissues_from_scan(&geometry, &scan.values, &params, "", "").unwrap();
        job.abort();
        let err = job.wait().err().expect("aborted");
        assert!(err.contains(dentsim_sim::error::STOPPED), "{err}");
        let mut job = start_teeth_from_scan(&geometry, &scan.values, &params, "", "").unwrap();
        job.abort();
        let err = job.wait().err().expect("aborted");
        assert!(err.contains(dentsim_sim::error::STOPPED), "{err}");
    }

    impl InputSurface {
        fn clone_surface(&self) -> InputSurface {
            InputSurface { name: self.name.clone(), points: self.points.clone(), triangles: self.triangles.clone() }
        }
    }

    #[test]
    fn the_tissue_colours_are_the_tables_as_paraview_settings() {
        let settings: serde_json::Value = serde_json::from_str(&tissue_colour_settings()).unwrap();
        let lut = &settings["array_lookup_tables"]["Tissue"]["PVLookupTable"];
        assert_eq!(lut["IndexedLookup"], 1);
        let names: Vec<&str> = lut["Annotations"].as_array().unwrap().iter().skip(1).step_by(2).map(|v| v.as_str().unwrap()).collect();
        let table = TissueTable::default();
        let enamel = table.get("enamel").unwrap();
        let i = names.iter().position(|n| *n == "enamel").unwrap();
        assert_eq!(lut["Annotations"][2 * i], enamel.label.to_string());
        assert!((lut["IndexedOpacities"][i].as_f64().unwrap() - f64::from(enamel.opacity)).abs() < 1e-6);
        assert!(enamel.opacity < 1.0, "enamel is translucent in the table");
        // The session's burr (by warning level) and force arrow have colours of their own.
        for (label, name) in [(burr_label(0), "burr"), (burr_label(1), "burr near the pulp"), (burr_label(2), "burr in the pulp"), (force_label(), "force")] {
            let k = names.iter().position(|n| *n == name).unwrap_or_else(|| panic!("{name}"));
            assert_eq!(lut["Annotations"][2 * k], label.to_string());
            assert!(table.tissues.iter().all(|t| i32::from(t.label) != label), "{name} is no tissue's label");
        }
        assert_eq!(names.len() * 3, lut["IndexedColors"].as_array().unwrap().len());
        for c in 0..3 {
            assert!((lut["IndexedColors"][3 * i + c].as_f64().unwrap() - f64::from(enamel.colour[c])).abs() < 1e-6);
        }
    }

    #[test]
    fn surfaces_carry_tissue_properties() {
        let params = StrokeParams { voxel_size_mm: 0.1, ..default_stroke() };
        let surfaces = phantom_stroke(&params).unwrap();
        let names: Vec<_> = surfaces.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names, ["enamel", "dentin", "pulp"]);
        for s in &surfaces {
            assert_eq!(s.points.len(), s.normals.len());
            assert!(s.triangles.iter().all(|&i| (i as usize) < s.points.len() / 3));
            assert!(s.stiffness_n_per_mm > 0.0);
        }
    }
}
