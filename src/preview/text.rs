//! Words in pictures: title lines, legends and landmark numbers, drawn from
//! an 8 × 8 bitmap font (font8x8's public-domain glyphs) at a whole-number
//! scale, with a halo so they read over any texture.

use image::RgbaImage;

/// Glyph cell, pixels a side at scale 1.
pub const GLYPH: u32 = 8;

/// Text scale for a picture of `size` pixels a side: 1 up to 767 px, 2 up
/// to 1279, then 3 and at most 4, so a line stays about 1/60 of the picture.
pub fn scale_for(size: u32) -> u32 {
    (size / 512).clamp(1, 4)
}

/// Height of one line of text at `scale`, its spacing included.
pub fn line_height(scale: u32) -> u32 {
    (GLYPH + 4) * scale
}

/// Width of `text` at `scale`, pixels.
pub fn width(text: &str, scale: u32) -> u32 {
    text.chars().count() as u32 * GLYPH * scale
}

/// The glyph of `c`: basic Latin and Latin-1; anything else shows as `?`.
fn glyph(c: char) -> [u8; 8] {
    let code = c as usize;
    match code {
        0x20..=0x7e => font8x8::legacy::BASIC_LEGACY[code],
        0xa0..=0xff => font8x8::legacy::LATIN_LEGACY[code - 0xa0],
        _ => font8x8::legacy::BASIC_LEGACY[usize::from(b'?')],
    }
}

/// Blends `rgb` at opacity `alpha` into pixel (x, y) if it is inside.
pub fn blend(image: &mut RgbaImage, x: i64, y: i64, rgb: [u8; 3], alpha: u8) {
    if x < 0 || y < 0 || x >= i64::from(image.width()) || y >= i64::from(image.height()) {
        return;
    }
    let p = image.get_pixel_mut(x as u32, y as u32);
    let a = u32::from(alpha);
    for (channel, &c) in p.0.iter_mut().zip(&rgb) {
        *channel = ((u32::from(c) * a + u32::from(*channel) * (255 - a)) / 255) as u8;
    }
    p.0[3] = p.0[3].max(alpha);
}

/// Fills the rectangle at (x, y) of `w` × `h` pixels with `rgb` at `alpha`.
pub fn fill_rect(image: &mut RgbaImage, x: i64, y: i64, w: u32, h: u32, rgb: [u8; 3], alpha: u8) {
    for j in 0..i64::from(h) {
        for i in 0..i64::from(w) {
            blend(image, x + i, y + j, rgb, alpha);
        }
    }
}

/// Fills a disc of `radius` around (cx, cy) with `rgb`, ringed by `ring`.
pub fn disc(image: &mut RgbaImage, cx: f64, cy: f64, radius: f64, rgb: [u8; 3], ring: [u8; 3]) {
    let r = radius.ceil() as i64 + 1;
    let (x0, y0) = (cx.floor() as i64, cy.floor() as i64);
    for y in y0 - r..=y0 + r {
        for x in x0 - r..=x0 + r {
            let d = ((x as f64 + 0.5 - cx).powi(2) + (y as f64 + 0.5 - cy).powi(2)).sqrt();
            if d <= radius - 1.0 {
                blend(image, x, y, rgb, 255);
            } else if d <= radius {
                blend(image, x, y, ring, 255);
            }
        }
    }
}

/// How a line of text is drawn: its colour, and the halo around each glyph
/// (one pixel of the scale wide) that keeps it readable on any background.
#[derive(Debug, Clone, Copy)]
pub struct Ink {
    pub colour: [u8; 3],
    pub halo: Option<[u8; 3]>,
    pub scale: u32,
}

impl Ink {
    /// Dark text with a white halo.
    pub fn dark(scale: u32) -> Self {
        Ink {
            colour: [20, 20, 20],
            halo: Some([255, 255, 255]),
            scale,
        }
    }
}

/// Draws `text` with its top-left corner at (x, y); returns its width.
pub fn draw(image: &mut RgbaImage, x: i64, y: i64, text: &str, ink: Ink) -> u32 {
    let s = i64::from(ink.scale.max(1));
    let cell = i64::from(GLYPH) * s;
    if let Some(halo) = ink.halo {
        for (k, c) in text.chars().enumerate() {
            let gx = x + k as i64 * cell;
            for_each_dot(glyph(c), |i, j| {
                fill_rect(
                    image,
                    gx + i * s - s,
                    y + j * s - s,
                    (3 * s) as u32,
                    (3 * s) as u32,
                    halo,
                    255,
                );
            });
        }
    }
    for (k, c) in text.chars().enumerate() {
        let gx = x + k as i64 * cell;
        for_each_dot(glyph(c), |i, j| {
            fill_rect(image, gx + i * s, y + j * s, s as u32, s as u32, ink.colour, 255);
        });
    }
    width(text, ink.scale)
}

/// Calls `f(column, row)` for each set dot of a glyph (bit 0 is the left).
fn for_each_dot(g: [u8; 8], mut f: impl FnMut(i64, i64)) {
    for (j, row) in g.iter().enumerate() {
        for i in 0..8 {
            if row >> i & 1 == 1 {
                f(i, j as i64);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::Rgba;

    #[test]
    fn text_is_drawn_where_asked_and_only_there() {
        let mut img = RgbaImage::from_pixel(64, 20, Rgba([255, 255, 255, 255]));
        let w = draw(&mut img, 2, 2, "L2 1", Ink::dark(1));
        assert_eq!(w, 32);
        fn dark(img: &RgbaImage, x0: u32, x1: u32) -> usize {
            let h = img.height();
            let cells = (x0..x1).flat_map(|x| (0..h).map(move |y| (x, y)));
            cells.filter(|&(x, y)| img.get_pixel(x, y).0[0] < 100).count()
        }
        assert!(dark(&img, 2, 34) > 20, "the glyphs are drawn");
        assert_eq!(dark(&img, 36, 64), 0, "nothing past the text");
        // A character outside the font shows as '?', not as nothing.
        let mut other = RgbaImage::from_pixel(16, 16, Rgba([255, 255, 255, 255]));
        draw(&mut other, 0, 0, "\u{2192}", Ink::dark(1));
        assert!(dark(&other, 0, 8) > 0);
    }

    #[test]
    fn the_scale_grows_with_the_picture() {
        assert_eq!(scale_for(160), 1);
        assert_eq!(scale_for(1024), 2);
        assert_eq!(scale_for(8192), 4);
    }
}
