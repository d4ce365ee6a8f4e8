//! Batch planning of a cohort: a manifest of scans × preparations, run whole or as shard I of N
//! (one job of a cluster array, one MPI rank), each case's figures written beside its prepared
//! tissues, then one merged report. `dentsim batch` and the plugin's "Dental Batch Plan" both
//! call this, so a cohort planned either way gives the same report.
//!
//! Cases are numbered scan-major (every preparation of scan 0, then of scan 1, …) and a shard
//! takes a contiguous run of them, so each scan is read and segmented by as few shards as
//! possible (once per shard that holds one of its cases).
use std::collections::HashMap;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::burr::Burr;
use crate::error::{invalid, Error, Result};
use crate::plan::path::{PathLimits, ToolPath};
use crate::plan::prepare::{prepare, PrepareOptions};
use crate::tissues::model::{TissueModel, TissueVolumes};
use crate::tissues::table::TissueTable;

/// Each case's figures, in `OUT/cases/<case>/`.
pub const CASE_FILE: &str = "case.json";
/// The merged report, in `OUT/`.
pub const REPORT_JSON: &str = "report.json";
pub const REPORT_CSV: &str = "report.csv";

/// Where a scan's tissues come from: exactly one of `tissues`, `scan`, `phantom`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScanEntry {
    pub name: String,
    /// A tissues .vdb (from `dentsim segment` or the plugin).
    pub tissues: Option<PathBuf>,
    /// A CBCT scan (DICOM folder, NIfTI, MetaImage, NRRD) segmented at tooth `fdi` near `seed_mm`.
    pub scan: Option<PathBuf>,
    /// The built-in capsule phantom.
    #[serde(default)]
    pub phantom: bool,
    #[serde(default = "default_fdi")]
    pub fdi: u8,
    pub seed_mm: Option<[f64; 3]>,
    /// Level-set voxel size for a scan or the phantom (mm).
    #[serde(default = "default_voxel")]
    pub voxel_mm: f64,
}

fn default_fdi() -> u8 {
    36
}

fn default_voxel() -> f64 {
    crate::tissues::model::DEFAULT_VOXEL_MM
}

/// A preparation: a tool path (CSV) cut with a burr, geometrically or at a force.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PreparationEntry {
    pub name: String,
    pub path: PathBuf,
    pub burr: String,
    /// 0: the geometric cut; above 0 (N): rate-limited by the tissue table.
    #[serde(default)]
    pub force_n: f64,
}

/// A cohort: every scan is prepared every way (scans × preparations).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    pub scans: Vec<ScanEntry>,
    pub preparations: Vec<PreparationEntry>,
}

/// One case: scan `scan` prepared as `preparation` (indices into the manifest).
#[derive(Clone, Debug, PartialEq)]
pub struct Case {
    pub index: usize,
    pub name: String,
    pub scan: usize,
    pub preparation: usize,
}

/// What a case produced: its inputs' names, each tissue's volumes, and its wall time (s, in
/// its shard: a scan's reading and segmentation count toward the first of its cases there).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CaseReport {
    pub index: usize,
    pub case: String,
    pub scan: String,
    pub preparation: String,
    pub burr: String,
    pub seconds: f64,
    pub tissues: Vec<TissueVolumes>,
}

impl Manifest {
    /// Reads a manifest (JSON); relative paths are taken from the manifest's folder. Errors name
    /// the file and the entry.
    pub fn read(path: &Path) -> Result<Self> {
        let file_err = |message: String| Error::File { path: path.to_owned(), message };
        let text = std::fs::read_to_string(path).map_err(|e| file_err(e.to_string()))?;
        let mut m: Manifest = serde_json::from_str(&text).map_err(|e| file_err(e.to_string()))?;
        let dir = path.parent().unwrap_or(Path::new("."));
        let resolve = |p: &mut PathBuf| {
            if p.is_relative() {
                *p = dir.join(&*p);
            }
        };
        for s in &mut m.scans {
            s.tissues.as_mut().map(resolve);
            s.scan.as_mut().map(resolve);
        }
        for p in &mut m.preparations {
            resolve(&mut p.path);
        }
        m.check().map_err(|e| file_err(e.to_string()))?;
        Ok(m)
    }

    fn check(&self) -> Result<()> {
        if self.scans.is_empty() || self.preparations.is_empty() {
            return Err(invalid("manifest", "needs at least one scan and one preparation"));
        }
        let names = self.scans.iter().map(|s| ("scan", &s.name)).chain(self.preparations.iter().map(|p| ("preparation", &p.name)));
        let mut seen = std::collections::HashSet::new();
        for (kind, name) in names {
            let safe = !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c)) && !name.starts_with('.');
            if !safe {
                return Err(invalid(format!("{kind} '{name}'"), "a name is letters, digits, '-', '_' and '.' (it names the case's folder)"));
            }
            if !seen.insert((kind, name.as_str())) {
                return Err(invalid(format!("{kind} '{name}'"), "appears twice"));
            }
        }
        for s in &self.scans {
            let sources = usize::from(s.tissues.is_some()) + usize::from(s.scan.is_some()) + usize::from(s.phantom);
            if sources != 1 {
                return Err(invalid(format!("scan '{}'", s.name), "give exactly one of tissues, scan, phantom"));
            }
        }
        Ok(())
    }

    /// Every case, scan-major.
    pub fn cases(&self) -> Vec<Case> {
        let n = self.preparations.len();
        (0..self.scans.len() * n)
            .map(|index| {
                let (scan, preparation) = (index / n, index % n);
                let name = format!("{}__{}", self.scans[scan].name, self.preparations[preparation].name);
                Case { index, name, scan, preparation }
            })
            .collect()
    }
}

/// Shard `index` of `count` (from 0): a contiguous run of the cases.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl Shard {
    pub const WHOLE: Shard = Shard { index: 0, count: 1 };

    pub fn new(index: usize, count: usize) -> Result<Self> {
        if count == 0 || index >= count {
            return Err(invalid("shard", format!("{index}/{count}, expected I/N with 0 <= I < N")));
        }
        Ok(Shard { index, count })
    }

    /// "I/N", e.g. from `$SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT`.
    pub fn parse(text: &str) -> Result<Self> {
        let bad = || invalid("shard", format!("'{text}', expected I/N with 0 <= I < N"));
        let (i, n) = text.split_once('/').ok_or_else(bad)?;
        Shard::new(i.trim().parse().map_err(|_| bad())?, n.trim().parse().map_err(|_| bad())?)
    }

    /// The cases of this shard among `n`: shards differ by at most one case.
    pub fn range(&self, n: usize) -> Range<usize> {
        self.index * n / self.count..(self.index + 1) * n / self.count
    }
}

/// Runs this shard's cases, writing each into `out/cases/<case>/` (prepared `tissues.vdb` and
/// [`CASE_FILE`], whole or not at all); `progress(case, fraction of the shard)` before each.
pub fn run_shard(manifest: &Manifest, out: &Path, shard: Shard, table: &TissueTable, progress: &mut dyn FnMut(&str, f64)) -> Result<Vec<CaseReport>> {
    run_shard_until(manifest, out, shard, table, &mut |case, f| {
        progress(case, f);
        true
    })
}

/// As [`run_shard`]; when `go_on(case, fraction)` returns false no further case starts (the
/// cases written stay) and the call ends with an error saying so.
pub fn run_shard_until(manifest: &Manifest, out: &Path, shard: Shard, table: &TissueTable, go_on: &mut dyn FnMut(&str, f64) -> bool) -> Result<Vec<CaseReport>> {
    let cases = manifest.cases();
    let range = shard.range(cases.len());
    let total = range.len().max(1);
    let mut loaded: HashMap<usize, TissueModel> = HashMap::new();
    let mut reports = Vec::new();
    for (k, case) in cases[range].iter().enumerate() {
        if !go_on(&case.name, k as f64 / total as f64) {
            return Err(invalid(format!("batch shard {}/{}", shard.index, shard.count), format!("stopped on request before case '{}'", case.name)));
        }
        let clock = Instant::now();
        let scan = &manifest.scans[case.scan];
        let prep = &manifest.preparations[case.preparation];
        let what = |e: Error| invalid(format!("case '{}'", case.name), e.to_string());
        let burr = Burr::parse(&prep.burr).map_err(what)?;
        let path = ToolPath::read(&prep.path, PathLimits::default()).map_err(|e| what(e.into()))?;
        if !(prep.force_n.is_finite() && prep.force_n >= 0.0) {
            return Err(invalid(format!("preparation '{}' force_n", prep.name), format!("{} N", prep.force_n)));
        }
        if !loaded.contains_key(&case.scan) {
            loaded.insert(case.scan, load_scan(scan, table).map_err(what)?);
        }
        let mut model = loaded[&case.scan].clone();
        let before = model.volumes();
        let options = PrepareOptions { force_n: (prep.force_n > 0.0).then_some(prep.force_n), ..Default::default() };
        let report = prepare(&mut model, &path, &burr, &options).map_err(what)?;
        let tissues = TissueVolumes::of(&model, &before, |name| report.removed_mm3.get(name).copied().unwrap_or(0.0));
        let dir = out.join("cases").join(&case.name);
        let mut record = CaseReport {
            index: case.index,
            case: case.name.clone(),
            scan: scan.name.clone(),
            preparation: prep.name.clone(),
            burr: burr.spec(),
            seconds: 0.0,
            tissues,
        };
        crate::tissues::export::all_or_nothing(&dir, |staged| {
            model.save(&staged.join("tissues.vdb"))?;
            record.seconds = clock.elapsed().as_secs_f64();
            let json = serde_json::to_vec_pretty(&record).map_err(|e| invalid(CASE_FILE, e.to_string()))?;
            dentsim_atomic::write(&staged.join(CASE_FILE), |w| w.write_all(&json))?;
            Ok(())
        })?;
        reports.push(record);
    }
    go_on("done", 1.0);
    Ok(reports)
}

fn load_scan(s: &ScanEntry, table: &TissueTable) -> Result<TissueModel> {
    if let Some(p) = &s.tissues {
        return TissueModel::load(p, table);
    }
    if let Some(p) = &s.scan {
        let volume = dentsim_cbct::read(p, &Default::default()).map_err(|e| invalid(format!("scan '{}'", s.name), e.to_string()))?;
        let request = crate::tissues::from_scan::TissuesFromScan { voxel_size_mm: s.voxel_mm, fdi: s.fdi, seed_mm: s.seed_mm, ..Default::default() };
        return Ok(request.run(&volume, table, &mut |_, _| {})?.0);
    }
    crate::tissues::model::check_voxel_mm("voxel_mm", s.voxel_mm)?;
    crate::tissues::capsule::CapsuleTooth::default().build(s.voxel_mm, table)
}

/// Reads every case's [`CASE_FILE`] under `out/cases/` and writes the merged [`REPORT_JSON`]
/// and [`REPORT_CSV`] into `out` (cases in manifest order). A missing case is an error naming
/// it and the shard of `shards` that should have made it.
pub fn merge(manifest: &Manifest, out: &Path, shards: usize) -> Result<Vec<CaseReport>> {
    let cases = manifest.cases();
    let mut reports = Vec::with_capacity(cases.len());
    let mut missing = Vec::new();
    for case in &cases {
        let file = out.join("cases").join(&case.name).join(CASE_FILE);
        match std::fs::read(&file) {
            Ok(bytes) => {
                let r: CaseReport = serde_json::from_slice(&bytes).map_err(|e| Error::File { path: file.clone(), message: e.to_string() })?;
                reports.push(r);
            }
            Err(_) => {
                let shard = (0..shards.max(1)).find(|&i| Shard { index: i, count: shards.max(1) }.range(cases.len()).contains(&case.index));
                missing.push(format!("{} (shard {}/{})", case.name, shard.unwrap_or(0), shards.max(1)));
            }
        }
    }
    if !missing.is_empty() {
        return Err(invalid(format!("batch {}", out.display()), format!("cases not run yet: {}", missing.join(", "))));
    }
    let json = serde_json::to_vec_pretty(&reports).map_err(|e| invalid(REPORT_JSON, e.to_string()))?;
    dentsim_atomic::write(&out.join(REPORT_JSON), |w| w.write_all(&json))?;
    dentsim_atomic::write(&out.join(REPORT_CSV), |w| w.write_all(report_csv(&reports).as_bytes()))?;
    Ok(reports)
}

/// One row per case and tissue.
pub fn report_csv(reports: &[CaseReport]) -> String {
    let mut text = String::from("case,scan,preparation,burr,tissue,removed_mm3,volume_before_mm3,volume_after_mm3,seconds\n");
    for r in reports {
        for t in &r.tissues {
            text += &format!(
                "{},{},{},{},{},{:.6},{:.6},{:.6},{:.3}\n",
                r.case, r.scan, r.preparation, r.burr, t.name, t.removed_mm3, t.volume_before_mm3, t.volume_after_mm3, r.seconds
            );
        }
    }
    text
}
