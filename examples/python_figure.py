# %% [markdown]
# # The buckling of the representative helix, from Python
#
# A figure of the paper from the Python API of helixbif (docs/python.md), in notebook style
# (each `# %%` is a cell; run it as a script or open it in Jupyter with jupytext):
#
# (a) the branch from rest of the representative helix, `hbar = h/h0` against the rate
#     `omega`, stable solid, unstable dashed, with its critical rate `omega_b` (a Hopf point);
# (b) the scaling of the critical rate `omegabar_b = omega_b mu ell^4/EI` with the helix's
#     radius over pitch, `R/lambda`, at the representative pitch, with a power-law fit.
#
# Cost: about 3 s on one core: `locate` and the branch at the study's N = 60 (0.3 s each), and
# five `locate` at a coarse 10 nodes per turn (N = 41, 0.4 s each; the paper's figure 4c uses
# 15 per turn, `studies/fig4c_radius.toml`). Needs matplotlib (`pip install matplotlib`).
#
#     python examples/python_figure.py [figure.png]

# %%
import sys
import time

import matplotlib

matplotlib.use("Agg")  # draw to a file; drop this line in a notebook
import matplotlib.pyplot as plt
import numpy as np

import helixbif

started = time.perf_counter()

# %% [markdown]
# ## The representative helix: omega_b and its branch

# %%
# Lighthill's operator at N = 60, as in the paper (the default fluid is the RPY line).
study = helixbif.Study.default().with_(**{"fluid.model": "lighthill"})
located = study.locate(single=True)  # at the study's N = 60, as `helixbif locate --single`
print(f"omega_b = {located.omega_b:.6f} rad/s ({located.kind}, {located.criticality}), "
      f"omegabar_b = {located.omegabar_b:.2f}, hbar there {located.hbar:.4f}")

branch = study.branch(omega_max=1.5 * located.omega_b)  # files in a temporary folder
print(f"{branch.points} points up to omega = {branch.omega_reached:.3f} rad/s; events:",
      [(e["kind"], round(e["omega"], 6)) for e in branch.events])

# %% [markdown]
# ## omegabar_b against R/lambda
#
# `shape.R_over_lambda` sets the radius by its ratio to the pitch (the pitch and the length
# fixed), and `discretization.per_turn` the node count by the turns, as in the sweep studies.

# %%
ratios = np.array([0.2, 0.25, 0.318, 0.4, 0.5])
coarse = study.with_(**{"discretization.per_turn": 10, "branch.omega_max": 3.0})
sweep = [coarse.with_(**{"shape.R_over_lambda": r}).locate(single=True) for r in ratios]
omegabar_b = np.array([s.omegabar_b for s in sweep])
for r, s in zip(ratios, sweep):
    print(f"R/lambda = {r:5.3f}: N = {s.nodes}, omegabar_b = {s.omegabar_b:8.2f} ({s.kind})")
fit = helixbif.fit_power_law(ratios, omegabar_b)
print(f"omegabar_b = {fit.C:.3g} (R/lambda)^{fit.p:.3f}, "
      f"95% interval of the exponent [{fit.p_ci[0]:.3f}, {fit.p_ci[1]:.3f}], r2 = {fit.r2:.5f}")

# %% [markdown]
# ## The figure

# %%
fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)

stable = branch.stable
unstable = ~stable | np.roll(~stable, -1)  # from the last stable point on, so the lines meet
for part, style in [(stable, "-"), (unstable, "--")]:
    # Each part as one line, broken (NaN) where the other part runs.
    left.plot(branch.omega, np.where(part, branch.hbar, np.nan), style, color="C0")
left.axvline(located.omega_b, color="C3", lw=0.8)
left.plot([located.omega_b], [located.hbar], "o", color="C3",
          label=f"Hopf point, omega_b = {located.omega_b:.4f} rad/s")
left.set_xlabel("omega (rad/s)")
left.set_ylabel("hbar = h/h0")
left.set_title("(a) representative helix, N = 60: stable solid, unstable dashed")
left.legend(loc="best")

right.loglog(ratios, omegabar_b, "o", label=f"locate, {sweep[0].nodes} nodes (10 per turn)")
fine = np.geomspace(ratios[0], ratios[-1], 50)
right.loglog(fine, fit.C * fine**fit.p, "-", color="C1",
             label=f"fit: omegabar_b ~ (R/lambda)^{fit.p:.2f}")
right.set_xlabel("R/lambda")
right.set_ylabel("omegabar_b = omega_b mu ell^4/EI")
right.set_title("(b) critical rate against radius over pitch")
right.legend(loc="best")

path = sys.argv[1] if len(sys.argv) > 1 else "helixbif_figure.png"
fig.savefig(path, dpi=120)
print(f"wrote {path} in {time.perf_counter() - started:.1f} s")
