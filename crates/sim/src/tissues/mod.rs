//! Tissues: the property table, the model (one narrow-band level set per tissue), the analytic
//! capsule phantom, tissues from a CBCT scan and what it could not read, their surfaces (the one
//! mesher) and exports.
pub mod blur_fit;
pub mod capsule;
pub mod export;
pub mod field;
pub mod from_scan;
pub mod ligament;
pub mod model;
pub mod surface;
pub mod table;
pub mod warnings;

#[cfg(test)]
pub(crate) mod test_shapes {
    use glam::DVec3;

    /// Mean angle (°) between the triangles' normals and the directions from `centre` to their
    /// middles, over the triangles whose middle `keep` takes: a ball's (or a chamber's) normal error.
    pub fn radial_normal_error(mesh: &dentsim_vdb::TriMesh, centre: DVec3, keep: impl Fn(DVec3) -> bool) -> f64 {
        let angles: Vec<f64> = mesh
            .triangles
            .iter()
            .filter_map(|t| {
                let [a, b, c] = t.map(|i| mesh.points[i as usize].as_dvec3());
                let (normal, mid) = ((b - a).cross(c - a), (a + b + c) / 3.0);
                (normal.length() > 1e-12 && keep(mid)).then(|| normal.normalize().dot((mid - centre).normalize()).clamp(-1.0, 1.0).acos().to_degrees())
            })
            .collect();
        angles.iter().sum::<f64>() / angles.len() as f64
    }
}

pub use capsule::CapsuleTooth;
pub use export::write_model;
pub use from_scan::{ScanReport, TissuesFromScan};
pub use model::{Tissue, TissueModel, TissueVolumes};
pub use surface::{surface, Mesher, SurfaceFrame};
pub use table::{TissueProps, TissueTable};
