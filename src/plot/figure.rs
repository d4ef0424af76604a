//! Drawing a [`Figure`], and the [`Plot`] that both figures and heat maps draw through: axes,
//! series, special points, annotation and a legend placed where it hides the least data.

use plotters::chart::{ChartBuilder, ChartContext};
use plotters::element::{Circle, DashedPathElement, DynElement, EmptyElement, IntoDynElement};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::axis::{Axis, PADDING};
use super::geometry::{self, Point};
use super::style::{
    ANNOTATION_PX, AXIS_LABEL_PX, BAND_OPACITY, CAP_PX, CHAR_WIDTH, DASH_PX, GAP_PX, Glyph,
    LEGEND_PX, LINE_WIDTH, MARKER_PX, NEUTRAL, SAMPLE_PX, SPECIAL_GLYPHS, SPECIAL_PX, TICK_PX,
    TITLE_PX, font, series_color,
};
use super::{Area, Figure, Marker, Series, Style, drawing_error};
use crate::Result;

/// A position in SVG pixels (`plotters`' backend coordinate).
type Pixel = (i32, i32);

/// Text of the single legend entry that explains dashed (unstable) runs.
const UNSTABLE_LABEL: &str = "unstable (dashed)";

/// Length of the tick marks `plotters` draws; tick labels sit twice this far from the axis.
pub(crate) const TICK_MARK_PX: i32 = 5;

/// Draws `fig` filling `area`.
pub(crate) fn draw(area: &Area, fig: &Figure) -> Result<()> {
    let (xs, ys) = fig.series.iter().map(geometry::extent).fold(
        (Vec::new(), Vec::new()),
        |(mut xs, mut ys), (x, y)| {
            xs.extend(x);
            ys.extend(y);
            (xs, ys)
        },
    );
    let xs = xs.into_iter().chain(fig.markers.iter().map(|m| m.x));
    let ys = ys.into_iter().chain(fig.markers.iter().map(|m| m.y));
    let area = titled(area, &fig.title)?;
    let (x_ticks, y_ticks) = tick_budget(&area);
    let x_axis = fit_x(
        |n| Axis::fit(fig.x_scale, xs.clone(), PADDING, n),
        x_ticks,
        &area,
    );
    let y_axis = Axis::fit(fig.y_scale, ys, PADDING, y_ticks);

    let mut plot = Plot::new(&area, x_axis, y_axis, (&fig.x_label, &fig.y_label), true)?;
    for (i, s) in fig.series.iter().enumerate() {
        plot.draw_series(s, series_color(i))?;
    }
    plot.draw_special_points(&fig.markers)?;
    if let Some(text) = &fig.annotation {
        plot.annotate(text)?;
    }
    plot.finish(2)
}

/// `area` below `title`, or all of it when there is no title.
pub fn titled<'b>(area: &Area<'b>, title: &str) -> Result<Area<'b>> {
    if title.is_empty() {
        Ok(area.clone())
    } else {
        area.titled(title, font(TITLE_PX)).map_err(drawing_error)
    }
}

/// How many labelled ticks fit along each axis of `area` at the figure's font sizes.
pub(crate) fn tick_budget(area: &Area) -> (usize, usize) {
    let (w, h) = area.dim_in_pixel();
    let fit = |len: u32, reserved: f64, per_tick: f64| {
        ((f64::from(len) - reserved) / per_tick).clamp(3.0, 8.0) as usize
    };
    (fit(w, 150.0, 100.0), fit(h, 120.0, 60.0))
}

/// The x axis with the most ticks (up to `max_ticks`) whose labels do not overlap across the
/// width of `area`, built by `make(max_ticks)`.
pub(crate) fn fit_x(make: impl Fn(usize) -> Axis, max_ticks: usize, area: &Area) -> Axis {
    let width = f64::from(area.dim_in_pixel().0) - 150.0;
    let mut axis = make(max_ticks);
    for n in (2..max_ticks).rev() {
        let needed = axis.ticks().len() as f64 * (axis.widest_label() + 2) as f64;
        if needed * CHAR_WIDTH * TICK_PX <= width {
            break;
        }
        axis = make(n);
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

/// How a legend entry's sample is drawn.
#[derive(Clone, Copy)]
enum Sample {
    Line(RGBColor),
    Dashed(RGBColor),
    Glyph(Glyph, RGBColor, i32),
}

impl Sample {
    /// The sample whose left end is at `(x, y)` in pixels.
    fn element<'e, DB: DrawingBackend + 'e>(self, (x, y): Pixel) -> DynElement<'e, DB, Pixel> {
        let stroke = |c: RGBColor| c.stroke_width(LINE_WIDTH);
        let line = vec![(x, y), (x + SAMPLE_PX, y)];
        match self {
            Sample::Line(c) => PathElement::new(line, stroke(c)).into_dyn(),
            Sample::Dashed(c) => {
                DashedPathElement::new(line, DASH_PX, GAP_PX, stroke(c)).into_dyn()
            }
            Sample::Glyph(g, c, r) => g.at((x + SAMPLE_PX / 2, y), r, c),
        }
    }
}

struct LegendEntry {
    label: String,
    sample: Sample,
}

/// A chart being drawn: the axes, the legend entries collected so far, and the pixels covered by
/// data (sampled along curves) so the legend can go where it covers the least.
pub(crate) struct Plot<'a, 'b> {
    chart: ChartContext<'a, SVGBackend<'b>, Cartesian2d<Axis, Axis>>,
    x: Axis,
    y: Axis,
    entries: Vec<LegendEntry>,
    special_entries: Vec<LegendEntry>,
    any_unstable: bool,
    annotated: bool,
    ink: Vec<Pixel>,
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
        (x_label, y_label): (&str, &str),
        grid: bool,
    ) -> Result<Self> {
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
        let chart = ChartBuilder::on(area)
            .margin_top(15)
            .margin_bottom(5)
            .margin_left(5)
            .margin_right(right as u32)
            .x_label_area_size(x_label_area(x_label))
            .y_label_area_size(y_area as u32)
            .build_cartesian_2d(x.clone(), y.clone())
            .map_err(drawing_error)?;
        let mut plot = Plot {
            chart,
            x,
            y,
            entries: Vec::new(),
            special_entries: Vec::new(),
            any_unstable: false,
            annotated: false,
            ink: Vec::new(),
        };
        plot.draw_axes(x_label, y_label, grid)?;
        Ok(plot)
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
            .bold_line_style(BLACK.mix(0.12).stroke_width(1));
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

    /// Draws one series in `color` (see [`Series`] for the rules) and notes its legend entry.
    pub(crate) fn draw_series(&mut self, s: &Series, color: RGBColor) -> Result<()> {
        let stroke = color.stroke_width(LINE_WIDTH);
        let sample = match s.style {
            Style::Line | Style::Dashed => {
                let bands = geometry::bands(s, &self.x, &self.y);
                let band_fill = color.mix(BAND_OPACITY).filled();
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

    /// Vertical bars with caps (the caps are fixed in pixels, so they are anchored at the ends).
    fn draw_error_bars(&mut self, bars: &[geometry::ErrorBar], stroke: ShapeStyle) -> Result<()> {
        let bar = |b: &geometry::ErrorBar| PathElement::new(vec![(b.x, b.lo), (b.x, b.hi)], stroke);
        self.chart
            .draw_series(bars.iter().map(bar))
            .map_err(drawing_error)?;
        let ends = bars.iter().flat_map(|b| {
            let lower = (!b.cut).then_some((b.x, b.lo));
            lower.into_iter().chain([(b.x, b.hi)])
        });
        let cap = |at: Point| {
            EmptyElement::at(at) + PathElement::new(vec![(-CAP_PX, 0), (CAP_PX, 0)], stroke)
        };
        self.chart
            .draw_series(ends.map(cap))
            .map_err(drawing_error)?;
        for b in bars {
            self.record_line(&[(b.x, b.lo), (b.x, b.hi)]);
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
            self.ink.push(pixel);
        }
        Ok(())
    }

    /// Draws the special points in black, one glyph per distinct label (in order of first
    /// appearance), each label once in the legend.
    fn draw_special_points(&mut self, markers: &[Marker]) -> Result<()> {
        let mut groups: Vec<(&str, Vec<Point>)> = Vec::new();
        for m in markers {
            let i = match groups.iter().position(|(label, _)| *label == m.label) {
                Some(i) => i,
                None => {
                    groups.push((&m.label, Vec::new()));
                    groups.len() - 1
                }
            };
            if self.x.shows(m.x) && self.y.shows(m.y) {
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

    /// Writes `text` (one line per `\n`) in the upper-left corner of the plot area, on a
    /// translucent white box so it stays legible over data.
    fn annotate(&mut self, text: &str) -> Result<()> {
        let lines: Vec<&str> = text.lines().collect();
        if lines.iter().all(|l| l.trim().is_empty()) {
            return Ok(());
        }
        let area = self.chart.plotting_area().strip_coord_spec();
        let line_px = 1.3 * ANNOTATION_PX;
        let widest = lines.iter().map(|l| l.chars().count()).max().unwrap_or(0);
        let (w, h) = (
            widest as f64 * CHAR_WIDTH * ANNOTATION_PX + 12.0,
            lines.len() as f64 * line_px + 8.0,
        );
        area.draw(&Rectangle::new(
            [(4, 4), (4 + w as i32, 4 + h as i32)],
            WHITE.mix(0.85).filled(),
        ))
        .map_err(drawing_error)?;
        let style = font(ANNOTATION_PX).pos(Pos::new(HPos::Left, VPos::Top));
        for (k, line) in lines.into_iter().enumerate() {
            let y = 8 + (k as f64 * line_px) as i32;
            area.draw(&Text::new(line, (10, y), &style))
                .map_err(drawing_error)?;
        }
        self.annotated = true;
        Ok(())
    }

    /// Notes the pixels covered by a curve through `points`, sampled every few pixels.
    fn record_line(&mut self, points: &[Point]) {
        let pixels: Vec<Pixel> = points.iter().map(|p| self.chart.backend_coord(p)).collect();
        if let [p] = pixels[..] {
            self.ink.push(p);
        }
        for pair in pixels.windows(2) {
            let ((x0, y0), (x1, y1)) = (pair[0], pair[1]);
            let len = f64::from(x1 - x0).hypot(f64::from(y1 - y0));
            let steps = (len / 4.0).ceil().clamp(1.0, 1000.0) as i32;
            self.ink.extend(
                (0..=steps).map(|k| (x0 + (x1 - x0) * k / steps, y0 + (y1 - y0) * k / steps)),
            );
        }
    }

    /// Draws the legend if it has at least `min_entries` entries (or any special point, whose
    /// meaning only the legend gives): series in order, then "unstable (dashed)" if any series
    /// has an unstable run, then the special points.
    ///
    /// The legend is laid out here rather than by `plotters`' series labels, so its box is the
    /// one [`Plot::legend_corner`] placed, and samples can be any element.
    pub(crate) fn finish(mut self, min_entries: usize) -> Result<()> {
        if self.any_unstable {
            self.entries.push(LegendEntry {
                label: UNSTABLE_LABEL.to_owned(),
                sample: Sample::Dashed(NEUTRAL),
            });
        }
        let has_specials = !self.special_entries.is_empty();
        self.entries.append(&mut self.special_entries);
        if self.entries.len() < min_entries && !has_specials {
            return Ok(());
        }
        let (w, h) = self.legend_size();
        let (x0, y0) = self.legend_corner((w, h));
        let area = self.chart.plotting_area().strip_coord_spec();
        let frame = [(x0, y0), (x0 + w, y0 + h)];
        area.draw(&Rectangle::new(frame, WHITE.mix(0.9).filled()))
            .map_err(drawing_error)?;
        area.draw(&Rectangle::new(frame, BLACK.mix(0.4).stroke_width(1)))
            .map_err(drawing_error)?;
        let style = font(LEGEND_PX).pos(Pos::new(HPos::Left, VPos::Center));
        for (k, entry) in self.entries.iter().enumerate() {
            let y = y0 + LEGEND_MARGIN + (LEGEND_ROW_PX * (k as f64 + 0.5)) as i32;
            let x = x0 + LEGEND_MARGIN;
            area.draw(&entry.sample.element((x, y)))
                .map_err(drawing_error)?;
            area.draw(&Text::new(
                entry.label.as_str(),
                (x + LEGEND_SAMPLE_AREA, y),
                &style,
            ))
            .map_err(drawing_error)?;
        }
        Ok(())
    }

    /// Width and height of the legend box in pixels.
    fn legend_size(&self) -> (i32, i32) {
        let widest = self
            .entries
            .iter()
            .map(|e| e.label.chars().count())
            .max()
            .unwrap_or(0);
        let text = widest as f64 * CHAR_WIDTH * LEGEND_PX;
        (
            text as i32 + LEGEND_SAMPLE_AREA + 2 * LEGEND_MARGIN,
            (self.entries.len() as f64 * LEGEND_ROW_PX) as i32 + 2 * LEGEND_MARGIN,
        )
    }

    /// Upper-left corner (in plot-area pixels) of the legend box of size `(w, h)`: the place
    /// where it covers the fewest data pixels among the corners of the plot area and, after
    /// them, the middles of its sides (for data that reach into every corner); ties go to upper
    /// right, upper left, lower right, lower left, then the middles of the left, right, top and
    /// bottom sides, in that order. The upper left is not used when it holds the annotation.
    fn legend_corner(&self, (w, h): (i32, i32)) -> Pixel {
        let area = self.chart.plotting_area();
        let (base_x, base_y) = area.get_base_pixel();
        let (aw, ah) = area.dim_in_pixel();
        let inset = 6;
        let (left, top) = (inset, inset);
        let (right, bottom) = (aw as i32 - w - inset, ah as i32 - h - inset);
        let upper_left = (left, top);
        let covered = |(x0, y0): Pixel| {
            self.ink
                .iter()
                .filter(|&&(x, y)| {
                    let (x, y) = (x - base_x, y - base_y);
                    x >= x0 && x <= x0 + w && y >= y0 && y <= y0 + h
                })
                .count()
        };
        let (middle_x, middle_y) = ((left + right) / 2, (top + bottom) / 2);
        [
            (right, top),
            upper_left,
            (right, bottom),
            (left, bottom),
            (left, middle_y),
            (right, middle_y),
            (middle_x, top),
            (middle_x, bottom),
        ]
        .into_iter()
        .filter(|&corner| !(self.annotated && corner == upper_left))
        .min_by_key(|&corner| covered(corner))
        .unwrap_or((right, top))
    }
}

/// Padding inside the legend box, in pixels.
const LEGEND_MARGIN: i32 = 8;
/// Height of one legend row.
const LEGEND_ROW_PX: f64 = 1.3 * LEGEND_PX;
/// Width reserved for the sample in front of each legend label.
const LEGEND_SAMPLE_AREA: i32 = SAMPLE_PX + 10;
