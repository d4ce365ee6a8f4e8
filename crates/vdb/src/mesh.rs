use glam::Vec3;

/// A triangle mesh in world millimetres, wound counter-clockwise seen from outside.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    pub points: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
}

impl TriMesh {
    /// Enclosed volume by the divergence theorem (positive for outward winding).
    pub fn volume(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.points[i as usize].as_dvec3());
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    /// Total surface area in mm².
    pub fn area(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.points[i as usize].as_dvec3());
                0.5 * (b - a).cross(c - a).length()
            })
            .sum()
    }

    pub(crate) fn from_buffers(m: crate::sys::ffi::MeshBuffers) -> Self {
        let vec3s = |v: &[f32]| v.chunks_exact(3).map(Vec3::from_slice).collect::<Vec<_>>();
        TriMesh {
            points: vec3s(&m.points),
            normals: vec3s(&m.normals),
            triangles: m.triangles.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
        }
    }

    pub(crate) fn flat_points(&self) -> Vec<f32> {
        self.points.iter().flat_map(|p| p.to_array()).collect()
    }

    pub(crate) fn flat_triangles(&self) -> Vec<u32> {
        self.triangles.iter().flatten().copied().collect()
    }
}
