//! The tracked eigenvalue of a Hopf curve: the member of the critical pair followed from point
//! to point (nearest its prediction), and the rest of the spectrum, whose unstable count is
//! watched for codimension-two points.

use faer::c64;

use crate::Result;
use crate::engine::stability::{Spectrum, is_complex};
use crate::error::EngineError;

/// The eigenvalue of `spectrum` nearest `track`, with its imaginary part made positive; an error
/// when a complex `track` finds only a real one (the pair has met on the real axis:
/// [`EngineError::PairBecameReal`], where the curve looks for a Bogdanov-Takens point).
pub(super) fn tracked(spectrum: &Spectrum, track: c64) -> Result<c64> {
    let s = spectrum.nearest(track);
    if is_complex(track) && !is_complex(s) {
        return Err(EngineError::PairBecameReal { track }.into());
    }
    Ok(c64::new(s.re, s.im.abs()))
}

/// The critical pair of `spectrum` continued through a Bogdanov-Takens point, as the two
/// test functions of the curve through it:
///
/// ```text
/// h  = Re (s1 + s2) / 2,          w2 = -Re ((s1 - s2) / 2)^2,                          (3)
/// ```
///
/// `s1` the eigenvalue nearest `track`, `s2` the one nearest its mirror image through the real
/// point `Re track` (its conjugate where `s1` is complex; the other real eigenvalue of the pair
/// where the pair is real). For a complex pair `h = Re s` and `w2 = w^2`; for a real pair
/// `w2 = -((s1 - s2) / 2)^2 < 0`. Both are the invariants `tr / 2` and `det - tr^2 / 4` of the
/// pair's two-dimensional block, smooth through the point where the pair meets on the real
/// axis (unlike `w`, a square root there), and computed from the eigenvalues to round-off even
/// at a double eigenvalue: their error `sqrt(eps)` cancels in the square. The curve `h = 0`
/// is the Hopf curve where `w2 > 0` and a curve of neutral saddles where `w2 < 0`; `w2`
/// vanishes at the Bogdanov-Takens point between them, transversally in the generic case.
pub(super) fn critical_pair(spectrum: &Spectrum, track: c64) -> Result<(f64, f64)> {
    let leading = &spectrum.leading;
    let nearest = |target: c64, skip: Option<usize>| {
        (0..leading.len())
            .filter(|&i| Some(i) != skip)
            .min_by(|&a, &b| {
                (leading[a] - target)
                    .norm()
                    .total_cmp(&(leading[b] - target).norm())
            })
    };
    let first = nearest(track, None).expect("a spectrum has at least one eigenvalue");
    let s1 = leading[first];
    let mirror = c64::new(2.0 * track.re - s1.re, -s1.im);
    let Some(second) = nearest(mirror, Some(first)) else {
        return Err(EngineError::PairBecameReal { track }.into());
    };
    let s2 = leading[second];
    let half = (s1 - s2) * 0.5;
    Ok((0.5 * (s1 + s2).re, -(half * half).re))
}

/// The spectrum without the tracked eigenvalue (and its conjugate), with its unstable count.
pub fn others(spectrum: &Spectrum, track: c64) -> Spectrum {
    let mut rest = spectrum.leading.clone();
    let mut remove = |target: c64| {
        if let Some(i) = (0..rest.len()).min_by(|&a, &b| {
            (rest[a] - target)
                .norm()
                .total_cmp(&(rest[b] - target).norm())
        }) {
            rest.remove(i);
        }
    };
    remove(track);
    if is_complex(track) {
        remove(track.conj());
    }
    let unstable = rest.iter().filter(|s| s.re > 0.0).count();
    Spectrum {
        leading: rest,
        unstable,
        solver: spectrum.solver.clone(),
    }
}
