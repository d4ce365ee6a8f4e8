//! The demo on the built-in phantom: scan the molar phantom, segment tooth 36 into level sets, and
//! prepare a class I cavity with two burrs: a round burr opens the central fossa down into the
//! dentin, then a flat-end cylinder extends the cavity along the central groove to a flat floor.
use std::path::Path;

use dentsim_cbct::{Label, Phantom, PhantomSpec};
use dentsim_devices::DEFAULT_RPM;
use glam::{DAffine3, DVec3};
use serde::Serialize;

use crate::burr::Burr;
use crate::error::{invalid, Result};
use crate::plan::path::{PathLimits, PathSample, ToolPath};
use crate::plan::prepare::{prepare, PrepareOptions, PrepareReport};
use crate::tissues::export::SUMMARY_NAME;
use crate::tissues::from_scan::{ScanReport, TissuesFromScan};
use crate::tissues::model::{TissueModel, TissueVolumes};
use crate::tissues::table::TissueTable;

const FDI: u8 = 36;
/// Cavity floor below the fossa, mm: through the enamel, into the dentin, clear of the pulp.
const DEPTH_MM: f64 = 2.0;
/// Half the cavity's mesiodistal extent along the central groove, mm.
const HALF_LENGTH_MM: f64 = 1.8;

/// One tissue in the demo's `summary.json`: the phantom's true volume beside the segmented
/// (before) and prepared (after) ones.
#[derive(Clone, Debug, Serialize)]
pub struct TissueOutcome {
    pub true_volume_mm3: f64,
    #[serde(flatten)]
    pub volumes: TissueVolumes,
}

#[derive(Clone, Debug, Serialize)]
pub struct DemoSummary {
    pub phantom: String,
    pub voxel_size_mm: f64,
    pub fossa_mm: [f64; 3],
    pub mesiodistal_axis: [f64; 3],
    pub segmentation: ScanReport,
    pub preparation: Vec<PrepareReport>,
    pub tissues: Vec<TissueOutcome>,
    /// Each tissue's surface triangle count, filled in by [`write`].
    pub triangles: Vec<(String, usize)>,
}

/// Runs the demo; the caller writes the model (see `export::write_model`).
pub fn run(voxel_size_mm: f64, table: &TissueTable, progress: &mut dyn FnMut(&str, f64)) -> Result<(TissueModel, DemoSummary)> {
    progress("making the phantom scan", 0.0);
    let phantom = Phantom::new(&PhantomSpec::default());
    let scan = phantom.scan();
    let request = TissuesFromScan { voxel_size_mm, fdi: FDI, seed_mm: phantom.tooth_seed(FDI), ..Default::default() };
    let (mut model, segmentation) = request.run(&scan, table, &mut |step, f| progress(step, 0.1 + 0.5 * f))?;
    let before = model.volumes();

    progress("planning the class I cavity", 0.6);
    let (fossa, axis) = fossa_and_axis(&phantom, &model)?;
    let round = Burr::parse("round:1.0")?;
    let cylinder = Burr::parse("cylinder_flat:1.0:4")?;
    let floor = fossa - DVec3::Z * DEPTH_MM;
    let access = path(&[fossa + DVec3::Z, floor + DVec3::Z * 0.2, floor - axis * 0.5 + DVec3::Z * 0.2, floor + axis * 0.5 + DVec3::Z * 0.2])?;
    let extension = path(&[
        fossa + DVec3::Z,
        floor,
        floor - axis * HALF_LENGTH_MM,
        floor + axis * HALF_LENGTH_MM,
        floor,
        fossa + DVec3::Z,
    ])?;
    progress("cutting with a round burr", 0.7);
    let mut preparation = vec![prepare(&mut model, &access, &round, &PrepareOptions::default())?];
    progress("cutting with a flat-end cylinder", 0.8);
    preparation.push(prepare(&mut model, &extension, &cylinder, &PrepareOptions::default())?);

    let removed = |name: &str| preparation.iter().map(|r| r.removed_mm3.get(name).copied().unwrap_or(0.0)).sum();
    let tissues = TissueVolumes::of(&model, &before, removed)
        .into_iter()
        .map(|volumes| {
            let true_volume_mm3 = Label::from_name(&volumes.name).map_or(f64::NAN, |l| phantom.tooth_volumes_mm3(FDI)[l as usize]);
            TissueOutcome { true_volume_mm3, volumes }
        })
        .collect();
    progress("done", 0.9);
    let summary = DemoSummary {
        phantom: "dentsim molar phantom (tooth 36 with 35 and 37, 0.2 mm CBCT)".into(),
        voxel_size_mm,
        fossa_mm: fossa.to_array(),
        mesiodistal_axis: axis.to_array(),
        segmentation,
        preparation,
        tissues,
        triangles: Vec::new(),
    };
    Ok((model, summary))
}

/// The enamel surface straight below the tooth's seed (the central fossa), found by stepping
/// down through the enamel level set, and the mesiodistal direction (from tooth 35 to 37).
fn fossa_and_axis(phantom: &Phantom, model: &TissueModel) -> Result<(DVec3, DVec3)> {
    let seed = phantom.tooth_seed(FDI).map(DVec3::from_array).ok_or_else(|| invalid("phantom", "has no tooth 36"))?;
    let (_, hi) = phantom.tooth_bounds(FDI).ok_or_else(|| invalid("phantom", "has no tooth 36"))?;
    let enamel = model.get("enamel").ok_or_else(|| invalid("segmentation", "found no enamel"))?;
    let mut reader = enamel.grid.reader();
    let step = enamel.grid.voxel_size() / 2.0;
    let mut p = DVec3::new(seed.x, seed.y, hi[2] + 1.0);
    while p.z > seed.z - 10.0 {
        if reader.value(p) < 0.0 {
            let (m, d) = (phantom.tooth_seed(35), phantom.tooth_seed(37));
            let axis = match (m, d) {
                (Some(m), Some(d)) => (DVec3::from_array(d) - DVec3::from_array(m)).with_z(0.0).normalize_or_zero(),
                _ => DVec3::X,
            };
            return Ok((p, if axis == DVec3::ZERO { DVec3::X } else { axis }));
        }
        p.z -= step;
    }
    Err(invalid("demo", "found no occlusal enamel above the tooth's seed"))
}

/// An upright burr (axis +Z) moving through `points` at 2 mm/s, cutting throughout; checked as
/// a CSV path is.
fn path(points: &[DVec3]) -> Result<ToolPath> {
    let mut t = 0.0;
    let mut samples = Vec::new();
    for (i, &p) in points.iter().enumerate() {
        if i > 0 {
            t += (p - points[i - 1]).length() / 2.0;
        }
        samples.push(PathSample { t, pose: DAffine3::from_translation(p), rpm: Some(DEFAULT_RPM), cut: true });
    }
    Ok(ToolPath::from_samples(&samples, "demo path", PathLimits::default())?)
}

/// Where `dentsim demo` puts its files.
pub fn write(model: &mut TissueModel, summary: &mut DemoSummary, out: &Path, progress: &mut dyn FnMut(&str, f64)) -> Result<()> {
    crate::tissues::export::all_or_nothing(out, |staged| {
        summary.triangles = crate::tissues::export::write_model(model, staged, progress)?;
        let json = serde_json::to_vec_pretty(summary).map_err(|e| invalid(SUMMARY_NAME, e.to_string()))?;
        Ok(dentsim_atomic::write(&staged.join(SUMMARY_NAME), |w| w.write_all(&json))?)
    })
}
