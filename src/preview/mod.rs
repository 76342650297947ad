//! Pictures a person can judge at a glance: the UV layout
//! ([`layout::draw_layout`]) and a flat-shaded render of the mesh with a
//! checker or its texture mapped through the new UVs ([`render::render_mesh`]).
//! Plain data in, pixels out; [`render_chart`] gives the PNG files to write.

pub mod caption;
pub mod layout;
pub mod render;
pub mod text;
pub mod texture;

use glam::DVec2;
use std::path::PathBuf;

/// Which pictures to draw of a solved chart, and their size.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Pictures {
    /// The UV layout picture (PNG).
    pub layout: Option<PathBuf>,
    /// The 3D render with a checker or the texture (PNG).
    pub render: Option<PathBuf>,
    /// Width and height in pixels.
    pub size: u32,
    /// An image drawn under the layout and through the UVs on the render in
    /// place of the material's texture: the constraint file's `image:`.
    pub background: Option<PathBuf>,
}

impl Pictures {
    /// Whether any picture is asked for.
    pub fn any(&self) -> bool {
        self.layout.is_some() || self.render.is_some()
    }

    /// The pictures drawn beside `output`: `<stem>.uv.png` and `<stem>.render.png`.
    pub fn beside(output: &std::path::Path, size: u32) -> Self {
        let stem = output
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        Pictures {
            layout: Some(output.with_file_name(format!("{stem}.uv.png"))),
            render: Some(output.with_file_name(format!("{stem}.render.png"))),
            size,
            background: None,
        }
    }
}

/// One constraint as drawn: glTF texture coordinates (u right, v down).
#[derive(Debug, Clone)]
pub struct Marker {
    /// Its number in the picture: its place in the constraint file, from 1.
    pub number: usize,
    pub label: Option<String>,
    /// Where step 1 (the bar-net) put the vertex.
    pub step1: DVec2,
    pub target: DVec2,
    /// Where the vertex ended.
    pub result: DVec2,
    pub reached: bool,
    /// Whether the arrow from step 1 to the target is drawn: on the square,
    /// where step 1 is in the layout's frame (a free or cut chart's step 1
    /// is not where anything starts).
    pub arrow: bool,
}

/// The pictures of a solved chart that `pictures` asks for, as PNG files to
/// write: the layout and the 3D render, from the chart, its outer loop, its
/// final layout (layout coordinates) and the report's constraints.
///
/// # Errors
/// A picture that cannot be encoded.
pub fn render_chart(
    asset: &crate::io::SourceAsset,
    prepared: &crate::chart::PreparedChart,
    outer_loop: &[u32],
    layout: &[DVec2],
    report: &crate::report::Report,
    pictures: &Pictures,
    written: &[[DVec2; 3]],
) -> Result<Vec<(PathBuf, Vec<u8>)>, PictureError> {
    let mut out = Vec::new();
    if !pictures.any() {
        return Ok(out);
    }
    let size = pictures.size.clamp(16, MAX_SIZE);
    let filled = &prepared.filled;
    let uvs: Vec<DVec2> = layout.iter().map(|&p| crate::param::xy_to_uv(p)).collect();
    let (texture, over) = background(asset, pictures);
    let real_triangles = &filled.mesh.triangles[..filled.n_real_triangles];
    let real_positions = &prepared.chart.mesh.positions;
    let caption = caption::Caption::of_report(report, over.as_deref());
    // Every chart's landmarks; arrows on the square's chart only.
    let on_square = matches!(prepared.domain, crate::domain::Domain::Square);
    let main = report.constraints.iter().map(|c| (c, on_square));
    let others = report.charts.iter().flat_map(|r| &r.constraints).map(|c| (c, false));
    let markers: Vec<Marker> = main
        .chain(others)
        .filter(|(c, _)| c.result.is_finite())
        .map(|(c, arrow)| Marker {
            number: c.index + 1,
            label: c.label.clone(),
            step1: c.step1,
            target: c.target,
            result: c.result,
            reached: c.reached,
            arrow,
        })
        .collect();
    if let Some(path) = &pictures.layout {
        let stretch =
            crate::metrics::triangle_stretch(real_positions, &layout[..filled.n_real_vertices], real_triangles);
        let scene = layout::LayoutScene {
            uvs: &uvs,
            triangles: &filled.mesh.triangles,
            n_real_triangles: filled.n_real_triangles,
            stretch: Some(&stretch),
            outer_loop,
            markers: &markers,
            texture: texture.as_deref(),
            written,
            rest_density: report
                .rest
                .as_ref()
                .map(|r| r.scale / crate::metrics::texture_per_mesh_length(real_positions, layout, real_triangles))
                .filter(|d| d.is_finite() && *d > 0.0),
        };
        let image = layout::draw_captioned(&scene, size, &caption);
        let png = render::encode_png(&image).map_err(|reason| PictureError::Encode {
            path: path.clone(),
            reason,
        })?;
        out.push((path.clone(), png));
    }
    if let Some(path) = &pictures.render {
        // The report lists the constraints in the order they were resolved.
        let marks: Vec<render::RenderMark> = report
            .constraints
            .iter()
            .zip(&prepared.constraint_vertices)
            .map(|(c, &vertex)| render::RenderMark {
                vertex,
                number: c.index + 1,
                reached: c.reached,
            })
            .collect();
        let scene = render::RenderScene {
            positions: real_positions,
            triangles: real_triangles,
            uvs: &uvs[..filled.n_real_vertices],
            texture: texture.as_deref(),
            marks: &marks,
            lines: &[],
            view: None,
            up: None,
        };
        let image = render::render_captioned(&scene, size, &caption);
        let png = render::encode_png(&image).map_err(|reason| PictureError::Encode {
            path: path.clone(),
            reason,
        })?;
        out.push((path.clone(), png));
    }
    Ok(out)
}

/// Where `prepared`'s chart is cut open, drawn from the front (facing the
/// landmarks) and from behind, side by side: the seams in red over the
/// grey mesh, the landmarks numbered. `size` is each view's side.
pub fn draw_seams(prepared: &crate::chart::PreparedChart, title: &str, size: u32) -> RgbaImageOut {
    let size = size.clamp(64, MAX_SIZE / 2);
    let mesh = &prepared.chart.mesh;
    let mut lines: Vec<[u32; 2]> = prepared.opening.seam.as_ref().map_or(Vec::new(), |s| s.edges.clone());
    lines.extend(
        prepared
            .opening
            .separation
            .iter()
            .filter_map(|e| Some([prepared.chart.local_of(e[0])?, prepared.chart.local_of(e[1])?])),
    );
    let normals = crate::cut::cost::vertex_normals(mesh);
    let facing = prepared
        .constraint_vertices
        .iter()
        .map(|&v| normals[v as usize])
        .sum::<glam::DVec3>()
        .try_normalize()
        .unwrap_or(glam::DVec3::NEG_Z);
    let grey = vec![DVec2::splat(0.25); mesh.n_vertices()];
    let marks: Vec<render::RenderMark> = prepared
        .constraints
        .iter()
        .zip(&prepared.constraint_vertices)
        .map(|(c, &vertex)| render::RenderMark {
            vertex,
            number: c.index + 1,
            reached: true,
        })
        .collect();
    let caption = caption::Caption {
        lines: vec![
            title.to_string(),
            format!("front (landmarks) | back; {} seam edges in red", lines.len()),
        ],
    };
    let mut out = image::RgbaImage::from_pixel(2 * size, size, image::Rgba([255, 255, 255, 255]));
    for (k, forward) in [-facing, facing].into_iter().enumerate() {
        let scene = render::RenderScene {
            positions: &mesh.positions,
            triangles: &mesh.triangles,
            uvs: &grey,
            texture: None,
            marks: &marks,
            lines: &lines,
            view: Some(forward),
            up: None,
        };
        let panel = render::render_captioned(&scene, size, &caption);
        image::imageops::overlay(&mut out, &panel, i64::from(k as u32 * size), 0);
    }
    out
}

/// A picture, in memory.
pub type RgbaImageOut = image::RgbaImage;

/// The image under the pictures: `pictures.background` when it can be read
/// (and its file name, for the title), else the material's texture.
fn background(
    asset: &crate::io::SourceAsset,
    pictures: &Pictures,
) -> (Option<std::sync::Arc<image::RgbaImage>>, Option<String>) {
    if let Some(path) = &pictures.background
        && let Ok(image) = texture::load_image(path, &asset.rules)
    {
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned());
        return (Some(std::sync::Arc::new(image)), name);
    }
    (texture::base_colour_texture(asset), None)
}

/// Draws and writes the pictures `pictures` asks for (see [`render_chart`]),
/// as `writing` allows.
///
/// # Errors
/// A picture that cannot be encoded or written.
pub fn draw_chart(
    asset: &crate::io::SourceAsset,
    prepared: &crate::chart::PreparedChart,
    outer_loop: &[u32],
    layout: &[DVec2],
    report: &crate::report::Report,
    pictures: &Pictures,
    writing: &crate::io::atomic::Writing,
) -> Result<(), PictureError> {
    let mut staged = crate::io::atomic::Staged::new().writing(writing.clone());
    for (path, png) in render_chart(asset, prepared, outer_loop, layout, report, pictures, &[])? {
        staged.add(path, png);
    }
    Ok(staged.commit()?)
}

/// Why a picture was not drawn or written.
#[derive(Debug, thiserror::Error)]
pub enum PictureError {
    #[error("cannot encode {}: {reason}", path.display())]
    Encode { path: PathBuf, reason: image::ImageError },
    #[error(transparent)]
    Write(#[from] crate::io::atomic::WriteError),
}

/// The largest picture drawn, in pixels a side.
pub const MAX_SIZE: u32 = 8192;

/// Marker colour of a reached constraint (RGB).
pub const REACHED_COLOUR: [u8; 3] = [0, 140, 255];
/// Marker colour of an unreached constraint (RGB).
pub const UNREACHED_COLOUR: [u8; 3] = [230, 0, 0];

/// The colour of a triangle of Sander L2 stretch `s`: pale green at 1
/// (isometric), yellow at 2, red from 4; magenta for a flipped triangle.
pub fn stretch_colour(s: f64) -> [u8; 3] {
    if !s.is_finite() {
        return [255, 0, 255];
    }
    let x = (s.max(1.0).log2() / 2.0).clamp(0.0, 1.0);
    let lerp = |a: [u8; 3], b: [u8; 3], t: f64| {
        [0, 1, 2].map(|i| (a[i] as f64 + (b[i] as f64 - a[i] as f64) * t).round() as u8)
    };
    let (green, yellow, red) = ([225, 245, 225], [255, 215, 110], [215, 50, 35]);
    if x < 0.5 {
        lerp(green, yellow, x * 2.0)
    } else {
        lerp(yellow, red, x * 2.0 - 1.0)
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_stretch_ramp_runs_green_yellow_red() {
        assert_eq!(super::stretch_colour(1.0), [225, 245, 225]);
        assert_eq!(super::stretch_colour(2.0), [255, 215, 110]);
        assert_eq!(super::stretch_colour(10.0), [215, 50, 35]);
        assert_eq!(super::stretch_colour(f64::INFINITY), [255, 0, 255]);
    }
}
