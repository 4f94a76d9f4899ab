//! Fit maps, as Marvelous Designer's strain and pressure maps: the cloth
//! coloured by how far it is stretched (the largest strain of each
//! triangle's edges, as a share of the fabric's strain limit: the quantity
//! the limit bounds) or by how hard it presses on the body (the contact
//! force each particle takes from the colliders over its share of the
//! cloth's area, Pa). Designers judge fit with these.
//!
//! The value of each garment vertex (the largest of its triangles', so a
//! hot spot is not averaged away) is drawn through a colour ramp texture:
//! blue (0) through cyan, green and yellow to red (the full scale: the
//! strain limit, or [`CONTACT_FULL_SCALE_PA`] on a square-root scale).

use nalgebra::Vector3;

use crate::mesh::TriMesh;
use crate::scene::Scene;

/// Full scale of the contact map, Pa. Cotton lying on a table presses
/// with its weight, 1.3 Pa; a skirt on walking hips up to about 3 Pa; cloth
/// drawn over a ball, tens. The map's colour follows the square root of
/// the pressure, so light contact is not lost in the blue of none.
pub const CONTACT_FULL_SCALE_PA: f64 = 10.0;
/// The strain map's full scale when a fabric has no limit (unitless: 5 %).
pub const STRAIN_FULL_SCALE_WITHOUT_LIMIT: f64 = 0.05;
/// The ramp's colours (sRGB) at 0, ¼, ½, ¾ and 1 of the full scale.
const RAMP: [[u8; 3]; 5] = [[40, 70, 200], [40, 190, 220], [60, 200, 80], [240, 220, 40], [220, 30, 30]];
/// Share of a fit map's colour shown unlit: the colours read the same in
/// any light, the folds still show.
pub const UNLIT_SHARE: f32 = 0.6;
/// Texels of the ramp texture.
const RAMP_TEXELS: u32 = 256;

/// What the garments' colours show.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FitMap {
    /// Stretch, as a share of the fabric's strain limit.
    Strain,
    /// Contact pressure from the body and colliders.
    Contact,
}

impl FitMap {
    /// Every map, in the order the View menu lists them.
    pub const ALL: [FitMap; 2] = [FitMap::Strain, FitMap::Contact];

    /// Name in the UI.
    pub fn label(self) -> &'static str {
        match self {
            FitMap::Strain => "Strain map",
            FitMap::Contact => "Contact map",
        }
    }

    /// The legend for the garments of `scene` (the first garment's limit):
    /// its title and the labels at the ramp's start, middle and end.
    pub fn legend(self, scene: &Scene) -> (String, [String; 3]) {
        match self {
            FitMap::Strain => {
                let limit = scene.garments.first().and_then(|g| g.fabric.strain_limit).filter(|l| *l > 0.0);
                let full = limit.unwrap_or(STRAIN_FULL_SCALE_WITHOUT_LIMIT) * 100.0;
                let end = match limit {
                    Some(_) => format!("{full:.1} % (the limit)"),
                    None => format!("{full:.0} % (no limit set)"),
                };
                ("Stretch".into(), ["0 %".into(), format!("{:.2} %", full / 2.0), end])
            }
            FitMap::Contact => {
                let labels = [
                    "0 Pa".into(),
                    format!("{:.1} Pa", CONTACT_FULL_SCALE_PA / 4.0),
                    format!("{CONTACT_FULL_SCALE_PA:.0} Pa"),
                ];
                ("Contact pressure".into(), labels)
            }
        }
    }
}

/// The colour (sRGB) of `value` on the ramp (0 = none, 1 = full scale; clamped).
pub fn ramp(value: f32) -> [u8; 3] {
    let x = value.clamp(0.0, 1.0) * (RAMP.len() - 1) as f32;
    let i = (x.floor() as usize).min(RAMP.len() - 2);
    let s = x - i as f32;
    std::array::from_fn(|c| (f32::from(RAMP[i][c]) * (1.0 - s) + f32::from(RAMP[i + 1][c]) * s).round() as u8)
}

/// The ramp as a texture, one texel high.
pub fn ramp_image() -> image::RgbaImage {
    image::RgbaImage::from_fn(RAMP_TEXELS, 1, |x, _| {
        let [r, g, b] = ramp(x as f32 / (RAMP_TEXELS - 1) as f32);
        image::Rgba([r, g, b, 255])
    })
}

/// The texture coordinate of `value` on [`ramp_image`]: texel centres from
/// the first to the last, so a wrapping sampler never mixes the two ends.
pub fn ramp_u(value: f32) -> f32 {
    let half_texel = 0.5 / RAMP_TEXELS as f32;
    half_texel + value.clamp(0.0, 1.0) * (1.0 - 2.0 * half_texel)
}

/// Each garment particle's value (0 = none, 1 = full scale, above 1 past
/// it) of `map`, every garment's in scene order as `positions` (m) and
/// `contact_force_n` (N) hold them.
pub fn map_values(map: FitMap, scene: &Scene, positions: &[Vector3<f64>], contact_force_n: &[f32]) -> Vec<f32> {
    let mut values = Vec::with_capacity(positions.len());
    let mut first = 0;
    for garment in &scene.garments {
        let n = garment.mesh.vertex_count();
        let part: Option<Vec<f32>> = match map {
            FitMap::Strain => positions.get(first..first + n).map(|p| {
                let scale = garment.fabric.strain_limit.filter(|l| *l > 0.0).unwrap_or(STRAIN_FULL_SCALE_WITHOUT_LIMIT);
                vertex_strain(&garment.mesh, p).iter().map(|s| (s / scale) as f32).collect()
            }),
            FitMap::Contact => contact_force_n.get(first..first + n).map(|f| {
                vertex_pressure_pa(&garment.mesh, f).iter().map(|p| (p / CONTACT_FULL_SCALE_PA).sqrt() as f32).collect()
            }),
        };
        values.extend(part.unwrap_or_else(|| vec![0.0; n]));
        first += n;
    }
    values
}

/// Each vertex's strain: the largest of its triangles' largest edge strain
/// `(l − l₀) / l₀` at `positions` against the mesh's own (rest) positions,
/// unitless (compression counts as none).
pub fn vertex_strain(mesh: &TriMesh, positions: &[Vector3<f64>]) -> Vec<f64> {
    let mut strain = vec![0.0f64; mesh.vertex_count()];
    for tri in &mesh.triangles {
        let edge = |a: u32, b: u32| {
            let (a, b) = (a as usize, b as usize);
            let rest = (mesh.positions[b] - mesh.positions[a]).norm();
            match (positions.get(a), positions.get(b)) {
                (Some(p), Some(q)) if rest > 0.0 => ((q - p).norm() - rest) / rest,
                _ => 0.0,
            }
        };
        let worst = edge(tri[0], tri[1]).max(edge(tri[1], tri[2])).max(edge(tri[2], tri[0])).max(0.0);
        for &v in tri {
            strain[v as usize] = strain[v as usize].max(worst);
        }
    }
    strain
}

/// Each vertex's contact pressure, Pa: its contact force (N) over its share
/// of the cloth's rest area (a third of each triangle around it).
pub fn vertex_pressure_pa(mesh: &TriMesh, force_n: &[f32]) -> Vec<f64> {
    let mut area = vec![0.0f64; mesh.vertex_count()];
    for tri in &mesh.triangles {
        let [a, b, c] = tri.map(|v| mesh.positions[v as usize]);
        let third = (b - a).cross(&(c - a)).norm() / 6.0;
        for &v in tri {
            area[v as usize] += third;
        }
    }
    area.iter().zip(force_n).map(|(a, f)| if *a > 0.0 { f64::from(*f) / a } else { 0.0 }).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;

    #[test]
    fn the_ramp_runs_blue_to_red_and_its_texture_ends_on_texel_centres() {
        assert_eq!(ramp(0.0), RAMP[0]);
        assert_eq!(ramp(1.0), RAMP[4]);
        assert_eq!(ramp(7.0), RAMP[4], "past the full scale stays red");
        assert_eq!(ramp(0.5), RAMP[2]);
        let image = ramp_image();
        let texel = |u: f32| (u * RAMP_TEXELS as f32 - 0.5).round() as u32;
        assert_eq!(texel(ramp_u(0.0)), 0);
        assert_eq!(texel(ramp_u(1.0)), RAMP_TEXELS - 1);
        assert_eq!(image.get_pixel(RAMP_TEXELS - 1, 0).0[..3], RAMP[4]);
    }

    #[test]
    fn a_square_stretched_two_percent_one_way_shows_two_percent_at_every_vertex() {
        let mesh = generate::grid(1.0, 4);
        let stretched: Vec<_> = mesh.positions.iter().map(|p| Vector3::new(p.x * 1.02, p.y, p.z)).collect();
        for s in vertex_strain(&mesh, &stretched) {
            assert!((s - 0.02).abs() < 1e-12, "{s}");
        }
        let squeezed: Vec<_> = mesh.positions.iter().map(|p| p * 0.9).collect();
        assert!(vertex_strain(&mesh, &squeezed).iter().all(|s| *s == 0.0), "compression is no stretch");
    }

    #[test]
    fn pressure_is_force_over_each_vertex_share_of_the_area() {
        let mesh = generate::grid(1.0, 2);
        let shares = vertex_pressure_pa(&mesh, &vec![1.0; mesh.vertex_count()]);
        let total_area: f64 = shares.iter().map(|p| 1.0 / p).sum();
        assert!((total_area - 1.0).abs() < 1e-9, "the shares add up to the 1 m² square: {total_area}");
    }
}
