//! Contact between a burr and the tissue level sets, measured at points on the burr surface.
//!
//! [`BurrSamples`] places area-weighted points on the burr's cutting head once per burr (star-shaped
//! heads, rays from an interior centre). [`ContactQuery`] holds every per-tick buffer, so a query
//! allocates nothing: one batched trilinear sampling call per tissue for all points, then value +
//! gradient only for the points inside a tissue. Cost ≈ points × tissues reached × 25–50 ns: a
//! tissue whose active bounding box the burr's bounding sphere does not reach is not sampled
//! (outside its band every value is the positive background, so no point can be in contact).
use glam::{DAffine3, DVec3};

use crate::burr::Burr;
use crate::error::{invalid, Result};
use crate::tissues::model::TissueModel;

/// Points on the burr head in the tool frame, with outward normals and the area each stands for.
#[derive(Clone, Debug)]
pub struct BurrSamples {
    pub points: Vec<DVec3>,
    pub normals: Vec<DVec3>,
    /// mm² per point; they add up to the head's surface area.
    pub areas: Vec<f64>,
    /// An interior point of the head (tool frame) the rays start from.
    pub centre: DVec3,
    pub burr: Burr,
    /// See [`BurrSamples::gap_depth`].
    gap: f64,
}

impl BurrSamples {
    /// `count` points on a Fibonacci sphere of directions, projected onto the head along rays from
    /// its centre; the area element of a ray hit is ρ²·dΩ / cos(ray, normal).
    pub fn new(burr: &Burr, count: usize) -> Result<Self> {
        if !(16..=65_536).contains(&count) {
            return Err(invalid("burr sample count", format!("{count}, expected 16 ..= 65536")));
        }
        let reach = burr.bounding_radius();
        // The deepest point of the head on its axis is interior for every rotationally symmetric
        // head; where the depth is level along the axis (a cylinder's), the middle of that
        // stretch, so rays from it reach both ends of a long head alike.
        let axis = |k: usize| DVec3::new(0.0, 0.0, reach * k as f64 / 200.0);
        let depths: Vec<f64> = (0..=200).map(|k| burr.sdf(axis(k))).collect();
        let best = depths.iter().copied().fold(f64::MAX, f64::min);
        if best >= 0.0 {
            return Err(invalid("burr", "found no interior point on its axis"));
        }
        let level = |d: f64| d <= best + 1e-12 * reach.max(1e-3);
        let first = depths.iter().position(|d| level(*d)).unwrap_or(0);
        let last = depths.iter().rposition(|d| level(*d)).unwrap_or(first);
        let centre = axis(first).lerp(axis(last), 0.5);
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        let solid_angle = 4.0 * std::f64::consts::PI / count as f64;
        let (mut points, mut normals, mut areas) = (Vec::new(), Vec::new(), Vec::new());
        let h = 1e-6 * reach.max(1e-3);
        for i in 0..count {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / count as f64;
            let r = (1.0 - z * z).sqrt();
            let phi = golden * i as f64;
            let dir = DVec3::new(r * phi.cos(), r * phi.sin(), z);
            // Bisection for the first sign change along the ray (star-shaped head).
            let (mut lo, mut hi) = (0.0, 2.0 * reach + 1.0);
            for _ in 0..80 {
                let mid = 0.5 * (lo + hi);
                if burr.sdf(centre + dir * mid) < 0.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            let rho = 0.5 * (lo + hi);
            // The samples need a head that each ray leaves once (star-shaped about the centre);
            // every ISO head is convex, but say so rather than sample a wrong surface.
            let crossings = (1..64).filter(|k| {
                let t = |k: i32| 2.0 * rho * f64::from(k) / 64.0;
                (burr.sdf(centre + dir * t(*k - 1)) < 0.0) != (burr.sdf(centre + dir * t(*k)) < 0.0)
            });
            if crossings.count() > 1 {
                return Err(invalid(
                    format!("burr {}", burr.spec()),
                    "its head is not star-shaped about its axis centre; haptic contact cannot sample it",
                ));
            }
            let p = centre + dir * rho;
            let g = DVec3::new(
                burr.sdf(p + DVec3::X * h) - burr.sdf(p - DVec3::X * h),
                burr.sdf(p + DVec3::Y * h) - burr.sdf(p - DVec3::Y * h),
                burr.sdf(p + DVec3::Z * h) - burr.sdf(p - DVec3::Z * h),
            );
            let n = g.try_normalize().unwrap_or(dir);
            points.push(p);
            normals.push(n);
            areas.push(rho * rho * solid_angle / dir.dot(n).max(0.2));
        }
        // Neighbours in memory, neighbours in space: the grids' accessors cache one leaf, so a
        // query walking the points in Morton order mostly stays in it (Fibonacci order jumps by
        // the golden angle and missed the cache nearly every point).
        let keys: Vec<u32> = points.iter().map(|p| morton_key(*p - centre, reach.max(1e-9))).collect();
        let mut order: Vec<usize> = (0..count).collect();
        order.sort_by_key(|&i| (keys[i], i));
        let points = order.iter().map(|&i| points[i]).collect();
        let normals = order.iter().map(|&i| normals[i]).collect();
        let areas = order.iter().map(|&i| areas[i]).collect();
        let mut samples = BurrSamples { points, normals, areas, centre, burr: burr.clone(), gap: 0.0 };
        let reach = samples.points.iter().map(|p| p.distance(centre)).fold(0.0, f64::max);
        samples.gap = 1.5 * std::f64::consts::PI * reach / count as f64;
        if burr.ball_radius().is_none() {
            // A head with edges (a flat end's rim, a cone's tip) pokes out between the samples
            // farther than a ball's smooth surface does: measure it, from the exact support
            // point in many directions (a tilted flat cylinder's rim: ~3 times the ball's
            // estimate, so without this the proxy rested on a rim no sample felt: no force).
            let dirs = 4 * count;
            let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
            let mut worst: f64 = 0.0;
            for i in 0..dirs {
                let z = 1.0 - 2.0 * (i as f64 + 0.5) / dirs as f64;
                let r = (1.0 - z * z).sqrt();
                let phi = golden * i as f64;
                let dir = DVec3::new(r * phi.cos(), r * phi.sin(), z);
                let sampled = samples.points.iter().map(|p| p.dot(dir)).fold(f64::MIN, f64::max);
                worst = worst.max(samples.support(dir).dot(dir) - sampled);
            }
            samples.gap = samples.gap.max(1.5 * worst);
        }
        Ok(samples)
    }

    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// The head's farthest point in direction `dir` (tool frame, unit): the best sample, refined
    /// on the exact burr SDF by tangent steps and projection. The samples alone leave gaps of
    /// ≈ r·(π/N) deep (0.002 mm for 256 points on a 1 mm ball); the proxy uses this to close them.
    pub fn support(&self, dir: DVec3) -> DVec3 {
        let mut best = 0;
        for (i, p) in self.points.iter().enumerate() {
            if p.dot(dir) > self.points[best].dot(dir) {
                best = i;
            }
        }
        let mut p = self.points[best];
        let mut step = self.areas[best].sqrt();
        let sdf = |q: DVec3| self.burr.sdf(q);
        let h = 1e-6;
        let grad = |q: DVec3| {
            DVec3::new(
                sdf(q + DVec3::X * h) - sdf(q - DVec3::X * h),
                sdf(q + DVec3::Y * h) - sdf(q - DVec3::Y * h),
                sdf(q + DVec3::Z * h) - sdf(q - DVec3::Z * h),
            )
            .try_normalize()
            .unwrap_or(dir)
        };
        for _ in 0..12 {
            let n = grad(p);
            let t = dir - n * dir.dot(n);
            let mut q = p + t * step;
            for _ in 0..3 {
                q -= grad(q) * sdf(q);
            }
            if q.dot(dir) > p.dot(dir) {
                p = q;
            } else {
                step *= 0.5;
            }
        }
        p
    }

    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    pub fn total_area(&self) -> f64 {
        self.areas.iter().sum()
    }

    /// Area of the head's shadow seen from `dir` (tool frame, unit): Σ area·max(0, n·dir).
    pub fn frontal_area(&self, dir: DVec3) -> f64 {
        self.normals.iter().zip(&self.areas).map(|(n, a)| a * n.dot(dir).max(0.0)).sum()
    }

    /// Like [`BurrSamples::frontal_area`] over the given contact points only (`dir` in the world
    /// frame, `pose` the burr's): the area those points present to a motion along `dir`. Over the
    /// points touching tissue, a stroke of length a along `dir` removes ≈ a × this.
    pub fn frontal_area_of(&self, contacts: &[ContactPoint], pose: &DAffine3, dir: DVec3) -> f64 {
        let dir = pose.matrix3.transpose() * dir;
        contacts.iter().map(|c| self.areas[c.sample as usize] * self.normals[c.sample as usize].dot(dir).max(0.0)).sum()
    }

    /// How far (mm) the surface of the head can lie beyond every sample point in some direction:
    /// ≈ reach·π/N (5.9 µm at worst for 256 points on a 1 mm ball, measured), with a 1.5 margin;
    /// for other heads at least 1.5 × the largest gap measured at construction (edges and tips).
    /// A band this deep over a surface holds at least one sample wherever the head touches it.
    pub fn gap_depth(&self) -> f64 {
        self.gap
    }
}

/// Morton (Z-order) key of `p` within the cube of half-side `half`, 10 bits per axis.
fn morton_key(p: DVec3, half: f64) -> u32 {
    let q = |v: f64| (((v / half + 1.0) * 0.5).clamp(0.0, 1.0) * 1023.0) as u32;
    let spread = |mut v: u32| {
        v = (v | (v << 16)) & 0x0300_00ff;
        v = (v | (v << 8)) & 0x0300_f00f;
        v = (v | (v << 4)) & 0x030c_30c3;
        (v | (v << 2)) & 0x0924_9249
    };
    spread(q(p.x)) | spread(q(p.y)) << 1 | spread(q(p.z)) << 2
}

/// One burr point inside a tissue.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactPoint {
    /// Index into [`BurrSamples`].
    pub sample: u32,
    /// Index of the tissue in the model.
    pub tissue: u16,
    /// How far inside (mm, > 0; at most the band's half width).
    pub depth: f64,
    /// Outward unit normal of the tissue at the point (world).
    pub normal: DVec3,
    /// World position of the point.
    pub position: DVec3,
}

/// Buffers for contact queries against one model, sized once; queries reuse them.
pub struct ContactQuery {
    pub samples: BurrSamples,
    xyz: Vec<f32>,
    /// Values per tissue, tissue-major, of the candidate points (see `query`).
    values: Vec<f32>,
    gather_xyz: Vec<f32>,
    gather_out: Vec<f32>,
    gather_index: Vec<u32>,
    /// The points a query samples (indices) and their world positions.
    candidates: Vec<u32>,
    candidate_xyz: Vec<f32>,
    owner: Vec<u16>,
    contacts: Vec<ContactPoint>,
    tissues: usize,
    /// World box of each tissue's active voxels, padded by a voxel for the trilinear stencil;
    /// `None` = unknown, always sample. See [`ContactQuery::with_bounds`].
    bounds: Vec<Option<(DVec3, DVec3)>>,
    /// Radius around `samples.centre` that holds every sample point (tool frame, mm).
    reach: f64,
    /// World → tool frame of a burr pose whose head is known to be free space (see
    /// [`ContactQuery::set_freed`]); `None` = the grids alone decide.
    freed: Option<DAffine3>,
    /// Per point: minus the freed head's signed distance (> 0 inside the freed head).
    freed_values: Vec<f64>,
}

/// World box (min, max) of a tissue's active voxels padded by one voxel; an empty grid gets an
/// inverted box that nothing reaches.
fn tissue_bounds(grid: &dentsim_vdb::LevelSet) -> (DVec3, DVec3) {
    let h = grid.voxel_size();
    match grid.index_bbox() {
        Some(b) => (grid.index_to_world(b.min) - DVec3::splat(h), grid.index_to_world(b.max) + DVec3::splat(h)),
        None => (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN)),
    }
}

impl ContactQuery {
    pub fn new(samples: BurrSamples, tissues: usize) -> Self {
        let n = samples.len();
        let reach = samples.points.iter().map(|p| p.distance(samples.centre)).fold(0.0, f64::max);
        ContactQuery {
            bounds: vec![None; tissues],
            reach,
            xyz: vec![0.0; 3 * n],
            values: vec![0.0; n * tissues.max(1)],
            gather_xyz: vec![0.0; 3 * n],
            gather_out: vec![0.0; 4 * n],
            gather_index: vec![0; n],
            candidates: vec![0; n],
            candidate_xyz: vec![0.0; 3 * n],
            owner: vec![0; n],
            contacts: Vec::with_capacity(n),
            tissues,
            freed: None,
            freed_values: vec![0.0; n],
            samples,
        }
    }

    /// Declares the burr head at `pose` free space for the following queries, or forgets it.
    ///
    /// The haptic tick passes the end pose of its last cut stroke: that head was removed exactly,
    /// but the grids only know it up to trilinear interpolation, which reads the rim of a fresh
    /// cut as inside tissue by up to ≈ h²/4r (1.2 µm for a 1 mm ball at 0.05 mm voxels, more than
    /// a tick's advance at the removal rate). Queries then read each point's tissue value as
    /// max(grid, −sdf_head(point)): the union of the grid's free space and the freed head, exact
    /// at the fresh cut surface. Material only ever goes away, so the statement stays true.
    pub fn set_freed(&mut self, pose: Option<DAffine3>) {
        self.freed = pose.map(|p| p.inverse());
    }

    /// Like [`ContactQuery::new`], with each tissue's bounding box taken once so queries skip the
    /// tissues the burr cannot reach. The boxes stay valid while tissues only lose material (cuts:
    /// the new surface lies inside the old material, hence inside the old band's box); call
    /// [`ContactQuery::refresh_bounds`] after anything else changes a grid.
    pub fn with_bounds(samples: BurrSamples, model: &TissueModel) -> Self {
        let mut q = Self::new(samples, model.tissues.len());
        q.refresh_bounds(model);
        q
    }

    /// Re-reads every tissue's bounding box (walks the trees: not for the haptic tick).
    pub fn refresh_bounds(&mut self, model: &TissueModel) {
        for (b, t) in self.bounds.iter_mut().zip(&model.tissues) {
            *b = Some(tissue_bounds(&t.grid));
        }
    }

    /// True if tissue `t` may hold a point within `margin` of the sphere (`centre`, `radius`).
    fn may_reach(&self, t: usize, centre: DVec3, radius: f64) -> bool {
        match self.bounds.get(t).copied().flatten() {
            Some((lo, hi)) => {
                let nearest = centre.clamp(lo.min(hi), hi.max(lo));
                lo.cmple(hi).all() && nearest.distance_squared(centre) <= radius * radius
            }
            None => true,
        }
    }

    /// The points of the burr at `pose` that lie deeper than `-threshold` in a tissue (value <
    /// `threshold`; pass 0 for penetration). Each point takes the tissue with the lowest value,
    /// i.e. the one containing it. Allocation-free when the model has the tissue count given to `new`.
    pub fn query(&mut self, model: &TissueModel, pose: &DAffine3, threshold: f32) -> &[ContactPoint] {
        self.contacts.clear();
        let n = self.samples.len();
        let tissues = model.tissues.len().min(self.tissues);
        for (i, p) in self.samples.points.iter().enumerate() {
            let w = pose.transform_point3(*p);
            self.xyz[3 * i] = w.x as f32;
            self.xyz[3 * i + 1] = w.y as f32;
            self.xyz[3 * i + 2] = w.z as f32;
            if let Some(to_tool) = &self.freed {
                self.freed_values[i] = -self.samples.burr.sdf(to_tool.transform_point3(w));
            }
        }
        // Candidates: with a freed head, a point that deep in its free space cannot touch, whatever
        // the grids say (in cut mode, the trailing half of the burr on each proxy sub-step).
        let mut candidates = 0usize;
        for i in 0..n {
            if self.freed.is_none() || self.freed_values[i] < f64::from(threshold) {
                self.candidates[candidates] = i as u32;
                self.candidate_xyz[3 * candidates..3 * candidates + 3].copy_from_slice(&self.xyz[3 * i..3 * i + 3]);
                candidates += 1;
            }
        }
        if candidates == 0 {
            return &self.contacts;
        }
        // Rotations keep distances, so the sample sphere maps to a sphere of the same radius.
        let centre = pose.transform_point3(self.samples.centre);
        let radius = self.reach + f64::from(threshold.max(0.0)) + 1e-6;
        for (t, tissue) in model.tissues.iter().take(tissues).enumerate() {
            let reach = self.may_reach(t, centre, radius);
            let values = &mut self.values[t * n..t * n + candidates];
            if reach {
                tissue.grid.sample_values(&self.candidate_xyz[..3 * candidates], values);
            } else {
                values.fill(f32::MAX);
            }
        }
        // Owner tissue of every point below the threshold.
        let mut inside = 0usize;
        for (k, &i) in self.candidates[..candidates].iter().enumerate() {
            let i = i as usize;
            let mut best = (f32::MAX, 0u16);
            for t in 0..tissues {
                let v = self.values[t * n + k];
                if v < best.0 {
                    best = (v, t as u16);
                }
            }
            let below = match self.freed {
                None => best.0 < threshold,
                Some(_) => f64::from(best.0).max(self.freed_values[i]) < f64::from(threshold),
            };
            if below {
                self.owner[i] = best.1;
                self.gather_index[inside] = i as u32;
                inside += 1;
            }
        }
        if inside == 0 {
            return &self.contacts;
        }
        // Gradients, one batched call per tissue over its own points.
        for t in 0..tissues {
            let mut m = 0usize;
            for k in 0..inside {
                let i = self.gather_index[k] as usize;
                if self.owner[i] as usize == t {
                    self.gather_xyz[3 * m..3 * m + 3].copy_from_slice(&self.xyz[3 * i..3 * i + 3]);
                    m += 1;
                }
            }
            if m == 0 {
                continue;
            }
            model.tissues[t]
                .grid
                .sample_value_gradients(&self.gather_xyz[..3 * m], &mut self.gather_out[..4 * m]);
            let mut j = 0usize;
            for k in 0..inside {
                let i = self.gather_index[k] as usize;
                if self.owner[i] as usize != t {
                    continue;
                }
                let g = &self.gather_out[4 * j..4 * j + 4];
                j += 1;
                // Deep inside the band the gradient vanishes: push along the burr's inward normal.
                let fallback = -pose.transform_vector3(self.samples.normals[i]);
                let grad = DVec3::new(f64::from(g[1]), f64::from(g[2]), f64::from(g[3]));
                let normal = grad.try_normalize().filter(|_| grad.length() > 0.5).unwrap_or(fallback);
                let value = match self.freed {
                    None => f64::from(g[0]),
                    Some(_) => f64::from(g[0]).max(self.freed_values[i]),
                };
                self.contacts.push(ContactPoint {
                    sample: i as u32,
                    tissue: t as u16,
                    depth: -value,
                    normal,
                    position: DVec3::new(
                        f64::from(self.xyz[3 * i]),
                        f64::from(self.xyz[3 * i + 1]),
                        f64::from(self.xyz[3 * i + 2]),
                    ),
                });
            }
        }
        &self.contacts
    }

    /// The lowest tissue value at one world point (mm), allocation-free; with a freed head (see
    /// [`ContactQuery::set_freed`]) at least minus its signed distance.
    pub fn value_at(&self, model: &TissueModel, p: DVec3) -> f32 {
        let xyz = [p.x as f32, p.y as f32, p.z as f32];
        let mut best = f32::MAX;
        for (i, t) in model.tissues.iter().take(self.tissues).enumerate() {
            if !self.may_reach(i, p, 1e-6) {
                continue;
            }
            let mut v = [0f32];
            t.grid.sample_values(&xyz, &mut v);
            best = best.min(v[0]);
        }
        match &self.freed {
            None => best,
            Some(to_tool) => best.max(-self.samples.burr.sdf(to_tool.transform_point3(p)) as f32),
        }
    }

    /// The contacts of the last query.
    pub fn contacts(&self) -> &[ContactPoint] {
        &self.contacts
    }
}
