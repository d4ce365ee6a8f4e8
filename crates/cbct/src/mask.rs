//! Masks over a voxel grid (x fastest): flood fills and face-neighbour maps. Calibration floods
//! most of a scan's coarse grid several times and segmentation the tooth's box, so both work a
//! row at a time: a queue of single voxels costs a push, a pop and index divisions per voxel; a
//! run costs them once and its voxels are one linear scan. The set a flood reaches does not
//! depend on the order.

use rayon::prelude::*;

/// Each voxel's `f(own, [−x, +x, −y, +y, −z, +z] neighbours)` over `of` (a mask, or levels), with `beyond`
/// past the grid's border; slabs side by side, rows scanned with no index divided. A row's
/// neighbour rows are slices (a row of `beyond` past the border), so its inner voxels need no
/// test of where they lie (a tooth's search box, 11 M voxels: 23 → 10 ms an erosion).
pub fn neighbour_map<T: Copy + Sync, U: Copy + Default + Send>(dims: [usize; 3], of: &[T], beyond: T, f: impl Fn(T, [T; 6]) -> U + Sync) -> Vec<U> {
    let [nx, ny, nz] = dims;
    let (sy, sz) = (nx, nx * ny);
    let mut out = vec![U::default(); of.len()];
    if of.is_empty() {
        return out;
    }
    let outside = vec![beyond; nx];
    out.par_chunks_mut(sz).enumerate().for_each(|(k, slab)| {
        let row = |j: usize, k: usize| &of[sy * j + sz * k..][..nx];
        for (j, dst) in slab.chunks_exact_mut(nx).enumerate() {
            let here = row(j, k);
            let south = if j > 0 { row(j - 1, k) } else { &outside };
            let north = if j + 1 < ny { row(j + 1, k) } else { &outside };
            let below = if k > 0 { row(j, k - 1) } else { &outside };
            let above = if k + 1 < nz { row(j, k + 1) } else { &outside };
            let at = |i: usize, left: T, right: T| f(here[i], [left, right, south[i], north[i], below[i], above[i]]);
            if nx == 1 {
                dst[0] = at(0, beyond, beyond);
                continue;
            }
            dst[0] = at(0, beyond, here[1]);
            for i in 1..nx - 1 {
                dst[i] = at(i, here[i - 1], here[i + 1]);
            }
            dst[nx - 1] = at(nx - 1, here[nx - 2], beyond);
        }
    });
    out
}

/// Fills from `start` over voxels `allowed` and not yet `seen`, marking them seen; calls
/// `on_run(first, last)` for each row run filled (inclusive linear indices). `stack` is scratch.
pub fn fill_from(dims: [usize; 3], allowed: &[bool], seen: &mut [bool], start: usize, stack: &mut Vec<usize>, mut on_run: impl FnMut(usize, usize)) {
    let [nx, ny, nz] = dims;
    let (sy, sz) = (nx, nx * ny);
    stack.clear();
    stack.push(start);
    while let Some(s) = stack.pop() {
        if !allowed[s] || seen[s] {
            continue;
        }
        let row = s / nx;
        let (row_start, row_end) = (row * nx, row * nx + nx - 1);
        let (mut a, mut b) = (s, s);
        while a > row_start && allowed[a - 1] && !seen[a - 1] {
            a -= 1;
        }
        while b < row_end && allowed[b + 1] && !seen[b + 1] {
            b += 1;
        }
        seen[a..=b].iter_mut().for_each(|v| *v = true);
        on_run(a, b);
        let (j, k) = (row % ny, row / ny);
        let rows = [(j > 0).then(|| a - sy), (j + 1 < ny).then(|| a + sy), (k > 0).then(|| a - sz), (k + 1 < nz).then(|| a + sz)];
        // One seed per fillable stretch of each neighbouring row under the run.
        for first in rows.into_iter().flatten() {
            let mut open = false;
            for m in first..=first + (b - a) {
                let fillable = allowed[m] && !seen[m];
                if fillable && !open {
                    stack.push(m);
                }
                open = fillable;
            }
        }
    }
}

/// The voxels of `allowed` connected to any of `starts` (6-connected).
pub fn flood(dims: [usize; 3], allowed: &[bool], starts: impl IntoIterator<Item = usize>) -> Vec<bool> {
    let mut seen = vec![false; allowed.len()];
    let mut stack = Vec::new();
    for s in starts {
        fill_from(dims, allowed, &mut seen, s, &mut stack, |_, _| {});
    }
    seen
}

/// The voxels of `allowed` connected to the grid's border (6-connected).
pub fn flood_from_border(dims: [usize; 3], allowed: &[bool]) -> Vec<bool> {
    // (Voxels on edges come twice; the second finds them seen.)
    let starts = border_voxels(dims).filter(|&n| allowed[n]);
    flood(dims, allowed, starts)
}

/// The floods from the border of every level at once: for voxels at `level`s (`levels` and above:
/// never reached), each voxel's least level L such that it is connected to the grid's border
/// through voxels at levels ≤ L (6-connected), `u8::MAX` where none is. So `reached[n] <= l` is
/// [`flood_from_border`] of `level <= l`, for each l: nested floods filled once, from the
/// lowest level up, each voxel a level stops at kept for the level that opens it.
pub fn flood_levels_from_border(dims: [usize; 3], level: &[u8], levels: u8) -> Vec<u8> {
    let [nx, ny, nz] = dims;
    let (sy, sz) = (nx, nx * ny);
    let mut reached = vec![u8::MAX; level.len()];
    let mut pending: Vec<Vec<usize>> = vec![Vec::new(); usize::from(levels)];
    for n in border_voxels(dims) {
        if level[n] < levels {
            pending[usize::from(level[n])].push(n);
        }
    }
    let mut stack = Vec::new();
    for l in 0..levels {
        let seeds = std::mem::take(&mut pending[usize::from(l)]);
        for s in seeds {
            stack.push(s);
            while let Some(s) = stack.pop() {
                if reached[s] != u8::MAX || level[s] > l {
                    continue;
                }
                let row = s / nx;
                let (row_start, row_end) = (row * nx, row * nx + nx - 1);
                let fillable = |m: usize, reached: &[u8]| level[m] <= l && reached[m] == u8::MAX;
                let (mut a, mut b) = (s, s);
                while a > row_start && fillable(a - 1, &reached) {
                    a -= 1;
                }
                while b < row_end && fillable(b + 1, &reached) {
                    b += 1;
                }
                reached[a..=b].iter_mut().for_each(|v| *v = l);
                // A voxel a level stops at waits for its own level (it is above l).
                let mut wait = |m: usize, reached: &[u8]| {
                    if reached[m] == u8::MAX && level[m] < levels {
                        pending[usize::from(level[m])].push(m);
                    }
                };
                if a > row_start {
                    wait(a - 1, &reached);
                }
                if b < row_end {
                    wait(b + 1, &reached);
                }
                let (j, k) = (row % ny, row / ny);
                let rows = [(j > 0).then(|| a - sy), (j + 1 < ny).then(|| a + sy), (k > 0).then(|| a - sz), (k + 1 < nz).then(|| a + sz)];
                for first in rows.into_iter().flatten() {
                    let mut open = false;
                    for m in first..=first + (b - a) {
                        let f = fillable(m, &reached);
                        if f && !open {
                            stack.push(m);
                        } else if !f {
                            wait(m, &reached);
                        }
                        open = f;
                    }
                }
            }
        }
    }
    reached
}

/// The voxels on the grid's six faces (those on edges more than once).
fn border_voxels([nx, ny, nz]: [usize; 3]) -> impl Iterator<Item = usize> {
    let at = move |i: usize, j: usize, k: usize| i + nx * (j + ny * k);
    let x_faces = (0..nz).flat_map(move |k| (0..ny).flat_map(move |j| [at(0, j, k), at(nx - 1, j, k)]));
    let y_faces = (0..nz).flat_map(move |k| (0..nx).flat_map(move |i| [at(i, 0, k), at(i, ny - 1, k)]));
    let z_faces = (0..ny).flat_map(move |j| (0..nx).flat_map(move |i| [at(i, j, 0), at(i, j, nz - 1)]));
    x_faces.chain(y_faces).chain(z_faces)
}

/// Connected components (6-connected) of `m`: the component's id per voxel (0 = none, ids in
/// the order of each component's first voxel) and each id's size (index 0 unused).
pub fn components(dims: [usize; 3], m: &[bool]) -> (Vec<u32>, Vec<usize>) {
    let mut id = vec![0u32; m.len()];
    let mut sizes = vec![0usize];
    let mut seen = vec![false; m.len()];
    let mut stack = Vec::new();
    for s in 0..m.len() {
        if !m[s] || seen[s] {
            continue;
        }
        let c = sizes.len() as u32;
        let mut size = 0;
        fill_from(dims, m, &mut seen, s, &mut stack, |a, b| {
            id[a..=b].iter_mut().for_each(|v| *v = c);
            size += b - a + 1;
        });
        sizes.push(size);
    }
    (id, sizes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::VecDeque;

    fn neighbours(n: usize, [nx, ny, nz]: [usize; 3]) -> Vec<usize> {
        let (i, j, k) = (n % nx, (n / nx) % ny, n / (nx * ny));
        let mut out = Vec::new();
        if i > 0 { out.push(n - 1) }
        if i + 1 < nx { out.push(n + 1) }
        if j > 0 { out.push(n - nx) }
        if j + 1 < ny { out.push(n + nx) }
        if k > 0 { out.push(n - nx * ny) }
        if k + 1 < nz { out.push(n + nx * ny) }
        out
    }

    /// Components by a voxel-at-a-time breadth-first search, the plain definition.
    fn components_by_queue(dims: [usize; 3], m: &[bool]) -> (Vec<u32>, Vec<usize>) {
        let mut id = vec![0u32; m.len()];
        let mut sizes = vec![0usize];
        for s in 0..m.len() {
            if !m[s] || id[s] != 0 {
                continue;
            }
            let c = sizes.len() as u32;
            sizes.push(0);
            id[s] = c;
            let mut q = VecDeque::from([s]);
            while let Some(n) = q.pop_front() {
                sizes[c as usize] += 1;
                for t in neighbours(n, dims) {
                    if m[t] && id[t] == 0 {
                        id[t] = c;
                        q.push_back(t);
                    }
                }
            }
        }
        (id, sizes)
    }

    /// Random masks of every density, in grids with sides of 1 and thin slabs among them.
    fn masks() -> Vec<([usize; 3], Vec<bool>)> {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let mut out = Vec::new();
        for dims in [[1, 1, 1], [7, 1, 1], [1, 9, 1], [1, 1, 6], [5, 6, 7], [13, 3, 1], [17, 11, 9], [32, 24, 16]] {
            for density in [10u64, 35, 50, 60, 75, 95] {
                let n = dims.iter().product();
                out.push((dims, (0..n).map(|_| next() % 100 < density).collect()));
            }
        }
        out
    }

    #[test]
    fn the_neighbour_map_sees_each_voxels_six_neighbours_and_beyond_past_the_border() {
        for (dims, m) in masks() {
            let [nx, ny, nz] = dims;
            // Each voxel's own index and its neighbours' (usize::MAX past the border), in order.
            let index: Vec<usize> = (0..m.len()).collect();
            let got = neighbour_map(dims, &index, usize::MAX, |own, near| (own, near));
            for (n, &(own, near)) in got.iter().enumerate() {
                let (i, j, k) = (n % nx, (n / nx) % ny, n / (nx * ny));
                let at = |ok: bool, d: isize| if ok { n.wrapping_add_signed(d) } else { usize::MAX };
                let (sy, sz) = (nx as isize, (nx * ny) as isize);
                let expected = [at(i > 0, -1), at(i + 1 < nx, 1), at(j > 0, -sy), at(j + 1 < ny, sy), at(k > 0, -sz), at(k + 1 < nz, sz)];
                assert_eq!((own, near), (n, expected), "{dims:?} voxel {n}");
            }
        }
    }

    #[test]
    fn runs_find_the_components_a_voxel_queue_finds() {
        for (dims, m) in masks() {
            assert_eq!(components(dims, &m), components_by_queue(dims, &m), "{dims:?}");
        }
    }

    #[test]
    fn the_border_flood_reaches_the_components_touching_the_border() {
        for (dims, m) in masks() {
            let (id, _) = components_by_queue(dims, &m);
            let [nx, ny, nz] = dims;
            let mut touching = vec![false; id.len() + 1];
            for n in 0..m.len() {
                let (i, j, k) = (n % nx, (n / nx) % ny, n / (nx * ny));
                if m[n] && (i == 0 || j == 0 || k == 0 || i + 1 == nx || j + 1 == ny || k + 1 == nz) {
                    touching[id[n] as usize] = true;
                }
            }
            let expected: Vec<bool> = (0..m.len()).map(|n| m[n] && touching[id[n] as usize]).collect();
            assert_eq!(flood_from_border(dims, &m), expected, "{dims:?}");
        }
    }

    #[test]
    fn the_floods_of_every_level_at_once_are_each_levels_flood() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        for (dims, m) in masks() {
            // Levels 0..=4 (4: never reached), with the mask's voxels kept low so that each
            // level's set is connected in places and walled in others.
            let level: Vec<u8> = m
                .iter()
                .map(|&v| {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    if v { (state % 3) as u8 } else { 2 + (state % 3) as u8 }
                })
                .collect();
            let reached = flood_levels_from_border(dims, &level, 4);
            for l in 0..4u8 {
                let allowed: Vec<bool> = level.iter().map(|&v| v <= l).collect();
                let expected = flood_from_border(dims, &allowed);
                let got: Vec<bool> = reached.iter().map(|&r| r <= l).collect();
                assert_eq!(got, expected, "{dims:?} level {l}");
            }
            assert!(reached.iter().zip(&level).all(|(&r, &v)| r == u8::MAX || (r >= v && r < 4)));
        }
    }
}

/// Where `mask` holds within `radius` voxels along each axis (a box, separably).
pub fn within_box(mut mask: Vec<bool>, dims: [usize; 3], radius: usize) -> Vec<bool> {
    for (axis, stride) in [(0usize, 1usize), (1, dims[0]), (2, dims[0] * dims[1])] {
        let n_axis = dims[axis];
        let src = mask.clone();
        mask.par_iter_mut().enumerate().for_each(|(n, out)| {
            let at = (n / stride) % n_axis;
            *out = (at.saturating_sub(radius)..=(at + radius).min(n_axis - 1)).any(|a| src[n - at * stride + a * stride]);
        });
    }
    mask
}
