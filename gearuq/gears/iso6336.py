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
from typing import Any

import numpy as np

from gearuq.gears.geometry import HelicalGearPair

__all__ = [
    "C_M_SOLID",
    "DynamicFactorB",
    "dynamic_factor_coefficients",
    "dynamic_factor_method_b",
    "pair_dynamic_factor_method_b",
    "reduced_mass_per_width",
    "resonance_speed",
    "running_in_allowance",
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


# ---------------------------------------------------------------------- dynamic factor K_v
#: Density of steel used by the standard's reduced mass [kg/mm^3].
STEEL_DENSITY_KG_PER_MM3: float = 7.83e-6


def reduced_mass_per_width(d_m1: float, d_b1: float, u: float, *, q1: float = 0.0,
                           q2: float = 0.0, rho1: float = STEEL_DENSITY_KG_PER_MM3,
                           rho2: float = STEEL_DENSITY_KG_PER_MM3) -> float:
    """Reduced mass of a gear pair per unit face width on the line of action [kg/mm].

    ISO 6336-1 (Formula for ``m_red`` of clause 6, Method B):
    ``m_red = (pi/8) (d_m1/d_b1)^2 d_m1^2 / (1/((1 - q1^4) rho1) + 1/((1 - q2^4) rho2 u^2))``,
    the two gear bodies as discs of the mean diameter ``d_m = (d_a + d_f)/2`` with bore
    ratio ``q = d_i / d_m``, each referred to its base circle.

    Parameters
    ----------
    d_m1, d_b1 : float
        Mean and base diameters of the pinion [mm].
    u : float
        Gear ratio ``z2 / z1`` (>= 1 for the standard's form, any positive value accepted).
    q1, q2 : float
        Bore ratios in [0, 1).
    rho1, rho2 : float
        Densities [kg/mm^3].
    """
    for name, value in (("d_m1", d_m1), ("d_b1", d_b1), ("u", u), ("rho1", rho1),
                        ("rho2", rho2)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name}={value!r} is outside its valid range (0, inf)")
    for name, value in (("q1", q1), ("q2", q2)):
        if not 0.0 <= value < 1.0:
            raise ValueError(f"{name}={value!r} is outside its valid range [0, 1)")
    return (math.pi / 8.0 * (d_m1 / d_b1) ** 2 * d_m1**2
            / (1.0 / ((1.0 - q1**4) * rho1) + 1.0 / ((1.0 - q2**4) * rho2 * u**2)))


def resonance_speed(z1: int, c_gamma_alpha: float, m_red: float) -> float:
    """Pinion resonance speed ``n_E1 = 30000 / (pi z1) sqrt(c_gamma_alpha / m_red)`` [rpm].

    ``c_gamma_alpha`` in N/(mm um), ``m_red`` in kg/mm (ISO 6336-1, clause 6, Method B):
    the speed at which the mesh frequency equals the natural frequency of the two gear
    bodies on the mean mesh stiffness.
    """
    if int(z1) != z1 or z1 < 1:
        raise ValueError(f"z1={z1!r} is outside its valid range: integers >= 1")
    for name, value in (("c_gamma_alpha", c_gamma_alpha), ("m_red", m_red)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name}={value!r} is outside its valid range (0, inf)")
    return 30000.0 / (math.pi * z1) * math.sqrt(c_gamma_alpha / m_red)


def dynamic_factor_coefficients(eps_gamma: float) -> tuple[float, ...]:
    """``(C_v1, ..., C_v7)`` of ISO 6336-1 Method B for the total contact ratio ``eps_gamma``.

    ``1 < eps_gamma <= 2``: 0.32, 0.34, 0.23, 0.90, 0.47, 0.47 and ``C_v7`` = 0.75
    (``eps_gamma <= 1.5``) or ``0.125 sin(pi (eps_gamma - 2)) + 0.875``; ``eps_gamma > 2``:
    ``C_v2 = 0.57/(eps_gamma - 0.3)``, ``C_v3 = 0.096/(eps_gamma - 1.56)``,
    ``C_v4 = (0.57 - 0.05 eps_gamma)/(eps_gamma - 1.44)``, ``C_v6 = 0.12/(eps_gamma -
    1.74)``, ``C_v7`` as above up to 2.5 and 1.0 beyond; ``C_v1 = 0.32``, ``C_v5 = 0.47``.
    """
    e = float(eps_gamma)
    if not (math.isfinite(e) and e > 1.0):
        raise ValueError(f"eps_gamma={eps_gamma!r} is outside its valid range (1, inf)")
    if e <= 1.5:
        cv7 = 0.75
    elif e <= 2.5:
        cv7 = 0.125 * math.sin(math.pi * (e - 2.0)) + 0.875
    else:
        cv7 = 1.0
    if e <= 2.0:
        return 0.32, 0.34, 0.23, 0.90, 0.47, 0.47, cv7
    return (0.32, 0.57 / (e - 0.3), 0.096 / (e - 1.56), (0.57 - 0.05 * e) / (e - 1.44),
            0.47, 0.12 / (e - 1.74), cv7)


def running_in_allowance(f_pb_um: float, material: str = "case_hardened",
                         sigma_hlim: float = 1500.0) -> float:
    """Running-in allowance ``y_alpha`` [um] of ISO 6336-1 for a base pitch deviation.

    ``"case_hardened"`` (and nitrided): ``0.075 f_pb``, at most 3 um;
    ``"through_hardened"``: ``160 / sigma_Hlim f_pb``, at most ``6400 / sigma_Hlim`` um
    (with ``sigma_Hlim`` in N/mm^2) for speeds above 10 m/s.
    """
    if not (math.isfinite(f_pb_um) and f_pb_um >= 0):
        raise ValueError(f"f_pb_um={f_pb_um!r} is outside its valid range [0, inf) um")
    if material == "case_hardened":
        return min(0.075 * f_pb_um, 3.0)
    if material == "through_hardened":
        if not (math.isfinite(sigma_hlim) and sigma_hlim > 0):
            raise ValueError(f"sigma_hlim={sigma_hlim!r} is outside its valid range (0, inf)")
        return min(160.0 / sigma_hlim * f_pb_um, 6400.0 / sigma_hlim)
    raise ValueError(f"material={material!r} is outside its valid set "
                     "{'case_hardened', 'through_hardened'}")


@dataclass(frozen=True)
class DynamicFactorB:
    """ISO 6336-1 Method B dynamic factor and its intermediate values.

    Attributes
    ----------
    kv : ndarray
        ``K_v`` at each speed [-].
    resonance_ratio : ndarray
        ``N = n1 / n_E1`` [-].
    regime : ndarray of str
        "subcritical", "main_resonance", "intermediate" or "supercritical" per speed.
    resonance_speed_rpm : float
        ``n_E1`` [rpm].
    N_S : float
        Lower limit of the main resonance range [-].
    B_p, B_f, B_k : float
        Non-dimensional pitch, profile-form and relief parameters [-].
    C_v : tuple of float
        ``C_v1 .. C_v7``.
    """

    kv: np.ndarray
    resonance_ratio: np.ndarray
    regime: np.ndarray
    resonance_speed_rpm: float
    N_S: float
    B_p: float
    B_f: float
    B_k: float
    C_v: tuple[float, ...]


def dynamic_factor_method_b(speed_rpm: Any, *, z1: int, c_prime: float, c_gamma_alpha: float,
                            m_red: float, eps_gamma: float, line_load: float,
                            f_pb_eff: float, f_f_eff: float, C_a: float) -> DynamicFactorB:
    """Dynamic factor ``K_v`` of ISO 6336-1:2019 Method B (clause 6) at pinion speeds.

    With the resonance ratio ``N = n1 / n_E1`` (:func:`resonance_speed`),
    ``B_p = c' f_pb,eff / (K_A F_t / b)``, ``B_f = c' f_f,eff / (K_A F_t / b)`` and
    ``B_k = |1 - c' C_a / (K_A F_t / b)|``:

    - subcritical, ``N <= N_S``: ``K_v = N (C_v1 B_p + C_v2 B_f + C_v3 B_k) + 1``, with
      ``N_S = 0.85``, or ``0.5 + 0.35 sqrt(K_A F_t / (100 b))`` below 100 N/mm;
    - main resonance, ``N_S < N <= 1.15``: ``K_v = C_v1 B_p + C_v2 B_f + C_v4 B_k + 1``;
    - supercritical, ``N >= 1.5``: ``K_v = C_v5 B_p + C_v6 B_f + C_v7``;
    - intermediate, ``1.15 < N < 1.5``: linear in ``N`` between the values at 1.15 and 1.5.

    Parameters
    ----------
    speed_rpm : float or array_like
        Pinion speeds [rpm], > 0.
    z1 : int
        Pinion teeth.
    c_prime, c_gamma_alpha : float
        Single and mesh stiffness per unit face width [N/(mm um)] (:func:`mesh_stiffness`).
    m_red : float
        Reduced mass per unit face width [kg/mm] (:func:`reduced_mass_per_width`).
    eps_gamma : float
        Total contact ratio.
    line_load : float
        ``K_A F_t / b`` [N/mm], > 0.
    f_pb_eff, f_f_eff : float
        Effective base pitch and profile form deviations after running-in [um], >= 0.
    C_a : float
        Tip relief amount [um] (the running-in amount ``C_ay`` when unmodified), >= 0.
    """
    n = np.atleast_1d(np.asarray(speed_rpm, dtype=float))
    if not np.all(np.isfinite(n) & (n > 0)):
        raise ValueError(f"speed_rpm={speed_rpm!r} is outside its valid range (0, inf) rpm")
    if not (math.isfinite(line_load) and line_load > 0):
        raise ValueError(f"line_load={line_load!r} is outside its valid range (0, inf) N/mm")
    for name, value in (("f_pb_eff", f_pb_eff), ("f_f_eff", f_f_eff), ("C_a", C_a),
                        ("c_prime", c_prime)):
        if not (math.isfinite(value) and value >= 0):
            raise ValueError(f"{name}={value!r} is outside its valid range [0, inf)")
    nE1 = resonance_speed(z1, c_gamma_alpha, m_red)
    cv = dynamic_factor_coefficients(eps_gamma)
    B_p = c_prime * f_pb_eff / line_load
    B_f = c_prime * f_f_eff / line_load
    B_k = abs(1.0 - c_prime * C_a / line_load)
    N_S = 0.85 if line_load >= 100.0 else 0.5 + 0.35 * math.sqrt(line_load / 100.0)
    N = n / nE1
    sub = N * (cv[0] * B_p + cv[1] * B_f + cv[2] * B_k) + 1.0
    main = cv[0] * B_p + cv[1] * B_f + cv[3] * B_k + 1.0
    sup = cv[4] * B_p + cv[5] * B_f + cv[6]
    inter = sup + (main - sup) / 0.35 * (1.5 - N)
    kv = np.where(N <= N_S, sub, np.where(N <= 1.15, main, np.where(N < 1.5, inter, sup)))
    regime = np.where(N <= N_S, "subcritical", np.where(
        N <= 1.15, "main_resonance", np.where(N < 1.5, "intermediate", "supercritical")))
    return DynamicFactorB(kv=kv, resonance_ratio=N, regime=regime, resonance_speed_rpm=nE1,
                          N_S=N_S, B_p=B_p, B_f=B_f, B_k=B_k, C_v=cv)


def pair_dynamic_factor_method_b(pair: HelicalGearPair, torque: float, speed_rpm: Any, *,
                                 accuracy_grade: int, tip_relief_um: float = 0.0,
                                 application_factor: float = 1.0,
                                 material: str = "case_hardened") -> DynamicFactorB:
    """ISO 6336-1 Method B ``K_v`` of a pair at a pinion torque, its class and its relief.

    The inputs the standard asks for, from the drawing: ``F_t = 2000 T / d_1`` [N];
    ``c'`` and ``c_gamma_alpha`` by :func:`mesh_stiffness` (solid discs, light-load
    correction below 100 N/mm); ``m_red`` of solid discs of diameter ``(d_a + d_f)/2``;
    ``f_pb`` the larger of the two gears' single pitch tolerances ``f_pT`` of ISO 1328-1
    for ``accuracy_grade`` projected on the base circle (``f_pT cos alpha_t``: ISO
    1328-1:2013 no longer tolerances the base pitch) and ``f_f_alpha`` the larger profile
    form tolerance ``f_fT``, each less the running-in allowance :func:`running_in_allowance`;
    ``C_a`` the tip relief, or for an unmodified pair the running-in relief
    ``C_ay = (sigma_Hlim/97 - 18.45)^2 / 18 + 1.5`` um of a case-hardened pair
    (``sigma_Hlim`` = 1500 N/mm^2: 2.0 um).
    """
    from gearuq.gears.deviations import iso1328_pitch_tolerances, iso1328_profile_form_tolerance

    if not (math.isfinite(torque) and torque > 0):
        raise ValueError(f"torque={torque!r} is outside its valid range (0, inf) N m")
    if not (math.isfinite(application_factor) and application_factor >= 1.0):
        raise ValueError(f"application_factor={application_factor!r} is outside its valid "
                         "range [1, inf)")
    if not (math.isfinite(tip_relief_um) and tip_relief_um >= 0):
        raise ValueError(f"tip_relief_um={tip_relief_um!r} is outside its valid range "
                         "[0, inf) um")
    d1_mm, b_mm = pair.d1 * 1e3, pair.face_width * 1e3
    line_load = application_factor * 2000.0 * torque / d1_mm / b_mm
    stiff = mesh_stiffness(pair, load_per_width=line_load)
    d_m1 = 0.5 * (pair.da1 + pair.df1) * 1e3
    m_red = reduced_mass_per_width(d_m1, pair.db1 * 1e3, pair.z2 / pair.z1)
    f_pb = max(iso1328_pitch_tolerances(d, pair.mn, accuracy_grade)[0]
               for d in (pair.d1, pair.d2)) * 1e6 * math.cos(pair.alpha_t)
    f_f = max(iso1328_profile_form_tolerance(d, pair.mn, accuracy_grade)
              for d in (pair.d1, pair.d2)) * 1e6
    y_a = running_in_allowance(f_pb, material)
    C_a = tip_relief_um if tip_relief_um > 0 else (1500.0 / 97.0 - 18.45) ** 2 / 18.0 + 1.5
    return dynamic_factor_method_b(
        speed_rpm, z1=pair.z1, c_prime=stiff.c_prime, c_gamma_alpha=stiff.c_gamma_alpha,
        m_red=m_red, eps_gamma=pair.eps_gamma, line_load=line_load,
        f_pb_eff=max(f_pb - y_a, 0.0), f_f_eff=max(f_f - y_a, 0.0), C_a=C_a)
