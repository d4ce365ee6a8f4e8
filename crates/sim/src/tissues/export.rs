//! Tissue surfaces to files ParaView and CAD tools open: VTK XML PolyData (.vtp) and binary STL.
//! Every file is written whole or not at all ([`dentsim_atomic`]).
use std::io::Write;
use std::path::Path;

use dentsim_vdb::TriMesh;

use crate::error::{Error, Result};
use crate::tissues::model::TissueModel;
use crate::tissues::table::TissueProps;

/// The files dentsim writes into an output folder (README lists them), one home for each name.
pub const TISSUES_NAME: &str = "tissues.vdb";
/// `dentsim session`'s binary log.
pub const LOG_NAME: &str = "session.dslog";
/// A session's or the demo's figures.
pub const SUMMARY_NAME: &str = "summary.json";
pub const REPLAY_SUMMARY_NAME: &str = "replay.json";
pub const PREPARE_SUMMARY_NAME: &str = "prepare.json";
pub const FORCES_CSV_NAME: &str = "forces.csv";
pub const FORCES_PNG_NAME: &str = "forces.png";

/// Runs `write` on a staging folder inside `out` and renames everything it wrote into `out` at
/// the end ([`dentsim_atomic::Batch`]): on any error `out` is as before (a folder this call
/// created is removed again) and the error names the file in `out`, not its staged twin.
pub fn all_or_nothing<T>(out: &Path, write: impl FnOnce(&Path) -> Result<T>) -> Result<T> {
    let existed = out.exists();
    let result = (|| {
        let batch = dentsim_atomic::Batch::new(out)?;
        let value = write(batch.dir()).map_err(|e| unstage(&batch, e))?;
        batch.commit()?;
        Ok(value)
    })();
    if result.is_err() && !existed {
        // Only an empty folder goes (a session's log, kept on purpose, keeps it).
        let _ = std::fs::remove_dir(out);
    }
    result
}

/// The same error naming the destination file instead of the staged one.
fn unstage(batch: &dentsim_atomic::Batch, e: Error) -> Error {
    let stage = batch.dir().display().to_string();
    let out = batch.destination().display().to_string();
    match e {
        Error::File { path, message } => Error::File { path: batch.final_path(&path), message: message.replace(&stage, &out) },
        other => {
            let text = other.to_string();
            if text.contains(&stage) { Error::Invalid { what: "writing".into(), message: text.replace(&stage, &out) } } else { other }
        }
    }
}

/// Writes each tissue's surface as `<tissue>.vtp` and `<tissue>.stl` and all grids as
/// [`TISSUES_NAME`] into `out`; returns each tissue's triangle count. `progress(step, fraction)`.
pub fn write_model(model: &mut TissueModel, out: &Path, progress: &mut dyn FnMut(&str, f64)) -> Result<Vec<(String, usize)>> {
    let mut triangles = Vec::new();
    let n = model.tissues.len();
    for (i, t) in model.tissues.iter().enumerate() {
        progress(&format!("meshing {}", t.props.name), i as f64 / n as f64);
        let mesh = crate::tissues::surface::surface(&t.grid)?;
        write_vtp(&out.join(format!("{}.vtp", t.props.name)), &mesh, &t.props)?;
        write_stl(&out.join(format!("{}.stl", t.props.name)), &mesh)?;
        triangles.push((t.props.name.clone(), mesh.triangles.len()));
    }
    progress(&format!("writing {TISSUES_NAME}"), 1.0);
    model.save(&out.join(TISSUES_NAME))?;
    Ok(triangles)
}

/// VTK XML PolyData with `Normals` per point, the tissue `Tissue` label per cell, and the
/// tissue's properties as field data (`Stiffness` N/mm, `Damping` N·s/mm, `RemovalRate`
/// mm³/(N·s), `Colour` RGB 0..1, `Opacity`).
pub fn write_vtp(path: &Path, mesh: &TriMesh, tissue: &TissueProps) -> Result<()> {
    write_vtp_with(path, mesh, tissue, &[])
}

/// [`write_vtp`] with more point arrays (name, one f32 per point).
pub fn write_vtp_with(path: &Path, mesh: &TriMesh, tissue: &TissueProps, point_arrays: &[(&str, &[f32])]) -> Result<()> {
    let points: Vec<f32> = mesh.points.iter().flat_map(|p| p.to_array()).collect();
    let normals: Vec<f32> = mesh.normals.iter().flat_map(|p| p.to_array()).collect();
    let connectivity: Vec<i64> = mesh.triangles.iter().flatten().map(|&i| i64::from(i)).collect();
    let offsets: Vec<i64> = (1..=mesh.triangles.len() as i64).map(|i| 3 * i).collect();
    let labels = vec![i32::from(tissue.label); mesh.triangles.len()];
    let mut arrays: Vec<(&str, &str, usize, Vec<u8>)> = vec![
        ("Stiffness", "Float64", 1, bytes(&[tissue.stiffness_n_per_mm])),
        ("Damping", "Float64", 1, bytes(&[tissue.damping_n_s_per_mm])),
        ("RemovalRate", "Float64", 1, bytes(&[tissue.removal_rate_mm3_per_n_s])),
        ("Colour", "Float32", 3, bytes(&tissue.colour)),
        ("Opacity", "Float32", 1, bytes(&[tissue.opacity])),
        ("Normals", "Float32", 3, bytes(&normals)),
        ("Points", "Float32", 3, bytes(&points)),
        ("Tissue", "Int32", 1, bytes(&labels)),
        ("connectivity", "Int64", 1, bytes(&connectivity)),
        ("offsets", "Int64", 1, bytes(&offsets)),
    ];
    for (name, values) in point_arrays {
        if values.len() != mesh.points.len() {
            return Err(crate::error::invalid(format!("point array '{name}'"), format!("has {} values for {} points", values.len(), mesh.points.len())));
        }
        arrays.push((name, "Float32", 1, bytes(values)));
    }
    let mut offset = 0usize;
    let mut tags = Vec::new();
    for (name, kind, components, data) in &arrays {
        tags.push(format!(
            r#"<DataArray type="{kind}" Name="{name}" NumberOfComponents="{components}" NumberOfTuples="{}" format="appended" offset="{offset}"/>"#,
            data.len() / components / kind_size(kind)
        ));
        offset += 8 + data.len();
    }
    let (n_points, n_polys) = (mesh.points.len(), mesh.triangles.len());
    Ok(dentsim_atomic::write(path, |w| {
        writeln!(w, r#"<?xml version="1.0"?>"#)?;
        writeln!(w, r#"<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian" header_type="UInt64">"#)?;
        writeln!(w, "<PolyData>\n<FieldData>\n{}\n</FieldData>", tags[..5].join("\n"))?;
        writeln!(w, r#"<Piece NumberOfPoints="{n_points}" NumberOfVerts="0" NumberOfLines="0" NumberOfStrips="0" NumberOfPolys="{n_polys}">"#)?;
        writeln!(w, "<PointData Normals=\"Normals\">\n{}\n{}\n</PointData>", tags[5], tags[10..].join("\n"))?;
        writeln!(w, "<CellData Scalars=\"Tissue\">\n{}\n</CellData>", tags[7])?;
        writeln!(w, "<Points>\n{}\n</Points>", tags[6])?;
        writeln!(w, "<Polys>\n{}\n{}\n</Polys>", tags[8], tags[9])?;
        writeln!(w, "</Piece>\n</PolyData>\n<AppendedData encoding=\"raw\">")?;
        w.write_all(b"_")?;
        for (_, _, _, data) in &arrays {
            w.write_all(&(data.len() as u64).to_le_bytes())?;
            w.write_all(data)?;
        }
        writeln!(w, "\n</AppendedData>\n</VTKFile>")
    })?)
}

/// Binary STL with per-facet normals from the triangles' winding.
pub fn write_stl(path: &Path, mesh: &TriMesh) -> Result<()> {
    let facets: Vec<stl_io::Triangle> = mesh
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| mesh.points[i as usize]);
            let n = (b - a).cross(c - a).normalize_or_zero();
            stl_io::Triangle {
                normal: stl_io::Normal::new(n.to_array()),
                vertices: [a, b, c].map(|v| stl_io::Vertex::new(v.to_array())),
            }
        })
        .collect();
    Ok(dentsim_atomic::write(path, |w| stl_io::write_stl(&mut WriteRef(w), facets.iter()))?)
}

struct WriteRef<'a>(&'a mut dyn Write);

impl Write for WriteRef<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.0.flush()
    }
}

trait LeBytes: Copy {
    fn le(self, out: &mut Vec<u8>);
}
macro_rules! le_bytes {
    ($($t:ty),*) => {$(impl LeBytes for $t { fn le(self, out: &mut Vec<u8>) { out.extend_from_slice(&self.to_le_bytes()) } })*};
}
le_bytes!(f32, f64, i32, i64);

fn bytes<T: LeBytes>(values: &[T]) -> Vec<u8> {
    let mut out = Vec::with_capacity(values.len() * std::mem::size_of::<T>());
    values.iter().for_each(|v| v.le(&mut out));
    out
}

fn kind_size(kind: &str) -> usize {
    match kind {
        "Float64" | "Int64" => 8,
        _ => 4,
    }
}
