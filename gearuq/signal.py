"""Signal processing for gear-dynamics responses: spectra, RMS, Poincaré sections, sidebands.

Every function works on numpy arrays along the **last axis** (time) and on
:class:`xarray.DataArray` objects with a ``time`` dimension; other dimensions such as
``sample`` or ``dof`` are kept, so a whole Monte Carlo batch is processed in one call.

Conventions
-----------
* Frequencies are in **cycles per unit of the time axis**. With ``t`` in seconds that is Hz;
  with a nondimensional time ``tau`` it is cycles per unit ``tau`` (multiply by ``2*pi`` for
  the nondimensional angular frequency, or by the time scale's inverse to get Hz).
* Amplitude spectra are **peak** amplitudes: a sinusoid ``A sin(2 pi f t)`` whose frequency
  falls on a bin reads ``A`` (one-sided), whatever the window, because the FFT is divided by
  the window's coherent gain ``sum(w)``.
* NaN inputs (failed samples) propagate to NaN results; nothing is silently dropped.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr
from scipy import signal as _sps
from scipy.interpolate import CubicSpline
from scipy.spatial import cKDTree
from scipy.spatial.distance import pdist
from scipy.special import ndtr

__all__ = [
    "FLATTOP_WINDOWS",
    "PoincareSection",
    "ResponseClass",
    "amplitude_spectrum",
    "classify_response",
    "dominant_frequencies",
    "get_window",
    "peak_to_peak",
    "phase_portrait",
    "poincare_section",
    "rms",
    "sidebands",
    "steady_state",
]

ArrayLike = np.ndarray | Sequence[float] | float
Signal = np.ndarray | xr.DataArray

#: Flat-top windows of Heinzel, Rüdiger & Schilling (2002), "Spectrum and spectral density
#: estimation by the Discrete Fourier transform (DFT)", Table/Sec. D: cosine-sum coefficients
#: ``w[j] = sum_k (-1)^k c_k cos(2 pi k j / N)``. The maximum amplitude (scalloping) error for
#: a tone anywhere between two bins is about 5e-4 (HFT95), 4.5e-4 (HFT90D), 3.3e-4 (HFT116D)
#: and 2.5e-4 (HFT144D); scipy's ``"flattop"`` reaches 1.1e-3. ``window="flattop"`` selects
#: HFT116D (sidelobes -116 dB, noise bandwidth 4.2 bins).
FLATTOP_WINDOWS: dict[str, tuple[float, ...]] = {
    "hft95": (1.0, 1.9383379, 1.3045202, 0.4028270, 0.0350665),
    "hft90d": (1.0, 1.942604, 1.340318, 0.440811, 0.043097),
    "hft116d": (1.0, 1.9575375, 1.4780705, 0.6367431, 0.1228389, 0.0066288),
    "hft144d": (1.0, 1.96760033, 1.57983607, 0.81123644, 0.22583558, 0.02773848, 0.00090360),
}
_RECT_NAMES = {"rect", "rectangular", "boxcar", "none", "uniform"}


# --------------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------------
def _time_last(x: xr.DataArray, dim: str) -> xr.DataArray:
    if dim not in x.dims:
        raise ValueError(f"DataArray has no {dim!r} dimension (dims: {x.dims}); pass dim=")
    return x.transpose(..., dim)


def _other_coords(x: xr.DataArray, dim: str) -> dict[str, xr.DataArray]:
    return {k: v for k, v in x.coords.items() if dim not in v.dims}


def _time_grid(x: Signal, t: Any, dim: str) -> np.ndarray:
    """Return the 1-D time grid of ``x`` (from ``t`` or the DataArray coordinate)."""
    n = x.shape[-1]
    if t is None:
        if isinstance(x, xr.DataArray) and dim in x.coords:
            t = x[dim].values
        else:
            raise ValueError("give the time grid t (or a DataArray with a time coordinate)")
    if isinstance(t, xr.DataArray):
        t = t.values
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or t.size != n:
        raise ValueError(f"t must be 1-D with {n} entries (the time axis of x), got {t.shape}")
    if n > 1 and not np.all(np.diff(t) > 0):
        raise ValueError("t must be strictly increasing")
    return t


def _uniform_step(t: Any, n: int) -> float:
    """Return the sample interval from a scalar ``dt`` or a uniform time grid."""
    ta = np.asarray(t.values if isinstance(t, xr.DataArray) else t, dtype=float)
    if ta.ndim == 0:
        dt = float(ta)
    else:
        if ta.ndim != 1 or ta.size != n:
            raise ValueError(f"t must be a scalar dt or 1-D with {n} entries, got {ta.shape}")
        steps = np.diff(ta)
        dt = (ta[-1] - ta[0]) / (n - 1)
        if np.max(np.abs(steps - dt)) > 1e-6 * abs(dt):
            raise ValueError(
                "the FFT needs a uniform time grid; this t has steps from "
                f"{steps.min():.6g} to {steps.max():.6g}: resample first (e.g. np.interp, "
                "or ask the model for equally spaced output instants)"
            )
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"the sample interval must be positive and finite, got {dt!r}")
    return float(dt)


def _frequency_attrs(time_attrs: Mapping[str, Any]) -> dict[str, str]:
    units = str(time_attrs.get("units", "")).strip()
    if units in ("s", "second", "seconds"):
        return {"units": "Hz", "long_name": "frequency"}
    if units in ("1", "-", "dimensionless"):
        return {
            "units": "1",
            "long_name": "frequency (cycles per unit nondimensional time)",
        }
    if not units:  # time units unknown: say what the number means, claim no unit
        return {"long_name": "frequency (cycles per unit of the time axis)"}
    return {"units": f"1/{units}", "long_name": f"frequency (cycles per {units})"}


def get_window(window: Any, n: int) -> np.ndarray:
    """Return a periodic (DFT-even) analysis window of length ``n``.

    Parameters
    ----------
    window : str, tuple, array or None
        ``None``/``"rect"``/``"boxcar"`` for no window; ``"flattop"`` (Heinzel HFT116D) or one
        of :data:`FLATTOP_WINDOWS`; an array of length ``n``; anything else is passed to
        :func:`scipy.signal.get_window` (``"hann"``, ``("kaiser", 8.0)``, ...).
    n : int
        Number of samples.

    Returns
    -------
    ndarray
        The window, shape ``(n,)``.
    """
    if window is None:
        return np.ones(n)
    if isinstance(window, str):
        key = window.lower()
        if key in _RECT_NAMES:
            return np.ones(n)
        if key == "flattop":
            key = "hft116d"
        if key in FLATTOP_WINDOWS:
            return _sps.windows.general_cosine(n, FLATTOP_WINDOWS[key], sym=False)
        return _sps.get_window(window, n, fftbins=True)
    if isinstance(window, tuple):
        return _sps.get_window(window, n, fftbins=True)
    w = np.asarray(window, dtype=float)
    if w.shape != (n,):
        raise ValueError(f"window array must have shape ({n},), got {w.shape}")
    return w


def _detrend(x: np.ndarray, detrend: Any) -> np.ndarray:
    if detrend in (None, False, "none"):
        return x
    if detrend in ("mean", "constant"):
        return x - x.mean(axis=-1, keepdims=True)
    if detrend == "linear":
        return _sps.detrend(x, axis=-1, type="linear")
    raise ValueError(f"detrend must be 'mean', 'linear' or None, got {detrend!r}")


# --------------------------------------------------------------------------------------------
# spectra
# --------------------------------------------------------------------------------------------
def _spectrum_array(
    x: np.ndarray,
    dt: float,
    window: Any,
    detrend: Any,
    onesided: bool,
    pad_to: int | None,
) -> tuple[np.ndarray, np.ndarray]:
    n = x.shape[-1]
    if n < 2:
        raise ValueError("amplitude_spectrum needs at least 2 samples along time")
    nfft = n if pad_to is None else int(pad_to)
    if nfft < n:
        raise ValueError(f"pad_to={pad_to} is shorter than the signal ({n} samples)")
    w = get_window(window, n)
    gain = float(w.sum())
    if gain == 0.0:
        raise ValueError("the window sums to zero; its coherent gain is undefined")
    xd = _detrend(x, detrend) * w
    if onesided:
        if np.iscomplexobj(x):
            raise ValueError("a complex signal needs onesided=False")
        amp = np.abs(np.fft.rfft(xd, n=nfft, axis=-1)) / gain
        # every bin but DC (and Nyquist for even nfft) holds half of the real tone's amplitude
        last = amp.shape[-1] - 1 if nfft % 2 == 0 else amp.shape[-1]
        amp[..., 1:last] *= 2.0
        freq = np.fft.rfftfreq(nfft, dt)
    else:
        amp = np.fft.fftshift(np.abs(np.fft.fft(xd, n=nfft, axis=-1)) / gain, axes=-1)
        freq = np.fft.fftshift(np.fft.fftfreq(nfft, dt))
    return freq, amp


def amplitude_spectrum(
    x: Signal,
    t: Any = None,
    *,
    dt: float | None = None,
    window: Any = "hann",
    detrend: str | None = "mean",
    onesided: bool = True,
    pad_to: int | None = None,
    dim: str = "time",
) -> tuple[Any, Any]:
    """Peak-amplitude spectrum of a uniformly sampled signal.

    The windowed, detrended signal is transformed with the FFT and divided by the window's
    coherent gain ``sum(w)``; one-sided spectra double every bin except DC and Nyquist. A
    sinusoid ``A sin(2 pi f t + phi)`` whose frequency ``f`` falls exactly on a bin therefore
    reads ``A`` with any window, and a constant ``c`` reads ``c`` at DC (with
    ``detrend=None``).

    **Scalloping.** With a window, a tone *between* two bins reads lower: by up to 36 % with
    the rectangular window and 15 % with Hann. Use ``window="flattop"`` (Heinzel HFT116D,
    worst-case error 3.3e-4) when amplitudes of tones at arbitrary frequencies matter, at the
    price of a main lobe about 10 bins wide (close tones need a longer record); zero padding
    (``pad_to``) also reduces scalloping by interpolating the spectrum.

    Parameters
    ----------
    x : ndarray or DataArray
        Signal; time along the last axis (ndarray) or along ``dim`` (DataArray). Other axes
        (``sample``, ``dof``, ...) are kept.
    t : array or float, optional
        Uniform time grid (same length as the time axis) or the sample interval as a scalar.
        Optional for a DataArray with a ``dim`` coordinate.
    dt : float, optional
        Sample interval (alternative to ``t``).
    window : str, tuple, array or None
        Analysis window, see :func:`get_window`. Default ``"hann"``.
    detrend : {"mean", "linear", None}
        Trend removed before windowing. With ``"mean"`` the DC bin holds only what the window
        leaks; use ``None`` to read the mean value at DC.
    onesided : bool
        One-sided spectrum of a real signal (default). ``False`` gives the two-sided,
        ``fftshift``-ed spectrum over negative and positive frequencies, where a real tone
        reads ``A/2`` at ``+f`` and ``-f``.
    pad_to : int, optional
        FFT length with zero padding (>= number of samples): finer frequency grid, same
        resolution; amplitudes keep their calibration.
    dim : str
        Time dimension name for DataArrays.

    Returns
    -------
    freq : ndarray or DataArray
        Frequencies in cycles per unit of ``t`` (Hz for seconds; cycles per unit ``tau`` for a
        nondimensional time ``tau``). For a DataArray input, the ``frequency`` coordinate.
    amplitude : ndarray or DataArray
        Peak amplitudes, shape ``(..., n_freq)``; in the units of ``x``. For a DataArray input
        a DataArray with ``dim`` replaced by ``frequency`` and units in ``attrs``.

    Raises
    ------
    ValueError
        For a non-uniform time grid, fewer than two samples, or a bad window/detrend choice.

    Examples
    --------
    >>> t = np.arange(1000) * 0.001
    >>> f, a = amplitude_spectrum(2.0 * np.sin(2 * np.pi * 50 * t), t)
    >>> round(float(a[np.argmin(abs(f - 50))]), 12)
    2.0
    """
    is_da = isinstance(x, xr.DataArray)
    if is_da:
        da = _time_last(x, dim)
        data = da.values
        time_attrs = dict(da[dim].attrs) if dim in da.coords else {}
    else:
        data = np.asarray(x)
        time_attrs = {}
    n = data.shape[-1]
    if t is None and dt is None:
        if is_da and dim in da.coords:
            t = da[dim].values
        else:
            raise ValueError("give the time grid t or the sample interval dt")
    step = _uniform_step(dt if t is None else t, n)
    freq, amp = _spectrum_array(data, step, window, detrend, onesided, pad_to)
    if not is_da:
        return freq, amp
    fattrs = _frequency_attrs(time_attrs)
    name = da.name if da.name is not None else "signal"
    attrs = {
        "units": da.attrs.get("units", "1"),
        "long_name": f"amplitude spectrum of {da.attrs.get('long_name', name)}",
        "scaling": "peak amplitude (one-sided)" if onesided else "peak amplitude (two-sided)",
        "window": str(window),
        "detrend": str(detrend),
        "sample_interval": step,
        "frequency_resolution": 1.0 / (n * step),
    }
    coords = _other_coords(da, dim)
    coords["frequency"] = ("frequency", freq, fattrs)
    out = xr.DataArray(
        amp, dims=(*da.dims[:-1], "frequency"), coords=coords, attrs=attrs, name=name
    )
    return out["frequency"], out


# --------------------------------------------------------------------------------------------
# scalar measures
# --------------------------------------------------------------------------------------------
def _reduce_dim(x: xr.DataArray, axis: int, dim: str | None) -> str:
    if dim is not None:
        return dim
    return "time" if "time" in x.dims else x.dims[axis]


def rms(x: Signal, axis: int = -1, *, dim: str | None = None, center: bool = False) -> Any:
    """Root mean square ``sqrt(mean(x**2))`` along time.

    Parameters
    ----------
    x : ndarray or DataArray
        Signal; for a DataArray the reduction runs over ``dim`` (default ``"time"`` if
        present, else the dimension at ``axis``).
    axis : int
        Axis for ndarray input.
    dim : str, optional
        Dimension for DataArray input.
    center : bool
        Remove the mean first (the "AC" RMS, i.e. the standard deviation over time). The
        default keeps the mean: ``rms(c + A sin) = sqrt(c**2 + A**2 / 2)``.

    Returns
    -------
    ndarray, float or DataArray
        RMS value(s) in the units of ``x``.
    """
    if isinstance(x, xr.DataArray):
        d = _reduce_dim(x, axis, dim)
        y = x - x.mean(d, skipna=False) if center else x
        out = np.sqrt((y**2).mean(d, skipna=False))
        out.attrs = {
            "units": x.attrs.get("units", "1"),
            "long_name": f"RMS of {x.attrs.get('long_name', x.name or 'signal')}",
        }
        return out
    a = np.asarray(x, dtype=float) if not np.iscomplexobj(x) else np.asarray(x)
    if center:
        a = a - a.mean(axis=axis, keepdims=True)
    return np.sqrt(np.mean(np.abs(a) ** 2, axis=axis))


def peak_to_peak(x: Signal, axis: int = -1, *, dim: str | None = None) -> Any:
    """Peak-to-peak value ``max(x) - min(x)`` along time.

    Parameters
    ----------
    x : ndarray or DataArray
        Signal (see :func:`rms` for the axis/dim rules).
    axis : int
        Axis for ndarray input.
    dim : str, optional
        Dimension for DataArray input.

    Returns
    -------
    ndarray, float or DataArray
        Peak-to-peak value(s) in the units of ``x``; NaN where ``x`` has NaN.
    """
    if isinstance(x, xr.DataArray):
        d = _reduce_dim(x, axis, dim)
        out = x.max(d, skipna=False) - x.min(d, skipna=False)
        out.attrs = {
            "units": x.attrs.get("units", "1"),
            "long_name": f"peak-to-peak of {x.attrs.get('long_name', x.name or 'signal')}",
        }
        return out
    a = np.asarray(x, dtype=float)
    return np.max(a, axis=axis) - np.min(a, axis=axis)


def steady_state(x: Signal, t: Any, t_start: float, *, dim: str = "time") -> Any:
    """Keep the part of a response at and after ``t_start`` (drop the transient).

    Parameters
    ----------
    x : ndarray or DataArray
        Signal, time along the last axis / along ``dim``.
    t : array or None
        Time grid; may be ``None`` for a DataArray with a time coordinate.
    t_start : float
        First instant kept (same units as ``t``).
    dim : str
        Time dimension name for DataArrays.

    Returns
    -------
    (t_ss, x_ss) : tuple of ndarray
        For ndarray input: the kept instants and ``x[..., kept]``.
    DataArray
        For DataArray input: ``x`` restricted along ``dim`` (the time coordinate travels
        with it).

    Raises
    ------
    ValueError
        If no instant is at or after ``t_start``.
    """
    tt = _time_grid(_time_last(x, dim) if isinstance(x, xr.DataArray) else np.asarray(x), t, dim)
    keep = tt >= t_start
    if not keep.any():
        raise ValueError(f"no instant at or after t_start={t_start} (t ends at {tt[-1]:g})")
    if isinstance(x, xr.DataArray):
        return x.isel({dim: np.flatnonzero(keep)})
    return tt[keep], np.asarray(x)[..., keep]


def phase_portrait(
    x: Signal,
    v: Signal | None = None,
    t: Any = None,
    *,
    t_start: float | None = None,
    dim: str = "time",
) -> tuple[Any, Any]:
    """Return the (displacement, velocity) pair of a phase portrait, after the transient.

    Parameters
    ----------
    x : ndarray or DataArray
        Displacement history.
    v : ndarray or DataArray, optional
        Velocity history of the same shape; if omitted it is estimated with
        :func:`numpy.gradient` on ``t`` (second-order differences).
    t : array, optional
        Time grid (needed when ``v`` is omitted or ``t_start`` is given, unless ``x`` is a
        DataArray with a time coordinate).
    t_start : float, optional
        Drop instants before it.
    dim : str
        Time dimension name for DataArrays.

    Returns
    -------
    (x, v) : tuple
        Arrays (or DataArrays) of equal shape, ready for ``ax.plot(x, v)``.
    """
    is_da = isinstance(x, xr.DataArray)
    xa = _time_last(x, dim) if is_da else np.asarray(x, dtype=float)
    if v is None or t_start is not None:
        tt = _time_grid(xa, t, dim)
    if v is None:
        grad = np.gradient(np.asarray(xa, dtype=float), tt, axis=-1)
        if is_da:
            va = xa.copy(data=grad)
            va.attrs = {"long_name": f"d/dt {xa.attrs.get('long_name', xa.name or 'x')}"}
        else:
            va = grad
    else:
        va = _time_last(v, dim) if isinstance(v, xr.DataArray) else np.asarray(v, dtype=float)
        if va.shape != xa.shape:
            raise ValueError(f"x and v must have the same shape, got {xa.shape} and {va.shape}")
    if t_start is not None:
        keep = np.flatnonzero(tt >= t_start)
        if keep.size == 0:
            raise ValueError(f"no instant at or after t_start={t_start}")
        xa = xa.isel({dim: keep}) if is_da else xa[..., keep]
        va = va.isel({dim: keep}) if isinstance(va, xr.DataArray) else va[..., keep]
    return xa, va


# --------------------------------------------------------------------------------------------
# Poincaré sections
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PoincareSection:
    """States sampled once per excitation period.

    Attributes
    ----------
    t : ndarray
        Section instants ``t_k = t_start + phase + k * period``, shape ``(n_points,)``.
    x : ndarray or DataArray
        Displacement at ``t_k``, shape ``(..., n_points)`` (DataArray dim ``crossing``).
    v : ndarray, DataArray or None
        Velocity at ``t_k`` (same shape as ``x``) if it was given.
    period : float
        Sampling period.
    scale : ndarray
        Peak-to-peak of the steady-state signal per column (``x`` and ``v``), shape
        ``(..., n_columns)``: the signal scale :func:`classify_response` uses for its
        relative tolerance.
    """

    t: np.ndarray
    x: Any
    v: Any = None
    period: float = float("nan")
    scale: np.ndarray = field(default_factory=lambda: np.ones(1))

    @property
    def points(self) -> np.ndarray:
        """Section points as an array ``(..., n_points)`` (x only) or ``(..., n_points, 2)``."""
        xv = np.asarray(self.x.values if isinstance(self.x, xr.DataArray) else self.x)
        if self.v is None:
            return xv
        vv = np.asarray(self.v.values if isinstance(self.v, xr.DataArray) else self.v)
        return np.stack([xv, vv], axis=-1)

    def __getitem__(self, index: Any) -> PoincareSection:
        """Select trajectories along the leading (non-crossing) dimensions."""
        if np.ndim(self.x) < 2:
            raise IndexError("this section holds a single trajectory")
        return PoincareSection(
            t=self.t,
            x=self.x[index],
            v=None if self.v is None else self.v[index],
            period=self.period,
            scale=np.asarray(self.scale)[index],
        )

    def __len__(self) -> int:
        return int(self.t.size)


def poincare_section(
    t: Any,
    x: Signal,
    v: Signal | None = None,
    *,
    period: float,
    t_start: float | None = None,
    phase: float = 0.0,
    dim: str = "time",
    min_points_per_period: float = 2.0,
) -> PoincareSection:
    """Stroboscopic Poincaré section: the state once per excitation period after transients.

    The response is interpolated with a cubic spline on its dense time grid at
    ``t_k = t_start + phase + k * period`` (``k = 0, 1, ...`` while ``t_k <= t[-1]``); instants
    that coincide with grid points (to 1e-9 of a step) are taken without interpolation. The
    spline error for a harmonic of period ``T_h`` and amplitude ``a_h`` is at most about
    ``20 * (dt / T_h)**4 * a_h`` (``5/384 (2 pi dt / T_h)**4``): 1e-4 of ``a_h`` at 20 points
    per ``T_h``, 5e-3 at 8. Count the points per period of the highest harmonic that matters
    (mesh-stiffness excitation has strong ones) and keep the error below the ``rtol`` of
    :func:`classify_response`. Fewer than ``min_points_per_period`` (default 2) grid points
    per excitation period raises, fewer than 8 warns. Responses with dead zones (backlash)
    are only piecewise smooth; resolve their switching with a fine grid too, or output the
    response exactly at the section instants (then no interpolation is done).

    Parameters
    ----------
    t : array or None
        Time grid, strictly increasing (may be non-uniform, e.g. adaptive solver output);
        ``None`` for a DataArray ``x`` with a time coordinate.
    x : ndarray or DataArray
        Displacement history, time along the last axis / along ``dim``.
    v : ndarray or DataArray, optional
        Velocity history of the same shape.
    period : float
        Excitation (sampling) period, same units as ``t``; e.g. ``2 * pi / Omega`` for a
        nondimensional mesh frequency ``Omega``.
    t_start : float, optional
        End of the transient; default ``t[0]``.
    phase : float
        Time offset of the section within the period (section plane ``phase / period`` of the
        forcing cycle).
    dim : str
        Time dimension name for DataArrays.
    min_points_per_period : float
        Hard lower limit on ``period / max(dt)`` over the sampled window.

    Returns
    -------
    PoincareSection
        ``t``, ``x`` (and ``v``) at the section instants, the period, and the signal scale
        (peak-to-peak of the steady-state signal) used by :func:`classify_response`.

    Raises
    ------
    ValueError
        If the grid is too coarse for the period, no section instant falls inside the record,
        or the shapes disagree.
    """
    if not (np.isfinite(period) and period > 0):
        raise ValueError(f"period must be positive and finite, got {period!r}")
    is_da = isinstance(x, xr.DataArray)
    xa = _time_last(x, dim) if is_da else np.asarray(x, dtype=float)
    tt = _time_grid(xa, t, dim)
    cols = [np.asarray(xa.values if is_da else xa, dtype=float)]
    if v is not None:
        va = _time_last(v, dim) if isinstance(v, xr.DataArray) else np.asarray(v, dtype=float)
        if va.shape != xa.shape:
            raise ValueError(f"x and v must have the same shape, got {xa.shape} and {va.shape}")
        cols.append(np.asarray(va.values if isinstance(va, xr.DataArray) else va, dtype=float))
    if tt.size < 2:
        raise ValueError("poincare_section needs at least two time instants")
    t0 = tt[0] if t_start is None else float(t_start)
    first = t0 + phase
    k0 = max(0, math.ceil((tt[0] - first) / period - 1e-9))
    k1 = math.floor((tt[-1] - first) / period + 1e-9)
    if k1 < k0:
        raise ValueError(
            f"no section instant t_start + phase + k*period in [{tt[0]:g}, {tt[-1]:g}] "
            f"(t_start={t0:g}, phase={phase:g}, period={period:g})"
        )
    tk = first + period * np.arange(k0, k1 + 1)
    # grid window covering the section instants (with two neighbours each side)
    lo = max(int(np.searchsorted(tt, tk[0], side="right")) - 3, 0)
    win = slice(lo, tt.size)
    tw = tt[win]
    max_dt = float(np.max(np.diff(tw))) if tw.size > 1 else float("inf")
    ppp = period / max_dt
    if ppp < min_points_per_period:
        raise ValueError(
            f"poincare_section: the time grid is too coarse for period={period:g}: only "
            f"{ppp:.3g} grid points per period (largest step {max_dt:.4g}); at least "
            f"{min_points_per_period:g} are required and 20 or more are recommended. Output "
            "the response on a finer time grid."
        )
    if ppp < 8.0:
        warnings.warn(
            f"poincare_section: only {ppp:.3g} grid points per period; cubic interpolation of "
            "the section points is inaccurate (use >= 20 points per period)",
            RuntimeWarning,
            stacklevel=2,
        )
    idx = np.clip(np.searchsorted(tw, tk), 0, tw.size - 1)
    idx_left = np.clip(idx - 1, 0, tw.size - 1)
    nearest = np.where(np.abs(tw[idx_left] - tk) < np.abs(tw[idx] - tk), idx_left, idx)
    on_grid = bool(np.all(np.abs(tw[nearest] - tk) <= 1e-9 * max_dt))
    sampled = []
    for c in cols:
        cw = c[..., win]
        if on_grid:
            sampled.append(cw[..., nearest])
        else:
            sampled.append(CubicSpline(tw, cw, axis=-1, extrapolate=False)(tk))
    steady = tt >= t0
    scale = np.stack([np.ptp(c[..., steady], axis=-1) for c in cols], axis=-1)
    if is_da:
        coords = _other_coords(xa, dim)
        coords["section_time"] = ("crossing", tk, dict(xa[dim].attrs) if dim in xa.coords else {})
        xs = xr.DataArray(
            sampled[0], dims=(*xa.dims[:-1], "crossing"), coords=coords,
            attrs=dict(xa.attrs), name=xa.name,
        )
        vs = None
        if v is not None:
            vattrs = dict(v.attrs) if isinstance(v, xr.DataArray) else {}
            vname = v.name if isinstance(v, xr.DataArray) else None
            vs = xr.DataArray(
                sampled[1], dims=xs.dims, coords=coords, attrs=vattrs, name=vname
            )
        return PoincareSection(t=tk, x=xs, v=vs, period=float(period), scale=scale)
    return PoincareSection(
        t=tk,
        x=sampled[0],
        v=sampled[1] if v is not None else None,
        period=float(period),
        scale=scale,
    )


# --------------------------------------------------------------------------------------------
# response classification
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ResponseClass:
    """Result of :func:`classify_response`.

    Attributes
    ----------
    kind : str
        ``"periodic"`` (period 1), ``"period-n"``, ``"quasi-periodic"``, ``"chaotic"`` or
        ``"undetermined"`` (too few points for the non-periodic test).
    period : int or None
        Number of excitation periods after which the section repeats (1 for periodic).
    confidence : float
        Heuristic score in [0, 1] (not a probability): for periodic kinds the margin of the
        repeat residual below the tolerance times a factor for the number of repeats seen;
        for the others ``2 Phi(|z|) - 1`` with ``z`` the distance of the Lyapunov proxy from
        the threshold in standard errors.
    n_points : int
        Number of section points used.
    tolerance : float
        Repeat tolerance relative to the signal scale (``rtol`` plus ``atol / scale``).
    residual : float
        Smallest repeat residual ``max_k |P[k+n] - P[k]| / scale`` over ``n <= max_period``.
    best_period : int
        The ``n`` attaining ``residual`` (the nearest candidate period even when not periodic).
    distinct_fraction : float
        Fraction of distinct points (clusters at the tolerance) among the section points.
    lyapunov : float
        Largest-Lyapunov-exponent proxy per excitation period (Rosenstein nearest-neighbour
        divergence); NaN when periodic.
    lyapunov_stderr : float
        Rough standard error of ``lyapunov``.
    correlation_dimension : float
        Grassberger-Procaccia correlation-dimension estimate of the (embedded) points: about
        1 for a closed curve (quasi-periodic), non-integer above 1 for a strange attractor;
        NaN when periodic or too few points.
    message : str
        Human-readable explanation.
    """

    kind: str
    period: int | None
    confidence: float
    n_points: int
    tolerance: float
    residual: float
    best_period: int
    distinct_fraction: float
    lyapunov: float = float("nan")
    lyapunov_stderr: float = float("nan")
    correlation_dimension: float = float("nan")
    message: str = ""

    @property
    def label(self) -> str:
        """Short label: ``"periodic"``, ``"period-3"``, ``"quasi-periodic"``, ..."""
        if self.kind == "period-n":
            return f"period-{self.period}"
        return self.kind

    @property
    def is_periodic(self) -> bool:
        """Whether a period ``<= max_period`` was found."""
        return self.kind in ("periodic", "period-n")


def _distinct_fraction(q: np.ndarray, tol: float) -> float:
    """Fraction of points with no *earlier* point within ``tol`` (max-norm).

    A period-n sequence gives ``n / N``; points that never repeat give about 1 (no chaining:
    a dense 1-D cloud is not merged into one cluster).
    """
    n = q.shape[0]
    if n < 2:
        return 1.0
    if tol <= 0:
        return np.unique(q, axis=0).shape[0] / n
    pairs = cKDTree(q).query_pairs(r=tol, p=np.inf, output_type="ndarray")
    if pairs.size == 0:
        return 1.0
    seen_before = np.zeros(n, dtype=bool)
    seen_before[np.max(pairs, axis=1)] = True
    return float(np.count_nonzero(~seen_before)) / n


def _delay_embed(q: np.ndarray, m: int) -> np.ndarray:
    if m <= 1:
        return q
    n = q.shape[0] - m + 1
    return np.concatenate([q[i : i + n] for i in range(m)], axis=1)


def _lyapunov_proxy(y: np.ndarray, steps: int, theiler: int) -> tuple[float, float, int]:
    """Rosenstein et al. (1993) largest-Lyapunov estimate per iteration for map data."""
    n = y.shape[0]
    m = n - steps
    if m < 10:
        return float("nan"), float("nan"), max(m, 0)
    ref = y[:m]
    tree = cKDTree(ref)
    k = min(m, 2 * theiler + 3)
    dist, nb = tree.query(ref, k=k)
    dist = dist.reshape(m, k)
    nb = nb.reshape(m, k)
    ok = np.abs(nb - np.arange(m)[:, None]) > theiler
    has = ok.any(axis=1)
    j = nb[np.arange(m), np.argmax(ok, axis=1)]
    i = np.arange(m)[has]
    j = j[has]
    if i.size < 10:
        return float("nan"), float("nan"), int(i.size)
    floor = 1e-12
    logd = np.empty((steps + 1, i.size))
    for s in range(steps + 1):
        d = np.max(np.abs(y[i + s] - y[j + s]), axis=1)
        logd[s] = np.log(np.maximum(d, floor))
    s_axis = np.arange(steps + 1, dtype=float)
    curve = logd.mean(axis=1)
    slope = float(np.polyfit(s_axis, curve, 1)[0])
    per_pair = (logd[-1] - logd[0]) / steps
    stderr = float(np.std(per_pair, ddof=1) / math.sqrt(per_pair.size))
    return slope, stderr, int(i.size)


def _correlation_dimension(y: np.ndarray, max_points: int = 1500) -> float:
    if y.shape[0] > max_points:
        y = y[:: int(math.ceil(y.shape[0] / max_points))]
    n = y.shape[0]
    if n < 30:
        return float("nan")
    d = pdist(y, metric="chebyshev")
    d = d[d > 0]
    if d.size < 100:
        return float("nan")
    # fraction of pairs from ~5 neighbours per point (below that the scaling is dominated by
    # the discreteness of the set) up to ~10 % of pairs (the size of the set)
    q_lo = max(1e-3, 5.0 / n, 20.0 / d.size)
    q_hi = min(max(0.1, 4.0 * q_lo), 0.3)
    if q_lo >= q_hi:
        return float("nan")
    qs = np.geomspace(q_lo, q_hi, 8)
    rs = np.quantile(d, qs)
    good = rs > 0
    if good.sum() < 3 or np.ptp(np.log(rs[good])) <= 0:
        return float("nan")
    return float(np.polyfit(np.log(rs[good]), np.log(qs[good]), 1)[0])


def classify_response(
    points: Any,
    *,
    rtol: float = 1e-3,
    max_period: int = 16,
    scale: ArrayLike | None = None,
    atol: float = 0.0,
    lyapunov_threshold: float = 0.1,
    lyapunov_steps: int = 4,
    embedding: int | None = None,
) -> ResponseClass:
    """Classify a steady response from its Poincaré points.

    Steps:

    1. Normalise each column (``x``, ``v``, ...) by its signal scale; the repeat tolerance
       is ``rtol + atol / scale``.
    2. **Periodic test.** For ``n = 1 .. max_period`` (with at least ``2 n`` points) compute
       the residual ``max_k |P[k+n] - P[k]|`` (max-norm over columns). The smallest ``n``
       whose residual is within tolerance is the period: ``"periodic"`` for 1,
       ``"period-n"`` otherwise.
    3. **Non-periodic test.** Otherwise, 1-D points are delay-embedded (dimension 3 by
       default) and the largest Lyapunov exponent per excitation period is estimated from the
       mean log divergence of nearest-neighbour pairs over ``lyapunov_steps`` iterations
       (Rosenstein et al., 1993). A proxy above ``lyapunov_threshold`` gives ``"chaotic"``,
       otherwise ``"quasi-periodic"`` (neighbours stay neighbours: the points fill a curve
       traversed by a rotation). The correlation dimension (about 1 for a closed curve)
       and the fraction of distinct points are reported as diagnostics.

    What it tells reliably, and what not:

    * **Periodic and period-n** are decided reliably when the points come from an accurate
      integration: the test is a direct repeat check. Set ``rtol`` above the integrator's
      relative accuracy (and the interpolation error of the section), else a periodic orbit
      with numerical noise looks non-periodic (``residual`` / ``best_period`` then show how
      close it came). Periods above ``max_period`` are not reported as period-n: such an
      orbit comes out "quasi-periodic" (its Lyapunov proxy is zero) with confidence 0, a
      small ``distinct_fraction`` and a message naming the repeat period found.
    * **Quasi-periodic vs chaotic** is a heuristic. It needs a few hundred points (fewer
      than ~15 usable pairs gives ``"undetermined"``). Weak chaos with a Lyapunov exponent
      below the threshold per period reads quasi-periodic; measurement/solver noise and
      random data read **chaotic** (noise also separates neighbours), so this test cannot
      tell chaos from noise; a long transient left in the data can also mislead it. A
      three-frequency (torus T^3) response has a 2-D section and still reads quasi-periodic
      (zero Lyapunov proxy) with correlation dimension near 2.

    Parameters
    ----------
    points : array, DataArray or PoincareSection
        Section points of one trajectory: shape ``(n,)`` (one coordinate) or ``(n, d)``
        (e.g. ``(x, v)``), in time order. A :class:`PoincareSection` of a single trajectory
        also supplies its signal scale.
    rtol : float
        Repeat tolerance relative to the signal scale.
    max_period : int
        Largest period (in excitation periods) searched.
    scale : float or array of length d, optional
        Signal scale per column. Default: the section's steady-state peak-to-peak for a
        :class:`PoincareSection`, else ``max(peak-to-peak, max|P|)`` of the points per column
        (give the signal's own peak-to-peak when the points cluster near zero).
    atol : float
        Absolute repeat tolerance added to ``rtol * scale``.
    lyapunov_threshold : float
        Lyapunov proxy (per excitation period) above which a non-periodic response is called
        chaotic.
    lyapunov_steps : int
        Iterations over which neighbour divergence is followed.
    embedding : int, optional
        Delay-embedding dimension; default 3 for 1-D points, 1 (none) for ``d >= 2``.

    Returns
    -------
    ResponseClass
        Kind, period, confidence and diagnostic numbers.

    Raises
    ------
    ValueError
        For fewer than two points, non-finite points, or a multi-trajectory section.
    """
    sec_scale = None
    if isinstance(points, PoincareSection):
        if np.ndim(points.x) != 1:
            raise ValueError(
                "classify_response takes one trajectory; index the section first, "
                "e.g. classify_response(section[i])"
            )
        sec_scale = np.asarray(points.scale, dtype=float).reshape(-1)
        points = points.points
    if isinstance(points, xr.DataArray):
        points = points.values
    p = np.asarray(points, dtype=float)
    if p.ndim == 1:
        p = p[:, None]
    if p.ndim != 2:
        raise ValueError(f"points must have shape (n,) or (n, d), got {np.shape(points)}")
    n, d = p.shape
    if n < 2:
        raise ValueError("classify_response needs at least two section points")
    if not np.all(np.isfinite(p)):
        raise ValueError("section points contain NaN/inf (failed sample?)")
    if scale is not None:
        sc = np.broadcast_to(np.asarray(scale, dtype=float), (d,)).copy()
    elif sec_scale is not None and sec_scale.size == d:
        sc = sec_scale.copy()
    else:
        sc = np.maximum(np.ptp(p, axis=0), np.max(np.abs(p), axis=0))
    sc = np.where(np.isfinite(sc) & (sc > 0), sc, np.maximum(np.max(np.abs(p), axis=0), 1.0))
    q = p / sc
    tol = float(rtol + np.max(atol / sc))

    # 1) repeat test
    residuals = {}
    for lag in range(1, min(max_period, n // 2) + 1):
        residuals[lag] = float(np.max(np.abs(q[lag:] - q[:-lag])))
    if not residuals:  # n < 2 * 1 cannot happen (n >= 2), kept for safety
        residuals[1] = float(np.max(np.abs(q[1:] - q[:-1])))
    best_period = min(residuals, key=residuals.__getitem__)
    best_residual = residuals[best_period]
    for lag, res in residuals.items():
        if res <= tol:
            distinct = _distinct_fraction(q, tol)
            repeats = (n - lag) / lag
            conf = (1.0 - res / tol) * repeats / (repeats + 1.0) if tol > 0 else 1.0
            kind = "periodic" if lag == 1 else "period-n"
            return ResponseClass(
                kind=kind, period=lag, confidence=float(np.clip(conf, 0, 1)), n_points=n,
                tolerance=tol, residual=res, best_period=lag, distinct_fraction=distinct,
                message=(
                    f"section repeats every {lag} excitation period(s): residual "
                    f"{res:.3g} <= tolerance {tol:.3g} over {n} points"
                ),
            )

    # 2) non-periodic: quasi-periodic vs chaotic
    m = embedding if embedding is not None else (3 if d == 1 else 1)
    y = _delay_embed(q, int(m))
    distinct = _distinct_fraction(y, tol)
    lam, lam_se, n_pairs = _lyapunov_proxy(y, int(lyapunov_steps), theiler=0)
    dim2 = _correlation_dimension(y)
    long_period = None
    for lag in range(max_period + 1, min(n // 2, 2000) + 1):
        if np.max(np.abs(q[lag:] - q[:-lag])) <= tol:
            long_period = lag
            break
    notes = [f"no repeat within {min(max_period, n // 2)} periods "
             f"(closest: period {best_period}, residual {best_residual:.3g} > {tol:.3g})"]
    if best_residual < 10 * tol:
        notes.append(f"nearly period-{best_period}: raise rtol if the data are that noisy")
    if long_period is not None:
        notes.append(
            f"the points repeat every {long_period} periods, above max_period={max_period} "
            "(raise max_period to report it as period-n)"
        )
    elif distinct < 0.5:
        notes.append(f"only {distinct:.0%} distinct points: possibly a long period")
    if not np.isfinite(lam) or n_pairs < 15:
        return ResponseClass(
            kind="undetermined", period=None, confidence=0.0, n_points=n, tolerance=tol,
            residual=best_residual, best_period=best_period, distinct_fraction=distinct,
            lyapunov=lam, lyapunov_stderr=lam_se, correlation_dimension=dim2,
            message="; ".join([*notes, "too few points to tell quasi-periodic from chaotic"]),
        )
    z = (lam - lyapunov_threshold) / max(lam_se, 1e-12)
    conf = float(2.0 * ndtr(abs(z)) - 1.0) if long_period is None else 0.0
    kind = "chaotic" if lam > lyapunov_threshold else "quasi-periodic"
    notes.append(
        f"Lyapunov proxy {lam:.3g} +- {lam_se:.2g} per period "
        f"({'>' if kind == 'chaotic' else '<='} {lyapunov_threshold:g}), "
        f"correlation dimension {dim2:.2f}"
    )
    return ResponseClass(
        kind=kind, period=None, confidence=conf, n_points=n, tolerance=tol,
        residual=best_residual, best_period=best_period, distinct_fraction=distinct,
        lyapunov=lam, lyapunov_stderr=lam_se, correlation_dimension=dim2,
        message="; ".join(notes),
    )


# --------------------------------------------------------------------------------------------
# spectral peaks and sidebands
# --------------------------------------------------------------------------------------------
def _freq_amp(freq: Any, amp: Any) -> tuple[np.ndarray, np.ndarray, xr.DataArray | None]:
    da = None
    if isinstance(amp, xr.DataArray):
        da = _time_last(amp, "frequency") if "frequency" in amp.dims else amp
        if freq is None and "frequency" in da.coords:
            freq = da["frequency"].values
        a = da.values
    else:
        a = np.asarray(amp, dtype=float)
    if freq is None:
        raise ValueError("give the frequency axis")
    f = np.asarray(freq.values if isinstance(freq, xr.DataArray) else freq, dtype=float)
    if f.ndim != 1 or f.size != a.shape[-1]:
        raise ValueError(f"freq must be 1-D with {a.shape[-1]} entries, got {f.shape}")
    if f.size > 1 and not np.all(np.diff(f) > 0):
        raise ValueError("freq must be strictly increasing")
    return f, a, da


def sidebands(
    freq: Any,
    amp: Any,
    carrier: float,
    spacing: float,
    n: int = 3,
    *,
    search_bins: int = 0,
) -> dict[str, Any]:
    """Amplitudes at the carrier and its sidebands ``carrier + k * spacing``, ``|k| <= n``.

    Typical use: mesh frequency (carrier) modulated by a shaft rotation frequency (spacing).

    Parameters
    ----------
    freq : array or None
        Frequency axis (increasing), e.g. from :func:`amplitude_spectrum`; ``None`` takes the
        ``frequency`` coordinate of a DataArray ``amp``.
    amp : ndarray or DataArray
        Amplitude spectrum ``(..., n_freq)``.
    carrier, spacing : float
        Carrier frequency and sideband spacing, in the units of ``freq``.
    n : int
        Number of sidebands on each side.
    search_bins : int
        Take the largest amplitude within this many bins of the nearest bin (0: nearest bin
        only), to catch peaks leaked into a neighbouring bin.

    Returns
    -------
    dict
        ``order`` (k = -n..n), ``frequency`` (target frequencies), ``bin_frequency`` (the bin
        read), ``amplitude`` (``(..., 2n+1)``; a DataArray with dim ``order`` for DataArray
        input) and ``relative`` (amplitude / carrier amplitude). Targets outside the
        frequency axis give NaN.
    """
    f, a, da = _freq_amp(freq, amp)
    orders = np.arange(-int(n), int(n) + 1)
    targets = carrier + orders * spacing
    df = np.median(np.diff(f)) if f.size > 1 else np.inf
    inside = (targets >= f[0] - 0.5 * df) & (targets <= f[-1] + 0.5 * df)
    idx = np.clip(np.searchsorted(f, targets), 1, f.size - 1) if f.size > 1 else np.zeros(
        targets.size, dtype=int
    )
    if f.size > 1:
        idx = np.where(np.abs(f[idx - 1] - targets) <= np.abs(f[idx] - targets), idx - 1, idx)
    vals = np.empty((*a.shape[:-1], orders.size))
    for c, i0 in enumerate(idx):
        lo = max(i0 - search_bins, 0)
        hi = min(i0 + search_bins + 1, f.size)
        vals[..., c] = np.max(a[..., lo:hi], axis=-1)
    vals[..., ~inside] = np.nan
    bin_f = np.where(inside, f[idx], np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = vals / vals[..., n : n + 1]
    out: dict[str, Any] = {
        "order": orders,
        "frequency": targets,
        "bin_frequency": bin_f,
        "amplitude": vals,
        "relative": rel,
    }
    if da is not None:
        coords = _other_coords(da, "frequency")
        coords["order"] = ("order", orders)
        coords["sideband_frequency"] = ("order", targets, dict(da["frequency"].attrs))
        for key in ("amplitude", "relative"):
            out[key] = xr.DataArray(
                out[key], dims=(*da.dims[:-1], "order"), coords=coords,
                attrs={"units": da.attrs.get("units", "1") if key == "amplitude" else "1"},
            )
    return out


def dominant_frequencies(
    freq: Any,
    amp: Any,
    n: int = 5,
    *,
    min_separation: float | None = None,
    rel_height: float = 0.0,
    include_dc: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """The ``n`` largest spectral peaks (local maxima), largest first.

    Parameters
    ----------
    freq : array or None
        Frequency axis (increasing); ``None`` for a DataArray ``amp`` with a ``frequency``
        coordinate.
    amp : ndarray or DataArray
        Amplitude spectrum ``(..., n_freq)``.
    n : int
        Number of peaks returned.
    min_separation : float, optional
        Minimum distance between reported peaks, in frequency units (e.g. a few bins for a
        windowed spectrum, so a main lobe counts once).
    rel_height : float
        Ignore peaks lower than ``rel_height * max(amp)``.
    include_dc : bool
        Let the DC bin count as a peak when it exceeds its neighbour.

    Returns
    -------
    freqs, amps : ndarray
        Shapes ``(..., n)``, sorted by decreasing amplitude, NaN-padded when there are fewer
        than ``n`` peaks. Frequencies are bin centres (resolution ``1 / record length``).
    """
    f, a, _ = _freq_amp(freq, amp)
    lead = a.shape[:-1]
    out_f = np.full((*lead, n), np.nan)
    out_a = np.full((*lead, n), np.nan)
    df = np.median(np.diff(f)) if f.size > 1 else 1.0
    distance = None if not min_separation else max(1, int(round(min_separation / df)))
    for ii in np.ndindex(*lead):
        row = a[ii]
        if not np.all(np.isfinite(row)):
            continue
        height = rel_height * np.max(row) if rel_height > 0 else None
        pk, _ = _sps.find_peaks(row, height=height, distance=distance)
        if include_dc and row.size > 1 and row[0] > row[1]:
            if height is None or row[0] >= height:
                pk = np.concatenate([[0], pk])
        order = pk[np.argsort(row[pk])[::-1]][:n]
        out_f[ii][: order.size] = f[order]
        out_a[ii][: order.size] = row[order]
    return out_f, out_a
