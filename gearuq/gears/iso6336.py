"""Tooth stiffness of a cylindrical gear pair by ISO 6336-1:2006/2019, method B.

Units: the standard's practical units are used inside, as it prints them — single
flexibility ``q'`` in mm um/N, stiffnesses per unit face width in N/(mm um) (= GPa); the
pair's mesh stiffness is also given in SI, N/m:
``k_mesh [N/m] = c_gamma_alpha [N/(mm um)] * b [mm] * 1e3 [um/mm] * 1e3 [mm/m]``.

Sources, the formulas and the paper-vs-standard choices are in ``docs/theory/gear_geometry.md``.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import asdict, dataclass

from gearuq.gears.geometry import HelicalGearPair

__all__ = [
    "C_M_SOLID",
    "Q_COEFFICIENTS",
    "MeshStiffness",
    "basic_rack_factor",
    "gear_blank_factor",
    "load_correction_factor",
    "mesh_stiffness",
    "single_stiffness_coefficient_q",
]

#: C1..C9 of ISO 6336-1 (Table "Constants for Formula q'"), q' in mm um/N.
Q_COEFFICIENTS: tuple[float, ...] = (
    0.04723,
    0.15551,
    0.25791,
    -0.00635,
    -0.11654,
    -0.00193,
    -0.24188,
    0.00529,
    0.00182,
)

#: Correction factor C_M between measured and theoretical single stiffness (solid disc gears).
C_M_SOLID: float = 0.8


def single_stiffness_coefficient_q(zn1: float, zn2: float, x1: float, x2: float) -> float:
    """Return the minimum flexibility of a tooth pair ``q'`` [mm um/N] (ISO 6336-1 method B).

    ``q' = C1 + C2/zn1 + C3/zn2 + C4 x1 + C5 x1/zn1 + C6 x2 + C7 x2/zn2 + C8 x1^2 + C9 x2^2``.

    Parameters
    ----------
    zn1, zn2 : float
        Virtual numbers of teeth of pinion and wheel, ``z / (cos^2(beta_b) cos(beta))``
        (pass ``z`` itself to reproduce Li, Hu and Han's form). External gears only: for an
        internal wheel the standard sets ``zn2 = inf`` (not implemented here).
    x1, x2 : float
        Profile shift coefficients. The regression is stated for ``x1 >= x2`` and
        ``-0.5 <= x1 + x2 <= 2``; outside that a ``UserWarning`` is issued.

    Returns
    -------
    float
        ``q'`` in mm um/N; the theoretical single stiffness is ``c'_th = 1/q'``.
    """
    if zn1 <= 0 or zn2 <= 0:
        raise ValueError(f"zn1={zn1!r}, zn2={zn2!r} must be > 0 (external gears)")
    if x1 < x2 - 1e-12 or not -0.5 <= x1 + x2 <= 2.0:
        warnings.warn(
            f"q' regression of ISO 6336-1 is stated for x1 >= x2 and -0.5 <= x1 + x2 <= 2; "
            f"got x1={x1!r}, x2={x2!r}",
            UserWarning,
            stacklevel=2,
        )
    c1, c2, c3, c4, c5, c6, c7, c8, c9 = Q_COEFFICIENTS
    return (
        c1
        + c2 / zn1
        + c3 / zn2
        + c4 * x1
        + c5 * x1 / zn1
        + c6 * x2
        + c7 * x2 / zn2
        + c8 * x1**2
        + c9 * x2**2
    )


def basic_rack_factor(
    hfP_over_mn: float,
    alpha_Pn_deg: float,
    hfP2_over_mn: float | None = None,
    alpha_Pn2_deg: float | None = None,
) -> float:
    """Return the basic rack factor ``C_B`` of ISO 6336-1.

    ``C_Bi = [1 + 0.5 (1.2 - h_fPi/mn)] [1 - 0.02 (20 - alpha_Pni)]`` (angles in degrees);
    when pinion and wheel are cut with different racks ``C_B = (C_B1 + C_B2) / 2``.

    Parameters
    ----------
    hfP_over_mn : float
        Dedendum of the basic rack of gear 1 relative to the normal module.
    alpha_Pn_deg : float
        Pressure angle of the basic rack of gear 1 [deg].
    hfP2_over_mn, alpha_Pn2_deg : float or None, optional
        Same for gear 2; ``None`` means the same rack as gear 1.

    Returns
    -------
    float
        ``C_B`` [-]. ISO 53 profile A (1.25, 20 deg) gives 0.975; profile D (1.4) gives 0.9.
    """

    def one(hf: float, alpha: float) -> float:
        return (1.0 + 0.5 * (1.2 - hf)) * (1.0 - 0.02 * (20.0 - alpha))

    hf2 = hfP_over_mn if hfP2_over_mn is None else hfP2_over_mn
    al2 = alpha_Pn_deg if alpha_Pn2_deg is None else alpha_Pn2_deg
    return 0.5 * (one(hfP_over_mn, alpha_Pn_deg) + one(hf2, al2))


def gear_blank_factor(bs_over_b: float | None = None, sR_over_mn: float | None = None) -> float:
    """Return the gear blank factor ``C_R`` of ISO 6336-1.

    Solid disc gears (``None`` arguments): ``C_R = 1``. Gears with a web (rim thickness
    ``s_R``, web thickness ``b_s``):
    ``C_R = 1 + ln(b_s/b) / (5 exp(s_R / (5 mn)))``, with ``b_s/b`` clipped to [0.2, 1.2]
    and ``s_R/mn`` raised to at least 1, as the standard prescribes.

    Parameters
    ----------
    bs_over_b : float or None
        Web thickness over face width.
    sR_over_mn : float or None
        Rim thickness over normal module.

    Returns
    -------
    float
        ``C_R`` [-].
    """
    if bs_over_b is None and sR_over_mn is None:
        return 1.0
    if bs_over_b is None or sR_over_mn is None:
        raise ValueError("gear_blank_factor needs both bs_over_b and sR_over_mn (or neither)")
    if bs_over_b <= 0 or sR_over_mn <= 0:
        raise ValueError(f"bs_over_b={bs_over_b!r} and sR_over_mn={sR_over_mn!r} must be > 0")
    r = min(max(bs_over_b, 0.2), 1.2)
    s = max(sR_over_mn, 1.0)
    return 1.0 + math.log(r) / (5.0 * math.exp(s / 5.0))


def load_correction_factor(load_per_width: float | None) -> float:
    """Return the light-load factor on ``c'``: ``[(F_t K_A / b) / (100 N/mm)]^0.25`` below 100.

    Parameters
    ----------
    load_per_width : float or None
        ``F_t K_A / b`` in N/mm; ``None`` (or >= 100 N/mm) gives 1.

    Returns
    -------
    float
        Factor in (0, 1].
    """
    if load_per_width is None:
        return 1.0
    if not (math.isfinite(load_per_width) and load_per_width > 0):
        raise ValueError(
            f"load_per_width={load_per_width!r} N/mm is outside its valid range (0, inf)"
        )
    return 1.0 if load_per_width >= 100.0 else (load_per_width / 100.0) ** 0.25


@dataclass(frozen=True)
class MeshStiffness:
    """ISO 6336-1 method B stiffness of a gear pair.

    Attributes
    ----------
    q_prime : float
        Minimum flexibility of a tooth pair ``q'`` [mm um/N].
    c_th : float
        Theoretical single stiffness ``c'_th = 1/q'`` [N/(mm um)].
    C_M, C_R, C_B : float
        Measured/theory correction, gear blank factor and basic rack factor [-].
    load_factor : float
        Light-load factor ``[(F_t K_A/b)/100]^0.25`` or 1 [-].
    c_prime : float
        Maximum single stiffness of a tooth pair per unit face width
        ``c' = c'_th C_M C_R C_B cos(beta) * load_factor`` [N/(mm um)].
    c_gamma_alpha : float
        Mean mesh stiffness per unit face width ``c' (0.75 eps_alpha + 0.25)`` [N/(mm um)]
        (used by the standard for K_v, K_Halpha, K_Falpha).
    c_gamma_beta : float
        ``0.85 c_gamma_alpha`` [N/(mm um)] (used for K_Hbeta).
    k_mesh_N_per_m : float
        Mean mesh stiffness of the pair ``c_gamma_alpha b`` in N/m (b = effective width).
    k_single_N_per_m : float
        ``c' b`` in N/m (single tooth pair stiffness over the face width).
    eps_alpha : float
        Transverse contact ratio used [-].
    face_width_mm : float
        Face width used [mm].
    use_virtual_teeth : bool
        True: ``q'`` from the virtual numbers of teeth (standard); False: from ``z`` (Li, Hu and
        Han).
    """

    q_prime: float
    c_th: float
    C_M: float
    C_R: float
    C_B: float
    load_factor: float
    c_prime: float
    c_gamma_alpha: float
    c_gamma_beta: float
    k_mesh_N_per_m: float
    k_single_N_per_m: float
    eps_alpha: float
    face_width_mm: float
    use_virtual_teeth: bool

    def as_dict(self) -> dict[str, float | bool]:
        """Return the fields as a plain dict."""
        return asdict(self)


def mesh_stiffness(
    pair: HelicalGearPair,
    *,
    C_R: float = 1.0,
    C_M: float = C_M_SOLID,
    C_B: float | None = None,
    load_per_width: float | None = None,
    use_virtual_teeth: bool = True,
) -> MeshStiffness:
    """Return the ISO 6336-1 method B tooth stiffness of a helical pair.

    Parameters
    ----------
    pair : HelicalGearPair
        The gear pair (SI units).
    C_R : float, optional
        Gear blank factor (1 for solid discs; see :func:`gear_blank_factor`).
    C_M : float, optional
        Correction factor, 0.8 for solid disc gears.
    C_B : float or None, optional
        Basic rack factor; ``None`` computes it from ``pair.hf_star`` and ``pair.alpha_n``
        (:func:`basic_rack_factor`).
    load_per_width : float or None, optional
        ``F_t K_A / b`` in N/mm for the light-load correction (< 100 N/mm); ``None``: none.
    use_virtual_teeth : bool, optional
        True (default, ISO 6336-1): ``q'`` from ``zn = z / (cos^2(beta_b) cos(beta))``.
        False: ``q'`` from the actual ``z``, the form printed in Li, Hu and Han (Eq. 9).

    Returns
    -------
    MeshStiffness
        All intermediate factors, per-width stiffnesses in N/(mm um) and ``k_mesh`` in N/m.
    """
    zn1, zn2 = (pair.zn1, pair.zn2) if use_virtual_teeth else (float(pair.z1), float(pair.z2))
    q = single_stiffness_coefficient_q(zn1, zn2, pair.x1, pair.x2)
    c_th = 1.0 / q
    if C_B is None:
        C_B = basic_rack_factor(pair.hf_star, math.degrees(pair.alpha_n))
    lf = load_correction_factor(load_per_width)
    c_prime = c_th * C_M * C_R * C_B * math.cos(pair.beta) * lf
    eps_a = pair.eps_alpha
    c_ga = c_prime * (0.75 * eps_a + 0.25)
    b_mm = pair.face_width * 1e3
    return MeshStiffness(
        q_prime=q,
        c_th=c_th,
        C_M=C_M,
        C_R=C_R,
        C_B=C_B,
        load_factor=lf,
        c_prime=c_prime,
        c_gamma_alpha=c_ga,
        c_gamma_beta=0.85 * c_ga,
        k_mesh_N_per_m=c_ga * b_mm * 1e6,
        k_single_N_per_m=c_prime * b_mm * 1e6,
        eps_alpha=eps_a,
        face_width_mm=b_mm,
        use_virtual_teeth=use_virtual_teeth,
    )
