"""Gear errors and flank modifications as initial normal clearances at the contact points.

Sign convention: a positive value removes material from the working flank (moves it away
from the mate), i.e. it *adds* initial clearance ``xi`` at the contact points. All inputs are
measured as ISO 1328 / ISO 21771 measure them and converted to the normal of the flank at
the contact (the direction of the LTCA compatibility equation):

- cumulative pitch deviations ``F_pk`` [m], tangential on the reference circle (Yuan et al. (2020),
  Eq. 2): ``xi = F_pk cos(alpha_t) cos(beta_b)``;
- profile (tip/root) relief and lead crowning, measured in the transverse plane along the
  base tangent (the line of action): ``xi = C cos(beta_b)``.

The parabolic tip relief of Yuan et al. (2020) (Eq. 12) is written in the POA coordinate ``s``; see
``docs/theory/ltca.md``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.optimize import brentq

from gearuq.gears.contact import MeshKinematics
from gearuq.gears.geometry import HelicalGearPair

__all__ = [
    "AMPLITUDE_READINGS",
    "FlankDeviations",
    "cumulative_pitch_from_germ",
    "cumulative_pitch_from_normals",
    "PITCH_GERM_PREFIXES",
    "pitch_germ_dimension",
    "pitch_germ_from_values",
    "pitch_germ_names",
    "pitch_germ_energy_fraction",
    "pitch_germ_scales",
    "pitch_germ_basis",
    "pitch_deviation_germ",
    "iso1328_pitch_tolerances",
    "iso1328_profile_form_tolerance",
    "PITCH_TOLERANCE_LAWS",
    "capable_pitch_scatter",
    "inspected_normal_spec",
    "total_cumulative_pitch_deviation",
    "pitch_deviations_from_cumulative",
    "random_cumulative_pitch_deviations",
]


def pitch_deviations_from_cumulative(Fp: np.ndarray) -> np.ndarray:
    """Return single pitch deviations ``f_pt,k = F_p,k - F_p,k-1`` (cyclic; Yuan et al. Eq. 1)."""
    Fp = np.asarray(Fp, dtype=float)
    return Fp - np.roll(Fp, 1)


def iso1328_pitch_tolerances(d: float, mn: float, accuracy_grade: int) -> tuple[float, float]:
    """Return ISO 1328-1 tolerances ``(f_pT, F_pT)`` [m] for a gear.

    ``f_pT = (0.001 d + 0.4 mn + 5) sqrt(2)^(A-5)`` um and
    ``F_pT = (0.002 d + 0.55 sqrt(d) + 0.7 mn + 12) sqrt(2)^(A-5)`` um, ``d``, ``mn`` in mm.

    Parameters
    ----------
    d, mn : float
        Reference diameter and normal module [m].
    accuracy_grade : int
        Flank tolerance class ``A`` in 1..12. ISO 1328-1:2013 defines classes 1-11 and the
        1995 edition grades 0-12 with the same step factor sqrt(2) per grade; grade 12 (the
        coarsest of the 1995 edition, still named in drawings) is accepted by the same
        formula, grade 0 is not (the 2013 formulas are not stated below class 1).
    """
    if int(accuracy_grade) != accuracy_grade or not 1 <= accuracy_grade <= 12:
        raise ValueError(
            f"accuracy_grade={accuracy_grade!r} is outside its valid range: integers 1..12"
        )
    dm, mm = d * 1e3, mn * 1e3
    f = math.sqrt(2.0) ** (accuracy_grade - 5)
    return (0.001 * dm + 0.4 * mm + 5.0) * f * 1e-6, (
        0.002 * dm + 0.55 * math.sqrt(dm) + 0.7 * mm + 12.0
    ) * f * 1e-6


def iso1328_profile_form_tolerance(d: float, mn: float, accuracy_grade: int) -> float:
    """Return the ISO 1328-1:2013 profile form tolerance ``f_fT`` [m] of a gear.

    ``f_fT = (2.5 sqrt(mn) + 0.17 sqrt(d) + 0.5) sqrt(2)^(A-5)`` um, ``d``, ``mn`` in mm;
    classes as :func:`iso1328_pitch_tolerances`.
    """
    if int(accuracy_grade) != accuracy_grade or not 1 <= accuracy_grade <= 12:
        raise ValueError(
            f"accuracy_grade={accuracy_grade!r} is outside its valid range: integers 1..12"
        )
    dm, mm = d * 1e3, mn * 1e3
    return (2.5 * math.sqrt(mm) + 0.17 * math.sqrt(dm) + 0.5) * math.sqrt(2.0) ** (
        accuracy_grade - 5) * 1e-6


#: Readings of the paper's "amplitude of the random cumulative pitch deviations".
AMPLITUDE_READINGS = ("sine", "largest")


def cumulative_pitch_from_germ(
    phase: float,
    normals: np.ndarray,
    *,
    amplitude: float,
    sigma: float,
    amplitude_reading: str = "sine",
) -> np.ndarray:
    """Cumulative pitch deviations from their random germ (Yuan, Liu and Liu (2020), Sec. 3) [m].

    ``F_p,k = A sin(2 pi k / z + phase) + sigma (n_k - n_0)`` with ``n_k`` standard normal.
    The germ ``(phase, normals)`` is the realisation; ``amplitude`` and ``sigma`` only scale
    it, so a realisation keeps its shape when the scatter changes.

    Parameters
    ----------
    phase : float
        Sine phase [rad].
    normals : ndarray, (z,)
        Standard-normal germ of the scatter.
    amplitude : float
        The paper's "amplitude" [m], read as ``amplitude_reading`` says.
    sigma : float
        Standard deviation of the scatter [m] (seed: 3 um).
    amplitude_reading : {"sine", "largest"}
        ``"sine"``: ``A = amplitude`` (the sine amplitude; the realised largest deviation is
        then larger). ``"largest"``: ``A >= 0`` is chosen so that ``max_k |F_p,k| =
        amplitude`` (the largest cumulative deviation); if the scatter alone already exceeds
        ``amplitude``, ``A = 0`` and the largest deviation is the scatter's.

    Returns
    -------
    ndarray, (z,)
    """
    if amplitude_reading not in AMPLITUDE_READINGS:
        raise ValueError(f"amplitude_reading={amplitude_reading!r} is outside its valid set "
                         f"{AMPLITUDE_READINGS}")
    if not (math.isfinite(amplitude) and amplitude >= 0):
        raise ValueError(f"amplitude={amplitude!r} is outside its valid range [0, inf) m")
    if not (math.isfinite(sigma) and sigma >= 0):
        raise ValueError(f"sigma={sigma!r} is outside its valid range [0, inf) m")
    normals = np.asarray(normals, dtype=float)
    z = normals.size
    wave = np.sin(2.0 * math.pi * np.arange(z) / z + phase)
    e = sigma * normals
    scatter = e - e[0]  # written as in version 1, so earlier realisations stay bit-identical
    if amplitude_reading == "sine":
        return amplitude * wave + scatter

    def largest(a: float) -> float:
        return float(np.max(np.abs(a * wave + scatter))) - amplitude

    if largest(0.0) >= 0.0:
        return scatter
    # max|a wave + scatter| is convex in a and below the target at 0: one crossing in (0, hi]
    hi = amplitude / max(float(np.max(np.abs(wave))), 1e-300) + float(np.max(np.abs(scatter)))
    a = brentq(largest, 0.0, hi, xtol=1e-15 * max(amplitude, 1e-300), rtol=4 * np.finfo(float).eps)
    return a * wave + scatter


def pitch_germ_dimension(z: int, n_harmonics: int | None = None) -> int:
    """Number of standard normals of one gear's pitch-deviation germ.

    Harmonics ``m = 1..M`` of the tooth index carry a cosine and a sine coefficient, except
    ``m = z/2`` (even ``z``), whose sine vanishes on the teeth: ``M = z // 2`` (the full
    germ) gives ``z - 1`` normals, exactly the degrees of freedom of ``z`` cumulative
    deviations with their mean removed.

    Parameters
    ----------
    z : int
        Number of teeth (>= 5).
    n_harmonics : int or None
        Harmonics kept ``M`` in ``1..z // 2``; ``None``: all (``z // 2``).
    """
    if int(z) != z or z < 5:
        raise ValueError(f"z={z!r} is outside its valid range: integers >= 5")
    top = int(z) // 2
    M = top if n_harmonics is None else n_harmonics
    if int(M) != M or not 1 <= M <= top:
        raise ValueError(f"pitch_harmonics={n_harmonics!r} (germ harmonics of a gear with "
                         f"z={z} teeth) is outside its valid range: integers 1..{top}")
    M = int(M)
    return 2 * M - (1 if 2 * M == z else 0)


def pitch_germ_scales(z: int, *, amplitude: float, sigma: float) -> np.ndarray:
    """Standard deviations of the ``z - 1`` Fourier coefficients of the full germ [m].

    The model of Yuan, Liu and Liu (Applied Sciences 2020, Sec. 3) is a once-per-revolution
    sine of amplitude ``A`` plus independent normal tooth scatter of standard deviation
    ``sigma``. Written as a Gaussian field over the teeth, the sine becomes a first harmonic
    with independent normal cosine and sine coefficients of standard deviation
    ``A / sqrt(2)`` (the mean square ``A^2 / 2`` of the sine of fixed amplitude and uniform
    phase); the scatter, white over the ``z`` teeth with its mean removed, puts the variance
    ``2 sigma^2 / z`` on every cosine and sine coefficient (``sigma^2 / z`` on the
    alternating harmonic ``z / 2``).
    Order: ``cos 1, sin 1, cos 2, sin 2, ...``.
    """
    if not (math.isfinite(amplitude) and amplitude >= 0):
        raise ValueError(f"amplitude={amplitude!r} is outside its valid range [0, inf) m")
    if not (math.isfinite(sigma) and sigma >= 0):
        raise ValueError(f"sigma={sigma!r} is outside its valid range [0, inf) m")
    n = pitch_germ_dimension(z)
    var = np.full(n, 2.0 * sigma**2 / z)
    if z % 2 == 0:
        var[-1] = sigma**2 / z
    var[:2] += 0.5 * amplitude**2
    return np.sqrt(var)


def pitch_germ_energy_fraction(z: int, n_harmonics: int, *, amplitude: float,
                               sigma: float) -> float:
    """Share of the mean-square cumulative pitch deviation kept by ``n_harmonics``.

    ``1 -`` this is the relative mean-square truncation error of the germ (the dropped
    coefficients are independent of the kept ones).
    """
    # mean square over the teeth: cos^2 and sin^2 average 1/2, (-1)^k squared is 1
    s2 = 0.5 * pitch_germ_scales(z, amplitude=amplitude, sigma=sigma) ** 2
    if z % 2 == 0:
        s2[-1] *= 2.0
    total = float(s2.sum())
    if total == 0.0:
        return 1.0
    return float(s2[:pitch_germ_dimension(z, n_harmonics)].sum() / total)


def cumulative_pitch_from_normals(
    xi: np.ndarray, z: int, *, amplitude: float, sigma: float
) -> np.ndarray:
    """Cumulative pitch deviations of one gear as a smooth function of standard normals [m].

    ``F_p,k = sum_c s_c xi_c phi_c(k)`` with ``phi = cos(2 pi m k / z), sin(2 pi m k / z)``
    for ``m = 1, 2, ...`` (:func:`pitch_germ_scales` gives ``s_c``). With ``xi`` independent
    standard normals and all ``z - 1`` of them, ``F_p`` has the covariance of the paper's
    sine-plus-scatter model with the sine phase randomised and the tooth mean removed (a
    common shift of all teeth of one gear turns it rigidly and changes no mesh quantity but
    the mean transmission error). Fewer normals truncate the expansion after the harmonic
    they complete (:func:`pitch_germ_energy_fraction`). ``xi = 0``: no deviation.

    Parameters
    ----------
    xi : array_like, (n,)
        Germ, ``1 <= n <= z - 1`` (``n`` from :func:`pitch_germ_dimension`).
    z : int
        Number of teeth.
    amplitude, sigma : float
        Sine amplitude and scatter standard deviation of the paper's model [m].
    """
    xi = np.asarray(xi, dtype=float).ravel()
    full = pitch_germ_dimension(z)
    if not 1 <= xi.size <= full:
        raise ValueError(f"pitch germ dimension {xi.size} is outside its valid range "
                         f"1..{full} for a gear with z={z} teeth")
    if not np.all(np.isfinite(xi)):
        raise ValueError("pitch germ contains non-finite values; valid range (-inf, inf)")
    s = pitch_germ_scales(z, amplitude=amplitude, sigma=sigma)[:xi.size]
    basis = np.ascontiguousarray(pitch_germ_basis(z, xi.size).T)
    return basis @ (s * xi)


def pitch_germ_basis(z: int, n: int) -> np.ndarray:
    """The shapes of the germ's first ``n`` normals over the ``z`` teeth, ``(n, z)``.

    Row ``c`` is ``cos(2 pi m k / z)`` for even ``c`` and ``sin`` for odd, ``m = c // 2 + 1``,
    ``k = 0..z-1``: a batch of germs ``xi`` ``(N, n)`` gives the cumulative pitch deviations
    ``(xi * s) @ basis`` with ``s`` of :func:`pitch_germ_scales`
    (:func:`cumulative_pitch_from_normals` for one germ).
    """
    k, c = np.arange(int(z)), np.arange(int(n))
    arg = 2.0 * math.pi * np.outer(c // 2 + 1, k) / z
    return np.where((c % 2 == 0)[:, None], np.cos(arg), np.sin(arg))


#: Parameter-name prefixes of the pinion and wheel germs: ``pitch_xi_p_1``, ``pitch_xi_g_1``.
PITCH_GERM_PREFIXES = ("pitch_xi_p_", "pitch_xi_g_")


def pitch_germ_names(z: int, gear: int) -> list[str]:
    """Parameter names of the full germ of the pinion (``gear=1``) or the wheel (``gear=2``).

    ``pitch_xi_p_1 .. pitch_xi_p_{z-1}`` in the order of :func:`pitch_germ_scales`
    (``_1``, ``_2``: cosine and sine of the once-per-revolution harmonic, and so on).
    """
    prefix = PITCH_GERM_PREFIXES[int(gear) - 1]
    return [f"{prefix}{i}" for i in range(1, pitch_germ_dimension(z) + 1)]


def pitch_germ_from_values(values: dict[str, float], z: int, gear: int,
                           n_harmonics: int | None = None) -> np.ndarray:
    """The kept germ of one gear from a parameter dict (missing names count as 0).

    Raises ValueError when ``n_harmonics`` is out of range or when a dropped coefficient is
    non-zero (a truncated germ cannot represent it; sample only the kept names).
    """
    n = pitch_germ_dimension(z, n_harmonics)
    names = pitch_germ_names(z, gear)
    xi = np.array([float(values.get(k, 0.0)) for k in names])
    dropped = np.flatnonzero(xi[n:] != 0.0)
    if dropped.size:
        k = names[n + dropped[0]]
        raise ValueError(
            f"{k}={float(xi[n + dropped[0]])!r} is outside the germ kept by pitch_harmonics="
            f"{n_harmonics} (valid: {names[0]}..{names[n - 1]}; the others must be 0)")
    return xi[:n]


def pitch_deviation_germ(
    z1: int, z2: int, seed: int | np.random.Generator | None
) -> tuple[float, np.ndarray, float, np.ndarray]:
    """The random germ ``(phase1, normals1, phase2, normals2)`` of a pinion/wheel realisation.

    Drawn in this order from ``numpy.random.default_rng(seed)``: pinion phase (uniform in
    [0, 2 pi)), ``z1`` standard normals, wheel phase, ``z2`` standard normals. This is the
    order in which two calls of :func:`random_cumulative_pitch_deviations` on one generator
    draw, so both give the same realisation for the same seed.
    """
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    phase1 = float(rng.uniform(0.0, 2.0 * math.pi))
    normals1 = rng.standard_normal(int(z1))
    phase2 = float(rng.uniform(0.0, 2.0 * math.pi))
    normals2 = rng.standard_normal(int(z2))
    return phase1, normals1, phase2, normals2


def random_cumulative_pitch_deviations(
    z: int,
    *,
    amplitude: float = 15e-6,
    sigma: float = 3e-6,
    phase: float | None = None,
    seed: int | np.random.Generator | None = 0,
    accuracy_grade: int | None = None,
    d: float | None = None,
    mn: float | None = None,
    amplitude_reading: str = "sine",
) -> np.ndarray:
    """Return random cumulative pitch deviations ``F_p,k``, k = 0..z-1 [m] (Yuan et al. (2020),
    Sec. 3).

    ``F_p,k = A sin(2 pi k / z + phase) + e_k - e_0``, ``e_k ~ N(0, sigma^2)`` i.i.d.:
    a once-per-revolution sine (run-out-like) plus normal scatter; tooth 0 is the reference
    (``F_p,0 = A sin(phase)``, the scatter is referenced to it). ``A`` follows from
    ``amplitude`` by ``amplitude_reading`` (:func:`cumulative_pitch_from_germ`).

    Parameters
    ----------
    z : int
        Number of teeth (>= 5).
    amplitude, sigma : float, optional
        The sine amplitude and the scatter standard deviation [m] (Yuan et al. (2020): 15 um,
        3 um).
    phase : float or None, optional
        Sine phase [rad]; ``None`` draws it uniformly from the generator.
    seed : int, Generator or None, optional
        Reproducibility: same seed, same deviations. The generator draws the phase (when
        not given) and then ``z`` standard normals, whatever ``sigma`` is.
    accuracy_grade : int or None, optional
        ISO 1328-1:2013 flank tolerance class 1-11: overrides ``amplitude = F_pT / 2`` (the
        sine spans the total cumulative tolerance) and ``sigma = f_pT / (3 sqrt(2))`` (single
        pitch deviations, the differences of two scatters, stay within ``f_pT`` at 3 sigma).
        Needs ``d``, ``mn``.
    d, mn : float or None, optional
        Reference diameter and normal module [m] for ``accuracy_grade``.
    amplitude_reading : {"sine", "largest"}, optional
        How ``amplitude`` is read (docs/theory/ltca.md, Sec. 5).

    Returns
    -------
    ndarray, (z,)
        ``F_p,k`` [m], tangential on the reference circle.
    """
    if int(z) != z or z < 5:
        raise ValueError(f"z={z!r} is outside its valid range: integers >= 5")
    if accuracy_grade is not None:
        if d is None or mn is None:
            raise ValueError("accuracy_grade needs d and mn (reference diameter, module) in m")
        f_pT, F_pT = iso1328_pitch_tolerances(d, mn, accuracy_grade)
        amplitude, sigma = 0.5 * F_pT, f_pT / (3.0 * math.sqrt(2.0))
    if not (math.isfinite(amplitude) and amplitude >= 0):
        raise ValueError(f"amplitude={amplitude!r} is outside its valid range [0, inf) m")
    if not (math.isfinite(sigma) and sigma >= 0):
        raise ValueError(f"sigma={sigma!r} is outside its valid range [0, inf) m")
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    ph = rng.uniform(0.0, 2.0 * math.pi) if phase is None else float(phase)
    normals = rng.standard_normal(int(z))
    return cumulative_pitch_from_germ(ph, normals, amplitude=amplitude, sigma=sigma,
                                      amplitude_reading=amplitude_reading)


def _relief(u: np.ndarray, amount: float, length: float) -> np.ndarray:
    """Parabolic relief ``amount ((length - u)/length)^2`` for ``0 <= u <= length``, else 0.

    ``u`` is the distance from the end of the path of contact (Yuan et al. Eq. 12).
    """
    if amount == 0.0 or length <= 0.0:
        return np.zeros_like(u)
    return np.where(u < length, amount * ((length - np.clip(u, 0.0, None)) / length) ** 2, 0.0)


@dataclass(frozen=True)
class FlankDeviations:
    """Errors and modifications of both gears, turned into normal clearances ``xi``.

    Parameters
    ----------
    Fp1, Fp2 : array_like or None
        Cumulative pitch deviations of pinion (``z1`` values) and wheel (``z2``) [m],
        tangential on the reference circle, teeth numbered in the order they enter mesh.
    tip_relief1, tip_relief2 : tuple (amount, length) or None
        Parabolic tip relief of pinion / wheel: amount [m] (transverse, along the line of
        action) and length along the path of contact [m] from the tip end (``s_E`` for the
        pinion, ``s_A`` for the wheel).
    root_relief1, root_relief2 : tuple (amount, length) or None
        Parabolic root relief (pinion root at ``s_A``, wheel root at ``s_E``).
    crowning : float
        Lead crowning ``C_b`` [m] (sum over both gears), ``C_b (2 y / b - 1)^2``.
    user : callable or None
        ``user(s, y, k1, k2) -> xi`` [m], extra normal clearance (already in the normal
        direction) for points ``(s, y)`` of pinion tooth ``k1`` and wheel tooth ``k2``.
    """

    Fp1: np.ndarray | None = None
    Fp2: np.ndarray | None = None
    tip_relief1: tuple[float, float] | None = None
    tip_relief2: tuple[float, float] | None = None
    root_relief1: tuple[float, float] | None = None
    root_relief2: tuple[float, float] | None = None
    crowning: float = 0.0
    user: Callable[..., np.ndarray] | None = None

    @classmethod
    def symmetric_tip_relief(cls, amount: float, length: float, **kw: object) -> FlankDeviations:
        """Yuan, Liu and Liu (2020) Eq. 12: the same parabolic tip relief on pinion and wheel."""
        return cls(tip_relief1=(amount, length), tip_relief2=(amount, length), **kw)

    @property
    def has_errors(self) -> bool:
        """Whether any tooth differs from the others (pitch deviations or a user map)."""
        return self.Fp1 is not None or self.Fp2 is not None or self.user is not None

    def design_only(self) -> FlankDeviations:
        """The designed modifications alone (reliefs, crowning): the same on every tooth."""
        return FlankDeviations(tip_relief1=self.tip_relief1, tip_relief2=self.tip_relief2,
                               root_relief1=self.root_relief1, root_relief2=self.root_relief2,
                               crowning=self.crowning)

    def validate(self, pair: HelicalGearPair) -> None:
        """Raise ValueError naming the field when an array has the wrong length or a value
        is outside its valid range."""
        for name, z in (("Fp1", pair.z1), ("Fp2", pair.z2)):
            v = getattr(self, name)
            if v is None:
                continue
            arr = np.asarray(v, dtype=float)
            if arr.shape != (z,):
                raise ValueError(
                    f"{name} has shape {arr.shape}, valid: ({z},) (one value per tooth, z={z})"
                )
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"{name} contains non-finite values; valid range (-inf, inf) m")
        for name in ("tip_relief1", "tip_relief2", "root_relief1", "root_relief2"):
            v = getattr(self, name)
            if v is None:
                continue
            if len(v) != 2:
                raise ValueError(f"{name}={v!r} must be (amount [m], length [m])")
            amount, length = float(v[0]), float(v[1])
            if not (math.isfinite(amount) and amount >= 0):
                raise ValueError(f"{name} amount={amount!r} is outside its valid range [0, inf) m")
            if not (math.isfinite(length) and 0 <= length <= pair.g_alpha):
                raise ValueError(
                    f"{name} length={length!r} is outside its valid range "
                    f"[0, g_alpha={pair.g_alpha!r}] m"
                )
        if not math.isfinite(self.crowning):
            raise ValueError(f"crowning={self.crowning!r} is outside its valid range (-inf, inf)")

    def clearance(
        self,
        pair: HelicalGearPair,
        kin: MeshKinematics,
        s: np.ndarray,
        y: np.ndarray,
        k1: np.ndarray,
        k2: np.ndarray,
    ) -> np.ndarray:
        """Return the initial normal clearance ``xi`` [m] at points ``(s, y)``.

        ``k1``, ``k2`` are the pinion and wheel tooth numbers of each point (broadcastable).
        """
        cb = kin.cos_bb
        xi = np.zeros(np.broadcast_shapes(s.shape, np.shape(k1)))
        conv = math.cos(pair.alpha_t) * cb  # Yuan et al. Eq. 2
        if self.Fp1 is not None:
            xi = xi + np.asarray(self.Fp1, dtype=float)[k1] * conv
        if self.Fp2 is not None:
            xi = xi + np.asarray(self.Fp2, dtype=float)[k2] * conv
        prof = np.zeros_like(s)
        if self.tip_relief1 is not None:
            prof = prof + _relief(kin.s_E - s, *self.tip_relief1)
        if self.tip_relief2 is not None:
            prof = prof + _relief(s - kin.s_A, *self.tip_relief2)
        if self.root_relief1 is not None:
            prof = prof + _relief(s - kin.s_A, *self.root_relief1)
        if self.root_relief2 is not None:
            prof = prof + _relief(kin.s_E - s, *self.root_relief2)
        if self.crowning:
            prof = prof + self.crowning * (2.0 * y / kin.b - 1.0) ** 2
        xi = xi + prof * cb
        if self.user is not None:
            xi = xi + np.asarray(self.user(s, y, k1, k2), dtype=float)
        return xi


# ---------------------------------------------------------------- laws of production
#: Laws of the pitch deviations of a gear of an ISO 1328 class (plugin option
#: ``pitch_tolerance_law``): ``"untruncated_iso"`` reads the class as the germ model's scale
#: (sine amplitude F_pT / 2, scatter f_pT / (3 sqrt 2)): about half of such gears exceed
#: F_pT, i.e. would be rejected; ``"capable_process"`` scales that law so that a stated share
#: of the process exceeds F_pT; inspection (F_p <= F_pT) then removes those gears, an event
#: the reliability engines handle as a limit state (docs/reliability.md).
PITCH_TOLERANCE_LAWS = ("untruncated_iso", "capable_process")


def total_cumulative_pitch_deviation(Fp: np.ndarray) -> np.ndarray:
    """ISO 1328-1 total cumulative pitch deviation ``F_p = max_k F_p,k - min_k F_p,k`` [m].

    ``Fp``: cumulative deviations over the teeth on the last axis (any leading shape).
    """
    Fp = np.asarray(Fp, dtype=float)
    return Fp.max(axis=-1) - Fp.min(axis=-1)


@lru_cache(maxsize=64)
def _unit_total_deviation_quantile(z: int, ratio: float, share: float, n_draws: int,
                                   seed: int) -> float:
    xi = np.random.default_rng(seed).standard_normal((n_draws, pitch_germ_dimension(z)))
    scales = pitch_germ_scales(z, amplitude=1.0, sigma=ratio)
    Fp = (xi * scales) @ pitch_germ_basis(z, scales.size)
    return float(np.quantile(total_cumulative_pitch_deviation(Fp), 1.0 - share))


def capable_pitch_scatter(z: int, f_pT: float, F_pT: float, share_beyond: float, *,
                          n_draws: int = 200_000, seed: int = 1328) -> tuple[float, float]:
    """Sine amplitude and scatter ``(A, sigma)`` [m] of a process with a share beyond F_pT.

    The germ model of :func:`cumulative_pitch_from_normals` with ISO's shape (``sigma / A =
    (f_pT / (3 sqrt 2)) / (F_pT / 2)``, as the class reading of ``"untruncated_iso"``),
    scaled so that ``P(F_p > F_pT) = share_beyond`` before inspection. ``F_p`` is positively
    homogeneous in ``(A, sigma)``, so the scale is ``F_pT`` over the ``1 - share_beyond``
    quantile of ``F_p`` at unit amplitude, estimated once from ``n_draws`` germs of a fixed
    ``seed`` (the relative error of the quantile is about
    ``sqrt(p (1 - p) / n) / (q f(q))``: 0.3 % at p = 0.05 with the defaults).

    Parameters
    ----------
    z : int
        Number of teeth.
    f_pT, F_pT : float
        Single and total cumulative pitch tolerances [m] (:func:`iso1328_pitch_tolerances`).
    share_beyond : float
        Share of the process beyond ``F_pT`` (rejected at inspection), in (0, 0.5].
    """
    if not 0.0 < share_beyond <= 0.5:
        raise ValueError(f"share_beyond={share_beyond!r} is outside its valid range (0, 0.5]")
    for name, value in (("f_pT", f_pT), ("F_pT", F_pT)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name}={value!r} is outside its valid range (0, inf) m")
    amplitude, sigma = 0.5 * F_pT, f_pT / (3.0 * math.sqrt(2.0))
    q = _unit_total_deviation_quantile(int(z), sigma / amplitude, float(share_beyond),
                                       int(n_draws), int(seed))
    scale = F_pT / (q * amplitude)
    return amplitude * scale, sigma * scale


def inspected_normal_spec(nominal: float, tolerance: float, share_beyond: float) -> dict:
    """Parameter-space spec of an inspected quantity: a capable normal process truncated.

    The process is normal about ``nominal`` with the standard deviation that puts
    ``share_beyond`` outside ``nominal +- tolerance`` (``sigma = tolerance /
    Phi^-1(1 - share_beyond / 2)``); inspection removes those parts, so the accepted parts
    follow the normal truncated to the tolerance band (``{"dist": "truncnormal", ...}`` of
    :class:`gearuq.space.ParameterSpace`).
    """
    from scipy.stats import norm

    if not 0.0 < share_beyond < 1.0:
        raise ValueError(f"share_beyond={share_beyond!r} is outside its valid range (0, 1)")
    if not (math.isfinite(tolerance) and tolerance > 0):
        raise ValueError(f"tolerance={tolerance!r} is outside its valid range (0, inf)")
    if not math.isfinite(nominal):
        raise ValueError(f"nominal={nominal!r} is outside its valid range (-inf, inf)")
    sigma = tolerance / float(norm.ppf(1.0 - 0.5 * share_beyond))
    return {"dist": "truncnormal", "mean": float(nominal), "std": sigma,
            "lower": float(nominal - tolerance), "upper": float(nominal + tolerance)}
