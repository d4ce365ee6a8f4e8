//! The one contract between the ParaView plugin and the Rust core. Plain data crosses as shared
//! structs; every call returns `Result`, which cxx turns into a C++ `rust::Error` exception, and
//! no panic crosses: each call runs under `catch_unwind`.
use std::panic::{catch_unwind, AssertUnwindSafe};

use dentsim_sim::model::Tissue;
use dentsim_sim::preparation::PhantomStroke;
use dentsim_sim::tissue::TissueTable;

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
    }

    /// A scalar image as VTK holds it: world = origin + direction · (ijk ∘ spacing), with the
    /// direction matrix row-major (column c is index axis c), x fastest in the values.
    struct ImageGeometry {
        dims: [u32; 3],
        spacing: [f64; 3],
        origin: [f64; 3],
        direction: [f64; 9],
    }

    /// Which tooth to turn into tissues, and how finely.
    struct SegmentParams {
        voxel_size_mm: f64,
        fdi: u8,
        use_seed: bool,
        seed_mm: [f64; 3],
    }

    extern "Rust" {
        fn default_stroke() -> StrokeParams;
        fn phantom_stroke(params: &StrokeParams) -> Result<Vec<TissueSurface>>;
        fn read_tissues(path: &str) -> Result<Vec<TissueSurface>>;
        fn segment_image(geometry: &ImageGeometry, values: &[f32], params: &SegmentParams) -> Result<Vec<TissueSurface>>;
        fn version() -> String;
    }
}

pub use bridge::{ImageGeometry, SegmentParams, StrokeParams, TissueSurface};

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
        Ok(outcome
            .model
            .tissues
            .iter()
            .zip(&outcome.tissues)
            .map(|(t, o)| surface(t, o.volume_before_mm3, o.volume_after_mm3, o.removed_mm3))
            .collect())
    })
}

/// Every tissue of a .vdb whose level-set grids are named by tissue, as surfaces.
pub fn read_tissues(path: &str) -> Result<Vec<TissueSurface>, String> {
    guarded("read tissues", || {
        let model = dentsim_sim::model::TissueModel::load(std::path::Path::new(path), &TissueTable::default())
            .map_err(|e| e.to_string())?;
        Ok(unchanged_surfaces(&model))
    })
}

/// One tooth's tissue surfaces from a scan already in memory (a ParaView reader's output).
pub fn segment_image(geometry: &ImageGeometry, values: &[f32], params: &SegmentParams) -> Result<Vec<TissueSurface>, String> {
    guarded("tissues from scan", || {
        let d = geometry.direction;
        let direction = [[d[0], d[3], d[6]], [d[1], d[4], d[7]], [d[2], d[5], d[8]]];
        let source = dentsim_cbct::SourceInfo { format: "vtkImageData".into(), path: "ParaView input".into(), ..Default::default() };
        let scan = dentsim_cbct::Volume::new(
            geometry.dims.map(|n| n as usize),
            geometry.spacing,
            geometry.origin,
            direction,
            values.to_vec(),
            source,
        )
        .map_err(|e| format!("input image: {e}"))?;
        let request = dentsim_sim::scan::ScanToTissues {
            voxel_size_mm: params.voxel_size_mm,
            fdi: params.fdi,
            seed_mm: params.use_seed.then_some(params.seed_mm),
            ..Default::default()
        };
        let (model, _) = request.run(&scan, &TissueTable::default(), &mut |_, _| {}).map_err(|e| e.to_string())?;
        Ok(unchanged_surfaces(&model))
    })
}

/// Surfaces of a model nothing has cut yet.
fn unchanged_surfaces(model: &dentsim_sim::model::TissueModel) -> Vec<TissueSurface> {
    model
        .tissues
        .iter()
        .map(|t| {
            let volume = t.grid.volume();
            surface(t, volume, volume, 0.0)
        })
        .collect()
}

/// A tissue's mesh and properties with the volumes the caller measured.
fn surface(t: &Tissue, volume_before_mm3: f64, volume_after_mm3: f64, removed_mm3: f64) -> TissueSurface {
    let mesh = t.grid.to_mesh();
    let p = &t.props;
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
    }
}

fn version() -> String {
    env!("CARGO_PKG_VERSION").to_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_parameters_come_back_as_errors() {
        let params = StrokeParams { voxel_size_mm: -1.0, ..default_stroke() };
        let err = phantom_stroke(&params).err().expect("refused");
        assert!(err.contains("voxel size"), "{err}");
    }

    #[test]
    fn panics_become_errors() {
        let err = guarded::<()>("probe", || panic!("boom")).unwrap_err();
        assert_eq!(err, "probe: internal error: boom");
    }

    #[test]
    fn images_with_bad_geometry_or_values_are_refused() {
        let geometry = ImageGeometry { dims: [4, 4, 4], spacing: [0.2; 3], origin: [0.0; 3], direction: [1., 0., 0., 0., 1., 0., 0., 0., 1.] };
        let params = SegmentParams { voxel_size_mm: 0.05, fdi: 36, use_seed: false, seed_mm: [0.0; 3] };
        let err = segment_image(&geometry, &[0.0; 10], &params).err().expect("refused");
        assert!(err.contains("input image"), "{err}");
        let mut values = vec![0.0f32; 64];
        values[5] = f32::NAN;
        let err = segment_image(&geometry, &values, &params).err().expect("refused");
        assert!(err.to_lowercase().contains("nan"), "{err}");
        let params = SegmentParams { fdi: 19, ..params };
        let err = segment_image(&geometry, &vec![0.0f32; 64], &params).err().expect("refused");
        assert!(err.contains("19"), "{err}");
    }

    #[test]
    fn reading_a_missing_file_names_it() {
        let err = read_tissues("/nonexistent/tissues.vdb").err().expect("refused");
        assert!(err.contains("/nonexistent/tissues.vdb"), "{err}");
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
