//! Text drawn into images: a fit map's legend (exported PNG frames: the
//! ramp with its title and the values at its start, middle and end, in the
//! lower left corner, as the editor's viewport shows it), and a contact
//! sheet tile's caption.

use ab_glyph::{FontRef, PxScale, PxScaleFont, ScaleFont, point};
use image::{Rgba, RgbaImage};

use super::fit_map::ramp;

/// Sizes at an image 720 pixels tall, pixels (scaled with the image).
const MARGIN: f32 = 16.0;
const BAR: (f32, f32) = (220.0, 12.0);
const TEXT: f32 = 13.0;
const PADDING: f32 = 8.0;

/// Draws the legend titled `title` with `labels` under the ramp's start,
/// middle and end into `image`.
pub fn draw_legend(image: &mut RgbaImage, title: &str, labels: &[String; 3]) {
    let Ok(font) = FontRef::try_from_slice(epaint_default_fonts::UBUNTU_LIGHT) else { return };
    let scale = image.height() as f32 / 720.0;
    let (bar_w, bar_h, text, pad) = (BAR.0 * scale, BAR.1 * scale, TEXT * scale, PADDING * scale);
    let left = MARGIN * scale + pad;
    let bar_top = image.height() as f32 - MARGIN * scale - pad - text - bar_h;
    let box_top = bar_top - text - 2.0 * pad;
    fill(image, (left - pad, box_top), (bar_w + 2.0 * pad, image.height() as f32 - MARGIN * scale - box_top), |_| {
        Rgba([0, 0, 0, 150])
    });
    fill(image, (left, bar_top), (bar_w, bar_h), |x| {
        let [r, g, b] = ramp((x - left) / (bar_w - 1.0).max(1.0));
        Rgba([r, g, b, 255])
    });
    let font = PxScaleFont { font, scale: PxScale::from(text) };
    write(image, &font, title, (left, bar_top - pad * 0.5 - text));
    let below = bar_top + bar_h + pad * 0.25;
    for (k, label) in labels.iter().enumerate() {
        let width = text_width(&font, label);
        let x = left + bar_w * k as f32 / 2.0 - width * k as f32 / 2.0;
        write(image, &font, label, (x, below));
    }
}

/// Writes `text` on a dark band along the bottom of `image`, `height`
/// pixels tall (a tile's label on a contact sheet).
pub fn draw_caption(image: &mut RgbaImage, text: &str, height: f32) {
    let Ok(font) = FontRef::try_from_slice(epaint_default_fonts::UBUNTU_LIGHT) else { return };
    let top = image.height() as f32 - height;
    fill(image, (0.0, top), (image.width() as f32, height), |_| Rgba([0, 0, 0, 170]));
    let font = PxScaleFont { font, scale: PxScale::from(height * 0.65) };
    write(image, &font, text, (height * 0.3, top + height * 0.15));
}

/// Blends `colour(x)` over the rectangle at `at` of `size`, pixels.
fn fill(image: &mut RgbaImage, at: (f32, f32), size: (f32, f32), colour: impl Fn(f32) -> Rgba<u8>) {
    let (x0, y0) = (at.0.max(0.0) as u32, at.1.max(0.0) as u32);
    let (x1, y1) = (((at.0 + size.0) as u32).min(image.width()), ((at.1 + size.1) as u32).min(image.height()));
    for y in y0..y1 {
        for x in x0..x1 {
            let c = colour(x as f32);
            blend(image, x, y, c, f32::from(c[3]) / 255.0);
        }
    }
}

fn blend(image: &mut RgbaImage, x: u32, y: u32, c: Rgba<u8>, alpha: f32) {
    let p = image.get_pixel_mut(x, y);
    for k in 0..3 {
        p[k] = (f32::from(p[k]) * (1.0 - alpha) + f32::from(c[k]) * alpha).round() as u8;
    }
}

fn text_width(font: &PxScaleFont<FontRef<'static>>, text: &str) -> f32 {
    text.chars().map(|c| font.h_advance(font.glyph_id(c))).sum()
}

/// Writes `text` in white with its top left at `at`, pixels.
fn write(image: &mut RgbaImage, font: &PxScaleFont<FontRef<'static>>, text: &str, at: (f32, f32)) {
    let mut x = at.0;
    let baseline = at.1 + font.ascent();
    for c in text.chars() {
        let glyph = font.glyph_id(c).with_scale_and_position(font.scale(), point(x, baseline));
        x += font.h_advance(glyph.id);
        let Some(outline) = font.outline_glyph(glyph) else { continue };
        let bounds = outline.px_bounds();
        outline.draw(|gx, gy, coverage| {
            let (px, py) = (bounds.min.x as i64 + i64::from(gx), bounds.min.y as i64 + i64::from(gy));
            if px >= 0 && py >= 0 && (px as u32) < image.width() && (py as u32) < image.height() {
                blend(image, px as u32, py as u32, Rgba([235, 235, 235, 255]), coverage.clamp(0.0, 1.0));
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_legend_shows_the_ramp_and_white_text_in_the_lower_left() {
        let mut image = RgbaImage::from_pixel(1280, 720, Rgba([128, 128, 128, 255]));
        draw_legend(&mut image, "Stretch", &["0 %".into(), "0.50 %".into(), "1.0 % (the limit)".into()]);
        let at = |x: f32, y: f32| image.get_pixel(x as u32, y as u32).0;
        let bar_y = 720.0 - MARGIN - PADDING - TEXT - BAR.1 / 2.0;
        assert_eq!(at(MARGIN + PADDING, bar_y)[..3], ramp(0.0), "blue at the start");
        assert_eq!(at(MARGIN + PADDING + BAR.0 - 1.0, bar_y)[..3], ramp(1.0), "red at the end");
        let box_grey = |p: &&Rgba<u8>| p[0] > 150 && p[0] == p[1] && p[1] == p[2] && p[0] != 128;
        let lettered = image.pixels().filter(box_grey).count();
        assert!(lettered > 100, "the labels are written: {lettered} light pixels");
        assert_eq!(at(1000.0, 100.0)[..3], [128, 128, 128], "the rest of the image is untouched");
    }

    #[test]
    fn a_caption_darkens_the_bottom_band_and_writes_on_it() {
        let mut image = RgbaImage::from_pixel(320, 240, Rgba([128, 128, 128, 255]));
        draw_caption(&mut image, "preset silk · friction 0.2", 24.0);
        assert_eq!(image.get_pixel(310, 230).0[..3], [43, 43, 43], "the band: black at 2/3 over grey 128");
        let lettered =
            (216..240).flat_map(|y| (0..320).map(move |x| (x, y))).filter(|&(x, y)| image.get_pixel(x, y)[0] > 150);
        assert!(lettered.count() > 50, "the text");
        assert_eq!(image.get_pixel(100, 100).0[..3], [128, 128, 128], "above the band, untouched");
    }
}
