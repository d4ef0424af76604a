"""helixbif: continuation and bifurcation analysis of an elastic rod turned in a viscous fluid.

The Python API of the helixbif library (Discrete Elastic Rods + Lighthill slender-body theory):
the rigidly rotating steady states of a slender elastic rod (a macroscopic bacterial flagellum)
clamped to a motor and turned at the rate omega, their continuation, stability and
bifurcations, at native speed. Every run is the command line's command with its options as
arguments, and gives the same numbers as its ``--json``; tables come as numpy arrays.

    >>> import helixbif
    >>> study = helixbif.Study.default()            # the representative helix
    >>> located = study.locate(single=True)         # helixbif locate --single
    >>> located.omega_b, located.kind               # rad/s, 'hopf'
    >>> branch = study.with_(**{"discretization.nodes": 40}).branch(omega_max=0.6)
    >>> branch.omega, branch.hbar                   # numpy arrays, one entry per point

Units are SI (rates rad/s, lengths m, forces N, times s); barred quantities are the solver's
dimensionless ones (docs/model.md). Bad input raises ValueError with the command line's
one-line message; a numerical failure raises NumericalError, which carries what was found
before it (``partial``); Ctrl-C (KeyboardInterrupt) ends a long run between two steps.

The reference is docs/python.md in the repository.
"""

from ._helixbif import (
    Boundary,
    Branch,
    Located,
    NumericalError,
    Orbits,
    PowerLaw,
    Simulation,
    Solution,
    Study,
    StudyRun,
    __version__,
    fit_power_law,
)

__all__ = [
    "Study",
    "Located",
    "Branch",
    "Solution",
    "Boundary",
    "Simulation",
    "Orbits",
    "PowerLaw",
    "StudyRun",
    "NumericalError",
    "fit_power_law",
    "__version__",
]
