//! Continuous collision detection of the elementary pairs: a vertex against a
//! triangle, an edge against an edge, every point moving linearly over the
//! step (PAPER section 3).
//!
//! A vertex can only pass through a triangle, or an edge through an edge, at a
//! time when the four points are coplanar: a root of the cubic
//! `f(t) = (B(t) × C(t)) · P(t)` (vertex-triangle: `B = b − a`, `C = c − a`,
//! `P = p − a`; edge-edge: `(b − a) × (d − c) · (c − a)`). The roots in
//! `[0, 1]` are found robustly: the interval is split at the cubic's critical
//! points into monotone pieces, each sign change is bisected to full
//! precision, and values that merely touch zero (within round-off) at the
//! pieces' ends count as candidates too, so no root at `t = 0`, `t = 1` or at a
//! double root is lost. Every candidate is then verified with the true
//! distance at that time.
//!
//! On top of the crossings, the paper's **critical contacts** are reported:
//! features closer than the thickness at the start or the end of the step
//! (1 and 2). For a sliver triangle (two nearly parallel edges, PAPER 3) the
//! paper runs only those end tests, because the cubic is ill-conditioned
//! there. Here every candidate root is verified with the true distance, so an
//! ill-conditioned cubic cannot invent a contact, and the interval test runs
//! on slivers too: a triangle that is a sliver at one end of the step has area
//! in between, and a vertex can pass through it there (a property test found
//! exactly that miss). What the paper's rule protects, the response, is kept
//! stable by never taking a sliver's noisy face direction as the contact
//! normal. When the motion keeps the four points coplanar throughout (the
//! cubic vanishes), the distance is sampled over the step instead.

use nalgebra::Vector3;

use super::geometry::{
    box_gap_squared, closest_between_segments, closest_on_triangle, point_triangle_distance, segment_distance,
};

/// Bisection steps on a sign change: 2⁻⁶⁰ of the step.
const BISECTIONS: usize = 60;
/// A triangle is a sliver when `|AB × AC| ≤ SLIVER |AB| |AC|` (angle ~0.6°).
const SLIVER: f64 = 1e-2;
/// Samples over the step when the motion is coplanar throughout.
const COPLANAR_SAMPLES: usize = 16;

/// Where a point is at the start and at the end of the step, m.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Path {
    /// Position at the start of the step.
    pub start: Vector3<f64>,
    /// Position at the end of the step.
    pub end: Vector3<f64>,
}

impl Path {
    /// Position at fraction `t` of the step.
    pub fn at(&self, t: f64) -> Vector3<f64> {
        self.start + (self.end - self.start) * t
    }
}

/// How far, at most, a point of one feature moves relative to a point of
/// the other over the step, m: the largest relative displacement of a corner
/// of `first` and a corner of `second`. The relative motion of any two points
/// of the features is a convex combination of those corners' relative
/// motions, so features that move together (a skirt carried by the body, a
/// cloth falling as one) have a small reach however fast they move. Rounded
/// up by a relative 1e-9, so round-off never culls a pair that could meet.
/// One square root, of the largest squared displacement (the root is
/// monotone and correctly rounded, so this is the largest of the lengths).
pub fn relative_reach(first: &[Path], second: &[Path]) -> f64 {
    let motion = |p: &Path| p.end - p.start;
    let squared = |a: &Path, b: &Path| (motion(a) - motion(b)).norm_squared();
    let largest = first.iter().flat_map(|a| second.iter().map(move |b| squared(a, b))).fold(0.0, f64::max);
    largest.sqrt() * (1.0 + 1e-9)
}

/// A contact between two features.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Fraction of the step at which the features meet, in `[0, 1]`.
    pub time: f64,
    /// Contact weights of the four points: the relative position of the two
    /// features' closest points is `Σ wᵢ xᵢ`. Vertex-triangle: `[1, −wa, −wb, −wc]`;
    /// edge-edge: `[1 − s, s, −(1 − t), −t]`.
    pub weights: [f64; 4],
    /// Unit normal, pointing from the second feature (triangle, second edge)
    /// to the first (vertex, first edge) as they were at the start of the step.
    pub normal: Vector3<f64>,
    /// Distance between the features at the start of the step, m.
    pub start_distance: f64,
    /// True when the features cross during the step (a root of the
    /// coplanarity cubic), false for a proximity at the start or end.
    pub crossing: bool,
}

/// Vertex `p` against triangle `(a, b, c)`: the first crossing within the
/// step, else the end or start proximity closer than `thickness`.
pub fn vertex_triangle(p: &Path, a: &Path, b: &Path, c: &Path, thickness: f64) -> Option<Hit> {
    vertex_triangle_within(p, a, b, c, thickness, f64::INFINITY)
}

/// [`vertex_triangle`] for features that move relative to each other by at
/// most `reach` m over the step: farther apart than `thickness + reach` at
/// the start, they cannot meet, and nothing more is computed.
pub fn vertex_triangle_within(p: &Path, a: &Path, b: &Path, c: &Path, thickness: f64, reach: f64) -> Option<Hit> {
    let at = |t: f64| (p.at(t), a.at(t), b.at(t), c.at(t));
    let (p0, a0, b0, c0) = at(0.0);
    if apart(box_gap_squared(&[p0], &[a0, b0, c0]), thickness + reach) {
        return None;
    }
    let start_gap = closest_direction_vt(&p0, &a0, &b0, &c0);
    let start_distance = start_gap.norm();
    if start_distance > thickness + reach {
        return None;
    }
    // The triangle's normal at the contact, on the side the vertex came from;
    // a vertex that started in the triangle's plane is pushed back the way it
    // came within the plane.
    let face0 = (b0 - a0).cross(&(c0 - a0));
    let side0 = face0.dot(&(p0 - a0));
    let start_normal = |t: f64| {
        let (pt, at_, bt, ct) = at(t);
        let face = (bt - at_).cross(&(ct - at_));
        let trusted = side0 != 0.0 && !is_sliver(&at_, &bt, &ct);
        let oriented = if trusted { orient(face, face0 * side0.signum()) } else { None };
        oriented
            .or_else(|| start_gap.try_normalize(0.0))
            .or_else(|| (pt - point_on_triangle(&pt, &at_, &bt, &ct)).try_normalize(0.0))
            .or_else(|| face.try_normalize(0.0))
    };
    let hit = |t: f64| {
        let (pt, at_, bt, ct) = at(t);
        let [wa, wb, wc] = closest_on_triangle(&pt, &at_, &bt, &ct);
        start_normal(t).map(|normal| Hit {
            time: t,
            weights: [1.0, -wa, -wb, -wc],
            normal,
            start_distance,
            crossing: false,
        })
    };
    let cubic = Cubic::vertex_triangle(p, a, b, c);
    let distance = |t: f64| {
        let (pt, at_, bt, ct) = at(t);
        point_triangle_distance(&pt, &at_, &bt, &ct)
    };
    if let Some(t) = cubic.first_root_where(|t| distance(t) <= thickness, distance, thickness) {
        return hit(t).map(|h| Hit { crossing: true, ..h });
    }
    let (p1, a1, b1, c1) = at(1.0);
    if point_triangle_distance(&p1, &a1, &b1, &c1) < thickness {
        return hit(1.0);
    }
    (start_distance < thickness).then(|| hit(0.0)).flatten()
}

/// Edge `a b` against edge `c d`: the first crossing within the step, else the
/// end or start proximity closer than `thickness`.
pub fn edge_edge(a: &Path, b: &Path, c: &Path, d: &Path, thickness: f64) -> Option<Hit> {
    edge_edge_within(a, b, c, d, thickness, f64::INFINITY)
}

/// [`edge_edge`] for edges that move relative to each other by at most
/// `reach` m over the step (see [`vertex_triangle_within`]).
pub fn edge_edge_within(a: &Path, b: &Path, c: &Path, d: &Path, thickness: f64, reach: f64) -> Option<Hit> {
    let at = |t: f64| (a.at(t), b.at(t), c.at(t), d.at(t));
    let (a0, b0, c0, d0) = at(0.0);
    if apart(box_gap_squared(&[a0, b0], &[c0, d0]), thickness + reach) {
        return None;
    }
    let (p0, q0) = closest_points_ee(&a0, &b0, &c0, &d0);
    let start_distance = (p0 - q0).norm();
    if start_distance > thickness + reach {
        return None;
    }
    let side0 = (p0 - q0).try_normalize(0.0);
    let hit = |t: f64| {
        let (at_, bt, ct, dt) = at(t);
        let (s, u) = closest_between_segments(&at_, &bt, &ct, &dt);
        let across = (bt - at_).cross(&(dt - ct));
        let towards = side0.or_else(|| {
            let gap = (at_ + (bt - at_) * s) - (ct + (dt - ct) * u);
            gap.try_normalize(0.0)
        });
        let normal = match towards {
            Some(side) => orient(across, side).unwrap_or(side),
            None => across.try_normalize(0.0)?,
        };
        Some(Hit { time: t, weights: [1.0 - s, s, -(1.0 - u), -u], normal, start_distance, crossing: false })
    };
    let cubic = Cubic::edge_edge(a, b, c, d);
    let distance = |t: f64| {
        let (at_, bt, ct, dt) = at(t);
        segment_distance(&at_, &bt, &ct, &dt)
    };
    if let Some(t) = cubic.first_root_where(|t| distance(t) <= thickness, distance, thickness) {
        return hit(t).map(|h| Hit { crossing: true, ..h });
    }
    if distance(1.0) < thickness {
        return hit(1.0);
    }
    (start_distance < thickness).then(|| hit(0.0)).flatten()
}

/// True when two edges of triangle `(a, b, c)` are nearly parallel (angle
/// below ~0.6°) or one has no length: its face direction is round-off.
fn is_sliver(a: &Vector3<f64>, b: &Vector3<f64>, c: &Vector3<f64>) -> bool {
    let (u, v) = (b - a, c - a);
    u.cross(&v).norm() <= SLIVER * u.norm() * v.norm()
}

/// `v` as a unit vector on the side of `reference`, if both are non-zero.
fn orient(v: Vector3<f64>, reference: Vector3<f64>) -> Option<Vector3<f64>> {
    let n = v.try_normalize(0.0)?;
    let dot = n.dot(&reference);
    if dot == 0.0 { None } else { Some(n * dot.signum()) }
}

fn point_on_triangle(p: &Vector3<f64>, a: &Vector3<f64>, b: &Vector3<f64>, c: &Vector3<f64>) -> Vector3<f64> {
    let [wa, wb, wc] = closest_on_triangle(p, a, b, c);
    a * wa + b * wb + c * wc
}

/// Whether features whose start boxes are `gap_squared` m² apart are
/// certainly farther apart than `distance`: by a relative 1e-6, far beyond
/// round-off, so the exact start distance would cull them too.
fn apart(gap_squared: f64, distance: f64) -> bool {
    gap_squared > (distance * (1.0 + 1e-6)).powi(2)
}

fn closest_direction_vt(p: &Vector3<f64>, a: &Vector3<f64>, b: &Vector3<f64>, c: &Vector3<f64>) -> Vector3<f64> {
    p - point_on_triangle(p, a, b, c)
}

fn closest_points_ee(
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    c: &Vector3<f64>,
    d: &Vector3<f64>,
) -> (Vector3<f64>, Vector3<f64>) {
    let (s, t) = closest_between_segments(a, b, c, d);
    (a + (b - a) * s, c + (d - c) * t)
}

/// A cubic `c₀ + c₁ t + c₂ t² + c₃ t³` on `[0, 1]`.
#[derive(Clone, Copy, Debug)]
struct Cubic {
    c: [f64; 4],
    /// Magnitude below which a value is round-off.
    noise: f64,
}

impl Cubic {
    /// `(B(t) × C(t)) · P(t)` for linearly moving `B`, `C`, `P`.
    fn triple(b: [Vector3<f64>; 2], c: [Vector3<f64>; 2], p: [Vector3<f64>; 2]) -> Self {
        let [(b0, db), (c0, dc), (p0, dp)] = [b, c, p].map(|[x0, x1]| (x0, x1 - x0));
        let n0 = b0.cross(&c0);
        let n1 = b0.cross(&dc) + db.cross(&c0);
        let n2 = db.cross(&dc);
        let c = [n0.dot(&p0), n0.dot(&dp) + n1.dot(&p0), n1.dot(&dp) + n2.dot(&p0), n2.dot(&dp)];
        // Each term is a product of three lengths; its round-off is about ε times
        // the largest such product.
        let scale = [b0.norm() + db.norm(), c0.norm() + dc.norm(), p0.norm() + dp.norm()];
        let noise = 64.0 * f64::EPSILON * scale[0] * scale[1] * scale[2];
        Cubic { c, noise }
    }

    fn vertex_triangle(p: &Path, a: &Path, b: &Path, c: &Path) -> Self {
        let rel = |x: &Path| [x.start - a.start, x.end - a.end];
        Cubic::triple(rel(b), rel(c), rel(p))
    }

    fn edge_edge(a: &Path, b: &Path, c: &Path, d: &Path) -> Self {
        let diff = |x: &Path, y: &Path| [x.start - y.start, x.end - y.end];
        Cubic::triple(diff(b, a), diff(d, c), diff(c, a))
    }

    fn value(&self, t: f64) -> f64 {
        ((self.c[3] * t + self.c[2]) * t + self.c[1]) * t + self.c[0]
    }

    /// True when every coefficient is round-off: the motion is coplanar.
    fn vanishes(&self) -> bool {
        self.c.iter().all(|c| c.abs() <= self.noise)
    }

    /// Split points of `[0, 1]` into pieces where the cubic is monotone: 0,
    /// the critical points inside, 1 (the first `count` entries, in order).
    fn pieces(&self) -> ([f64; 4], usize) {
        let (a, b, c) = (3.0 * self.c[3], 2.0 * self.c[2], self.c[1]);
        let mut inner = [f64::NAN; 2];
        if a.abs() > f64::EPSILON * (b.abs() + c.abs()) {
            let disc = b * b - 4.0 * a * c;
            if disc >= 0.0 {
                let q = -0.5 * (b + b.signum() * disc.sqrt());
                inner = [if q != 0.0 { c / q } else { f64::NAN }, q / a];
            }
        } else if b != 0.0 {
            inner[0] = -c / b;
        }
        if inner[1] < inner[0] {
            inner.swap(0, 1);
        }
        let mut points = [0.0; 4];
        let mut count = 1;
        for t in inner {
            if t > 0.0 && t < 1.0 {
                points[count] = t;
                count += 1;
            }
        }
        points[count] = 1.0;
        (points, count + 1)
    }

    /// The earliest root `t` in `[0, 1]` for which `accept(t)`; when the cubic
    /// vanishes, the earliest sampled time at which `distance(t) ≤ limit`.
    fn first_root_where(&self, accept: impl Fn(f64) -> bool, distance: impl Fn(f64) -> f64, limit: f64) -> Option<f64> {
        if self.vanishes() {
            return (0..=COPLANAR_SAMPLES).map(|k| k as f64 / COPLANAR_SAMPLES as f64).find(|&t| distance(t) <= limit);
        }
        let (points, count) = self.pieces();
        for w in points[..count].windows(2) {
            let (lo, hi) = (w[0], w[1]);
            let (f_lo, f_hi) = (self.value(lo), self.value(hi));
            if f_lo.abs() <= self.noise && accept(lo) {
                return Some(lo);
            }
            if f_lo.signum() != f_hi.signum() && f_hi.abs() > self.noise {
                let t = self.bisect(lo, hi, f_lo);
                if accept(t) {
                    return Some(t);
                }
            }
            if f_hi.abs() <= self.noise && accept(hi) {
                return Some(hi);
            }
        }
        None
    }

    /// A root in `[lo, hi]` where the cubic changes sign, `f(lo) = f_lo`.
    fn bisect(&self, mut lo: f64, mut hi: f64, f_lo: f64) -> f64 {
        for _ in 0..BISECTIONS {
            let mid = 0.5 * (lo + hi);
            if self.value(mid).signum() == f_lo.signum() {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn still(p: [f64; 3]) -> Path {
        let v = Vector3::from(p);
        Path { start: v, end: v }
    }

    fn moving(from: [f64; 3], to: [f64; 3]) -> Path {
        Path { start: Vector3::from(from), end: Vector3::from(to) }
    }

    const THICK: f64 = 1e-3;

    /// The unit triangle in the XZ plane.
    fn floor() -> [Path; 3] {
        [still([0.0, 0.0, 0.0]), still([1.0, 0.0, 0.0]), still([0.0, 0.0, 1.0])]
    }

    /// Brute force: between two of `samples` times, does the signed volume
    /// `f(t).0` of the four points change sign at a root (refined by
    /// bisection) where their distance `f(t).1` is zero? The lines of two
    /// edges (or a vertex and a triangle's plane) pass each other often; the
    /// features cross only when they touch then.
    fn sampled_crossing(samples: usize, f: impl Fn(f64) -> (f64, f64)) -> bool {
        let mut previous = f(0.0);
        for k in 1..=samples {
            let t = k as f64 / samples as f64;
            let now = f(t);
            if previous.0.signum() != now.0.signum() {
                let (mut lo, mut hi, sign) = ((k - 1) as f64 / samples as f64, t, previous.0.signum());
                for _ in 0..60 {
                    let mid = 0.5 * (lo + hi);
                    if f(mid).0.signum() == sign { lo = mid } else { hi = mid }
                }
                if f(0.5 * (lo + hi)).1 < 1e-9 {
                    return true;
                }
            }
            previous = now;
        }
        false
    }

    /// Does the vertex cross the triangle, by sampling?
    fn sampled_vt_crossing(p: &Path, a: &Path, b: &Path, c: &Path, samples: usize) -> bool {
        sampled_crossing(samples, |t| {
            let (pt, at, bt, ct) = (p.at(t), a.at(t), b.at(t), c.at(t));
            ((bt - at).cross(&(ct - at)).dot(&(pt - at)), point_triangle_distance(&pt, &at, &bt, &ct))
        })
    }

    /// Do the edges cross, by sampling?
    fn sampled_ee_crossing(a: &Path, b: &Path, c: &Path, d: &Path, samples: usize) -> bool {
        sampled_crossing(samples, |t| {
            let (at, bt, ct, dt) = (a.at(t), b.at(t), c.at(t), d.at(t));
            ((bt - at).cross(&(dt - ct)).dot(&(ct - at)), segment_distance(&at, &bt, &ct, &dt))
        })
    }

    #[test]
    fn vertex_falling_through_a_triangle_is_caught_at_the_crossing_time() {
        let [a, b, c] = floor();
        let hit = vertex_triangle(&moving([0.2, 0.3, 0.2], [0.2, -0.1, 0.2]), &a, &b, &c, THICK).unwrap();
        assert!((hit.time - 0.75).abs() < 1e-9 && hit.crossing, "{hit:?}");
        assert_eq!(hit.normal, Vector3::y(), "points to where the vertex came from");
        let [_, wa, wb, wc] = hit.weights;
        assert!((wa + 0.6).abs() < 1e-9 && (wb + 0.2).abs() < 1e-9 && (wc + 0.2).abs() < 1e-9);
    }

    #[test]
    fn contact_exactly_at_the_start_and_at_the_end_is_found() {
        let [a, b, c] = floor();
        let end = vertex_triangle(&moving([0.2, 0.3, 0.2], [0.2, 0.0, 0.2]), &a, &b, &c, THICK).unwrap();
        assert_eq!(end.time, 1.0);
        let near = vertex_triangle(&moving([0.2, 0.3, 0.2], [0.2, 0.0005, 0.2]), &a, &b, &c, THICK).unwrap();
        assert!(!near.crossing && near.time == 1.0, "ending within the thickness is a proximity");
        let start = vertex_triangle(&moving([0.2, 0.0, 0.2], [0.2, 0.5, 0.2]), &a, &b, &c, THICK).unwrap();
        assert_eq!(start.time, 0.0);
    }

    #[test]
    fn grazing_vertex_skimming_the_surface_is_a_contact_and_a_clear_miss_is_not() {
        let [a, b, c] = floor();
        let graze = moving([0.1, 0.0005, 0.1], [0.6, 0.0005, 0.3]);
        assert!(vertex_triangle(&graze, &a, &b, &c, THICK).is_some());
        let clear = moving([0.1, 0.01, 0.1], [0.6, 0.01, 0.3]);
        assert!(vertex_triangle(&clear, &a, &b, &c, THICK).is_none());
    }

    #[test]
    fn vertex_passing_through_the_triangles_edge_and_its_vertex_is_caught() {
        let [a, b, c] = floor();
        let through_edge = moving([0.5, 0.2, 0.0], [0.5, -0.2, 0.0]);
        assert!(vertex_triangle(&through_edge, &a, &b, &c, THICK).is_some());
        let through_corner = moving([1.0, 0.2, 0.0], [1.0, -0.2, 0.0]);
        assert!(vertex_triangle(&through_corner, &a, &b, &c, THICK).is_some());
        let beside = moving([1.1, 0.2, 0.0], [1.1, -0.2, 0.0]);
        assert!(vertex_triangle(&beside, &a, &b, &c, THICK).is_none());
    }

    #[test]
    fn coplanar_motion_is_sampled_and_caught() {
        let [a, b, c] = floor();
        let sliding_in = moving([-0.5, 0.0, 0.2], [0.3, 0.0, 0.2]);
        assert!(vertex_triangle(&sliding_in, &a, &b, &c, THICK).is_some());
        let sliding_past = moving([-0.5, 0.0, -0.2], [0.3, 0.0, -0.2]);
        assert!(vertex_triangle(&sliding_past, &a, &b, &c, THICK).is_none());
    }

    #[test]
    fn vertex_through_a_sliver_is_caught_with_the_start_gap_as_normal() {
        let [a, b, c] = [still([0.0, 0.0, 0.0]), still([1.0, 0.0, 0.0]), still([0.5, 0.0, 0.001])];
        let passing = moving([0.5, 0.2, 0.0005], [0.5, -0.2, 0.0005]);
        let hit = vertex_triangle(&passing, &a, &b, &c, THICK).unwrap();
        assert!(hit.crossing && (hit.time - 0.5).abs() < 1e-9, "{hit:?}");
        assert!((hit.normal - Vector3::y()).norm() < 1e-12, "the gap at the start, not the sliver's face");
        let landing = moving([0.5, 0.2, 0.0005], [0.5, 0.0002, 0.0005]);
        assert!(vertex_triangle(&landing, &a, &b, &c, THICK).is_some(), "end proximity still counts");
    }

    /// Found by the property test below: the triangle starts degenerate (two
    /// corners together) and ends a sliver, yet has area mid-step, where the
    /// vertex passes through it at t ≈ 0.5285.
    #[test]
    fn vertex_through_a_triangle_that_is_a_sliver_at_both_ends_is_caught() {
        let p = moving([0.0, 0.491_904_928_779_108_24, 0.0], [0.0, 0.0, 0.0]);
        let a = moving([0.0; 3], [-0.983_761_512_495_133_5, 0.145_564_941_960_405_54, 0.393_234_740_718_395_9]);
        let b = moving([0.0; 3], [0.955_813_717_331_938_4, 0.730_580_703_784_353_5, -0.846_815_934_397_898_6]);
        let c = moving(
            [0.0, 0.0, 0.646_743_338_593_620_5],
            [0.407_507_210_938_518_9, 0.556_957_367_530_952_3, -0.508_904_803_253_758_1],
        );
        let hit = vertex_triangle(&p, &a, &b, &c, THICK).unwrap();
        assert!(hit.crossing && (hit.time - 0.528_504).abs() < 1e-5, "{hit:?}");
    }

    #[test]
    fn crossing_edges_are_caught_and_parallel_edges_only_by_proximity() {
        let (a, b) = (still([-1.0, 0.0, 0.0]), still([1.0, 0.0, 0.0]));
        let (c, d) = (moving([0.0, 0.5, -1.0], [0.0, -0.5, -1.0]), moving([0.0, 0.5, 1.0], [0.0, -0.5, 1.0]));
        let hit = edge_edge(&c, &d, &a, &b, THICK).unwrap();
        assert!((hit.time - 0.5).abs() < 1e-9);
        assert!((hit.normal - Vector3::y()).norm() < 1e-12, "from edge ab towards where cd came from");
        let (e, f) = (moving([-1.0, 0.5, 0.0], [-1.0, 0.0005, 0.0]), moving([1.0, 0.5, 0.0], [1.0, 0.0005, 0.0]));
        assert!(edge_edge(&e, &f, &a, &b, THICK).is_some(), "parallel, ends within the thickness");
        let (g, h) = (moving([-1.0, 0.5, 0.0], [-1.0, 0.2, 0.0]), moving([1.0, 0.5, 0.0], [1.0, 0.2, 0.0]));
        assert!(edge_edge(&g, &h, &a, &b, THICK).is_none());
    }

    /// Mostly uniform coordinates, some on a coarse lattice so that shared
    /// corners, still points, degenerate and coplanar configurations occur.
    fn coordinate() -> impl Strategy<Value = [f64; 3]> {
        let lattice = (-2..=2i32).prop_map(|k| f64::from(k) * 0.5);
        let axis = prop_oneof![3 => -1.0..1.0f64, 1 => lattice];
        [axis.clone(), axis.clone(), axis]
    }

    fn path() -> impl Strategy<Value = Path> {
        (coordinate(), coordinate()).prop_map(|(a, b)| moving(a, b))
    }

    /// Features moving together have no reach; one moving alone, its own
    /// motion; opposite motions add.
    #[test]
    fn relative_reach_follows_the_relative_motion() {
        let carried = |p: [f64; 3]| moving(p, [p[0] + 0.3, p[1], p[2] - 0.4]);
        let triangle = [carried([0.0, 0.0, 0.0]), carried([1.0, 0.0, 0.0]), carried([0.0, 0.0, 1.0])];
        assert!(relative_reach(&[carried([0.2, 0.1, 0.2])], &triangle) < 1e-12);
        assert!((relative_reach(&[still([0.2, 0.1, 0.2])], &triangle) - 0.5).abs() < 1e-9);
        let edge = [moving([0.0; 3], [0.0, 1.0, 0.0]), still([1.0, 0.0, 0.0])];
        let other = [moving([0.0; 3], [0.0, -1.0, 0.0]), still([0.0, 0.0, 1.0])];
        assert!((relative_reach(&edge, &other) - 2.0).abs() < 1e-8);
    }

    /// Fails unless `distance(t)`, sampled over the step, never falls below
    /// `distance(0) − reach`.
    fn stays_within_reach(distance: impl Fn(f64) -> f64, reach: f64) -> Result<(), TestCaseError> {
        let start = distance(0.0);
        for k in 0..=100 {
            let t = f64::from(k) / 100.0;
            let now = distance(t);
            prop_assert!(now >= start - reach - 1e-12, "t = {t}: {now} < {start} - {reach}");
        }
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(400))]

        /// The distance between a vertex and a triangle never falls below its
        /// start value minus their relative reach (sampled over the step), so
        /// culling by it loses no contact.
        #[test]
        fn vertex_triangle_distance_stays_within_the_relative_reach(p in path(), a in path(), b in path(), c in path()) {
            let distance = |t: f64| point_triangle_distance(&p.at(t), &a.at(t), &b.at(t), &c.at(t));
            stays_within_reach(distance, relative_reach(&[p], &[a, b, c]))?;
        }

        #[test]
        fn edge_edge_distance_stays_within_the_relative_reach(a in path(), b in path(), c in path(), d in path()) {
            let distance = |t: f64| segment_distance(&a.at(t), &b.at(t), &c.at(t), &d.at(t));
            stays_within_reach(distance, relative_reach(&[a, b], &[c, d]))?;
        }

        /// CCD never misses a crossing that a 10,000-sample brute force finds.
        #[test]
        fn vertex_triangle_never_misses_a_sampled_crossing(p in path(), a in path(), b in path(), c in path()) {
            if sampled_vt_crossing(&p, &a, &b, &c, 10_000) {
                prop_assert!(vertex_triangle(&p, &a, &b, &c, THICK).is_some());
            }
        }

        #[test]
        fn edge_edge_never_misses_a_sampled_crossing(a in path(), b in path(), c in path(), d in path()) {
            if sampled_ee_crossing(&a, &b, &c, &d, 10_000) {
                prop_assert!(edge_edge(&a, &b, &c, &d, THICK).is_some());
            }
        }
    }
}
