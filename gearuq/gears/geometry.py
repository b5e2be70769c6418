"""Involute geometry of an external cylindrical helical gear pair (ISO 21771 notation).

All inputs and outputs of the public API are SI: lengths in metres, angles in radians.
The formulas, their sources and the choices made are in ``docs/theory/gear_geometry.md``.

Main entry points
-----------------
:class:`HelicalGearPair`
    Frozen dataclass built from the basic data of the pair; every derived quantity is a
    property, and construction validates the data (``ValueError`` naming the parameter).
:func:`seed000_pair`, :func:`seed002_pair`, :func:`iso_tr_6336_30_example1`
    The built-in pairs of the three papers gearuq's models follow and of ISO/TR 6336-30:2017,
    Example 1.
:func:`involute`, :func:`inverse_involute`
    ``inv(alpha) = tan(alpha) - alpha`` and its inverse on ``[0, pi/2)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from scipy.optimize import brentq

__all__ = [
    "HelicalGearPair",
    "involute",
    "inverse_involute",
    "iso_tr_6336_30_example1",
    "seed000_pair",
    "seed002_pair",
]

_DEG = math.pi / 180.0


def involute(alpha: float) -> float:
    """Return the involute function ``inv(alpha) = tan(alpha) - alpha``.

    Parameters
    ----------
    alpha : float
        Pressure angle in radians, ``0 <= alpha < pi/2``.

    Returns
    -------
    float
        ``tan(alpha) - alpha`` in radians.
    """
    return math.tan(alpha) - alpha


def inverse_involute(value: float, *, tol: float = 1e-15, max_iter: int = 50) -> float:
    """Return the angle ``alpha`` in ``[0, pi/2)`` with ``inv(alpha) = value``.

    Newton's method on ``f(alpha) = tan(alpha) - alpha - value`` (``f' = tan^2(alpha)``),
    started from the series inverse ``alpha0 = (3 value)^(1/3)``; if Newton does not
    converge (it always does for gear angles), the root is bracketed and found by brentq.

    Parameters
    ----------
    value : float
        Involute value in radians, ``>= 0``.
    tol : float, optional
        Absolute tolerance on ``alpha``.
    max_iter : int, optional
        Newton iterations before the brentq fallback.

    Returns
    -------
    float
        The angle in radians.

    Raises
    ------
    ValueError
        If ``value`` is negative or not finite.
    """
    if not math.isfinite(value) or value < 0.0:
        raise ValueError(f"inverse_involute: value={value!r} must be finite and >= 0")
    if value == 0.0:
        return 0.0
    alpha = min((3.0 * value) ** (1.0 / 3.0), 1.5)
    for _ in range(max_iter):
        t = math.tan(alpha)
        step = (t - alpha - value) / (t * t)
        alpha_new = alpha - step
        if not 0.0 < alpha_new < math.pi / 2:
            break
        if abs(alpha_new - alpha) <= tol:
            return alpha_new
        alpha = alpha_new
    upper = math.pi / 2 - 1e-12
    return brentq(lambda a: involute(a) - value, 0.0, upper, xtol=tol, maxiter=500)


def _check_range(name: str, value: float, lo: float, hi: float, text: str) -> None:
    """Raise a ValueError naming ``name`` unless ``lo < value < hi`` (bounds open)."""
    if not (math.isfinite(value) and lo < value < hi):
        raise ValueError(f"{name}={value!r} is outside its valid range {text}")


@dataclass(frozen=True)
class HelicalGearPair:
    """External cylindrical involute helical gear pair with parallel axes.

    Gear 1 is the pinion (driving), gear 2 the wheel. Notation follows ISO 21771 and
    ISO 6336-1; SI units throughout (metres, radians).

    Parameters
    ----------
    mn : float
        Normal module [m], > 0.
    z1, z2 : int
        Numbers of teeth, >= 5 (external gears only).
    alpha_n : float
        Normal pressure angle at the reference cylinder [rad], in (0, 45 deg).
    beta : float
        Helix angle at the reference cylinder [rad], in [0, 45 deg) (0 gives a spur pair).
    b1, b2 : float
        Face widths of pinion and wheel [m], > 0.
    x1, x2 : float, optional
        Profile shift coefficients (ISO 21771 sign convention), default 0.
    ha_star : float, optional
        Addendum factor of the basic rack, ``h_aP / mn`` (ISO 53 profile A: 1.0).
    hf_star : float, optional
        Dedendum factor of the basic rack, ``h_fP / mn`` (ISO 53 A: 1.25, i.e. c* = 0.25).
    rho_f_star : float, optional
        Root fillet radius factor of the basic rack, ``rho_fP / mn`` (ISO 53 A: 0.38).
    a : float or None, optional
        Working centre distance [m]. ``None``: the zero-backlash centre distance for
        ``x1 + x2`` (working pressure angle from the involute equation).
    b : float or None, optional
        Effective (common) face width [m]; ``None`` gives ``min(b1, b2)``.
    tip_diameters : tuple of float or None, optional
        Tip diameters ``(da1, da2)`` [m] when they are not the nominal
        ``d + 2 mn (ha_star + x)`` (e.g. with tip shortening).

    Raises
    ------
    ValueError
        When a value is outside its valid range, the pinion or wheel is undercut, the tip
        is pointed, the wheel tip interferes below the pinion base circle (or vice versa),
        or the transverse contact ratio is below 1. The message names the parameter, its
        value and the valid range.

    Notes
    -----
    Derived quantities are properties; they are cheap closed-form expressions except the
    working pressure angle, which needs one inverse-involute solve when ``a`` is not given.
    """

    mn: float
    z1: int
    z2: int
    alpha_n: float
    beta: float
    b1: float
    b2: float
    x1: float = 0.0
    x2: float = 0.0
    ha_star: float = 1.0
    hf_star: float = 1.25
    rho_f_star: float = 0.38
    a: float | None = None
    b: float | None = None
    tip_diameters: tuple[float, float] | None = None

    # ------------------------------------------------------------------ validation
    def __post_init__(self) -> None:
        for name in ("z1", "z2"):
            z = getattr(self, name)
            if isinstance(z, bool) or int(z) != z:
                raise ValueError(
                    f"{name}={z!r} is not an integer number of teeth; valid range: "
                    "integers in [5, inf)"
                )
            if z < 5:
                raise ValueError(
                    f"{name}={z!r} is outside its valid range [5, inf) "
                    "(external gears only; ISO 6336 covers z >= 5)"
                )
        _check_range("mn", self.mn, 0.0, math.inf, "(0, inf) m")
        _check_range("alpha_n", self.alpha_n, 0.0, 45.0 * _DEG, "(0, 45 deg) = (0, 0.7854) rad")
        if not (math.isfinite(self.beta) and 0.0 <= self.beta < 45.0 * _DEG):
            raise ValueError(
                f"beta={self.beta!r} is outside its valid range [0, 45 deg) = [0, 0.7854) rad"
            )
        for name in ("b1", "b2"):
            _check_range(name, getattr(self, name), 0.0, math.inf, "(0, inf) m")
        if self.b is not None:
            _check_range(
                "b",
                self.b,
                0.0,
                min(self.b1, self.b2) * (1 + 1e-12),
                f"(0, min(b1, b2)] = (0, {min(self.b1, self.b2)!r}] m",
            )
        for name in ("x1", "x2"):
            _check_range(name, getattr(self, name), -3.0, 3.0, "(-3, 3)")
        _check_range("ha_star", self.ha_star, 0.0, 3.0, "(0, 3)")
        _check_range("hf_star", self.hf_star, 0.0, 3.0, "(0, 3)")
        if not (math.isfinite(self.rho_f_star) and 0.0 <= self.rho_f_star < 1.0):
            raise ValueError(f"rho_f_star={self.rho_f_star!r} is outside its valid range [0, 1)")
        if self.a is not None:
            _check_range("a", self.a, 0.0, math.inf, "(0, inf) m")
            ratio = self.a0 * math.cos(self.alpha_t) / self.a
            if ratio >= 1.0:
                raise ValueError(
                    f"a={self.a!r} m is outside its valid range "
                    f"({self.a0 * math.cos(self.alpha_t)!r}, inf) m "
                    "(a cos(alpha_wt) = a0 cos(alpha_t) needs a > a0 cos(alpha_t))"
                )
        if self.tip_diameters is not None:
            if len(self.tip_diameters) != 2:
                raise ValueError(
                    f"tip_diameters={self.tip_diameters!r} must be a pair (da1, da2) in m"
                )
            for i, (da, db) in enumerate(
                zip(self.tip_diameters, (self.db1, self.db2), strict=True), 1
            ):
                _check_range(
                    f"tip_diameters[{i - 1}] (da{i})", da, db, math.inf, f"(db{i}={db!r}, inf) m"
                )
        # undercut (ISO 21771 generating-rack limit, see x_min)
        for i, (x, x_min) in enumerate(((self.x1, self.x_min1), (self.x2, self.x_min2)), 1):
            if x < x_min - 1e-12:
                raise ValueError(
                    f"x{i}={x!r} is outside its valid range [x_min{i}={x_min:.5f}, inf): "
                    f"gear {i} (z{i}={getattr(self, f'z{i}')}) is undercut"
                )
        # pointed tips
        for i, sa in enumerate((self.sa1, self.sa2), 1):
            if sa <= 0.0:
                raise ValueError(
                    f"x{i}={getattr(self, f'x{i}')!r} gives a pointed tip on gear {i}: "
                    f"transverse tip thickness sa{i}={sa!r} m, valid range (0, inf) m"
                )
        # tip of one gear reaching below the base circle of the other (involute interference)
        if self.g_f1 < 0.0 or self.g_f2 < 0.0:
            which = 1 if self.g_f1 < 0.0 else 2
            raise ValueError(
                f"z{3 - which}/x{3 - which}: the tip of gear {3 - which} reaches below the "
                f"base circle of gear {which} (g_f{which}="
                f"{min(self.g_f1, self.g_f2)!r} m, valid range [0, inf) m)"
            )
        if self.eps_alpha < 1.0:
            raise ValueError(
                f"eps_alpha={self.eps_alpha!r} (transverse contact ratio from z1, z2, mn, "
                f"alpha_n, beta, x1, x2, ha_star, a) is outside its valid range [1, inf)"
            )

    # ------------------------------------------------------------------ basic transverse data
    @property
    def u(self) -> float:
        """Gear ratio ``z2 / z1`` [-]."""
        return self.z2 / self.z1

    @property
    def mt(self) -> float:
        """Transverse module ``mn / cos(beta)`` [m]."""
        return self.mn / math.cos(self.beta)

    @property
    def alpha_t(self) -> float:
        """Transverse pressure angle ``atan(tan(alpha_n) / cos(beta))`` [rad]."""
        return math.atan(math.tan(self.alpha_n) / math.cos(self.beta))

    @property
    def beta_b(self) -> float:
        """Base helix angle ``atan(tan(beta) cos(alpha_t))`` [rad]."""
        return math.atan(math.tan(self.beta) * math.cos(self.alpha_t))

    @property
    def face_width(self) -> float:
        """Effective face width ``b`` (``min(b1, b2)`` unless given) [m]."""
        return min(self.b1, self.b2) if self.b is None else self.b

    # ------------------------------------------------------------------ diameters
    @property
    def d1(self) -> float:
        """Pinion reference diameter ``z1 mt`` [m]."""
        return self.z1 * self.mt

    @property
    def d2(self) -> float:
        """Wheel reference diameter ``z2 mt`` [m]."""
        return self.z2 * self.mt

    @property
    def db1(self) -> float:
        """Pinion base diameter ``d1 cos(alpha_t)`` [m]."""
        return self.d1 * math.cos(self.alpha_t)

    @property
    def db2(self) -> float:
        """Wheel base diameter ``d2 cos(alpha_t)`` [m]."""
        return self.d2 * math.cos(self.alpha_t)

    @property
    def da1(self) -> float:
        """Pinion tip diameter ``d1 + 2 mn (ha_star + x1)`` unless given [m]."""
        if self.tip_diameters is not None:
            return float(self.tip_diameters[0])
        return self.d1 + 2.0 * self.mn * (self.ha_star + self.x1)

    @property
    def da2(self) -> float:
        """Wheel tip diameter ``d2 + 2 mn (ha_star + x2)`` unless given [m]."""
        if self.tip_diameters is not None:
            return float(self.tip_diameters[1])
        return self.d2 + 2.0 * self.mn * (self.ha_star + self.x2)

    @property
    def df1(self) -> float:
        """Pinion root diameter ``d1 - 2 mn (hf_star - x1)`` [m]."""
        return self.d1 - 2.0 * self.mn * (self.hf_star - self.x1)

    @property
    def df2(self) -> float:
        """Wheel root diameter ``d2 - 2 mn (hf_star - x2)`` [m]."""
        return self.d2 - 2.0 * self.mn * (self.hf_star - self.x2)

    @property
    def dw1(self) -> float:
        """Pinion working pitch diameter ``db1 / cos(alpha_wt)`` [m]."""
        return self.db1 / math.cos(self.alpha_wt)

    @property
    def dw2(self) -> float:
        """Wheel working pitch diameter ``db2 / cos(alpha_wt)`` [m]."""
        return self.db2 / math.cos(self.alpha_wt)

    # ------------------------------------------------------------------ centre distance
    @property
    def a0(self) -> float:
        """Reference centre distance ``(d1 + d2) / 2`` [m]."""
        return 0.5 * (self.d1 + self.d2)

    @property
    def alpha_wt(self) -> float:
        """Working transverse pressure angle [rad].

        From the given centre distance, ``cos(alpha_wt) = a0 cos(alpha_t) / a``; otherwise
        from ``inv(alpha_wt) = inv(alpha_t) + 2 tan(alpha_n) (x1 + x2) / (z1 + z2)``.
        """
        if self.a is not None:
            return math.acos(self.a0 * math.cos(self.alpha_t) / self.a)
        inv_wt = involute(self.alpha_t) + 2.0 * math.tan(self.alpha_n) * (self.x1 + self.x2) / (
            self.z1 + self.z2
        )
        return inverse_involute(inv_wt)

    @property
    def centre_distance(self) -> float:
        """Working centre distance ``a`` [m] (given, or ``a0 cos(alpha_t)/cos(alpha_wt)``)."""
        if self.a is not None:
            return float(self.a)
        return self.a0 * math.cos(self.alpha_t) / math.cos(self.alpha_wt)

    @property
    def x_sum_zero_backlash(self) -> float:
        """Sum of profile shifts that would mesh without backlash at ``centre_distance``."""
        return (
            (involute(self.alpha_wt) - involute(self.alpha_t))
            * (self.z1 + self.z2)
            / (2.0 * math.tan(self.alpha_n))
        )

    # ------------------------------------------------------------------ pitches
    @property
    def pt(self) -> float:
        """Transverse pitch ``pi mt`` [m]."""
        return math.pi * self.mt

    @property
    def pbt(self) -> float:
        """Transverse base pitch ``pi mt cos(alpha_t)`` [m]."""
        return math.pi * self.mt * math.cos(self.alpha_t)

    @property
    def pbn(self) -> float:
        """Normal base pitch ``pi mn cos(alpha_n)`` [m] (= ``pbt cos(beta_b)``)."""
        return math.pi * self.mn * math.cos(self.alpha_n)

    @property
    def px(self) -> float:
        """Axial pitch ``pi mn / sin(beta)`` [m] (``inf`` for a spur pair)."""
        s = math.sin(self.beta)
        return math.inf if s == 0.0 else math.pi * self.mn / s

    # ------------------------------------------------------------------ path and ratios
    @property
    def g_a1(self) -> float:
        """Length of path of addendum of the pinion, ``sqrt(da1^2 - db1^2)/2 - a sin(awt)/2``.

        Measured from the pitch point to the pinion's tip (end of contact when the pinion
        drives) [m]. Together with ``g_a2``: ``g_alpha = g_a1 + g_a2``.
        """
        return 0.5 * math.sqrt(self.da1**2 - self.db1**2) - self.db1 / 2 * math.tan(self.alpha_wt)

    @property
    def g_a2(self) -> float:
        """Length of path of addendum of the wheel (pitch point to the wheel's tip) [m]."""
        return 0.5 * math.sqrt(self.da2**2 - self.db2**2) - self.db2 / 2 * math.tan(self.alpha_wt)

    @property
    def g_f1(self) -> float:
        """Distance from the pinion's base-circle tangency point T1 to the start of contact.

        ``a sin(alpha_wt) - sqrt(da2^2 - db2^2)/2`` [m]; negative means the wheel tip
        reaches below the pinion base circle (interference).
        """
        return self.centre_distance * math.sin(self.alpha_wt) - 0.5 * math.sqrt(
            self.da2**2 - self.db2**2
        )

    @property
    def g_f2(self) -> float:
        """Distance from the wheel's tangency point T2 to the end of contact [m]."""
        return self.centre_distance * math.sin(self.alpha_wt) - 0.5 * math.sqrt(
            self.da1**2 - self.db1**2
        )

    @property
    def g_alpha(self) -> float:
        """Length of path of contact (transverse plane) [m].

        ``0.5 [sqrt(da1^2 - db1^2) + sqrt(da2^2 - db2^2)] - a sin(alpha_wt)``.
        """
        return 0.5 * (
            math.sqrt(self.da1**2 - self.db1**2) + math.sqrt(self.da2**2 - self.db2**2)
        ) - self.centre_distance * math.sin(self.alpha_wt)

    @property
    def eps_alpha(self) -> float:
        """Transverse contact ratio ``g_alpha / pbt`` [-]."""
        return self.g_alpha / self.pbt

    @property
    def eps_beta(self) -> float:
        """Overlap ratio ``b sin(beta) / (pi mn)`` [-]."""
        return self.face_width * math.sin(self.beta) / (math.pi * self.mn)

    @property
    def eps_gamma(self) -> float:
        """Total contact ratio ``eps_alpha + eps_beta`` [-]."""
        return self.eps_alpha + self.eps_beta

    # ------------------------------------------------------------------ virtual teeth
    @property
    def zn1(self) -> float:
        """Pinion virtual number of teeth ``z1 / (cos^2(beta_b) cos(beta))`` (ISO 6336-1)."""
        return self.z1 / (math.cos(self.beta_b) ** 2 * math.cos(self.beta))

    @property
    def zn2(self) -> float:
        """Wheel virtual number of teeth ``z2 / (cos^2(beta_b) cos(beta))`` (ISO 6336-1)."""
        return self.z2 / (math.cos(self.beta_b) ** 2 * math.cos(self.beta))

    # ------------------------------------------------------------------ limits
    def _x_min(self, z: int) -> float:
        h_ffp = self.hf_star - self.rho_f_star * (1.0 - math.sin(self.alpha_n))
        return h_ffp - z * math.sin(self.alpha_t) ** 2 / (2.0 * math.cos(self.beta))

    @property
    def x_min1(self) -> float:
        """Smallest undercut-free profile shift of the pinion.

        ``x_min = [hf_star - rho_f_star (1 - sin(alpha_n))] - z sin^2(alpha_t) / (2 cos(beta))``:
        the end of the straight flank of the generating rack (whose addendum is the gear's
        dedendum) must not pass the interference point. For the ISO 53 A rack the bracket is
        1.0000 = ha_star, i.e. the textbook ``ha* - z sin^2(alpha_t)/(2 cos(beta))``.
        """
        return self._x_min(self.z1)

    @property
    def x_min2(self) -> float:
        """Smallest undercut-free profile shift of the wheel (see ``x_min1``)."""
        return self._x_min(self.z2)

    def _tip_thickness(self, z: int, x: float, da: float) -> float:
        d = z * self.mt
        st = self.mt * (math.pi / 2.0 + 2.0 * x * math.tan(self.alpha_n))
        alpha_a = math.acos(d * math.cos(self.alpha_t) / da)
        return da * (st / d + involute(self.alpha_t) - involute(alpha_a))

    @property
    def sa1(self) -> float:
        """Pinion transverse tooth thickness (arc) at the tip circle [m]."""
        return self._tip_thickness(self.z1, self.x1, self.da1)

    @property
    def sa2(self) -> float:
        """Wheel transverse tooth thickness (arc) at the tip circle [m]."""
        return self._tip_thickness(self.z2, self.x2, self.da2)

    # ------------------------------------------------------------------ contact lines
    @property
    def contact_line_length_mean(self) -> float:
        """Mean total length of the lines of contact ``b eps_alpha / cos(beta_b)`` [m]."""
        return self.face_width * self.eps_alpha / math.cos(self.beta_b)

    @property
    def contact_line_length_min(self) -> float:
        """Minimum total length of the lines of contact (no tip relief) [m].

        With ``n_a = frac(eps_alpha)`` and ``n_b = frac(eps_beta)``:
        ``L_min = [eps_alpha b - n_a n_b px] / cos(beta_b)`` if ``n_a <= 1 - n_b`` else
        ``[eps_alpha b - (1 - n_a)(1 - n_b) px] / cos(beta_b)`` (AGMA 908 / ANSI/AGMA 2101).
        For a spur pair it is ``b`` (one pair in contact).
        """
        if self.beta == 0.0:
            return self.face_width
        n_a = self.eps_alpha - math.floor(self.eps_alpha)
        n_b = self.eps_beta - math.floor(self.eps_beta)
        if n_a <= 1.0 - n_b:
            num = self.eps_alpha * self.face_width - n_a * n_b * self.px
        else:
            num = self.eps_alpha * self.face_width - (1.0 - n_a) * (1.0 - n_b) * self.px
        return num / math.cos(self.beta_b)

    # ------------------------------------------------------------------ summary
    def summary(self) -> dict[str, float]:
        """Return the main derived quantities as a flat dict (SI units, radians)."""
        keys = (
            "mt alpha_t beta_b alpha_wt a0 centre_distance d1 d2 db1 db2 da1 da2 df1 df2 "
            "pbt pbn g_alpha eps_alpha eps_beta eps_gamma zn1 zn2 face_width"
        ).split()
        return {k: float(getattr(self, k)) for k in keys}


# ---------------------------------------------------------------------- built-in examples
def seed000_pair() -> HelicalGearPair:
    """Return the helical pair of Li, Hu and Han, Table 1.

    z 34/84, mn 6 mm, beta 17 deg, alpha_n 25 deg (as Table 1 prints it), b1 = b2 = 70 mm,
    x1 = x2 = 0, ISO 53 A basic rack (the paper gives no rack: ha* 1, hf* 1.25, rho* 0.38
    assumed), standard centre distance.
    """
    return HelicalGearPair(
        mn=6e-3,
        z1=34,
        z2=84,
        alpha_n=25.0 * _DEG,
        beta=17.0 * _DEG,
        b1=70e-3,
        b2=70e-3,
    )


def seed002_pair() -> HelicalGearPair:
    """Return the helical pair of Yuan, Liu and Liu (2020), Table 1.

    z 30/30, mn 6 mm, alpha_n 20 deg, beta 18 deg (Yuan et al.'s +-18 is the hand of the two
    gears), b 40 mm, ha* 1, c* 0.25 (hf* 1.25), x = 0; rho_f* 0.38 assumed (not given).
    """
    return HelicalGearPair(
        mn=6e-3,
        z1=30,
        z2=30,
        alpha_n=20.0 * _DEG,
        beta=18.0 * _DEG,
        b1=40e-3,
        b2=40e-3,
    )


def iso_tr_6336_30_example1() -> HelicalGearPair:
    """Return the helical pair of ISO/TR 6336-30:2017, Example 1.

    mn 8 mm, z 17/103, alpha_n 20 deg, beta 15.8 deg, b 100 mm, a 500 mm, x1 0.145, x2 0,
    basic rack ISO 53 D (ha* 1.0, hf* 1.4, rho_f* 0.39). Gives eps_alpha = 1.54934,
    eps_beta = 1.0834 (see tests/test_gears.py).
    """
    return HelicalGearPair(
        mn=8e-3,
        z1=17,
        z2=103,
        alpha_n=20.0 * _DEG,
        beta=15.8 * _DEG,
        b1=100e-3,
        b2=100e-3,
        x1=0.145,
        x2=0.0,
        ha_star=1.0,
        hf_star=1.4,
        rho_f_star=0.39,
        a=500e-3,
    )
