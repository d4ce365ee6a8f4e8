//! Exact signed distance to a solid of revolution about +Z, given by its half-profile in the
//! (radial, z) half-plane: a chain of line segments and circular arcs that starts and ends on the
//! axis. The 3-D distance to the surface equals the 2-D distance from (ρ, z) to that chain (the
//! axis itself is not surface), and the sign comes from a crossing test on the closed chain, so
//! the result is exact everywhere, corners and tips included.
use glam::DVec2;

/// One piece of the profile, in order from the tip (bottom) to the top.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Piece {
    Line { a: DVec2, b: DVec2 },
    /// Counter-clockwise (seen with ρ to the right, z up) arc of at most half a turn about
    /// `centre` from `a` to `b`; `ccw = false` runs clockwise.
    Arc { centre: DVec2, radius: f64, a: DVec2, b: DVec2, ccw: bool },
}

impl Piece {
    pub fn start(&self) -> DVec2 {
        match *self {
            Piece::Line { a, .. } | Piece::Arc { a, .. } => a,
        }
    }

    pub fn end(&self) -> DVec2 {
        match *self {
            Piece::Line { b, .. } | Piece::Arc { b, .. } => b,
        }
    }

    /// Unsigned distance from `p` to the piece.
    pub fn distance(&self, p: DVec2) -> f64 {
        match *self {
            Piece::Line { a, b } => {
                let ab = b - a;
                let t = ((p - a).dot(ab) / ab.length_squared().max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
                (p - (a + ab * t)).length()
            }
            Piece::Arc { centre, radius, a, b, ccw } => {
                let v = p - centre;
                let (s, e) = if ccw { (a - centre, b - centre) } else { (b - centre, a - centre) };
                // Inside the angular span (at most half a turn): both cross products non-negative.
                if s.perp_dot(v) >= 0.0 && v.perp_dot(e) >= 0.0 {
                    (v.length() - radius).abs()
                } else {
                    (p - a).length().min((p - b).length())
                }
            }
        }
    }

    /// Whether `p` lies in the circular segment between this arc and its chord (false for lines).
    fn in_segment(&self, p: DVec2) -> bool {
        let Piece::Arc { centre, radius, a, b, ccw } = *self else { return false };
        if (p - centre).length_squared() >= radius * radius {
            return false;
        }
        // The arc's midpoint side of the chord holds the segment.
        let mid_dir = {
            let (s, e) = if ccw { (a - centre, b - centre) } else { (b - centre, a - centre) };
            let m = s + e;
            if m.length_squared() > 1e-24 { m } else { s.perp() }
        };
        let chord = b - a;
        let side_p = chord.perp_dot(p - a);
        let side_m = chord.perp_dot(centre + mid_dir - a);
        side_p * side_m > 0.0
    }
}

/// A closed half-profile: pieces from a point on the axis back to the axis.
#[derive(Clone, Debug, PartialEq)]
pub struct Profile {
    pub pieces: Vec<Piece>,
    /// Largest radial extent and z range, for bounds.
    pub max_radius: f64,
    pub z_min: f64,
    pub z_max: f64,
    /// Whether the solid (the profile and its mirror image across the axis) is convex.
    pub convex: bool,
    /// The highest point of the surface with an outward normal pointing down (−z), and the lowest
    /// with one pointing up: above the first, the surface faces no lower than sideways.
    pub facing_down_below: f64,
    pub facing_up_above: f64,
    /// The pieces readied for [`sdf`](Self::sdf), then the closing chord along the axis.
    edges: Vec<Edge>,
    /// The same in f32 for [`sdf_row`](Self::sdf_row).
    edges32: Vec<Edge32>,
}

/// A piece readied for [`Profile::sdf`]: what every evaluation would otherwise recompute.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Edge {
    a: DVec2,
    b: DVec2,
    ab: DVec2,
    inv_len2: f64,
    /// The chord's run in ρ per unit of z (crossing test; unused when level).
    dx_dz: f64,
    /// Arcs keep their piece (distance and circular segment); a line's distance is inline.
    arc: Option<Piece>,
}

/// A piece in f32 for [`Profile::sdf_row`]; arcs carry their circle, span and chord side.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Edge32 {
    a: [f32; 2],
    b: [f32; 2],
    ab: [f32; 2],
    inv_len2: f32,
    dx_dz: f32,
    arc: bool,
    centre: [f32; 2],
    radius: f32,
    /// The span's first and last directions from the centre, counter-clockwise.
    span: [[f32; 2]; 2],
    /// +1 or −1: the side of the chord (a → b) the arc lies on.
    side: f32,
    /// Whether a ray toward +ρ can cross the chord: not when it is level (the crossing test is
    /// half-open in z), nor when it lies on the axis (the test looks from ρ > 0).
    crossable: bool,
}

impl Edge32 {
    fn new(e: &Edge) -> Self {
        let v = |p: DVec2| [p.x as f32, p.y as f32];
        let mut out = Edge32 { a: v(e.a), b: v(e.b), ab: v(e.ab), inv_len2: e.inv_len2 as f32, dx_dz: e.dx_dz as f32, ..Default::default() };
        out.crossable = out.a[1] != out.b[1] && !(out.a[0] == 0.0 && out.b[0] == 0.0);
        if let Some(Piece::Arc { centre, radius, a, b, ccw }) = e.arc {
            let (s, t) = if ccw { (a - centre, b - centre) } else { (b - centre, a - centre) };
            let mid = if (s + t).length_squared() > 1e-24 { s + t } else { s.perp() };
            out.arc = true;
            out.centre = v(centre);
            out.radius = radius as f32;
            out.span = [v(s), v(t)];
            out.side = (b - a).perp_dot(centre + mid - a).signum() as f32;
        }
        out
    }
}

/// Points per batch of [`Profile::sdf_row`]: short arrays the compiler vectorises across.
const BATCH: usize = 16;

/// Points in one batch of [`Profile::sdf_lanes`].
pub const LANES: usize = BATCH;

/// Up to [`LANES`] points of rows that share a step: lane `l` is the point `origin[l] + t[l]·step`
/// of its own row. A haptic tick's rows are evaluated a few voxels at a time (the band's two
/// sides of the head), so a row's runs leave most of a batch idle; lanes filled from several rows
/// keep it full. Each lane's arithmetic is the row kernel's, so its distance is bit for bit the
/// one [`Profile::sdf_row_from`] gives at `t[l]` along its row.
#[derive(Clone, Copy, Debug, Default)]
pub struct Lanes {
    pub x: [f32; LANES],
    pub y: [f32; LANES],
    pub z: [f32; LANES],
    pub t: [f32; LANES],
}

impl Edge {
    fn new(a: DVec2, b: DVec2, arc: Option<Piece>) -> Self {
        let ab = b - a;
        let dx_dz = if ab.y != 0.0 { ab.x / ab.y } else { 0.0 };
        Edge { a, b, ab, inv_len2: 1.0 / ab.length_squared().max(f64::MIN_POSITIVE), dx_dz, arc }
    }

    /// Whether the ray from `q` toward +ρ crosses the chord (half-open in z), as the sign test needs.
    #[inline(always)]
    fn crossed_by(&self, q: DVec2) -> bool {
        (self.a.y > q.y) != (self.b.y > q.y) && self.a.x + (q.y - self.a.y) * self.dx_dz > q.x
    }
}

impl Profile {
    pub fn new(pieces: Vec<Piece>) -> Self {
        let mut max_radius: f64 = 0.0;
        let (mut z_min, mut z_max) = (f64::INFINITY, f64::NEG_INFINITY);
        for piece in &pieces {
            for q in [piece.start(), piece.end()] {
                max_radius = max_radius.max(q.x);
                z_min = z_min.min(q.y);
                z_max = z_max.max(q.y);
            }
            if let Piece::Arc { centre, radius, a, b, ccw } = *piece {
                // An arc may bulge beyond its end points, at most to its circle's extreme points
                // that lie on the arc. (The whole circle bounded a flame's shallow ogive, 6 mm
                // of radius, by a box four times the head's.)
                let (s, e) = if ccw { (a - centre, b - centre) } else { (b - centre, a - centre) };
                for dir in [DVec2::X, DVec2::NEG_X, DVec2::Y, DVec2::NEG_Y] {
                    if s.perp_dot(dir) >= 0.0 && dir.perp_dot(e) >= 0.0 {
                        let q = centre + dir * radius;
                        max_radius = max_radius.max(q.x);
                        z_min = z_min.min(q.y);
                        z_max = z_max.max(q.y);
                    }
                }
            }
        }
        let (convex, facing_down_below, facing_up_above) = facing(&pieces);
        let mut edges: Vec<Edge> = pieces
            .iter()
            .map(|p| Edge::new(p.start(), p.end(), matches!(p, Piece::Arc { .. }).then_some(*p)))
            .collect();
        if let (Some(first), Some(last)) = (pieces.first(), pieces.last()) {
            edges.push(Edge::new(last.end(), first.start(), None));
        }
        let edges32 = edges.iter().map(Edge32::new).collect();
        Profile { pieces, max_radius, z_min, z_max, convex, facing_down_below, facing_up_above, edges, edges32 }
    }

    /// An upper bound on the radius of the profile's points with height in `[z0, z1]` (0 when
    /// none): a line's largest at the window's edges or its ends, an arc's at most its circle's
    /// over the part of the window its heights span.
    pub fn max_radius_within(&self, z0: f64, z1: f64) -> f64 {
        let mut best: f64 = 0.0;
        for piece in &self.pieces {
            match *piece {
                Piece::Line { a, b } => {
                    let (lo, hi) = (a.y.min(b.y).max(z0), a.y.max(b.y).min(z1));
                    if lo > hi {
                        continue;
                    }
                    if a.y == b.y {
                        best = best.max(a.x.max(b.x));
                        continue;
                    }
                    let at = |z: f64| a.x + (b.x - a.x) * ((z - a.y) / (b.y - a.y)).clamp(0.0, 1.0);
                    best = best.max(at(lo)).max(at(hi));
                }
                Piece::Arc { centre, radius, a, b, ccw } => {
                    // The arc's heights: its ends', and its circle's top or bottom where the arc
                    // passes them.
                    let (s, e) = if ccw { (a - centre, b - centre) } else { (b - centre, a - centre) };
                    let (mut lo, mut hi) = (a.y.min(b.y), a.y.max(b.y));
                    for dir in [DVec2::Y, DVec2::NEG_Y] {
                        if s.perp_dot(dir) >= 0.0 && dir.perp_dot(e) >= 0.0 {
                            lo = lo.min(centre.y + dir.y * radius);
                            hi = hi.max(centre.y + dir.y * radius);
                        }
                    }
                    let (lo, hi) = (lo.max(z0), hi.min(z1));
                    if lo > hi {
                        continue;
                    }
                    let dz = if centre.y < lo { lo - centre.y } else if centre.y > hi { centre.y - hi } else { 0.0 };
                    best = best.max(centre.x + (radius * radius - dz * dz).max(0.0).sqrt());
                }
            }
        }
        best
    }

    /// Exact signed distance (negative inside) of the point at radius `rho` ≥ 0 and height `z`.
    pub fn sdf(&self, rho: f64, z: f64) -> f64 {
        let p = DVec2::new(rho, z);
        // The sign test looks from just off the axis, so chords lying on the axis stay outside it.
        let q = DVec2::new(rho.max(1e-9), z);
        // Lines by squared distance (one root at the end), arcs by their own.
        let (mut line2, mut arc) = (f64::INFINITY, f64::INFINITY);
        let mut inside = false;
        let Some((closing, pieces)) = self.edges.split_last() else { return f64::INFINITY };
        for e in pieces {
            match e.arc {
                None => {
                    let ap = p - e.a;
                    let t = (ap.dot(e.ab) * e.inv_len2).clamp(0.0, 1.0);
                    line2 = line2.min((ap - e.ab * t).length_squared());
                }
                Some(piece) => {
                    arc = arc.min(piece.distance(p));
                    inside ^= piece.in_segment(q);
                }
            }
            inside ^= e.crossed_by(q);
        }
        // The axis closes the chain (from the last end back to the first start).
        inside ^= closing.crossed_by(q);
        let d = line2.sqrt().min(arc);
        if inside { -d } else { d }
    }
}

impl Profile {
    /// [`sdf`](Self::sdf) in f32 at the tool-frame points `origin + i·step` for each `out[i]`,
    /// batches of points at a time (the same exact distance, to f32 rounding: about 1e-7 of the
    /// coordinates). For a row of voxels, where one point at a time leaves the vector units idle.
    pub fn sdf_row(&self, origin: [f32; 3], step: [f32; 3], out: &mut [f32]) {
        self.sdf_row_from(origin, step, 0, out);
    }

    /// [`sdf_row`](Self::sdf_row) at the row's points `first + i` for each `out[i]`: each value
    /// bit for bit what the row from its origin gives there, wherever a run of it starts.
    pub fn sdf_row_from(&self, origin: [f32; 3], step: [f32; 3], first: usize, out: &mut [f32]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, checked just above.
            return unsafe { self.sdf_row_from_avx2(origin, step, first, out) };
        }
        self.sdf_row_from_baseline(origin, step, first, out);
    }

    /// [`Self::sdf_row_from`] compiled for AVX2, the same values (see [`Self::sdf_lanes_avx2`]).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn sdf_row_from_avx2(&self, origin: [f32; 3], step: [f32; 3], first: usize, out: &mut [f32]) {
        self.sdf_row_from_baseline(origin, step, first, out);
    }

    /// [`Self::sdf_row_from`] for the baseline target (inlined into the AVX2 build).
    #[inline(always)]
    pub(crate) fn sdf_row_from_baseline(&self, origin: [f32; 3], step: [f32; 3], first: usize, out: &mut [f32]) {
        let Some((closing, pieces)) = self.edges32.split_last() else {
            out.fill(f32::INFINITY);
            return;
        };
        // Whole batches; a tail of at most 8 in a smaller one (rows are short, a run is often
        // under 20 voxels, and a small batch costs nearly what a whole one does).
        let (mut first, mut rest) = (first, out);
        while !rest.is_empty() {
            let n = rest.len();
            let (chunk, tail) = rest.split_at_mut(n.min(BATCH));
            let ts = |l: usize| (first + l) as f32;
            match n {
                9.. => sdf_batch::<BATCH>(pieces, closing, origin, step, std::array::from_fn(ts), chunk),
                5..=8 => sdf_batch::<8>(pieces, closing, origin, step, std::array::from_fn(ts), chunk),
                _ => sdf_batch::<4>(pieces, closing, origin, step, std::array::from_fn(ts), chunk),
            }
            first += chunk.len();
            rest = tail;
        }
    }
}

impl Profile {
    /// [`sdf_row_from`](Self::sdf_row_from) at the first `n` (at most [`LANES`]) lanes' points,
    /// each bit for bit its row's value there, into `out[..n]`.
    pub fn sdf_lanes(&self, lanes: &Lanes, n: usize, step: [f32; 3], out: &mut [f32]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, checked just above.
            return unsafe { self.sdf_lanes_avx2(lanes, n, step, out) };
        }
        self.sdf_lanes_baseline(lanes, n, step, out);
    }

    /// [`Self::sdf_lanes`] compiled for AVX2: eight lanes an instruction where the baseline
    /// x86-64 has four. The same operations lane by lane (no fused multiply-add: that is another
    /// feature, and Rust never fuses unasked), so the same values bit for bit (a test pins them).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn sdf_lanes_avx2(&self, lanes: &Lanes, n: usize, step: [f32; 3], out: &mut [f32]) {
        self.sdf_lanes_baseline(lanes, n, step, out);
    }

    /// [`Self::sdf_lanes`] for the baseline target (inlined into the AVX2 build).
    #[inline(always)]
    pub(crate) fn sdf_lanes_baseline(&self, lanes: &Lanes, n: usize, step: [f32; 3], out: &mut [f32]) {
        let Some((closing, pieces)) = self.edges32.split_last() else {
            out[..n].fill(f32::INFINITY);
            return;
        };
        // The row kernel's batch sizes: a lane's arithmetic is the same in each.
        match n {
            9.. => lanes_batch::<BATCH>(pieces, closing, lanes, step, &mut out[..n]),
            5..=8 => lanes_batch::<8>(pieces, closing, lanes, step, &mut out[..n]),
            _ => lanes_batch::<4>(pieces, closing, lanes, step, &mut out[..n]),
        }
    }
}

/// [`Profile::sdf_lanes`] in a batch of N: each lane's point as [`sdf_batch`] makes it.
#[inline(always)]
fn lanes_batch<const N: usize>(pieces: &[Edge32], closing: &Edge32, lanes: &Lanes, step: [f32; 3], out: &mut [f32]) {
    let (mut rho, mut z) = ([0f32; N], [0f32; N]);
    for l in 0..N {
        let t = lanes.t[l];
        let (x, y) = (lanes.x[l] + step[0] * t, lanes.y[l] + step[1] * t);
        rho[l] = (x * x + y * y).sqrt();
        z[l] = lanes.z[l] + step[2] * t;
    }
    sdf_points(pieces, closing, rho, z, out);
}

/// [`Profile::sdf_row`] at the row's points `ts[l]` (l < N), into `out` (at most N). Each
/// lane's arithmetic is the same whatever N, so a point's distance does not depend on the batch
/// it falls in.
#[inline(always)]
fn sdf_batch<const N: usize>(pieces: &[Edge32], closing: &Edge32, origin: [f32; 3], step: [f32; 3], ts: [f32; N], out: &mut [f32]) {
    let (mut rho, mut z) = ([0f32; N], [0f32; N]);
    for l in 0..N {
        let t = ts[l];
        let (x, y) = (origin[0] + step[0] * t, origin[1] + step[1] * t);
        rho[l] = (x * x + y * y).sqrt();
        z[l] = origin[2] + step[2] * t;
    }
    sdf_points(pieces, closing, rho, z, out);
}

/// The signed distance at N points given by radius and height, into `out` (at most N).
#[inline(always)]
fn sdf_points<const N: usize>(pieces: &[Edge32], closing: &Edge32, rho: [f32; N], z: [f32; N], out: &mut [f32]) {
    // The sign test looks from just off the axis, as `sdf`.
    let rho_q = rho.map(|r| r.max(1e-9));
    let (mut line2, mut arc) = ([f32::INFINITY; N], [f32::INFINITY; N]);
    let mut inside = [0u32; N];
    for e in pieces {
        if e.arc {
            for l in 0..N {
                let (vx, vz) = (rho[l] - e.centre[0], z[l] - e.centre[1]);
                let in_span = (e.span[0][0] * vz - e.span[0][1] * vx >= 0.0) & (vx * e.span[1][1] - vz * e.span[1][0] >= 0.0);
                let (ax, az) = (rho[l] - e.a[0], z[l] - e.a[1]);
                let (bx, bz) = (rho[l] - e.b[0], z[l] - e.b[1]);
                // One root per arc, of the centre's square within the span, else of the nearer
                // end's: the values of a root each (correctly rounded and monotone). Picked by
                // bit masks: an `if` here made the compiler branch per lane and lose the vectors.
                let keep = 0u32.wrapping_sub(u32::from(in_span));
                let pick = |a: f32, b: f32| f32::from_bits((a.to_bits() & keep) | (b.to_bits() & !keep));
                let root = pick(vx * vx + vz * vz, (ax * ax + az * az).min(bx * bx + bz * bz)).sqrt();
                // (Outside the span, root − 0 is the root itself, bit for bit: it is not negative.)
                arc[l] = arc[l].min((root - pick(e.radius, 0.0)).abs());
                // In the circular segment between the arc and its chord.
                let (qx, qz) = (rho_q[l] - e.centre[0], z[l] - e.centre[1]);
                let side = e.ab[0] * (z[l] - e.a[1]) - e.ab[1] * (rho_q[l] - e.a[0]);
                inside[l] ^= ((qx * qx + qz * qz < e.radius * e.radius) & (side * e.side > 0.0)) as u32;
            }
        } else {
            for l in 0..N {
                let (px, pz) = (rho[l] - e.a[0], z[l] - e.a[1]);
                let t = ((px * e.ab[0] + pz * e.ab[1]) * e.inv_len2).max(0.0).min(1.0);
                let (dx, dz) = (px - e.ab[0] * t, pz - e.ab[1] * t);
                line2[l] = line2[l].min(dx * dx + dz * dz);
            }
        }
        // (Uncrossable chords are skipped: each would flip no lane.)
        if e.crossable {
            for l in 0..N {
                inside[l] ^= e.crossed_by(rho_q[l], z[l]) as u32;
            }
        }
    }
    if closing.crossable {
        for l in 0..N {
            inside[l] ^= closing.crossed_by(rho_q[l], z[l]) as u32;
        }
    }
    for (l, o) in out.iter_mut().enumerate() {
        let d = line2[l].sqrt().min(arc[l]);
        *o = if inside[l] != 0 { -d } else { d };
    }
}

impl Edge32 {
    #[inline(always)]
    fn crossed_by(&self, rho: f32, z: f32) -> bool {
        ((self.a[1] > z) != (self.b[1] > z)) & (self.a[0] + (z - self.a[1]) * self.dx_dz > rho)
    }
}

/// Convexity and the facing heights of [`Profile`], from the chain as a fine polygon (arcs in
/// steps of at most π/512). A line's normal is its edge's; an arc's normals over one step lie
/// within half a step of its chord's, so an arc edge facing within that of sideways counts as
/// facing both ways (a bound, never short).
fn facing(pieces: &[Piece]) -> (bool, f64, f64) {
    const ARC_STEPS: usize = 1024;
    // Points, each with the slack of the normal of the edge that ends there.
    let mut chain: Vec<(DVec2, f64)> = Vec::new();
    for piece in pieces {
        match *piece {
            Piece::Line { a, b } => chain.extend([(a, 0.0), (b, 0.0)]),
            Piece::Arc { centre, radius, a, b, ccw } => {
                let (sa, sb) = ((a - centre).to_angle(), (b - centre).to_angle());
                let mut span = sb - sa;
                if ccw && span < 0.0 {
                    span += std::f64::consts::TAU;
                }
                if !ccw && span > 0.0 {
                    span -= std::f64::consts::TAU;
                }
                let slack = (span.abs() / ARC_STEPS as f64).sin();
                chain.extend((0..=ARC_STEPS).map(|i| (centre + DVec2::from_angle(sa + span * i as f64 / ARC_STEPS as f64) * radius, slack)));
            }
        }
    }
    chain.dedup_by(|a, b| (a.0 - b.0).length_squared() < 1e-24);
    // The closed outline of the solid's section through the axis: the chain, then its mirror
    // image back down. Its orientation says which side of an edge is outward.
    let mut outline: Vec<DVec2> = chain.iter().map(|p| p.0).collect();
    outline.extend(chain.iter().rev().map(|p| DVec2::new(-p.0.x, p.0.y)));
    outline.dedup_by(|a, b| (*a - *b).length_squared() < 1e-24);
    let n = outline.len();
    let area2: f64 = (0..n).map(|i| outline[i].perp_dot(outline[(i + 1) % n])).sum();
    let orientation = area2.signum();
    let mut convex = n >= 3;
    for i in 0..n {
        let (a, b, c) = (outline[i], outline[(i + 1) % n], outline[(i + 2) % n]);
        // A right turn in a counter-clockwise outline (or the reverse) is a dent.
        if (b - a).perp_dot(c - b) * orientation < -1e-12 * (b - a).length() * (c - b).length() {
            convex = false;
        }
    }
    let (mut down_below, mut up_above) = (f64::NEG_INFINITY, f64::INFINITY);
    for w in chain.windows(2) {
        let ((a, _), (b, slack)) = (w[0], w[1]);
        let d = b - a;
        // The outward normal's z: the edge turned a quarter away from the inside.
        let normal_z = -d.x * orientation / d.length();
        if normal_z < slack {
            down_below = down_below.max(a.y.max(b.y));
        }
        if normal_z > -slack {
            up_above = up_above.min(a.y.min(b.y));
        }
    }
    (convex, down_below, up_above)
}

/// The point where a line from external point `from` touches the circle, on the side of larger ρ.
pub fn tangent_point(centre: DVec2, radius: f64, from: DVec2) -> Option<DVec2> {
    let v = from - centre;
    let d = v.length();
    if !(d > radius) {
        return None;
    }
    let beta = (radius / d).acos();
    let u = v / d;
    let candidates = [DVec2::from_angle(beta).rotate(u), DVec2::from_angle(-beta).rotate(u)];
    let t = if candidates[0].x >= candidates[1].x { candidates[0] } else { candidates[1] };
    Some(centre + t * radius)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square() -> Profile {
        Profile::new(vec![
            Piece::Line { a: DVec2::new(0.0, 0.0), b: DVec2::new(1.0, 0.0) },
            Piece::Line { a: DVec2::new(1.0, 0.0), b: DVec2::new(1.0, 2.0) },
            Piece::Line { a: DVec2::new(1.0, 2.0), b: DVec2::new(0.0, 2.0) },
        ])
    }

    #[test]
    fn flat_cylinder_distances_are_exact() {
        let s = square();
        assert!((s.sdf(0.5, 1.0) + 0.5).abs() < 1e-12);
        assert!((s.sdf(0.0, 1.0) + 1.0).abs() < 1e-12, "on the axis, nearest is the side or an end");
        assert!((s.sdf(2.0, 3.0) - 2f64.sqrt()).abs() < 1e-12, "corner");
        assert!((s.sdf(0.2, -0.3) - 0.3).abs() < 1e-12);
    }

    #[test]
    fn half_circle_is_a_ball() {
        let c = DVec2::new(0.0, 1.0);
        let ball = Profile::new(vec![Piece::Arc {
            centre: c,
            radius: 1.0,
            a: DVec2::new(0.0, 0.0),
            b: DVec2::new(0.0, 2.0),
            ccw: true,
        }]);
        for (rho, z) in [(0.0, 1.0), (0.3, 0.2), (2.0, 1.0), (0.1, 2.5), (0.0, -1.0), (0.7, 1.9)] {
            let exact = (DVec2::new(rho, z) - c).length() - 1.0;
            assert!((ball.sdf(rho, z) - exact).abs() < 1e-12, "{rho} {z}: {} vs {exact}", ball.sdf(rho, z));
        }
    }
}
