//! The heavy elastica: an inextensible strip clamped horizontally at one end
//! and bent by its own weight, the exact model behind the cantilever test.
//!
//! With arc length `s = l u` from the clamp and `φ(u)` the strip's angle
//! below the horizontal, the bending moment balances the weight beyond each
//! point: `φ'' = −λ (1 − u) cos φ`, `φ(0) = 0`, `φ'(1) = 0`, where
//! `λ = w l³ / G` (w weight per area, G flexural rigidity, l overhang). The
//! bending length `c = (G/w)^⅓` is then `l λ^(−⅓)`. At the test's 41.5° chord
//! λ = 8.004, so `c = l / 2` to 0.02 % (Peirce's approximate formula is
//! 1.8 % off there).

/// Integration steps along the strip.
const STEPS: usize = 400;
/// Bisection rounds of each search.
const ROUNDS: usize = 60;
/// The largest load parameter searched (a chord of 80°; the shooting is
/// reliable up to λ ≈ 120).
const MAX_LAMBDA: f64 = 100.0;

/// Integrates the strip with clamp curvature `k0` under load `lambda`:
/// the curvature at the tip `φ'(1)` and the tip's position `(x, y)` in
/// units of the overhang (y downward).
fn shoot(lambda: f64, k0: f64) -> (f64, f64, f64) {
    let h = 1.0 / STEPS as f64;
    let slope = |u: f64, phi: f64| -lambda * (1.0 - u) * phi.cos();
    let (mut phi, mut k, mut x, mut y) = (0.0_f64, k0, 0.0, 0.0);
    for i in 0..STEPS {
        let u = i as f64 * h;
        // Classical Runge-Kutta on (φ, φ').
        let (p1, k1) = (k, slope(u, phi));
        let (p2, k2) = (k + 0.5 * h * k1, slope(u + 0.5 * h, phi + 0.5 * h * p1));
        let (p3, k3) = (k + 0.5 * h * k2, slope(u + 0.5 * h, phi + 0.5 * h * p2));
        let (p4, k4) = (k + h * k3, slope(u + h, phi + h * p3));
        let next = phi + h / 6.0 * (p1 + 2.0 * p2 + 2.0 * p3 + p4);
        // Position by the midpoint angle.
        let mid = 0.5 * (phi + next);
        x += h * mid.cos();
        y += h * mid.sin();
        phi = next;
        k += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    }
    (k, x, y)
}

/// Angle below the horizontal of the chord from the clamp to the tip of a
/// strip under load `lambda = w l³ / G`, radians.
pub fn chord_angle(lambda: f64) -> f64 {
    // The clamp curvature that leaves the tip free of moment: between 0 and
    // the small-deflection value λ/2 (the moment only shrinks as it bends).
    let (mut lo, mut hi) = (0.0, 0.5 * lambda);
    for _ in 0..ROUNDS {
        let mid = 0.5 * (lo + hi);
        if shoot(lambda, mid).0 > 0.0 { hi = mid } else { lo = mid }
    }
    let (_, x, y) = shoot(lambda, 0.5 * (lo + hi));
    y.atan2(x)
}

/// The load `λ = w l³ / G` at which the chord hangs `angle` radians below
/// the horizontal, for `0 < angle` up to 80° (steeper chords give 100).
pub fn load_for_chord_angle(angle: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, MAX_LAMBDA);
    for _ in 0..ROUNDS {
        let mid = 0.5 * (lo + hi);
        if chord_angle(mid) < angle { lo = mid } else { hi = mid }
    }
    0.5 * (lo + hi)
}

/// Bending length of a strip of overhang `overhang_m` whose chord hangs
/// `angle` radians below the horizontal, m.
pub fn bending_length(overhang_m: f64, angle: f64) -> f64 {
    overhang_m / load_for_chord_angle(angle).cbrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_loads_deflect_like_the_linear_beam() {
        // Tip deflection w l⁴ / 8G, so the chord's slope is λ/8.
        let lambda = 0.01;
        assert!((chord_angle(lambda).tan() / (lambda / 8.0) - 1.0).abs() < 1e-3);
    }

    #[test]
    fn the_astm_angle_puts_the_bending_length_at_half_the_overhang() {
        let c = bending_length(1.0, 41.5f64.to_radians());
        assert!((c - 0.5).abs() < 5e-4, "{c}");
    }

    #[test]
    fn chord_angle_and_load_invert_each_other() {
        for lambda in [0.5, 3.0, 8.0, 40.0] {
            let back = load_for_chord_angle(chord_angle(lambda));
            assert!((back / lambda - 1.0).abs() < 1e-6, "{lambda} -> {back}");
        }
    }
}
