//! Burr distances against brute force over a densely sampled profile, and spec parsing.
use glam::{DVec2, DVec3};

use super::profile::{Piece, Profile};
use super::*;

/// The profile as a fine closed polygon (including the axis), sampled independently of the
/// exact distance code.
fn polygon(profile: &Profile) -> Vec<DVec2> {
    let mut pts = Vec::new();
    for piece in &profile.pieces {
        let n = 4000;
        for i in 0..n {
            let t = i as f64 / n as f64;
            pts.push(match *piece {
                Piece::Line { a, b } => a + (b - a) * t,
                Piece::Arc { centre, radius, a, b, ccw } => {
                    let (sa, sb) = ((a - centre).to_angle(), (b - centre).to_angle());
                    let mut span = sb - sa;
                    if ccw && span < 0.0 { span += std::f64::consts::TAU; }
                    if !ccw && span > 0.0 { span -= std::f64::consts::TAU; }
                    centre + DVec2::from_angle(sa + span * t) * radius
                }
            });
        }
    }
    pts.push(profile.pieces.last().unwrap().end());
    pts
}

/// Brute-force signed distance to a closed polygon: every edge but the closing one along the
/// axis, with runs of edges skipped only where their bounding box is already farther than the
/// nearest edge found (the same minimum, found sooner).
struct Brute<'a> {
    poly: &'a [DVec2],
    /// (first edge, past the last, box min, box max)
    runs: Vec<(usize, usize, DVec2, DVec2)>,
}

impl<'a> Brute<'a> {
    const RUN: usize = 64;

    fn new(poly: &'a [DVec2]) -> Self {
        let edges = poly.len() - 1;
        let runs = (0..edges)
            .step_by(Self::RUN)
            .map(|a| {
                let b = (a + Self::RUN).min(edges);
                let pts = &poly[a..=b];
                let lo = pts.iter().fold(DVec2::INFINITY, |m, q| m.min(*q));
                let hi = pts.iter().fold(DVec2::NEG_INFINITY, |m, q| m.max(*q));
                (a, b, lo, hi)
            })
            .collect();
        Brute { poly, runs }
    }

    fn distance(&self, p: DVec2) -> f64 {
        let box_distance = |&(_, _, lo, hi): &(usize, usize, DVec2, DVec2)| (lo - p).max(p - hi).max(DVec2::ZERO).length();
        let edges = |first: usize, past: usize| {
            self.poly[first..=past].windows(2).fold(f64::INFINITY, |d: f64, w| {
                let (a, b) = (w[0], w[1]);
                let ab = b - a;
                let t = ((p - a).dot(ab) / ab.length_squared().max(1e-300)).clamp(0.0, 1.0);
                d.min((p - a - ab * t).length())
            })
        };
        // The nearest box's edges first, so that most other runs are skipped.
        let nearest = (0..self.runs.len()).min_by(|&a, &b| box_distance(&self.runs[a]).total_cmp(&box_distance(&self.runs[b]))).unwrap_or(0);
        let (first, past, _, _) = self.runs[nearest];
        let mut d = edges(first, past);
        for run in &self.runs {
            if box_distance(run) < d {
                d = d.min(edges(run.0, run.1));
            }
        }
        // Crossings of a ray in +x, the closing edge included; a run that lies wholly above or
        // below the ray crosses it nowhere.
        let crosses = |a: DVec2, b: DVec2| (a.y > p.y) != (b.y > p.y) && a.x + (p.y - a.y) / (b.y - a.y) * (b.x - a.x) > p.x;
        let mut inside = crosses(self.poly[self.poly.len() - 1], self.poly[0]);
        for &(first, past, lo, hi) in &self.runs {
            if p.y < lo.y || p.y >= hi.y {
                continue;
            }
            for w in self.poly[first..=past].windows(2) {
                inside ^= crosses(w[0], w[1]);
            }
        }
        if inside { -d } else { d }
    }
}

fn every_burr() -> Vec<Burr> {
    Shape::ALL.iter().map(|&s| Burr::new(s, if s == Shape::Wheel { 2.5 } else { 1.2 }, None).unwrap()).collect()
}

#[test]
fn every_shape_is_exact_within_a_tenth_of_a_voxel_in_the_band() {
    let voxel = 0.05;
    let band = 3.0 * voxel;
    for burr in every_burr() {
        let profile = burr.head_profile();
        let poly = polygon(&profile);
        let brute = Brute::new(&poly);
        let mut worst: f64 = 0.0;
        let mut checked = 0;
        // A deterministic scatter over the head's bounding box plus the band.
        for i in 0..20_000u32 {
            let f = f64::from(i);
            let u = (f * 0.618_034).fract();
            let v = (f * 0.414_214 + 0.3).fract();
            let phi = f * 2.399_963;
            let rho = u * (profile.max_radius + 2.0 * band);
            let z = profile.z_min - 2.0 * band + v * (profile.z_max - profile.z_min + 4.0 * band);
            let p = DVec3::new(rho * phi.cos(), rho * phi.sin(), z);
            let exact = brute.distance(DVec2::new(rho, z));
            if exact.abs() > band {
                continue;
            }
            checked += 1;
            worst = worst.max((burr.sdf(p) - exact).abs());
        }
        assert!(checked > 500, "{:?}: only {checked} band points", burr.shape);
        assert!(worst <= 0.1 * voxel, "{:?}: error {worst} mm", burr.shape);
        println!("{:>15} worst |sdf - brute| = {worst:.2e} mm over {checked} band points", burr.shape.name());
    }
}

#[test]
fn sizes_follow_the_spec() {
    for burr in every_burr() {
        let profile = burr.head_profile();
        assert!((profile.max_radius - burr.diameter_mm / 2.0).abs() < 1e-9 || burr.shape == Shape::Flame,
            "{:?}: widest {} vs {}", burr.shape, profile.max_radius, burr.diameter_mm / 2.0);
        assert!((profile.z_min).abs() < 1e-9 || burr.shape == Shape::Flame, "{:?}: tip at the origin", burr.shape);
        assert!(burr.sdf(DVec3::ZERO).abs() < 1e-9, "{:?}: the tip is on the surface", burr.shape);
        assert!(burr.sdf(DVec3::new(0.0, 0.0, -0.01)) > 0.0);
        let (cz, rb) = burr.bound();
        for q in polygon(&profile) {
            assert!(q.length() <= burr.bounding_radius() + 1e-9, "{:?}: {q} outside the bounding radius", burr.shape);
            assert!((q - DVec2::new(0.0, cz)).length() <= rb + 1e-9, "{:?}: {q} outside the bound", burr.shape);
        }
    }
}

#[test]
fn shank_does_not_cut_and_sits_above_the_tip() {
    for burr in every_burr() {
        let high = DVec3::new(0.0, 0.0, burr.length_mm + 5.0);
        assert!(burr.shank_sdf(high) < 0.0, "{:?}", burr.shape);
        assert!(burr.sdf(high) > 1.0, "{:?}: the head does not reach the shank", burr.shape);
        assert!(burr.shank_sdf(DVec3::new(0.0, 0.0, -0.1)) > 0.0);
    }
}

#[test]
fn specs_parse_and_errors_name_the_token() {
    let b = Burr::parse("round:1.0").unwrap();
    assert_eq!((b.shape, b.diameter_mm), (Shape::Round, 1.0));
    let b = Burr::parse("cylinder_flat:1.2:4").unwrap();
    assert_eq!((b.shape, b.diameter_mm, b.length_mm), (Shape::CylinderFlat, 1.2, 4.0));
    let b = Burr::parse("806 314 243 524 016").unwrap();
    assert_eq!((b.shape, b.diameter_mm), (Shape::Flame, 1.6));
    assert_eq!(b.iso.unwrap().to_string(), "806 314 243 524 016");
    let b = Burr::parse("806314001524010").unwrap();
    assert_eq!((b.shape, b.diameter_mm), (Shape::Round, 1.0));
    let b = Burr::parse("806 204 010 524 012").unwrap();
    assert_eq!((b.shape, b.shank_diameter_mm), (Shape::InvertedCone, 2.35));
    assert_eq!(Burr::parse("flame_016").unwrap().shape, Shape::Flame);
    for (spec, token) in [
        ("806 314 999 524 016", "'999'"),
        ("806 999 001 524 016", "'999'"),
        ("123 314 001 524 016", "'123'"),
        ("806 314 001 900 016", "'900'"),
        ("806 314 001 524", "4 groups"),
        ("806 314 001 524 0x6", "'0x6'"),
        ("trapezoid:1.0", "'trapezoid'"),
        ("round:abc", "'abc'"),
        ("round:1.0:x", "'x'"),
        ("round:-1", "-1"),
        ("cylinder_round:1.2:0.3", "length"),
        ("round", "DIAMETER"),
    ] {
        let e = Burr::parse(spec).unwrap_err().to_string();
        assert!(e.contains(token), "{spec}: {e}");
    }
}

#[test]
fn builtin_catalogue_parses() {
    let cat = catalogue::Catalogue::parse(include_str!("../../burrs.toml"), "burrs.toml").unwrap();
    assert!(cat.burrs.len() >= 11);
    let shapes: std::collections::HashSet<_> = cat.burrs.iter().map(|e| e.burr().unwrap().shape).collect();
    assert_eq!(shapes.len(), Shape::ALL.len(), "every shape has a catalogue entry");
    let e = catalogue::Catalogue::parse("[[burr]]\nname = \"x\"\nshape = \"round\"\n", "user.toml").unwrap_err().to_string();
    assert!(e.contains("user.toml") && e.contains("'x'"), "{e}");
}

#[test]
fn the_default_spec_is_the_default_round_burr() {
    assert_eq!(Burr::parse(DEFAULT_BURR).unwrap(), Burr::round(DEFAULT_ROUND_DIAMETER_MM).unwrap());
}

/// Every head we model is convex (the sweep's skip of a translating head's back relies on it),
/// and its facing heights bound, from the right side, every sampled surface point whose outward
/// normal points down (or up).
#[test]
fn every_head_is_convex_and_its_facing_heights_hold() {
    for burr in every_burr() {
        let (down_below, up_above) = burr.facing_heights().unwrap_or_else(|| panic!("{:?} has a dent", burr.shape));
        let poly = polygon(&burr.head_profile());
        for w in poly.windows(2) {
            let d = w[1] - w[0];
            if d.length() < 1e-12 {
                continue;
            }
            // The chain runs counter-clockwise (tip, out, up, back to the axis): outward is right.
            let normal_z = -d.x / d.length();
            if normal_z < -1e-9 {
                assert!(w[0].y.max(w[1].y) <= down_below + 1e-9, "{:?}: faces down at {} above {down_below}", burr.shape, w[0].y.max(w[1].y));
            }
            if normal_z > 1e-9 {
                assert!(w[0].y.min(w[1].y) >= up_above - 1e-9, "{:?}: faces up at {} below {up_above}", burr.shape, w[0].y.min(w[1].y));
            }
        }
    }
    // A dented profile is not taken for convex.
    let dented = Profile::new(vec![
        Piece::Line { a: DVec2::new(0.0, 0.0), b: DVec2::new(1.0, 0.0) },
        Piece::Line { a: DVec2::new(1.0, 0.0), b: DVec2::new(0.5, 1.0) },
        Piece::Line { a: DVec2::new(0.5, 1.0), b: DVec2::new(1.0, 2.0) },
        Piece::Line { a: DVec2::new(1.0, 2.0), b: DVec2::new(0.0, 2.0) },
    ]);
    assert!(!dented.convex);
    let cylinder = Profile::new(vec![
        Piece::Line { a: DVec2::new(0.0, 0.0), b: DVec2::new(1.0, 0.0) },
        Piece::Line { a: DVec2::new(1.0, 0.0), b: DVec2::new(1.0, 2.0) },
        Piece::Line { a: DVec2::new(1.0, 2.0), b: DVec2::new(0.0, 2.0) },
    ]);
    assert!(cylinder.convex);
    assert_eq!((cylinder.facing_down_below, cylinder.facing_up_above), (0.0, 2.0), "the wall faces sideways only");
}

/// The row evaluation agrees with the f64 distance at every point of random rows through every
/// head (to f32 rounding of coordinates of a few mm).
#[test]
fn rows_of_distances_match_the_pointwise_distance() {
    let mut next = crate::unit_random(0x9e37_79b9_7f4a_7c15);
    let mut unit = || next() * 2.0 - 1.0;
    let mut out = vec![0f32; 77];
    for burr in every_burr() {
        for _ in 0..200 {
            let origin = DVec3::new(1.5 * unit(), 1.5 * unit(), 1.5 * unit() + burr.length_mm / 2.0);
            let step = DVec3::new(unit(), unit(), unit()).normalize_or_zero() * 0.05;
            burr.sdf_row(origin.as_vec3(), step.as_vec3(), &mut out);
            for (i, got) in out.iter().enumerate() {
                let exact = burr.sdf(origin + step * i as f64);
                assert!((f64::from(*got) - exact).abs() < 2e-5, "{:?} point {i}: row {got} vs {exact}", burr.shape);
            }
        }
    }
}

/// The distance kernels as dispatched (AVX2 where the CPU has it) give the baseline build's
/// values bit for bit, rows and lanes, through every head and near its surface (where the
/// arithmetic's last bits decide the sign): replays must not depend on the machine.
#[test]
fn the_avx2_kernels_give_the_baseline_values_bit_for_bit() {
    use super::profile::{Lanes, LANES};
    let mut next = crate::unit_random(0x2545_f491_4f6c_dd1d);
    let mut unit = || next() * 2.0 - 1.0;
    let (mut row, mut baseline) = (vec![0f32; 77], vec![0f32; 77]);
    let (mut lane_out, mut lane_base) = ([0f32; LANES], [0f32; LANES]);
    for burr in every_burr().into_iter().chain(["flame_016", "pear_010", "inverted_cone_010", "taper_flat_012"].map(|s| Burr::parse(s).unwrap())) {
        let profile = burr.head_profile();
        let radius = burr.bounding_radius();
        for _ in 0..300 {
            let origin = DVec3::new(radius * unit(), radius * unit(), radius * unit() + burr.length_mm / 2.0).as_vec3().to_array();
            let step = (DVec3::new(unit(), unit(), unit()).normalize_or_zero() * 0.05).as_vec3().to_array();
            let first = (8.0 * (unit() + 1.0)) as usize;
            profile.sdf_row_from(origin, step, first, &mut row);
            profile.sdf_row_from_baseline(origin, step, first, &mut baseline);
            assert_eq!(row.iter().map(|v| v.to_bits()).collect::<Vec<_>>(), baseline.iter().map(|v| v.to_bits()).collect::<Vec<_>>(), "{}: a row", burr.spec());
            let mut lanes = Lanes::default();
            for l in 0..LANES {
                (lanes.x[l], lanes.y[l], lanes.z[l], lanes.t[l]) = (origin[0] + 0.05 * unit() as f32, origin[1], origin[2] + 0.05 * l as f32, first as f32);
            }
            for n in [LANES, 11, 7, 3] {
                profile.sdf_lanes(&lanes, n, step, &mut lane_out);
                profile.sdf_lanes_baseline(&lanes, n, step, &mut lane_base);
                assert!(lane_out[..n].iter().zip(&lane_base[..n]).all(|(a, b)| a.to_bits() == b.to_bits()), "{}: {n} lanes", burr.spec());
            }
        }
    }
}

/// Every point of the inner capsule lies at least the margin inside the head (sampled densely,
/// caps included), and the capsule is not a sliver.
#[test]
fn the_inner_capsule_lies_deep_inside_every_head() {
    let margin = 0.155;
    for burr in every_burr() {
        let Some((za, zb, r)) = burr.inner_capsule(margin) else {
            assert!(burr.shape == Shape::Needle || burr.shape == Shape::Wheel, "{:?}: no inner capsule", burr.shape);
            continue;
        };
        assert!(r > 0.0 && zb >= za, "{:?}: {za} {zb} {r}", burr.shape);
        let mut worst = f64::NEG_INFINITY;
        for i in 0..=60 {
            let z = za - r + (zb - za + 2.0 * r) * i as f64 / 60.0;
            for j in 0..=20 {
                for k in 0..8 {
                    let rho = r * j as f64 / 20.0;
                    let angle = k as f64 * std::f64::consts::TAU / 8.0;
                    let p = DVec3::new(rho * angle.cos(), rho * angle.sin(), z);
                    let axis = DVec3::new(0.0, 0.0, z.clamp(za, zb));
                    if (p - axis).length() <= r {
                        worst = worst.max(burr.sdf(p));
                    }
                }
            }
        }
        assert!(worst <= -margin + 1e-9, "{:?}: a point of the capsule at depth {}", burr.shape, -worst);
    }
}

/// The slabs run from the head's lowest point to its highest, in order, and every point of the
/// profile (sampled independently of the bound's code) lies within its slab's radius; the
/// bound is no looser than the head's widest radius, and tight where the radius is known.
#[test]
fn the_axis_slabs_hold_every_head() {
    for burr in every_burr().into_iter().chain(["flame_016", "pear_010", "inverted_cone_010", "taper_round_014"].map(|s| Burr::parse(s).unwrap())) {
        let slabs = burr.axis_slabs();
        if burr.ball_radius().is_some() {
            assert!(slabs.is_empty());
            continue;
        }
        let profile = burr.head_profile();
        assert_eq!((slabs[0].0, slabs[slabs.len() - 1].1), (profile.z_min, profile.z_max), "{:?}", burr.shape);
        for w in slabs.windows(2) {
            assert!(w[0].1 == w[1].0 && w[0].0 < w[0].1, "{:?}: slabs {w:?}", burr.shape);
        }
        for p in polygon(&profile) {
            let widest = slabs.iter().filter(|s| s.0 <= p.y && p.y <= s.1).map(|s| s.2).fold(f64::NEG_INFINITY, f64::max);
            assert!(p.x <= widest + 1e-12, "{:?}: profile point {p} beyond its slabs ({widest})", burr.shape);
        }
        for s in slabs {
            assert!(s.2 <= profile.max_radius + 1e-12, "{:?}: slab {s:?}", burr.shape);
        }
    }
    // A flat cylinder is one slab of its radius; a flat taper's slabs widen toward the top
    // (its tip is the narrow end) to within the radius it has there.
    let cylinder = Burr::parse("cylinder_flat_012").unwrap();
    assert_eq!(cylinder.axis_slabs(), &[(0.0, 4.0, 0.6)]);
    let taper = Burr::parse("taper_flat_012").unwrap();
    let radius_at = |z: f64| 0.6 - (6.0 - z) * 2f64.to_radians().tan();
    for s in taper.axis_slabs() {
        assert!((s.2 - radius_at(s.1)).abs() < 1e-12, "taper slab {s:?}");
    }
}

/// The frustums share the slabs' heights, and every point of the profile (sampled independently
/// of the bound's code) lies within the radius that runs linearly across its frustum, on average
/// no wider than its slab's cylinder; and they are tight where the radius is known.
#[test]
fn the_axis_frustums_hold_every_head() {
    for burr in every_burr().into_iter().chain(["flame_016", "pear_010", "inverted_cone_010", "taper_round_014"].map(|s| Burr::parse(s).unwrap())) {
        let (slabs, frustums) = (burr.axis_slabs(), burr.axis_frustums());
        if burr.ball_radius().is_some() {
            assert!(frustums.is_empty());
            continue;
        }
        assert_eq!(slabs.len(), frustums.len(), "{:?}", burr.shape);
        for (s, f) in slabs.iter().zip(frustums) {
            assert_eq!((s.0, s.1), (f.0, f.1), "{:?}", burr.shape);
            assert!(f.2 >= 0.0 && f.3 >= 0.0 && f.2 + f.3 <= 2.0 * s.2 + 1e-12, "{:?}: frustum {f:?} looser than slab {s:?}", burr.shape);
        }
        for p in polygon(&burr.head_profile()) {
            let widest = frustums
                .iter()
                .filter(|f| f.0 <= p.y && p.y <= f.1)
                .map(|f| f.2 + (f.3 - f.2) * (p.y - f.0) / (f.1 - f.0))
                .fold(f64::NEG_INFINITY, f64::max);
            assert!(p.x <= widest + 1e-12, "{:?}: profile point {p} beyond its frustums ({widest})", burr.shape);
        }
    }
    // A flat taper's frustums follow its side: at each end within a hair of its radius there.
    let taper = Burr::parse("taper_flat_012").unwrap();
    let radius_at = |z: f64| 0.6 - (6.0 - z) * 2f64.to_radians().tan();
    for f in taper.axis_frustums() {
        assert!((f.2 - radius_at(f.0)).abs() < 1e-3 && (f.3 - radius_at(f.1)).abs() < 1e-3, "taper frustum {f:?}");
    }
    assert_eq!(Burr::parse("cylinder_flat_012").unwrap().axis_frustums(), &[(0.0, 4.0, 0.6, 0.6)]);
}

/// A row's distances do not depend on where the row is cut into batches or runs: every prefix
/// of a row, and every run from any point of it, gives bit for bit the whole row's values.
#[test]
fn a_row_prefix_gives_the_rows_values_bit_for_bit() {
    let mut out = vec![0f32; 53];
    let mut prefix = vec![0f32; 53];
    for burr in every_burr() {
        let origin = DVec3::new(-1.1, 0.23, burr.length_mm * 0.4).as_vec3();
        let step = DVec3::new(0.05, 0.004, -0.002).as_vec3();
        burr.sdf_row(origin, step, &mut out);
        for len in 0..out.len() {
            burr.sdf_row(origin, step, &mut prefix[..len]);
            for i in 0..len {
                assert_eq!(prefix[i].to_bits(), out[i].to_bits(), "{:?}: point {i} of a row of {len}", burr.shape);
            }
        }
        // And a run starting anywhere along the row.
        for first in 0..out.len() {
            let run = &mut prefix[..(out.len() - first).min(19)];
            burr.sdf_row_from(origin, step, first, run);
            for (i, v) in run.iter().enumerate() {
                assert_eq!(v.to_bits(), out[first + i].to_bits(), "{:?}: point {} in a run from {first}", burr.shape, first + i);
            }
        }
    }
}

/// Lanes drawn from several rows (any origins, any points along them, any count up to a batch)
/// give bit for bit each row's own values: the sweep packs a tick's short runs into them.
#[test]
fn lanes_from_several_rows_give_each_rows_values_bit_for_bit() {
    let mut unit = crate::unit_random(0x9e37_79b9_7f4a_7c15u64);
    let step = DVec3::new(0.05, 0.004, -0.002).as_vec3();
    let rows = 5;
    let mut values = vec![vec![0f32; 40]; rows];
    for burr in every_burr().into_iter().chain([Burr::parse("round:1").unwrap()]) {
        let origins: Vec<glam::Vec3> = (0..rows)
            .map(|_| DVec3::new(-1.0 + 0.2 * unit(), unit() - 0.5, burr.length_mm * unit()).as_vec3())
            .collect();
        for (o, v) in origins.iter().zip(&mut values) {
            burr.sdf_row(*o, step, v);
        }
        let mut compared = 0;
        for _ in 0..200 {
            let n = 1 + (unit() * profile::LANES as f64) as usize % profile::LANES;
            let mut lanes = profile::Lanes::default();
            let mut at = [(0usize, 0usize); profile::LANES];
            for l in 0..n {
                let (r, i) = ((unit() * rows as f64) as usize % rows, (unit() * 40.0) as usize % 40);
                let o = origins[r];
                (lanes.x[l], lanes.y[l], lanes.z[l], lanes.t[l]) = (o.x, o.y, o.z, i as f32);
                at[l] = (r, i);
            }
            let mut out = [f32::NAN; profile::LANES];
            burr.sdf_lanes(&lanes, n, step, &mut out);
            for l in 0..n {
                let (r, i) = at[l];
                assert_eq!(out[l].to_bits(), values[r][i].to_bits(), "{:?}: lane {l} of {n}, row {r} point {i}", burr.shape);
                compared += 1;
            }
            assert!(out[n..].iter().all(|v| v.is_nan()), "{:?}: wrote past {n} lanes", burr.shape);
        }
        assert!(compared > 1000);
    }
}
