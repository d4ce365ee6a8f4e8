//! Unsigned distance from points to a triangle mesh, exact to the triangles (parry3d's BVH): a
//! level set's band ends a few voxels from its surface, and the distances an assessment reads
//! (dentin over the pulp, a surface's deviation) reach millimetres.
use dentsim_vdb::TriMesh;
use glam::DVec3;
use parry3d::math::Point;
use parry3d::query::PointQuery;
use parry3d::shape::TriMesh as ParryMesh;

pub struct NearestSurface(Option<ParryMesh>);

impl NearestSurface {
    pub fn new(mesh: &TriMesh) -> Self {
        if mesh.triangles.is_empty() {
            return NearestSurface(None);
        }
        let points = mesh.points.iter().map(|p| Point::new(p.x, p.y, p.z)).collect();
        NearestSurface(Some(ParryMesh::new(points, mesh.triangles.clone())))
    }

    pub fn is_empty(&self) -> bool {
        self.0.is_none()
    }

    /// Distance from `p` to the nearest triangle (infinite for an empty mesh).
    pub fn distance(&self, p: DVec3) -> f64 {
        match &self.0 {
            Some(mesh) => f64::from(mesh.distance_to_local_point(&Point::new(p.x as f32, p.y as f32, p.z as f32), false)),
            None => f64::INFINITY,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn distances_to_a_square_are_exact() {
        let mesh = TriMesh {
            points: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
            normals: Vec::new(),
            triangles: vec![[0, 1, 2], [0, 2, 3]],
        };
        let near = NearestSurface::new(&mesh);
        for (p, want) in [(DVec3::new(0.5, 0.5, 2.0), 2.0), (DVec3::new(2.0, 0.5, 0.0), 1.0), (DVec3::new(-3.0, -4.0, 0.0), 5.0), (DVec3::new(0.2, 0.7, -0.3), 0.3)] {
            assert!((near.distance(p) - want).abs() < 1e-5, "{p}: {}", near.distance(p));
        }
        assert!(NearestSurface::new(&TriMesh::default()).distance(DVec3::ZERO).is_infinite());
    }
}
