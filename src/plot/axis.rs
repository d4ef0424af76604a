//! Axis ranges, tick positions and tick labels.
//!
//! `plotters`' own coordinates fall short for scientific figures: its log axis has no labelled
//! tick at all when the range lies within one decade, and its float labels can read
//! `0.30000000000000004`. [`Axis`] replaces both: it fixes the visible range (with padding and
//! a sensible span for degenerate data), chooses "nice" ticks (1-2-5 steps; decades, or 1-2-5 /
//! 1…9 mantissas within decades, on a log axis) and formats their labels once, so layout code can
//! size margins from the real label text.

use std::ops::Range;

use plotters::coord::ranged1d::{KeyPointHint, NoDefaultFormatting, Ranged, ValueFormatter};

use super::Scale;

/// Relative padding added on each side of a data range (multiplicative on a log axis).
pub(crate) const PADDING: f64 = 0.05;

/// One axis of a chart: scale, visible range and labelled ticks.
#[derive(Clone, Debug)]
pub(crate) struct Axis {
    scale: Scale,
    lo: f64,
    hi: f64,
    ticks: Vec<(f64, String)>,
}

impl Axis {
    /// An axis covering the `values` this scale can show (see [`Axis::shows`]), widened by
    /// `padding` (a fraction of the span) on each side, with at most `max_ticks` labelled ticks.
    ///
    /// Without any showable value the range is 0..1 (linear) or 1..10 (log). All-equal values
    /// get a window of ±5 % around them (±1 around zero; a factor 2 on a log axis).
    pub fn fit(
        scale: Scale,
        values: impl IntoIterator<Item = f64>,
        padding: f64,
        max_ticks: usize,
    ) -> Self {
        let extent = values.into_iter().filter(|&v| shows(scale, v)).fold(
            None,
            |acc: Option<(f64, f64)>, v| match acc {
                None => Some((v, v)),
                Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
            },
        );
        let (lo, hi) = match (scale, extent) {
            (Scale::Linear, None) => (0.0, 1.0),
            (Scale::Log, None) => (1.0, 10.0),
            (Scale::Linear, Some((lo, hi))) => widen_linear(lo, hi, padding),
            (Scale::Log, Some((lo, hi))) => widen_log(lo, hi, padding),
        };
        let ticks = match scale {
            Scale::Linear => linear_ticks(lo, hi, max_ticks),
            Scale::Log => log_ticks(lo, hi, max_ticks),
        };
        Axis {
            scale,
            lo,
            hi,
            ticks,
        }
    }

    /// An axis without tick labels (used across a colour bar).
    pub(crate) fn bare(lo: f64, hi: f64) -> Self {
        Axis {
            scale: Scale::Linear,
            lo,
            hi,
            ticks: Vec::new(),
        }
    }

    /// Whether `v` can be drawn on this axis: finite, and positive on a log axis.
    pub(crate) fn shows(&self, v: f64) -> bool {
        shows(self.scale, v)
    }

    /// Whether `v` can be drawn and lies within the visible range.
    pub(crate) fn contains(&self, v: f64) -> bool {
        self.shows(v) && (-1e-9..=1.0 + 1e-9).contains(&self.fraction(v))
    }

    /// The value at `t` of the axis' length (0 at `lo`, 1 at `hi`): the inverse of
    /// [`Axis::fraction`].
    pub(crate) fn at_fraction(&self, t: f64) -> f64 {
        match self.scale {
            Scale::Linear => self.lo + t * (self.hi - self.lo),
            Scale::Log => (self.lo.ln() + t * (self.hi.ln() - self.lo.ln())).exp(),
        }
    }

    pub(crate) fn scale(&self) -> Scale {
        self.scale
    }

    /// The point half-way between `a` and `b` as seen on the axis (geometric mean on a log axis).
    pub fn midpoint(&self, a: f64, b: f64) -> f64 {
        match self.scale {
            Scale::Linear => 0.5 * a + 0.5 * b,
            Scale::Log => a.sqrt() * b.sqrt(),
        }
    }

    /// Visible range.
    pub(crate) fn bounds(&self) -> (f64, f64) {
        (self.lo, self.hi)
    }

    /// The labelled ticks: position and label.
    pub fn ticks(&self) -> &[(f64, String)] {
        &self.ticks
    }

    /// Number of characters of the longest tick label, for sizing the label area.
    pub(crate) fn widest_label(&self) -> usize {
        self.ticks
            .iter()
            .map(|(_, label)| label.chars().count())
            .max()
            .unwrap_or(0)
    }

    /// Position of `v` along the axis as a fraction of its length (0 at `lo`, 1 at `hi`).
    pub fn fraction(&self, v: f64) -> f64 {
        let (num, den) = match self.scale {
            // Halving first keeps huge ranges (±1e308) from overflowing.
            Scale::Linear => (0.5 * v - 0.5 * self.lo, 0.5 * self.hi - 0.5 * self.lo),
            Scale::Log => (v.ln() - self.lo.ln(), self.hi.ln() - self.lo.ln()),
        };
        if den > 0.0 { num / den } else { 0.5 }
    }
}

impl Ranged for Axis {
    type FormatOption = NoDefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let (a, b) = (f64::from(limit.0), f64::from(limit.1));
        // `as` saturates, so even a value far outside the range maps to some pixel.
        (a + self.fraction(*value) * (b - a)).round() as i32
    }

    /// The labelled ticks, thinned evenly if fewer are asked for. `plotters` asks for zero points
    /// for the light grid lines, which these figures do without.
    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        let max = hint.max_num_points();
        if max == 0 {
            return Vec::new();
        }
        let stride = self.ticks.len().div_ceil(max).max(1);
        self.ticks.iter().step_by(stride).map(|t| t.0).collect()
    }

    fn range(&self) -> Range<f64> {
        self.lo..self.hi
    }
}

impl ValueFormatter<f64> for Axis {
    /// Only reached for a value that is not one of the axis' ticks.
    fn format(value: &f64) -> String {
        value.to_string()
    }

    fn format_ext(&self, value: &f64) -> String {
        self.ticks
            .iter()
            .find(|(v, _)| v == value)
            .map_or_else(|| Self::format(value), |(_, label)| label.clone())
    }
}

fn shows(scale: Scale, v: f64) -> bool {
    v.is_finite() && (scale == Scale::Linear || v > 0.0)
}

/// The linear range `lo..hi` widened by `padding` of its span on each side.
fn widen_linear(lo: f64, hi: f64, padding: f64) -> (f64, f64) {
    let half_span = 0.5 * hi - 0.5 * lo;
    let magnitude = lo.abs().max(hi.abs());
    if half_span <= 1e-12 * magnitude || half_span == 0.0 {
        // All values (numerically) equal: centre them in a window of their own size.
        let mid = 0.5 * lo + 0.5 * hi;
        let w = if magnitude > 0.0 {
            0.05 * magnitude
        } else {
            1.0
        };
        return (mid - w, mid + w);
    }
    let pad = 2.0 * padding * half_span;
    let (a, b) = (lo - pad, hi + pad);
    if a.is_finite() && b.is_finite() {
        (a, b)
    } else {
        (lo, hi)
    }
}

/// The positive range `lo..hi` widened by `padding` of its logarithmic span on each side.
fn widen_log(lo: f64, hi: f64, padding: f64) -> (f64, f64) {
    let (l, h) = (lo.ln(), hi.ln());
    let (a, b) = if h - l <= 1e-12 * l.abs().max(h.abs()).max(1.0) {
        (lo / 2.0, hi * 2.0)
    } else {
        let factor = (padding * (h - l)).exp();
        (lo / factor, hi * factor)
    };
    if a > 0.0 && b.is_finite() && a < b {
        (a, b)
    } else {
        (lo / 2.0, hi)
    }
}

/// Nice steps m·10^e (m ∈ {1, 2, 5}) with their exponent e, from the smallest one not below
/// `raw` upwards (none for a `raw` that is not positive and finite).
fn nice_steps(raw: f64) -> impl Iterator<Item = (f64, i32)> {
    let valid = raw.is_finite() && raw > 0.0;
    let e0 = if valid { raw.log10().floor() as i32 } else { 0 };
    (0..)
        .take_while(move |_| valid)
        .flat_map(move |k| [1.0, 2.0, 5.0].map(|m| (m * 10f64.powi(e0 + k), e0 + k)))
        .skip_while(move |&(step, _)| step < raw * (1.0 - 1e-9))
        .take_while(|&(step, _)| step.is_finite() && step > 0.0)
}

/// Ticks at multiples of the smallest nice step that puts at most `max` of them in `lo..=hi`.
fn linear_ticks(lo: f64, hi: f64, max: usize) -> Vec<(f64, String)> {
    if max < 2 {
        return Vec::new();
    }
    // The multiples k·step with first <= k <= last lie in the range.
    let multiples = |step: f64| ((lo / step).ceil(), (hi / step).floor());
    let found = nice_steps((0.5 * hi - 0.5 * lo) / max as f64 * 2.0).find(|&(step, _)| {
        let (first, last) = multiples(step);
        first.is_finite() && last.is_finite() && last - first < max as f64
    });
    let Some((step, e)) = found else {
        return Vec::new();
    };
    let (first, last) = multiples(step);
    let largest = (first * step).abs().max((last * step).abs());
    let scientific = !(1e-3..1e5).contains(&largest);
    let count = (last - first) as i64;
    (0..=count)
        .map(|k| {
            let v = (first + k as f64) * step;
            // Snap the zero tick so it is never labelled "-0.0".
            let v = if v.abs() < 1e-6 * step { 0.0 } else { v };
            let label = if !scientific {
                format!("{:.*}", e.min(0).unsigned_abs() as usize, v)
            } else if v == 0.0 {
                "0".to_owned()
            } else {
                scientific_label(v, e)
            };
            (v, typographic_minus(label))
        })
        .collect()
}

/// `label` with its hyphen-minus replaced by the real minus sign, as typeset in print.
fn typographic_minus(label: String) -> String {
    label.replace('-', "\u{2212}")
}

/// `v` as "m×10ⁿ" with as many mantissa digits as a step of 10^`step_exp` needs, less trailing
/// zeros ("1×10¹⁰" next to "5×10⁹", not "1.0×10¹⁰").
fn scientific_label(v: f64, step_exp: i32) -> String {
    // Ticks are multiples of the step, so they are exact up to rounding: nudge before flooring.
    let e = (v.abs() * (1.0 + 1e-9)).log10().floor() as i32;
    let mantissa = v / 10f64.powi(e);
    let digits = (e - step_exp).max(0) as usize;
    let mantissa = format!("{mantissa:.digits$}");
    let mantissa = if mantissa.contains('.') {
        mantissa.trim_end_matches('0').trim_end_matches('.')
    } else {
        &mantissa
    };
    format!("{mantissa}×10{}", superscript(e))
}

/// Ticks at m·10^e for the sparsest mantissa set that gives at least three ticks, or for the
/// densest one that stays within `max`; every k-th decade when even the decades are too many.
/// Within a range too narrow for two such ticks, linear ticks are used instead.
fn log_ticks(lo: f64, hi: f64, max: usize) -> Vec<(f64, String)> {
    if max < 2 {
        return Vec::new();
    }
    let (e_lo, e_hi) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    let inside = |v: f64| v >= lo * (1.0 - 1e-12) && v <= hi * (1.0 + 1e-12);
    let candidates = |mantissas: &[u32], stride: i32| -> Vec<(f64, String)> {
        (e_lo..=e_hi)
            .filter(|e| e.rem_euclid(stride) == 0)
            .flat_map(|e| mantissas.iter().map(move |&m| (m, e)))
            .map(|(m, e)| (f64::from(m) * 10f64.powi(e), m, e))
            .filter(|&(v, _, _)| inside(v))
            .map(|(v, m, e)| (v, log_label(m, e)))
            .collect()
    };
    let decades = candidates(&[1], 1);
    if decades.len() > max {
        let stride = i32::try_from(decades.len().div_ceil(max)).unwrap_or(i32::MAX);
        return candidates(&[1], stride);
    }
    let mut best = decades;
    for mantissas in [&[1, 2, 5][..], &[1, 2, 3, 4, 5, 6, 7, 8, 9]] {
        if best.len() >= 3 {
            break;
        }
        let denser = candidates(mantissas, 1);
        if denser.len() > max {
            break;
        }
        best = denser;
    }
    if best.len() < 2 {
        linear_ticks(lo, hi, max)
    } else {
        best
    }
}

/// Label of the log tick m·10^e: a plain decimal for 0.001 … 10000, else "10ⁿ" or "m×10ⁿ".
fn log_label(m: u32, e: i32) -> String {
    if (-3..=4).contains(&e) {
        let v = f64::from(m) * 10f64.powi(e);
        format!("{:.*}", e.min(0).unsigned_abs() as usize, v)
    } else if m == 1 {
        format!("10{}", superscript(e))
    } else {
        format!("{m}×10{}", superscript(e))
    }
}

/// An integer in Unicode superscript digits, for exponents in tick labels.
fn superscript(n: i32) -> String {
    n.to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            '0' => '⁰',
            '1' => '¹',
            '2' => '²',
            '3' => '³',
            '4' => '⁴',
            '5' => '⁵',
            '6' => '⁶',
            '7' => '⁷',
            '8' => '⁸',
            '9' => '⁹',
            other => other,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn labels(axis: &Axis) -> Vec<&str> {
        axis.ticks().iter().map(|(_, l)| l.as_str()).collect()
    }

    #[test]
    fn linear_ticks_are_round_and_padded() {
        let axis = Axis::fit(Scale::Linear, [0.0, 1.0], PADDING, 8);
        assert_eq!(axis.bounds(), (-0.05, 1.05));
        assert_eq!(labels(&axis), ["0.0", "0.2", "0.4", "0.6", "0.8", "1.0"]);
        // As many ticks as allowed: 0, 2, ..., 10 rather than 0, 5, 10.
        let axis = Axis::fit(Scale::Linear, [0.0, 10.0], PADDING, 6);
        assert_eq!(labels(&axis), ["0", "2", "4", "6", "8", "10"]);
        let negative = Axis::fit(Scale::Linear, [-1.0, 1.0], 0.0, 3);
        assert_eq!(labels(&negative), ["\u{2212}1", "0", "1"]);
    }

    #[test]
    fn constant_data_get_a_window() {
        let axis = Axis::fit(Scale::Linear, [3.0, 3.0, f64::NAN], PADDING, 8);
        let (lo, hi) = axis.bounds();
        assert!(lo < 3.0 && hi > 3.0);
        assert!(axis.ticks().len() >= 2);
        let zero = Axis::fit(Scale::Linear, [0.0], PADDING, 8);
        assert_eq!(zero.bounds(), (-1.0, 1.0));
    }

    #[test]
    fn large_values_are_labelled_in_scientific_notation() {
        let axis = Axis::fit(Scale::Linear, [0.0, 3e6], 0.0, 4);
        assert_eq!(labels(&axis), ["0", "1×10⁶", "2×10⁶", "3×10⁶"]);
        let mixed = Axis::fit(Scale::Linear, [0.0, 1.5e10], 0.0, 4);
        assert_eq!(labels(&mixed), ["0", "5×10⁹", "1×10¹⁰", "1.5×10¹⁰"]);
        let small = Axis::fit(Scale::Linear, [-2e-4, 0.0], 0.0, 3);
        assert_eq!(labels(&small), ["\u{2212}2×10⁻⁴", "\u{2212}1×10⁻⁴", "0"]);
    }

    #[test]
    fn extreme_ranges_do_not_overflow() {
        let axis = Axis::fit(Scale::Linear, [-f64::MAX, f64::MAX], PADDING, 8);
        assert_eq!(axis.bounds(), (-f64::MAX, f64::MAX));
        assert_eq!(axis.map(&0.0, (0, 100)), 50);
    }

    #[test]
    fn log_ticks_use_decades_or_mantissas() {
        let wide = Axis::fit(Scale::Log, [1.0, 1000.0], 0.0, 8);
        assert_eq!(labels(&wide), ["1", "10", "100", "1000"]);
        let narrow = Axis::fit(Scale::Log, [2.0, 8.0], 0.0, 8);
        assert_eq!(labels(&narrow), ["2", "3", "4", "5", "6", "7", "8"]);
        let tiny = Axis::fit(Scale::Log, [1e-9, 1e-5], 0.0, 8);
        assert_eq!(labels(&tiny), ["10⁻⁹", "10⁻⁸", "10⁻⁷", "10⁻⁶", "10⁻⁵"]);
        let huge = Axis::fit(Scale::Log, [1e-100, 1e100], 0.0, 5);
        assert!(huge.ticks().len() <= 5 && huge.ticks().len() >= 2);
    }

    #[test]
    fn log_axis_skips_non_positive_values() {
        let axis = Axis::fit(Scale::Log, [-5.0, 0.0, 10.0, 100.0], 0.0, 8);
        assert_eq!(axis.bounds(), (10.0, 100.0));
        assert!(!axis.shows(0.0));
        assert!((axis.midpoint(10.0, 1000.0) - 100.0).abs() < 1e-9);
    }

    #[test]
    fn key_points_thin_out_and_skip_light_lines() {
        let axis = Axis::fit(Scale::Linear, [0.0, 10.0], 0.0, 11);
        assert_eq!(axis.key_points(11).len(), 11);
        assert_eq!(axis.key_points(5).len(), 4);
        assert!(axis.key_points(0).is_empty());
        assert_eq!(axis.format_ext(&2.0), "2");
    }
}
