"""Figures that show what they promise: readable ticks, bands, every curve, units.

Each test reads the drawn artists back from the Figure (through the Agg renderer where
positions matter), so a figure that hides something fails here rather than in a review.
"""

import matplotlib.colors
import numpy as np
import pytest

from gearuq import plot as gplot


def _overlapping_tick_labels(fig) -> list[str]:
    """Axes/axis pairs whose tick-label boxes intersect once the figure is laid out."""
    fig.draw_without_rendering()
    renderer = fig.canvas.get_renderer()
    bad = []
    for k, ax in enumerate(fig.axes):
        for name, axis in (("x", ax.xaxis), ("y", ax.yaxis)):
            boxes = [t.get_window_extent(renderer) for t in axis.get_majorticklabels()
                     if t.get_text()]
            for i, a in enumerate(boxes):
                for b in boxes[i + 1:]:
                    if a.overlaps(b):
                        bad.append(f"axes {k} ({ax.get_title()}) {name}: "
                                   f"{[t.get_text() for t in axis.get_majorticklabels()]}")
                        break
    return sorted(set(bad))


def _gear_like_series(offset: float, amp: float, period: float, n_periods: int = 400):
    """Steady periodic response far from zero (a static deflection of -205 units), as the
    helical pair's support DOFs: long tick labels on narrow panels."""
    t = np.arange(n_periods * 64 + 1) * (period / 64)
    w = 2 * np.pi / period
    x = offset + amp * np.cos(w * t) + 0.08 * amp * np.cos(2 * w * t + 0.3)
    v = -amp * w * np.sin(w * t) - 0.16 * amp * w * np.sin(2 * w * t + 0.3)
    return t, x, v


@pytest.mark.e2e
def test_time_panels_tick_labels_do_not_overlap():
    period = 6.3471
    t, xp, vp = _gear_like_series(-204.5, 0.55, period)
    _, xg, vg = _gear_like_series(124.87, 0.057, period)
    _, x4, v4 = _gear_like_series(867.12, 0.22, period)
    series = {"x_p (p1)": (xp, vp), "z_g (p8)": (xg, vg), "theta_gy (p9)": (x4, v4)}
    fig, axes = gplot.plot_time_panels(t, series, period, t_start=300 * period,
                                       normalize_frequency=True, fmax=4.0, x_name="p",
                                       v_name="dp/dtau", time_units="1",
                                       units=("1e-05 m", "1e-05 m"),
                                       time_window=12 * period, figsize=(16.0, 9.0))
    assert axes.shape == (3, 5)
    assert _overlapping_tick_labels(fig) == []
    assert _overlapping_axis_labels(fig) == []
    for ax in axes.ravel():  # a unit on every axis
        assert ax.get_xlabel().endswith("]") and ax.get_ylabel().endswith("]"), ax.get_title()
    # the limits are untouched: the Poincare panel still centres its one point
    lo, hi = axes[0, 4].get_xlim()
    assert lo < xp[-1] < hi


# --------------------------------------------------------------------------------------------
# reliability curves: identical modes, the band, spikes
# --------------------------------------------------------------------------------------------
def _rel(n: int = 10_000, seed: int = 1):
    """Reliability of three bands over 51 instants: ``b = 2 a`` exactly (the band scaled
    alike), so modes a and b coincide; failures at one instant (a spike) and over a plateau."""
    import xarray as xr

    import gearuq
    from gearuq.failure.modes import Band

    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 50.0, 51)
    amp = 1.0 + 0.05 * rng.standard_normal((n, 1))
    shape = np.where(t == 10.0, 1.3, 1.0) * np.where((t >= 30) & (t <= 40), 1.1, 1.0)
    a = amp * shape * np.cos(0 * t)
    c = 1.0 + 0.3 * rng.standard_normal((n, t.size))
    ds = xr.Dataset({"a": (("sample", "time"), a), "b": (("sample", "time"), 2.0 * a),
                     "c": (("sample", "time"), c), "status": ("sample", np.zeros(n, int))},
                    coords={"time": ("time", t, {"units": "s", "long_name": "time"})})
    bands = [Band("a", -1.2, 1.2, name="a"), Band("b", -2.4, 2.4, name="b"),
             Band("c", -np.inf, 1.6, name="c")]
    return gearuq.reliability(ds, bands, confidence=0.95)


def _legend_texts(ax) -> list[str]:
    return [t.get_text() for t in ax.get_legend().get_texts()]


def test_identical_modes_are_drawn_once_and_all_listed():
    rel = _rel()
    np.testing.assert_array_equal(rel["pf"].sel(mode="a"), rel["pf"].sel(mode="b"))
    for q in ("r", "pf", "beta"):
        fig, ax = gplot.plot_reliability_curves(rel, quantity=q)
        texts = _legend_texts(ax)
        assert "a = b" in texts  # one curve named after both modes
        assert {"c", "system"} <= set(texts)
        # one line per distinct curve: a = b, c, system (a copy under a copy is never drawn)
        assert len(ax.get_lines()) == 3
        colours = [matplotlib.colors.to_hex(ln.get_color()) for ln in ax.get_lines()]
        assert len(set(colours)) == 3


def test_band_is_drawn_and_says_where_the_line_hides_it():
    from gearuq.failure.intervals import wilson_interval

    rel = _rel()
    n = int(rel.attrs["n_valid"])
    _, upper0 = wilson_interval(0, n, 0.95)
    fig, ax = gplot.plot_reliability_curves(rel, quantity="r")
    band = [t for t in _legend_texts(ax) if "band" in t]
    assert len(band) == 1 and band[0].startswith("95 % Wilson band")
    # at the instants without failures the band [1 - 3.8e-4, 1] is far thinner than a line
    # on an axis reaching down to R ~ 0.3: the legend says so and gives the threshold
    assert float(upper0) == pytest.approx(3.84 / (n + 3.84), rel=1e-3)
    assert "hidden by the line where narrower than" in band[0]
    thr = float(band[0].rsplit(" ", 1)[1].rstrip(")"))
    assert upper0 < thr < 0.02
    # the band is drawn: some filled patch spans [R_lower, R_upper] of a = b at t = 35
    # (a plateau of failures), where the interval is nonzero
    c = rel.sel(mode="a", time=35.0)
    lo, hi = float(c["r_lower"]), float(c["r_upper"])
    assert hi - lo > 0.005
    spans = []
    for coll in ax.collections:
        for path in coll.get_paths():
            v = path.vertices
            at = np.isclose(v[:, 0], 35.0)
            if at.sum() >= 2:
                spans.append((v[at, 1].min(), v[at, 1].max()))
    assert any(s0 <= lo + 1e-9 and s1 >= hi - 1e-9 for s0, s1 in spans)
    # the one-instant spike of a = b at t = 10: marked, its interval drawn as a bar
    ab = rel.sel(mode="a", time=10.0)
    assert 0 < float(ab["pf"]) < 1 and float(rel.sel(mode="a", time=8.0)["pf"]) == 0
    bars = [seg for coll in ax.collections if hasattr(coll, "get_segments")
            for seg in coll.get_segments() if len(seg) == 2 and np.isclose(seg[0][0], 10.0)]
    assert any(np.isclose(min(s[0][1], s[1][1]), float(ab["r_lower"]))
               and np.isclose(max(s[0][1], s[1][1]), float(ab["r_upper"])) for s in bars)


def test_log_pf_shows_zero_failure_bound_once_and_no_point_vanishes():
    rel = _rel()
    fig, ax = gplot.plot_reliability_curves(rel, quantity="pf")
    assert ax.get_yscale() == "log"
    strip = [t for t in _legend_texts(ax) if t.startswith("no failure observed")]
    assert strip == ["no failure observed: pf below 3.8e-04 (95 % upper bound)"]
    # the spike of a = b at t = 10 has zero neighbours (NaN on a log axis): a line alone
    # would not draw it, so it carries a marker
    line = next(ln for ln in ax.get_lines() if ln.get_label() == "a = b")
    t = line.get_xdata()
    marked = np.asarray(line.get_markevery())
    assert line.get_marker() == "o" and 10.0 in t[marked]
    y0, _ = ax.get_ylim()
    assert y0 < 3.8e-4  # the bound is inside the axis


def test_wide_band_is_not_declared_hidden():
    rel = _rel(n=200)
    fig, ax = gplot.plot_reliability_curves(rel.sel(mode=["c"]), quantity="r")
    band = [t for t in _legend_texts(ax) if "band" in t]
    assert band == ["95 % Wilson band"]  # about +-0.02 on R ~ 0.98, at every instant


# --------------------------------------------------------------------------------------------
# the default study (gearuq demo): its figures and the summary's identical rows
# --------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    from gearuq.registry import DEFAULT_STUDY, get_study

    out = tmp_path_factory.mktemp("demo")
    assert get_study(DEFAULT_STUDY)(out, n_samples=1000, seed=7, progress=False) == 0
    return out


@pytest.mark.e2e
def test_demo_summary_says_which_rows_are_identical_and_why(demo):
    import gearuq

    text = (demo / "summary.txt").read_text()
    table: dict[str, str] = {}  # the first table (Table 3 analog), first row of each DOF
    for ln in text.splitlines():
        if ln.split()[:1] and ln.split()[0] in ("x_p", "y_p", "z_p", "theta_py"):
            table.setdefault(ln.split()[0], ln)
    assert table["y_p"].endswith("= x_p") and table["z_p"].endswith("= x_p")
    assert not table["theta_py"].endswith("= x_p")
    assert "Identical rows (marked '= name'): x_p = y_p = z_p; x_g = y_g = z_g" in text
    # the stated reason, with the direction cosines' ratios of the model's geometry
    a_n, b = np.radians(25.0), np.radians(17.0)
    ny_nx, nz_nx = np.cos(b) / np.tan(a_n), np.sin(b) / np.tan(a_n)
    assert f"v2 = {ny_nx:.5g} v1" in text and f"v8 = {nz_nx:.5g} v6" in text
    assert "k_r = k_a = 5.968e+06 N/m" in text and "n_x : n_y : n_z" in text
    # and the data bear it out: the responses are proportional with exactly these ratios
    ds = gearuq.load(demo / "helical_pair_mc.nc")
    for ref, other, ratio in (("v1", "v2", ny_nx), ("v1", "v3", nz_nx), ("v6", "v7", ny_nx)):
        x, y = ds[ref].values, ds[other].values
        assert np.max(np.abs(y - ratio * x)) <= 1e-9 * np.max(np.abs(y))


def test_equal_support_stiffness_is_what_makes_the_translations_proportional():
    """The stated mechanism can fail: with k_a != k_r the axial response is no longer the
    radial one scaled by n_z / n_x (the model, one nominal sample)."""
    import gearuq

    model = gearuq.get_model("helical_pair")
    tau = np.linspace(0.0, 200.0, 401)
    nz_nx = np.sin(np.radians(17.0)) / np.tan(np.radians(25.0))
    same = model.response({}, tau, outputs=["v1", "v3"])
    x, z = same["v1"].values[0], same["v3"].values[0]
    assert np.max(np.abs(z - nz_nx * x)) < 1e-8 * np.max(np.abs(z))
    stiff = model.response({"k_a": [2 * 5.968e6]}, tau, outputs=["v1", "v3"])
    x, z = stiff["v1"].values[0], stiff["v3"].values[0]
    assert np.max(np.abs(z - nz_nx * x)) > 0.05 * np.max(np.abs(z))


# end to end: the whole default study (10^3 samples, netCDF written and read back) for its
# figures, 6.5 s of CPU; CI runs them with -m e2e, beside the demo's summary test sharing the run
@pytest.mark.e2e
def test_demo_reliability_figure_lists_every_dof_and_shows_the_band(demo):
    import gearuq
    from gearuq_studies.helical_pair_reliability import (
        DOF_NAMES,
        _first_passage_figure,
        _reliability_figure,
    )

    rel = gearuq.load(demo / "reliability_margin.nc")
    fig = _reliability_figure(rel)
    ax_r, ax_pf = fig.axes[:2]
    texts = _legend_texts(ax_r)
    listed = [name for t in texts for name in t.split(" = ")]
    assert set(DOF_NAMES) | {"system"} <= set(listed)
    assert "x_p = y_p = z_p" in texts and "x_g = y_g = z_g" in texts
    assert any(t.startswith("95 % Wilson band") for t in texts)
    assert any(t.startswith("no failure observed: pf below") for t in _legend_texts(ax_pf))
    assert ax_pf.get_yscale() == "log"
    # the system's first-passage band has a visible height (a flat curve with ~n^-1/2 band)
    fp = rel.sel(mode="system").isel(time=-1)
    assert float(fp["r_first_passage_upper"] - fp["r_first_passage_lower"]) > 0.02
    assert _overlapping_tick_labels(fig) == []
    fig = _first_passage_figure(rel)
    listed = [name for t in _legend_texts(fig.axes[0]) for name in t.split(" = ")]
    assert set(DOF_NAMES) | {"system"} <= set(listed)


@pytest.mark.e2e  # reads the demo's own result file: the same whole default study
def test_demo_fits_figure_has_units_on_every_axis(demo):
    import gearuq
    from gearuq_studies.helical_pair_reliability import DOF_NAMES, _fits_figure

    ds = gearuq.load(demo / "helical_pair_mc.nc")
    unit = ds.attrs["length_scale"]
    assert unit == "1e-05 m"
    fits = {}
    for i, dof in enumerate(DOF_NAMES):
        dev = np.abs(ds[f"v{i + 1}"].values[:, -1])
        fits[dof] = (dev, gearuq.fit_distributions(dev, candidates=("normal", "weibull")))
    fig = _fits_figure(fits, unit)
    for ax, dof in zip(fig.axes, DOF_NAMES, strict=True):
        assert ax.get_xlabel().endswith("[1e-05 m arc]" if dof.startswith("theta")
                                        else "[1e-05 m]"), ax.get_xlabel()
        assert ax.get_ylabel() == "probability density [1/(" + ax.get_xlabel()[
            ax.get_xlabel().index("[") + 1:-1] + ")]"
    titles = [ax.get_title() for ax in fig.axes]
    assert titles[1].startswith("y_p = 2.0508 x_p") and titles[7].startswith("z_g = 0.62699 x_g")
    assert titles[0].startswith("x_p: ") and titles[3].startswith("theta_py: ")
    assert _overlapping_tick_labels(fig) == []
    assert _overlapping_axis_labels(fig) == []


def _overlapping_axis_labels(fig) -> list[str]:
    """Pairs of x-axis labels of neighbouring panels that run into each other."""
    fig.draw_without_rendering()
    renderer = fig.canvas.get_renderer()
    boxes = [(ax.get_xlabel(), ax.xaxis.label.get_window_extent(renderer)) for ax in fig.axes]
    return [f"{a} / {b}" for i, (a, ba) in enumerate(boxes) for b, bb in boxes[i + 1:]
            if ba.overlaps(bb)]


@pytest.mark.e2e
def test_demo_note_calls_proportional_only_what_is(tmp_path):
    """At 50 samples two rows coincide in their printed digits without proportional
    responses (theta_pz and x_p): the note keeps them apart from the proportional ones, and
    every ratio it calls exact holds in the data to round-off."""
    import re

    import gearuq
    from gearuq.registry import DEFAULT_STUDY, get_study

    assert get_study(DEFAULT_STUDY)(tmp_path, n_samples=50, progress=False) == 0
    text = (tmp_path / "summary.txt").read_text()
    ds = gearuq.load(tmp_path / "helical_pair_mc.nc")
    ok = ds["status"].values == 0
    exact = next(ln for ln in text.splitlines() if ln.startswith("Not a copying error"))
    pairs = re.findall(r"(v\d+) = ([0-9.e+-]+) (v\d+) \(deviation", exact)
    assert pairs
    for other, ratio, ref in pairs:
        x, y = ds[ref].values[ok], ds[other].values[ok]
        c = float(np.sum(x * y) / np.sum(x * x))
        assert c == pytest.approx(float(ratio), rel=1e-4)
        assert np.max(np.abs(y - c * x)) <= 1e-9 * np.max(np.abs(y))
    only = next(ln for ln in text.splitlines() if ln.startswith("Equal in the printed digits"))
    for dof, ref, dev in re.findall(r"(\w+) and (\w+) \(deviation ([0-9.e+-]+)\)", only):
        assert float(dev) > 1e-3, (dof, ref, dev)  # far from proportional
    assert "theta_pz and x_p" in only
