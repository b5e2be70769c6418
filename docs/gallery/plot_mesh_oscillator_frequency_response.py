"""
Mesh-oscillator frequency response with contact loss
====================================================

A quick version of the study run by ``gearuq study mesh_oscillator_regions``: the
nondimensional frequency response of the ``mesh_oscillator``
model (single-degree-of-freedom gear mesh after Eritenel and Parker, *Nonlinear Vibration of
Gears With Tooth Surface Modifications*, ASME Journal of Vibration and Acoustics 135, 2013)
near primary resonance, with the parameters of the paper's Fig. 4, by the second-order
multiple-scales solution. Upward and downward sweeps part where the teeth lose contact
(softening jump); the linear time-invariant response is drawn for comparison. Five samples of
the model's built-in random space (damping ratio and first excitation harmonic) show how the
uncertain inputs move the resonance.
"""

import matplotlib.pyplot as plt

import gearuq

model = gearuq.get_model("mesh_oscillator")
nominal = model.response({}, None, outputs=["amplitude_up", "amplitude_down",
                                             "linear_amplitude", "separation_up"],
                         frequency_min=0.8, frequency_max=1.2, n_frequencies=161)
space = model.default_space()
print(space)
ds = gearuq.monte_carlo(model, space, None, n_samples=5, rng=3, progress=False,
                        outputs=["amplitude_up"],
                        model_options={"frequency_min": 0.8, "frequency_max": 1.2,
                                       "n_frequencies": 161})

# %%
# Nominal response (thick) and the upward sweeps of five random samples (thin).

fig, ax = plt.subplots(figsize=(7.5, 4.2), layout="constrained")
f = nominal["frequency"].values
ax.plot(f, nominal["linear_amplitude"].squeeze(), color="0.4", ls="--", lw=1.2,
        label="linear (no contact loss)")
ax.plot(f, nominal["amplitude_up"].squeeze(), color="tab:blue", lw=2.0, label="upward sweep")
ax.plot(f, nominal["amplitude_down"].squeeze(), color="tab:red", lw=2.0, ls="-.",
        label="downward sweep")
for i in range(ds.sizes["sample"]):
    ax.plot(f, ds["amplitude_up"].isel(sample=i), color="tab:purple", lw=0.7, alpha=0.7,
            label="random samples, upward" if i == 0 else None)
ax.set_xlabel("mesh frequency / natural frequency (1)")
ax.set_ylabel("amplitude a / d (1)")
ax.set_title("mesh_oscillator: second-order multiple scales, Eritenel and Parker Fig. 4")
ax.legend(fontsize=8)
plt.show()
