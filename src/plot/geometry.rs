//! Turning a [`Series`] into drawable pieces: which points can be shown, where a line breaks
//! or changes between solid and dashed, and the outlines of error bands and bars.
//!
//! These are pure functions of the data and the axes, kept apart from the drawing code so the
//! rules (documented on [`Series`]) are easy to check.

use super::axis::Axis;
use super::{Scale, Series, Style};

/// A point in data coordinates.
pub type Point = (f64, f64);

/// A connected piece of a line series, drawn with one stroke.
#[derive(Clone, Debug, PartialEq)]
pub struct Run {
    pub points: Vec<Point>,
    pub dashed: bool,
}

/// A vertical error bar.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ErrorBar {
    pub x: f64,
    pub lo: f64,
    pub hi: f64,
    /// The lower end was cut at the bottom of the axis (below its range, or at or below zero on
    /// a log axis), so it must not get a cap (a cap would claim the error ends there).
    pub cut: bool,
    /// The upper end was cut at the top of the axis.
    pub cut_hi: bool,
}

/// Whether point `i` of `s` can be drawn on these axes.
fn shown(s: &Series, i: usize, xa: &Axis, ya: &Axis) -> bool {
    xa.shows(s.x[i]) && ya.shows(s.y[i])
}

/// `v` moved into the range of `axis` (a value it cannot show goes to the bottom), and whether
/// it had to be moved.
fn clamp(axis: &Axis, v: f64) -> (f64, bool) {
    let (lo, hi) = axis.bounds();
    if !axis.shows(v) || v < lo {
        (lo, true)
    } else if v > hi {
        (hi, true)
    } else {
        (v, false)
    }
}

/// The error of point `i`, if the series has one that can be drawn.
fn error(s: &Series, i: usize) -> Option<f64> {
    s.err
        .as_ref()
        .map(|err| err[i].abs())
        .filter(|e| e.is_finite())
}

/// Maximal stretches of consecutive indices for which `keep` holds.
fn stretches(n: usize, keep: impl Fn(usize) -> bool) -> Vec<Vec<usize>> {
    let mut out: Vec<Vec<usize>> = Vec::new();
    let mut current = Vec::new();
    for i in 0..n {
        if keep(i) {
            current.push(i);
        } else if !current.is_empty() {
            out.push(std::mem::take(&mut current));
        }
    }
    if !current.is_empty() {
        out.push(current);
    }
    out
}

/// The points of `s` that can be drawn on these axes, in order.
pub fn points(s: &Series, xa: &Axis, ya: &Axis) -> Vec<Point> {
    (0..s.x.len())
        .filter(|&i| xa.contains(s.x[i]) && ya.contains(s.y[i]))
        .map(|i| (s.x[i], s.y[i]))
        .collect()
}

/// The runs of a line series (Line or Dashed style).
///
/// A point that cannot be drawn breaks the line. A Dashed series is dashed throughout; a Line
/// series is dashed where `stable` is false, and where stability changes between two points the
/// runs meet at the midpoint between them (as seen on the axes), so the curve stays connected.
/// A run of a single point is returned as such; the caller draws it (like any run that stays on
/// one point) as a dot, so it is not lost. Runs are cut where they leave the axes' ranges.
pub(crate) fn line_runs(s: &Series, xa: &Axis, ya: &Axis) -> Vec<Run> {
    let dashed = |i: usize| match s.style {
        Style::Dashed => true,
        _ => s.stable.as_ref().is_some_and(|stable| !stable[i]),
    };
    let at = |i: usize| (s.x[i], s.y[i]);
    let mut runs = Vec::new();
    for stretch in stretches(s.x.len(), |i| shown(s, i, xa, ya)) {
        let mut run = Run {
            points: vec![at(stretch[0])],
            dashed: dashed(stretch[0]),
        };
        for pair in stretch.windows(2) {
            let (i, j) = (pair[0], pair[1]);
            if dashed(j) == run.dashed {
                run.points.push(at(j));
            } else {
                let mid = (xa.midpoint(s.x[i], s.x[j]), ya.midpoint(s.y[i], s.y[j]));
                run.points.push(mid);
                let next = Run {
                    points: vec![mid, at(j)],
                    dashed: dashed(j),
                };
                runs.push(std::mem::replace(&mut run, next));
            }
        }
        runs.push(run);
    }
    runs.into_iter()
        .flat_map(|run| {
            clip(&run.points, xa, ya)
                .into_iter()
                .map(move |points| Run {
                    points,
                    dashed: run.dashed,
                })
        })
        .collect()
}

/// The pieces of the polyline `points` within the axes' ranges: a segment that leaves them is
/// cut where it crosses the frame (found in axis fractions, so on log axes too).
fn clip(points: &[Point], xa: &Axis, ya: &Axis) -> Vec<Vec<Point>> {
    const EPS: f64 = 1e-9;
    let frac = |p: Point| (xa.fraction(p.0), ya.fraction(p.1));
    let inside =
        |(u, v): (f64, f64)| (-EPS..=1.0 + EPS).contains(&u) && (-EPS..=1.0 + EPS).contains(&v);
    if points.iter().all(|p| inside(frac(*p))) {
        return vec![points.to_vec()];
    }
    if points.len() < 2 {
        return Vec::new();
    }
    let back = |(u, v): (f64, f64)| (xa.at_fraction(u), ya.at_fraction(v));
    let mut pieces = Vec::new();
    let mut current: Vec<Point> = Vec::new();
    for pair in points.windows(2) {
        let (a, b) = (frac(pair[0]), frac(pair[1]));
        let Some((t0, t1)) = liang_barsky(a, b, -EPS, 1.0 + EPS) else {
            if current.len() >= 2 {
                pieces.push(std::mem::take(&mut current));
            }
            current.clear();
            continue;
        };
        let at = |t: f64| (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
        let start = if t0 > 0.0 { back(at(t0)) } else { pair[0] };
        let end = if t1 < 1.0 { back(at(t1)) } else { pair[1] };
        if t0 > 0.0 || current.is_empty() {
            if current.len() >= 2 {
                pieces.push(std::mem::take(&mut current));
            }
            current = vec![start];
        }
        current.push(end);
        if t1 < 1.0 {
            pieces.push(std::mem::take(&mut current));
        }
    }
    if current.len() >= 2 {
        pieces.push(current);
    }
    pieces
}

/// The part `t0..t1` of the segment from `a` to `b` inside the square `lo..=hi` in both
/// coordinates (Liang–Barsky); `None` if it misses the square.
fn liang_barsky(a: (f64, f64), b: (f64, f64), lo: f64, hi: f64) -> Option<(f64, f64)> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-dx, a.0 - lo),
        (dx, hi - a.0),
        (-dy, a.1 - lo),
        (dy, hi - a.1),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let r = q / p;
            if p < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    (t0 <= t1 && t0.is_finite() && t1.is_finite()).then_some((t0, t1))
}

/// Outlines of the ±err band around a Line series: one polygon per stretch of at least two
/// points with a drawable error (upper edge forwards, lower edge backwards). The edges are cut at
/// the ends of the y axis (on a log axis the lower edge at the bottom where y − err ≤ 0).
pub fn bands(s: &Series, xa: &Axis, ya: &Axis) -> Vec<Vec<Point>> {
    let keep = |i: usize| shown(s, i, xa, ya) && error(s, i).is_some_and(|e| ya.shows(s.y[i] + e));
    stretches(s.x.len(), keep)
        .into_iter()
        .filter(|stretch| stretch.len() >= 2)
        .map(|stretch| {
            let upper = stretch
                .iter()
                .map(|&i| (s.x[i], clamp(ya, s.y[i] + error(s, i).unwrap_or(0.0)).0));
            let lower = stretch
                .iter()
                .rev()
                .map(|&i| (s.x[i], clamp(ya, s.y[i] - error(s, i).unwrap_or(0.0)).0));
            upper.chain(lower).collect()
        })
        .collect()
}

/// Vertical error bars of a Markers series, for the drawable points with a drawable error.
/// Ends beyond the y axis' range are cut at its ends (on a log axis the lower end at the
/// bottom where y − err ≤ 0).
pub(crate) fn error_bars(s: &Series, xa: &Axis, ya: &Axis) -> Vec<ErrorBar> {
    (0..s.x.len())
        .filter(|&i| xa.contains(s.x[i]) && ya.contains(s.y[i]))
        .filter_map(|i| {
            let e = error(s, i)?;
            let ((hi, cut_hi), (lo, cut)) = (clamp(ya, s.y[i] + e), clamp(ya, s.y[i] - e));
            Some(ErrorBar {
                x: s.x[i],
                lo,
                hi,
                cut,
                cut_hi,
            })
        })
        .collect()
}

/// Every x and y value of `s` that the axes must cover: the points, and where there are errors,
/// y ± err. On a logarithmic y axis (`y_scale`) a lower end below a tenth of its point counts as
/// that tenth: an error near or above the value itself would otherwise stretch the axis over
/// decades down to `y - err` (or, at `y - err <= 0`, cannot be shown at all), squeezing every
/// curve into a strip; such a bar or band is cut at the bottom of the axis instead. Values the
/// axis cannot show are filtered out by [`Axis::fit`].
pub(crate) fn extent(s: &Series, y_scale: Scale) -> (Vec<f64>, Vec<f64>) {
    let mut ys = s.y.clone();
    if let Some(err) = &s.err {
        // A point without an error (NaN) adds nothing beyond the point itself.
        for (y, e) in s.y.iter().zip(err).filter(|(_, e)| e.is_finite()) {
            ys.push(y + e.abs());
            ys.push(match y_scale {
                Scale::Log => (y - e.abs()).max(0.1 * y),
                Scale::Linear => y - e.abs(),
            });
        }
    }
    (s.x.clone(), ys)
}

#[cfg(test)]
mod tests {
    use super::super::{MarkerShape, Scale};
    use super::*;

    #[test]
    fn lines_are_cut_at_the_frame() {
        let xa = Axis::fit(Scale::Linear, [0.0, 10.0], 0.0, 5);
        let ya = Axis::fit(Scale::Linear, [0.0, 1.0], 0.0, 5);
        // Up through the top at x = 1.5, back in at x = 3.5, out through the right side.
        let pieces = clip(
            &[(0.0, 0.0), (2.0, 2.0), (3.0, 2.0), (4.0, 0.0), (12.0, 0.5)],
            &xa,
            &ya,
        );
        assert_eq!(pieces.len(), 2, "{pieces:?}");
        let last = |p: &Vec<Point>| *p.last().unwrap();
        // The frame is widened by 1e-9 of the axis' length, so crossings lie that close to it.
        let near = |a: f64, b: f64| (a - b).abs() < 1e-7;
        assert!(near(last(&pieces[0]).0, 1.0) && near(last(&pieces[0]).1, 1.0));
        assert!(near(pieces[1][0].0, 3.5));
        assert!(near(last(&pieces[1]).0, 10.0));
        assert!(clip(&[(20.0, 0.5), (30.0, 0.5)], &xa, &ya).is_empty());
    }

    fn axis(scale: Scale) -> Axis {
        Axis::fit(scale, [1.0, 100.0], 0.0, 5)
    }

    fn line(y: Vec<f64>, stable: Option<Vec<bool>>) -> Series {
        Series {
            label: "s".into(),
            x: (1..=y.len()).map(|i| i as f64).collect(),
            y,
            style: Style::Line,
            stable,
            err: None,
        }
    }

    #[test]
    fn stability_change_splits_at_the_midpoint() {
        let s = line(
            vec![1.0, 2.0, 3.0, 4.0],
            Some(vec![true, true, false, false]),
        );
        let lin = axis(Scale::Linear);
        let runs = line_runs(&s, &lin, &lin);
        assert_eq!(
            runs,
            [
                Run {
                    points: vec![(1.0, 1.0), (2.0, 2.0), (2.5, 2.5)],
                    dashed: false
                },
                Run {
                    points: vec![(2.5, 2.5), (3.0, 3.0), (4.0, 4.0)],
                    dashed: true
                },
            ]
        );
    }

    #[test]
    fn non_finite_and_non_positive_points_break_the_line() {
        let s = line(vec![1.0, f64::NAN, 3.0, 4.0, -1.0, 5.0], None);
        let runs = line_runs(&s, &axis(Scale::Linear), &axis(Scale::Log));
        let lengths: Vec<usize> = runs.iter().map(|r| r.points.len()).collect();
        assert_eq!(lengths, [1, 2, 1]);
        assert!(runs.iter().all(|r| !r.dashed));
    }

    #[test]
    fn bands_and_bars_are_cut_at_the_bottom_of_a_log_axis() {
        let mut s = line(vec![10.0, 20.0], None);
        s.err = Some(vec![15.0, 5.0]);
        let (lin, log) = (axis(Scale::Linear), axis(Scale::Log));
        assert_eq!(
            bands(&s, &lin, &log),
            [vec![(1.0, 25.0), (2.0, 25.0), (2.0, 15.0), (1.0, 1.0)]]
        );
        s.style = Style::Markers(MarkerShape::Circle);
        let bar = |x, lo, cut| ErrorBar {
            x,
            lo,
            hi: 25.0,
            cut,
            cut_hi: false,
        };
        assert_eq!(
            error_bars(&s, &lin, &log),
            [bar(1.0, 1.0, true), bar(2.0, 15.0, false)]
        );
    }

    /// On a logarithmic axis an error as large as the value (or larger) covers at most a decade
    /// below the point; on a linear axis the whole bar.
    #[test]
    fn an_error_near_the_value_stretches_a_log_axis_by_one_decade_at_most() {
        let s = Series {
            label: String::new(),
            x: vec![1.0, 2.0, 3.0],
            y: vec![100.0, 50.0, 20.0],
            style: Style::Line,
            stable: None,
            err: Some(vec![10.0, 49.9, 30.0]),
        };
        let (_, log) = extent(&s, Scale::Log);
        assert_eq!(&log[3..], [110.0, 90.0, 99.9, 5.0, 50.0, 2.0]);
        // A point without an error widens nothing.
        let without = Series {
            err: Some(vec![10.0, f64::NAN, 30.0]),
            ..s.clone()
        };
        let (_, log) = extent(&without, Scale::Log);
        assert_eq!(&log[3..], [110.0, 90.0, 50.0, 2.0]);
        let (_, linear) = extent(&s, Scale::Linear);
        assert!((linear[6] - 0.1).abs() < 1e-12 && linear[8] == -10.0);
    }
}
