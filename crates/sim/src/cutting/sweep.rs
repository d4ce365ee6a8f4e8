//! The burr's swept volume between two poses as a dense patch of signed distances.
//!
//! Poses are interpolated (translation linearly, rotation by slerp) at `n` sub-steps. A round
//! burr's swept volume is the union of capsules between consecutive ball centres: exact for pure
//! translation; with rotation the centre path is sub-stepped so its chord error (sagitta) is at
//! most 0.25 voxel. Any other head takes the minimum of its exact SDF over the sub-poses; since a
//! signed distance is 1-Lipschitz in the body's displacement, spacing the sub-poses so no point of
//! the head moves more than 0.5 voxel between them bounds the gap to the true swept distance by
//! 0.25 voxel, for translation and rotation alike, at any speed (no tunnelling).
//!
//! Voxels whose lower bound lies beyond `band + 1.5 voxel` get that cut-off value without an exact
//! evaluation; every value is therefore either exact (to the bound above) or ≥ the cut-off, which
//! keeps the patch valid for `LevelSet::subtract_logged` (it reads one voxel past the band; an
//! unmeasured one reads nothing from the band up, see [`Sweep::set_unmeasured`]). Other
//! heads are evaluated a run of a row at a time ([`Burr::sdf_row`]); the runs leave out what a
//! stroke continuing the last cannot change (see `Behind` and [`Burr::inner_capsule`]). With one
//! pose to evaluate, rows are bounded by the head's slabs ([`Burr::axis_frustums`]) and written by a
//! fast path that gives the general loop's values bit for bit (a test pins the two together).
use dentsim_vdb::{block_counts, ColumnRuns, DensePatch, LEAF_DIM};
use glam::{DAffine3, DMat3, DQuat, DVec3, IVec3};

use crate::burr::Burr;
use crate::error::{invalid, Result};

/// Chord / gap tolerance in voxels (issue 4: ≤ 0.25 voxel).
pub const GAP_VOXELS: f64 = 0.25;
/// A stroke longer than this many sub-steps is refused (a teleport, not a motion).
pub const MAX_SUBSTEPS: usize = 20_000;
/// A stroke whose patch would exceed this many voxels (64 MiB of f32) is refused: split it.
pub const MAX_PATCH_VOXELS: usize = 16 << 20;
/// Margin (mm) of the already-cut test: a voxel the new stroke would cut at most this much deeper
/// than the done ball did is left alone. Far above f32 rounding of the distances (~1e-7 mm), which
/// would otherwise count the trailing half of every stroke as cut again; far below anything a cut
/// resolves (2e-4 voxel at 0.05 mm).
const DONE_SLACK: f32 = 1e-5;

/// A ball (centre, radius in mm) every grid has already lost: `value ≥ min(radius − |p − centre|,
/// background)` everywhere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CutBall {
    pub centre: DVec3,
    pub radius: f64,
}

/// The head of any burr at a pose, shrunk by `offset` mm, that every grid has already lost:
/// `value ≥ min(−(sdf_head(to_tool · p) + offset), background)` everywhere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CutHead {
    /// World → tool frame of the pose.
    pub to_tool: DAffine3,
    pub offset: f64,
}

/// What the grids already lost where the next stroke starts (see [`Sweep::build_skipping`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Done {
    Ball(CutBall),
    Head(CutHead),
}

/// Reusable buffers for building swept patches; allocation-free once warmed up.
#[derive(Default)]
pub struct Sweep {
    pub patch: DensePatch,
    /// World-to-tool transform of each sub-pose.
    inverse: Vec<DAffine3>,
    /// World centre of the head's bounding ball at each sub-pose.
    centres: Vec<DVec3>,
    /// World ends of the head's axis at each sub-pose (non-round heads; see [`Burr::axis_extent`]).
    axes: Vec<(DVec3, DVec3)>,
    /// The capsules about those axes the rows reach, readied; with one pose evaluated, the
    /// truncated cones of the head's slabs at it instead (see [`Burr::axis_frustums`]), each with
    /// its bounding box across the rows (y and z, mm).
    capsules: Vec<LineCapsule>,
    frustums: Vec<Frustum>,
    slab_boxes: Vec<[f64; 4]>,
    pub substeps: usize,
    /// Index box of the patch (inclusive).
    pub lo: IVec3,
    pub hi: IVec3,
    /// Which leaf-aligned 8³ blocks of the box hold material (see [`Sweep::build_in`]: 2, or 1
    /// for a leaf all at the background), and per row of blocks the x range (voxel index,
    /// inclusive) from the first such block to the last.
    material: Vec<u8>,
    material_rows: Vec<(i32, i32)>,
    /// With [`Sweep::set_columns`], per column of blocks the z range (voxel index, inclusive)
    /// from the first block with material to the last.
    material_columns: Vec<(i32, i32)>,
    rows: RowScratch,
    /// Evaluates every row the general way, bounded by the head's one cylinder, without the
    /// one-pose fast path and the slabs; the tests pin those to it.
    exhaustive: bool,
    /// The cut-off (f32 bits) that every value of the patch outside its spans holds, once built.
    spans_only: Option<u32>,
    /// Only an unmeasured subtract reads the patch (see [`Sweep::set_unmeasured`]).
    unmeasured: bool,
    /// One-pose heads whose axis lies nearest z are evaluated in columns along z (see
    /// [`Sweep::set_columns`]).
    columns: bool,
    /// Whether the last build was (see [`Sweep::built_in_columns`]).
    in_columns: bool,
    /// A build in columns writes only its runs, not the patch (see [`Sweep::set_runs_only`]).
    runs_only: bool,
    /// With the last build in columns, its column runs (see [`Sweep::column_runs`]).
    column_runs: ColumnRuns,
    /// Per k of the box, the tool frame's z axis times the voxel's z, its x components, then its
    /// y, then its z (see `fill_columns`).
    z_terms: Vec<f64>,
}

/// One row run's distances for a non-round head (see [`Sweep::build_in`]), voxel by voxel.
#[derive(Default)]
struct RowScratch {
    /// The least over the poses evaluated, from the cut-off down.
    best: Vec<f32>,
    /// The start pose's distance, or a bound on it (infinite where no pose reached).
    start: Vec<f32>,
    /// One pose's distances.
    pose: Vec<f32>,
}

impl RowScratch {
    fn reserve(&mut self, voxels: usize) {
        for v in [&mut self.best, &mut self.start, &mut self.pose] {
            v.reserve(voxels.saturating_sub(v.len()));
        }
    }
}

/// Rotation part as a unit quaternion, or an error naming the pose when it is not a rotation.
pub fn rotation_of(pose: &DAffine3, what: &str) -> Result<DQuat> {
    let m: DMat3 = pose.matrix3;
    if !pose.is_finite() {
        return Err(invalid(what, "is not finite (NaN or infinite entries)"));
    }
    let err = (m.transpose() * m - DMat3::IDENTITY).to_cols_array().iter().fold(0f64, |a, v| a.max(v.abs()));
    if err > 1e-6 || m.determinant() < 0.0 {
        return Err(invalid(what, format!("rotation is not orthonormal (|RᵀR − I| = {err:.2e}); was the quaternion normalised?")));
    }
    Ok(DQuat::from_mat3(&m).normalize())
}

impl Sweep {
    /// Grows the buffers for any stroke whose head's bounding-ball centre moves at most
    /// `travel_mm` (see [`build`](Self::build)); returns the largest patch's voxels per axis.
    pub fn reserve(&mut self, burr: &Burr, voxel: f64, band: f64, travel_mm: f64) -> [u32; 3] {
        let side = Self::box_side(burr, voxel, band, travel_mm) as u32;
        let total = side as usize * side as usize * side as usize;
        let p = &mut self.patch;
        p.values.reserve(total.saturating_sub(p.values.len()));
        p.spans.reserve((2 * side as usize * side as usize).saturating_sub(p.spans.len()));
        let blocks = (side as usize / LEAF_DIM as usize + 2).pow(3);
        self.material.reserve(blocks.saturating_sub(self.material.len()));
        self.material_rows.reserve(blocks.saturating_sub(self.material_rows.len()));
        self.material_columns.reserve(blocks.saturating_sub(self.material_columns.len()));
        // At most three runs a column (see `runs_outside`), four numbers each, and a value per voxel.
        let runs = &mut self.column_runs;
        runs.runs.reserve((12 * side as usize * side as usize).saturating_sub(runs.runs.len()));
        runs.values.reserve(total.saturating_sub(runs.values.len()));
        self.z_terms.reserve((3 * side as usize).saturating_sub(self.z_terms.len()));
        self.rows.reserve(side as usize);
        // The sub-poses of a translation that long (rotation adds more; those still grow once).
        let poses = (travel_mm.max(0.0) / (2.0 * GAP_VOXELS * voxel)).ceil().min(MAX_SUBSTEPS as f64) as usize + 2;
        self.inverse.reserve(poses.saturating_sub(self.inverse.len()));
        self.centres.reserve(poses.saturating_sub(self.centres.len()));
        self.axes.reserve(poses.saturating_sub(self.axes.len()));
        self.capsules.reserve(poses.max(crate::burr::MAX_SLABS).saturating_sub(self.capsules.len()));
        self.slab_boxes.reserve(crate::burr::MAX_SLABS.saturating_sub(self.slab_boxes.len()));
        self.frustums.reserve(crate::burr::MAX_SLABS.saturating_sub(self.frustums.len()));
        [side; 3]
    }

    /// Whether only an unmeasured subtract (`Measure::Skip`, no tool offset) will read the
    /// patches built from now on. Such a subtract reads no voxel whose value is at least the
    /// grid's background, and `band` is the largest background: so heads evaluated at one pose
    /// bound their rows by what lies within the band of the head, not the cut-off, and the voxels
    /// between (a voxel and a half deep around the head) keep the cut-off. Values below the band
    /// are the same bit for bit, so the grids such a subtract leaves are too.
    pub fn set_unmeasured(&mut self, unmeasured: bool) {
        self.unmeasured = unmeasured;
    }

    /// Whether a head evaluated at one pose (the haptic tick's usual stroke) whose axis lies nearest
    /// the z axis (of the three) is evaluated in columns along z rather than rows along x. The
    /// band a tick can change is a shell about the head: rows across the axis cut it into short
    /// runs, each paying the row's bounds (slabs, back, deep capsule), while columns along a
    /// near-vertical head run the shell's length, so there are far fewer of them. A voxel's point
    /// is the one its row along x gives (the row's origin in f64, then the f32 step), so every
    /// voxel evaluated holds the row path's value bit for bit; the bounds are the same sets, taken
    /// along z (to a voxel at their edges, which the bounds' own arguments cover: such voxels
    /// change no grid). The patch keeps its layout (x fastest) and its spans (unless
    /// [`Self::set_runs_only`]).
    pub fn set_columns(&mut self, columns: bool) {
        self.columns = columns;
    }

    /// Whether a build in columns writes its values to its runs only (see [`Self::column_runs`]),
    /// leaving the patch at the cut-off with empty spans: for a cutter that subtracts along the
    /// runs and reads nothing else of the patch. Each value written was a scattered store into the
    /// patch (x fastest) and its row's span; the runs' copy is contiguous.
    pub fn set_runs_only(&mut self, runs_only: bool) {
        self.runs_only = runs_only;
    }

    /// Whether the last build evaluated its head in columns along z (see [`Self::set_columns`]).
    pub fn built_in_columns(&self) -> bool {
        self.in_columns
    }

    /// The last build's runs along z, as `LevelSet::subtract_logged_runs` takes them: each from a
    /// run's first value below the cut-off to its last, with its values; every value outside them
    /// is the cut-off. Empty unless built in columns.
    pub fn column_runs(&self) -> &ColumnRuns {
        &self.column_runs
    }

    /// Voxels along each side of the box a cut of `travel_mm` works in (what [`Self::reserve`]
    /// grows the buffers for), saturating rather than overflowing for absurd voxel sizes.
    pub fn box_side(burr: &Burr, voxel: f64, band: f64, travel_mm: f64) -> u64 {
        let reach = burr.bound().1 + band + 1.5 * voxel;
        // The box runs from floor((lo − reach)/h) to ceil((hi + reach)/h), both inclusive.
        ((2.0 * reach + travel_mm.max(0.0)) / voxel).ceil().min(u32::MAX as f64 / 2.0) as u64 + 3
    }

    /// Fills `patch` with the swept head's signed distance over its box plus `band` mm (the
    /// largest background of the grids it will cut), skipping what `done` already removed.
    pub fn build(&mut self, burr: &Burr, from: DAffine3, to: DAffine3, voxel: f64, band: f64, done: Option<CutBall>) -> Result<()> {
        self.build_skipping(burr, from, to, voxel, band, done.map(Done::Ball))
    }

    /// Like [`build`](Self::build), skipping what `done` (a ball, or any head at a pose) already
    /// removed. A head done at the stroke's start pose costs nothing extra: its distance is the
    /// first sub-pose's, which the sweep evaluates anyway.
    pub fn build_skipping(&mut self, burr: &Burr, from: DAffine3, to: DAffine3, voxel: f64, band: f64, done: Option<Done>) -> Result<()> {
        self.build_in(burr, from, to, voxel, band, done, |_, _, blocks| {
            blocks.fill(2);
            Ok(())
        })
    }

    /// [`build_skipping`](Self::build_skipping) where only blocks that `mark_material(box min,
    /// box dims, blocks)` sets to 2 can change (blocks as [`block_counts`] counts them): the
    /// others take the cut-off without an evaluation. A cut changes nothing in a block where every
    /// grid's voxels are at the background (see `LevelSet::mark_material_blocks`), so marking the
    /// blocks with material in any grid leaves the cut exact, and a head mostly in the air costs
    /// what its part in the tissue costs. A round burr's rows also take in the blocks marked 1
    /// (leaves a cut left clear): its distances depend, to f32 rounding, on where a row's run
    /// starts, and that start stays where it always was.
    #[allow(clippy::too_many_arguments)]
    pub fn build_in(
        &mut self,
        burr: &Burr,
        from: DAffine3,
        to: DAffine3,
        voxel: f64,
        band: f64,
        done: Option<Done>,
        mut mark_material: impl FnMut(IVec3, [u32; 3], &mut [u8]) -> Result<()>,
    ) -> Result<()> {
        let q0 = rotation_of(&from, "stroke start pose")?;
        let q1 = rotation_of(&to, "stroke end pose")?;
        let (t0, t1) = (from.translation, to.translation);
        let angle = q0.angle_between(q1);
        let (cz, rb) = burr.bound();
        let n = match burr.ball_radius() {
            // Ball: only rotation bends the centre path; sagitta r·(Δθ)²/8 ≤ GAP.
            Some(r) => (angle * (r / (8.0 * GAP_VOXELS * voxel)).sqrt()).ceil(),
            // Any head: no point moves more than 2·GAP between sub-poses.
            None => ((t1 - t0).length() + (cz.abs() + rb) * angle) / (2.0 * GAP_VOXELS * voxel),
        }
        .ceil()
        .max(1.0);
        if !(n <= MAX_SUBSTEPS as f64) {
            return Err(invalid("stroke", format!("needs {n} sub-steps (> {MAX_SUBSTEPS}); the poses are too far apart")));
        }
        let n = n as usize;
        self.substeps = n;
        self.in_columns = false;
        self.column_runs.clear();
        self.inverse.clear();
        self.centres.clear();
        self.axes.clear();
        let (z_min, z_max, r_axis) = burr.axis_extent();
        for s in 0..=n {
            let u = s as f64 / n as f64;
            let pose = DAffine3::from_rotation_translation(q0.slerp(q1, u), t0.lerp(t1, u));
            self.inverse.push(pose.inverse());
            self.centres.push(pose.transform_point3(DVec3::new(0.0, 0.0, cz)));
            if burr.ball_radius().is_none() {
                self.axes.push((pose.transform_point3(DVec3::new(0.0, 0.0, z_min)), pose.transform_point3(DVec3::new(0.0, 0.0, z_max))));
            }
        }
        let cutoff = band + 1.5 * voxel;
        let reach = rb + cutoff;
        // The head lies in its bounding ball and, when it has an axis, in the capsule about it.
        let axis_reach = r_axis + cutoff;
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for c in &self.centres {
            lo = lo.min(*c - reach);
            hi = hi.max(*c + reach);
        }
        if !self.axes.is_empty() {
            let (mut a_lo, mut a_hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            for (a, b) in &self.axes {
                a_lo = a_lo.min(a.min(*b) - axis_reach);
                a_hi = a_hi.max(a.max(*b) + axis_reach);
            }
            lo = lo.max(a_lo);
            hi = hi.min(a_hi);
        }
        let lo = (lo / voxel).floor().as_ivec3();
        let hi = (hi / voxel).ceil().as_ivec3();
        let dims = (hi - lo + IVec3::ONE).max(IVec3::ONE).as_uvec3();
        self.lo = lo;
        self.hi = hi;
        let patch = &mut self.patch;
        let total = dims.x as usize * dims.y as usize * dims.z as usize;
        if total > MAX_PATCH_VOXELS {
            return Err(invalid("stroke", format!("would touch {total} voxels (> {MAX_PATCH_VOXELS}); the poses are too far apart, split the stroke")));
        }
        // Every value is the cut-off: only the last build's spans hold others (every value a build
        // writes is at most the cut-off, and a span runs from a row's first value below it to its
        // last), so those are put back rather than the whole box filled again.
        let cutoff32 = cutoff as f32;
        let [px, py, pz] = patch.dims.map(|d| d as usize);
        if self.spans_only == Some(cutoff32.to_bits()) && patch.values.len() == px * py * pz && patch.spans.len() == 2 * py * pz {
            for (row, span) in patch.spans.chunks_exact(2).enumerate() {
                patch.values[row * px + span[0] as usize..row * px + span[1] as usize].fill(cutoff32);
            }
            patch.values.truncate(total);
        } else {
            patch.values.clear();
        }
        patch.values.resize(total, cutoff32);
        self.spans_only = Some(cutoff32.to_bits());
        patch.index_min = lo;
        patch.dims = dims.to_array();
        patch.spans.clear();
        patch.spans.resize(2 * dims.y as usize * dims.z as usize, 0);
        let (first_block, blocks) = block_counts(lo, patch.dims);
        self.material.clear();
        self.material.resize(blocks.iter().product(), 0);
        mark_material(lo, patch.dims, &mut self.material)?;
        self.material_rows.clear();
        let least = if burr.ball_radius().is_some() { 1 } else { 2 };
        for row in self.material.chunks_exact(blocks[0]) {
            let range = match (row.iter().position(|m| *m >= least), row.iter().rposition(|m| *m >= least)) {
                (Some(a), Some(b)) => (first_block.x + a as i32 * LEAF_DIM, first_block.x + b as i32 * LEAF_DIM + LEAF_DIM - 1),
                _ => (1, 0),
            };
            self.material_rows.push(range);
        }
        let ball = burr.ball_radius();
        let (done_head, done) = match done {
            Some(Done::Head(h)) => (Some(h), None),
            Some(Done::Ball(b)) => (None, Some(b)),
            None => (None, None),
        };
        // The done head at the stroke's start pose: its distance is sub-pose 0's.
        // (To rounding: the quaternion round trip may move the pose by an ulp, 1e-16 mm, far
        // below the skip's slack.)
        let head_at_start = done_head.filter(|h| same_pose(&h.to_tool, &self.inverse[0]));
        // A translating head done, whole, at the start pose: the sweep evaluates only the later
        // sub-poses; (the distance moved per sub-pose) for the bound on the start pose's.
        let translating = q0 == q1;
        let start_free = match head_at_start {
            Some(h) if h.offset == 0.0 && translating && n > 0 => Some((t1 - t0).length() / n as f64),
            _ => None,
        };
        // A convex head translating from a pose the grids hold: a voxel changes only where some
        // later pose comes closer, and by convexity none does unless every subgradient g of the
        // head's distance at the start has g·(motion) > 0. For a solid of revolution g's radial
        // part points outward (convex and even in the radius), so behind the plane through the
        // start's axis normal to the motion's part across it, only the axial part can make
        // g·(motion) positive; and beyond the head's facing height (minus the band: the deepest
        // voxel that can change lies that far inside) the surface nearest a voxel faces no lower
        // (higher) than sideways. Rows skip where both hold.
        let behind = match (start_free, burr.facing_heights()) {
            (Some(_), Some((down_below, up_above))) => {
                let axis = from.matrix3 * DVec3::Z;
                let motion = t1 - t0;
                let along = motion.dot(axis);
                let margin = band + f64::from(DONE_SLACK) + 1e-6;
                let height = if along < 0.0 {
                    Some((1.0, down_below + margin))
                } else if along > 0.0 {
                    Some((-1.0, -(up_above - margin)))
                } else {
                    None
                };
                Some(Behind { origin: t0, across: motion - axis * along, axis, height })
            }
            _ => None,
        };
        // With the start free, voxels inside the start head's inner capsule lie deeper in it than
        // the band (and its slack; a hair narrower for rounding): they keep the cut-off.
        let inner_axis = match start_free {
            Some(_) => burr.inner_capsule(band + f64::from(DONE_SLACK) + 1e-5).map(|(za, zb, r)| {
                (from.transform_point3(DVec3::new(0.0, 0.0, za)), from.transform_point3(DVec3::new(0.0, 0.0, zb)), r - 1e-6)
            }),
            None => None,
        };
        // With its bounding box across the rows (y and z, mm), the cheaper test.
        let capsule_across = |(a, b, r): (DVec3, DVec3, f64)| {
            let (low, high) = (a.min(b) - r, a.max(b) + r);
            (LineCapsule::new(a, b, r), [low.y, high.y, low.z, high.z])
        };
        let inner = inner_axis.map(capsule_across);
        // A translating ball whose start lies within the done ball: behind the plane through the
        // start, normal to the motion, the capsule's nearest point is the start, which the done
        // ball covers, so every voxel there would come out as the cut-off. Rows skip that part.
        let front = match (ball, done) {
            (Some(r), Some(d)) if self.centres.len() == 2 && (self.centres[0] - d.centre).length() + r <= d.radius => {
                Some((self.centres[0], self.centres[1] - self.centres[0]))
            }
            _ => None,
        };
        let (nx, ny) = (dims.x as usize, dims.y as usize);
        let inv_voxel = 1.0 / voxel;
        let rows = &mut self.rows;
        rows.reserve(nx);
        // With the start free, the start pose changes nothing: rows reach as the later ones do.
        let first_pose = usize::from(start_free.is_some());
        self.capsules.clear();
        self.frustums.clear();
        self.slab_boxes.clear();
        // Columns along z (see `set_columns`): the one pose's bounds with x and z swapped, so
        // that what they give along a row along x they give along a column.
        let columns = match (&self.axes[..], start_free) {
            ([_, (a, b)], Some(_)) => {
                let d = (*b - *a).abs();
                self.columns && d.z >= d.x.max(d.y)
            }
            _ => false,
        };
        let turn = |v: DVec3| if columns { swap_xz(v) } else { v };
        match &self.axes[first_pose.min(self.axes.len())..] {
            // One pose: each slab's frustum, grown by the cut-off along the axis and across it,
            // holds every point within the cut-off of the head's part in that slab (within the
            // band, when no voxel from the band up is read).
            [(a, b)] if !self.exhaustive && !burr.axis_frustums().is_empty() => {
                let along = |h: f64| *a + (*b - *a) * ((h - z_min) / (z_max - z_min));
                let grow = if self.unmeasured { band } else { cutoff };
                for &(h0, h1, r0, r1) in burr.axis_frustums() {
                    let (p, q) = (turn(along(h0 - grow - FRUSTUM_SLACK)), turn(along(h1 + grow + FRUSTUM_SLACK)));
                    let frustum = Frustum::around(p, q, (h0, h1, r0, r1), grow);
                    // (A hair wider than the frustum: the box only culls.)
                    let r = frustum.widest() + 1e-9;
                    let (low, high) = (p.min(q) - r, p.max(q) + r);
                    self.frustums.push(frustum);
                    self.slab_boxes.push([low.y, high.y, low.z, high.z]);
                }
            }
            axes => self.capsules.extend(axes.iter().map(|(a, b)| LineCapsule::new(*a, *b, axis_reach))),
        }
        let slabbed = !self.frustums.is_empty();
        if columns && slabbed {
            if let Some(moves) = start_free {
                self.material_columns.clear();
                let plane = blocks[0] * blocks[1];
                for column in 0..plane {
                    let has = |bz: &usize| self.material[column + plane * bz] >= least;
                    let range = match ((0..blocks[2]).find(has), (0..blocks[2]).rev().find(has)) {
                        (Some(a), Some(b)) => (first_block.z + a as i32 * LEAF_DIM, first_block.z + b as i32 * LEAF_DIM + LEAF_DIM - 1),
                        _ => (1, 0),
                    };
                    self.material_columns.push(range);
                }
                let bounds = ColumnBounds {
                    frustums: &self.frustums,
                    slab_boxes: &self.slab_boxes,
                    material: &self.material_columns,
                    first_block,
                    blocks_x: blocks[0],
                    behind: behind.map(|b| Behind { origin: swap_xz(b.origin), across: swap_xz(b.across), axis: swap_xz(b.axis), height: b.height }),
                    inner: inner_axis.map(|(a, b, r)| capsule_across((swap_xz(a), swap_xz(b), r))),
                };
                fill_columns(burr, patch, (&mut self.column_runs, &mut self.z_terms, self.runs_only), &self.inverse[1], &bounds, (voxel, band, cutoff, moves));
                self.in_columns = true;
                return Ok(());
            }
        }
        let (centres, capsules, frustums, slab_boxes) = (&self.centres[first_pose..], &self.capsules, &self.frustums, &self.slab_boxes);
        for k in lo.z..=hi.z {
            let z = f64::from(k) * voxel;
            for j in lo.y..=hi.y {
                let y = f64::from(j) * voxel;
                // Rows without material first: the cheapest test, and most of a long head's box.
                let block_row = ((j - first_block.y) / LEAF_DIM) as usize + blocks[1] * ((k - first_block.z) / LEAF_DIM) as usize;
                let (m_lo, m_hi) = self.material_rows[block_row];
                if m_lo > m_hi {
                    continue;
                }
                // The x-range where the head's bounding balls (grown by the cut-off) can reach,
                // swept along the centre path (segments between consecutive centres).
                let (mut x_lo, mut x_hi) = (f64::INFINITY, f64::NEG_INFINITY);
                // (The slabs' cylinders lie within the one pose's bounding ball.)
                let segments = if slabbed { 0 } else { centres.len().saturating_sub(1).max(1) };
                for s in 0..segments {
                    let a = centres[s];
                    let b = centres[(s + 1).min(centres.len() - 1)];
                    let d = segment_distance_2d((y, z), (a.y, a.z), (b.y, b.z));
                    if d < reach {
                        let half = (reach * reach - d * d).sqrt();
                        x_lo = x_lo.min(a.x.min(b.x) - half);
                        x_hi = x_hi.max(a.x.max(b.x) + half);
                    }
                }
                if !capsules.is_empty() {
                    let (mut c_lo, mut c_hi) = (f64::INFINITY, f64::NEG_INFINITY);
                    for capsule in capsules {
                        if let Some((l, h)) = capsule.x_interval(y, z) {
                            c_lo = c_lo.min(l);
                            c_hi = c_hi.max(h);
                        }
                    }
                    x_lo = x_lo.max(c_lo);
                    x_hi = x_hi.min(c_hi);
                }
                if slabbed {
                    let (l, h) = slab_hull(frustums, slab_boxes, y, z, Frustum::x_interval);
                    x_lo = x_lo.min(l);
                    x_hi = x_hi.max(h);
                }
                if x_lo > x_hi {
                    continue;
                }
                if let Some((a, u)) = front {
                    // Keep (p − a)·u > 0 along the row: a half-line in x, or all or nothing.
                    let rest = (y - a.y) * u.y + (z - a.z) * u.z;
                    if u.x > 0.0 {
                        x_lo = x_lo.max(a.x - rest / u.x);
                    } else if u.x < 0.0 {
                        x_hi = x_hi.min(a.x - rest / u.x);
                    } else if rest <= 0.0 {
                        continue;
                    }
                }
                // The frustums are grown past rounding (FRUSTUM_SLACK): the voxels within them.
                let (i_lo, i_hi) = if slabbed {
                    (ceil_i32(x_lo * inv_voxel), floor_i32(x_hi * inv_voxel))
                } else {
                    (floor_i32(x_lo * inv_voxel), ceil_i32(x_hi * inv_voxel))
                };
                let (i_lo, i_hi) = (i_lo.max(lo.x).max(m_lo), i_hi.min(hi.x).min(m_hi));
                if i_lo > i_hi {
                    continue;
                }
                let row_index = (j - lo.y) as usize + ny * (k - lo.z) as usize;
                let row = nx * row_index;
                let out = &mut patch.values[row + (i_lo - lo.x) as usize..=row + (i_hi - lo.x) as usize];
                match ball {
                    // One straight segment (no rotation): the capsule, x stepping along the row.
                    // f32 relative to the segment's start: 1e-7 mm of rounding, twice the speed.
                    Some(r) if self.centres.len() == 2 => {
                        let a = self.centres[0];
                        let ab = (self.centres[1] - a).as_vec3();
                        let inv = 1.0 / ab.length_squared().max(f32::MIN_POSITIVE);
                        let (dy, dz) = ((y - a.y) as f32, (z - a.z) as f32);
                        let (r, cutoff, h, band) = (r as f32, cutoff as f32, voxel as f32, band as f32);
                        let x0 = (f64::from(i_lo) * voxel - a.x) as f32;
                        let yz = dy * ab.y + dz * ab.z;
                        // No done ball: one of radius −∞ excludes nothing.
                        let (c, rc) = done.map_or((glam::Vec3::ZERO, f32::NEG_INFINITY), |d| ((d.centre - a).as_vec3(), d.radius as f32));
                        // Branch-free per voxel so the row vectorises.
                        for (n, v) in out.iter_mut().enumerate() {
                            let px = x0 + n as f32 * h;
                            let t = ((px * ab.x + yz) * inv).max(0.0).min(1.0);
                            let (qx, qy, qz) = (px - ab.x * t, dy - ab.y * t, dz - ab.z * t);
                            let d = ((qx * qx + qy * qy + qz * qz).sqrt() - r).min(cutoff);
                            let (ex, ey, ez) = (px - c.x, dy - c.y, dz - c.z);
                            let d_done = (ex * ex + ey * ey + ez * ez).sqrt() - rc;
                            *v = unless_done(d, d_done, band, cutoff);
                        }
                    }
                    Some(r) => {
                        for (v, i) in out.iter_mut().zip(i_lo..) {
                            let p = DVec3::new(f64::from(i) * voxel, y, z);
                            let mut best = cutoff;
                            for w in self.centres.windows(2) {
                                best = best.min(segment_distance(p, w[0], w[1]) - r);
                            }
                            *v = match done {
                                Some(d) => unless_done(best as f32, ((p - d.centre).length() - d.radius) as f32, band as f32, cutoff as f32),
                                None => best as f32,
                            };
                        }
                    }
                    None => {
                        // Voxels (inclusive) behind the translating head keep the cut-off; the
                        // rest of the row is evaluated a run at a time, each pose over the part
                        // of the run its bounding ball (grown by the cut-off) reaches.
                        let gap = behind.map_or((1, 0), |b| b.row_gap(y, z, inv_voxel));
                        // And with the start free, the voxels deep inside its head.
                        let deep = inner
                            .filter(|(_, b)| y >= b[0] && y <= b[1] && z >= b[2] && z <= b[3])
                            .and_then(|(c, _)| c.x_interval(y, z))
                            .map_or((1, 0), |(l, h)| whole_voxels(l, h, inv_voxel));
                        let runs = runs_outside(i_lo, i_hi, [gap, deep]);
                        // The haptic tick's usual stroke: a head translating from a pose the
                        // grids hold, so short (under 2·GAP voxels) that one later pose is all
                        // the sweep evaluates. The general loop below then reduces to one pass
                        // per run, done here without its buffers, bit for bit the same.
                        if let (Some(moves), 2, false) = (start_free, self.inverse.len(), self.exhaustive) {
                            let (inv, c) = (&self.inverse[1], self.centres[1]);
                            // The slabs already bound the row; beyond the pose's ball a voxel
                            // would take the cut-off anyway.
                            let (reach_lo, reach_hi) = if slabbed {
                                (i32::MIN, i32::MAX)
                            } else {
                                let d2 = (y - c.y) * (y - c.y) + (z - c.z) * (z - c.z);
                                if d2 >= reach * reach {
                                    continue;
                                }
                                let half = (reach * reach - d2).sqrt();
                                (floor_i32((c.x - half) * inv_voxel), ceil_i32((c.x + half) * inv_voxel))
                            };
                            let step = (inv.matrix3.x_axis * voxel).as_vec3();
                            // Points from the box's first voxel on: a voxel's distance does not
                            // depend on where its run starts.
                            let origin = inv.transform_point3(DVec3::new(f64::from(lo.x) * voxel, y, z)).as_vec3();
                            let (cutoff32, moved) = (cutoff as f32, moves as f32);
                            let deep_held = (-band - f64::from(DONE_SLACK) - 1e-6) as f32;
                            for (a, b) in runs {
                                let (ka, kb) = (reach_lo.max(a), reach_hi.min(b));
                                if ka > kb {
                                    continue;
                                }
                                let m = (kb - ka + 1) as usize;
                                rows.pose.resize(m, 0.0);
                                burr.sdf_row_from(origin, step, (ka - lo.x) as usize, &mut rows.pose[..m]);
                                let run = &mut out[(ka - i_lo) as usize..=(kb - i_lo) as usize];
                                for (v, d) in run.iter_mut().zip(&rows.pose[..m]) {
                                    *v = if *d + moved <= deep_held { cutoff32 } else { cutoff32.min(*d) };
                                }
                                // The span from what this run wrote: the rest of the row keeps
                                // the cut-off (the runs come in order along it).
                                let below = |v: &f32| *v < cutoff32;
                                if let (Some(first), Some(last)) = (run.iter().position(below), run.iter().rposition(below)) {
                                    let (first, last) = ((ka - lo.x) as u32 + first as u32, (ka - lo.x) as u32 + last as u32 + 1);
                                    let span = &mut patch.spans[2 * row_index..2 * row_index + 2];
                                    if span[0] == span[1] {
                                        span[0] = first;
                                    }
                                    span[1] = last;
                                }
                            }
                            continue;
                        } else {
                        for (a, b) in runs {
                            if a > b {
                                continue;
                            }
                            let len = (b - a + 1) as usize;
                            rows.best.clear();
                            rows.best.resize(len, cutoff as f32);
                            // The start pose's distance (a head done there reads it), or with
                            // the start free, an upper bound on it from the later poses.
                            rows.start.clear();
                            rows.start.resize(len, f32::INFINITY);
                            let first_pose = usize::from(start_free.is_some());
                            for (k, (inv, c)) in self.inverse.iter().zip(&self.centres).enumerate().skip(first_pose) {
                                let d2 = (y - c.y) * (y - c.y) + (z - c.z) * (z - c.z);
                                if d2 >= reach * reach {
                                    continue;
                                }
                                let half = (reach * reach - d2).sqrt();
                                let ka = floor_i32((c.x - half) * inv_voxel).max(a);
                                let kb = ceil_i32((c.x + half) * inv_voxel).min(b);
                                if ka > kb {
                                    continue;
                                }
                                let (off, m) = ((ka - a) as usize, (kb - ka + 1) as usize);
                                // Points from the box's first voxel on, as the fast path's.
                                let origin = inv.transform_point3(DVec3::new(f64::from(lo.x) * voxel, y, z)).as_vec3();
                                rows.pose.resize(m, 0.0);
                                burr.sdf_row_from(origin, (inv.matrix3.x_axis * voxel).as_vec3(), (ka - lo.x) as usize, &mut rows.pose[..m]);
                                let best = &mut rows.best[off..off + m];
                                let start = &mut rows.start[off..off + m];
                                match start_free {
                                    // The start pose's distance is at most a later pose's plus how
                                    // far it moved (1-Lipschitz in translation).
                                    Some(moves) => {
                                        let moved = (moves * k as f64) as f32;
                                        for ((d, bst), st) in rows.pose[..m].iter().zip(best).zip(start) {
                                            *bst = bst.min(*d);
                                            *st = st.min(*d + moved);
                                        }
                                    }
                                    None => {
                                        for ((d, bst), st) in rows.pose[..m].iter().zip(best).zip(start) {
                                            *bst = bst.min(*d);
                                            if k == 0 {
                                                *st = *d;
                                            }
                                        }
                                    }
                                }
                            }
                            let out = &mut out[(a - i_lo) as usize..=(b - i_lo) as usize];
                            let (band32, cutoff32) = (band as f32, cutoff as f32);
                            if start_free.is_some() {
                                // The grids hold the start pose's head (to the slack): a voxel
                                // deeper than the band in it keeps the cut-off.
                                let deep = (-band - f64::from(DONE_SLACK) - 1e-6) as f32;
                                for ((v, bst), st) in out.iter_mut().zip(&rows.best).zip(&rows.start) {
                                    *v = if *st <= deep { cutoff32 } else { *bst };
                                }
                                continue;
                            }
                            match (done_head, head_at_start) {
                                // Skipped at sub-pose 0 only when it is beyond the cut-off or
                                // some later pose came closer, which already beats it.
                                (_, Some(h)) => {
                                    let offset = h.offset as f32;
                                    for ((v, bst), st) in out.iter_mut().zip(&rows.best).zip(&rows.start) {
                                        *v = unless_done(*bst, st.min(cutoff32) + offset, band32, cutoff32);
                                    }
                                }
                                (Some(h), None) => {
                                    let origin = h.to_tool.transform_point3(DVec3::new(f64::from(a) * voxel, y, z)).as_vec3();
                                    rows.pose.resize(len, 0.0);
                                    burr.sdf_row(origin, (h.to_tool.matrix3.x_axis * voxel).as_vec3(), &mut rows.pose[..len]);
                                    let offset = h.offset as f32;
                                    for ((v, bst), d) in out.iter_mut().zip(&rows.best).zip(&rows.pose) {
                                        *v = unless_done(*bst, *d + offset, band32, cutoff32);
                                    }
                                }
                                (None, _) => match done {
                                    Some(d) => {
                                        for ((v, bst), i) in out.iter_mut().zip(&rows.best).zip(a..) {
                                            let p = DVec3::new(f64::from(i) * voxel, y, z);
                                            *v = unless_done(*bst, ((p - d.centre).length() - d.radius) as f32, band32, cutoff32);
                                        }
                                    }
                                    None => out.copy_from_slice(&rows.best),
                                },
                            }
                        }
                        }
                    }
                }
                let below = |v: &f32| *v < cutoff as f32;
                if let (Some(first), Some(last)) = (out.iter().position(below), out.iter().rposition(below)) {
                    let start = (i_lo - lo.x) as u32;
                    patch.spans[2 * row_index] = start + first as u32;
                    patch.spans[2 * row_index + 1] = start + last as u32 + 1;
                }
            }
        }
        Ok(())
    }
}

/// Where a convex translating head's back lies (see [`Sweep::build_in`]): world points `p` with
/// `(p − origin)·across ≤ 0` and, when `height` is `(s, level)`, `s·(p − origin)·axis ≥ level`.
#[derive(Clone, Copy)]
struct Behind {
    origin: DVec3,
    across: DVec3,
    axis: DVec3,
    height: Option<(f64, f64)>,
}

impl Behind {
    /// The voxel indices (inclusive; empty when lo > hi) of the row at (y, z) that lie behind.
    fn row_gap(&self, y: f64, z: f64, inv_voxel: f64) -> (i32, i32) {
        let (dy, dz) = (y - self.origin.y, z - self.origin.z);
        // c·x + e ≤ 0 as an interval of x.
        let half_line = |c: f64, e: f64| -> (f64, f64) {
            if c > 0.0 {
                (f64::NEG_INFINITY, -e / c)
            } else if c < 0.0 {
                (-e / c, f64::INFINITY)
            } else if e <= 0.0 {
                (f64::NEG_INFINITY, f64::INFINITY)
            } else {
                (f64::INFINITY, f64::NEG_INFINITY)
            }
        };
        let a = self.across;
        let (mut lo, mut hi) = half_line(a.x, a.y * dy + a.z * dz - a.x * self.origin.x);
        if let Some((s, level)) = self.height {
            let w = self.axis;
            let (l, h) = half_line(-s * w.x, level - s * (w.y * dy + w.z * dz - w.x * self.origin.x));
            lo = lo.max(l);
            hi = hi.min(h);
        }
        if !(lo <= hi) {
            return (1, 0);
        }
        whole_voxels(lo, hi, inv_voxel)
    }
}

/// The point with its x and z swapped: bounds made for rows along x, built from swapped points,
/// bound columns along z (called with (y, x)).
fn swap_xz(v: DVec3) -> DVec3 {
    DVec3::new(v.z, v.y, v.x)
}

/// What bounds a column along z of [`fill_columns`], built with x and z swapped.
struct ColumnBounds<'a> {
    frustums: &'a [Frustum],
    slab_boxes: &'a [[f64; 4]],
    /// Per column of blocks, the z range with material (see `Sweep::material_columns`).
    material: &'a [(i32, i32)],
    first_block: IVec3,
    blocks_x: usize,
    behind: Option<Behind>,
    inner: Option<(LineCapsule, [f64; 4])>,
}

/// The one-pose fast path of [`Sweep::build_in`] in columns along z (see [`Sweep::set_columns`]):
/// the head at `inv` (world to tool), started from a pose the grids hold that lies `moves` mm
/// away. Each voxel's point is its row's (`origin(y, z) + (i − lo.x)·step`, the origin in f64 as
/// `DAffine3::transform_point3` sums it) and its value the row path's; only values below the
/// cut-off are written (the patch holds the cut-off elsewhere), each widening its row's span,
/// and each run's part from its first such value to its last goes to `runs` with its values (see
/// [`Sweep::column_runs`]); with `runs_only`, only there.
fn fill_columns(burr: &Burr, patch: &mut DensePatch, (runs, z_terms, runs_only): (&mut ColumnRuns, &mut Vec<f64>, bool), inv: &DAffine3, bounds: &ColumnBounds, (voxel, band, cutoff, moves): (f64, f64, f64, f64)) {
    use crate::burr::profile::{Lanes, LANES};
    let (lo, [nx, ny, _]) = (patch.index_min, patch.dims.map(|d| d as usize));
    let hi = lo + IVec3::from_array(patch.dims.map(|d| d as i32)) - IVec3::ONE;
    let inv_voxel = 1.0 / voxel;
    let step = (inv.matrix3.x_axis * voxel).as_vec3();
    let row_start = inv.matrix3.x_axis * (f64::from(lo.x) * voxel);
    let (cutoff32, moved) = (cutoff as f32, moves as f32);
    let deep_held = (-band - f64::from(DONE_SLACK) - 1e-6) as f32;
    let plane = nx * ny;
    // The origin's z term per k, once per build rather than per voxel (the same product).
    // Apart by component, so that a run's lanes take their sums a vector at a time.
    z_terms.clear();
    for axis in 0..3 {
        z_terms.extend((lo.z..=hi.z).map(|k| (inv.matrix3.z_axis * (f64::from(k) * voxel))[axis]));
    }
    let depth = (hi.z - lo.z + 1) as usize;
    let (z_x, rest) = z_terms.split_at(depth);
    let (z_y, z_z) = rest.split_at(depth);
    let shift = inv.translation;
    let mut out = [0f32; LANES];
    for i in lo.x..=hi.x {
        let x = f64::from(i) * voxel;
        let bx = ((i - bounds.first_block.x) / LEAF_DIM) as usize;
        let at = (i - lo.x) as usize;
        for j in lo.y..=hi.y {
            let y = f64::from(j) * voxel;
            let by = ((j - bounds.first_block.y) / LEAF_DIM) as usize;
            let (m_lo, m_hi) = bounds.material[bx + bounds.blocks_x * by];
            if m_lo > m_hi {
                continue;
            }
            let (z_lo, z_hi) = slab_hull(bounds.frustums, bounds.slab_boxes, y, x, Frustum::line_interval);
            if z_lo > z_hi {
                continue;
            }
            let (k_lo, k_hi) = (ceil_i32(z_lo * inv_voxel).max(lo.z).max(m_lo), floor_i32(z_hi * inv_voxel).min(hi.z).min(m_hi));
            if k_lo > k_hi {
                continue;
            }
            let gap = bounds.behind.map_or((1, 0), |b| b.row_gap(y, x, inv_voxel));
            let deep = bounds
                .inner
                .filter(|(_, b)| y >= b[0] && y <= b[1] && x >= b[2] && x <= b[3])
                .and_then(|(c, _)| c.x_interval(y, x))
                .map_or((1, 0), |(l, h)| whole_voxels(l, h, inv_voxel));
            // The row origin's first two terms, as `transform_point3` adds them.
            let across = row_start + inv.matrix3.y_axis * y;
            let column = at + nx * (j - lo.y) as usize;
            for (a, b) in runs_outside(k_lo, k_hi, [gap, deep]) {
                // The run's values go to `runs` from its first value below the cut-off (the
                // cut-off where the patch keeps it), then are cut back to its last such value.
                let start = runs.values.len();
                let (mut first, mut last) = (i32::MAX, i32::MIN);
                let mut k = a;
                while k <= b {
                    let n = ((b - k + 1) as usize).min(LANES);
                    let mut lanes = Lanes { t: [at as f32; LANES], ..Default::default() };
                    // `(across + term + translation).as_vec3()`, component by component.
                    let at_k = (k - lo.z) as usize;
                    for (lane, term) in lanes.x[..n].iter_mut().zip(&z_x[at_k..at_k + n]) {
                        *lane = ((across.x + term) + shift.x) as f32;
                    }
                    for (lane, term) in lanes.y[..n].iter_mut().zip(&z_y[at_k..at_k + n]) {
                        *lane = ((across.y + term) + shift.y) as f32;
                    }
                    for (lane, term) in lanes.z[..n].iter_mut().zip(&z_z[at_k..at_k + n]) {
                        *lane = ((across.z + term) + shift.z) as f32;
                    }
                    burr.sdf_lanes(&lanes, n, step, &mut out);
                    for (l, d) in out[..n].iter_mut().enumerate() {
                        if *d + moved <= deep_held || !(*d < cutoff32) {
                            *d = cutoff32;
                            continue;
                        }
                        first = first.min(k + l as i32);
                        last = k + l as i32;
                        if runs_only {
                            continue;
                        }
                        let row = (j - lo.y) as usize + ny * (k + l as i32 - lo.z) as usize;
                        patch.values[column + plane * (k + l as i32 - lo.z) as usize] = *d;
                        let span = &mut patch.spans[2 * row..2 * row + 2];
                        if span[0] == span[1] {
                            span[0] = at as u32;
                        }
                        span[1] = at as u32 + 1;
                    }
                    // From the run's first value below the cut-off on.
                    if first < k + n as i32 {
                        runs.values.extend_from_slice(&out[(first - k).max(0) as usize..n]);
                    }
                    k += n as i32;
                }
                if first <= last {
                    runs.values.truncate(start + (last - first + 1) as usize);
                    runs.runs.extend([column as u32, (first - lo.z) as u32, (last - lo.z + 1) as u32, start as u32]);
                }
            }
        }
    }
}

/// The hull of the slabs' intervals along one line, `(p, q)` its place across (a row's (y, z), a
/// column's (y, x)); each slab's box is tested first, the cheaper test. Empty: lo > hi.
#[inline(always)]
fn slab_hull(frustums: &[Frustum], boxes: &[[f64; 4]], p: f64, q: f64, interval: impl Fn(&Frustum, f64, f64) -> Option<(f64, f64)>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    // The end slabs first, then those between, each skipped when the part of the line between
    // its planes lies within the hull already (its interval does: the same hull, bit for bit).
    let n = frustums.len();
    for i in 0..n {
        let s = match i {
            0 => 0,
            1 => n - 1,
            _ => i - 1,
        };
        let (frustum, b) = (&frustums[s], &boxes[s]);
        if p < b[0] || p > b[1] || q < b[2] || q > b[3] {
            continue;
        }
        if let Some((l, h)) = frustum.planes_interval(p, q) {
            if l >= lo && h <= hi {
                continue;
            }
        }
        if let Some((l, h)) = interval(frustum, p, q) {
            lo = lo.min(l);
            hi = hi.max(h);
        }
    }
    (lo, hi)
}

/// ⌊x⌋ as an index (saturating; NaN gives 0). The baseline x86-64 target has no rounding
/// instruction, and `f64::floor` there is a library call on every row.
#[inline(always)]
fn floor_i32(x: f64) -> i32 {
    // Branch-free: which way a row's bound rounds is a coin toss to the predictor.
    let t = x as i32;
    t.saturating_sub(i32::from(f64::from(t) > x))
}

/// ⌈x⌉ as an index (saturating; NaN gives 0).
#[inline(always)]
fn ceil_i32(x: f64) -> i32 {
    let t = x as i32;
    t.saturating_add(i32::from(f64::from(t) < x))
}

/// The voxel indices (inclusive) whose centres lie within [lo, hi] mm, a hair inside (saturating
/// casts keep infinities in range); `inv_voxel` is 1 / the voxel size (a product, not a
/// division per row: the hair, 1e-9 voxel, is far above its rounding).
fn whole_voxels(lo: f64, hi: f64, inv_voxel: f64) -> (i32, i32) {
    (ceil_i32(lo * inv_voxel + 1e-9), floor_i32(hi * inv_voxel - 1e-9))
}

/// The runs (inclusive; empty ones have lo > hi) of [lo, hi] outside both `cuts` (inclusive
/// index ranges, empty when lo > hi).
fn runs_outside(lo: i32, hi: i32, cuts: [(i32, i32); 2]) -> [(i32, i32); 3] {
    let mut cuts = cuts.map(|(a, b)| if a > b { (i32::MAX, i32::MAX) } else { (a, b) });
    cuts.sort_unstable();
    let [(a0, b0), (a1, b1)] = cuts;
    if a0 == i32::MAX {
        return [(lo, hi), (1, 0), (1, 0)];
    }
    if a1 == i32::MAX || a1 <= b0.saturating_add(1) {
        // One cut, or two that touch: one gap.
        let b = if a1 == i32::MAX { b0 } else { b0.max(b1) };
        return [(lo, hi.min(a0.saturating_sub(1))), (lo.max(b.saturating_add(1)), hi), (1, 0)];
    }
    [(lo, hi.min(a0.saturating_sub(1))), (lo.max(b0.saturating_add(1)), hi.min(a1.saturating_sub(1))), (lo.max(b1.saturating_add(1)), hi)]
}

/// The tool's distance `d` at a voxel, or `cutoff` (no change) when the ball already cut there
/// (at distance `d_done`) went at least as deep, or beyond the band, where values saturate.
#[inline(always)]
fn unless_done(d: f32, d_done: f32, band: f32, cutoff: f32) -> f32 {
    if (d >= d_done - DONE_SLACK) | (d_done <= -band - DONE_SLACK) {
        cutoff
    } else {
        d
    }
}

/// Two poses equal to 1e-12 (mm and rotation entries).
fn same_pose(a: &DAffine3, b: &DAffine3) -> bool {
    a.abs_diff_eq(*b, 1e-12)
}

/// The capsule of radius `r` about the segment from `a` to `b`, readied for
/// [`LineCapsule::x_interval`] along many rows: what does not depend on the row (the axis
/// direction, the quadratic's leading term, the slab's divisions) once.
#[derive(Clone, Copy, Debug)]
struct LineCapsule {
    a: DVec3,
    b: DVec3,
    /// The radius a hair wider (rounding never drops a tangent point), squared.
    r2: f64,
    /// Unit axis and length (len 0: the two balls alone).
    u: DVec3,
    len: f64,
    qa: f64,
    inv_2qa: f64,
    inv_ux: f64,
}

impl LineCapsule {
    fn new(a: DVec3, b: DVec3, r: f64) -> Self {
        let r = r * (1.0 + 1e-12) + 1e-9;
        let len = (b - a).length();
        let u = if len > 0.0 { (b - a) / len } else { DVec3::ZERO };
        let qa = 1.0 - u.x * u.x;
        LineCapsule { a, b, r2: r * r, u, len, qa, inv_2qa: 1.0 / (2.0 * qa), inv_ux: 1.0 / u.x }
    }

    /// The x-interval of the line {(x, y, z)} within the capsule (convex: the hull of its two
    /// balls' and its cylinder's intervals), if any.
    fn x_interval(&self, y: f64, z: f64) -> Option<(f64, f64)> {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        let mut take = |l: f64, h: f64| {
            if l <= h {
                lo = lo.min(l);
                hi = hi.max(h);
            }
        };
        for c in [self.a, self.b] {
            let d2 = (y - c.y) * (y - c.y) + (z - c.z) * (z - c.z);
            if d2 <= self.r2 {
                let half = (self.r2 - d2).sqrt();
                take(c.x - half, c.x + half);
            }
        }
        if self.len > 0.0 {
            let (a, u) = (self.a, self.u);
            // p(x) − a = w + x·X; the distance to the axis line is quadratic in x, its foot linear.
            let w = DVec3::new(-a.x, y - a.y, z - a.z);
            let wu = w.dot(u);
            let (qb, qc) = (2.0 * (w.x - wu * u.x), w.length_squared() - wu * wu - self.r2);
            let (mut l, mut h) = if self.qa > 1e-12 {
                let disc = qb * qb - 4.0 * self.qa * qc;
                if disc < 0.0 {
                    (1.0, 0.0)
                } else {
                    let s = disc.sqrt();
                    ((-qb - s) * self.inv_2qa, (-qb + s) * self.inv_2qa)
                }
            } else if qc <= 0.0 {
                (f64::NEG_INFINITY, f64::INFINITY)
            } else {
                (1.0, 0.0)
            };
            // Within the slab 0 ≤ (p − a)·u ≤ len.
            if u.x.abs() > 1e-12 {
                let (s0, s1) = (-wu * self.inv_ux, (self.len - wu) * self.inv_ux);
                l = l.max(s0.min(s1));
                h = h.min(s0.max(s1));
            } else if !(0.0..=self.len).contains(&wu) {
                h = l - 1.0;
            }
            take(l, h);
        }
        (lo <= hi).then_some((lo, hi))
    }
}

/// How far (mm) a frustum of [`Frustum::around`] reaches past the points within the cut-off of
/// the head: far above the rounding of the row's f32 distances (~1e-6 mm; a voxel whose value
/// rounds below the cut-off lies within it) and of its own f64 roots, a fifth of a thousandth of
/// a voxel at 0.05 mm.
const FRUSTUM_SLACK: f64 = 1e-5;

/// The points within the cut-off of a head's part in one of its slabs (see
/// [`Burr::axis_frustums`]), bounded by a truncated cone about the axis, readied for
/// [`Frustum::x_interval`] along many rows. A solid of revolution's nearest point to p lies in
/// p's half-plane through the axis, so growing the profile's radius bound `r0 + s·h` (a line in
/// that half-plane) by `c` across itself, `c·√(1 + s²)`, and its heights by `c` bounds it.
#[derive(Clone, Copy, Debug)]
struct Frustum {
    /// The axis point at the lowest height and the unit axis; heights along it from 0 to `len`.
    a: DVec3,
    u: DVec3,
    len: f64,
    /// Radius at height 0 and its growth per unit height.
    g0: f64,
    s: f64,
    /// The row quadratic's leading term, and its divisions.
    qa: f64,
    inv_2qa: f64,
    inv_ux: f64,
}

impl Frustum {
    /// From world points `a` (the axis at the slab's lowest height less `cutoff` and the slack)
    /// and `b` (the highest plus both), the slab's `(h0, h1, r0, r1)`.
    fn around(a: DVec3, b: DVec3, (h0, h1, r0, r1): (f64, f64, f64, f64), cutoff: f64) -> Self {
        let len = (b - a).length();
        let u = if len > 0.0 { (b - a) / len } else { DVec3::Z };
        let s = if h1 > h0 { (r1 - r0) / (h1 - h0) } else { 0.0 };
        // At height 0, (cutoff + slack) below h0; grown across by the cut-off and the slack.
        let g0 = r0 - s * (cutoff + FRUSTUM_SLACK) + (cutoff + FRUSTUM_SLACK) * (1.0 + s * s).sqrt();
        let qa = 1.0 - u.x * u.x * (1.0 + s * s);
        Frustum { a, u, len, g0, s, qa, inv_2qa: 0.5 / qa, inv_ux: 1.0 / u.x }
    }

    /// [`x_interval`](Self::x_interval), and None as well for a line nearly parallel to the
    /// axis that stays outside the frustum (which `x_interval` gives the whole slab): a column
    /// along a near-vertical head.
    fn line_interval(&self, y: f64, z: f64) -> Option<(f64, f64)> {
        let (l, h) = self.x_interval(y, z)?;
        if self.qa.abs() > 1e-6 || !(l.is_finite() && h.is_finite()) {
            return Some((l, h));
        }
        // x_interval's quadratic (squared distance to the axis less the squared radius), its
        // least over [l, h]: at an end, or at the vertex when it opens upward.
        let (_, qb, qc) = self.along_x(y, z);
        let f = |x: f64| (self.qa * x + qb) * x + qc;
        let mut least = f(l).min(f(h));
        if self.qa > 0.0 {
            let v = -qb * self.inv_2qa;
            if v > l && v < h {
                least = least.min(f(v));
            }
        }
        (least <= 0.0).then_some((l, h))
    }

    /// The largest radius (at one end or the other).
    fn widest(&self) -> f64 {
        self.g0.max(self.g0 + self.s * self.len)
    }

    /// Along the line {(x, y, z)}: the height of its point at x = 0 over the axis ((p − a)·u),
    /// and the linear and constant terms of the squared distance to the axis line less the
    /// squared radius at the foot's height (quadratic in x, `qa` its square term; p(x) − a = w + x·X).
    #[inline(always)]
    fn along_x(&self, y: f64, z: f64) -> (f64, f64, f64) {
        let (a, u, s) = (self.a, self.u, self.s);
        let w = DVec3::new(-a.x, y - a.y, z - a.z);
        let wu = w.dot(u);
        let g = self.g0 + s * wu;
        let qb = 2.0 * (w.x - u.x * (wu + s * g));
        let qc = w.length_squared() - wu * wu - g * g;
        (wu, qb, qc)
    }

    /// The x-interval of the line {(x, y, z)} between the slab's planes, as
    /// [`x_interval`](Self::x_interval) computes it (which gives a part of it); None for a line
    /// (nearly) parallel to them.
    #[inline(always)]
    fn planes_interval(&self, y: f64, z: f64) -> Option<(f64, f64)> {
        let (a, u) = (self.a, self.u);
        if !(u.x.abs() > 1e-12) {
            return None;
        }
        let wu = DVec3::new(-a.x, y - a.y, z - a.z).dot(u);
        let (s0, s1) = (-wu * self.inv_ux, (self.len - wu) * self.inv_ux);
        Some((s0.min(s1), s0.max(s1)))
    }

    /// An x-interval of the line {(x, y, z)} holding its points within the frustum, if any.
    #[inline]
    fn x_interval(&self, y: f64, z: f64) -> Option<(f64, f64)> {
        let u = self.u;
        let (wu, qb, qc) = self.along_x(y, z);
        // Within the slab 0 ≤ (p − a)·u ≤ len.
        let (mut l, mut h) = if u.x.abs() > 1e-12 {
            let (s0, s1) = (-wu * self.inv_ux, (self.len - wu) * self.inv_ux);
            (s0.min(s1), s0.max(s1))
        } else if (0.0..=self.len).contains(&wu) {
            (f64::NEG_INFINITY, f64::INFINITY)
        } else {
            return None;
        };
        let disc = qb * qb - 4.0 * self.qa * qc;
        if self.qa > 1e-6 {
            if disc < 0.0 {
                return None;
            }
            let root = disc.sqrt();
            l = l.max((-qb - root) * self.inv_2qa);
            h = h.min((-qb + root) * self.inv_2qa);
        } else if self.qa < -1e-6 && disc >= 0.0 {
            // The cone is steeper than the row: outside the roots, which within the slab (the
            // frustum is convex) leaves one side; the hull of both sides is the bound.
            let root = disc.sqrt();
            let (r_lo, r_hi) = ((-qb + root) * self.inv_2qa, (-qb - root) * self.inv_2qa);
            let (left, right) = ((l, h.min(r_lo)), (l.max(r_hi), h));
            match (left.0 <= left.1, right.0 <= right.1) {
                (true, true) => {}
                (true, false) => h = left.1,
                (false, true) => l = right.0,
                (false, false) => return None,
            }
        }
        // (Otherwise, nearly level with the row or nowhere outside the cone: the whole slab.)
        (l <= h).then_some((l, h))
    }
}

/// Distance in the (y, z) plane from a point to a segment: a lower bound on the 3-D distance
/// from any point of the row through it.
fn segment_distance_2d(p: (f64, f64), a: (f64, f64), b: (f64, f64)) -> f64 {
    let (abx, aby) = (b.0 - a.0, b.1 - a.1);
    let len2 = abx * abx + aby * aby;
    let t = if len2 > 0.0 { (((p.0 - a.0) * abx + (p.1 - a.1) * aby) / len2).clamp(0.0, 1.0) } else { 0.0 };
    let (dx, dy) = (p.0 - a.0 - abx * t, p.1 - a.1 - aby * t);
    (dx * dx + dy * dy).sqrt()
}

#[inline]
fn segment_distance(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let t = ((p - a).dot(ab) / ab.length_squared().max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
    (p - (a + ab * t)).length()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The one-pose fast path and the slabs' row bounds give, bit for bit, the patch (values and
    /// spans) that the general loop bounded by the head's one cylinder gives: every burr family,
    /// random short translations from a pose the grids hold (the haptic tick's stroke, one pose
    /// evaluated) and longer ones (several), any direction, any tilt.
    #[test]
    fn the_fast_sweep_matches_the_general_sweep_bit_for_bit() {
        let mut unit = crate::unit_random(0x2545_f491_4f6c_dd1du64);
        let (voxel, band) = (0.05, 0.15);
        let cutoff = (band + 1.5 * voxel) as f32;
        let specs = ["cylinder_flat_012", "cylinder_round_012", "taper_flat_012", "taper_round_014", "inverted_cone_010", "flame_016", "pear_010", "needle_012", "xmas_016", "wheel_025"];
        let (mut fast, mut general) = (Sweep::default(), Sweep { exhaustive: true, ..Default::default() });
        for spec in specs {
            let burr = Burr::parse(spec).unwrap();
            let (mut one_pose, mut cut) = (0, 0);
            for case in 0..16 {
                let mut v = [0.0; 9];
                v.iter_mut().for_each(|x| *x = unit());
                let direction = |a: f64, b: f64, c: f64| DVec3::new(a - 0.5, b - 0.5, c - 0.5).normalize_or(DVec3::Z);
                let tilt = DQuat::from_axis_angle(direction(v[0], v[1], v[2]), std::f64::consts::PI * v[3]);
                let from = DAffine3::from_rotation_translation(tilt, DVec3::new(v[4], v[5], v[6]) - 0.5);
                // Most strokes as a haptic tick's (under half a voxel), some a few voxels long.
                let length = if case % 4 == 3 { 0.2 * v[7] } else { 0.024 * v[7] };
                let to = DAffine3::from_rotation_translation(tilt, from.translation + direction(v[8], unit(), unit()) * length);
                let done = Some(Done::Head(CutHead { to_tool: from.inverse(), offset: 0.0 }));
                fast.build_skipping(&burr, from, to, voxel, band, done).unwrap();
                general.build_skipping(&burr, from, to, voxel, band, done).unwrap();
                let (f, g) = (&fast.patch, &general.patch);
                assert_eq!((f.index_min, f.dims), (g.index_min, g.dims), "{spec} case {case}");
                assert_eq!(f.spans, g.spans, "{spec} case {case}: spans");
                for (n, (a, b)) in f.values.iter().zip(&g.values).enumerate() {
                    assert_eq!(a.to_bits(), b.to_bits(), "{spec} case {case}: voxel {n}: {a} vs {b}");
                }
                one_pose += usize::from(fast.substeps == 1);
                cut += usize::from(f.values.iter().any(|v| *v < cutoff));
            }
            assert!(one_pose >= 8 && cut == 16, "{spec}: {one_pose} one-pose strokes, {cut} that cut");
        }
    }

    /// A patch built for an unmeasured subtract holds, bit for bit, the full patch's value at
    /// every voxel where either is below the band (the only voxels such a subtract reads), and
    /// its spans lie within the full patch's: every burr family, haptic ticks and longer strokes.
    #[test]
    fn an_unmeasured_patch_keeps_every_value_below_the_band() {
        let mut unit = crate::unit_random(0x5851_f42d_4c95_7f2du64);
        let (voxel, band) = (0.05, 0.15);
        let band32 = band as f32;
        let specs = ["cylinder_flat_012", "cylinder_round_012", "taper_flat_012", "taper_round_014", "inverted_cone_010", "flame_016", "pear_010", "needle_012", "xmas_016", "wheel_025", "round:1"];
        let (mut full, mut unmeasured) = (Sweep::default(), Sweep::default());
        unmeasured.set_unmeasured(true);
        let mut left_out = 0;
        for spec in specs {
            let burr = Burr::parse(spec).unwrap();
            for case in 0..16 {
                let tilt = DQuat::from_axis_angle(DVec3::new(unit() - 0.5, unit() - 0.5, unit() - 0.5).normalize_or(DVec3::Z), std::f64::consts::PI * unit());
                let from = DAffine3::from_rotation_translation(tilt, DVec3::new(unit(), unit(), unit()) - 0.5);
                let length = if case % 4 == 3 { 0.2 * unit() } else { 0.024 * unit() };
                let to = DAffine3::from_rotation_translation(tilt, from.translation + DVec3::new(unit() - 0.5, unit() - 0.5, unit() - 0.5).normalize_or(DVec3::X) * length);
                let done = match burr.ball_radius() {
                    Some(r) => Some(Done::Ball(CutBall { centre: from.transform_point3(DVec3::new(0.0, 0.0, r)), radius: r })),
                    None => Some(Done::Head(CutHead { to_tool: from.inverse(), offset: 0.0 })),
                };
                full.build_skipping(&burr, from, to, voxel, band, done).unwrap();
                unmeasured.build_skipping(&burr, from, to, voxel, band, done).unwrap();
                let (f, u) = (&full.patch, &unmeasured.patch);
                assert_eq!((f.index_min, f.dims), (u.index_min, u.dims), "{spec} case {case}");
                for (n, (a, b)) in f.values.iter().zip(&u.values).enumerate() {
                    if *a < band32 || *b < band32 {
                        assert_eq!(a.to_bits(), b.to_bits(), "{spec} case {case}: voxel {n}: {a} vs {b}");
                    }
                    left_out += usize::from(a != b);
                }
                for (row, (fs, us)) in f.spans.chunks_exact(2).zip(u.spans.chunks_exact(2)).enumerate() {
                    assert!(us[0] == us[1] || (fs[0] <= us[0] && us[1] <= fs[1]), "{spec} case {case}: row {row}: span {us:?} beyond {fs:?}");
                }
            }
        }
        // The bound was taken: voxels between the band and the cut-off were left out.
        assert!(left_out > 0);
    }

    /// A sweep reused from stroke to stroke (which puts back only the last spans) gives the
    /// patch a fresh one gives, bit for bit: boxes of every size, round burrs and heads, and a
    /// stroke refused in between.
    #[test]
    fn a_reused_sweep_builds_what_a_fresh_one_builds() {
        let mut unit = crate::unit_random(0x1234_5678_9abc_def1u64);
        let mut reused = Sweep::default();
        for (case, spec) in ["flame_016", "round:1", "cylinder_flat_012", "round:0.6", "taper_flat_012", "pear_010"].iter().cycle().take(30).enumerate() {
            let burr = Burr::parse(spec).unwrap();
            // (A new band, a new cut-off: the whole box is filled again.)
            let band = [0.15, 0.1][case / 12 % 2];
            let tilt = DQuat::from_axis_angle(DVec3::new(unit() - 0.5, unit() - 0.5, unit() - 0.5).normalize_or(DVec3::Z), 3.0 * unit());
            let from = DAffine3::from_rotation_translation(tilt, DVec3::new(unit(), unit(), unit()) - 0.5);
            let to = DAffine3::from_rotation_translation(tilt, from.translation + DVec3::new(unit() - 0.5, unit() - 0.5, unit() - 0.5) * 0.4 * unit());
            let done = Some(Done::Head(CutHead { to_tool: from.inverse(), offset: 0.0 })).filter(|_| burr.ball_radius().is_none());
            if case % 7 == 6 {
                // Refused for its box, after the last patch was built.
                let far = DAffine3::from_rotation_translation(tilt, from.translation + DVec3::splat(60.0));
                assert!(reused.build_skipping(&burr, from, far, 0.05, band, None).unwrap_err().to_string().contains("would touch"));
            }
            reused.build_skipping(&burr, from, to, 0.05, band, done).unwrap();
            let mut fresh = Sweep::default();
            fresh.build_skipping(&burr, from, to, 0.05, band, done).unwrap();
            let (a, b) = (&reused.patch, &fresh.patch);
            assert_eq!((a.index_min, a.dims, &a.spans), (b.index_min, b.dims, &b.spans), "case {case} {spec}");
            assert!(a.values.iter().zip(&b.values).all(|(x, y)| x.to_bits() == y.to_bits()), "case {case} {spec}: values differ");
            assert_eq!(a.values.len(), b.values.len());
        }
    }

    /// The fast floor and ceiling agree with the library's wherever an i32 holds the result.
    #[test]
    fn index_floor_and_ceiling_match_the_library() {
        for x in [-3.5, -3.0, -2.9999999, -0.5, -0.0, 0.0, 0.25, 1.0, 7.999999999, 1e6 + 0.5, -1e6 - 0.5] {
            assert_eq!(floor_i32(x), x.floor() as i32, "{x}");
            assert_eq!(ceil_i32(x), x.ceil() as i32, "{x}");
        }
        assert_eq!((floor_i32(f64::INFINITY), ceil_i32(f64::NEG_INFINITY)), (i32::MAX, i32::MIN));
    }

    /// Runs cover exactly the indices of the range outside the cuts.
    #[test]
    fn runs_outside_the_cuts_cover_the_rest_exactly() {
        let cuts = [(1, 0), (3, 5), (4, 9), (7, 8), (-20, 2), (12, 40), (i32::MIN, 6), (9, i32::MAX), (0, 0), (10, 10)];
        for c0 in cuts {
            for c1 in cuts {
                let runs = runs_outside(0, 10, [c0, c1]);
                for i in -2..=12 {
                    let kept = runs.iter().filter(|(a, b)| (*a..=*b).contains(&i)).count();
                    let cut = [c0, c1].iter().any(|(a, b)| (*a..=*b).contains(&i));
                    let want = usize::from((0..=10).contains(&i) && !cut);
                    assert_eq!(kept, want, "index {i}, cuts {c0:?} {c1:?}: runs {runs:?}");
                }
            }
        }
    }

    /// The interval holds exactly the row's points within reach of the segment (brute force).
    #[test]
    fn line_capsule_interval_matches_brute_force() {
        let cases = [
            (DVec3::new(0.1, 0.2, -0.3), DVec3::new(0.5, 1.9, 2.2), 0.7),
            (DVec3::new(0.0, 0.0, 0.0), DVec3::new(0.0, 0.0, 4.0), 0.8),
            (DVec3::new(-1.0, 0.3, 0.2), DVec3::new(2.0, 0.3, 0.2), 0.5),
            (DVec3::new(0.4, 0.4, 0.4), DVec3::new(0.4, 0.4, 0.4), 0.6),
        ];
        for (a, b, r) in cases {
            for yi in -30..=30 {
                for zi in -30..=60 {
                    let (y, z) = (yi as f64 * 0.1, zi as f64 * 0.1);
                    let got = LineCapsule::new(a, b, r).x_interval(y, z);
                    let within = |reach: f64| -> Vec<f64> {
                        (-400..=400).map(|i| i as f64 * 0.01).filter(|x| segment_distance(DVec3::new(*x, y, z), a, b) <= reach).collect()
                    };
                    // Every point within r - 1e-6 is in the interval; the interval holds no point
                    // beyond r + 1e-6 but for the 0.01 mm step of the brute force.
                    let (inner, outer) = (within(r - 1e-6), within(r + 1e-6));
                    if let (Some(f), Some(e)) = (inner.first(), inner.last()) {
                        let (l, h) = got.unwrap_or_else(|| panic!("{a} {b} {r} row ({y}, {z}): none, points within reach"));
                        assert!(l <= *f + 1e-9 && h >= *e - 1e-9, "{a} {b} {r} row ({y}, {z}): [{l}, {h}] misses [{f}, {e}]");
                    }
                    if let Some((l, h)) = got {
                        match (outer.first(), outer.last()) {
                            (Some(f), Some(e)) => assert!(l >= f - 0.011 && h <= e + 0.011, "{a} {b} {r} row ({y}, {z}): [{l}, {h}] beyond [{f}, {e}]"),
                            _ => assert!(h - l < 0.02, "{a} {b} {r} row ({y}, {z}): [{l}, {h}] where nothing is within reach"),
                        }
                    }
                }
            }
        }
    }
}
