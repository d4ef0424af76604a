//! The one style of every figure: the font (its family in the SVG, the file embedded for the PNG
//! and for measuring text), font sizes, colours, line widths, dash patterns, marker glyphs and
//! sizes, and the PNG's scale. Figures agree because nothing of this is set anywhere else.

use plotters::element::{Circle, Cross, DynElement, EmptyElement, IntoDynElement, Polygon};
use plotters::prelude::{DrawingBackend, Rectangle};
use plotters::style::{Color, IntoFont, RGBColor, ShapeStyle, TextStyle};

use skrifa::MetadataProvider;
use skrifa::prelude::{FontRef, LocationRef, Size};

use super::MarkerShape;

/// The font of every text: DejaVu Sans 2.37 (Bitstream Vera licence, see
/// `assets/fonts/LICENSE-DejaVu.txt`), embedded so the PNG looks the same on every machine and
/// needs no font installed (no fontconfig). It covers what the labels use: Greek letters,
/// combining macrons (F̄, ω̄, h̄), sub- and superscript digits and letters, ×, −, ±, ℓ.
pub(crate) static FONT_TTF: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// The family name of [`FONT_TTF`]; the SVG asks for the generic `sans-serif`, which the PNG
/// renderer maps to this font.
pub(crate) const FONT_NAME: &str = "DejaVu Sans";

/// The family every `<text>` of the SVG asks for.
pub(crate) const FONT_FAMILY: &str = "sans-serif";

/// Pixels of the PNG per pixel of the SVG: 2 gives a 1600×1200 image for a 800×600 figure,
/// sharp enough to paste into a paper or a slide.
pub const PNG_SCALE: u32 = 2;

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

/// Width of a typical character relative to the font size, for sizing margins from tick labels
/// (generous, so margins are not too tight); boxes around text use [`text_width`].
pub(crate) const CHAR_WIDTH: f64 = 0.62;

/// The embedded font, parsed.
fn font_ref() -> FontRef<'static> {
    FontRef::new(FONT_TTF).expect("the embedded font parses")
}

/// Width in pixels of `text` set in [`FONT_TTF`] at `px` pixels, the width it has in the PNG
/// (a viewer of the SVG with another sans-serif font sets it a little narrower or wider; DejaVu
/// Sans is among the widest, so boxes sized by it hold the text in the usual fonts too). A
/// character the font lacks counts as [`CHAR_WIDTH`] em; combining marks add nothing.
pub(crate) fn text_width(text: &str, px: f64) -> f64 {
    let font = font_ref();
    let charmap = font.charmap();
    let metrics = font.glyph_metrics(Size::new(px as f32), LocationRef::default());
    text.chars()
        .map(|c| {
            charmap
                .map(c)
                .and_then(|g| metrics.advance_width(g))
                .map_or(CHAR_WIDTH * px, f64::from)
        })
        .sum()
}

/// The characters of `text` that the embedded font has no glyph for (they would be missing from
/// the PNG); empty for every label the figures use.
pub fn missing_glyphs(text: &str) -> Vec<char> {
    let charmap = font_ref().charmap();
    text.chars()
        .filter(|c| !c.is_whitespace() && charmap.map(*c).is_none())
        .collect()
}

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

/// The figures' font whose SVG `font-size` is `px` (`plotters`' SVG backend divides the size it
/// is given by 1.24).
pub(crate) fn font(px: f64) -> TextStyle<'static> {
    (FONT_FAMILY, px * 1.24).into_font().into()
}

/// Space kept between a legend or annotation box and the data, and between the box and the
/// frame of the plot area, in pixels.
pub(crate) const CLEARANCE_PX: i32 = 4;
/// Padding inside the legend and annotation boxes, in pixels.
pub(crate) const BOX_MARGIN_PX: i32 = 8;
/// Height of one row of a legend or annotation, relative to its font size.
pub(crate) const ROW_HEIGHT: f64 = 1.3;
/// Opacity of the white under a legend or annotation box.
pub(crate) const BOX_FILL_OPACITY: f64 = 0.9;
/// Opacity of the black frame of a legend box.
pub(crate) const BOX_FRAME_OPACITY: f64 = 0.4;
/// Opacity of the grid lines.
pub(crate) const GRID_OPACITY: f64 = 0.12;

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
    /// How far the glyph of radius `r` reaches from its centre, in pixels (with its stroke).
    pub fn reach(self, r: i32) -> i32 {
        match self {
            Glyph::Triangle | Glyph::TriangleDown | Glyph::Diamond => r + r / 3 + 1,
            _ => r + 1,
        }
    }

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
