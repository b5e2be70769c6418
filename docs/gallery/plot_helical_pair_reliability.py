"""
Helical-pair vibration reliability R(t)
=======================================

A quick version of the default study (``gearuq demo``): Monte Carlo over the built-in random
parameters of the ``helical_pair`` model (lumped helical gear pair after Li, Hu and Han, *A
non-linear random vibration reliability analysis method for multi degree of freedom helical
gear driven system*), then the instantaneous and first-passage reliability of the pinion and
gear radial vibration ``v1`` and ``v6`` inside a tolerance band, with 95 % Wilson intervals.

The production study uses 10^4 samples; 400 Latin-hypercube samples here keep the page quick
and show how wide the intervals are at that size.
"""

import matplotlib.pyplot as plt
import numpy as np

import gearuq

model = gearuq.get_model("helical_pair")
space = model.default_space()  # B1, B2, b5, rho, s, n: independent normals
print(space)

tau = np.linspace(0.0, 200.0, 201)  # nondimensional time
ds = gearuq.monte_carlo(model, space, tau, n_samples=400, rule="lhs", rng=1,
                        outputs=["v1", "v6"], progress=False)

# Allowed band on each vibration (1 = 10 um), judged over the steady window tau in [100, 200]:
# the demo's band on v1 and a band on v6 that about a third of the samples leave.
bands = {"v1": 0.506, "v6": 0.092}
rel = gearuq.reliability(ds, {k: (-b, b) for k, b in bands.items()}, time=(100.0, 200.0))
end = rel.isel(time=-1)
for mode in rel["mode"].values:
    e = end.sel(mode=mode)
    print(f"{mode:>6}: first-passage Pf over tau in [100, 200] = {float(e['pf_first_passage']):.3f}"
          f"  (95 % interval {float(e['pf_first_passage_lower']):.3f}"
          f" - {float(e['pf_first_passage_upper']):.3f})")

# %%
# First-passage reliability :math:`R_{fp}(t) = P(|v(s)| \le b \;\forall s \in [100, t])`
# (thick, with its 95 % interval shaded) and instantaneous reliability
# :math:`R(t) = P(|v(t)| \le b)` (thin): the instantaneous one dips once per vibration period
# where the response peaks, the first-passage one only falls.

fig, ax = plt.subplots(figsize=(7.5, 4.2), layout="constrained")
t = rel["time"].values
for mode, colour in (("v1", "tab:blue"), ("v6", "tab:orange"), ("system", "tab:green")):
    r = rel.sel(mode=mode)
    label = {"v1": "pinion x (v1)", "v6": "gear x (v6)", "system": "both bands"}[mode]
    if mode != "system":
        ax.plot(t, r["r"], color=colour, lw=0.6, alpha=0.6, label=f"{label}, instantaneous")
    ax.plot(t, r["r_first_passage"], color=colour, lw=1.8, ls="--" if mode == "system" else "-",
            label=f"{label}, first passage")
    ax.fill_between(t, r["r_first_passage_lower"], r["r_first_passage_upper"], color=colour,
                    alpha=0.2, lw=0)
ax.set_xlabel("nondimensional time tau (1)")
ax.set_ylabel("reliability (1)")
ax.set_title(f"helical_pair, {ds.sizes['sample']} LHS samples: |v1| <= {bands['v1']}, "
             f"|v6| <= {bands['v6']} (1 = 10 um)")
ax.set_ylim(0.0, 1.02)
ax.legend(fontsize=8, loc="lower left")
plt.show()
