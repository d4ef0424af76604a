//! Publication-ready figures: branch diagrams, scatter plots with error bars, phase-diagram
//! heat maps, and side-by-side panels, each written as an SVG and, beside it, a PNG of the same
//! name.
//!
//! Everything is drawn with `plotters`' SVG backend, so text stays real `<text>` elements that
//! journals' and editors' tools can restyle. The defaults aim at a figure that can go into a
//! paper unchanged: white background, 16–20 px sans-serif text, axis labels with their units as
//! given (Unicode math such as ω, λ, F̄ₚ, ℓ² is written as it is), the colour-blind-safe
//! Okabe–Ito palette, a legend whenever there is more than one thing to tell apart, with each
//! series' own line or marker, and margins sized from the actual tick labels so nothing is cut
//! off. All of it (font, sizes, colours, widths, dashes, markers) comes from one style module.
//!
//! # Legend and annotation
//! The legend and the annotation each go in a box that covers no data: the first free one of
//! the corners and side middles of the plot area, then of the positions along its sides; the
//! legend avoids the annotation too. When no such place exists (a heat map fills its plot area),
//! the figure is drawn again with a strip below the plot that holds the box. [`Layout`] tells
//! where everything went ([`render_figure`] and its siblings return it), so tests can check that
//! no box covers data.
//!
//! # PNG
//! The PNG is the SVG rendered by `resvg` (pure Rust: `usvg` parses, `tiny-skia` rasterises,
//! text is shaped by `harfrust`) with DejaVu Sans embedded in the binary as the only font, at
//! [`PNG_SCALE`] pixels per SVG pixel. So the PNG shows exactly what the SVG says, combining
//! marks and all, on any machine, with no system library or installed font (no fontconfig).
//! `plotters`' own bitmap backend was the alternative: it would draw every figure a second time
//! through `ab_glyph`, which places glyphs without their side bearings (a combining macron lands
//! beside its letter, not over it) and sizes text differently from the SVG.
//!
//! Data are never trusted to be clean: non-finite values are skipped (a line is broken at them),
//! on logarithmic axes non-positive values are skipped too, and a range of all-equal values is
//! widened so the axis still has a span. Malformed input (series whose vectors differ in length,
//! a heat-map grid that does not match its values) is reported as [`Error::Input`], never a
//! panic.
//!
//! # What the SVG contains
//! Callers and tests may rely on how `plotters` 0.3.7 writes the figure:
//! - every text (title, axis labels, tick labels, legend, annotation lines) is one `<text>`
//!   element holding the string verbatim, XML-escaped and surrounded by a newline on each side
//!   (trim it), except a title wider than its frame less 20 px each side, which is one `<text>`
//!   per line, top down, broken at spaces (runs of spaces become one);
//!   with `font-family="sans-serif"` and `font-size` in pixels (20 title, 18 axis
//!   labels, 16 ticks, legend and annotation); the y label carries `transform="rotate(270, …)"`;
//!   negative tick labels use the minus sign U+2212 and exponents superscript digits ("10⁻³");
//! - a solid curve is one `<polyline fill="none" stroke="#RRGGBB" stroke-width="2" points="x,y
//!   x,y …">` in the series colour (upper-case hex), its vertices rounded to whole pixels;
//! - a dashed curve has no `stroke-dasharray`: `plotters` cuts it into one short `<polyline>`
//!   per dash ([`DASH_PX`] long, [`GAP_PX`] apart, measured along the curve in pixels), so a
//!   dash that turns a corner has three vertices;
//! - series markers are `<circle>`, `<rect>` or `<polygon>` elements (a cross is two `<line>`s),
//!   special points black `<polygon>`s, `<rect>`s or `<circle>`s, error bars and their caps
//!   two-point `<polyline>`s, error bands `<polygon opacity="0.2">`s, heat-map cells and colour
//!   bar bands opaque filled `<rect>`s;
//! - axes and tick marks are black `<polyline>`s, grid lines `<line opacity="0.12">`s, the
//!   background one white `<rect>` covering the whole image.

mod axis;
mod figure;
mod geometry;
mod heatmap;
mod layout;
mod legend;
mod png;
mod style;

use std::path::{Path, PathBuf};

use plotters::prelude::*;

use crate::{Error, Result};

use layout::Below;
pub use layout::{Layout, Rect};
pub use style::{DASH_PX, GAP_PX, PNG_SCALE, missing_glyphs};

/// How a curve is drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Style {
    /// A solid line (dashed where [`Series::stable`] says the state is unstable).
    Line,
    /// A dashed line throughout, e.g. for a reference curve or an asymptote.
    Dashed,
    /// Unconnected markers, e.g. for measurements; may carry error bars.
    Markers(MarkerShape),
}

/// The symbol of a [`Style::Markers`] series.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MarkerShape {
    Circle,
    Square,
    Triangle,
    Cross,
}

/// One data series.
///
/// `stable`, when given (same length as `x`), splits a [`Style::Line`] series into runs: stable
/// runs solid, unstable runs dashed, in the same colour. A run ends half-way between the last
/// point of one stability and the first of the other, which is the best guess for where the
/// stability changes without further information. The legend then shows the label once, plus one
/// extra entry "unstable (dashed)" for the whole figure if any unstable run exists.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend text; an empty label gives the series no legend entry.
    pub label: String,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub style: Style,
    pub stable: Option<Vec<bool>>,
    /// Optional symmetric error bars (same length as y) for Markers series, or a shaded band +- err
    /// around a Line series.
    pub err: Option<Vec<f64>>,
}

/// A labelled special point (e.g. a fold or Hopf point), drawn as a distinct marker with its
/// label in the legend (one legend entry per distinct label).
#[derive(Clone, Debug)]
pub struct Marker {
    pub label: String,
    pub x: f64,
    pub y: f64,
}

/// The scale of an axis. On a [`Scale::Log`] axis non-positive values cannot be shown and are
/// skipped (the lower end of an error bar or band that would reach them is cut at the axis).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Scale {
    #[default]
    Linear,
    Log,
}

/// A 2-D line/scatter figure.
///
/// Axis ranges cover all drawable data (including error bars, bands and special points) with 5 %
/// padding on each side (multiplicative on a log axis).
#[derive(Clone, Debug, Default)]
pub struct Figure {
    pub title: String,
    /// x-axis label with its unit, e.g. "omega (rad/s)".
    pub x_label: String,
    pub y_label: String,
    pub x_scale: Scale,
    pub y_scale: Scale,
    pub series: Vec<Series>,
    pub markers: Vec<Marker>,
    /// Free text in a box where it covers no data, upper left if free (e.g. "m = 0.62 ± 0.03");
    /// each `\n` starts a new line.
    pub annotation: Option<String>,
    /// One unit spans as many pixels along x as along y (linear axes only), the range of the
    /// axis with the longer unit widened to match: for shapes in space.
    pub equal_scale: bool,
    /// No legend, e.g. on all but one of panels that show the same curves.
    pub hide_legend: bool,
    /// The y range shown, instead of one fitted to the data; whatever lies beyond it is cut at
    /// the frame (lines are drawn up to it, markers beyond it are left out).
    pub y_range: Option<(f64, f64)>,
}

/// A colour map over a regular grid (phase diagrams): `z[i][j]` at `(x[j], y[i])`; NaN cells left blank.
///
/// Cells extend half-way to their neighbours, so the map covers exactly the area the grid
/// samples; `x` and `y` must be strictly monotonic. Colours follow the perceptually uniform,
/// colour-blind-safe viridis map, explained by a colour bar on the right.
#[derive(Clone, Debug, Default)]
pub struct Heatmap {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub colorbar_label: String,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    pub z: Vec<Vec<f64>>,
    /// Curves drawn over the map (e.g. a stability boundary) and labelled points/ranges (Markers
    /// series with err bars allowed).
    pub overlays: Vec<Series>,
    /// Colours interpolated linearly along y between the centres of neighbouring rows of a
    /// column (where both are finite), one pixel row at a time: for a map sampled finely in y,
    /// whose rows would otherwise show as bands. Columns stay apart.
    pub smooth_y: bool,
}

/// Size of the SVG written by [`write_figure`] and [`write_heatmap`], in pixels.
const DEFAULT_SIZE: (u32, u32) = (800, 600);

/// Smallest panel [`write_panels`] accepts: below this the tick labels, axis labels and title no
/// longer fit beside a usable plot area.
const MIN_PANEL_SIZE: (u32, u32) = (300, 240);

/// A figure drawn in memory: the SVG text and where things went on each panel.
#[derive(Clone, Debug)]
pub struct Drawing {
    pub svg: String,
    /// One layout per panel (one for a single figure or heat map).
    pub layouts: Vec<Layout>,
}

impl Drawing {
    /// Writes the SVG to `path` and the PNG beside it ([`png_path`]).
    pub fn write(&self, path: &Path) -> Result<()> {
        std::fs::write(path, &self.svg).map_err(|source| Error::Io {
            path: path.display().to_string(),
            source,
        })?;
        png::write(&self.svg, &png_path(path))
    }
}

/// Where the PNG of the figure written to `svg` goes: the same name with `.png`.
pub fn png_path(svg: &Path) -> PathBuf {
    svg.with_extension("png")
}

/// Several figures side by side (e.g. two orthogonal camera views of a rod shape), each panel
/// with its own axes. `size` is the size of the whole figure, shared evenly. The plot areas
/// keep one height: each panel's starts below the tallest title band (titles can wrap to
/// different numbers of lines) and ends above the tallest strip below.
pub fn render_panels(panels: &[Figure], size: (u32, u32)) -> Result<Drawing> {
    if panels.is_empty() {
        return Err(Error::input("panels", "no figure to draw"));
    }
    let columns = u32::try_from(panels.len()).unwrap_or(u32::MAX);
    if size.0 / columns < MIN_PANEL_SIZE.0 || size.1 < MIN_PANEL_SIZE.1 {
        return Err(Error::input(
            "size",
            format!(
                "{}x{} px is too small for {} panel(s): each needs at least {}x{} px",
                size.0,
                size.1,
                panels.len(),
                MIN_PANEL_SIZE.0,
                MIN_PANEL_SIZE.1
            ),
        ));
    }
    for (i, fig) in panels.iter().enumerate() {
        fig.validate(&format!("panels[{i}]"))?;
    }
    render(size, panels.len(), |root, below| {
        let areas = root.split_evenly((1, panels.len()));
        let under = areas
            .iter()
            .zip(panels)
            .map(|(area, fig)| figure::titled(area, &fig.title))
            .collect::<Result<Vec<Area>>>()?;
        // Titles that wrap to different numbers of lines leave plot areas of one height: each
        // panel's plot starts below the tallest title band of any of them.
        let band = |area: &Area, under: &Area| area.dim_in_pixel().1 - under.dim_in_pixel().1;
        let tallest = areas.iter().zip(&under).map(|(a, u)| band(a, u)).max();
        areas
            .iter()
            .zip(&under)
            .zip(panels)
            .zip(below)
            .map(|(((area, under), fig), below)| {
                let pad = tallest.unwrap_or(0) - band(area, under);
                let (_, plot) = under.split_vertically(pad);
                figure::draw_under_title(&plot, fig, *below)
            })
            .collect()
    })
}

/// `fig` drawn in memory at [`DEFAULT_SIZE`].
pub fn render_figure(fig: &Figure) -> Result<Drawing> {
    fig.validate("figure")?;
    render(DEFAULT_SIZE, 1, |root, below| {
        Ok(vec![figure::draw(root, fig, below[0])?])
    })
}

/// `map` with its colour bar drawn in memory at [`DEFAULT_SIZE`].
pub fn render_heatmap(map: &Heatmap) -> Result<Drawing> {
    map.validate()?;
    render(DEFAULT_SIZE, 1, |root, below| {
        Ok(vec![heatmap::draw(root, map, below[0])?])
    })
}

/// Writes [`render_panels`] to `path` (SVG) and its PNG beside it.
pub fn write_panels(panels: &[Figure], path: &Path, size: (u32, u32)) -> Result<()> {
    render_panels(panels, size)?.write(path)
}

/// Writes [`render_figure`] to `path` (SVG) and its PNG beside it.
pub fn write_figure(fig: &Figure, path: &Path) -> Result<()> {
    render_figure(fig)?.write(path)
}

/// Writes [`render_heatmap`] to `path` (SVG) and its PNG beside it.
pub fn write_heatmap(map: &Heatmap, path: &Path) -> Result<()> {
    render_heatmap(map)?.write(path)
}

/// The drawing area every figure is drawn on: a whole SVG document or one panel of it.
type Area<'a> = DrawingArea<SVGBackend<'a>, plotters::coord::Shift>;

/// Draws `panels` panels into an in-memory SVG of `size` on a white background, as `draw` does
/// with room below each plot for what the [`Below`] of its panel holds.
///
/// Drawn first with nothing below; while a legend or annotation found no free place inside its
/// plot, drawn again with it below (at most once more per kind of box, so at most three times).
/// Side-by-side panels all get a strip as tall as the tallest any of them needs.
fn render(
    size: (u32, u32),
    panels: usize,
    draw: impl Fn(&Area, &[Below]) -> Result<Vec<Layout>>,
) -> Result<Drawing> {
    let mut below = vec![Below::default(); panels];
    loop {
        let mut svg = String::new();
        let layouts = {
            let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
            root.fill(&WHITE).map_err(drawing_error)?;
            let layouts = draw(&root, &below)?;
            root.present().map_err(drawing_error)?;
            layouts
        };
        match legend::more_below(&below, &layouts) {
            Some(mut more) => {
                // Panels side by side keep plot areas of one height (one scale for two views
                // of one object): each gets the tallest strip of any of them.
                let tallest = more.iter().map(Below::height).max().unwrap_or(0);
                for b in &mut more {
                    b.reserve = tallest;
                }
                below = more;
            }
            None => return Ok(Drawing { svg, layouts }),
        }
    }
}

/// `plotters` reports drawing failures with its own error type; they are not the caller's input
/// errors, so they become [`Error::Numerical`].
fn drawing_error<E: std::error::Error + Send + Sync>(
    e: plotters::drawing::DrawingAreaErrorKind<E>,
) -> Error {
    Error::Numerical(format!("drawing the SVG figure failed: {e}"))
}

impl Series {
    /// Checks that the optional vectors match the data in length.
    fn validate(&self, field: &str) -> Result<()> {
        let n = self.x.len();
        let check = |name: &str, len: usize| {
            if len == n {
                Ok(())
            } else {
                Err(Error::input(
                    format!("{field}.{name}"),
                    format!("has {len} values but x has {n}"),
                ))
            }
        };
        check("y", self.y.len())?;
        if let Some(stable) = &self.stable {
            check("stable", stable.len())?;
        }
        if let Some(err) = &self.err {
            check("err", err.len())?;
        }
        Ok(())
    }
}

impl Figure {
    fn validate(&self, field: &str) -> Result<()> {
        for (i, s) in self.series.iter().enumerate() {
            s.validate(&format!("{field}.series[{i}]"))?;
        }
        Ok(())
    }
}

impl Heatmap {
    /// Checks that `z` has one row per `y` and one column per `x`, and that the grid is
    /// finite and strictly monotonic (cells are built from the midpoints between grid values).
    fn validate(&self) -> Result<()> {
        if self.z.len() != self.y.len() {
            return Err(Error::input(
                "heatmap.z",
                format!(
                    "has {} rows but y has {} values",
                    self.z.len(),
                    self.y.len()
                ),
            ));
        }
        if let Some((i, row)) = self
            .z
            .iter()
            .enumerate()
            .find(|(_, row)| row.len() != self.x.len())
        {
            return Err(Error::input(
                format!("heatmap.z[{i}]"),
                format!("has {} values but x has {}", row.len(), self.x.len()),
            ));
        }
        for (name, grid) in [("x", &self.x), ("y", &self.y)] {
            if !heatmap::is_strictly_monotonic(grid) {
                return Err(Error::input(
                    format!("heatmap.{name}"),
                    "grid values must be finite and strictly increasing or decreasing",
                ));
            }
        }
        for (i, s) in self.overlays.iter().enumerate() {
            s.validate(&format!("heatmap.overlays[{i}]"))?;
        }
        Ok(())
    }
}
