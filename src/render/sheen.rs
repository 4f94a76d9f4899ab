//! The fabric sheen lobe of glTF's KHR_materials_sheen: the "Charlie"
//! distribution (Estevez & Kulla 2017) with Neubelt & Pettineo's visibility,
//! and its directional albedo, tabulated once so the shader can scale the base
//! layer by what the sheen reflects (energy conservation).
//!
//! The shader (`shaders/pbr.wgsl`) evaluates the same two functions; the table
//! is the only piece computed here.

use std::f64::consts::PI;

/// Table size along each axis (cos θ and sheen roughness).
pub const SHEEN_TABLE_SIZE: usize = 32;

/// Smallest sheen roughness the shader uses (the lobe degenerates at 0).
pub const MIN_SHEEN_ROUGHNESS: f64 = 0.07;

/// Charlie microfacet distribution at `cos_h` (normal · half vector) for
/// sheen roughness `roughness` (α = roughness²), 1/sr.
pub fn charlie_distribution(cos_h: f64, roughness: f64) -> f64 {
    let alpha = roughness.max(MIN_SHEEN_ROUGHNESS).powi(2);
    let inv_alpha = 1.0 / alpha;
    let sin2 = (1.0 - cos_h * cos_h).max(0.0);
    (2.0 + inv_alpha) * sin2.powf(0.5 * inv_alpha) / (2.0 * PI)
}

/// Neubelt & Pettineo's visibility term for sheen, `1 / (4 (n·l + n·v − n·l n·v))`.
pub fn sheen_visibility(cos_v: f64, cos_l: f64) -> f64 {
    (1.0 / (4.0 * (cos_l + cos_v - cos_l * cos_v))).clamp(0.0, 1.0)
}

/// Directional albedo of a white sheen lobe: the fraction of light arriving
/// from direction `cos_v` (to the normal) that the lobe reflects, integrated
/// over the hemisphere by the midpoint rule, unitless.
pub fn sheen_albedo(cos_v: f64, roughness: f64) -> f64 {
    const THETA_STEPS: usize = 64;
    const PHI_STEPS: usize = 64;
    let cos_v = cos_v.clamp(1e-4, 1.0);
    let view = [(1.0 - cos_v * cos_v).sqrt(), 0.0, cos_v];
    let (d_theta, d_phi) = (0.5 * PI / THETA_STEPS as f64, PI / PHI_STEPS as f64);
    let mut sum = 0.0;
    for i in 0..THETA_STEPS {
        let theta = (i as f64 + 0.5) * d_theta;
        let (sin_t, cos_l) = theta.sin_cos();
        // Symmetric about the plane of incidence: integrate φ over [0, π] twice.
        for j in 0..PHI_STEPS {
            let phi = (j as f64 + 0.5) * d_phi;
            let light = [sin_t * phi.cos(), sin_t * phi.sin(), cos_l];
            let half = [view[0] + light[0], view[1] + light[1], view[2] + light[2]];
            let cos_h = half[2] / (half[0] * half[0] + half[1] * half[1] + half[2] * half[2]).sqrt();
            let brdf = charlie_distribution(cos_h, roughness) * sheen_visibility(cos_v, cos_l);
            sum += 2.0 * brdf * cos_l * sin_t * d_theta * d_phi;
        }
    }
    sum
}

/// The albedo table, row-major with cos θ_v along x and roughness along y
/// (texel centres at `(i + 0.5) / SIZE`), quantised to 8 bits for an R8 texture.
pub fn sheen_albedo_table() -> Vec<u8> {
    let centre = |i: usize| (i as f64 + 0.5) / SHEEN_TABLE_SIZE as f64;
    let mut table = Vec::with_capacity(SHEEN_TABLE_SIZE * SHEEN_TABLE_SIZE);
    for row in 0..SHEEN_TABLE_SIZE {
        for col in 0..SHEEN_TABLE_SIZE {
            let albedo = sheen_albedo(centre(col), centre(row)).clamp(0.0, 1.0);
            table.push((albedo * 255.0).round() as u8);
        }
    }
    table
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Integral of `f(cos θ)` over the hemisphere, dω = sin θ dθ dφ.
    fn hemisphere_integral(f: impl Fn(f64) -> f64) -> f64 {
        let steps = 4000;
        let d = 0.5 * PI / steps as f64;
        (0..steps).map(|i| (i as f64 + 0.5) * d).map(|t| f(t.cos()) * t.sin() * d * 2.0 * PI).sum()
    }

    #[test]
    fn charlie_distribution_is_normalised_over_projected_area() {
        // A microfacet distribution satisfies ∫ D(h) (n·h) dω_h = 1.
        for roughness in [0.3, 0.6, 1.0] {
            let total = hemisphere_integral(|c| charlie_distribution(c, roughness) * c);
            assert!((total - 1.0).abs() < 1e-3, "roughness {roughness}: {total}");
        }
    }

    #[test]
    fn sheen_albedo_is_a_fraction_and_grows_towards_grazing() {
        for roughness in [0.1, 0.5, 1.0] {
            let head_on = sheen_albedo(1.0, roughness);
            let grazing = sheen_albedo(0.1, roughness);
            assert!(head_on > 0.0 && grazing <= 1.0, "{head_on} {grazing}");
            assert!(grazing > head_on, "roughness {roughness}: grazing {grazing} head-on {head_on}");
        }
    }

    #[test]
    fn table_samples_the_albedo_at_texel_centres() {
        let table = sheen_albedo_table();
        assert_eq!(table.len(), SHEEN_TABLE_SIZE * SHEEN_TABLE_SIZE);
        let (col, row) = (5, 20);
        let expected = sheen_albedo((col as f64 + 0.5) / 32.0, (row as f64 + 0.5) / 32.0);
        assert!((f64::from(table[row * SHEEN_TABLE_SIZE + col]) / 255.0 - expected).abs() <= 0.5 / 255.0 + 1e-9);
    }
}
