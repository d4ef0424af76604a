//! Heat maps (phase diagrams) over a regular grid, with overlays and a colour bar.

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::axis::Axis;
use super::figure::{Plot, TICK_MARK_PX, fit_x, split_below, tick_budget, titled, x_label_area};
use super::layout::{Below, Layout, Rect};
use super::style::{AXIS_LABEL_PX, CHAR_WIDTH, TICK_PX, font, overlay_color};
use super::{Area, Heatmap, Scale, drawing_error};
use crate::Result;

/// The viridis colour map at ten evenly spaced levels (as R's `viridis(10)`): perceptually
/// uniform, readable by colour-blind readers and in greyscale. Levels in between are
/// interpolated linearly.
const VIRIDIS: [(u8, u8, u8); 10] = [
    (0x44, 0x01, 0x54),
    (0x48, 0x28, 0x78),
    (0x3E, 0x4A, 0x89),
    (0x31, 0x68, 0x8E),
    (0x26, 0x82, 0x8E),
    (0x1F, 0x9E, 0x89),
    (0x35, 0xB7, 0x79),
    (0x6D, 0xCD, 0x59),
    (0xB4, 0xDE, 0x2C),
    (0xFD, 0xE7, 0x25),
];

/// Width of the colour bar itself and the gap between it and the map, in pixels.
const COLORBAR_PX: u32 = 24;
const COLORBAR_GAP_PX: u32 = 20;

/// Whether `v` is finite and strictly increasing or strictly decreasing (true when it has fewer
/// than two values).
pub(crate) fn is_strictly_monotonic(v: &[f64]) -> bool {
    v.iter().all(|x| x.is_finite())
        && (v.windows(2).all(|w| w[0] < w[1]) || v.windows(2).all(|w| w[0] > w[1]))
}

/// Cell edges of a grid: midpoints between neighbours, and half a spacing beyond each end. A
/// single value gets a cell as wide as half its magnitude on either side (±0.5 around zero).
fn edges(v: &[f64]) -> Vec<f64> {
    match v {
        [] => Vec::new(),
        [only] => {
            let half = if *only == 0.0 { 0.5 } else { 0.5 * only.abs() };
            vec![only - half, only + half]
        }
        _ => {
            // The outer edge lies as far beyond `end` as the midpoint to `inner` lies before it.
            let outer = |inner: f64, end: f64| end + (0.5 * end - 0.5 * inner);
            let n = v.len();
            std::iter::once(outer(v[1], v[0]))
                .chain(v.windows(2).map(|w| 0.5 * w[0] + 0.5 * w[1]))
                .chain(std::iter::once(outer(v[n - 2], v[n - 1])))
                .collect()
        }
    }
}

/// The viridis colour at `t` in 0..=1 (clamped).
fn viridis(t: f64) -> RGBColor {
    let pos = t.clamp(0.0, 1.0) * (VIRIDIS.len() - 1) as f64;
    let i = (pos.floor() as usize).min(VIRIDIS.len() - 2);
    let f = pos - i as f64;
    let (a, b) = (VIRIDIS[i], VIRIDIS[i + 1]);
    let mix = |p: u8, q: u8| (f64::from(p) + f * (f64::from(q) - f64::from(p))).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// Draws `map` filling `area`, with room below for what `below` holds: the map with its
/// overlays on the left, the colour bar on the right. The axes span exactly the map's cells
/// (overlays reaching beyond them are cut at the frame); the colour scale spans exactly the
/// finite values of `z`.
pub(crate) fn draw(area: &Area, map: &Heatmap, below: Below) -> Result<Layout> {
    let titled_area = titled(area, &map.title)?;
    let (area, strip) = split_below(&titled_area, &below);
    let (x_ticks, y_ticks) = tick_budget(&area);
    let z_axis = Axis::fit(Scale::Linear, map.z.iter().flatten().copied(), 0.0, y_ticks);
    let label_px = f64::from(2 * TICK_MARK_PX)
        + z_axis.widest_label() as f64 * CHAR_WIDTH * TICK_PX
        + if map.colorbar_label.is_empty() {
            0.0
        } else {
            AXIS_LABEL_PX + 10.0
        }
        + 8.0;
    let bar_area_px = COLORBAR_GAP_PX + COLORBAR_PX + label_px as u32;
    let (width, _) = area.dim_in_pixel();
    let (main, bar) = area.split_horizontally(width.saturating_sub(bar_area_px));

    let (x_edges, y_edges) = (edges(&map.x), edges(&map.y));
    let x_axis = fit_x(
        |n| Axis::fit(Scale::Linear, x_edges.iter().copied(), 0.0, n),
        x_ticks,
        &main,
    );
    let y_axis = Axis::fit(Scale::Linear, y_edges.iter().copied(), 0.0, y_ticks);

    let mut plot = Plot::new(&main, x_axis, y_axis, (&map.x_label, &map.y_label), false)?;
    plot.below(&titled_area, strip, below);
    draw_cells(&mut plot, map, &z_axis, (&x_edges, &y_edges))?;
    for (i, s) in map.overlays.iter().enumerate() {
        plot.draw_series(s, overlay_color(i))?;
    }
    let layout = plot.finish(1)?;

    draw_colorbar(
        &bar,
        z_axis,
        &map.colorbar_label,
        &map.x_label,
        label_px as u32,
    )?;
    Ok(layout)
}

/// The cells of the map, in pixels: each reaches one pixel into its right and lower neighbours
/// (which are drawn after it, over that pixel), so no renderer leaves a hairline seam between
/// cells at any zoom; the map stays inside the plot area.
fn draw_cells(
    plot: &mut Plot,
    map: &Heatmap,
    z_axis: &Axis,
    edges: (&[f64], &[f64]),
) -> Result<()> {
    let (x_edges, y_edges) = edges;
    if x_edges.is_empty() || y_edges.is_empty() {
        return Ok(());
    }
    let frame = plot.chart().plotting_area().strip_coord_spec();
    let (bx, by) = frame.get_base_pixel();
    let (fw, fh) = frame.dim_in_pixel();
    let inside = Rect::spanning((bx, by), (bx + fw as i32 - 1, by + fh as i32 - 1));
    let mut cells = Vec::new();
    let mut covered = Vec::new();
    // Rows from the top of the image down and columns from left to right, so each cell's
    // overlap falls under the cell drawn next.
    let mut rows: Vec<usize> = (0..map.y.len()).collect();
    let mut columns: Vec<usize> = (0..map.x.len()).collect();
    let pixel = |x: f64, y: f64| plot.chart.backend_coord(&(x, y));
    let top_first = pixel(0.0, y_edges[0]).1 > pixel(0.0, y_edges[y_edges.len() - 1]).1;
    if top_first {
        rows.reverse();
    }
    let left_first = pixel(x_edges[0], 0.0).0 < pixel(x_edges[x_edges.len() - 1], 0.0).0;
    if !left_first {
        columns.reverse();
    }
    // Pixel row of the centre of each row of the map.
    let centre: Vec<i32> = map.y.iter().map(|&y| pixel(x_edges[0], y).1).collect();
    for &i in &rows {
        for &j in &columns {
            let z = map.z[i][j];
            if !z.is_finite() {
                continue;
            }
            let cell = Rect::spanning(
                pixel(x_edges[j], y_edges[i]),
                pixel(x_edges[j + 1], y_edges[i + 1]),
            );
            let grown = Rect {
                x0: cell.x0,
                y0: cell.y0,
                x1: (cell.x1 + 1).min(inside.x1),
                y1: (cell.y1 + 1).min(inside.y1),
            };
            if !map.smooth_y {
                cells.push((grown, viridis(z_axis.fraction(z))));
                covered.push(grown);
                continue;
            }
            // The value at pixel row `py`: towards the neighbouring row on its side.
            let at = |py: i32| {
                let toward = [i.wrapping_sub(1), i + 1]
                    .into_iter()
                    .filter(|&k| k < map.y.len())
                    .find(|&k| (centre[k] - centre[i]) * (py - centre[i]) > 0);
                match toward.map(|k| (k, map.z[k][j])) {
                    Some((k, zk)) if zk.is_finite() => {
                        let t = f64::from(py - centre[i]) / f64::from(centre[k] - centre[i]);
                        z + t.clamp(0.0, 1.0) * (zk - z)
                    }
                    _ => z,
                }
            };
            // Runs of pixel rows of one colour, each one pixel taller than it is (the next run
            // covers the extra pixel).
            let mut py = grown.y0;
            while py < grown.y1 {
                let color = viridis(z_axis.fraction(at(py)));
                let mut end = py + 1;
                while end < grown.y1 && viridis(z_axis.fraction(at(end))) == color {
                    end += 1;
                }
                let strip = Rect {
                    y0: py,
                    y1: end.min(grown.y1),
                    ..grown
                };
                cells.push((strip, color));
                py = end;
            }
            covered.push(grown);
        }
    }
    for (rect, color) in cells {
        frame
            .draw(&Rectangle::new(
                [(rect.x0 - bx, rect.y0 - by), (rect.x1 - bx, rect.y1 - by)],
                color.filled(),
            ))
            .map_err(drawing_error)?;
    }
    for rect in covered {
        plot.cover(rect);
    }
    Ok(())
}

/// The colour bar: one band per pixel row from the bottom to the top of `z_axis`, framed, with
/// ticks and `label` on its right. Its vertical margins match the map's so both line up.
fn draw_colorbar(
    area: &Area,
    z_axis: Axis,
    label: &str,
    x_label: &str,
    label_px: u32,
) -> Result<()> {
    let (z_lo, z_hi) = z_axis.bounds();
    let n_ticks = z_axis.ticks().len();
    let mut chart = ChartBuilder::on(area)
        .margin_top(15)
        .margin_bottom(5)
        .margin_left(COLORBAR_GAP_PX)
        .x_label_area_size(x_label_area(x_label))
        .right_y_label_area_size(label_px)
        .build_cartesian_2d(Axis::bare(0.0, 1.0), z_axis)
        .map_err(drawing_error)?;
    let mut mesh = chart.configure_mesh();
    mesh.disable_mesh()
        .disable_x_axis()
        .y_labels(n_ticks)
        .max_light_lines(0)
        .set_all_tick_mark_size(TICK_MARK_PX)
        .label_style(font(TICK_PX))
        .axis_style(BLACK.stroke_width(1));
    mesh.draw().map_err(drawing_error)?;
    if !label.is_empty() {
        // Drawn here rather than as `plotters`' axis description, which on the right reads top
        // to bottom: like the y label it should read bottom to top, centred on the bar.
        let (_, bar_top) = chart.plotting_area().get_base_pixel();
        let (_, bar_height) = chart.plotting_area().dim_in_pixel();
        let (_, area_top) = area.get_base_pixel();
        let (width, _) = area.dim_in_pixel();
        let style = font(AXIS_LABEL_PX)
            .transform(FontTransform::Rotate270)
            .pos(Pos::new(HPos::Center, VPos::Top));
        let centre = bar_top - area_top + (bar_height / 2) as i32;
        area.draw_text(
            label,
            &style,
            (width as i32 - AXIS_LABEL_PX as i32 - 4, centre),
        )
        .map_err(drawing_error)?;
    }

    // One band per pixel row, each one pixel taller than its row (the next band covers the
    // extra pixel), so the bar is smooth and seamless.
    let bar = chart.plotting_area().strip_coord_spec();
    let (w, h) = bar.dim_in_pixel();
    let (w, h) = (w as i32, h as i32);
    for row in 0..h {
        // Row 0 is the top of the bar, at z_hi.
        let t = 1.0 - (f64::from(row) + 0.5) / f64::from(h);
        let bottom = (row + 1).min(h - 1);
        bar.draw(&Rectangle::new(
            [(0, row), (w - 1, bottom)],
            viridis(t).filled(),
        ))
        .map_err(drawing_error)?;
    }
    chart
        .draw_series([Rectangle::new(
            [(0.0, z_lo), (1.0, z_hi)],
            BLACK.stroke_width(1),
        )])
        .map_err(drawing_error)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edges_lie_half_way_between_grid_values() {
        assert_eq!(edges(&[0.0, 1.0, 3.0]), [-0.5, 0.5, 2.0, 4.0]);
        assert_eq!(edges(&[2.0, 1.0]), [2.5, 1.5, 0.5]);
        assert_eq!(edges(&[4.0]), [2.0, 6.0]);
        assert!(edges(&[]).is_empty());
    }

    #[test]
    fn viridis_runs_from_purple_to_yellow() {
        assert_eq!(viridis(0.0), RGBColor(0x44, 0x01, 0x54));
        assert_eq!(viridis(1.0), RGBColor(0xFD, 0xE7, 0x25));
        assert_eq!(viridis(2.0), viridis(1.0));
    }

    #[test]
    fn monotonic_grids() {
        assert!(is_strictly_monotonic(&[1.0, 2.0, 3.0]));
        assert!(is_strictly_monotonic(&[3.0, 2.0]));
        assert!(!is_strictly_monotonic(&[1.0, 1.0]));
        assert!(!is_strictly_monotonic(&[1.0, f64::NAN]));
        assert!(is_strictly_monotonic(&[]));
    }
}
