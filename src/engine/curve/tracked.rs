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
