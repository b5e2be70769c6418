"""
gearuq and OpenTURNS, both directions
=====================================

``gearuq.interop.openturns`` (install with ``pip install "gearuq[openturns]"``) hands a gearuq
model and parameter space to OpenTURNS as an ``ot.Function`` and a joint distribution
(marginals and copula), and reads an OpenTURNS distribution back as a gearuq
``ParameterSpace``. This page does both:

1. **gearuq -> OpenTURNS.** The lumped helical gear pair (after Li, Hu and Han's 10-DOF
   model with backlash, bearing clearances and time-varying mesh stiffness): the largest
   dynamic mesh force over a time window, as a function of its six random parameters.
   OpenTURNS' Monte Carlo on the event "force above a limit" is compared with gearuq's own
   crude Monte Carlo on the same limit state; the two 95 % intervals must overlap.
2. **OpenTURNS -> gearuq.** A Gumbel load and a lognormal strength joined by a normal copula,
   built in OpenTURNS, become a gearuq space; gearuq's samples reproduce OpenTURNS' moments
   and Spearman correlation, and a limit state on them gets the same failure probability
   from both libraries' FORM.
"""

import matplotlib.pyplot as plt
import numpy as np
import openturns as ot
from scipy.stats import spearmanr

import gearuq
from gearuq.failure.modes import LimitState
from gearuq.interop.openturns import (
    from_openturns_distribution,
    to_openturns_distribution,
    to_openturns_function,
)

# %%
# gearuq -> OpenTURNS: Monte Carlo on a gear model
# ------------------------------------------------
# The space's six parameters (face widths B1, B2, half backlash b5, density rho, stiffness
# variation s, speed n) become an OpenTURNS joint distribution; the model output, reduced to its
# maximum over the nondimensional instants ``t``, an OpenTURNS function. One OpenTURNS block of
# 500 points is one batched call of the model. Both libraries see the same quantity, the
# largest force over the instants ``t``; gearuq's status tells whether that grid resolves the
# continuous-time peak (status 7 when halving the grid changes the answer by more than half the
# interval's width: the mesh-frequency force peaks are sharp).

model = gearuq.get_model("helical_pair")
space = model.default_space()
t = np.linspace(0.0, 20.0, 401)  # fine enough to resolve the force peaks (status 0)
force_limit = 7.977e4  # N: about the 70th percentile, so the failure probability is about 0.3

dist = to_openturns_distribution(space)
peak_force = to_openturns_function(model, space, "mesh_force", t=t, reduce="max")
event = ot.ThresholdEvent(ot.CompositeRandomVector(peak_force, ot.RandomVector(dist)),
                          ot.Greater(), force_limit)
ot.RandomGenerator.SetSeed(3)
algo = ot.ProbabilitySimulationAlgorithm(event, ot.MonteCarloExperiment())
algo.setBlockSize(500)
algo.setMaximumOuterSampling(2)
algo.setMaximumCoefficientOfVariation(0.0)
algo.run()
res = algo.getResult()
pf_ot = res.getProbabilityEstimate()
half_ot = 1.96 * res.getStandardDeviation()

limit = LimitState.upper("mesh_force", force_limit)
mine = gearuq.failure_probability(model, space, limit, t, method="mc", rng=3, n_samples=1000)
pf_gq = float(mine["pf"])
lo_gq, hi_gq = float(mine["pf_lower"]), float(mine["pf_upper"])
print(f"OpenTURNS Monte Carlo: Pf = {pf_ot:.3f} +- {half_ot:.3f} (1000 runs)")
print(f"gearuq crude MC:       Pf = {pf_gq:.3f} [{lo_gq:.3f}, {hi_gq:.3f}] "
      f"(1000 runs, status {int(mine['status'])})")
print("gearuq's status says:", mine.attrs.get("message") or "nothing to flag")
assert pf_ot - half_ot <= hi_gq and lo_gq <= pf_ot + half_ot, "the intervals must overlap"

# %%
# OpenTURNS -> gearuq: a distribution built in OpenTURNS
# -------------------------------------------------------
# A Gumbel load S and a lognormal strength R, correlated through a normal copula, read back
# as a gearuq space. gearuq's Latin hypercube reproduces OpenTURNS' Spearman correlation,
# and both libraries' FORM give the same reliability index for ``g = R - S``.

load = ot.Gumbel(8.0, 40.0)  # beta (scale), gamma (mode)
strength = ot.LogNormal(np.log(100.0), 0.1)
copula = ot.NormalCopula(ot.CorrelationMatrix(2, [1.0, 0.4, 0.4, 1.0]))
joint = ot.JointDistribution([load, strength], copula)
joint.setDescription(["S", "R"])
space_rs = from_openturns_distribution(joint)
print(space_rs)

draw = space_rs.sample(4000, rule="lhs", rng=5)
x_gq = np.column_stack([draw["S"], draw["R"]])
x_ot = np.array(joint.getSample(4000))
rho_ot = joint.getSpearmanCorrelation()[0, 1]
rho_gq = spearmanr(x_gq[:, 0], x_gq[:, 1]).statistic
print(f"Spearman correlation: OpenTURNS {rho_ot:.3f} (exact), gearuq sample {rho_gq:.3f}")

g_model = gearuq.FunctionModel(lambda S, R: R - S, ["S", "R"], ["g"], name="strength_minus_load")
form_gq = gearuq.failure_probability(g_model, space_rs, "g", method="form", rng=1)
g_ot = to_openturns_function(g_model, space_rs, "g")
ev = ot.ThresholdEvent(ot.CompositeRandomVector(g_ot, ot.RandomVector(joint)),
                       ot.LessOrEqual(), 0.0)
solver = ot.Cobyla()
solver.setStartingPoint(joint.getMean())
form_ot = ot.FORM(solver, ev)
form_ot.run()
beta_ot = form_ot.getResult().getHasoferReliabilityIndex()
print(f"FORM beta: OpenTURNS {beta_ot:.4f}, gearuq {float(form_gq['beta']):.4f}")

# %%
# Left: the peak mesh force of the gear pair from the two libraries' Monte Carlo runs, the
# limit marked. Right: the load-strength samples of both libraries over the same copula.

ot.RandomGenerator.SetSeed(11)
x_force = dist.getSample(300)
f_ot = np.array(peak_force(x_force)).ravel()
f_gq = gearuq.monte_carlo(model, space, t, n_samples=300, rng=11, outputs=["mesh_force"],
                          progress=False)["mesh_force"].max("time").values

fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(10, 4.2), layout="constrained")
bins = np.linspace(min(f_ot.min(), f_gq.min()), max(f_ot.max(), f_gq.max()), 30) / 1e3
ax0.hist(f_ot / 1e3, bins=bins, histtype="step", lw=2, color="tab:blue", label="OpenTURNS sample")
ax0.hist(f_gq / 1e3, bins=bins, histtype="step", lw=2, color="tab:orange", label="gearuq sample")
ax0.axvline(force_limit / 1e3, color="k", ls="--", label="limit")
ax0.set_xlabel("largest dynamic mesh force [kN]")
ax0.set_ylabel("samples per bin [-]")
ax0.set_title("helical pair: peak mesh force")
ax0.legend()
ax1.plot(x_ot[:800, 0], x_ot[:800, 1], ".", ms=3, color="tab:blue", label="OpenTURNS")
ax1.plot(x_gq[:800, 0], x_gq[:800, 1], ".", ms=3, color="tab:orange", label="gearuq (LHS)")
s = np.linspace(x_ot[:, 0].min(), x_ot[:, 0].max(), 2)
ax1.plot(s, s, "k--", label="g = R - S = 0")
ax1.set_xlabel("load S [kN]")
ax1.set_ylabel("strength R [kN]")
ax1.set_title("Gumbel x lognormal, normal copula")
ax1.legend()
plt.show()
