//! Colours, fonts, sizes and marker glyphs shared by every figure.

use plotters::element::{Circle, Cross, DynElement, EmptyElement, IntoDynElement, Polygon};
use plotters::prelude::{DrawingBackend, Rectangle};
use plotters::style::{Color, IntoFont, RGBColor, ShapeStyle, TextStyle};

use super::MarkerShape;

/// Length of one dash of a dashed curve, in pixels.
pub const DASH_PX: i32 = 7;
/// Gap between two dashes of a dashed curve, in pixels.
pub const GAP_PX: i32 = 4;

/// Okabe & Ito's colour-blind-safe palette, ordered so neighbouring series differ most. Their
/// yellow is left out: it is too faint as a line on white.
const PALETTE: [RGBColor; 7] = [
    RGBColor(0x00, 0x72, 0xB2), // blue
    RGBColor(0xD5, 0x5E, 0x00), // vermillion
    RGBColor(0x00, 0x9E, 0x73), // bluish green
    RGBColor(0xE6, 0x9F, 0x00), // orange
    RGBColor(0xCC, 0x79, 0xA7), // reddish purple
    RGBColor(0x56, 0xB4, 0xE9), // sky blue
    RGBColor(0x00, 0x00, 0x00), // black
];

/// Colours for curves over a viridis heat map: the palette reordered so the first ones (red,
/// black, pink) are hues viridis does not contain.
const OVERLAY_PALETTE: [RGBColor; 7] = [
    PALETTE[1], PALETTE[6], PALETTE[4], PALETTE[3], PALETTE[0], PALETTE[5], PALETTE[2],
];

/// Colour of the i-th series of a figure.
pub(crate) fn series_color(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

/// Colour of the i-th overlay of a heat map.
pub(crate) fn overlay_color(i: usize) -> RGBColor {
    OVERLAY_PALETTE[i % OVERLAY_PALETTE.len()]
}

/// Colour of the legend sample that explains dashed (unstable) runs: neutral, since it stands
/// for every series.
pub const NEUTRAL: RGBColor = RGBColor(0x55, 0x55, 0x55);

/// Font sizes in pixels, as they appear in the SVG's `font-size`.
pub(crate) const TITLE_PX: f64 = 20.0;
pub(crate) const AXIS_LABEL_PX: f64 = 18.0;
pub(crate) const TICK_PX: f64 = 16.0;
pub(crate) const LEGEND_PX: f64 = 16.0;
pub(crate) const ANNOTATION_PX: f64 = 16.0;

/// Width of a typical character relative to the font size, for laying out text whose rendered
/// width the SVG backend cannot know (generous, so boxes and margins are not too tight).
pub(crate) const CHAR_WIDTH: f64 = 0.62;

pub(crate) const LINE_WIDTH: u32 = 2;
/// Radius of the markers of a Markers series.
pub(crate) const MARKER_PX: i32 = 5;
/// Radius of the special-point markers, larger so they stand out on the curves.
pub(crate) const SPECIAL_PX: i32 = 7;
/// Half-width of the caps of error bars.
pub(crate) const CAP_PX: i32 = 4;
/// Opacity of the band drawn around a Line series with errors.
pub(crate) const BAND_OPACITY: f64 = 0.2;
/// Length of the line drawn as a legend sample: exactly three dashes when dashed.
pub(crate) const SAMPLE_PX: i32 = 3 * DASH_PX + 2 * GAP_PX;

/// A sans-serif font whose SVG `font-size` is `px` (`plotters`' SVG backend divides the size it
/// is given by 1.24).
pub(crate) fn font(px: f64) -> TextStyle<'static> {
    ("sans-serif", px * 1.24).into_font().into()
}

/// The symbol drawn at a point: the public [`MarkerShape`]s plus two shapes reserved for special
/// points, so those never look like data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Glyph {
    Circle,
    Square,
    Triangle,
    Cross,
    Diamond,
    TriangleDown,
}

impl From<MarkerShape> for Glyph {
    fn from(shape: MarkerShape) -> Self {
        match shape {
            MarkerShape::Circle => Glyph::Circle,
            MarkerShape::Square => Glyph::Square,
            MarkerShape::Triangle => Glyph::Triangle,
            MarkerShape::Cross => Glyph::Cross,
        }
    }
}

/// Glyphs of the special points, one per distinct label in turn; all drawn in black.
pub(crate) const SPECIAL_GLYPHS: [Glyph; 4] = [
    Glyph::Diamond,
    Glyph::TriangleDown,
    Glyph::Square,
    Glyph::Circle,
];

impl Glyph {
    /// The glyph of radius `r` pixels centred on `at` (a data point or a legend position).
    pub fn at<'a, DB: DrawingBackend + 'a, C: Clone + 'a>(
        self,
        at: C,
        r: i32,
        color: RGBColor,
    ) -> DynElement<'a, DB, C> {
        let fill = color.filled();
        let anchor = EmptyElement::at(at);
        // Triangles and diamonds are drawn a little larger than r to match a circle's weight.
        let t = r + r / 3;
        match self {
            Glyph::Circle => (anchor + Circle::new((0, 0), r, fill)).into_dyn(),
            Glyph::Square => (anchor + Rectangle::new([(-r, -r), (r, r)], fill)).into_dyn(),
            Glyph::Triangle => (anchor
                + Polygon::new(vec![(0, -t), (t, r * 2 / 3), (-t, r * 2 / 3)], fill))
            .into_dyn(),
            Glyph::TriangleDown => (anchor
                + Polygon::new(vec![(0, t), (t, -r * 2 / 3), (-t, -r * 2 / 3)], fill))
            .into_dyn(),
            Glyph::Diamond => {
                (anchor + Polygon::new(vec![(0, -t), (t, 0), (0, t), (-t, 0)], fill)).into_dyn()
            }
            Glyph::Cross => {
                let stroke = ShapeStyle::from(color).stroke_width(LINE_WIDTH);
                (anchor + Cross::new((0, 0), r, stroke)).into_dyn()
            }
        }
    }
}
