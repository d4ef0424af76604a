//! Near misses: a mode that rises towards the imaginary axis and falls back between the points of
//! a branch, where a window of instability may hide inside one step.
//!
//! A branch's events are changes of the unstable count between two of its points. A mode that
//! crosses the axis and comes back inside one step (a window of instability narrower than the
//! step) leaves the counts at both ends alike and is not seen. The step control keeps steps
//! short where an eigenvalue extrapolated linearly reaches the axis ([`super::arclength`]), and a
//! mode that turns back sharply escapes that prediction (two modes interacting: on the rod of
//! `exponent_m` at `lambda/l = 0.25`, `R/lambda = 0.3725`, a window 5% wide in `omega` lies inside
//! one step about a quarter of the rate long).
//!
//! What the points do show is the largest real part of the spectrum, `f(p)`, a continuous
//! function of the parameter (the largest of the eigenvalues' real parts; where the leading mode
//! changes, its slope jumps up, so its corners are never maxima), rising and falling back around
//! a point `m` between its neighbours `l` and `r`. The parabola through the three,
//!
//! ```text
//! q(p) = f_m + d1 (p - p_m) + d2 (p - p_m)^2,                                          (1)
//! ```
//!
//! has its vertex at `p_v = p_m - d1 / (2 d2)` with the predicted peak `q_v = f_m - d1^2 / (4 d2)`.
//! A sharp peak rises above its parabola, so the peak is probed where the parabola comes within
//! its own rise above `f_m` of the axis (`q_v + (q_v - f_m) >= 0`), or within the larger fall
//! from `m` to a neighbour (`q_v + max(f_m - f_l, f_m - f_r) >= 0`: nothing finer than the
//! points says how the peak is shaped, and a maximum closer to the axis than to one of its
//! neighbours may hide a window). The probe solves the state at `p_v` and its spectrum; a probe
//! with an unstable eigenvalue has found the window; one without is a new sample, and the search
//! goes on from the highest sample and its two neighbours (parabolic search for the maximum, as
//! in Brent's `fmin`, with a step to the middle of the larger side where the vertex would land
//! on a sample). Each probe measures the parabola's own error, `|q(p) - f(p)|` at the probe,
//! which replaces the fall as the error, and the search goes on while the new parabola comes
//! within its rise or that error of the axis. On the rod above, the parabola of the first three
//! points puts the peak at `+0.134`, the probe there finds `-0.019`, and the next parabola's
//! `-0.0095` lies within that error of the axis: its probe is unstable. The search ends when
//! neither criterion holds (the peak stays below the axis). It is unresolved, and the caller
//! says so, where the peak is pinned between samples closer than the tolerance with the
//! parabola still reaching the axis, where a probe fails or gives no finite real part, or when
//! [`MAX_PROBES`] probes are spent.
//!
//! Only a local maximum among the points is searched: a window whose mode rises and falls
//! between two points while `f` at the points keeps rising (or falling) leaves no trace in them.

use crate::Result;

/// Probes spent on one near miss at most. On the rod above two find the window.
pub const MAX_PROBES: usize = 8;

/// A sample of the largest real part of the spectrum at the parameter `p`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    pub p: f64,
    pub re: f64,
}

/// A probe's result: the sample, whether the state there has an unstable eigenvalue, and the
/// caller's state.
pub struct Probe<S> {
    pub sample: Sample,
    pub unstable: bool,
    pub state: S,
}

/// How the search of one near miss ended.
pub enum Peak<S> {
    /// The peak stays below the axis: no window.
    Below { probes: usize, highest: Sample },
    /// A probe found an unstable eigenvalue: the window, with the stable samples nearest it on
    /// either side (`before` towards the branch's start, `after` towards its end) and the
    /// number of probes.
    Window {
        probes: usize,
        unstable: Probe<S>,
        before: Sample,
        after: Sample,
    },
    /// The probes were spent, a probe could not be solved or gave no finite real part, or the
    /// peak was pinned within the tolerance with the parabola still reaching the axis: no window
    /// found, none excluded.
    Unresolved {
        probes: usize,
        highest: Sample,
        why: String,
    },
}

/// The parabola (1) through three samples.
#[derive(Clone, Copy, Debug)]
struct Parabola {
    m: Sample,
    d1: f64,
    d2: f64,
}

impl Parabola {
    /// Through `l`, `m`, `r` (ordered in `p`, either way) where `m` is at least as high as both
    /// neighbours and the parabola opens downwards; `None` elsewhere.
    fn around(l: Sample, m: Sample, r: Sample) -> Option<Parabola> {
        if !(m.re >= l.re && m.re >= r.re) || (m.p - l.p) * (r.p - m.p) <= 0.0 {
            return None;
        }
        let d_l = (m.re - l.re) / (m.p - l.p);
        let d_r = (r.re - m.re) / (r.p - m.p);
        let d2 = (d_r - d_l) / (r.p - l.p);
        // The slope at m: that of the parabola through the three.
        let d1 = d_l + d2 * (m.p - l.p);
        (d2 < 0.0 && d2.is_finite()).then_some(Parabola { m, d1, d2 })
    }

    /// The vertex `(p_v, q_v)`.
    fn vertex(&self) -> (f64, f64) {
        let p_v = self.m.p - self.d1 / (2.0 * self.d2);
        (p_v, self.at(p_v))
    }

    fn at(&self, p: f64) -> f64 {
        let x = p - self.m.p;
        self.m.re + x * (self.d1 + x * self.d2)
    }

    /// The parabola comes within its own rise above `m` of the axis, or within `error` (how far
    /// a parabola missed a probe) of it.
    fn reaches(&self, error: f64) -> bool {
        let (_, q_v) = self.vertex();
        2.0 * q_v - self.m.re >= 0.0 || q_v + error >= 0.0
    }
}

/// How far the peak between `l` and `r` may lie above the parabola before any probe: the larger
/// fall from `m` to a neighbour (nothing finer than that says how the peak is shaped).
fn unprobed_error(l: Sample, m: Sample, r: Sample) -> f64 {
    (m.re - l.re).max(m.re - r.re)
}

/// The vertex `p_v` of the parabola (1) through `l`, `m`, `r` (ordered in `p`, either way) where
/// `m` is at least as high as both neighbours and the parabola comes within its own rise of the
/// axis (`2 q_v - f_m >= 0`) or within the larger fall from `m` to a neighbour (`q_v + max(f_m -
/// f_l, f_m - f_r) >= 0`; a peak closer to the axis than to one of its neighbours); `None`
/// elsewhere.
pub fn probe_at(l: Sample, m: Sample, r: Sample) -> Option<f64> {
    Parabola::around(l, m, r)
        .filter(|q| q.reaches(unprobed_error(l, m, r)))
        .map(|q| q.vertex().0)
}

/// Searches the peak of `f` between `l` and `r` around `m` (a near miss, [`probe_at`] some) with
/// `probe` (the sample at a parameter, solved), until a probe is unstable, the parabola through
/// the highest sample and its neighbours no longer reaches the axis (within its rise, or within
/// the error the last parabola made at its probe), or the peak is pinned between samples closer
/// than `tol` in `p` (unresolved where its parabola still reaches the axis).
pub fn search<S>(
    l: Sample,
    m: Sample,
    r: Sample,
    tol: f64,
    mut probe: impl FnMut(f64) -> Result<Probe<S>>,
) -> Peak<S> {
    let ascending = r.p > l.p;
    let mut samples = vec![l, m, r];
    let mut probes = 0;
    let mut error = unprobed_error(l, m, r);
    loop {
        let i = (1..samples.len() - 1)
            .max_by(|&a, &b| samples[a].re.total_cmp(&samples[b].re))
            .expect("three samples at least");
        let (left, best, right) = (samples[i - 1], samples[i], samples[i + 1]);
        let parabola = Parabola::around(left, best, right).filter(|q| q.reaches(error));
        let Some(parabola) = parabola else {
            return Peak::Below {
                probes,
                highest: best,
            };
        };
        if (right.p - left.p).abs() <= tol {
            return Peak::Unresolved {
                probes,
                highest: best,
                why: format!(
                    "the peak is pinned within the tolerance, its parabola's peak {:.1e} within \
                     its error of the axis",
                    parabola.vertex().1
                ),
            };
        }
        if probes == MAX_PROBES {
            return Peak::Unresolved {
                probes,
                highest: best,
                why: format!("{MAX_PROBES} probes spent"),
            };
        }
        // Not on a sample: within a hundredth of the bracket of one, the middle of the larger
        // side of the highest sample instead.
        let (vertex, _) = parabola.vertex();
        let clear = 0.01 * (right.p - left.p).abs();
        let p = if (vertex - best.p).abs() < clear
            || (vertex - left.p).abs() < clear
            || (vertex - right.p).abs() < clear
        {
            if (best.p - left.p).abs() > (right.p - best.p).abs() {
                0.5 * (left.p + best.p)
            } else {
                0.5 * (best.p + right.p)
            }
        } else {
            vertex
        };
        probes += 1;
        let found = match probe(p) {
            Ok(found) if found.sample.re.is_finite() => found,
            Ok(_) => {
                return Peak::Unresolved {
                    probes,
                    highest: best,
                    why: "a probe gave no finite real part".into(),
                };
            }
            Err(e) => {
                return Peak::Unresolved {
                    probes,
                    highest: best,
                    why: format!("a probe failed: {e}"),
                };
            }
        };
        let at = samples
            .iter()
            .position(|s| (s.p > p) == ascending)
            .expect("the probe lies inside the samples");
        if found.unstable {
            return Peak::Window {
                probes,
                before: samples[at - 1],
                after: samples[at],
                unstable: found,
            };
        }
        error = (parabola.at(p) - found.sample.re).abs();
        samples.insert(at, found.sample);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A mode whose real part `-0.3 + a / (1 + ((p - c) / w)^2)` peaks at `-0.3 + a` at `c`.
    fn bump(a: f64, c: f64, w: f64) -> impl Fn(f64) -> f64 {
        move |p| -0.3 + a / (1.0 + ((p - c) / w).powi(2))
    }

    fn run(f: &impl Fn(f64) -> f64, ps: [f64; 3]) -> Peak<()> {
        let s = |p: f64| Sample { p, re: f(p) };
        search(s(ps[0]), s(ps[1]), s(ps[2]), 1e-9, |p| {
            Ok(Probe {
                sample: s(p),
                unstable: f(p) > 0.0,
                state: (),
            })
        })
    }

    #[test]
    fn a_window_narrower_than_the_steps_is_found_inside_it() {
        // Peak +0.02 at 99.4, above the axis for |p - 99.4| < 0.26 w: with w = 8 a window about
        // 4 wide between samples 25 apart (the rod's case in the module's doc), and narrower;
        // each also with the samples in decreasing p (a branch followed towards negative p).
        for (w, ps) in [
            (8.0, [79.5, 104.7, 111.9]),
            (8.0, [70.0, 95.0, 120.0]),
            (3.0, [90.0, 100.5, 110.0]),
        ] {
            let f = bump(0.32, 99.4, w);
            let half = w * (0.32f64 / 0.3 - 1.0).sqrt();
            for ps in [ps, [ps[2], ps[1], ps[0]]] {
                let Peak::Window {
                    probes,
                    unstable,
                    before,
                    after,
                } = run(&f, ps)
                else {
                    panic!("w = {w}, {ps:?}: the window was not found");
                };
                let p = unstable.sample.p;
                assert!(
                    (p - 99.4).abs() < half,
                    "w = {w}: probe {p} outside the window"
                );
                // The stable samples returned are either side of the probe along the samples, the
                // nearest ones: the window's exact edges lie between them.
                assert!(
                    (before.p - p) * (ps[2] - ps[0]) < 0.0 && (after.p - p) * (ps[2] - ps[0]) > 0.0,
                    "{ps:?}: {before:?} and {after:?} around {p}"
                );
                let (lo, hi) = (before.p.min(after.p), before.p.max(after.p));
                assert!(
                    lo < 99.4 - half && 99.4 + half < hi,
                    "w = {w}, {ps:?}: the window is not between {before:?} and {after:?}"
                );
                assert!(probes <= 4, "w = {w}, {ps:?}: {probes} probes");
            }
        }
    }

    #[test]
    fn a_peak_below_the_axis_is_not_a_window_and_is_given_up_cheaply() {
        // Peak -0.01 at 99.4 (a near miss): probes nearer the peak than the points, and stable.
        let f = bump(0.29, 99.4, 8.0);
        for ps in [[79.5, 104.7, 111.9], [111.9, 104.7, 79.5]] {
            let Peak::Below { probes, highest } = run(&f, ps) else {
                panic!("{ps:?}: a peak at -0.01 was not found below the axis");
            };
            assert!(
                highest.re > f(104.7),
                "no probe came nearer the peak: {highest:?}"
            );
            assert!(probes <= 4, "{probes} probes");
        }
        // A broad maximum far below the axis is not probed at all.
        let far = |p: f64| -1.0 - 1e-4 * (p - 100.0).powi(2);
        assert!(matches!(
            run(&far, [80.0, 95.0, 120.0]),
            Peak::Below { probes: 0, .. }
        ));
    }

    #[test]
    fn a_probe_that_fails_leaves_the_near_miss_unresolved() {
        let f = bump(0.32, 99.4, 8.0);
        let s = |p: f64| Sample { p, re: f(p) };
        let failing =
            |_: f64| -> Result<Probe<()>> { Err(crate::Error::Numerical("no convergence".into())) };
        match search(s(79.5), s(104.7), s(111.9), 1e-9, failing) {
            Peak::Unresolved { probes: 1, why, .. } => assert!(why.contains("no convergence")),
            _ => panic!("a failed probe was taken for a verdict"),
        }
        let nan = |p: f64| {
            Ok(Probe {
                sample: Sample { p, re: f64::NAN },
                unstable: false,
                state: (),
            })
        };
        assert!(matches!(
            search(s(79.5), s(104.7), s(111.9), 1e-9, nan),
            Peak::Unresolved { probes: 1, .. }
        ));
    }

    #[test]
    fn a_maximum_is_probed_where_its_parabola_comes_within_its_fall_or_its_rise_of_the_axis() {
        // q(p) = c - 0.01 (p - 1)^2 sampled at p = 0, 1.5, 3: vertex 1, q_v = c, f_m = c - 0.0025,
        // the larger fall from m to a neighbour 0.0375 (to p = 3), the parabola's rise 0.0025.
        let at = |c: f64, p: f64| Sample {
            p,
            re: c - 0.01 * (p - 1.0).powi(2),
        };
        let probed = |c: f64| probe_at(at(c, 0.0), at(c, 1.5), at(c, 3.0));
        // Within the fall (c = -0.03): probed at the vertex; farther (c = -0.04): not.
        let v = probed(-0.03).expect("probed");
        assert!((v - 1.0).abs() < 1e-12, "{v}");
        assert!(probed(-0.04).is_none());
        // Samples at 0.3, 0.5, 1.6 of c - (p - 1)^2: the rise (0.25) exceeds the larger fall
        // (0.24), so c = -0.245 is probed by the rise alone, and c = -0.255 is not.
        let tight = |c: f64| {
            let at = |p: f64| Sample {
                p,
                re: c - (p - 1.0).powi(2),
            };
            probe_at(at(0.3), at(0.5), at(1.6))
        };
        let v = tight(-0.245).expect("probed by its rise");
        assert!((v - 1.0).abs() < 1e-12, "{v}");
        assert!(tight(-0.255).is_none());
        // Ordered the other way in p, the same vertex.
        let w = probe_at(at(-0.03, 3.0), at(-0.03, 1.5), at(-0.03, 0.0)).expect("probed");
        assert!((w - 1.0).abs() < 1e-12, "{w}");
        // Not a maximum: never probed.
        assert!(probe_at(at(-0.03, 1.5), at(-0.03, 0.0), at(-0.03, -1.5)).is_none());
    }
}
