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
        Profile { pieces, max_radius, z_min, z_max }
    }

    /// Exact signed distance (negative inside) of the point at radius `rho` ≥ 0 and height `z`.
    pub fn sdf(&self, rho: f64, z: f64) -> f64 {
        let p = DVec2::new(rho, z);
        // The sign test looks from just off the axis, so chords lying on the axis stay outside it.
        let q = DVec2::new(rho.max(1e-9), z);
        let mut d = f64::INFINITY;
        let mut inside = false;
        for piece in &self.pieces {
            d = d.min(piece.distance(p));
            inside ^= crosses(piece.start(), piece.end(), q) ^ piece.in_segment(q);
        }
        // The axis closes the chain (from the last end back to the first start).
        if let (Some(first), Some(last)) = (self.pieces.first(), self.pieces.last()) {
            inside ^= crosses(last.end(), first.start(), q);
        }
        if inside { -d } else { d }
    }
}

/// Whether the ray from `p` toward +ρ crosses the chord from `a` to `b` (half-open in z).
fn crosses(a: DVec2, b: DVec2, p: DVec2) -> bool {
    if (a.y > p.y) == (b.y > p.y) {
        return false;
    }
    let x = a.x + (p.y - a.y) / (b.y - a.y) * (b.x - a.x);
    x > p.x
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
