//! The UV layout picture: the unit square (over the base-colour texture when
//! there is one), every triangle coloured by its stretch, holes shaded, the
//! outer boundary drawn, the rest of the written UV set in grey with each
//! chart outlined, and each constraint as a dot where it ended (red if
//! unreached), with an arrow from its step-1 position to its target on the
//! square (where step 1 is in the same frame).

use super::{Marker, REACHED_COLOUR, UNREACHED_COLOUR, stretch_colour};
use glam::DVec2;
use tiny_skia::{Color, FillRule, LineCap, LineJoin, Paint, PathBuilder, Pixmap, Stroke, Transform};

/// What the layout picture shows. Coordinates are glTF texture coordinates.
#[derive(Debug, Clone, Copy)]
pub struct LayoutScene<'a> {
    /// One UV per vertex of `triangles`.
    pub uvs: &'a [DVec2],
    pub triangles: &'a [[u32; 3]],
    /// Which triangles are virtual (hole fill): those from this index on.
    pub n_real_triangles: usize,
    /// Stretch per real triangle (colour ramp), if known.
    pub stretch: Option<&'a [f64]>,
    /// The outer boundary loop (vertex ids).
    pub outer_loop: &'a [u32],
    pub markers: &'a [Marker],
    /// The base-colour texture, drawn under the triangles.
    pub texture: Option<&'a image::RgbaImage>,
    /// Every triangle of the written UV set (texture coordinates): the
    /// other charts, drawn in grey under the chart, each outlined.
    pub written: &'a [[DVec2; 3]],
    /// The other charts' texel density over the chart's (texture length per
    /// mesh length), when some were packed beside it.
    pub rest_density: Option<f64>,
}

/// Margin around the square, pixels, for a picture of `size`.
pub fn margin(size: u32) -> f32 {
    (size as f32 / 32.0).max(4.0)
}

/// Pictures of at least this size carry a title band above the square and a
/// legend band below it; thumbnails (sweeps) are the layout alone.
pub const CAPTIONED_FROM: u32 = 256;

/// Lines of the title band (file and status; landmarks; stretch and time).
pub const TITLE_LINES: u32 = 3;
/// Lines of the legend band (the stretch ramp; the marker key).
pub const LEGEND_LINES: u32 = 2;

/// Where the unit square sits in a layout picture of `size`: its top-left
/// pixel and its side. Depends on the size alone, so a reader of the PNG
/// can find any texture coordinate with [`uv_to_pixel`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    pub left: f32,
    pub top: f32,
    pub span: f32,
}

/// The frame of a layout picture of `size` pixels a side.
pub fn frame(size: u32) -> Frame {
    let m = margin(size);
    let (title, legend) = if size >= CAPTIONED_FROM {
        let line = super::text::line_height(super::text::scale_for(size)) as f32;
        (TITLE_LINES as f32 * line, LEGEND_LINES as f32 * line)
    } else {
        (0.0, 0.0)
    };
    let span = (size as f32 - 2.0 * m - title - legend).max(1.0);
    Frame {
        left: (size as f32 - span) / 2.0,
        top: m + title,
        span,
    }
}

/// The pixel centre of texture coordinate `uv` in a layout picture of `size`.
pub fn uv_to_pixel(uv: DVec2, size: u32) -> (f32, f32) {
    let f = frame(size);
    (f.left + uv.x as f32 * f.span, f.top + uv.y as f32 * f.span)
}

fn paint(rgb: [u8; 3], alpha: u8) -> Paint<'static> {
    let mut p = Paint::default();
    p.set_color(Color::from_rgba8(rgb[0], rgb[1], rgb[2], alpha));
    p.anti_alias = true;
    p
}

/// Draws the layout picture, `size` × `size` pixels.
///
/// # Panics
/// If `size` is 0.
pub fn draw_layout(scene: &LayoutScene, size: u32) -> Pixmap {
    let mut pixmap = Pixmap::new(size, size).expect("non-zero size");
    pixmap.fill(Color::WHITE);
    draw_background(&mut pixmap, scene, size);
    draw_written(&mut pixmap, scene, size);
    draw_triangles(&mut pixmap, scene, size);
    draw_outer_loop(&mut pixmap, scene, size);
    // Constraints: arrows first, then dots on top.
    let radius = (size as f32 / 110.0).max(3.0);
    draw_arrows(&mut pixmap, scene, size, radius);
    draw_markers(&mut pixmap, scene, size, radius);
    pixmap
}

/// Draws the layout picture with its words (on pictures of at least
/// [`CAPTIONED_FROM`] px): `caption` above, the legend below, and each
/// landmark's number beside its target.
pub fn draw_captioned(scene: &LayoutScene, size: u32, caption: &super::caption::Caption) -> image::RgbaImage {
    let mut image = to_image(&draw_layout(scene, size));
    if size < CAPTIONED_FROM {
        return image;
    }
    let radius = (size as f32 / 110.0).max(3.0);
    super::caption::draw_numbers(&mut image, scene.markers, radius, |uv| uv_to_pixel(uv, size));
    // The dots again, over any number that came near them.
    for m in scene.markers {
        let (x, y) = uv_to_pixel(m.result, size);
        let colour = if m.reached { REACHED_COLOUR } else { UNREACHED_COLOUR };
        super::text::disc(
            &mut image,
            f64::from(x),
            f64::from(y),
            f64::from(radius),
            colour,
            [255, 255, 255],
        );
    }
    super::caption::draw_title(&mut image, caption, margin(size));
    let holes = scene.triangles.len() > scene.n_real_triangles;
    let arrows = scene.markers.iter().any(|m| m.arrow);
    let others = scene.written.len() > scene.n_real_triangles;
    let more = match (arrows, others) {
        (true, false) => "arrow: step 1 -> target",
        (true, true) => "arrow: step 1 -> target   grey: other charts",
        (false, true) => "grey: other charts",
        (false, false) => "",
    };
    let density = scene.rest_density.map(|d| format!("grey: {}x texels", significant(d)));
    super::caption::draw_layout_legend(&mut image, margin(size), holes, density.as_deref(), more);
    image
}

/// `x` with two significant digits (0.071, 1.3, 12).
fn significant(x: f64) -> String {
    let digits = (1.0 - x.abs().max(1e-9).log10().floor()).max(0.0) as usize;
    format!("{x:.digits$}")
}

/// The texture (or a light grey square) under the layout.
fn draw_background(pixmap: &mut Pixmap, scene: &LayoutScene, size: u32) {
    let Frame { left, top, span } = frame(size);
    let square = tiny_skia::Rect::from_xywh(left, top, span, span).expect("square");
    match scene.texture.and_then(texture_pixmap) {
        Some(tex) => {
            let sx = span / tex.width() as f32;
            let sy = span / tex.height() as f32;
            pixmap.draw_pixmap(
                0,
                0,
                tex.as_ref(),
                &tiny_skia::PixmapPaint {
                    quality: tiny_skia::FilterQuality::Bilinear,
                    ..Default::default()
                },
                Transform::from_row(sx, 0.0, 0.0, sy, left, top),
                None,
            );
        }
        None => pixmap.fill_rect(square, &paint([242, 242, 242], 255), Transform::identity(), None),
    }
}

/// The triangles coloured by stretch (virtual hole triangles shaded), and
/// their edges where they are big enough to see (about 8 px² or more).
/// The whole written UV set under the chart: grey triangles, and the
/// outline of every chart (the edges only one triangle has, by their two
/// texture coordinates).
fn draw_written(pixmap: &mut Pixmap, scene: &LayoutScene, size: u32) {
    if scene.written.is_empty() {
        return;
    }
    let px = |uv: DVec2| uv_to_pixel(uv, size);
    let key = |p: DVec2| (p.x.to_bits(), p.y.to_bits());
    let point = |(x, y): (u64, u64)| DVec2::new(f64::from_bits(x), f64::from_bits(y));
    // Ordered: the same picture on every run (strokes drawn in one order).
    let mut uses: std::collections::BTreeMap<[(u64, u64); 2], u32> = std::collections::BTreeMap::new();
    let mut fill = PathBuilder::new();
    for t in scene.written.iter().filter(|t| t.iter().all(|p| p.is_finite())) {
        let [a, b, c] = t.map(px);
        fill.move_to(a.0, a.1);
        fill.line_to(b.0, b.1);
        fill.line_to(c.0, c.1);
        fill.close();
        for k in 0..3 {
            let mut e = [key(t[k]), key(t[(k + 1) % 3])];
            e.sort_unstable();
            *uses.entry(e).or_default() += 1;
        }
    }
    let grey = if scene.texture.is_some() { 90 } else { 255 };
    if let Some(path) = fill.finish() {
        pixmap.fill_path(
            &path,
            &paint([214, 218, 226], grey),
            FillRule::Winding,
            Transform::identity(),
            None,
        );
    }
    let mut outline = PathBuilder::new();
    for [p, q] in uses.iter().filter(|e| *e.1 == 1).map(|e| *e.0) {
        let (a, b) = (px(point(p)), px(point(q)));
        outline.move_to(a.0, a.1);
        outline.line_to(b.0, b.1);
    }
    if let Some(path) = outline.finish() {
        let stroke = Stroke {
            width: (size as f32 / 700.0).max(0.75),
            ..Default::default()
        };
        pixmap.stroke_path(&path, &paint([90, 98, 120], 255), &stroke, Transform::identity(), None);
    }
}

fn draw_triangles(pixmap: &mut Pixmap, scene: &LayoutScene, size: u32) {
    let px = |uv: DVec2| uv_to_pixel(uv, size);
    let textured = scene.texture.is_some();
    let many = scene.triangles.len() as u64 * 8 > u64::from(size) * u64::from(size);
    // One path per fill colour (and one for all edges): triangles of a
    // fold-free layout do not overlap, so filling them together is the same
    // picture without seams, and much faster on big meshes.
    let mut fills: std::collections::BTreeMap<[u8; 4], PathBuilder> = std::collections::BTreeMap::new();
    let mut edges = PathBuilder::new();
    let triangle = |pb: &mut PathBuilder, [a, b, c]: [(f32, f32); 3]| {
        pb.move_to(a.0, a.1);
        pb.line_to(b.0, b.1);
        pb.line_to(c.0, c.1);
        pb.close();
    };
    for (i, t) in scene.triangles.iter().enumerate() {
        let corners = t.map(|v| px(scene.uvs[v as usize]));
        let virtual_triangle = i >= scene.n_real_triangles;
        let key = if virtual_triangle {
            [110, 110, 120, 140]
        } else {
            let s = scene.stretch.and_then(|s| s.get(i).copied()).unwrap_or(1.0);
            let [r, g, b] = stretch_colour(s);
            [r, g, b, if textured { 110 } else { 255 }]
        };
        triangle(fills.entry(key).or_default(), corners);
        if !many && !virtual_triangle {
            triangle(&mut edges, corners);
        }
    }
    for (key, pb) in fills {
        if let Some(path) = pb.finish() {
            let fill = paint([key[0], key[1], key[2]], key[3]);
            pixmap.fill_path(&path, &fill, FillRule::Winding, Transform::identity(), None);
        }
    }
    if let Some(path) = edges.finish() {
        let edge = Stroke {
            width: 0.5,
            ..Default::default()
        };
        pixmap.stroke_path(&path, &paint([40, 40, 40], 90), &edge, Transform::identity(), None);
    }
}

/// The outer boundary as a dark blue line.
fn draw_outer_loop(pixmap: &mut Pixmap, scene: &LayoutScene, size: u32) {
    let px = |uv: DVec2| uv_to_pixel(uv, size);
    let Some((&first, rest)) = scene.outer_loop.split_first() else {
        return;
    };
    let mut pb = PathBuilder::new();
    let p0 = px(scene.uvs[first as usize]);
    pb.move_to(p0.0, p0.1);
    for &v in rest {
        let p = px(scene.uvs[v as usize]);
        pb.line_to(p.0, p.1);
    }
    pb.close();
    if let Some(path) = pb.finish() {
        let stroke = Stroke {
            width: (size as f32 / 256.0).max(1.5),
            line_join: LineJoin::Round,
            ..Default::default()
        };
        pixmap.stroke_path(&path, &paint([20, 40, 120], 255), &stroke, Transform::identity(), None);
    }
}

/// An arrow from each constraint's step-1 position to its target.
fn draw_arrows(pixmap: &mut Pixmap, scene: &LayoutScene, size: u32, radius: f32) {
    let px = |uv: DVec2| uv_to_pixel(uv, size);
    let arrow = Stroke {
        width: (size as f32 / 400.0).max(1.0),
        line_cap: LineCap::Round,
        ..Default::default()
    };
    for mk in scene.markers.iter().filter(|m| m.arrow) {
        let (s, t) = (px(mk.step1), px(mk.target));
        let (dx, dy) = (t.0 - s.0, t.1 - s.1);
        let len = (dx * dx + dy * dy).sqrt();
        if len <= 1.0 {
            continue;
        }
        let mut pb = PathBuilder::new();
        pb.move_to(s.0, s.1);
        pb.line_to(t.0, t.1);
        let (ux, uy) = (dx / len, dy / len);
        let head = (radius * 1.6).min(len * 0.5);
        for side in [-1.0f32, 1.0] {
            pb.move_to(t.0, t.1);
            pb.line_to(
                t.0 - head * (ux * 0.87 - side * uy * 0.5),
                t.1 - head * (uy * 0.87 + side * ux * 0.5),
            );
        }
        if let Some(path) = pb.finish() {
            pixmap.stroke_path(&path, &paint([25, 25, 25], 230), &arrow, Transform::identity(), None);
        }
    }
}

/// A dot where each constraint ended (red, with a ring on its target, if unreached).
fn draw_markers(pixmap: &mut Pixmap, scene: &LayoutScene, size: u32, radius: f32) {
    let px = |uv: DVec2| uv_to_pixel(uv, size);
    let thin = |width: f32| Stroke {
        width,
        ..Default::default()
    };
    for mk in scene.markers {
        let colour = if mk.reached { REACHED_COLOUR } else { UNREACHED_COLOUR };
        if !mk.reached {
            let t = px(mk.target);
            if let Some(ring) = PathBuilder::from_circle(t.0, t.1, radius * 1.4) {
                pixmap.stroke_path(&ring, &paint(colour, 255), &thin(1.5), Transform::identity(), None);
            }
        }
        let r = px(mk.result);
        if let Some(dot) = PathBuilder::from_circle(r.0, r.1, radius) {
            pixmap.fill_path(
                &dot,
                &paint(colour, 255),
                FillRule::Winding,
                Transform::identity(),
                None,
            );
            pixmap.stroke_path(
                &dot,
                &paint([255, 255, 255], 255),
                &thin(1.0),
                Transform::identity(),
                None,
            );
        }
    }
}

/// An RGBA image as a premultiplied tiny-skia pixmap.
fn texture_pixmap(image: &image::RgbaImage) -> Option<Pixmap> {
    let mut p = Pixmap::new(image.width(), image.height())?;
    for (dst, src) in p.pixels_mut().iter_mut().zip(image.pixels()) {
        let [r, g, b, a] = src.0;
        *dst = tiny_skia::ColorU8::from_rgba(r, g, b, a).premultiply();
    }
    Some(p)
}

/// The pixmap as a straight-alpha RGBA image (for the PNG encoder).
pub fn to_image(pixmap: &Pixmap) -> image::RgbaImage {
    let mut out = image::RgbaImage::new(pixmap.width(), pixmap.height());
    for (dst, src) in out.pixels_mut().zip(pixmap.pixels()) {
        let c = src.demultiply();
        *dst = image::Rgba([c.red(), c.green(), c.blue(), c.alpha()]);
    }
    out
}
