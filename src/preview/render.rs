//! A flat-shaded render of the mesh with a checker (or the texture) mapped
//! through its UVs, from a default view: orthographic, looking against the
//! mesh's area-weighted mean normal (the "front" of an open patch), z-buffered.
//! Stretch shows as uneven checker squares, folds as torn ones.

use glam::{DVec2, DVec3};
use image::{Rgba, RgbaImage};

/// Checker squares per texture side.
pub const CHECKER_SQUARES: f64 = 10.0;

/// The white margin around the mesh in a render of `size`, pixels.
fn margin(size: u32) -> f64 {
    f64::from(size) * 0.05
}

/// A landmark marked on the render: its chart vertex and number.
#[derive(Debug, Clone, Copy)]
pub struct RenderMark {
    pub vertex: u32,
    pub number: usize,
    pub reached: bool,
}

/// What the render shows: triangles of `positions` with texture coordinates
/// `uvs` (glTF, one per vertex), the texture (else a checker), the landmarks.
#[derive(Debug, Clone, Copy)]
pub struct RenderScene<'a> {
    pub positions: &'a [DVec3],
    pub triangles: &'a [[u32; 3]],
    pub uvs: &'a [DVec2],
    pub texture: Option<&'a RgbaImage>,
    pub marks: &'a [RenderMark],
    /// Edges drawn over the mesh where they are in view (seams), as
    /// vertex pairs.
    pub lines: &'a [[u32; 2]],
    /// The direction the view looks along (default: against the mesh's
    /// mean normal).
    pub view: Option<DVec3>,
    /// The direction shown up (default: the world's +Y, or +Z when
    /// looking nearly along Y).
    pub up: Option<DVec3>,
}

/// Renders `triangles` of `positions` with texture coordinates `uvs` (glTF,
/// one per vertex), `size` × `size` pixels, over white.
pub fn render_mesh(
    positions: &[DVec3],
    triangles: &[[u32; 3]],
    uvs: &[DVec2],
    texture: Option<&RgbaImage>,
    size: u32,
) -> RgbaImage {
    let scene = RenderScene {
        positions,
        triangles,
        uvs,
        texture,
        marks: &[],
        lines: &[],
        view: None,
        up: None,
    };
    rasterise(&scene, size, (0.0, 0.0)).image
}

/// A render to find things on: the picture, which triangle each pixel
/// shows (row by row, `None` where none), and where each vertex lands
/// (pixel coordinates, x right, y down; pixel `(i, j)` spans
/// `i..i + 1`, `j..j + 1`).
#[derive(Debug, Clone)]
pub struct ViewRender {
    pub image: RgbaImage,
    pub triangle: Vec<Option<u32>>,
    pub screen: Vec<DVec2>,
}

/// `scene` rendered `size` × `size` pixels over white, with which triangle
/// each pixel shows: the photo workflow finds a face on the render and
/// carries each point back to the surface through it.
pub fn render_view(scene: &RenderScene, size: u32) -> ViewRender {
    let drawn = rasterise(scene, size, (0.0, 0.0));
    ViewRender {
        image: drawn.image,
        triangle: drawn.triangle,
        screen: drawn.screen,
    }
}

/// The render with its words (on pictures of at least
/// [`super::layout::CAPTIONED_FROM`] px): the title above, the legend below,
/// and each landmark as a numbered dot (a ring when it is hidden behind the
/// mesh).
pub fn render_captioned(scene: &RenderScene, size: u32, caption: &super::caption::Caption) -> RgbaImage {
    use super::text;
    if size < super::layout::CAPTIONED_FROM {
        return rasterise(scene, size, (0.0, 0.0)).image;
    }
    let scale = text::scale_for(size);
    let line = f64::from(text::line_height(scale));
    let Drawn { mut image, marks, .. } = rasterise(scene, size, (line * caption.lines.len() as f64, line));
    let radius = (f64::from(size) / 110.0).max(3.0);
    for m in &marks {
        let colour = if m.reached {
            super::REACHED_COLOUR
        } else {
            super::UNREACHED_COLOUR
        };
        let (fill, ring) = if m.visible {
            (colour, [255, 255, 255])
        } else {
            ([255, 255, 255], colour)
        };
        text::disc(&mut image, m.x, m.y, radius, fill, ring);
        let at = (m.x + radius * 1.3) as i64;
        text::draw(
            &mut image,
            at,
            (m.y - radius * 1.3) as i64 - i64::from(text::GLYPH * scale),
            &m.number.to_string(),
            text::Ink::dark(scale),
        );
    }
    let margin = margin(size);
    super::caption::draw_title(&mut image, caption, margin as f32);
    let what = if scene.texture.is_some() {
        "texture through the UVs"
    } else {
        "even checker = low stretch"
    };
    let y = i64::from(size) - margin as i64 - line as i64 + (line as i64) / 4;
    super::caption::draw_marker_key(&mut image, margin as i64, y, scale, &format!("ring: hidden   {what}"));
    image
}

/// A landmark where the render put it: pixel centre, and whether it is in
/// front (not hidden behind another part of the mesh).
#[derive(Debug, Clone, Copy)]
struct PlacedMark {
    x: f64,
    y: f64,
    visible: bool,
    number: usize,
    reached: bool,
}

/// A z-buffered render: the picture, where each landmark landed, which
/// triangle each pixel shows and where each vertex landed.
struct Drawn {
    image: RgbaImage,
    marks: Vec<PlacedMark>,
    triangle: Vec<Option<u32>>,
    screen: Vec<DVec2>,
}

/// The z-buffered render, leaving `bands` (top, bottom) pixels free for
/// words.
fn rasterise(scene: &RenderScene, size: u32, bands: (f64, f64)) -> Drawn {
    let (positions, triangles) = (scene.positions, scene.triangles);
    let image = RgbaImage::from_pixel(size, size, Rgba([255, 255, 255, 255]));
    let mut drawn = Drawn {
        image,
        marks: Vec::new(),
        triangle: vec![None; (size as usize) * (size as usize)],
        screen: Vec::new(),
    };
    if triangles.is_empty() || size == 0 {
        return drawn;
    }
    let (right, up, forward) = match scene.view {
        Some(v) => basis_along(v, scene.up),
        None => view_basis(positions, triangles),
    };
    let project = |p: DVec3| DVec3::new(p.dot(right), p.dot(up), p.dot(forward));
    let projected: Vec<DVec3> = positions.iter().map(|&p| project(p)).collect();
    let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
    for t in triangles {
        for &v in t {
            let p = projected[v as usize].truncate();
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    let margin = margin(size);
    let extent = (hi - lo).max_element().max(1e-12);
    let room = (size as f64 - 2.0 * margin - bands.0 - bands.1).max(1.0);
    let scale = room / extent;
    let centre = (lo + hi) * 0.5;
    let (half_x, half_y) = (size as f64 * 0.5, margin + bands.0 + room * 0.5);
    // Screen: x right, y down.
    let screen = |p: DVec3| {
        DVec3::new(
            half_x + (p.x - centre.x) * scale,
            half_y - (p.y - centre.y) * scale,
            p.z,
        )
    };
    let mut depth = vec![f64::INFINITY; (size * size) as usize];
    for (k, t) in triangles.iter().enumerate() {
        let corners = t.map(|v| screen(projected[v as usize]));
        let mut target = Target {
            image: &mut drawn.image,
            depth: &mut depth,
            triangle: &mut drawn.triangle,
        };
        fill_triangle(&mut target, scene, (k as u32, *t), corners, forward);
    }
    let tolerance = 1e-3 * (hi - lo).length().max(1e-12) + 2.0 / scale;
    for line in scene.lines {
        let [a, b] = line.map(|v| screen(projected[v as usize]));
        draw_line(&mut drawn.image, &depth, a, b, tolerance);
    }
    drawn.screen = projected.iter().map(|&p| screen(p).truncate()).collect();
    drawn.marks = scene
        .marks
        .iter()
        .filter_map(|m| {
            let p = screen(*projected.get(m.vertex as usize)?);
            let (x, y) = (p.x.floor(), p.y.floor());
            let inside = x >= 0.0 && y >= 0.0 && x < size as f64 && y < size as f64;
            let front = inside && p.z <= depth[(y as u32 * size + x as u32) as usize] + tolerance;
            Some(PlacedMark {
                x: p.x,
                y: p.y,
                visible: front,
                number: m.number,
                reached: m.reached,
            })
        })
        .collect();
    drawn
}

/// Where a triangle is drawn: the picture, its depth and triangle buffers.
struct Target<'a> {
    image: &'a mut RgbaImage,
    depth: &'a mut [f64],
    triangle: &'a mut [Option<u32>],
}

/// Draws triangle `k` (`t`), lit by its normal against the view, z-buffered.
fn fill_triangle(
    target: &mut Target,
    scene: &RenderScene,
    (k, t): (u32, [u32; 3]),
    [a, b, c]: [DVec3; 3],
    forward: DVec3,
) {
    let size = target.image.width();
    let [pa, pb, pc] = t.map(|v| scene.positions[v as usize]);
    let normal = (pb - pa).cross(pc - pa);
    if normal.length_squared() == 0.0 {
        return;
    }
    let light = 0.3 + 0.7 * normal.normalize().dot(forward).abs();
    let [ua, ub, uc] = t.map(|v| scene.uvs[v as usize]);
    let area = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
    if area.abs() < 1e-12 {
        return;
    }
    let x0 = a.x.min(b.x).min(c.x).floor().max(0.0) as u32;
    let x1 = (a.x.max(b.x).max(c.x).ceil() as i64).clamp(0, size as i64 - 1) as u32;
    let y0 = a.y.min(b.y).min(c.y).floor().max(0.0) as u32;
    let y1 = (a.y.max(b.y).max(c.y).ceil() as i64).clamp(0, size as i64 - 1) as u32;
    for y in y0..=y1 {
        for x in x0..=x1 {
            let (sx, sy) = (x as f64 + 0.5, y as f64 + 0.5);
            let w0 = ((b.x - sx) * (c.y - sy) - (c.x - sx) * (b.y - sy)) / area;
            let w1 = ((c.x - sx) * (a.y - sy) - (a.x - sx) * (c.y - sy)) / area;
            let w2 = 1.0 - w0 - w1;
            if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                continue;
            }
            let z = w0 * a.z + w1 * b.z + w2 * c.z;
            let at = (y * size + x) as usize;
            if z >= target.depth[at] {
                continue;
            }
            target.depth[at] = z;
            target.triangle[at] = Some(k);
            let uv = ua * w0 + ub * w1 + uc * w2;
            let base = match scene.texture {
                Some(tex) => sample(tex, uv),
                None => checker(uv),
            };
            let shaded = base.map(|ch| (ch as f64 * light).round().clamp(0.0, 255.0) as u8);
            target
                .image
                .put_pixel(x, y, Rgba([shaded[0], shaded[1], shaded[2], 255]));
        }
    }
}

/// A seam's colour.
const LINE_COLOUR: Rgba<u8> = Rgba([220, 20, 60, 255]);

/// Draws the segment `a`–`b` (screen x, y, depth) three pixels wide where
/// it is not behind the mesh.
fn draw_line(image: &mut RgbaImage, depth: &[f64], a: DVec3, b: DVec3, tolerance: f64) {
    let size = image.width() as i64;
    let steps = ((b - a).truncate().length().ceil() as usize).max(1);
    for k in 0..=steps {
        let p = a.lerp(b, k as f64 / steps as f64);
        for (dx, dy) in [(0, 0), (1, 0), (0, 1), (-1, 0), (0, -1)] {
            let (x, y) = (p.x.floor() as i64 + dx, p.y.floor() as i64 + dy);
            if x < 0 || y < 0 || x >= size || y >= size {
                continue;
            }
            if p.z <= depth[(y * size + x) as usize] + tolerance {
                image.put_pixel(x as u32, y as u32, LINE_COLOUR);
            }
        }
    }
}

/// The view looking along `forward`: right, up and forward unit vectors,
/// up from `up` where given and not along the view, else the world's +Y
/// (or +Z when looking nearly along Y).
fn basis_along(forward: DVec3, up: Option<DVec3>) -> (DVec3, DVec3, DVec3) {
    let forward = forward.normalize_or(DVec3::NEG_Z);
    let world_up = match up.map(|u| u.normalize_or_zero()) {
        Some(u) if u.cross(forward).length() > 0.1 => u,
        _ if forward.y.abs() > 0.9 => DVec3::Z,
        _ => DVec3::Y,
    };
    let right = forward.cross(world_up).normalize();
    (right, right.cross(forward).normalize(), forward)
}

/// The view: right, up and forward (into the screen) unit vectors. Forward
/// is against the area-weighted mean normal; up is the world's +Y projected
/// (or +Z when forward is nearly vertical).
fn view_basis(positions: &[DVec3], triangles: &[[u32; 3]]) -> (DVec3, DVec3, DVec3) {
    let mut sum = DVec3::ZERO;
    let mut total = 0.0;
    for t in triangles {
        let [a, b, c] = t.map(|v| positions[v as usize]);
        let n = (b - a).cross(c - a);
        sum += n;
        total += n.length();
    }
    let front = if total > 0.0 && sum.length() > 0.1 * total {
        sum.normalize()
    } else {
        DVec3::Z
    };
    let forward = -front;
    let world_up = if forward.y.abs() > 0.9 { DVec3::Z } else { DVec3::Y };
    let right = forward.cross(world_up).normalize();
    let up = right.cross(forward).normalize();
    (right, up, forward)
}

fn checker(uv: DVec2) -> [u8; 3] {
    let (i, j) = (
        (uv.x * CHECKER_SQUARES).floor() as i64,
        (uv.y * CHECKER_SQUARES).floor() as i64,
    );
    if (i + j).rem_euclid(2) == 0 {
        [235, 235, 235]
    } else {
        [70, 110, 190]
    }
}

fn sample(tex: &RgbaImage, uv: DVec2) -> [u8; 3] {
    let (w, h) = (tex.width(), tex.height());
    let x = ((uv.x.rem_euclid(1.0)) * w as f64).floor().clamp(0.0, w as f64 - 1.0) as u32;
    let y = ((uv.y.rem_euclid(1.0)) * h as f64).floor().clamp(0.0, h as f64 - 1.0) as u32;
    let p = tex.get_pixel(x, y).0;
    [p[0], p[1], p[2]]
}

/// Encodes an RGBA image as PNG bytes, with fast compression: pictures
/// are redrawn on every daemon write and every sweep run.
///
/// # Errors
/// The encoder's.
pub fn encode_png(image: &RgbaImage) -> Result<Vec<u8>, image::ImageError> {
    use image::ImageEncoder;
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    let mut out = Vec::new();
    PngEncoder::new_with_quality(&mut out, CompressionType::Fast, FilterType::Adaptive).write_image(
        image.as_raw(),
        image.width(),
        image.height(),
        image::ExtendedColorType::Rgba8,
    )?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::grid_mesh;

    #[test]
    fn a_flat_grid_seen_from_the_front_fills_the_middle_with_the_checker() {
        let m = grid_mesh(6, 6);
        let uvs: Vec<DVec2> = m.positions.iter().map(|p| DVec2::new(p.x, 1.0 - p.y)).collect();
        let img = render_mesh(&m.positions, &m.triangles, &uvs, None, 100);
        // The grid faces +Z, so it fills 90 % of the picture; corners stay white.
        assert_eq!(img.get_pixel(1, 1).0, [255, 255, 255, 255]);
        let centre = img.get_pixel(50, 50).0;
        assert!(centre != [255, 255, 255, 255], "{centre:?}");
        // Lit head-on: full checker colours.
        let colours: std::collections::HashSet<[u8; 4]> = (10..90).map(|x| img.get_pixel(x, 50).0).collect();
        assert!(
            colours.contains(&[235, 235, 235, 255]) && colours.contains(&[70, 110, 190, 255]),
            "{colours:?}"
        );
    }

    #[test]
    fn a_view_render_says_which_triangle_each_pixel_shows_and_keeps_up_on_top() {
        let m = grid_mesh(4, 8);
        let uvs = vec![DVec2::ZERO; m.positions.len()];
        let scene = RenderScene {
            positions: &m.positions,
            triangles: &m.triangles,
            uvs: &uvs,
            texture: None,
            marks: &[],
            lines: &[],
            view: Some(DVec3::NEG_Z),
            up: Some(DVec3::X),
        };
        let r = render_view(&scene, 64);
        // +X shown up: vertices with larger x are higher on screen (smaller y).
        let (lo, hi) = (
            m.positions.iter().position(|p| p.x == 0.0).unwrap(),
            m.positions.iter().position(|p| p.x == 1.0).unwrap(),
        );
        assert!(r.screen[hi].y < r.screen[lo].y, "{:?} {:?}", r.screen[hi], r.screen[lo]);
        // Every covered pixel's centre lies in the triangle it names.
        let mut covered = 0;
        for (at, t) in r.triangle.iter().enumerate() {
            let Some(t) = t else { continue };
            covered += 1;
            let p = DVec2::new((at % 64) as f64 + 0.5, (at / 64) as f64 + 0.5);
            let [a, b, c] = m.triangles[*t as usize].map(|v| r.screen[v as usize]);
            let side = |u: DVec2, v: DVec2| (v - u).perp_dot(p - u);
            let s = [side(a, b), side(b, c), side(c, a)];
            assert!(
                s.iter().all(|&x| x >= -1e-9) || s.iter().all(|&x| x <= 1e-9),
                "pixel {at} not in {t}"
            );
        }
        assert!(covered > 64 * 64 / 2, "{covered}");
        assert_eq!(r.triangle[0], None);
    }
}
