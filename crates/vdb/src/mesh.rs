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

    /// The integral of the mean curvature H = (κ₁ + κ₂)/2 over a closed surface, mm (positive
    /// where convex): half the sum over edges of length × dihedral angle. Edges not shared by
    /// exactly two triangles add nothing.
    pub fn total_mean_curvature(&self) -> f64 {
        self.total_mean_curvature_where(|_| true)
    }

    /// The connected piece (triangles joined through shared vertices) enclosing the largest
    /// volume, alone; points, normals and triangles keep their order.
    pub fn largest_body(&self) -> TriMesh {
        let mut parent: Vec<u32> = (0..self.points.len() as u32).collect();
        fn root(parent: &mut [u32], mut x: u32) -> u32 {
            while parent[x as usize] != x {
                parent[x as usize] = parent[parent[x as usize] as usize];
                x = parent[x as usize];
            }
            x
        }
        for t in &self.triangles {
            let a = root(&mut parent, t[0]);
            for &v in &t[1..] {
                let b = root(&mut parent, v);
                parent[b as usize] = a;
            }
        }
        let mut volumes: std::collections::HashMap<u32, f64> = std::collections::HashMap::new();
        for t in &self.triangles {
            let [a, b, c] = t.map(|i| self.points[i as usize].as_dvec3());
            *volumes.entry(root(&mut parent, t[0])).or_insert(0.0) += a.dot(b.cross(c)) / 6.0;
        }
        // Ties by the smaller root, so the choice is the same on every run.
        let Some(body) = volumes.iter().max_by(|a, b| a.1.total_cmp(b.1).then(b.0.cmp(a.0))).map(|(&r, _)| r) else { return TriMesh::default() };
        let mut index = vec![u32::MAX; self.points.len()];
        let mut out = TriMesh::default();
        for (i, p) in self.points.iter().enumerate() {
            if root(&mut parent, i as u32) == body {
                index[i] = out.points.len() as u32;
                out.points.push(*p);
                if let Some(n) = self.normals.get(i) {
                    out.normals.push(*n);
                }
            }
        }
        out.triangles = self.triangles.iter().filter(|t| index[t[0] as usize] != u32::MAX).map(|t| t.map(|i| index[i as usize])).collect();
        out
    }

    /// [`Self::total_mean_curvature`] over the edges whose midpoint `keep` admits.
    pub fn total_mean_curvature_where(&self, keep: impl Fn(glam::DVec3) -> bool) -> f64 {
        let p = |i: u32| self.points[i as usize].as_dvec3();
        // Per undirected edge: its first triangle's directed edge (a, b) and far corner c, the
        // second's far corner d, and how many triangles share it (a third: non-manifold).
        struct Edge {
            a: u32,
            b: u32,
            c: u32,
            d: u32,
            shared: u8,
        }
        // In the triangles' order, so the sum is the same on every run.
        let mut edges: Vec<Edge> = Vec::with_capacity(self.triangles.len() * 3 / 2);
        let mut index: std::collections::HashMap<(u32, u32), usize> = std::collections::HashMap::with_capacity(edges.capacity());
        for tri in &self.triangles {
            for e in 0..3 {
                let (a, b, c) = (tri[e], tri[(e + 1) % 3], tri[(e + 2) % 3]);
                let i = *index.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    edges.push(Edge { a, b, c, d: u32::MAX, shared: 0 });
                    edges.len() - 1
                });
                let edge = &mut edges[i];
                if edge.shared == 1 {
                    edge.d = c;
                }
                edge.shared = edge.shared.saturating_add(1);
            }
        }
        edges
            .iter()
            .filter(|e| e.shared == 2 && keep(0.5 * (p(e.a) + p(e.b))))
            .map(|e| {
                let (pa, pb, pc, pd) = (p(e.a), p(e.b), p(e.c), p(e.d));
                let edge = pb - pa;
                let n1 = edge.cross(pc - pa).normalize_or_zero();
                let n2 = (pa - pb).cross(pd - pb).normalize_or_zero();
                let angle = n1.cross(n2).length().atan2(n1.dot(n2));
                // Convex where the second triangle's far corner lies behind the first's plane.
                let sign = if (pd - pa).dot(n1) < 0.0 { 1.0 } else { -1.0 };
                0.5 * edge.length() * angle * sign
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
