//! Independent pieces of one linearization or one stability pair, run on two threads where they
//! are large enough to pay for it.

/// Unknowns from which the pieces run on two threads ([`join_if`]). Below it each piece takes a
/// fraction of a millisecond, and waking the second thread for it cost more than it saved: with
/// the linearization's and the stability pair's pieces joined at every size, `locate` on the
/// default (`N = 60`, 233 unknowns) took 0.256 s against 0.217 s (medians of 8 alternated runs),
/// with 4568 context switches against 101.
pub(crate) const FROM: usize = 600;

/// `(a(), b())`, on two threads when `parallel` (rayon's `join`). The arithmetic of each is the
/// same either way.
pub(crate) fn join_if<A: Send, B: Send>(
    parallel: bool,
    a: impl FnOnce() -> A + Send,
    b: impl FnOnce() -> B + Send,
) -> (A, B) {
    if parallel {
        rayon::join(a, b)
    } else {
        (a(), b())
    }
}
