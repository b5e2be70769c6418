"""Tests of gearuq.signal (spectra, measures, Poincaré sections, classifier) and gearuq.plot."""

from __future__ import annotations

import math

import numpy as np
import pytest
import xarray as xr
from scipy import stats
from scipy.integrate import solve_ivp

from gearuq import plot as gplot
from gearuq.signal import (
    PoincareSection,
    amplitude_spectrum,
    classify_response,
    dominant_frequencies,
    peak_to_peak,
    phase_portrait,
    poincare_section,
    rms,
    sidebands,
    steady_state,
)

GOLDEN = (1.0 + math.sqrt(5.0)) / 2.0
TWO_PI = 2.0 * math.pi

# record used by the spectrum tests: 1000 samples at 1 kHz -> 1 Hz bins
N = 1000
DT = 1e-3
T = np.arange(N) * DT


def _tone(amp: float, freq: float, phase: float = 0.7) -> np.ndarray:
    return amp * np.sin(TWO_PI * freq * T + phase)


def _bin(freq_axis: np.ndarray, f: float) -> int:
    return int(np.argmin(np.abs(freq_axis - f)))


# --------------------------------------------------------------------------------------------
# amplitude spectrum
# --------------------------------------------------------------------------------------------
def test_frequency_axis_and_dt_forms():
    f, a = amplitude_spectrum(_tone(1.0, 50.0), T)
    np.testing.assert_allclose(f, np.arange(N // 2 + 1) / (N * DT), rtol=0, atol=1e-9)
    assert a.shape == f.shape
    f2, a2 = amplitude_spectrum(_tone(1.0, 50.0), dt=DT)
    f3, a3 = amplitude_spectrum(_tone(1.0, 50.0), DT)  # scalar t means dt
    np.testing.assert_array_equal(f, f2)
    np.testing.assert_array_equal(a, a3)
    # nondimensional time: frequency in cycles per unit tau
    tau = np.arange(256) * (TWO_PI / 32)  # 32 samples per unit angular period
    f_tau, a_tau = amplitude_spectrum(np.sin(3.0 * tau), tau, window=None)
    assert f_tau[_bin(f_tau, 3.0 / TWO_PI)] == pytest.approx(3.0 / TWO_PI, rel=1e-12)
    assert a_tau[_bin(f_tau, 3.0 / TWO_PI)] == pytest.approx(1.0, abs=1e-10)


def test_rectangular_window_bin_centre_exact():
    f, a = amplitude_spectrum(_tone(2.5, 50.0), T, window="rect")
    k = _bin(f, 50.0)
    assert f[k] == pytest.approx(50.0)
    assert abs(a[k] - 2.5) < 1e-10
    others = np.delete(a, k)
    assert others.max() < 1e-10


def test_hann_bin_centre_within_1e3_and_scalloping_documented():
    f, a = amplitude_spectrum(_tone(2.5, 50.0), T, window="hann")
    assert abs(a[_bin(f, 50.0)] - 2.5) < 1e-3 * 2.5
    # half a bin off: Hann reads ~15 % low (scalloping, as documented)
    f, a = amplitude_spectrum(_tone(1.0, 50.5), T, window="hann")
    assert 0.14 < 1.0 - a.max() < 0.16


@pytest.mark.parametrize("offset", np.linspace(0.0, 1.0, 11))
def test_flattop_accurate_between_bins(offset):
    x = _tone(1.7, 120.0 + offset, phase=0.3 + offset)
    f, a = amplitude_spectrum(x, T, window="flattop")
    assert abs(a.max() - 1.7) < 1e-3 * 1.7


def test_dc_handled():
    x = 0.8 + _tone(1.5, 40.0)
    for window in ("rect", "hann", "flattop"):
        f, a = amplitude_spectrum(x, T, window=window, detrend=None)
        assert f[0] == 0.0
        assert abs(a[0] - 0.8) < 1e-10  # DC read as the mean, not doubled
        assert abs(a[_bin(f, 40.0)] - 1.5) < 1e-3
    _, a = amplitude_spectrum(x, T, window="rect")  # detrend="mean" by default
    assert a[0] < 1e-12


def test_two_tones_resolved():
    x = _tone(1.0, 50.0) + _tone(0.3, 56.0, phase=2.0)
    f, a = amplitude_spectrum(x, T, window="hann")
    assert abs(a[_bin(f, 50.0)] - 1.0) < 1e-3
    assert abs(a[_bin(f, 56.0)] - 0.3) < 1e-3
    assert a[_bin(f, 53.0)] < 1e-3  # a clear gap between the two lines
    fp, ap = dominant_frequencies(f, a, n=2)
    np.testing.assert_allclose(fp, [50.0, 56.0])
    np.testing.assert_allclose(ap, [1.0, 0.3], atol=1e-3)


def test_nyquist_two_sided_and_padding():
    n = np.arange(N)
    _, a = amplitude_spectrum(0.4 * np.cos(np.pi * n), 1.0, window=None, detrend=None)
    assert abs(a[-1] - 0.4) < 1e-12  # Nyquist bin not doubled
    f2, a2 = amplitude_spectrum(_tone(2.0, 50.0), T, window="rect", onesided=False)
    assert f2[0] < 0 < f2[-1] and np.all(np.diff(f2) > 0)
    assert abs(a2[_bin(f2, 50.0)] - 1.0) < 1e-10 and abs(a2[_bin(f2, -50.0)] - 1.0) < 1e-10
    fp, ap = amplitude_spectrum(_tone(2.0, 50.0), T, window="hann", pad_to=4 * N)
    assert fp[1] == pytest.approx(0.25)
    assert abs(ap[_bin(fp, 50.0)] - 2.0) < 1e-10


def test_spectrum_errors():
    with pytest.raises(ValueError, match="uniform"):
        amplitude_spectrum(np.ones(10), np.r_[0.0, np.cumsum(np.linspace(1, 2, 9))])
    with pytest.raises(ValueError, match="time grid t or the sample interval"):
        amplitude_spectrum(np.ones(10))
    with pytest.raises(ValueError, match="pad_to"):
        amplitude_spectrum(np.ones(10), 1.0, pad_to=5)


def test_dataarray_spectrum_keeps_sample_and_units():
    amps = np.array([1.0, 2.0, 3.0])
    data = amps[:, None] * np.sin(TWO_PI * 50.0 * T)[None, :]
    da = xr.DataArray(
        data, dims=("sample", "time"),
        coords={"sample": [10, 11, 12], "time": ("time", T, {"units": "s"})},
        attrs={"units": "um", "long_name": "transmission error"}, name="dte",
    )
    f, a = amplitude_spectrum(da)
    assert a.dims == ("sample", "frequency")
    assert list(a["sample"].values) == [10, 11, 12]
    assert a.attrs["units"] == "um"
    assert f.attrs["units"] == "Hz"
    np.testing.assert_allclose(a.sel(frequency=50.0).values, amps, atol=1e-10)
    f_np, a_np = amplitude_spectrum(data, T)
    np.testing.assert_allclose(a.values, a_np)
    # transposed input and nondimensional time
    da_nd = da.T.assign_coords(time=("time", T, {"units": "1"}))
    f_nd, a_nd = amplitude_spectrum(da_nd)
    assert a_nd.dims == ("sample", "frequency")
    assert "cycles per unit" in f_nd.attrs["long_name"]


# --------------------------------------------------------------------------------------------
# scalar measures
# --------------------------------------------------------------------------------------------
def test_rms_and_peak_to_peak():
    x = _tone(3.0, 50.0, phase=0.0)  # 50 whole periods
    assert rms(x) == pytest.approx(3.0 / math.sqrt(2.0), abs=1e-12)
    assert rms(x + 2.0) == pytest.approx(math.sqrt(4.0 + 4.5), abs=1e-12)
    assert rms(x + 2.0, center=True) == pytest.approx(3.0 / math.sqrt(2.0), abs=1e-12)
    xp = 3.0 * np.cos(TWO_PI * 50.0 * T)  # samples hit both peaks (20 samples per period)
    assert peak_to_peak(xp) == pytest.approx(6.0, abs=1e-12)
    da = xr.DataArray(np.vstack([x, 2 * x]), dims=("sample", "time"), attrs={"units": "m"})
    r = rms(da)
    assert r.dims == ("sample",) and r.attrs["units"] == "m"
    np.testing.assert_allclose(r.values, [3 / math.sqrt(2), 6 / math.sqrt(2)], atol=1e-12)
    np.testing.assert_allclose(peak_to_peak(np.vstack([xp, 2 * xp])), [6.0, 12.0], atol=1e-12)
    assert np.isnan(rms(np.array([1.0, np.nan])))  # failed samples are not hidden


def test_steady_state_and_phase_portrait():
    t = np.linspace(0.0, 10.0, 101)
    x = np.sin(t)
    ts, xs = steady_state(x, t, 4.0)
    assert ts[0] == pytest.approx(4.0) and xs.shape == (61,)
    da = xr.DataArray(x, dims="time", coords={"time": t})
    assert steady_state(da, None, 4.0).sizes["time"] == 61
    with pytest.raises(ValueError, match="no instant"):
        steady_state(x, t, 11.0)
    xp, vp = phase_portrait(x, t=t, t_start=4.0)  # velocity by finite differences
    assert xp.shape == vp.shape == (61,)
    np.testing.assert_allclose(vp[1:-1], np.cos(t[t >= 4.0])[1:-1], atol=2e-3)


# --------------------------------------------------------------------------------------------
# Poincaré sections and classification
# --------------------------------------------------------------------------------------------
def _grid(n_periods: int, per_period: float, period: float = TWO_PI) -> np.ndarray:
    # deliberately incommensurate with the period so the section is interpolated
    return np.arange(0.0, n_periods * period, period / per_period)


def test_poincare_period1_single_point():
    t = _grid(200, 37.3)
    x = np.sin(t) + 0.3 * np.cos(2 * t + 0.4)
    v = np.cos(t) - 0.6 * np.sin(2 * t + 0.4)
    sec = poincare_section(t, x, v, period=TWO_PI, t_start=20 * TWO_PI, phase=0.5)
    assert isinstance(sec, PoincareSection)
    np.testing.assert_allclose(np.diff(sec.t), TWO_PI, rtol=1e-12)
    assert sec.t[0] == pytest.approx(20 * TWO_PI + 0.5)
    # one point: the cloud's spread stays within the documented cubic-spline error bound
    # 20 (dt / T_h)^4 a_h summed over harmonics (37.3 points per period, 18.6 per period of
    # the 2nd harmonic): about 1.9e-5 for x and 1.2e-4 for v, i.e. < 1e-4 of the scale
    dt = t[1] - t[0]
    bound_x = 20 * (dt / TWO_PI) ** 4 * 1.0 + 20 * (2 * dt / TWO_PI) ** 4 * 0.3
    bound_v = 20 * (dt / TWO_PI) ** 4 * 1.0 + 20 * (2 * dt / TWO_PI) ** 4 * 0.6
    assert np.ptp(sec.x) < bound_x and np.ptp(sec.v) < bound_v
    assert np.ptp(sec.x) / sec.scale[0] < 1e-4 and np.ptp(sec.v) / sec.scale[1] < 1e-4
    assert sec.x[0] == pytest.approx(math.sin(0.5) + 0.3 * math.cos(1.4), abs=1e-5)
    res = classify_response(sec)
    assert res.kind == "periodic" and res.period == 1 and res.label == "periodic"
    assert res.residual < 1e-5 and res.confidence > 0.95


def test_poincare_on_grid_is_exact():
    t = np.linspace(0.0, 50 * TWO_PI, 50 * 40 + 1)
    x = np.sin(t) + 0.2 * np.sin(3 * t)
    sec = poincare_section(t, x, period=TWO_PI)
    assert len(sec) == 51
    np.testing.assert_allclose(sec.x, x[::40], rtol=0, atol=0)


def test_subharmonic_period3():
    t = _grid(300, 29.7)
    x = np.sin(t) + 0.5 * np.sin(t / 3 + 0.2)
    v = np.cos(t) + 0.5 / 3 * np.cos(t / 3 + 0.2)
    sec = poincare_section(t, x, v, period=TWO_PI, t_start=10 * TWO_PI)
    res = classify_response(sec)
    assert res.kind == "period-n" and res.period == 3 and res.label == "period-3"
    assert res.distinct_fraction == pytest.approx(3 / res.n_points)
    # 1-D points (x only) give the same answer
    assert classify_response(sec.x).period == 3


def test_quasi_periodic_golden_mean_closed_curve():
    t = _grid(500, 31.1)
    x = np.sin(t) + 0.5 * np.sin(GOLDEN * t)
    v = np.cos(t) + 0.5 * GOLDEN * np.cos(GOLDEN * t)
    sec = poincare_section(t, x, v, period=TWO_PI)
    res = classify_response(sec)
    assert res.kind == "quasi-periodic" and res.period is None
    assert res.distinct_fraction > 0.95  # points do not repeat
    assert abs(res.lyapunov) < 0.05
    assert 0.85 < res.correlation_dimension < 1.2  # a curve
    # ... and the curve is closed: at t_k = 2 pi k the points lie on the ellipse
    # (x / 0.5)^2 + ((v - 1) / (0.5 GOLDEN))^2 = 1
    ellipse = (sec.x / 0.5) ** 2 + ((sec.v - 1.0) / (0.5 * GOLDEN)) ** 2
    np.testing.assert_allclose(ellipse, 1.0, atol=3e-4)  # spline error at 19 pts/period
    # angles on the ellipse cover the whole circle (no gap larger than 2 % of a turn)
    ang = np.sort(np.arctan2((sec.v - 1.0) / (0.5 * GOLDEN), sec.x / 0.5))
    assert np.max(np.diff(np.r_[ang, ang[0] + TWO_PI])) < 0.02 * TWO_PI
    assert classify_response(sec.x).kind == "quasi-periodic"  # 1-D, delay-embedded


def test_logistic_map_chaotic():
    z = np.empty(400)
    z[0] = 0.1234
    for i in range(z.size - 1):
        z[i + 1] = 4.0 * z[i] * (1.0 - z[i])
    res = classify_response(z)
    assert res.kind == "chaotic" and res.period is None
    assert res.lyapunov == pytest.approx(math.log(2.0), abs=0.15)  # exact exponent ln 2


def test_henon_map_chaotic():
    h = np.empty((600, 2))
    h[0] = (0.1, 0.1)
    for i in range(h.shape[0] - 1):
        h[i + 1] = (1.0 - 1.4 * h[i, 0] ** 2 + h[i, 1], 0.3 * h[i, 0])
    res = classify_response(h[100:])
    assert res.kind == "chaotic"
    assert res.lyapunov == pytest.approx(0.42, abs=0.12)  # literature value 0.419
    assert 1.1 < res.correlation_dimension < 1.4  # literature D2 = 1.21


def _duffing(c: float, k1: float, k3: float, f: float, w: float, n_periods: int, per: int):
    period = TWO_PI / w
    t = np.linspace(0.0, n_periods * period, n_periods * per + 1)

    def rhs(tt, y):
        return [y[1], -c * y[1] - k1 * y[0] - k3 * y[0] ** 3 + f * np.cos(w * tt)]

    sol = solve_ivp(rhs, (0.0, t[-1]), [1.0, 0.0], method="DOP853", rtol=1e-9, atol=1e-9,
                    t_eval=t)
    assert sol.success
    return sol.t, sol.y[0], sol.y[1], period


@pytest.mark.e2e
def test_duffing_end_to_end_periodic_and_chaotic():
    # weakly forced hardening Duffing: period-1
    t, x, v, per = _duffing(0.2, 1.0, 1.0, 0.3, 1.2, 120, 32)
    res = classify_response(poincare_section(t, x, v, period=per, t_start=80 * per))
    assert res.kind == "periodic"
    # Ueda's oscillator x'' + 0.05 x' + x^3 = 7.5 cos t: chaotic (strange attractor)
    t, x, v, per = _duffing(0.05, 0.0, 1.0, 7.5, 1.0, 220, 32)
    res = classify_response(poincare_section(t, x, v, period=per, t_start=20 * per))
    assert res.kind == "chaotic"
    assert res.lyapunov > 0.3
    assert res.correlation_dimension > 1.2  # fractal, not a closed curve


def test_noise_reads_chaotic_documented_limitation():
    # The heuristic cannot tell noise from chaos; it only guarantees "not periodic".
    rng = np.random.default_rng(3)
    res = classify_response(rng.normal(size=(400, 2)))
    assert not res.is_periodic
    assert res.kind == "chaotic"


def test_long_period_and_undetermined():
    t = _grid(300, 23.0)
    x = np.sin(t) + 0.4 * np.sin(t / 20)
    v = np.cos(t) + 0.02 * np.cos(t / 20)
    sec = poincare_section(t, x, v, period=TWO_PI)
    res = classify_response(sec)  # max_period=16 < 20
    assert res.kind == "quasi-periodic" and res.confidence == 0.0
    assert "every 20 periods" in res.message
    res = classify_response(sec, max_period=24)
    assert res.kind == "period-n" and res.period == 20
    few = classify_response(np.random.default_rng(0).uniform(size=12))
    assert few.kind == "undetermined"


def test_classify_input_errors_and_scale():
    with pytest.raises(ValueError, match="NaN"):
        classify_response(np.array([0.1, np.nan, 0.2]))
    with pytest.raises(ValueError, match="at least two"):
        classify_response(np.array([1.0]))
    # points near zero: relative tolerance needs the signal scale
    pts = 1e-8 + 1e-10 * np.random.default_rng(1).normal(size=50)
    assert classify_response(pts).kind != "periodic"
    assert classify_response(pts, scale=1.0).kind == "periodic"


def test_poincare_too_coarse_raises_and_warns():
    t = np.arange(0.0, 100.0, 4.0)  # 1.57 points per period 2 pi
    with pytest.raises(ValueError, match="too coarse"):
        poincare_section(t, np.sin(t), period=TWO_PI)
    t = np.arange(0.0, 200.0, 1.3)  # ~4.8 points per period
    with pytest.warns(RuntimeWarning, match="points per period"):
        poincare_section(t, np.sin(t), period=TWO_PI)
    with pytest.raises(ValueError, match="no section instant"):
        poincare_section(np.linspace(0, 1, 50), np.zeros(50), period=TWO_PI, t_start=2.0)


def test_poincare_dataarray_multi_sample():
    t = _grid(60, 25.0)
    amps = np.array([1.0, 2.0])
    x = xr.DataArray(amps[:, None] * np.sin(t)[None, :], dims=("sample", "time"),
                     coords={"time": ("time", t, {"units": "1"})}, attrs={"units": "m"})
    v = xr.DataArray(amps[:, None] * np.cos(t)[None, :], dims=("sample", "time"),
                     coords={"time": t})
    sec = poincare_section(None, x, v, period=TWO_PI, t_start=10 * TWO_PI, phase=1.0)
    assert sec.x.dims == ("sample", "crossing")
    assert sec.x.attrs["units"] == "m"
    assert sec.points.shape == (2, len(sec), 2)
    np.testing.assert_allclose(sec.x.values[:, 0], amps * math.sin(1.0), atol=1e-6)
    np.testing.assert_allclose(sec.scale[:, 0], 2 * amps, rtol=1e-2)  # ptp on the grid
    with pytest.raises(ValueError, match="one trajectory"):
        classify_response(sec)
    assert [classify_response(sec[i]).kind for i in range(2)] == ["periodic", "periodic"]


# --------------------------------------------------------------------------------------------
# sidebands and peaks
# --------------------------------------------------------------------------------------------
def test_sidebands_amplitude_modulation():
    x = (1.0 + 0.4 * np.cos(TWO_PI * 10.0 * T)) * np.sin(TWO_PI * 100.0 * T)
    f, a = amplitude_spectrum(x, T, window="rect")
    sb = sidebands(f, a, carrier=100.0, spacing=10.0, n=3)
    np.testing.assert_array_equal(sb["order"], np.arange(-3, 4))
    np.testing.assert_allclose(sb["bin_frequency"], 100.0 + 10.0 * np.arange(-3, 4))
    np.testing.assert_allclose(sb["amplitude"], [0, 0, 0.2, 1.0, 0.2, 0, 0], atol=1e-10)
    np.testing.assert_allclose(sb["relative"][[2, 4]], [0.2, 0.2], atol=1e-10)
    far = sidebands(f, a, carrier=495.0, spacing=10.0, n=1)  # 505 Hz beyond Nyquist
    assert np.isnan(far["amplitude"][2]) and not np.isnan(far["amplitude"][1])
    # DataArray route
    da = xr.DataArray(np.vstack([x, 2 * x]), dims=("sample", "time"),
                      coords={"time": T}, attrs={"units": "m"})
    _, ada = amplitude_spectrum(da, window="rect")
    sbd = sidebands(None, ada, 100.0, 10.0, n=1)
    assert sbd["amplitude"].dims == ("sample", "order")
    np.testing.assert_allclose(sbd["amplitude"].values, [[0.2, 1, 0.2], [0.4, 2, 0.4]],
                               atol=1e-10)


def test_dominant_frequencies_padding_and_batch():
    x = np.vstack([_tone(1.0, 30.0) + _tone(0.5, 80.0), _tone(2.0, 200.0)])
    f, a = amplitude_spectrum(x, T, window="rect")
    fp, ap = dominant_frequencies(f, a, n=3, rel_height=0.01)
    np.testing.assert_allclose(fp[0, :2], [30.0, 80.0])
    assert np.isnan(fp[0, 2])
    np.testing.assert_allclose(fp[1, 0], 200.0)
    np.testing.assert_allclose(ap[1, 0], 2.0, atol=1e-10)
    a_dc = amplitude_spectrum(3 + x[1], T, window="rect", detrend=None)[1]
    fdc, _ = dominant_frequencies(f, a_dc, n=2, include_dc=True)
    np.testing.assert_allclose(fdc, [0.0, 200.0])


# --------------------------------------------------------------------------------------------
# plots
# --------------------------------------------------------------------------------------------
def _is_png(path) -> bool:
    data = path.read_bytes()
    return len(data) > 1000 and data[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.e2e
def test_plot_time_panels(tmp_path):
    t = _grid(60, 32.0)
    xd = xr.DataArray(np.sin(t) + 0.2 * np.sin(2.5 * t), dims="time",
                      coords={"time": ("time", t, {"units": "1"})},
                      attrs={"units": "um", "long_name": "pinion displacement"})
    vd = xr.DataArray(np.cos(t) + 0.5 * np.cos(2.5 * t), dims="time", coords={"time": t},
                      attrs={"units": "um/s", "long_name": "pinion velocity"})
    series = {"driving": (xd, vd), "driven": (0.5 * xd.values, 0.5 * vd.values)}
    fig, axes = gplot.plot_time_panels(None, series, period=TWO_PI, t_start=10 * TWO_PI,
                                       normalize_frequency=True, fmax=4.0)
    assert axes.shape == (2, 5)
    assert axes[0, 0].get_ylabel() == "pinion displacement [um]"
    assert axes[1, 4].get_title().startswith("(j) driven")
    out = gplot.save_figure(fig, tmp_path / "sub" / "panels.png")
    assert _is_png(out)


@pytest.mark.e2e
def test_plot_reliability_curves(tmp_path):
    time = np.linspace(0.0, 10.0, 21)
    pf = np.vstack([np.linspace(0.0, 0.2, 21), np.linspace(0.0, 0.05, 21)])
    ds = xr.Dataset(
        {
            "pf": (("mode", "time"), pf),
            "r": (("mode", "time"), 1 - pf),
            "pf_lower": (("mode", "time"), np.clip(pf - 0.02, 0, 1)),
            "pf_upper": (("mode", "time"), np.clip(pf + 0.02, 0, 1)),
            "beta": (("mode", "time"), -stats.norm.ppf(pf)),
        },
        coords={"mode": ["x1", "system"], "time": ("time", time, {"units": "s"})},
        attrs={"confidence_level": 0.95},
    )
    for q, log in (("r", False), ("pf", True), ("beta", False)):
        fig, ax = gplot.plot_reliability_curves(ds, quantity=q)
        assert (ax.get_yscale() == "log") == log
        assert len(ax.get_lines()) == 2
        assert _is_png(gplot.save_figure(fig, tmp_path / f"rel_{q}.png"))
    with pytest.raises(ValueError, match="quantity"):
        gplot.plot_reliability_curves(ds, quantity="x")


def test_plot_fit_dict_and_duck_type(tmp_path):
    rng = np.random.default_rng(0)
    samples = rng.lognormal(0.0, 0.3, 500)
    dists = {
        "lognorm": stats.lognorm(*stats.lognorm.fit(samples, floc=0)),
        "gamma": stats.gamma(*stats.gamma.fit(samples, floc=0)),
        "norm": stats.norm(*stats.norm.fit(samples)),
    }
    fig, ax = gplot.plot_fit(samples, dists, top=2)
    assert len(ax.get_lines()) == 2
    assert _is_png(gplot.save_figure(fig, tmp_path / "fit.png"))

    class Fits:
        ranking = ["norm", "gamma"]

        def frozen(self, name):
            return dists[name]

    import matplotlib.figure

    fig0 = matplotlib.figure.Figure()
    ax0 = fig0.add_subplot()
    fig1, ax1 = gplot.plot_fit(xr.DataArray(samples, attrs={"units": "um", "long_name": "DTE"}),
                               Fits(), ax=ax0)
    assert ax1 is ax0 and fig1 is fig0
    assert ax1.get_xlabel() == "DTE [um]"
    assert _is_png(gplot.save_figure(ax1, tmp_path / "fit2"))


def test_plot_work_precision(tmp_path):
    table = [
        {"method": m, "rtol": r, "time_per_sample": c * r ** -0.2, "error": e * r}
        for m, c, e in (("RK45", 1e-3, 3.0), ("DOP853", 2e-3, 0.5))
        for r in (1e-3, 1e-6, 1e-9)
    ]
    table.append({"method": "RK45", "rtol": 1e-12, "time_per_sample": 0.1, "error": 0.0})
    fig, ax = gplot.plot_work_precision(table)
    assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
    assert len(ax.get_lines()) == 2
    assert "1 row" in ax.get_title()
    assert _is_png(gplot.save_figure(fig, tmp_path / "wp.png"))
