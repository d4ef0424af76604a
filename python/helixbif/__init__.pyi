"""Type stubs of helixbif (the extension module helixbif._helixbif re-exported); the reference
is docs/python.md. Units are SI: rates rad/s, lengths m, forces N, torques N m, times s."""

import os
from collections.abc import Mapping, Sequence
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

__version__: str

_F = npt.NDArray[np.float64]
_I = npt.NDArray[np.int64]
_B = npt.NDArray[np.bool_]
_S = npt.NDArray[np.str_]
_Path = str | os.PathLike[str]
_Value = bool | int | float | str | Sequence[Any] | Mapping[str, Any]

class NumericalError(RuntimeError):
    """A numerical failure (the command line's exit code 1): `message` says where and why;
    `partial` is the result found before it (its tables so far), or None."""

    message: str
    partial: Located | Branch | Boundary | Simulation | Orbits | None

class Study:
    """A validated study (physical parameters in SI units, numerical settings), immutable."""

    @staticmethod
    def default() -> Study:
        """The built-in representative helix (docs/model.md section 7)."""
    @staticmethod
    def from_file(path: _Path) -> Study:
        """The study file at `path` (TOML). Raises ValueError."""
    @staticmethod
    def from_toml(text: str) -> Study:
        """The study of TOML text. Raises ValueError."""
    def with_(self, *sets: str | Mapping[str, _Value], **overrides: _Value) -> Study:
        """A copy with fields overridden by dotted keys, as `--set key=value`:
        `study.with_(**{"rod.E": 2e6, "discretization.nodes": 80})`. Raises ValueError."""
    def to_toml(self) -> str:
        """The study as a study file's TOML text."""
    def to_dict(self) -> dict[str, Any]:
        """The study as a dict (tables as dicts)."""
    def __getitem__(self, key: str) -> Any:
        """The value at a dotted key, `study["rod.E"]`. Raises KeyError."""
    @property
    def name(self) -> str: ...
    @property
    def nodes(self) -> int:
        """The node count N."""
    @property
    def overrides(self) -> list[str]:
        """The overrides applied by `with_()`, as `--set` arguments."""
    def __eq__(self, other: object) -> bool: ...
    def locate(
        self,
        accuracy: float | None = None,
        *,
        single: bool = False,
        max_nodes: int | None = None,
        extrapolate: bool = False,
        nodes: Sequence[int] | None = None,
        tol: float | None = None,
    ) -> Located:
        """omega_b (rad/s), the first loss of stability of the branch from rest
        (`helixbif locate`): refined in N to `accuracy` (default 1e-3, at most `max_nodes`,
        default 500, which must exceed the study's N), or at the study's N (`single=True`), or over a ladder `nodes`
        extrapolated (`extrapolate=True`); `tol` the relative precision of omega_b. Raises
        ValueError on bad input, NumericalError when the continuation fails or the refinement
        stops short of `accuracy` (the `Located` then in `partial`)."""
    def branch(self, omega_max: float | None = None, *, out: _Path | None = None) -> Branch:
        """The branch from rest up to `omega_max` rad/s (`helixbif branch`); files into `out`
        (default a fresh temporary folder). Raises NumericalError with `partial` when it
        stalls."""
    def solve(self, omega: float) -> Solution:
        """One steady state at `omega` rad/s (`helixbif solve`), each observable with its
        estimated error (`errors`)."""
    def boundary(
        self,
        vary: str,
        start: float,
        stop: float,
        *,
        accuracy: float | None = None,
        max_nodes: int | None = None,
        carry_spacing: float | None = None,
        out: _Path | None = None,
    ) -> Boundary:
        """The stability boundary omega_b(q) with the field `vary` from `start` to `stop`
        (`helixbif boundary`); with `accuracy`, every Hopf point carried to it (up to
        `max_nodes`, default 500, above the study's N), or with `carry_spacing` only points that
        far apart in ln q, the others interpolated (column `answer`). Raises NumericalError with
        `partial` when the curve stops or a point falls short of `accuracy`."""
    def simulate(
        self,
        omega: float | None = None,
        *,
        t_end: float,
        from_steady: bool = False,
        perturb: float | None = None,
        from_orbit: _Path | None = None,
        ramp_time: float = 20.0,
        transient: float | None = None,
        shape_every: int = 50,
        out: _Path | None = None,
        resume: bool = False,
    ) -> Simulation:
        """The rod stepped through time for `t_end` s at `omega` rad/s
        (`helixbif simulate`). Raises NumericalError with `partial` when a step fails."""
    def run(self, *, out: _Path | None = None, resume: bool = False) -> StudyRun:
        """The study's plan (`[study]`, any kind; without one, `locate` refined to the default
        accuracy) run into `out` as `helixbif run` does; `resume=True` is `--resume`. Raises
        NumericalError with `partial` when the study does not complete."""
    def orbits(
        self,
        *,
        max_orbits: int = 40,
        steps: int = 100,
        amplitude: float = 1e-3,
        omega_min: float | None = None,
        omega_max: float | None = None,
        out: _Path | None = None,
        resume: bool = False,
    ) -> Orbits:
        """The periodic orbits born at the Hopf point (`helixbif orbits`). Raises
        NumericalError with `partial` when the branch stalls."""

class _Result:
    """What every result has: `to_dict()` (the command line's --json), `result[key]` (its
    values), `columns` (the main table as numpy arrays), `to_pandas()`."""

    def to_dict(self) -> dict[str, Any]: ...
    @property
    def columns(self) -> dict[str, npt.NDArray[Any]]: ...
    def to_pandas(self) -> Any:
        """A pandas DataFrame (or Series); needs pandas."""
    def keys(self) -> list[str]: ...
    def __getitem__(self, key: str) -> Any: ...
    def __contains__(self, key: str) -> bool: ...
    def __getattr__(self, name: str) -> Any: ...

class Located(_Result):
    """`helixbif locate --json`; `resolution` says which of single, refine, ladder."""

    resolution: Literal["single", "refine", "ladder"]
    study: str
    kind: Literal["hopf", "fold", "branch_point", "unstable_at_rest", "none"]
    omega_b: float | None
    """rad/s (ladder: a list, one per node count)."""
    omegabar_b: float | None
    im: float | None
    """Frequency of the critical mode in the co-rotating frame, rad/s."""
    imbar: float | None
    Fp: float | None
    Fpbar: float | None
    hbar: float | None
    nodes: int
    precision: float | None
    unstable_at_rest: int
    omega_max: float
    points: int
    corrector_iterations: int
    l1: float | None
    l1_precision: float | None
    criticality: Literal["supercritical", "subcritical", "undetermined"] | None
    l1_failure: str | None
    probes: int
    """States solved to probe the branch's near misses (docs/model.md section 5)."""
    window_between: list[float] | None
    """Rates (rad/s) of the two points of the step a window of instability found by a probe
    lies in; omega_b is then the window's loss."""
    near_miss_unresolved: str | None
    """A near miss whose probes neither found nor excluded a window (where and why)."""
    error: float | None
    """Estimated error of omega_b against the continuous model, rad/s (`omega_b_error`): the
    answer's error in N (the finest rung's discretization error, `estimate`, or the limit's,
    `extrapolation_error`) plus, on the RPY line, the error of the quadrature's correction where
    the answer is the limit less the quadrature's error (`quadrature_correction`), else the size
    of the quadrature's own error (`quadrature`)."""
    omega_b_error: float | None
    relative_error: float | None
    answer: Literal["finest_rung", "limit"] | None
    """Where omega_b comes from (refined; absent for single and ladder results): the finest rung,
    or the limit in N of the three finest rungs (on the RPY line less the quadrature's own error,
    `quadrature_correction`)."""
    omega_b_finest: float | None
    """The finest rung's own omega_b, rad/s (refined), and its error (`finest_error`)."""
    finest_error: float | None
    accuracy: float | None
    """The accuracy asked for; None for a study that fixes N (its error estimated from a coarser
    rung)."""
    reached: bool
    estimate: dict[str, Any] | None
    """The discretization error in N: `error` (rad/s), `limit`, `observed_order`, `method`."""
    quadrature: dict[str, Any] | None
    """The RPY quadrature's own error, measured at the coarsest rung (refined and ladder):
    `error` (rad/s, signed), `points_per_blob`, `compared_with`, `nodes`, `omega_b_compared`,
    `failed` (why it could not be measured); None on Lighthill's operator."""
    quadrature_finer: dict[str, Any] | None
    """The same measured at the second rung (refined, where a third followed on a model whose
    limit may be trusted; ladder, where it halves the spacing)."""
    quadrature_correction: dict[str, Any] | None
    """Where the answer is the limit less the quadrature's error (refined and ladder): `nodes` of
    the two measurements, `subtracted` (rad/s, the finer measurement) and its `error` (rad/s, the change
    between the two)."""
    lyapunov_error: dict[str, Any] | None
    """The error in N of the finest rung's `l1` (refined, at a Hopf point): `rungs` (`nodes`,
    `l1`, `precision` of the two rungs before the finest), `error` (first order from the two
    finest rungs, or None) and `failed` (why not); `criticality` is then the sign only where it
    is settled in N."""
    rungs: list[dict[str, Any]]
    stopped: str | None
    fluid: Literal["lighthill", "rpy"]
    """The hydrodynamic model of the rungs (refined)."""
    omega_b_extrapolated: float
    """rad/s (ladder): the limit in N, on the RPY line less the quadrature's error
    (`quadrature_correction`)."""
    extrapolation_error: float | None
    """rad/s (ladder; refined where `answer` is `limit`, else None): the extrapolation's own
    error; `error` adds, on the RPY line, the error of the quadrature's correction (or the size of
    the quadrature's error where none was made)."""
    omegabar_b_extrapolated: float
    coefficients: list[float]
    """The ladder's fit of omegabar_b(N), lowest order first (see `model`)."""
    model: str
    """The ladder's fit, e.g. `omega_b(N) = c0 + c1 h + c2 h^2, h = 1/(N - 1)`."""
    nodes_max: int
    """The largest admissible node count of the rod (ladder)."""
    kinds: list[str]

class Branch(_Result):
    """`helixbif branch --json` with the columns of branch.csv."""

    s: _F
    omega: _F
    """rad/s"""
    omegabar: _F
    Fp: _F
    """N"""
    Fpbar: _F
    Fpbar_rigid: _F
    Tp: _F
    """N m"""
    eta: _F
    """NaN at rest"""
    h: _F
    """m"""
    hbar: _F
    max_re: _F
    """1/s"""
    n_unstable: _I
    stable: _B
    probe: _B
    """A state solved by a probe of a near miss between two points (docs/model.md section 5)."""
    events: list[dict[str, Any]]
    study: str
    nodes: int
    points: int
    omega_reached: float
    omega_max: float
    probes: int
    """States solved to probe the branch's near misses."""
    windows_between: list[list[float]]
    """The steps (rates of their two points, rad/s) that hold a window of instability a probe
    found; its loss and regain are among the events."""
    near_miss_unresolved: list[str]
    """Near misses whose probes neither found nor excluded a window: where and why."""
    stop: str
    stalled: bool
    seconds: float
    """Wall time of the run, s."""
    out: str

class Solution(_Result):
    """`helixbif solve --json` with the node positions."""

    positions: _F
    """(N, 3), m"""
    theta: _F
    """(N - 1,), rad"""
    study: str
    omega: float
    omegabar: float
    Fp: float
    Fpbar: float
    Fp_rigid: float
    Fpbar_rigid: float
    Tp: float
    eta: float | None
    h: float
    h0: float
    hbar: float
    nodes: int
    newton_iterations: int
    residual_norm: float
    residual_history: list[float]
    errors: dict[str, Any] | None
    """The estimated error of each observable (`Fp`, `Fpbar`, `Tp`, `eta`, `h`, `h0`, `hbar`,
    `Fpbar_rigid`; `coarse_nodes`, `quadrature_compared_with`, `quadrature_missing`), None
    where not estimated."""
    errors_missing: str | None
    """Why `errors` is None."""

class Boundary(_Result):
    """`helixbif boundary --json` with the columns of boundary.csv."""

    segment: _I
    q: _F
    omega_b: _F
    """rad/s: the curve's at its N, or with `accuracy` the point's refined answer."""
    omega_b_error: _F
    """Estimated error of omega_b, rad/s (NaN where not estimated): with `accuracy` the
    refinement's, else the discretization error at the curve's N."""
    reached: _B | _F | _S
    """Whether the point reached `accuracy` (bool); without one (or on fold and branch-point
    curves alone) empty: NaN floats; text where fold rows leave cells empty among the others."""
    omegabar_b: _F
    kind: _S
    w: _F
    wbar: _F
    Fpbar: _F
    hbar: _F
    m_loc: _F
    m_loc_error: _F
    """Estimated error of m_loc, from the points' relative errors (NaN where not estimated)."""
    precision: _F
    l1: _F
    l1_precision: _F
    criticality: _S
    """The column; the report's counts are `result["criticality"]`."""
    nodes: _I
    """The N of omega_b (the curve's is `curve_nodes`)."""
    curve_omega_b: _F
    """The curve's own omega_b at `curve_nodes`, rad/s."""
    curve_nodes: _I
    answer: _S
    """Where omega_b comes from: `curve`, `refined`, `interpolated` (with `carry_spacing`) or
    `kept` (at the curve's N)."""
    key: str
    to: float
    """The end of the range of `key`; its start is `result["from"]` (`from` is a Python
    keyword)."""
    points: int
    segments: int
    special: list[dict[str, Any]]
    evaluations: int
    window_checks: int
    """Independent `locate` runs below the curve, watching for another mode's window."""
    check_omega_b: float | None
    check_difference: float | None
    accuracy: float | None
    carried: int | None
    """Points carried to `accuracy` (the Hopf points; None without one)."""
    not_reached: int | None
    """Points that fell short of `accuracy` (None without one)."""
    interpolated: int | None
    """Of the points carried, those interpolated between refined ones (`carry_spacing`)."""
    relative_error_max: list[float] | None
    """The largest estimated relative error of omega_b over the points, and its q."""
    first_shortfall: str | None
    first_unresolved_near_miss: str | None
    """The first window check whose branch had a near miss its probes neither resolved nor
    excluded (where and why)."""
    """Where the first point fell short of `accuracy`, and why its refinement stopped."""
    nodes_max: int
    seconds: float
    """Wall time of the run, s."""
    time: dict[str, float]
    """Where the seconds went: `curve` (the rest: the locate at the start, the curve's steady
    solves, spectra and Lyapunov coefficients, its special points, the files), `window_checks`,
    `rows` (the points' rows: their errors from N/2 + 1, or their refinements with
    `accuracy`), `end_check`."""
    out: str

class Simulation(_Result):
    """`helixbif simulate --json` with the columns of timeseries.csv and the shapes."""

    t: _F
    """s"""
    omega: _F
    """The column; the rate asked for is `result["omega"]`."""
    hbar: _F
    Fp: _F
    Fpbar: _F
    Tp: _F
    eta: _F
    shapes: _F
    """(F, N, 3), m"""
    shape_times: _F
    """(F,), s"""
    cycles: dict[str, npt.NDArray[Any]]
    study: str
    t_end: float
    steps: int
    rejected: int
    newton_iterations: int
    jacobians: int
    hbar_mean: float | None
    hbar_std: float | None
    Fpbar_mean: float | None
    Fpbar_std: float | None
    eta_mean: float | None
    eta_std: float | None
    transient: float
    orbit: dict[str, Any] | None
    seconds: float
    """Wall time of the run, s."""
    out: str

class Orbits(_Result):
    """`helixbif orbits --json` with the columns of orbits.csv."""

    index: _I
    omega: _F
    omegabar: _F
    period: _F
    periodbar: _F
    amplitude: _F
    amplitudebar: _F
    hbar_mean: _F
    Fpbar_mean: _F
    Fp_mean: _F
    Tp_mean: _F
    max_multiplier: _F
    unstable: _I
    stable: _B
    verdict: _S
    trivial_error: _F
    iterations: _I
    steady: dict[str, npt.NDArray[Any]]
    study: str
    nodes: int
    omega_hopf: float
    frequency: float
    l1: float
    criticality: str
    orbits: int
    stop: Any
    events: list[dict[str, Any]]
    first: dict[str, Any] | None
    last: dict[str, Any] | None
    resumed_at: int | None
    seconds: float
    """Wall time of the run, s."""
    out: str

class StudyRun(_Result):
    """`helixbif run --json` with the table the study's kind writes at the top of `out`."""

    study: str
    kind: str
    """The plan's kind: branch, locate, sweep, phase, boundary, shapes, dynamics, orbits."""
    seconds: float
    """Wall time of the run, s."""
    out: str
    result: dict[str, Any] | None
    """The kind's own result, as `meta.json` records it under `run` (None in the `partial` of
    a study that failed before it had one). `columns` is the table the run wrote at the top of
    `out` (branch.csv, sweep.csv, ...; empty for locate and for several cases); its columns are
    not attributes."""

class PowerLaw(_Result):
    """A power law y = C x^p (the fit's part of `helixbif fit --json`)."""

    C: float
    p: float
    C_ci: list[float]
    p_ci: list[float]
    n: int
    r2: float
    residuals: _F

def fit_power_law(x: npt.ArrayLike, y: npt.ArrayLike) -> PowerLaw:
    """y = C x^p by least squares in logarithms, with 95% intervals. Raises ValueError."""
