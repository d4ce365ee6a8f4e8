//! From a CBCT volume to one tooth's tissues: calibrate grey values, segment the tooth, crop to
//! it, and turn each tissue into a smooth narrow-band level set at a voxel size finer than the
//! scan's (the blurred indicator is meshed at 0.5 and converted back, so no staircase remains).
use std::time::Instant;

use dentsim_cbct::phantom::gaussian_blur;
use dentsim_cbct::{calibrate, crop, crop_labels, segment, tooth_box, Calibration, Label, SegmentOptions, ToothSelect, Volume};

use dentsim_vdb::{DenseVolume, LevelSet};
use serde::Serialize;

use crate::error::{invalid, Error, Result};
use crate::model::TissueModel;
use crate::tissue::TissueTable;

#[derive(Clone, Debug)]
pub struct ScanToTissues {
    /// Voxel size of the level sets, mm.
    pub voxel_size_mm: f64,
    /// FDI (ISO 3950) number of the tooth to keep.
    pub fdi: u8,
    /// A point in (or near) the tooth, LPS mm; the scan's centre when absent.
    pub seed_mm: Option<[f64; 3]>,
    /// A box (LPS mm) the tooth lies in.
    pub bounds_mm: Option<([f64; 3], [f64; 3])>,
    /// Grey values per tissue overriding the automatic calibration (at least two).
    pub thresholds: Option<Vec<(Label, f64)>>,
    /// Scan kept around the tooth, mm.
    pub margin_mm: f64,
}

impl Default for ScanToTissues {
    fn default() -> Self {
        ScanToTissues { voxel_size_mm: 0.05, fdi: 36, seed_mm: None, bounds_mm: None, thresholds: None, margin_mm: 1.0 }
    }
}

#[derive(Clone, Debug, Serialize)]
pub struct TissueVolume {
    pub name: String,
    pub volume_mm3: f64,
    /// Voxels of the segmentation at the scan's resolution.
    pub scan_voxels: usize,
    pub active_voxels: u64,
}

#[derive(Clone, Debug, Serialize)]
pub struct ScanReport {
    pub fdi: u8,
    pub voxel_size_mm: f64,
    pub scan_dims: [usize; 3],
    pub scan_spacing_mm: [f64; 3],
    /// Scan voxel box kept around the tooth (min inclusive, max exclusive).
    pub crop_min: [usize; 3],
    pub crop_max: [usize; 3],
    /// Dentin voxels outside the main dentin body, given to the enamel.
    pub dentin_specks_relabelled: usize,
    pub calibration: Calibration,
    pub tissues: Vec<TissueVolume>,
    pub seconds: Timings,
}

#[derive(Clone, Debug, Default, Serialize)]
pub struct Timings {
    pub calibrate: f64,
    pub segment: f64,
    pub crop: f64,
    pub level_sets: f64,
}

impl ScanToTissues {
    pub fn validate(&self) -> Result<()> {
        if !(self.voxel_size_mm.is_finite() && (0.01..=1.0).contains(&self.voxel_size_mm)) {
            return Err(invalid("voxel size", format!("{} mm, expected 0.01 to 1 mm", self.voxel_size_mm)));
        }
        if !dentsim_cbct::segment::valid_fdi(self.fdi) {
            return Err(invalid("tooth", format!("{} is not an ISO 3950 (FDI) tooth number", self.fdi)));
        }
        if !(self.margin_mm.is_finite() && self.margin_mm >= 0.0) {
            return Err(invalid("margin", format!("{} mm", self.margin_mm)));
        }
        Ok(())
    }

    /// Runs every step; `progress(step, fraction)` follows the work.
    pub fn run(&self, scan: &Volume, table: &TissueTable, progress: &mut dyn FnMut(&str, f64)) -> Result<(TissueModel, ScanReport)> {
        self.validate()?;
        let cbct = |e: dentsim_cbct::Error| Error::Invalid { what: format!("scan {}", scan.source.path), message: e.to_string() };
        let mut seconds = Timings::default();

        progress("calibrating grey values", 0.0);
        let clock = Instant::now();
        let calibration = match &self.thresholds {
            Some(values) => Calibration::manual(values).map_err(cbct)?,
            None => calibrate(scan).map_err(cbct)?,
        };
        seconds.calibrate = clock.elapsed().as_secs_f64();

        progress("segmenting", 0.1);
        let clock = Instant::now();
        let seed = self.seed_mm.unwrap_or_else(|| centre_of(scan));
        let options = SegmentOptions {
            tooth: Some(ToothSelect { fdi: self.fdi, seed, bounds: self.bounds_mm }),
            ..SegmentOptions::default()
        };
        let labels = segment(scan, &calibration, &options).map_err(cbct)?;
        seconds.segment = clock.elapsed().as_secs_f64();

        progress("cropping to the tooth", 0.4);
        let clock = Instant::now();
        let region = tooth_box(&labels, self.fdi, None, self.margin_mm).map_err(cbct)?;
        let tooth_scan = crop(scan, &region).map_err(cbct)?;
        let mut tooth_labels = crop_labels(&labels, &region).map_err(cbct)?;
        let specks = keep_largest_component(&mut tooth_labels, Label::Dentin, Label::Enamel);
        seconds.crop = clock.elapsed().as_secs_f64();

        let clock = Instant::now();
        let source = format!("{} {}", scan.source.format, scan.source.path);
        let mut model = TissueModel::new(source, Some(self.fdi));
        let mut tissues = Vec::new();
        let mut builder = NestedBuilder { scan: &tooth_scan, labels: &tooth_labels, voxel_size_mm: self.voxel_size_mm };
        let mut built = 0.0;
        for (label, grid) in builder.build(&mut |name| {
            built += 1.0;
            progress(&format!("level set: {name}"), 0.5 + 0.1 * built);
        })? {
            let props = table
                .get(label.name())
                .cloned()
                .ok_or_else(|| invalid("tissue table", format!("has no '{}'", label.name())))?;
            tissues.push(TissueVolume {
                name: label.name().into(),
                volume_mm3: grid.volume(),
                scan_voxels: tooth_labels.labels.iter().filter(|&&l| l == label as u8).count(),
                active_voxels: grid.active_voxel_count(),
            });
            model.push(props, grid)?;
        }
        seconds.level_sets = clock.elapsed().as_secs_f64();
        if model.tissues.is_empty() {
            return Err(invalid(format!("tooth {}", self.fdi), "no enamel, dentin or pulp found in the scan"));
        }
        progress("done", 1.0);
        let report = ScanReport {
            fdi: self.fdi,
            voxel_size_mm: self.voxel_size_mm,
            scan_dims: scan.dims,
            scan_spacing_mm: scan.spacing,
            crop_min: region.min,
            crop_max: region.max,
            dentin_specks_relabelled: specks,
            calibration,
            tissues,
            seconds,
        };
        Ok((model, report))
    }
}

/// Builds the tooth's tissues from nested unions so that each grid encloses only its own material
/// and neighbours share their interface exactly (DESIGN.md "Tissues"):
/// enamel = tooth ∖ core, dentin = core ∖ pulp ∖ caries, with core = dentin ∪ pulp ∪ caries.
/// Building a shell directly would not do: OpenVDB's mesh-to-level-set decides inside by flooding
/// from outside, so a cavity enclosed by a tissue (the pulp in the dentin) would count as inside.
const UNION_BLUR_VOXELS: f64 = 0.35;
/// Φ(0.5 / σ) for σ = 0.35: the blurred indicator half a voxel inside a flat boundary.
const FLAT_INSIDE: f32 = 0.9234;

struct NestedBuilder<'a> {
    scan: &'a Volume,
    labels: &'a dentsim_cbct::LabelVolume,
    voxel_size_mm: f64,
}

impl NestedBuilder<'_> {
    fn present(&self, label: Label) -> bool {
        self.labels.labels.contains(&(label as u8))
    }

    /// Level set of the union of `labels`: their indicator, blurred (σ = 0.35 voxel) so that the
    /// surface has no staircase, then held to its side of 0.5 where the blur would flip a voxel:
    /// inside voxels keep at least the value a flat boundary gives them (≈ 0.92), outside ones at
    /// most 0.08. Flat and gently curved walls stay smooth, and thin canals or pulp horns,
    /// which a plain blur would narrow or break, keep their width.
    fn union(&self, labels: &[Label]) -> Result<Option<LevelSet>> {
        let codes: Vec<u8> = labels.iter().filter(|l| self.present(**l)).map(|&l| l as u8).collect();
        if codes.is_empty() {
            return Ok(None);
        }
        let mut field: Vec<f32> = self.labels.labels.iter().map(|l| f32::from(u8::from(codes.contains(l)))).collect();
        let inside: Vec<bool> = field.iter().map(|&v| v > 0.5).collect();
        gaussian_blur(&mut field, self.scan.dims, [UNION_BLUR_VOXELS; 3]);
        for (v, inside) in field.iter_mut().zip(inside) {
            *v = if inside { v.max(FLAT_INSIDE) } else { v.min(1.0 - FLAT_INSIDE) };
        }
        self.level_set(&field, 0.5, true).map(Some)
    }

    fn level_set(&self, field: &[f32], iso: f32, inside_above: bool) -> Result<LevelSet> {
        let dims = self.scan.dims.map(|d| d as u32);
        let dense = DenseVolume { dims, index_to_world: self.scan.index_to_world(), values: field };
        Ok(LevelSet::from_dense(&dense, iso, inside_above, self.voxel_size_mm, 3.0)?)
    }

    fn build(&mut self, progress: &mut dyn FnMut(&str)) -> Result<Vec<(Label, LevelSet)>> {
        use Label::{Caries, Dentin, Enamel, Pulp};
        progress("pulp and caries");
        let pulp = self.union(&[Pulp])?;
        let caries = self.union(&[Caries])?;
        progress("dentin");
        let core = self.union(&[Dentin, Pulp, Caries])?;
        progress("enamel");
        let tooth = self.union(&[Enamel, Dentin, Pulp, Caries])?;
        let mut out = Vec::new();
        if let (Some(mut enamel), Some(core)) = (tooth, core.as_ref()) {
            enamel.csg_difference(core)?;
            out.push((Enamel, enamel));
        }
        if let Some(mut dentin) = core {
            for inner in [&pulp, &caries].into_iter().flatten() {
                dentin.csg_difference(inner)?;
            }
            out.push((Dentin, dentin));
        }
        out.extend(pulp.map(|g| (Pulp, g)));
        out.extend(caries.map(|g| (Caries, g)));
        Ok(out)
    }
}

/// Relabels every `label` voxel outside its largest 6-connected component as `replacement`;
/// returns how many. A tooth's dentin is one body: other specks are partial-volume voxels where
/// bright enamel meets dark air through dentin's grey range, and as dentin they would punch holes
/// in the enamel.
fn keep_largest_component(labels: &mut dentsim_cbct::LabelVolume, label: Label, replacement: Label) -> usize {
    let [nx, ny, nz] = labels.dims;
    let code = label as u8;
    let mut component = vec![u32::MAX; labels.labels.len()];
    let mut sizes: Vec<usize> = Vec::new();
    let mut queue = std::collections::VecDeque::new();
    for start in 0..labels.labels.len() {
        if labels.labels[start] != code || component[start] != u32::MAX {
            continue;
        }
        let id = sizes.len() as u32;
        let mut size = 0;
        component[start] = id;
        queue.push_back(start);
        while let Some(n) = queue.pop_front() {
            size += 1;
            let (i, j, k) = (n % nx, (n / nx) % ny, n / (nx * ny));
            let neighbours = [
                (i > 0).then(|| n - 1),
                (i + 1 < nx).then(|| n + 1),
                (j > 0).then(|| n - nx),
                (j + 1 < ny).then(|| n + nx),
                (k > 0).then(|| n - nx * ny),
                (k + 1 < nz).then(|| n + nx * ny),
            ];
            for m in neighbours.into_iter().flatten() {
                if labels.labels[m] == code && component[m] == u32::MAX {
                    component[m] = id;
                    queue.push_back(m);
                }
            }
        }
        sizes.push(size);
    }
    let Some(largest) = (0..sizes.len()).max_by_key(|&c| sizes[c]) else { return 0 };
    let mut moved = 0;
    for (l, c) in labels.labels.iter_mut().zip(&component) {
        if *l == code && *c != largest as u32 {
            *l = replacement as u8;
            moved += 1;
        }
    }
    moved
}

/// The world position of the scan's central voxel.
fn centre_of(scan: &Volume) -> [f64; 3] {
    let m = scan.index_to_world();
    let c = scan.dims.map(|d| (d as f64 - 1.0) / 2.0);
    [0, 1, 2].map(|r| m[4 * r] * c[0] + m[4 * r + 1] * c[1] + m[4 * r + 2] * c[2] + m[4 * r + 3])
}
