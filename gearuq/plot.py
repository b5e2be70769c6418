"""Matplotlib figures for gearuq results.

Figures are built on :class:`matplotlib.figure.Figure` with the Agg canvas, never through
the pyplot state machine: nothing pops up, nothing needs ``plt.show()``, and the helpers are
safe in worker processes and headless runs. Every function takes an optional ``ax`` (axes
to draw into, e.g. from ``plt.subplots`` in a notebook) and returns ``(fig, ax)``; save with
:func:`save_figure`. Axis labels take ``long_name`` and ``units`` from DataArray attributes
where available.
"""

from __future__ import annotations

import functools
import inspect
import sys
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import matplotlib
import numpy as np
import xarray as xr
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from scipy.stats import norm

from gearuq import signal as sig

__all__ = [
    "QUICK_MARK_KEY",
    "plot_fit",
    "plot_reliability_curves",
    "plot_time_panels",
    "plot_work_precision",
    "quick_mode",
    "quick_run",
    "save_figure",
]

#: The mark of the quick run in progress (:func:`quick_run`), stamped by :func:`save_figure`.
_QUICK_MARK: str | None = None

#: The PNG text key under which :func:`save_figure` records the quick-run mark (read it with
#: ``PIL.Image.open(path).text.get(QUICK_MARK_KEY)``; absent from a full run's figures).
QUICK_MARK_KEY = "gearuq quick run"


# --------------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------------
def _new_figure(figsize: tuple[float, float]) -> Figure:
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _fig_ax(ax: Axes | None, figsize: tuple[float, float] = (6.0, 4.0)) -> tuple[Figure, Axes]:
    if ax is not None:
        return ax.figure, ax
    fig = _new_figure(figsize)
    return fig, fig.add_subplot(1, 1, 1)


def _label(obj: Any, default: str, units: str | None = None) -> str:
    """``"long_name [units]"`` from DataArray attrs, else ``default`` (with ``units``)."""
    name = default
    if isinstance(obj, xr.DataArray):
        name = obj.attrs.get("long_name") or (str(obj.name) if obj.name is not None else default)
        units = obj.attrs.get("units", units)
    if units not in (None, ""):
        return f"{name} [{units}]"
    return name


def _values(obj: Any) -> np.ndarray:
    return np.asarray(obj.values if isinstance(obj, xr.DataArray) else obj, dtype=float)


def _time_of(obj: Any, t: Any, dim: str = "time") -> tuple[np.ndarray, str | None]:
    """Time grid (and its units) for a 1-D series."""
    units = None
    if t is None:
        if isinstance(obj, xr.DataArray) and dim in obj.coords:
            units = obj[dim].attrs.get("units")
            return np.asarray(obj[dim].values, dtype=float), units
        raise ValueError("give t, or series as DataArrays with a time coordinate")
    if isinstance(t, xr.DataArray):
        units = t.attrs.get("units")
    return _values(t), units


def _frequency_label(time_units: str | None) -> str:
    if time_units in ("s", "second", "seconds"):
        return "frequency [Hz]"
    if time_units in (None, "", "1", "-"):
        return "frequency [cycles per unit time]"
    return f"frequency [1/{time_units}]"


def _identical_groups(curves: Mapping[str, Sequence[Any]]) -> list[list[str]]:
    """Keys whose arrays are all exactly equal (NaN equal to NaN), in order of appearance.

    Curves that coincide exactly would hide each other (the last drawn covers the rest and
    only its colour is seen), so they are drawn once with one label naming all of them.
    """
    groups: list[list[str]] = []
    reps: list[Sequence[Any]] = []
    for key, arrays in curves.items():
        for group, rep in zip(groups, reps, strict=True):
            if all((a is None and b is None) or (a is not None and b is not None and np.array_equal(
                    np.asarray(a, dtype=float), np.asarray(b, dtype=float), equal_nan=True))
                   for a, b in zip(arrays, rep, strict=True)):
                group.append(key)
                break
        else:
            groups.append([key])
            reps.append(arrays)
    return groups


def _labels_overlap(axis: Any, renderer: Any, pad: float) -> bool:
    """True when two neighbouring tick labels of ``axis`` are closer than ``pad`` pixels."""
    boxes = [t.get_window_extent(renderer) for t in axis.get_majorticklabels()
             if t.get_text()]
    if axis.axis_name == "x":
        spans = sorted((b.x0, b.x1) for b in boxes)
    else:
        spans = sorted((b.y0, b.y1) for b in boxes)
    return any(nxt[0] < prev[1] + pad for prev, nxt in zip(spans, spans[1:], strict=False))


def _declutter_ticks(fig: Figure, axes: Iterable[Axes]) -> None:
    """Use fewer ticks on any axis whose tick labels overlap (long labels, narrow panels).

    The figure is laid out once (as when saved at its size), then each axis with overlapping
    labels gets a locator with fewer bins until its labels are at least half the font
    size apart; the limits are not changed.
    """
    from matplotlib.ticker import MaxNLocator

    fig.draw_without_rendering()
    renderer = fig.canvas.get_renderer()
    for a in axes:
        for axis in (a.xaxis, a.yaxis):
            if axis.get_scale() != "linear":
                continue
            labels = [t for t in axis.get_majorticklabels() if t.get_text()]
            if not labels:
                continue
            pad = 0.5 * labels[0].get_fontsize() * fig.dpi / 72.0  # about one space
            nbins = len(labels)
            while nbins > 2 and _labels_overlap(axis, renderer, pad):
                nbins -= 1
                axis.set_major_locator(MaxNLocator(nbins=nbins, steps=[1, 2, 2.5, 5, 10]))


def _uniform(t: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Resample onto a uniform grid (same count) when ``t`` is not uniform, for the FFT."""
    steps = np.diff(t)
    if steps.size and np.max(np.abs(steps - steps.mean())) <= 1e-6 * abs(steps.mean()):
        return t, x
    tu = np.linspace(t[0], t[-1], t.size)
    return tu, np.interp(tu, t, x)


# --------------------------------------------------------------------------------------------
# time-domain responses
# --------------------------------------------------------------------------------------------
def plot_time_panels(
    t: Any,
    series: Mapping[str, tuple[Any, Any]],
    period: float,
    t_start: float,
    *,
    ax: Any = None,
    window: Any = "hann",
    fmax: float | None = None,
    normalize_frequency: bool = False,
    show_transient: bool = False,
    time_units: str | None = None,
    x_name: str = "displacement",
    v_name: str = "velocity",
    units: tuple[str | None, str | None] = (None, None),
    figsize: tuple[float, float] | None = None,
    time_window: float | None = None,
) -> tuple[Figure, np.ndarray]:
    """Time history, velocity, phase portrait, spectrum and Poincaré section per series.

    One row per series (e.g. driving and driven gear), five panels per row, lettered
    (a), (b), ... row by row, as in the classic gear-dynamics response figure.

    Parameters
    ----------
    t : array or None
        Time grid shared by all series; ``None`` if the series are DataArrays with a time
        coordinate.
    series : dict
        ``label -> (x, v)``: displacement and velocity histories (1-D arrays or DataArrays).
    period : float
        Excitation period (for the Poincaré section and the normalised frequency axis).
    t_start : float
        End of the transient; phase portrait, spectrum and Poincaré section use ``t >=
        t_start``.
    ax : array of Axes, optional
        Axes of shape ``(len(series), 5)`` to draw into.
    window : str
        Spectrum window (see :func:`gearuq.signal.amplitude_spectrum`).
    fmax : float, optional
        Upper frequency limit of the spectrum panels (in plotted units).
    normalize_frequency : bool
        Plot frequency as a multiple of the excitation frequency ``1 / period``.
    show_transient : bool
        Show the whole record in the time panels with the transient shaded; by default only
        the steady state is shown.
    time_units : str, optional
        Time units for labels (default from the time coordinate's attrs).
    x_name, v_name : str
        Quantity names used when the series carry no attrs.
    units : (str, str)
        Units of x and v used when the series carry no attrs.
    figsize : (float, float), optional
        Figure size; default ``(16, 3 * n_series)``.
    time_window : float, optional
        Show only the last ``time_window`` time units in the time-history and velocity panels
        (a long steady record otherwise plots as a solid band); the other panels use the
        whole steady state.

    Returns
    -------
    fig : Figure
    axes : ndarray of Axes, shape ``(n_series, 5)``
    """
    if not series:
        raise ValueError("series is empty")
    n_rows = len(series)
    if ax is None:
        fig = _new_figure(figsize or (16.0, 3.0 * n_rows))
        axes = np.asarray(fig.subplots(n_rows, 5, squeeze=False))
    else:
        axes = np.asarray(ax, dtype=object).reshape(n_rows, 5)
        fig = axes[0, 0].figure
    if t is None:  # share the time coordinate of the first DataArray series
        for x, _ in series.values():
            if isinstance(x, xr.DataArray) and "time" in x.coords:
                t = x["time"]
                break
    letters = "abcdefghijklmnopqrstuvwxyz"
    f_exc = 1.0 / period
    for r, (label, (x, v)) in enumerate(series.items()):
        own = isinstance(x, xr.DataArray) and "time" in x.coords
        tt, tu = _time_of(x, None if own else t)
        tu = time_units or tu
        xv, vv = _values(x), _values(v)
        if xv.shape != tt.shape or vv.shape != tt.shape:
            raise ValueError(f"series {label!r}: x, v and t must be 1-D of equal length")
        xl = _label(x, x_name, units[0])
        vl = _label(v, v_name, units[1])
        tcoord = x["time"] if own else t
        tname = "time"
        if isinstance(tcoord, xr.DataArray):
            tname = tcoord.attrs.get("long_name", "time")
        tl = _label(None, tname, tu)
        steady = tt >= t_start
        a_x, a_v, a_ph, a_sp, a_po = axes[r]
        shown = slice(None) if show_transient else steady
        if time_window is not None:
            shown = tt >= max(tt[-1] - time_window, tt[0] if show_transient else t_start)
        for a, y, yl in ((a_x, xv, xl), (a_v, vv, vl)):
            a.plot(tt[shown], y[shown], lw=0.7)
            if show_transient and time_window is None:
                a.axvspan(tt[0], t_start, color="0.9", zorder=0, label="transient")
            a.set_xlabel(tl)
            a.set_ylabel(yl)
        a_ph.plot(xv[steady], vv[steady], lw=0.5)
        a_ph.ticklabel_format(useOffset=False)  # read values directly, as in (a) and the section
        a_ph.set_xlabel(xl)
        a_ph.set_ylabel(vl)
        ts, xs = _uniform(tt[steady], xv[steady])
        freq, amp = sig.amplitude_spectrum(xs, ts, window=window)
        fplot = freq / f_exc if normalize_frequency else freq
        a_sp.plot(fplot, amp, lw=0.8)
        if normalize_frequency:
            a_sp.set_xlabel("frequency / excitation frequency [1]")
        else:
            a_sp.set_xlabel(_frequency_label(tu))
        x_units = x.attrs.get("units", units[0]) if isinstance(x, xr.DataArray) else units[0]
        a_sp.set_ylabel(_label(None, "amplitude", x_units))
        if fmax is not None:
            a_sp.set_xlim(0, fmax)
        sec = sig.poincare_section(tt, xv, vv, period=period, t_start=t_start)
        a_po.plot(sec.x, sec.v, "o", ms=2.5)
        a_po.ticklabel_format(useOffset=False)
        for pts, scale, setter in ((sec.x, sec.scale[0], a_po.set_xlim),
                                   (sec.v, sec.scale[1], a_po.set_ylim)):
            if len(pts) and np.ptp(pts) < 1e-3 * scale:  # (nearly) one point: show it
                centre = float(np.mean(pts))  # against 10 % of the signal range
                setter(centre - 0.05 * scale, centre + 0.05 * scale)
        a_po.set_xlabel(xl)
        a_po.set_ylabel(vl)
        titles = ("time history", "velocity", "phase portrait", "amplitude spectrum",
                  "Poincaré section")
        for c, (a, title) in enumerate(zip(axes[r], titles, strict=True)):
            a.set_title(f"({letters[(r * 5 + c) % 26]}) {label}: {title}", fontsize=9)
    _declutter_ticks(fig, axes.ravel())
    return fig, axes


# --------------------------------------------------------------------------------------------
# reliability
# --------------------------------------------------------------------------------------------
def plot_reliability_curves(
    rel_ds: xr.Dataset,
    *,
    quantity: str = "r",
    log: bool | None = None,
    modes: Iterable[Any] | None = None,
    band: bool = True,
    ax: Axes | None = None,
) -> tuple[Figure, Axes]:
    """Reliability ``R(t)``, failure probability ``pf(t)`` or index ``beta(t)`` per mode.

    Parameters
    ----------
    rel_ds : Dataset
        Dims ``mode`` and ``time``; variables ``r``, ``pf``, ``pf_lower``, ``pf_upper``,
        ``beta`` (as produced by :func:`gearuq.reliability`). A dataset without ``mode`` is
        drawn as one curve.
    quantity : {"r", "pf", "beta"}
        What to draw. Bands: ``pf`` uses ``[pf_lower, pf_upper]``; ``r`` uses
        ``[1 - pf_upper, 1 - pf_lower]``; ``beta`` uses ``[-Phi^-1(pf_upper),
        -Phi^-1(pf_lower)]``.
    log : bool, optional
        Log y axis; default True for ``pf``. Zero probabilities are left out of a log plot
        (band edges at zero are drawn at the plot's lower limit).
    modes : iterable, optional
        Subset of ``mode`` labels to draw.
    band : bool
        Shade the confidence band when the bounds are present.
    ax : Axes, optional
        Axes to draw into.

    Returns
    -------
    fig, ax

    Notes
    -----
    So that nothing the figure promises is hidden:

    * modes whose curves (value and band) are identical are drawn once, labelled with all
      their names (``"x_p = y_p"``): drawn one over the other, only the last would be seen;
    * an instant with failures between two without any (a spike one sample wide, where a
      band is only a sliver) is marked with a dot and its interval drawn as a vertical bar;
    * the band has its own legend entry naming the interval; where the band is narrower
      than the line it is hidden by it, and the entry says below which width that happens;
    * on a log ``pf`` axis an estimate of zero cannot be drawn: the upper bound at the
      instants without failures is drawn once, as a hatched strip from the bottom of the
      axis (labelled), instead of one band per mode stacked on each other.
    """
    if quantity not in ("r", "pf", "beta"):
        raise ValueError(f"quantity must be 'r', 'pf' or 'beta', got {quantity!r}")
    if quantity not in rel_ds:
        raise ValueError(f"rel_ds has no variable {quantity!r} (has {list(rel_ds.data_vars)})")
    log = (quantity == "pf") if log is None else log
    fig, ax = _fig_ax(ax)
    ds = rel_ds if "mode" in rel_ds.dims else rel_ds.expand_dims(mode=[quantity])
    if modes is not None:
        ds = ds.sel(mode=list(modes))
    has_band = band and "pf_lower" in ds and "pf_upper" in ds
    tcoord = ds["time"] if "time" in ds.coords else None
    curves: dict[str, tuple] = {}
    for m in ds["mode"].values:
        one = ds.sel(mode=m)
        tt = _values(one["time"]) if tcoord is not None else np.arange(one[quantity].size)
        y = _values(one[quantity])
        pf = _values(one["pf"]) if "pf" in one else None
        lo = hi = None
        if has_band:
            pl, pu = _values(one["pf_lower"]), _values(one["pf_upper"])
            if quantity == "pf":
                lo, hi = pl, pu
            elif quantity == "r":
                lo, hi = 1.0 - pu, 1.0 - pl
            else:
                with np.errstate(divide="ignore"):
                    lo, hi = -norm.ppf(pu), -norm.ppf(pl)
        curves[str(m)] = (tt, y, lo, hi, pf)
    groups = _identical_groups({m: c[1:4] for m, c in curves.items()})
    n_comp = sum("system" not in g for g in groups)
    # distinct colours for every curve (tab10 repeats after ten); the series system black
    cmap = matplotlib.colormaps["tab10" if n_comp <= 10 else "tab20"]
    positives: list[float] = []
    drawn = []
    k = 0
    for group in groups:
        tt, y, lo, hi, pf = curves[group[0]]
        if "system" in group:
            colour = "k"
        else:
            colour, k = cmap(k % cmap.N), k + 1
        spike = np.zeros(y.shape, dtype=bool)
        if pf is not None:
            fail = np.nan_to_num(pf) > 0
            spike = fail & ~np.r_[False, fail[:-1]] & ~np.r_[fail[1:], False]
        if log:
            for arr in (y, lo, hi):
                if arr is not None:
                    positives.extend(arr[np.isfinite(arr) & (arr > 0)].tolist())
            y = np.where(y > 0, y, np.nan)
        finite = np.isfinite(y)
        isolated = finite & ~np.r_[False, finite[:-1]] & ~np.r_[finite[1:], False]
        marks = np.flatnonzero((spike & finite) | isolated)
        label = " = ".join(group)
        if not np.any(finite):
            label += " (pf = 0 throughout)" if quantity != "r" else " (no finite value)"
        # the system's markers are open rings: a component with nearly the same value
        # (the one that dominates the system) stays visible inside
        (line,) = ax.plot(tt, y, lw=1.8 if "system" in group else 1.2, color=colour,
                          label=label, marker="o" if marks.size else None,
                          ms=5.0 if "system" in group else 3.5,
                          mfc="none" if "system" in group else colour,
                          markevery=marks.tolist() if marks.size else None)
        drawn.append((line, tt, lo, hi, marks))
    floor = min(positives) / 10.0 if (log and positives) else None
    level = rel_ds.attrs.get("confidence_level", rel_ds.attrs.get("confidence"))
    kind = str(rel_ds.attrs.get("interval", "confidence")).capitalize()
    level_txt = f"{float(level):.0%}".replace("%", " %") if level is not None else ""
    zero_hi: np.ndarray | None = None
    widths = []
    for line, tt, lo, hi, marks in drawn:
        if lo is None:
            continue
        lo = np.where(np.isfinite(lo), lo, np.nan)
        hi = np.where(np.isfinite(hi), hi, np.nan)
        if log and quantity == "pf":
            none = ~(lo > 0)  # no failure observed: the interval is [0, upper]
            zh = np.where(none, hi, np.nan)
            zero_hi = zh if zero_hi is None else np.fmax(zero_hi, zh)
            lo, hi = np.where(none, np.nan, lo), np.where(none, np.nan, hi)
        elif log and floor is not None:
            lo = np.where(lo > 0, lo, floor)
            hi = np.where(hi > 0, hi, floor)
        ax.fill_between(tt, lo, hi, color=line.get_color(), alpha=0.2, lw=0)
        if marks.size:  # above the lines, so a bar is not hidden by another curve
            ax.vlines(tt[marks], lo[marks], hi[marks], color=line.get_color(), lw=2.5,
                      alpha=0.6, zorder=3)
        widths.append((line.get_linewidth(), np.log10(hi / lo) if log else hi - lo))
    if log:
        ax.set_yscale("log")
        if floor is not None:
            ax.set_ylim(bottom=floor)
    if zero_hi is not None and np.any(np.isfinite(zero_hi)) and floor is not None:
        top = float(np.nanmax(zero_hi))
        ax.fill_between(drawn[0][1], floor, zero_hi, facecolor="none", edgecolor="0.55",
                        hatch="///", lw=0,
                        label=f"no failure observed: pf below {top:.1e} "
                              f"({level_txt} upper bound)")
    if has_band:
        ax.fill_between([], [], [], color="0.5", alpha=0.3, lw=0,
                        label=_band_label(fig, ax, widths, log, f"{level_txt} {kind} band"))
    names = {
        "r": "reliability R",
        "pf": "failure probability pf",
        "beta": "reliability index beta = Phi^-1(R)",
    }
    ax.set_ylabel(names[quantity])
    ax.set_xlabel(_label(tcoord, "time") if tcoord is not None else "index")
    title = names[quantity]
    if has_band:
        title += " (band: " + (f"{float(level):.0%} interval)" if level is not None
                               else "confidence interval)")
    ax.set_title(title, fontsize=10)
    ax.legend(title="mode", fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    return fig, ax


def _band_label(fig: Figure, ax: Axes, widths: list[tuple[float, np.ndarray]], log: bool,
                name: str) -> str:
    """Legend text of a band; says below which width the line hides it, if it does anywhere.

    The line's width in data units follows from the laid-out axes height and its y limits
    (in decades on a log axis).
    """
    fig.draw_without_rendering()
    height_pt = ax.get_window_extent().height * 72.0 / fig.dpi
    y0, y1 = ax.get_ylim()
    span = np.log10(y1 / y0) if log else y1 - y0
    hidden = []
    for lw, w in widths:
        thr = lw / max(height_pt, 1e-9) * abs(span)
        w = w[np.isfinite(w)]
        if np.any((w > 0) & (w < thr)):
            hidden.append(thr)
    if not hidden:
        return name.strip()
    thr = max(hidden)
    what = f"upper/lower < {10 ** thr:.3g}" if log else f"narrower than {thr:.1g}"
    return f"{name.strip()} (hidden by the line where {what})"


# --------------------------------------------------------------------------------------------
# distribution fits
# --------------------------------------------------------------------------------------------
class _DictFits:
    """Adapter giving a ``name -> frozen distribution`` mapping the fit-result interface."""

    def __init__(self, mapping: Mapping[str, Any]) -> None:
        self._m = dict(mapping)
        self.ranking = list(self._m)

    def frozen(self, name: str) -> Any:
        return self._m[name]


def plot_fit(
    samples: Any,
    fits: Any,
    *,
    top: int = 3,
    bins: Any = "auto",
    ax: Axes | None = None,
    xlabel: str | None = None,
) -> tuple[Figure, Axes]:
    """Density histogram of samples with the fitted pdfs of the best candidates.

    Parameters
    ----------
    samples : array or DataArray
        Response samples (NaN ignored); label and units from DataArray attrs.
    fits : fit result or dict
        Object with ``.ranking`` (names, best first) and ``.frozen(name)`` returning a scipy
        frozen distribution (as :func:`gearuq.fit_distributions` gives), or a dict
        ``name -> frozen distribution`` (ranked in dict order).
    top : int
        Number of candidates drawn.
    bins : int, str or array
        Histogram bins (numpy rules).
    ax : Axes, optional
        Axes to draw into.
    xlabel : str, optional
        Axis label override.

    Returns
    -------
    fig, ax
    """
    if isinstance(fits, Mapping):
        fits = _DictFits(fits)
    data = _values(samples).ravel()
    data = data[np.isfinite(data)]
    if data.size == 0:
        raise ValueError("no finite samples to plot")
    fig, ax = _fig_ax(ax)
    # one filled step outline instead of a Rectangle per bin: same picture, ~10x faster to draw
    ax.hist(data, bins=bins, density=True, histtype="stepfilled", facecolor="0.8",
            edgecolor="0.5", lw=0.5, label=f"samples (n={data.size})")
    span = np.ptp(data) or max(abs(float(data[0])), 1.0)
    grid = np.linspace(data.min() - 0.1 * span, data.max() + 0.1 * span, 400)
    for rank, entry in enumerate(list(fits.ranking)[:top], start=1):
        name = entry if isinstance(entry, str) else getattr(entry, "name", str(entry))
        dist = fits.frozen(name)
        pdf = dist.pdf(grid) if hasattr(dist, "pdf") else dist.pmf(np.round(grid))
        ax.plot(grid, pdf, lw=1.5 if rank == 1 else 1.0, ls="-" if rank == 1 else "--",
                label=f"{rank}. {name}")
    ax.set_xlabel(xlabel or _label(samples, "response"))
    units = samples.attrs.get("units") if isinstance(samples, xr.DataArray) else None
    ax.set_ylabel("probability density" + (f" [1/({units})]" if units not in (None, "", "1")
                                           else ""))
    ax.legend(fontsize=8)
    return fig, ax


# --------------------------------------------------------------------------------------------
# benchmarks
# --------------------------------------------------------------------------------------------
def plot_work_precision(
    table: Any,
    *,
    ax: Axes | None = None,
    x: str = "time_per_sample",
    y: str = "error",
    annotate: bool = True,
) -> tuple[Figure, Axes]:
    """Work-precision diagram: error against time per sample, one line per method.

    Parameters
    ----------
    table : list of dict or DataFrame
        Rows with keys ``method``, ``rtol``, ``time_per_sample`` [s] and ``error``
        (anything with ``to_dict("records")`` is accepted too).
    ax : Axes, optional
        Axes to draw into.
    x, y : str
        Column names for the axes.
    annotate : bool
        Write each row's ``rtol`` next to its point.

    Returns
    -------
    fig, ax

    Notes
    -----
    Rows with a non-positive or non-finite time or error cannot be shown on log axes and are
    left out (their count is given in the title).
    """
    rows: Sequence[Mapping[str, Any]]
    rows = table.to_dict("records") if hasattr(table, "to_dict") else list(table)
    fig, ax = _fig_ax(ax)
    methods: dict[str, list[tuple[float, float, Any]]] = {}
    skipped = 0
    for row in rows:
        xv = float(row.get(x, np.nan))
        yv = float(row.get(y, np.nan))
        if not (np.isfinite(xv) and np.isfinite(yv) and xv > 0 and yv > 0):
            skipped += 1
            continue
        methods.setdefault(str(row.get("method", "?")), []).append((xv, yv, row.get("rtol")))
    for name, pts in methods.items():
        pts.sort(key=lambda p: p[0])
        xs = [p[0] for p in pts]
        ys = [p[1] for p in pts]
        (line,) = ax.plot(xs, ys, "o-", ms=4, lw=1.0, label=name)
        if annotate:
            for xv, yv, tol in pts:
                if tol is not None:
                    ax.annotate(f"{float(tol):.0e}", (xv, yv), textcoords="offset points",
                                xytext=(3, 3), fontsize=6, color=line.get_color())
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("time per sample [s]" if x == "time_per_sample" else x)
    ax.set_ylabel(y)
    title = "work-precision"
    if skipped:
        title += f" ({skipped} row(s) with non-positive values not shown)"
    ax.set_title(title, fontsize=10)
    if methods:
        ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    return fig, ax


# --------------------------------------------------------------------------------------------
# output
# --------------------------------------------------------------------------------------------
def save_figure(fig: Any, path: str | Path, *, dpi: int = 120,
                bbox_inches: str | None = None) -> Path:
    """Save a figure as PNG (parent directories created) and close it.

    Parameters
    ----------
    fig : Figure, Axes or (Figure, ...) tuple
        What the plot helpers return.
    path : str or Path
        Output file (``.png`` is appended when there is no suffix).
    dpi : int
        Resolution.
    bbox_inches : str, optional
        ``"tight"`` crops the saved image to what is drawn (a long title, a legend outside
        the axes); as matplotlib's ``savefig``.

    Returns
    -------
    Path
        The written file.

    Notes
    -----
    Inside :func:`quick_run` every figure saved is stamped "quick: ..., not a result".
    """
    if isinstance(fig, tuple):
        fig = fig[0]
    if isinstance(fig, Axes):
        fig = fig.figure
    out = Path(path)
    if not out.suffix:
        out = out.with_suffix(".png")
    out.parent.mkdir(parents=True, exist_ok=True)
    if _QUICK_MARK and not getattr(fig, "_gearuq_quick_mark", False):
        # across the middle, faint: it cannot be cropped away or hide under a legend
        fig.text(0.5, 0.5, _QUICK_MARK, ha="center", va="center", rotation=20,
                 fontsize=max(9.0, min(22.0, 2.2 * fig.get_figwidth())), color="crimson",
                 alpha=0.35, zorder=1000, wrap=True)
        fig._gearuq_quick_mark = True
    # the mark also goes into the PNG's text chunks, where a script (or a test) reads it
    # without looking at pixels
    metadata = {QUICK_MARK_KEY: _QUICK_MARK} if _QUICK_MARK and out.suffix == ".png" else None
    fig.savefig(out, dpi=dpi, bbox_inches=bbox_inches, metadata=metadata)
    plt = sys.modules.get("matplotlib.pyplot")
    if plt is not None:
        plt.close(fig)
    return out


@contextmanager
def quick_run(quick: bool, runs: int | str, left_out: str) -> Iterator[str]:
    """Mark a quick run: on screen now, and on every figure :func:`save_figure` writes.

    The one way every study says its quick mode is not a result: it prints ``quick: N runs,
    not a result; left out: ...`` when the block starts and stamps the same mark across each
    figure saved inside the block.

    Parameters
    ----------
    quick : bool
        Whether the run is quick; when False nothing is printed or stamped.
    runs : int or str
        What the quick run computed: a number of model runs, or words for it ("8 samples per
        grade at 6 speeds").
    left_out : str
        What the quick run left out, compared with the full study, in words.

    Yields
    ------
    str
        The mark (``""`` when not quick), for the study's own text and markdown files.

    Raises
    ------
    ValueError
        If ``runs`` is not a positive count or a non-empty text, or ``left_out`` is empty.
    """
    global _QUICK_MARK
    if not quick:
        yield ""
        return
    if isinstance(runs, bool) or not (isinstance(runs, str) and runs.strip()
                                      or isinstance(runs, (int, np.integer)) and runs > 0):
        raise ValueError(f"runs: expected a positive number of runs or words for them, got "
                         f"{runs!r}")
    if not isinstance(left_out, str) or not left_out.strip():
        raise ValueError("left_out: say in words what the quick run leaves out")
    what = f"{runs} runs" if isinstance(runs, (int, np.integer)) else runs.strip()
    mark = f"quick: {what}, not a result"
    print(f"{mark}; left out: {left_out.strip()}", flush=True)
    previous, _QUICK_MARK = _QUICK_MARK, mark
    try:
        yield mark
    finally:
        _QUICK_MARK = previous


def quick_mode(runs: int | str | Callable[[Mapping[str, Any]], int | str],
               left_out: str | Callable[[Mapping[str, Any]], str]
               ) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """Decorate a study's ``run(out, quick=False, ...)`` so a quick call runs in :func:`quick_run`.

    Parameters
    ----------
    runs : int, str or callable
        What the quick run computes (see :func:`quick_run`); a callable receives the call's
        arguments (defaults applied) by name and returns it, so a setting that overrides the
        quick size is reported as run.
    left_out : str or callable
        What the quick run leaves out, in words; a callable receives the call's arguments
        like ``runs`` (so that what it says follows the settings given).

    Returns
    -------
    callable
        The decorator; the decorated function keeps the signature and docstring of ``run``
        (``gearuq study NAME --help`` reads them).
    """
    def decorate(run: Callable[..., Any]) -> Callable[..., Any]:
        signature = inspect.signature(run)
        if "quick" not in signature.parameters:
            raise ValueError(f"quick_mode: {run.__qualname__} has no 'quick' parameter")

        @functools.wraps(run)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            bound = signature.bind(*args, **kwargs)
            bound.apply_defaults()
            quick = bool(bound.arguments["quick"])
            what = runs(bound.arguments) if callable(runs) and quick else runs
            left = left_out(bound.arguments) if callable(left_out) and quick else left_out
            with quick_run(quick, what, left):
                return run(*args, **kwargs)

        defaults = {k: p.default for k, p in signature.parameters.items()
                    if p.default is not p.empty}
        wrapper.quick_left_out = (  # type: ignore[attr-defined]
            left_out(defaults) if callable(left_out) else left_out)
        return wrapper

    return decorate
