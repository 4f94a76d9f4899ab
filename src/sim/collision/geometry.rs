//! Closest points between the elementary features of triangle meshes, in f64.

use nalgebra::Vector3;

/// The point of triangle `(a, b, c)` closest to `p`, as barycentric weights
/// `[wa, wb, wc]` (non-negative, summing to one). Ericson, *Real-Time Collision
/// Detection*, §5.1.5: Voronoi regions of vertices, then edges, then the face.
pub fn closest_on_triangle(p: &Vector3<f64>, a: &Vector3<f64>, b: &Vector3<f64>, c: &Vector3<f64>) -> [f64; 3] {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return [1.0, 0.0, 0.0];
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return [0.0, 1.0, 0.0];
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return [1.0 - v, v, 0.0];
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return [0.0, 0.0, 1.0];
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return [1.0 - w, 0.0, w];
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return [0.0, 1.0 - w, w];
    }
    let denominator = va + vb + vc;
    if denominator <= 0.0 {
        // Degenerate triangle: fall back to the closest of its edges.
        return closest_on_degenerate_triangle(p, a, b, c);
    }
    let (v, w) = (vb / denominator, vc / denominator);
    [1.0 - v - w, v, w]
}

fn closest_on_degenerate_triangle(p: &Vector3<f64>, a: &Vector3<f64>, b: &Vector3<f64>, c: &Vector3<f64>) -> [f64; 3] {
    let on = |x: &Vector3<f64>, y: &Vector3<f64>| {
        let d = y - x;
        let t = if d.norm_squared() > 0.0 { ((p - x).dot(&d) / d.norm_squared()).clamp(0.0, 1.0) } else { 0.0 };
        (t, (x + d * t - p).norm_squared())
    };
    let (tab, dab) = on(a, b);
    let (tbc, dbc) = on(b, c);
    let (tca, dca) = on(c, a);
    if dab <= dbc && dab <= dca {
        [1.0 - tab, tab, 0.0]
    } else if dbc <= dca {
        [0.0, 1.0 - tbc, tbc]
    } else {
        [tca, 0.0, 1.0 - tca]
    }
}

/// Parameters `(s, t)` in `[0, 1]²` of the closest points `p0 + s (p1 − p0)` and
/// `q0 + t (q1 − q0)` of two segments. Ericson §5.1.9, with parallel segments
/// resolved to the middle of their overlap so the contact is well placed.
pub fn closest_between_segments(
    p0: &Vector3<f64>,
    p1: &Vector3<f64>,
    q0: &Vector3<f64>,
    q1: &Vector3<f64>,
) -> (f64, f64) {
    let (d1, d2, r) = (p1 - p0, q1 - q0, p0 - q0);
    let (a, e, f) = (d1.norm_squared(), d2.norm_squared(), d2.dot(&r));
    if a == 0.0 && e == 0.0 {
        return (0.0, 0.0);
    }
    if a == 0.0 {
        return (0.0, (f / e).clamp(0.0, 1.0));
    }
    let c = d1.dot(&r);
    if e == 0.0 {
        return ((-c / a).clamp(0.0, 1.0), 0.0);
    }
    let b = d1.dot(&d2);
    let denominator = a * e - b * b;
    if denominator <= 1e-12 * a * e {
        // Parallel: the middle of the overlap of q's projection onto p.
        let lo = (-c / a).clamp(0.0, 1.0);
        let hi = ((b - c) / a).clamp(0.0, 1.0);
        let s = 0.5 * (lo.min(hi) + lo.max(hi));
        let t = ((b * s + f) / e).clamp(0.0, 1.0);
        return (s, t);
    }
    let mut s = ((b * f - c * e) / denominator).clamp(0.0, 1.0);
    let mut t = (b * s + f) / e;
    if t < 0.0 {
        t = 0.0;
        s = (-c / a).clamp(0.0, 1.0);
    } else if t > 1.0 {
        t = 1.0;
        s = ((b - c) / a).clamp(0.0, 1.0);
    }
    (s, t)
}

/// Distance from `p` to triangle `(a, b, c)`, m.
pub fn point_triangle_distance(p: &Vector3<f64>, a: &Vector3<f64>, b: &Vector3<f64>, c: &Vector3<f64>) -> f64 {
    let [wa, wb, wc] = closest_on_triangle(p, a, b, c);
    (p - (a * wa + b * wb + c * wc)).norm()
}

/// Distance between segments `p0 p1` and `q0 q1`, m.
pub fn segment_distance(p0: &Vector3<f64>, p1: &Vector3<f64>, q0: &Vector3<f64>, q1: &Vector3<f64>) -> f64 {
    let (s, t) = closest_between_segments(p0, p1, q0, q1);
    ((p0 + (p1 - p0) * s) - (q0 + (q1 - q0) * t)).norm()
}

/// Squared distance between the axis-aligned boxes of two point sets, m²:
/// at most the squared distance between any point of one's convex hull and
/// any point of the other's (on each axis the hulls are at least the boxes'
/// gap apart). A few comparisons, where the closest points take a
/// projection and divisions.
pub fn box_gap_squared(first: &[Vector3<f64>], second: &[Vector3<f64>]) -> f64 {
    let span = |points: &[Vector3<f64>], k: usize| {
        points.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(low, high), p| (low.min(p[k]), high.max(p[k])))
    };
    (0..3)
        .map(|k| {
            let ((low1, high1), (low2, high2)) = (span(first, k), span(second, k));
            let gap = (low2 - high1).max(low1 - high2).max(0.0);
            gap * gap
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn vec3() -> impl Strategy<Value = Vector3<f64>> {
        (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64).prop_map(|(x, y, z)| Vector3::new(x, y, z))
    }

    /// Brute force: the minimum over a fine grid of barycentric points.
    fn sampled_triangle_distance(p: &Vector3<f64>, a: &Vector3<f64>, b: &Vector3<f64>, c: &Vector3<f64>) -> f64 {
        let n = 200;
        let mut best = f64::INFINITY;
        for i in 0..=n {
            for j in 0..=n - i {
                let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                best = best.min((a * (1.0 - u - v) + b * u + c * v - p).norm());
            }
        }
        best
    }

    proptest! {
        #[test]
        fn triangle_closest_point_is_no_farther_than_any_sample(p in vec3(), a in vec3(), b in vec3(), c in vec3()) {
            let w = closest_on_triangle(&p, &a, &b, &c);
            prop_assert!(w.iter().all(|&x| x >= -1e-12) && (w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            let exact = point_triangle_distance(&p, &a, &b, &c);
            let sampled = sampled_triangle_distance(&p, &a, &b, &c);
            prop_assert!(exact <= sampled + 1e-12, "{exact} > {sampled}");
            prop_assert!(sampled - exact < 0.02, "{exact} ≪ {sampled}");
        }

        #[test]
        fn segment_closest_points_are_no_farther_than_any_sample(p0 in vec3(), p1 in vec3(), q0 in vec3(), q1 in vec3()) {
            let exact = segment_distance(&p0, &p1, &q0, &q1);
            let n = 400;
            let mut sampled = f64::INFINITY;
            for i in 0..=n {
                let s = i as f64 / n as f64;
                let p = p0 + (p1 - p0) * s;
                let (t0, t1) = (q0, q1);
                let t = closest_between_segments(&p, &p, &t0, &t1).1;
                sampled = sampled.min((p - (t0 + (t1 - t0) * t)).norm());
            }
            prop_assert!(exact <= sampled + 1e-12, "{exact} > {sampled}");
            prop_assert!(sampled - exact < 0.01);
        }
    }

    proptest! {
        #[test]
        fn the_boxes_gap_is_never_more_than_the_features_distance(
            p in vec3(), a in vec3(), b in vec3(), c in vec3(), offset in vec3(),
        ) {
            // Offset so that both near and far pairs are drawn.
            let p = p + offset * 2.0;
            let gap = box_gap_squared(&[p], &[a, b, c]).sqrt();
            prop_assert!(gap <= point_triangle_distance(&p, &a, &b, &c) * (1.0 + 1e-12) + 1e-15);
            let q = a + offset * 2.0;
            let gap = box_gap_squared(&[p, q], &[b, c]).sqrt();
            prop_assert!(gap <= segment_distance(&p, &q, &b, &c) * (1.0 + 1e-12) + 1e-15);
        }
    }

    #[test]
    fn boxes_apart_on_two_axes_are_as_far_as_their_corners() {
        let first = [Vector3::new(0.0, 0.0, 0.0), Vector3::new(1.0, 1.0, 0.5)];
        let second = [Vector3::new(4.0, 5.0, 0.2), Vector3::new(6.0, 7.0, 0.3)];
        assert_eq!(box_gap_squared(&first, &second), 3.0 * 3.0 + 4.0 * 4.0);
        assert_eq!(box_gap_squared(&second, &first), 25.0);
        assert_eq!(box_gap_squared(&first, &first), 0.0);
    }

    #[test]
    fn parallel_segments_meet_in_the_middle_of_their_overlap() {
        let (s, t) = closest_between_segments(
            &Vector3::new(0.0, 0.0, 0.0),
            &Vector3::new(2.0, 0.0, 0.0),
            &Vector3::new(1.0, 1.0, 0.0),
            &Vector3::new(3.0, 1.0, 0.0),
        );
        assert!((s - 0.75).abs() < 1e-12 && (t - 0.25).abs() < 1e-12, "{s} {t}");
    }

    #[test]
    fn point_above_the_face_projects_inside() {
        let w = closest_on_triangle(&Vector3::new(0.2, 1.0, 0.3), &Vector3::zeros(), &Vector3::x(), &Vector3::z());
        assert!((w[1] - 0.2).abs() < 1e-12 && (w[2] - 0.3).abs() < 1e-12);
    }
}
