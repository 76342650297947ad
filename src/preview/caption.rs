//! The words on a picture, so that it reads without a guide: a title band
//! (the constraint file, the status, how many landmarks are on target, the
//! largest residual, the stretch and the time), a legend band (the stretch
//! colours with their values, what the dots and arrows mean), and each
//! landmark's number (and label, on large pictures) beside it.

use super::text::{self, Ink};
use super::{Marker, REACHED_COLOUR, UNREACHED_COLOUR, stretch_colour};
use crate::report::{Report, Status};
use image::RgbaImage;

/// The title band's lines.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Caption {
    pub lines: Vec<String>,
}

impl Caption {
    /// The title of a solved chart's picture: the file and its status, the
    /// landmarks on target with the largest residual, the stretch and time;
    /// `over` names the image under the layout, if it is not the material's.
    pub fn of_report(report: &Report, over: Option<&str>) -> Self {
        let file = std::path::Path::new(&report.constraint_file)
            .file_name()
            .map_or_else(|| report.constraint_file.clone(), |n| n.to_string_lossy().into_owned());
        let status = match report.status {
            Status::Reached => "reached",
            Status::Partial => "PARTIAL",
            Status::Error => "ERROR (not written)",
        };
        // Every chart's landmarks count, the first's and the others'.
        let all: Vec<_> = report.every_constraint().collect();
        let on_target = all.iter().filter(|c| c.reached).count();
        let mut first = format!("{file}: {status}");
        if let Some(image) = over {
            first += &format!(", over {image}");
        }
        Caption {
            lines: vec![
                first,
                format!(
                    "{on_target} of {} landmarks on target, max residual {:.1e}",
                    all.len(),
                    report.max_residual
                ),
                format!(
                    "stretch L2 {:.3}, Linf {:.2}; {:.0} ms",
                    report.stretch_final.l2, report.stretch_final.linf, report.total_ms
                ),
            ],
        }
    }
}

/// Draws `caption` in the band above `top` (pixels), each line cut to the
/// picture's width.
pub fn draw_title(image: &mut RgbaImage, caption: &Caption, margin: f32) {
    let scale = text::scale_for(image.width());
    let fits = (image.width().saturating_sub(2 * margin as u32) / (text::GLYPH * scale)) as usize;
    for (k, line) in caption.lines.iter().enumerate() {
        let y = margin as i64 / 2 + (k as u32 * text::line_height(scale)) as i64;
        text::draw(image, margin as i64, y, &shorten(line, fits), Ink::dark(scale));
    }
}

/// `line` cut to `fits` characters, ending in `...` when cut.
fn shorten(line: &str, fits: usize) -> String {
    if line.chars().count() <= fits {
        return line.to_string();
    }
    let kept: String = line.chars().take(fits.saturating_sub(3)).collect();
    kept + "..."
}

/// The layout picture's legend, in the band that ends `margin` above the
/// bottom: the stretch ramp with its values, then the marker key and
/// `more` (what the arrows or the grey charts are).
/// `density`: the other charts' texel density over the chart's, said on
/// the first line.
pub fn draw_layout_legend(image: &mut RgbaImage, margin: f32, hole_fill: bool, density: Option<&str>, more: &str) {
    let scale = text::scale_for(image.width());
    let line = text::line_height(scale) as i64;
    let glyph = i64::from(text::GLYPH * scale);
    let y0 = i64::from(image.height()) - margin as i64 - 2 * line + line / 4;
    let mut x = margin as i64;
    x += i64::from(text::draw(image, x, y0, "stretch ", Ink::dark(scale)));
    // Two ramp segments, 1 -> 2 -> 4+, the values between them.
    for (from, to, label) in [(1.0f64, 2.0, "1 "), (2.0, 4.0, " 2 ")] {
        x += i64::from(text::draw(image, x, y0, label, Ink::dark(scale)));
        let w = 6 * glyph;
        for i in 0..w {
            let s = from * (to / from).powf(i as f64 / w as f64);
            text::fill_rect(image, x + i, y0, 1, text::GLYPH * scale, stretch_colour(s), 255);
        }
        x += w;
    }
    x += i64::from(text::draw(image, x, y0, " 4+", Ink::dark(scale)));
    if hole_fill {
        x += glyph;
        text::fill_rect(image, x, y0, (glyph) as u32, (glyph) as u32, [110, 110, 120], 140);
        x += glyph + glyph / 2;
        x += i64::from(text::draw(image, x, y0, "hole fill", Ink::dark(scale)));
    }
    if let Some(d) = density {
        text::draw(image, x + 2 * glyph, y0, d, Ink::dark(scale));
    }
    draw_marker_key(image, margin as i64, y0 + line, scale, more);
}

/// The key of the landmark dots (and `more`, a last item), at (x, y).
pub fn draw_marker_key(image: &mut RgbaImage, mut x: i64, y: i64, scale: u32, more: &str) {
    let glyph = f64::from(text::GLYPH * scale);
    for (colour, words) in [
        (REACHED_COLOUR, "on target   "),
        (UNREACHED_COLOUR, "short, ring: target   "),
    ] {
        text::disc(
            image,
            x as f64 + glyph / 2.0,
            y as f64 + glyph / 2.0,
            glyph / 2.0,
            colour,
            [255, 255, 255],
        );
        x += (glyph * 1.5) as i64;
        x += i64::from(text::draw(image, x, y, words, Ink::dark(scale)));
    }
    text::draw(image, x, y, more, Ink::dark(scale));
}

/// Each landmark's number (with its label on pictures of 768 px or more)
/// beside its target, where it overlaps no other: up-right, down-right,
/// up-left or down-left of it. Numbers are placed first, then each label
/// where it fits without covering another; `at` gives a texture
/// coordinate's pixel.
pub fn draw_numbers(image: &mut RgbaImage, markers: &[Marker], radius: f32, at: impl Fn(glam::DVec2) -> (f32, f32)) {
    let scale = text::scale_for(image.width());
    let height = i64::from(text::GLYPH * scale);
    let gap = f64::from(radius) * 1.4;
    let spots = |m: &Marker, width: i64| {
        let (x, y) = at(m.target);
        let (x, y) = (f64::from(x), f64::from(y));
        [
            (x + gap, y - gap - height as f64),
            (x + gap, y + gap),
            (x - gap - width as f64, y - gap - height as f64),
            (x - gap - width as f64, y + gap),
        ]
        .map(|(cx, cy)| [cx as i64, cy as i64, width, height])
    };
    // No word covers a landmark's dot.
    let dots: Vec<[i64; 4]> = markers
        .iter()
        .map(|m| {
            let (x, y) = at(m.target);
            let r = f64::from(radius);
            [
                (f64::from(x) - r) as i64,
                (f64::from(y) - r) as i64,
                (2.0 * r) as i64,
                (2.0 * r) as i64,
            ]
        })
        .collect();
    // `clear`: the room kept around other dots (a label passing close by
    // another landmark reads as that landmark's).
    let free = |r: &[i64; 4], placed: &[[i64; 4]], own: usize, clear: i64| {
        r[0] >= 0
            && r[0] + r[2] <= i64::from(image.width())
            && !placed.iter().enumerate().any(|(k, p)| k != own && overlap(p, r))
            && !dots.iter().enumerate().any(|(k, d)| {
                let room = if k == own { 0 } else { clear };
                overlap(&[d[0] - room, d[1] - room, d[2] + 2 * room, d[3] + 2 * room], r)
            })
    };
    let mut placed: Vec<[i64; 4]> = Vec::new();
    let mut words: Vec<String> = Vec::new();
    for (k, m) in markers.iter().enumerate() {
        let number = m.number.to_string();
        let options = spots(m, i64::from(text::width(&number, scale)));
        let rect = options.iter().find(|r| free(r, &placed, k, 0)).unwrap_or(&options[0]);
        placed.push(*rect);
        words.push(number);
    }
    if image.width() >= 768 {
        for (k, m) in markers.iter().enumerate() {
            let Some(label) = &m.label else { continue };
            let long = format!("{} {label}", m.number);
            if let Some(r) = spots(m, i64::from(text::width(&long, scale)))
                .into_iter()
                .find(|r| free(r, &placed, k, height))
            {
                placed[k] = r;
                words[k] = long;
            }
        }
    }
    for (r, w) in placed.iter().zip(&words) {
        text::draw(image, r[0], r[1], w, Ink::dark(scale));
    }
}

/// Whether two rectangles (x, y, width, height) overlap, with a pixel between.
fn overlap(a: &[i64; 4], b: &[i64; 4]) -> bool {
    a[0] <= b[0] + b[2] && b[0] <= a[0] + a[2] && a[1] <= b[1] + b[3] && b[1] <= a[1] + a[3]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_lines_are_cut_with_an_ellipsis() {
        assert_eq!(shorten("abcdef", 6), "abcdef");
        assert_eq!(shorten("abcdefgh", 6), "abc...");
    }
}
