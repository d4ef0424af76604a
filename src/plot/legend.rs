//! The legend and the annotation of a plot: each in a box placed where it covers no data (see
//! [`free_place`]), the annotation first; a box that finds no such place goes below the plot,
//! in a strip the figure is drawn again with.

use plotters::element::{DashedPathElement, DynElement, IntoDynElement};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::figure::{Pixel, Plot};
use super::layout::{
    ANNOTATION_ANCHORS, Below, GAP_BELOW_PX, LEGEND_ANCHORS, Layout, Rect, free_place,
};
use super::style::{
    ANNOTATION_PX, BOX_FILL_OPACITY, BOX_FRAME_OPACITY, BOX_MARGIN_PX, CLEARANCE_PX, DASH_PX,
    GAP_PX, Glyph, LEGEND_PX, LINE_WIDTH, NEUTRAL, ROW_HEIGHT, SAMPLE_PX, font, text_width,
};
use super::{Area, drawing_error};
use crate::Result;

/// Text of the single legend entry that explains dashed (unstable) runs.
const UNSTABLE_LABEL: &str = "unstable (dashed)";

/// Width reserved for the sample in front of each legend label.
const SAMPLE_AREA_PX: i32 = SAMPLE_PX + 10;

/// How a legend entry's sample is drawn: the series' own line, dashes or marker.
#[derive(Clone, Copy)]
pub(crate) enum Sample {
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

pub(crate) struct LegendEntry {
    pub label: String,
    pub sample: Sample,
}

/// Height of one row of text at `px` pixels.
fn row_px(px: f64) -> f64 {
    ROW_HEIGHT * px
}

impl<'b> Plot<'_, 'b> {
    /// Writes `text` (one line per `\n`) in a box where it covers no data (upper left if free);
    /// drawn by [`Plot::finish`].
    pub(crate) fn annotate(&mut self, text: &str) -> Result<()> {
        if text.lines().all(|l| l.trim().is_empty()) {
            return Ok(());
        }
        self.annotation = text.lines().map(str::to_owned).collect();
        Ok(())
    }

    /// Size of the annotation box.
    fn annotation_size(&self) -> (i32, i32) {
        let widest = self
            .annotation
            .iter()
            .map(|l| text_width(l, ANNOTATION_PX))
            .fold(0.0, f64::max);
        (
            widest.ceil() as i32 + 2 * BOX_MARGIN_PX,
            (self.annotation.len() as f64 * row_px(ANNOTATION_PX)).ceil() as i32
                + 2 * BOX_MARGIN_PX,
        )
    }

    /// Size of the legend box.
    fn legend_size(&self) -> (i32, i32) {
        let widest = self
            .entries
            .iter()
            .map(|e| text_width(&e.label, LEGEND_PX))
            .fold(0.0, f64::max);
        (
            widest.ceil() as i32 + SAMPLE_AREA_PX + 2 * BOX_MARGIN_PX,
            (self.entries.len() as f64 * row_px(LEGEND_PX)).ceil() as i32 + 2 * BOX_MARGIN_PX,
        )
    }

    /// Draws the annotation and the legend, and returns the figure's layout. The legend is drawn
    /// if it has at least `min_entries` entries (or any special point, whose meaning only the
    /// legend gives): series in order, then "unstable (dashed)" if any series has an unstable
    /// run, then the special points.
    ///
    /// Each box goes where it covers no data (the legend not the annotation either), else below
    /// the plot when the figure is drawn with room for it there; until then the layout asks for
    /// that room ([`Layout::wants_below`]).
    pub(crate) fn finish(mut self, min_entries: usize) -> Result<Layout> {
        if self.any_unstable {
            self.entries.push(LegendEntry {
                label: UNSTABLE_LABEL.to_owned(),
                sample: Sample::Dashed(NEUTRAL),
            });
        }
        let has_specials = !self.special_entries.is_empty();
        self.entries.append(&mut self.special_entries);
        let legend = self.entries.len() >= min_entries || has_specials;
        let plot_area = self.layout.plot_area;
        let mut below_y = self.strip_top() + GAP_BELOW_PX;
        let mut taken = self.data.clone();

        if !self.annotation.is_empty() {
            let size = self.annotation_size();
            let place = if self.below.annotation.is_some() {
                Some(self.below_box(size, &mut below_y))
            } else {
                free_place(plot_area, size, &taken, CLEARANCE_PX, &ANNOTATION_ANCHORS)
            };
            match place {
                Some(rect) => {
                    self.draw_annotation(rect)?;
                    self.layout.annotation = Some(rect);
                    self.layout.annotation_below = self.below.annotation.is_some();
                    taken.push(rect);
                }
                None => self.layout.wants_below.annotation = Some(size),
            }
        }
        if legend && !self.entries.is_empty() {
            let size = self.legend_size();
            let place = if self.below.legend.is_some() {
                Some(self.below_box(size, &mut below_y))
            } else {
                free_place(plot_area, size, &taken, CLEARANCE_PX, &LEGEND_ANCHORS)
            };
            match place {
                Some(rect) => {
                    self.draw_legend(rect)?;
                    self.layout.legend = Some(rect);
                    self.layout.legend_below = self.below.legend.is_some();
                }
                None => self.layout.wants_below.legend = Some(size),
            }
        }
        self.layout.data = std::mem::take(&mut self.data);
        Ok(self.layout)
    }

    /// Top of the strip below the plot, in pixels of the SVG.
    fn strip_top(&self) -> i32 {
        self.strip
            .as_ref()
            .map_or(self.layout.plot_area.y1, |s| s.get_base_pixel().1)
    }

    /// The next box of `size` in the strip below the plot, centred under the plot area.
    fn below_box(&self, size: (i32, i32), y: &mut i32) -> Rect {
        let area = self.layout.plot_area;
        let x = (area.x0 + area.x1 - size.0) / 2;
        let rect = Rect::sized((x.max(0), *y), size);
        *y += size.1 + GAP_BELOW_PX;
        rect
    }

    /// The panel to draw the boxes on and its upper-left corner in pixels of the SVG.
    fn canvas(&self) -> (Area<'b>, Pixel) {
        let area = match &self.canvas {
            Some(canvas) => canvas.clone(),
            None => self.chart.plotting_area().strip_coord_spec(),
        };
        let base = area.get_base_pixel();
        (area, base)
    }

    /// A white box at `rect`, framed when `framed`.
    fn draw_box(&self, rect: Rect, framed: bool) -> Result<()> {
        let (canvas, (bx, by)) = self.canvas();
        let corners = [(rect.x0 - bx, rect.y0 - by), (rect.x1 - bx, rect.y1 - by)];
        canvas
            .draw(&Rectangle::new(
                corners,
                WHITE.mix(BOX_FILL_OPACITY).filled(),
            ))
            .map_err(drawing_error)?;
        if framed {
            canvas
                .draw(&Rectangle::new(
                    corners,
                    BLACK.mix(BOX_FRAME_OPACITY).stroke_width(1),
                ))
                .map_err(drawing_error)?;
        }
        Ok(())
    }

    fn draw_annotation(&self, rect: Rect) -> Result<()> {
        self.draw_box(rect, false)?;
        let (canvas, (bx, by)) = self.canvas();
        let style = font(ANNOTATION_PX).pos(Pos::new(HPos::Left, VPos::Center));
        for (k, line) in self.annotation.iter().enumerate() {
            let y = rect.y0 + BOX_MARGIN_PX + (row_px(ANNOTATION_PX) * (k as f64 + 0.5)) as i32;
            canvas
                .draw(&Text::new(
                    line.as_str(),
                    (rect.x0 + BOX_MARGIN_PX - bx, y - by),
                    &style,
                ))
                .map_err(drawing_error)?;
        }
        Ok(())
    }

    fn draw_legend(&self, rect: Rect) -> Result<()> {
        self.draw_box(rect, true)?;
        let (canvas, (bx, by)) = self.canvas();
        let style = font(LEGEND_PX).pos(Pos::new(HPos::Left, VPos::Center));
        for (k, entry) in self.entries.iter().enumerate() {
            let y = rect.y0 + BOX_MARGIN_PX + (row_px(LEGEND_PX) * (k as f64 + 0.5)) as i32 - by;
            let x = rect.x0 + BOX_MARGIN_PX - bx;
            canvas
                .draw(&entry.sample.element((x, y)))
                .map_err(drawing_error)?;
            canvas
                .draw(&Text::new(
                    entry.label.as_str(),
                    (x + SAMPLE_AREA_PX, y),
                    &style,
                ))
                .map_err(drawing_error)?;
        }
        Ok(())
    }
}

/// What the layouts of a drawing ask to put below their plots, added to what `below` already
/// puts there; `None` when they ask for nothing new.
pub(crate) fn more_below(below: &[Below], layouts: &[Layout]) -> Option<Vec<Below>> {
    let grows = below
        .iter()
        .zip(layouts)
        .any(|(b, l)| b.adds(&l.wants_below));
    grows.then(|| {
        below
            .iter()
            .zip(layouts)
            .map(|(b, l)| b.union(&l.wants_below))
            .collect()
    })
}
