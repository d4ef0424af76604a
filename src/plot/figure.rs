//! Drawing a [`Figure`], and the [`Plot`] that both figures and heat maps draw through: axes,
//! series, special points, and the boxes covered by data, which the legend and the annotation
//! (see `legend.rs`) must not cover.

use plotters::chart::{ChartBuilder, ChartContext};
use plotters::element::{Circle, DashedPathElement, EmptyElement};
use plotters::prelude::*;

use super::axis::{Axis, PADDING};
use super::geometry::{self, Point};
use super::layout::{Below, Layout, Rect, stroke_boxes};
use super::legend::{LegendEntry, Sample};
use super::style::{
    AXIS_LABEL_PX, BAND_OPACITY, CAP_PX, CHAR_WIDTH, DASH_PX, GAP_PX, GRID_OPACITY, Glyph,
    LINE_WIDTH, MARKER_PX, SPECIAL_GLYPHS, SPECIAL_PX, TICK_PX, TITLE_PX, font, series_color,
    text_width,
};
use super::{Area, Figure, Marker, Scale, Series, Style, drawing_error};
use crate::Result;

/// A position in SVG pixels (`plotters`' backend coordinate).
pub(crate) type Pixel = (i32, i32);

/// Length of the tick marks `plotters` draws; tick labels sit twice this far from the axis.
pub(crate) const TICK_MARK_PX: i32 = 5;

/// Draws `fig` filling `area`, with room below the plot for what `below` holds; returns where
/// everything went.
pub(crate) fn draw(area: &Area, fig: &Figure, below: Below) -> Result<Layout> {
    draw_under_title(&titled(area, &fig.title)?, fig, below)
}

/// [`draw`] into `area`, the part of the figure's area below its title (already drawn).
pub(crate) fn draw_under_title(area: &Area, fig: &Figure, below: Below) -> Result<Layout> {
    let (xs, ys) = fig
        .series
        .iter()
        .map(|s| geometry::extent(s, fig.y_scale))
        .fold((Vec::new(), Vec::new()), |(mut xs, mut ys), (x, y)| {
            xs.extend(x);
            ys.extend(y);
            (xs, ys)
        });
    let xs = xs.into_iter().chain(fig.markers.iter().map(|m| m.x));
    let ys: Vec<f64> = match fig.y_range {
        Some((lo, hi)) => vec![lo, hi],
        None => ys
            .into_iter()
            .chain(fig.markers.iter().map(|m| m.y))
            .collect(),
    };
    let y_padding = if fig.y_range.is_some() { 0.0 } else { PADDING };
    let (chart_area, strip) = split_below(area, &below);
    let (x_ticks, y_ticks) = tick_budget(&chart_area);
    let mut x_axis = fit_x(
        |n| Axis::fit(fig.x_scale, xs.clone(), PADDING, n),
        x_ticks,
        &chart_area,
    );
    let mut y_axis = Axis::fit(fig.y_scale, ys, y_padding, y_ticks);
    if fig.equal_scale && fig.x_scale == Scale::Linear && fig.y_scale == Scale::Linear {
        (x_axis, y_axis) = equal_scales(&chart_area, x_axis, y_axis, (&fig.x_label, &fig.y_label));
    }

    let mut plot = Plot::new(
        &chart_area,
        x_axis,
        y_axis,
        (&fig.x_label, &fig.y_label),
        true,
    )?;
    plot.below(area, strip, below);
    for (i, s) in fig.series.iter().enumerate() {
        plot.draw_series(s, series_color(i))?;
    }
    plot.draw_special_points(&fig.markers)?;
    if let Some(text) = &fig.annotation {
        plot.annotate(text)?;
    }
    if fig.hide_legend {
        plot.entries.clear();
        plot.special_entries.clear();
        plot.any_unstable = false;
    }
    plot.finish(2)
}

/// `area` split into the part for the chart and, when `below` holds anything, a strip at the
/// bottom for it.
pub(crate) fn split_below<'b>(area: &Area<'b>, below: &Below) -> (Area<'b>, Option<Area<'b>>) {
    let height = below.height();
    if height <= 0 {
        return (area.clone(), None);
    }
    let (_, h) = area.dim_in_pixel();
    let (top, strip) = area.split_vertically(h.saturating_sub(height as u32));
    (top, Some(strip))
}

/// The axes widened so one unit spans as many pixels along x as along y on `area`: the axis
/// whose unit is longer gets a wider range around the same centre. Iterated because new tick
/// labels can change the margins and so the plot area.
fn equal_scales(area: &Area, mut x: Axis, mut y: Axis, labels: (&str, &str)) -> (Axis, Axis) {
    let (data_x, data_y) = (x.bounds(), y.bounds());
    let (x_ticks, y_ticks) = tick_budget(area);
    let (aw, ah) = area.dim_in_pixel();
    for _ in 0..8 {
        let frame = Frame::of(&x, &y, labels);
        let (w, h) = frame.plot_size((aw, ah));
        let (sx, sy) = (w / (data_x.1 - data_x.0), h / (data_y.1 - data_y.0));
        if !(sx.is_finite() && sy.is_finite() && sx > 0.0 && sy > 0.0) {
            break;
        }
        let s = sx.min(sy);
        let around = |(lo, hi): (f64, f64), px: f64| {
            let (mid, half) = (0.5 * lo + 0.5 * hi, 0.5 * px / s);
            [mid - half, mid + half]
        };
        let new_x = fit_x(
            |n| Axis::fit(Scale::Linear, around(data_x, w), 0.0, n),
            x_ticks,
            area,
        );
        let new_y = Axis::fit(Scale::Linear, around(data_y, h), 0.0, y_ticks);
        let settled = new_x.bounds() == x.bounds()
            && new_y.bounds() == y.bounds()
            && new_x.ticks() == x.ticks()
            && new_y.ticks() == y.ticks();
        (x, y) = (new_x, new_y);
        if settled {
            break;
        }
    }
    (x, y)
}

/// `area` below `title`, or all of it when there is no title. A title wider than the area less
/// a margin of one title size each side is broken at spaces into lines that fit (a word wider
/// than that stays whole on its line), each a centred text of its own, so that no title runs
/// past the frame; a title that fits is one text, verbatim.
pub fn titled<'b>(area: &Area<'b>, title: &str) -> Result<Area<'b>> {
    let room = f64::from(area.dim_in_pixel().0) - 2.0 * TITLE_PX;
    if title.is_empty() {
        return Ok(area.clone());
    }
    if text_width(title, TITLE_PX) <= room {
        return area.titled(title, font(TITLE_PX)).map_err(drawing_error);
    }
    let mut lines: Vec<String> = Vec::new();
    for word in title.split(' ').filter(|w| !w.is_empty()) {
        match lines.last_mut() {
            Some(line) if text_width(&format!("{line} {word}"), TITLE_PX) <= room => {
                line.push(' ');
                line.push_str(word);
            }
            _ => lines.push(word.to_string()),
        }
    }
    let mut below = area.clone();
    for line in &lines {
        below = below.titled(line, font(TITLE_PX)).map_err(drawing_error)?;
    }
    Ok(below)
}

/// How many labelled ticks fit along each axis of `area` at the figure's font sizes.
pub(crate) fn tick_budget(area: &Area) -> (usize, usize) {
    let (w, h) = area.dim_in_pixel();
    let fit = |len: u32, reserved: f64, per_tick: f64| {
        ((f64::from(len) - reserved) / per_tick).clamp(3.0, MAX_TICKS as f64) as usize
    };
    (fit(w, 150.0, 100.0), fit(h, 120.0, 60.0))
}

/// Most ticks an axis gets.
const MAX_TICKS: usize = 8;

/// The x axis with the most ticks (up to `max_ticks`) whose labels do not overlap across the
/// width of `area`, built by `make(max_ticks)`; with at least two if their labels fit.
pub(crate) fn fit_x(make: impl Fn(usize) -> Axis, max_ticks: usize, area: &Area) -> Axis {
    let width = f64::from(area.dim_in_pixel().0) - 150.0;
    let fits = |axis: &Axis| {
        let needed = axis.ticks().len() as f64 * (axis.widest_label() + 2) as f64;
        needed * CHAR_WIDTH * TICK_PX <= width
    };
    let mut axis = make(max_ticks);
    for n in (2..max_ticks).rev() {
        if fits(&axis) {
            break;
        }
        axis = make(n);
    }
    // A budget of a few ticks can leave a single one (steps of 1, 2, 5: −4.4..4.4 with at most
    // 3 ticks gets only 0); then more are allowed, as long as their labels fit.
    if axis.ticks().len() < 2
        && let Some(more) = (max_ticks + 1..=MAX_TICKS)
            .map(&make)
            .find(|a| a.ticks().len() >= 2 && fits(a))
    {
        axis = more;
    }
    axis
}

/// Height of the area below a plot holding the x tick labels and, if not empty, `x_label`.
pub(crate) fn x_label_area(x_label: &str) -> u32 {
    let desc = if x_label.is_empty() {
        0.0
    } else {
        AXIS_LABEL_PX + 10.0
    };
    (TICK_PX + f64::from(2 * TICK_MARK_PX) + desc + 10.0) as u32
}

/// The margins and label areas of a chart, sized from its tick labels and axis labels, so the
/// plot area can be known before the chart is built (for equal scales).
pub(crate) struct Frame {
    right: u32,
    x_area: u32,
    y_area: u32,
}

/// Fixed margins of a chart: above, below and left of it (the right one depends on the last x
/// tick label).
const MARGIN_TOP: u32 = 15;
const MARGIN_BOTTOM: u32 = 5;
const MARGIN_LEFT: u32 = 5;

impl Frame {
    pub fn of(x: &Axis, y: &Axis, (x_label, y_label): (&str, &str)) -> Self {
        let desc = |label: &str| {
            if label.is_empty() {
                0.0
            } else {
                AXIS_LABEL_PX + 10.0
            }
        };
        let y_area = y.widest_label() as f64 * CHAR_WIDTH * TICK_PX
            + f64::from(2 * TICK_MARK_PX)
            + desc(y_label)
            + 8.0;
        let last_x_label = x.ticks().last().map_or(0, |(_, l)| l.chars().count());
        let right = (last_x_label as f64 * CHAR_WIDTH * TICK_PX / 2.0 + 8.0).max(20.0);
        Frame {
            right: right as u32,
            x_area: x_label_area(x_label),
            y_area: y_area as u32,
        }
    }

    /// Width and height of the plot area on an area of `size` pixels.
    pub fn plot_size(&self, (w, h): (u32, u32)) -> (f64, f64) {
        let w = f64::from(w) - f64::from(MARGIN_LEFT + self.right + self.y_area);
        let h = f64::from(h) - f64::from(MARGIN_TOP + MARGIN_BOTTOM + self.x_area);
        (w.max(1.0), h.max(1.0))
    }
}

/// A chart being drawn: the axes, the legend entries collected so far, and the boxes covered by
/// data so the legend and the annotation can go where they cover none.
pub(crate) struct Plot<'a, 'b> {
    pub(super) chart: ChartContext<'a, SVGBackend<'b>, Cartesian2d<Axis, Axis>>,
    x: Axis,
    y: Axis,
    pub(super) entries: Vec<LegendEntry>,
    pub(super) special_entries: Vec<LegendEntry>,
    pub(super) any_unstable: bool,
    /// Boxes covering the data drawn so far, in pixels of the SVG.
    pub(super) data: Vec<Rect>,
    /// The whole panel below its title, for drawing the legend and annotation anywhere on it.
    pub(super) canvas: Option<Area<'b>>,
    /// The strip below the plot and what goes into it.
    pub(super) strip: Option<Area<'b>>,
    pub(super) below: Below,
    /// The annotation's lines, drawn by [`Plot::finish`].
    pub(super) annotation: Vec<String>,
    pub(super) layout: Layout,
}

impl<'a, 'b> Plot<'a, 'b> {
    /// Axes with tick labels and axis labels on `area`; grid lines at the ticks when `grid`.
    ///
    /// The label areas are sized from the actual tick labels and the margins leave room for the
    /// last x label, so no text is cut off.
    pub fn new(
        area: &'a Area<'b>,
        x: Axis,
        y: Axis,
        labels: (&str, &str),
        grid: bool,
    ) -> Result<Self> {
        let frame = Frame::of(&x, &y, labels);
        let chart = ChartBuilder::on(area)
            .margin_top(MARGIN_TOP)
            .margin_bottom(MARGIN_BOTTOM)
            .margin_left(MARGIN_LEFT)
            .margin_right(frame.right)
            .x_label_area_size(frame.x_area)
            .y_label_area_size(frame.y_area)
            .build_cartesian_2d(x.clone(), y.clone())
            .map_err(drawing_error)?;
        let mut plot = Plot {
            chart,
            x,
            y,
            entries: Vec::new(),
            special_entries: Vec::new(),
            any_unstable: false,
            data: Vec::new(),
            canvas: None,
            strip: None,
            below: Below::default(),
            annotation: Vec::new(),
            layout: Layout::default(),
        };
        plot.layout.plot_area = plot.plot_rect();
        plot.layout.px_per_unit = (plot.px_per_unit(true), plot.px_per_unit(false));
        plot.draw_axes(labels.0, labels.1, grid)?;
        Ok(plot)
    }

    /// Where the legend and annotation may be drawn: `canvas` (the panel below its title), and
    /// `strip` at its bottom for what `below` puts below the plot.
    pub fn below(&mut self, canvas: &Area<'b>, strip: Option<Area<'b>>, below: Below) {
        self.canvas = Some(canvas.clone());
        self.strip = strip;
        self.below = below;
    }

    /// The plot area in pixels of the SVG.
    fn plot_rect(&self) -> Rect {
        let area = self.chart.plotting_area();
        let (x0, y0) = area.get_base_pixel();
        let (w, h) = area.dim_in_pixel();
        Rect::spanning((x0, y0), (x0 + w as i32 - 1, y0 + h as i32 - 1))
    }

    /// Pixels per data unit along x (`true`) or y on a linear axis; NaN on a log axis.
    fn px_per_unit(&self, along_x: bool) -> f64 {
        let (axis, other) = if along_x {
            (&self.x, &self.y)
        } else {
            (&self.y, &self.x)
        };
        if axis.scale() != Scale::Linear {
            return f64::NAN;
        }
        let (lo, hi) = axis.bounds();
        let at = other.bounds().0;
        let point = |v: f64| if along_x { (v, at) } else { (at, v) };
        let (a, b) = (
            self.chart.backend_coord(&point(lo)),
            self.chart.backend_coord(&point(hi)),
        );
        let px = if along_x { b.0 - a.0 } else { a.1 - b.1 };
        f64::from(px.abs()) / (hi - lo)
    }

    fn draw_axes(&mut self, x_label: &str, y_label: &str, grid: bool) -> Result<()> {
        let (nx, ny) = (self.x.ticks().len(), self.y.ticks().len());
        let mut mesh = self.chart.configure_mesh();
        mesh.x_labels(nx)
            .y_labels(ny)
            .max_light_lines(0)
            .set_all_tick_mark_size(TICK_MARK_PX)
            .label_style(font(TICK_PX))
            .axis_desc_style(font(AXIS_LABEL_PX))
            .axis_style(BLACK.stroke_width(1))
            .bold_line_style(BLACK.mix(GRID_OPACITY).stroke_width(1));
        if !grid {
            mesh.disable_mesh();
        }
        if !x_label.is_empty() {
            mesh.x_desc(x_label);
        }
        if !y_label.is_empty() {
            mesh.y_desc(y_label);
        }
        mesh.draw().map_err(drawing_error)
    }

    /// The chart, for drawing what only one kind of figure has (heat-map cells).
    pub fn chart(&mut self) -> &mut ChartContext<'a, SVGBackend<'b>, Cartesian2d<Axis, Axis>> {
        &mut self.chart
    }

    /// Notes that `rect` (pixels of the SVG) is covered by data.
    pub(crate) fn cover(&mut self, rect: Rect) {
        self.data.push(rect);
    }

    /// Draws one series in `color` (see [`Series`] for the rules) and notes its legend entry.
    /// Whatever lies outside the axes' ranges is cut at the frame.
    pub(crate) fn draw_series(&mut self, s: &Series, color: RGBColor) -> Result<()> {
        let stroke = color.stroke_width(LINE_WIDTH);
        let sample = match s.style {
            Style::Line | Style::Dashed => {
                let bands = geometry::bands(s, &self.x, &self.y);
                let band_fill = color.mix(BAND_OPACITY).filled();
                for band in &bands {
                    self.cover_band(band);
                }
                self.chart
                    .draw_series(bands.into_iter().map(|b| Polygon::new(b, band_fill)))
                    .map_err(drawing_error)?;
                for run in geometry::line_runs(s, &self.x, &self.y) {
                    self.record_line(&run.points);
                    // A run that does not go anywhere would be an invisible zero-length line.
                    if run.points.iter().all(|p| *p == run.points[0]) {
                        let dot = Circle::new(run.points[0], LINE_WIDTH + 1, color.filled());
                        self.chart.draw_series([dot]).map_err(drawing_error)?;
                    } else if run.dashed {
                        self.any_unstable |= s.style == Style::Line;
                        let dashed = DashedPathElement::new(run.points, DASH_PX, GAP_PX, stroke);
                        self.chart.draw_series([dashed]).map_err(drawing_error)?;
                    } else {
                        let solid = PathElement::new(run.points, stroke);
                        self.chart.draw_series([solid]).map_err(drawing_error)?;
                    }
                }
                if s.style == Style::Dashed {
                    Sample::Dashed(color)
                } else {
                    Sample::Line(color)
                }
            }
            Style::Markers(shape) => {
                let bars = geometry::error_bars(s, &self.x, &self.y);
                self.draw_error_bars(&bars, stroke)?;
                let points = geometry::points(s, &self.x, &self.y);
                self.draw_glyphs(&points, shape.into(), MARKER_PX, color)?;
                Sample::Glyph(shape.into(), color, MARKER_PX)
            }
        };
        if !s.label.is_empty() {
            self.entries.push(LegendEntry {
                label: s.label.clone(),
                sample,
            });
        }
        Ok(())
    }

    /// Notes the area of a band (upper edge forwards, lower edge backwards) as covered, slice by
    /// slice between neighbouring points.
    fn cover_band(&mut self, band: &[Point]) {
        let n = band.len() / 2;
        let pixels: Vec<Pixel> = band.iter().map(|p| self.chart.backend_coord(p)).collect();
        for k in 0..n.saturating_sub(1) {
            let corners = [
                pixels[k],
                pixels[k + 1],
                pixels[2 * n - 1 - k],
                pixels[2 * n - 2 - k],
            ];
            let (xs, ys): (Vec<i32>, Vec<i32>) = corners.into_iter().unzip();
            let rect = Rect {
                x0: *xs.iter().min().unwrap_or(&0),
                y0: *ys.iter().min().unwrap_or(&0),
                x1: *xs.iter().max().unwrap_or(&0),
                y1: *ys.iter().max().unwrap_or(&0),
            };
            self.data.push(rect);
        }
    }

    /// Vertical bars with caps (the caps are fixed in pixels, so they are anchored at the ends);
    /// an end cut at the frame gets no cap.
    fn draw_error_bars(&mut self, bars: &[geometry::ErrorBar], stroke: ShapeStyle) -> Result<()> {
        let bar = |b: &geometry::ErrorBar| PathElement::new(vec![(b.x, b.lo), (b.x, b.hi)], stroke);
        self.chart
            .draw_series(bars.iter().map(bar))
            .map_err(drawing_error)?;
        let ends = bars.iter().flat_map(|b| {
            let lower = (!b.cut).then_some((b.x, b.lo));
            let upper = (!b.cut_hi).then_some((b.x, b.hi));
            lower.into_iter().chain(upper)
        });
        let cap = |at: Point| {
            EmptyElement::at(at) + PathElement::new(vec![(-CAP_PX, 0), (CAP_PX, 0)], stroke)
        };
        self.chart
            .draw_series(ends.map(cap))
            .map_err(drawing_error)?;
        for b in bars {
            let (lo, hi) = (
                self.chart.backend_coord(&(b.x, b.lo)),
                self.chart.backend_coord(&(b.x, b.hi)),
            );
            self.data
                .push(Rect::spanning(lo, hi).inflate(CAP_PX.max(LINE_WIDTH as i32)));
        }
        Ok(())
    }

    /// Draws `glyph` at each point. (Glyphs are drawn one by one on the plotting area:
    /// `plotters`' `draw_series` cannot take the boxed elements that let one function return
    /// every glyph shape.)
    fn draw_glyphs(
        &mut self,
        points: &[Point],
        glyph: Glyph,
        r: i32,
        color: RGBColor,
    ) -> Result<()> {
        for p in points {
            self.chart
                .plotting_area()
                .draw(&glyph.at(*p, r, color))
                .map_err(drawing_error)?;
            let pixel = self.chart.backend_coord(p);
            self.data
                .push(Rect::spanning(pixel, pixel).inflate(glyph.reach(r)));
        }
        Ok(())
    }

    /// Draws the special points in black, one glyph per distinct label (in order of first
    /// appearance), each label once in the legend.
    pub(crate) fn draw_special_points(&mut self, markers: &[Marker]) -> Result<()> {
        let mut groups: Vec<(&str, Vec<Point>)> = Vec::new();
        for m in markers {
            let i = match groups.iter().position(|(label, _)| *label == m.label) {
                Some(i) => i,
                None => {
                    groups.push((&m.label, Vec::new()));
                    groups.len() - 1
                }
            };
            if self.x.contains(m.x) && self.y.contains(m.y) {
                groups[i].1.push((m.x, m.y));
            }
        }
        for (i, (label, points)) in groups.into_iter().enumerate() {
            let glyph = SPECIAL_GLYPHS[i % SPECIAL_GLYPHS.len()];
            self.draw_glyphs(&points, glyph, SPECIAL_PX, BLACK)?;
            if !label.is_empty() {
                self.special_entries.push(LegendEntry {
                    label: label.to_owned(),
                    sample: Sample::Glyph(glyph, BLACK, SPECIAL_PX),
                });
            }
        }
        Ok(())
    }

    /// Notes the pixels covered by a curve through `points`.
    fn record_line(&mut self, points: &[Point]) {
        let pixels: Vec<Pixel> = points.iter().map(|p| self.chart.backend_coord(p)).collect();
        self.data.extend(stroke_boxes(&pixels, LINE_WIDTH as i32));
    }
}
