//! A tooth as one narrow-band level set per tissue, each enclosing only its own material.
use std::path::Path;

use dentsim_vdb::{LevelSet, MetaValue};
use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::error::{invalid, Error, Result};
use crate::tissues::table::{TissueProps, TissueTable};

#[derive(Clone)]
pub struct Tissue {
    pub props: TissueProps,
    pub grid: LevelSet,
}

/// Level-set voxel size (mm) segmentation, the demo and the phantoms use unless told otherwise:
/// fine enough for a 1 mm burr's cut to show (REFERENCE.md).
pub const DEFAULT_VOXEL_MM: f64 = 0.05;

/// One tissue's volume before and after some work (a session, a replay, a preparation) and what
/// the work removed, mm³: the one per-tissue volume record every report and face uses (JSON
/// field names as the README documents them).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TissueVolumes {
    pub name: String,
    pub volume_before_mm3: f64,
    pub volume_after_mm3: f64,
    pub removed_mm3: f64,
}

impl TissueVolumes {
    /// Each tissue of `model` as it is now, against its volume in `before` (from
    /// [`TissueModel::volumes`]; NaN when absent) and `removed(name)`.
    pub fn of(model: &TissueModel, before: &[(String, f64)], removed: impl Fn(&str) -> f64) -> Vec<TissueVolumes> {
        model
            .tissues
            .iter()
            .map(|t| {
                let name = t.props.name.clone();
                TissueVolumes {
                    volume_before_mm3: before.iter().find(|(n, _)| *n == name).map_or(f64::NAN, |b| b.1),
                    volume_after_mm3: t.grid.volume(),
                    removed_mm3: removed(&name),
                    name,
                }
            })
            .collect()
    }

    /// Each tissue of a model nothing has cut.
    pub fn unchanged(model: &TissueModel) -> Vec<TissueVolumes> {
        let volumes = model.volumes().into_iter();
        volumes.map(|(name, v)| TissueVolumes { name, volume_before_mm3: v, volume_after_mm3: v, removed_mm3: 0.0 }).collect()
    }
}

/// Every tissue's grid shares one transform (voxel size, origin at world zero).
/// Voxel sizes (mm) a model is built at (the capsule phantom, tissues rebuilt from surfaces):
/// finer takes minutes, coarser loses the enamel layer.
pub const VOXEL_RANGE_MM: std::ops::RangeInclusive<f64> = 0.01..=0.5;

/// Refuses a voxel size outside [`VOXEL_RANGE_MM`]; `what` names the field.
pub fn check_voxel_mm(what: &str, voxel_mm: f64) -> Result<()> {
    if voxel_mm.is_finite() && VOXEL_RANGE_MM.contains(&voxel_mm) {
        return Ok(());
    }
    Err(invalid(what, format!("{voxel_mm} mm, expected {} ..= {} mm", VOXEL_RANGE_MM.start(), VOXEL_RANGE_MM.end())))
}

#[derive(Clone)]
pub struct TissueModel {
    pub tissues: Vec<Tissue>,
    /// Where the tissues came from (scan file, phantom name); no patient identifiers.
    pub source: String,
    /// FDI (ISO 3950) number of the tooth, when known.
    pub fdi_tooth: Option<u8>,
}

impl TissueModel {
    pub fn new(source: impl Into<String>, fdi_tooth: Option<u8>) -> Self {
        TissueModel { tissues: Vec::new(), source: source.into(), fdi_tooth }
    }

    pub fn voxel_size(&self) -> Option<f64> {
        self.tissues.first().map(|t| t.grid.voxel_size())
    }

    /// Readies every grid for cutting without allocation (see [`LevelSet::voxelize_inside`]);
    /// values are unchanged. [`compact`](Self::compact) takes the spare leaves back.
    pub fn voxelize_for_cutting(&mut self) -> Result<()> {
        self.tissues.iter_mut().try_for_each(|t| t.grid.voxelize_inside().map_err(Into::into))
    }

    /// Bytes the tissues may hold once cut or made ready for cutting: their trees now, plus a
    /// leaf for every voxel of each tissue's bounding box (what [`Self::voxelize_for_cutting`]
    /// makes of the interior, and the most a cut can touch), at 4 bytes a voxel. Cheap: no
    /// allocation; callers check it against [`crate::Limits`] before the work.
    pub fn cutting_bytes_estimate(&self) -> u64 {
        self.tissues
            .iter()
            .map(|t| {
                let boxed = t.grid.index_bbox().map_or(0u64, |b| {
                    let d = (b.max - b.min).as_i64vec3() + glam::I64Vec3::ONE;
                    (d.x.max(0) as u64).saturating_mul(d.y.max(0) as u64).saturating_mul(d.z.max(0) as u64)
                });
                t.grid.mem_bytes().saturating_add(boxed.saturating_mul(4))
            })
            .fold(0u64, u64::saturating_add)
    }

    /// Collapses uniform inactive leaves into tiles (OpenVDB's `pruneLevelSet`).
    pub fn compact(&mut self) {
        self.tissues.iter_mut().for_each(|t| t.grid.prune());
    }

    /// Adds a tissue; its grid is renamed after it.
    pub fn push(&mut self, props: TissueProps, mut grid: LevelSet) -> Result<()> {
        if let Some(h) = self.voxel_size() {
            if grid.voxel_size() != h {
                return Err(invalid(
                    format!("tissue '{}'", props.name),
                    format!("voxel size {} mm differs from the model's {h} mm", grid.voxel_size()),
                ));
            }
        }
        if self.get(&props.name).is_some() {
            return Err(invalid(format!("tissue '{}'", props.name), "is already in the model"));
        }
        grid.set_name(&props.name);
        self.tissues.push(Tissue { props, grid });
        Ok(())
    }

    pub fn get(&self, name: &str) -> Option<&Tissue> {
        self.tissues.iter().find(|t| t.props.name == name)
    }

    /// Each tissue's enclosed volume, mm³.
    pub fn volumes(&self) -> Vec<(String, f64)> {
        self.tissues.iter().map(|t| (t.props.name.clone(), t.grid.volume())).collect()
    }

    /// Writes one .vdb with a grid per tissue carrying its properties as metadata.
    pub fn save(&mut self, path: &Path) -> Result<()> {
        for t in &mut self.tissues {
            let p = &t.props;
            let g = &mut t.grid;
            g.set_meta("tissue", &MetaValue::String(p.name.clone()));
            g.set_meta("label", &MetaValue::I64(p.label.into()));
            g.set_meta("colour", &MetaValue::Vec3(Vec3::from_array(p.colour)));
            g.set_meta("opacity", &MetaValue::F64(p.opacity.into()));
            g.set_meta("stiffness_n_per_mm", &MetaValue::F64(p.stiffness_n_per_mm));
            g.set_meta("damping_n_s_per_mm", &MetaValue::F64(p.damping_n_s_per_mm));
            g.set_meta("removal_rate_mm3_per_n_s", &MetaValue::F64(p.removal_rate_mm3_per_n_s));
            g.set_meta("source", &MetaValue::String(self.source.clone()));
            if let Some(fdi) = self.fdi_tooth {
                g.set_meta("fdi_tooth", &MetaValue::I64(fdi.into()));
            }
        }
        let grids: Vec<&LevelSet> = self.tissues.iter().map(|t| &t.grid).collect();
        dentsim_vdb::write_file(path, &grids)?;
        Ok(())
    }

    /// Level sets at `voxel_mm` rebuilt from closed tissue surfaces named by tissue (what a
    /// ParaView pipeline hands on: the reader's, Tissues From Scan's or a preparation's blocks),
    /// with the properties of `table`, in the surfaces' order. Surfaces without triangles are skipped; a name that is
    /// not a tissue is an error naming the block. Conversion is OpenVDB's `meshToLevelSet`: the
    /// surface moves by well under a voxel, so volumes agree to the mesher's accuracy.
    pub fn from_surfaces(source: &str, surfaces: &[(String, dentsim_vdb::TriMesh)], voxel_mm: f64, table: &TissueTable) -> Result<Self> {
        check_voxel_mm("voxel size", voxel_mm)?;
        let mut model = TissueModel::new(source, None);
        for (name, mesh) in surfaces.iter().filter(|(_, m)| !m.triangles.is_empty()) {
            let Some(props) = table.get(name) else {
                let known: Vec<_> = table.tissues.iter().map(|t| t.name.as_str()).collect();
                return Err(invalid(format!("{source} block '{name}'"), format!("is not a tissue (known: {})", known.join(", "))));
            };
            let grid = level_set_of_shells(mesh, voxel_mm).map_err(|e| invalid(format!("{source} block '{name}'"), e.to_string()))?;
            model.push(props.clone(), grid)?;
        }
        if model.tissues.is_empty() {
            return Err(invalid(source, "holds no tissue surfaces"));
        }
        Ok(model)
    }

    /// Reads a .vdb whose level-set grids are named by tissue. Properties stored with a grid win;
    /// missing ones (files from other tools) come from `table`.
    pub fn load(path: &Path, table: &TissueTable) -> Result<Self> {
        let file_err = |message: String| Error::File { path: path.to_owned(), message };
        let mut model = TissueModel::new(path.display().to_string(), None);
        for g in dentsim_vdb::read_file(path)? {
            let Some(grid) = g.level_set else {
                return Err(file_err(format!("grid '{}' is {}, expected a float level set", g.name, g.grid_type)));
            };
            if g.grid_class != "level set" {
                return Err(file_err(format!("grid '{}' is of class '{}', expected 'level set'", g.name, g.grid_class)));
            }
            let Some(defaults) = table.get(&g.name) else {
                let known: Vec<_> = table.tissues.iter().map(|t| t.name.as_str()).collect();
                return Err(file_err(format!("grid '{}' is not a tissue (known: {})", g.name, known.join(", "))));
            };
            let mut props = defaults.clone();
            // A key the file holds must have the expected type; absent keys keep the table's value.
            let present = grid.meta_keys();
            let meta = |key: &str| -> Result<Option<MetaValue>> {
                if !present.iter().any(|k| k == key) {
                    return Ok(None);
                }
                grid.meta(key).map(Some).map_err(|e| file_err(format!("grid '{}': {e}", g.name)))
            };
            let wrong = |key: &str, v: &MetaValue, expected: &str| {
                file_err(format!("grid '{}' metadata '{key}' is {}, expected {expected}", g.name, v.kind()))
            };
            let number = |key: &str| -> Result<Option<f64>> {
                match meta(key)? {
                    None => Ok(None),
                    Some(MetaValue::F64(v)) => Ok(Some(v)),
                    Some(MetaValue::I64(v)) => Ok(Some(v as f64)),
                    Some(v) => Err(wrong(key, &v, "a number")),
                }
            };
            if let Some(v) = number("stiffness_n_per_mm")? { props.stiffness_n_per_mm = v; }
            if let Some(v) = number("damping_n_s_per_mm")? { props.damping_n_s_per_mm = v; }
            if let Some(v) = number("removal_rate_mm3_per_n_s")? { props.removal_rate_mm3_per_n_s = v; }
            if let Some(v) = number("opacity")? { props.opacity = v as f32; }
            match meta("colour")? {
                None => {}
                Some(MetaValue::Vec3(c)) => props.colour = c.to_array(),
                Some(v) => return Err(wrong("colour", &v, "vec3s")),
            }
            if let Some(v) = number("fdi_tooth")? {
                let fdi = (v.fract() == 0.0 && (0.0..=255.0).contains(&v)).then_some(v as u8);
                match fdi.filter(|&f| dentsim_cbct::roi::valid_fdi(f)) {
                    Some(f) => model.fdi_tooth = Some(f),
                    None => return Err(file_err(format!("grid '{}' metadata 'fdi_tooth' is {v}, expected an FDI tooth number", g.name))),
                }
            }
            if let Some(v) = meta("tissue")?.filter(|v| !matches!(v, MetaValue::String(_))) {
                return Err(wrong("tissue", &v, "a string"));
            }
            match meta("source")? {
                None => {}
                Some(MetaValue::String(s)) => model.source = s,
                Some(v) => return Err(wrong("source", &v, "a string")),
            }
            // The same rules as the tissue table's TOML.
            props.check().map_err(|e| file_err(format!("grid '{}' metadata: {e}", g.name)))?;
            model.push(props, grid).map_err(|e| file_err(e.to_string()))?;
        }
        // OpenVDB hands grids back in name order; keep the table's (label) order instead.
        model.tissues.sort_by_key(|t| t.props.label);
        Ok(model)
    }
}

/// The level set of a closed surface that may hold nested shells (enamel's outer surface and the
/// inward-wound surface around the dentin it encloses): `meshToLevelSet` fills everything not
/// reachable from outside, so each connected shell is converted alone, outward-wound ones
/// united and inward-wound ones (negative enclosed volume) cut away.
fn level_set_of_shells(mesh: &dentsim_vdb::TriMesh, voxel_mm: f64) -> Result<LevelSet> {
    let n = mesh.points.len();
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    for t in &mesh.triangles {
        let a = root(&mut parent, t[0] as usize);
        for &v in &t[1..] {
            let b = root(&mut parent, v as usize);
            parent[b] = a;
        }
    }
    let mut shells: std::collections::BTreeMap<usize, Vec<[u32; 3]>> = Default::default();
    for t in &mesh.triangles {
        shells.entry(root(&mut parent, t[0] as usize)).or_default().push(*t);
    }
    let mut outer: Option<LevelSet> = None;
    let mut inner = Vec::new();
    for (_, triangles) in shells {
        let mut shell = dentsim_vdb::TriMesh { points: mesh.points.clone(), normals: Vec::new(), triangles };
        let inward = shell.volume() < 0.0;
        if inward {
            shell.triangles.iter_mut().for_each(|t| t.swap(1, 2));
        }
        let grid = LevelSet::from_mesh(&shell, voxel_mm, 3.0)?;
        if inward {
            inner.push(grid);
        } else if let Some(o) = outer.as_mut() {
            o.csg_union(&grid)?;
        } else {
            outer = Some(grid);
        }
    }
    let mut grid = outer.ok_or_else(|| invalid("surface", "has no outward-wound shell"))?;
    for hole in &inner {
        grid.csg_difference(hole)?;
    }
    Ok(grid)
}
