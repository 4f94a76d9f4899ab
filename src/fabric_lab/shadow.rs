//! The shadow a draped specimen casts on the floor under a point light far
//! above (what a drape meter photographs): the area covered by the cloth's
//! triangles projected straight down, each point counted once however many
//! layers cover it.

use nalgebra::Vector3;

/// Side of the square pixels the shadow is measured with, m.
pub const PIXEL_M: f64 = 0.5e-3;

/// The shadow on a square of pixels centred under the axis.
#[derive(Clone, Debug, PartialEq)]
pub struct Shadow {
    /// Pixels along each side.
    pub side: usize,
    /// Row-major (rows along +Z, columns along +X): whether cloth covers the pixel.
    pub covered: Vec<bool>,
}

impl Shadow {
    /// The shadow of `triangles` of `positions` projected onto the XZ plane
    /// within `half_width_m` of the axis, on [`PIXEL_M`] pixels (a pixel is
    /// covered when its centre lies inside a triangle, edges included).
    pub fn cast(positions: &[Vector3<f64>], triangles: &[[u32; 3]], half_width_m: f64) -> Shadow {
        let side = (2.0 * half_width_m / PIXEL_M).ceil() as usize;
        let mut covered = vec![false; side * side];
        for t in triangles {
            let corners = t.map(|i| {
                let p = positions[i as usize];
                ((p.x + half_width_m) / PIXEL_M, (p.z + half_width_m) / PIXEL_M)
            });
            cover(&corners, side, &mut covered);
        }
        Shadow { side, covered }
    }

    /// Covered area, m².
    pub fn area_m2(&self) -> f64 {
        self.covered.iter().filter(|&&c| c).count() as f64 * PIXEL_M * PIXEL_M
    }

    /// The shadow as a drape meter shows it, seen from above (+X right, −Z
    /// up): cloth dark on white, with the supporting disc of `disc_radius_m`
    /// outlined.
    pub fn picture(&self, disc_radius_m: f64) -> image::GrayImage {
        let centre = 0.5 * self.side as f64;
        let ring = disc_radius_m / PIXEL_M;
        image::GrayImage::from_fn(self.side as u32, self.side as u32, |x, y| {
            // Image rows run down the screen, towards +Z seen from above.
            let covered = self.covered[y as usize * self.side + x as usize];
            let r = (x as f64 + 0.5 - centre).hypot(y as f64 + 0.5 - centre);
            let on_ring = (r - ring).abs() < 1.5;
            image::Luma([match (covered, on_ring) {
                (_, true) => 150,
                (true, false) => 40,
                (false, false) => 255,
            }])
        })
    }
}

/// Marks the pixels of a `side` × `side` grid whose centres lie inside the
/// triangle `corners` (in pixel units), whichever way it winds.
fn cover(corners: &[(f64, f64); 3], side: usize, covered: &mut [bool]) {
    let [a, b, c] = *corners;
    let area = (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0);
    if area == 0.0 {
        return;
    }
    let inside_of =
        |p: (f64, f64), q: (f64, f64), x: f64, y: f64| ((q.0 - p.0) * (y - p.1) - (q.1 - p.1) * (x - p.0)) * area;
    // Pixels whose centres the triangle's box spans, clipped to the grid.
    let range = |values: [f64; 3]| {
        let lo = values.iter().copied().fold(f64::INFINITY, f64::min).floor().max(0.0) as usize;
        let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max).ceil().min(side as f64) as usize;
        lo..hi
    };
    for row in range([a.1, b.1, c.1]) {
        let y = row as f64 + 0.5;
        for column in range([a.0, b.0, c.0]) {
            let x = column as f64 + 0.5;
            if inside_of(a, b, x, y) >= 0.0 && inside_of(b, c, x, y) >= 0.0 && inside_of(c, a, x, y) >= 0.0 {
                covered[row * side + column] = true;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;

    #[test]
    fn a_flat_square_casts_its_own_area() {
        let mesh = generate::grid(0.2, 11);
        let area = Shadow::cast(&mesh.positions, &mesh.triangles, 0.2).area_m2();
        assert!((area / 0.04 - 1.0).abs() < 0.01, "{area}");
        // Cloth beyond the square measured is not counted.
        let clipped = Shadow::cast(&mesh.positions, &mesh.triangles, 0.05).area_m2();
        assert!((clipped / 0.01 - 1.0).abs() < 0.01, "{clipped}");
    }

    #[test]
    fn overlapping_layers_count_once_and_height_does_not_matter() {
        let mesh = generate::grid(0.1, 5);
        let mut positions = mesh.positions.clone();
        let mut triangles = mesh.triangles.clone();
        // A second layer over the same square, 5 cm higher and shifted by half a side.
        let n = positions.len() as u32;
        positions.extend(mesh.positions.iter().map(|p| p + Vector3::new(0.05, 0.05, 0.0)));
        triangles.extend(mesh.triangles.iter().map(|t| t.map(|i| i + n)));
        let area = Shadow::cast(&positions, &triangles, 0.2).area_m2();
        assert!((area / 0.015 - 1.0).abs() < 0.02, "{area}");
    }
}
