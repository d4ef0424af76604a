//! Where things went on a drawn figure, in pixels of the SVG, and the search for a place for a
//! legend or an annotation box that covers no data.

/// An axis-aligned box in pixels of the SVG (`x0 <= x1`, `y0 <= y1`, y downwards), edges
/// included.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Rect {
    pub x0: i32,
    pub y0: i32,
    pub x1: i32,
    pub y1: i32,
}

impl Rect {
    /// The box with corners `a` and `b` in any order.
    pub fn spanning(a: (i32, i32), b: (i32, i32)) -> Self {
        Rect {
            x0: a.0.min(b.0),
            y0: a.1.min(b.1),
            x1: a.0.max(b.0),
            y1: a.1.max(b.1),
        }
    }

    /// The box of size `(w, h)` whose upper-left corner is `at`.
    pub fn sized(at: (i32, i32), (w, h): (i32, i32)) -> Self {
        Rect {
            x0: at.0,
            y0: at.1,
            x1: at.0 + w,
            y1: at.1 + h,
        }
    }

    /// The box grown by `d` pixels on every side.
    pub fn inflate(self, d: i32) -> Self {
        Rect {
            x0: self.x0 - d,
            y0: self.y0 - d,
            x1: self.x1 + d,
            y1: self.y1 + d,
        }
    }

    /// Whether the two boxes share any pixel.
    pub fn intersects(&self, other: &Rect) -> bool {
        self.x0 <= other.x1 && other.x0 <= self.x1 && self.y0 <= other.y1 && other.y0 <= self.y1
    }

    /// Whether `other` lies inside this box.
    pub fn contains(&self, other: &Rect) -> bool {
        self.x0 <= other.x0 && other.x1 <= self.x1 && self.y0 <= other.y0 && other.y1 <= self.y1
    }

    pub fn width(&self) -> i32 {
        self.x1 - self.x0
    }

    pub fn height(&self) -> i32 {
        self.y1 - self.y0
    }
}

/// What was drawn where on one figure or panel, for checking a figure without looking at it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Layout {
    /// The plot area (inside the axes).
    pub plot_area: Rect,
    /// Boxes covering everything drawn from the data: each marker, error bar, heat-map cell,
    /// slice of an error band, and piece (at most a few pixels long) of each curve, with the
    /// stroke's width.
    pub data: Vec<Rect>,
    /// The legend's box, if there is a legend.
    pub legend: Option<Rect>,
    /// The annotation's box, if there is an annotation.
    pub annotation: Option<Rect>,
    /// Whether the legend, the annotation, went below the plot because no place inside the plot
    /// area was free of data.
    pub legend_below: bool,
    pub annotation_below: bool,
    /// Pixels per data unit along x and along y, on linear axes (NaN on a log axis): equal for a
    /// figure drawn with [`super::Figure::equal_scale`].
    pub px_per_unit: (f64, f64),
    /// Sizes of the legend and annotation boxes that did not fit inside the plot area; the
    /// figure is drawn again with room for them below.
    pub(crate) wants_below: Below,
}

/// What goes below the plot area: the sizes of the boxes that found no place inside it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Below {
    pub legend: Option<(i32, i32)>,
    pub annotation: Option<(i32, i32)>,
    /// The strip's least height, whatever it holds: side-by-side panels all get the tallest
    /// strip of any of them, so their plot areas keep one height.
    pub reserve: i32,
}

impl Below {
    /// Height of the strip below the plot that holds these boxes, one above the other.
    pub fn height(&self) -> i32 {
        let boxes = [self.legend, self.annotation];
        let heights: Vec<i32> = boxes.iter().flatten().map(|b| b.1).collect();
        let held = if heights.is_empty() {
            0
        } else {
            heights.iter().sum::<i32>() + GAP_BELOW_PX * (heights.len() as i32 + 1)
        };
        held.max(self.reserve)
    }

    /// Whether `other` asks to put below anything this does not.
    pub fn adds(&self, other: &Below) -> bool {
        (other.legend.is_some() && self.legend.is_none())
            || (other.annotation.is_some() && self.annotation.is_none())
    }

    /// Everything either puts below (the sizes of `other` where both have a box).
    pub fn union(&self, other: &Below) -> Below {
        Below {
            legend: other.legend.or(self.legend),
            annotation: other.annotation.or(self.annotation),
            reserve: self.reserve.max(other.reserve),
        }
    }
}

/// Space between the boxes of the strip below the plot, and above and below them.
pub(crate) const GAP_BELOW_PX: i32 = 6;

/// Where a box of `size` pixels goes inside `area` without touching any of `obstacles` (which
/// are grown by `clearance`), searched in this order: the `preferred` corners and side middles,
/// then every position along the four sides of the area (the box touching the frame), every
/// `STEP_PX` pixels; `None` when no such place exists.
pub(crate) fn free_place(
    area: Rect,
    size: (i32, i32),
    obstacles: &[Rect],
    clearance: i32,
    preferred: &[Anchor],
) -> Option<Rect> {
    let inner = area.inflate(-clearance);
    let (w, h) = size;
    if w > inner.width() || h > inner.height() {
        return None;
    }
    let (left, top, right, bottom) = (inner.x0, inner.y0, inner.x1 - w, inner.y1 - h);
    let free = |r: &Rect| !obstacles.iter().any(|o| o.inflate(clearance).intersects(r));
    let anchored = preferred.iter().map(|a| {
        let x = match a.0 {
            Side::Start => left,
            Side::Middle => (left + right) / 2,
            Side::End => right,
        };
        let y = match a.1 {
            Side::Start => top,
            Side::Middle => (top + bottom) / 2,
            Side::End => bottom,
        };
        (x, y)
    });
    let along = |from: i32, to: i32| {
        (0..)
            .map(move |k| from + k * STEP_PX)
            .take_while(move |v| *v <= to)
    };
    let sides = along(left, right)
        .flat_map(|x| [(x, top), (x, bottom)])
        .chain(along(top, bottom).flat_map(|y| [(left, y), (right, y)]));
    anchored
        .chain(sides)
        .map(|at| Rect::sized(at, size))
        .find(free)
}

/// Step between the positions along the sides that [`free_place`] tries.
const STEP_PX: i32 = 4;

/// Where along one direction a box is anchored.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Side {
    Start,
    Middle,
    End,
}

/// A position of a box in the plot area: horizontal side, vertical side.
pub(crate) type Anchor = (Side, Side);

/// The legend's order of preference: upper right, upper left, lower right, lower left, then the
/// middles of the left, right, top and bottom sides.
pub(crate) const LEGEND_ANCHORS: [Anchor; 8] = [
    (Side::End, Side::Start),
    (Side::Start, Side::Start),
    (Side::End, Side::End),
    (Side::Start, Side::End),
    (Side::Start, Side::Middle),
    (Side::End, Side::Middle),
    (Side::Middle, Side::Start),
    (Side::Middle, Side::End),
];

/// The annotation's order of preference: upper left first, where a reader looks for it.
pub(crate) const ANNOTATION_ANCHORS: [Anchor; 8] = [
    (Side::Start, Side::Start),
    (Side::End, Side::Start),
    (Side::Start, Side::End),
    (Side::End, Side::End),
    (Side::Start, Side::Middle),
    (Side::End, Side::Middle),
    (Side::Middle, Side::Start),
    (Side::Middle, Side::End),
];

/// The boxes covering a stroke of `width` pixels along the polyline `pixels`, cut into pieces at
/// most `PIECE_PX` long so that a diagonal stroke is covered closely.
pub(crate) fn stroke_boxes(pixels: &[(i32, i32)], width: i32) -> Vec<Rect> {
    let half = width / 2 + 1;
    if let [p] = pixels {
        return vec![Rect::spanning(*p, *p).inflate(half + 1)];
    }
    let mut out = Vec::new();
    for pair in pixels.windows(2) {
        let ((x0, y0), (x1, y1)) = (pair[0], pair[1]);
        let len = f64::from(x1 - x0).hypot(f64::from(y1 - y0));
        let steps = (len / PIECE_PX).ceil().clamp(1.0, 4000.0) as i32;
        let at = |k: i32| (x0 + (x1 - x0) * k / steps, y0 + (y1 - y0) * k / steps);
        out.extend((0..steps).map(|k| Rect::spanning(at(k), at(k + 1)).inflate(half)));
    }
    out
}

/// Longest piece of a curve covered by one box.
const PIECE_PX: f64 = 6.0;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn boxes_intersect_when_they_share_a_pixel() {
        let a = Rect::sized((0, 0), (10, 10));
        assert!(a.intersects(&Rect::sized((10, 10), (5, 5))));
        assert!(!a.intersects(&Rect::sized((11, 0), (5, 5))));
        assert!(a.contains(&Rect::sized((2, 2), (3, 3))));
    }

    #[test]
    fn a_box_goes_to_the_first_free_anchor_or_along_a_side() {
        let area = Rect::sized((0, 0), (200, 100));
        let upper_right = Rect::sized((150, 0), (50, 30));
        let place = free_place(area, (40, 20), &[upper_right], 2, &LEGEND_ANCHORS).unwrap();
        assert_eq!(
            (place.x0, place.y0),
            (2, 2),
            "upper left when upper right is taken"
        );
        // A band through the middle of every side except the bottom's right half.
        let cross = [
            Rect::sized((0, 0), (200, 70)),
            Rect::sized((0, 70), (120, 30)),
        ];
        let place = free_place(area, (40, 20), &cross, 2, &LEGEND_ANCHORS).unwrap();
        assert!(cross.iter().all(|c| !c.inflate(2).intersects(&place)));
        assert!(area.contains(&place));
        let full = [Rect::sized((0, 0), (200, 100))];
        assert_eq!(free_place(area, (40, 20), &full, 2, &LEGEND_ANCHORS), None);
        assert_eq!(free_place(area, (400, 20), &[], 2, &LEGEND_ANCHORS), None);
    }

    #[test]
    fn strokes_are_covered_piece_by_piece() {
        let boxes = stroke_boxes(&[(0, 0), (60, 60)], 2);
        assert!(boxes.len() >= 10);
        assert!(boxes.iter().all(|b| b.width() <= 8 && b.height() <= 8));
        assert!(
            !boxes
                .iter()
                .any(|b| b.intersects(&Rect::sized((40, 0), (10, 10))))
        );
    }
}
