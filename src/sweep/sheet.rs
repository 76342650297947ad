//! The contact sheet: one thumbnail per run, a status bar under each.

use super::{Row, Run};
use std::collections::HashMap;
use std::path::Path;

/// Status colour under each thumbnail of the contact sheet.
pub fn status_colour(status: &str) -> [u8; 3] {
    match status {
        "reached" => [40, 170, 70],
        "partial" => [240, 160, 30],
        "folded" => [200, 0, 200],
        _ => [200, 30, 30],
    }
}

/// One thumbnail per run: a row per (file, setting, jitter sample), a
/// column per blend value, each with a status bar (green reached, orange
/// partial, magenta folded, red error). Rows are labelled with their
/// setting (and file and sample when there are several), columns with
/// their blend, and a key below names the bar colours.
pub fn contact_sheet(runs: &[Run], rows: &[Row], thumbs: &Path, size: u32) -> image::RgbaImage {
    use crate::preview::text::{self, Ink};
    use image::{Rgba, RgbaImage};
    let columns = runs.iter().map(|r| r.blend_index).max().map_or(1, |m| m + 1) as u32;
    let n_rows = (runs.len() as u32).div_ceil(columns.max(1));
    let (gap, bar) = (4u32, 6u32);
    let line = text::line_height(1);
    let row_names: Vec<String> = runs
        .iter()
        .step_by(columns as usize)
        .map(|r| row_name(r, runs))
        .collect();
    let label_w = row_names.iter().map(|n| text::width(n, 1)).max().unwrap_or(0) + 2 * gap;
    let key = "bar: reached  partial  folded  error";
    let (cell_w, cell_h) = (size + gap, size + bar + gap);
    let width = (label_w + columns * cell_w + gap).max(text::width(key, 1) + 10 * text::GLYPH);
    let mut sheet = RgbaImage::from_pixel(
        width,
        line + n_rows * cell_h + gap + line + gap,
        Rgba([255, 255, 255, 255]),
    );
    let ink = Ink::dark(1);
    let by_id: HashMap<&str, &Row> = rows.iter().map(|r| (r.id.as_str(), r)).collect();
    for (k, run) in runs.iter().enumerate() {
        let (col, row_k) = (k as u32 % columns, k as u32 / columns);
        let (cx, cy) = (label_w + col * cell_w + gap, line + row_k * cell_h + gap);
        if row_k == 0 {
            text::draw(&mut sheet, i64::from(cx), 2, &format!("blend {}", run.blend), ink);
        }
        if col == 0 {
            let y = i64::from(cy + size / 2) - i64::from(text::GLYPH / 2);
            text::draw(&mut sheet, i64::from(gap), y, &row_names[row_k as usize], ink);
        }
        let row = by_id.get(run.id.as_str());
        let thumb = row
            .and_then(|r| r.thumbnail.as_ref())
            .and_then(|t| image::open(thumbs.join(t)).ok())
            .map(|i| i.to_rgba8());
        for y in 0..size {
            for x in 0..size {
                let p = thumb
                    .as_ref()
                    .and_then(|t| t.get_pixel_checked(x, y).copied())
                    .unwrap_or(Rgba([225, 225, 225, 255]));
                sheet.put_pixel(cx + x, cy + y, p);
            }
        }
        let colour = status_colour(row.map_or("error", |r| r.status.as_str()));
        text::fill_rect(&mut sheet, i64::from(cx), i64::from(cy + size), size, bar, colour, 255);
    }
    let key_y = i64::from(sheet.height() - line);
    draw_bar_key(&mut sheet, i64::from(gap), key_y);
    sheet
}

/// How a contact-sheet row is named: its setting, with the file and the
/// jitter sample when the sweep has several of them.
fn row_name(run: &Run, runs: &[Run]) -> String {
    let mut name = run.setting.name.clone();
    if runs.iter().any(|r| r.file_index != run.file_index) {
        name = format!("file {} {name}", run.file_index + 1);
    }
    if let Some(sample) = run.sample {
        name += &format!(" #{sample}");
    }
    // A long name is cut: the sheet's size stays bounded by its thumbnails.
    if name.chars().count() > 40 {
        name = name.chars().take(37).collect::<String>() + "...";
    }
    name
}

/// The key of the status bars: a swatch and a word for each status.
fn draw_bar_key(sheet: &mut image::RgbaImage, mut x: i64, y: i64) {
    use crate::preview::text::{self, Ink};
    x += i64::from(text::draw(sheet, x, y, "bar: ", Ink::dark(1)));
    for status in ["reached", "partial", "folded", "error"] {
        text::fill_rect(sheet, x, y, text::GLYPH * 2, text::GLYPH, status_colour(status), 255);
        x += i64::from(text::GLYPH * 2 + 4);
        x += i64::from(text::draw(sheet, x, y, &format!("{status}   "), Ink::dark(1)));
    }
}
