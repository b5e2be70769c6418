"""Tooth compliance at the contact points of a helical pair (replaces the paper's FE matrix).

Global (linear) part
    Per unit face width, each tooth of the transverse section is a variable-section cantilever
    (potential-energy method: bending, shear and axial compression, Yang & Lin 1987 /
    Tian 2004, in the Cartesian form of Chen & Shao 2011 that also covers the band between
    root and base circle) on an elastic fillet foundation (Sainsot, Velex & Duverger 2004).
    This gives the transverse compliance per unit width ``c_t(rho)`` [m^2/N] of the
    pinion and of the wheel as functions of the roll radius ``rho`` of the contact point.
    Along the face width the slices are coupled by a normalised exponential kernel
    ``K(y, y') = exp(-|y - y'| / lam) / (2 lam)`` with mirror images at both faces (so a
    uniform line load gives exactly the slice deflection ``c_t p``). The influence
    coefficient between points ``i`` and ``j`` of one tooth pair, normal direction, is::

        D_ij = cos^2(beta_b) [sqrt(c1_i c1_j) + sqrt(c2_i c2_j)] <K(y_i, .)>_j

    where ``<.>_j`` averages the kernel over segment ``j`` (exact, closed form). Different
    tooth pairs are not coupled (block-diagonal matrix).

Local (nonlinear) part
    Weber's line-contact approach (Weber 1949; Weber & Banaschek 1953), per body::

        w_k = 2 p (1 - nu^2) / (pi E) [ln(2 h_k / a) - nu / (2 (1 - nu))]

    with ``p`` the normal load per contact-line length, ``a`` the Hertz half-width of the
    normal section (radii ``rho_t / cos(beta_b)``) and ``h_k`` the half tooth thickness at
    the contact point. It depends on ``p`` only, so it is independent of the discretisation.

See ``docs/theory/ltca.md`` for the derivation, units and parameter sources.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from gearuq.gears.contact import MeshKinematics
from gearuq.gears.face_coupling import plate_coupling_length
from gearuq.gears.geometry import HelicalGearPair, involute

__all__ = [
    "SAINSOT_COEFFICIENTS",
    "ComplianceModel",
    "ToothCompliance",
    "kernel_cell_average",
    "tooth_compliance",
    "weber_contact_approach",
]

#: Sainsot et al. (2004) fillet-foundation coefficients (A, B, C, D, E, F) of
#: ``X = A/theta_f^2 + B h_f^2 + C h_f/theta_f + D/theta_f + E h_f + F`` for L*, M*, P*, Q*.
SAINSOT_COEFFICIENTS: dict[str, tuple[float, ...]] = {
    "L": (-5.574e-5, -1.9986e-3, -2.3015e-4, 4.7702e-3, 0.0271, 6.8045),
    "M": (60.111e-5, 28.100e-3, -83.431e-4, -9.9256e-3, 0.1624, 0.9086),
    "P": (-50.952e-5, 185.50e-3, 0.0538e-4, 53.300e-3, 0.2895, 0.9236),
    "Q": (-6.2042e-5, 9.0889e-3, -4.0964e-4, 7.8297e-3, -0.1472, 0.6904),
}


def _sainsot(name: str, h_f: float, theta_f: float) -> float:
    a, b, c, d, e, f = SAINSOT_COEFFICIENTS[name]
    return a / theta_f**2 + b * h_f**2 + c * h_f / theta_f + d / theta_f + e * h_f + f


@dataclass(frozen=True)
class ToothCompliance:
    """Tabulated transverse compliance per unit width of one tooth vs roll radius.

    Attributes
    ----------
    rho : ndarray
        Roll radius (transverse radius of curvature) of the contact point [m].
    bending, shear, axial, foundation : ndarray
        The four compliance terms per unit face width [m^2/N].
    half_thickness : ndarray
        Half transverse tooth thickness at the contact point [m].
    beam_root_radius : float
        Radius of the section where the cantilever is clamped on the fillet foundation [m]
        (the root circle; the base circle in the ``beam_root="base_circle"`` variant).
    """

    rho: np.ndarray
    bending: np.ndarray
    shear: np.ndarray
    axial: np.ndarray
    foundation: np.ndarray
    half_thickness: np.ndarray
    beam_root_radius: float = math.nan

    @property
    def total(self) -> np.ndarray:
        """Sum of the four terms [m^2/N]."""
        return self.bending + self.shear + self.axial + self.foundation

    def __call__(self, rho: np.ndarray) -> np.ndarray:
        """Interpolate the total compliance at roll radii ``rho`` [m^2/N]."""
        return np.interp(rho, self.rho, self.total)

    def thickness(self, rho: np.ndarray) -> np.ndarray:
        """Interpolate the half thickness at roll radii ``rho`` [m]."""
        return np.interp(rho, self.rho, self.half_thickness)


def tooth_compliance(
    pair: HelicalGearPair,
    gear: int,
    *,
    E: float = 206e9,
    nu: float = 0.3,
    plane_strain: bool = True,
    bore_ratio: float = 0.5,
    n_rho: int = 121,
    n_int: int = 400,
    beam_root: str = "root_circle",
) -> ToothCompliance:
    """Return the potential-energy compliance of a tooth of ``gear`` (1 or 2) vs roll radius.

    The transverse section of the tooth is used (slice method). The involute flank from the
    base circle to the tip has half thickness ``h(r) = r sin(psi(r))`` at the section
    ``x = r cos(psi(r))`` with ``psi(r) = s_t/d + inv(alpha_t) - inv(alpha_r)``; between root
    and base circle the section is taken constant (Chen & Shao 2011). The force at the
    contact point acts along the line of action at ``alpha_1 = tan(alpha_r) - psi_b`` to the
    normal of the tooth centreline.

    Parameters
    ----------
    pair : HelicalGearPair
        The gear pair.
    gear : int
        1 (pinion) or 2 (wheel).
    E, nu : float, optional
        Young's modulus [Pa] and Poisson's ratio (steel).
    plane_strain : bool, optional
        Use ``E/(1 - nu^2)`` in the beam terms (wide face, ``b/mn`` > 5).
    bore_ratio : float, optional
        ``r_int / r_f`` of the Sainsot foundation (bore radius over root radius), in (0, 1).
    n_rho, n_int : int, optional
        Table size and integration points.
    beam_root : {"root_circle", "base_circle"}, optional
        Where the cantilever is clamped when the root circle lies above the base circle.
        ``"root_circle"`` (default, correct): the gear body below the root circle is not
        beam. ``"base_circle"``: the version-1 behaviour, which counted the body between
        base and root circle as tooth and made large-tooth-number gears 5-30 % too soft;
        kept only to document that correction (``docs/theory/ltca.md``).

    Returns
    -------
    ToothCompliance
    """
    if gear not in (1, 2):
        raise ValueError(f"gear={gear!r} is outside its valid set {{1, 2}}")
    if beam_root not in ("root_circle", "base_circle"):
        raise ValueError(f"beam_root={beam_root!r} is outside its valid set "
                         "{'root_circle', 'base_circle'}")
    if not 0.0 < bore_ratio < 1.0:
        raise ValueError(f"bore_ratio={bore_ratio!r} is outside its valid range (0, 1)")
    z = pair.z1 if gear == 1 else pair.z2
    x_shift = pair.x1 if gear == 1 else pair.x2
    d = z * pair.mt
    rb = 0.5 * (pair.db1 if gear == 1 else pair.db2)
    ra = 0.5 * (pair.da1 if gear == 1 else pair.da2)
    rf = 0.5 * (pair.df1 if gear == 1 else pair.df2)
    st = pair.mt * (math.pi / 2.0 + 2.0 * x_shift * math.tan(pair.alpha_n))
    psi_b = st / d + involute(pair.alpha_t)  # half angle at the base circle
    Ep = E / (1.0 - nu**2) if plane_strain else E
    G = E / (2.0 * (1.0 + nu))

    # Section table along the centreline from the root circle to the tip. The cantilever is
    # clamped at the root circle: below it lies the gear body, whose compliance is the
    # Sainsot fillet-foundation term. When the root circle lies above the base circle
    # (about z > 42 at x = 0, alpha_n = 20 deg) the beam therefore starts on the involute at
    # r = r_f; otherwise it starts at r_f with the constant-thickness band between root and
    # base circle (Chen & Shao 2011).
    r_root_beam = max(rf, rb) if beam_root == "root_circle" else rb
    r_inv = np.linspace(r_root_beam, ra, n_int)
    al_r = np.arccos(np.clip(rb / r_inv, -1.0, 1.0))
    psi = psi_b - (np.tan(al_r) - al_r)
    x_inv = r_inv * np.cos(psi)
    h_inv = r_inv * np.sin(psi)
    if rf < rb:
        x_base = rb * math.cos(psi_b)  # centreline coordinate of the base-circle section
        x_low = np.linspace(min(rf, x_base), x_base, max(n_int // 4, 8), endpoint=False)
        h_low = np.full_like(x_low, rb * math.sin(psi_b))
    else:
        x_low = np.zeros(0)
        h_low = np.zeros(0)
    x_all = np.concatenate([x_low, x_inv])
    h_all = np.concatenate([h_low, h_inv])
    # half angle of the tooth at the root circle (Sainsot's theta_f): psi_b below the base
    # circle (the value used since the first version; radial flank), the involute half
    # angle psi(r_f) when the root circle lies above the base circle
    theta_f = psi_b if r_root_beam <= rb else float(psi[0])

    # contact points: roll radius rho = rb tan(alpha_r), from the beam root to the tip
    rho_max = math.sqrt(ra**2 - rb**2)
    rho = np.linspace(math.sqrt(r_root_beam**2 - rb**2), rho_max, n_rho)
    r_c = np.sqrt(rb**2 + rho**2)
    al_c = np.arctan(rho / rb)
    psi_c = psi_b - (np.tan(al_c) - al_c)
    x_c = r_c * np.cos(psi_c)
    h_c = r_c * np.sin(psi_c)
    a1 = np.tan(al_c) - psi_b  # load angle to the normal of the centreline
    bend = np.empty(n_rho)
    shear = np.empty(n_rho)
    axial = np.empty(n_rho)
    for i in range(n_rho):
        m = x_all <= x_c[i]
        xs = np.append(x_all[m], x_c[i])
        hs = np.append(h_all[m], h_c[i])
        inertia = (2.0 * hs) ** 3 / 12.0
        area = 2.0 * hs
        arm = math.cos(a1[i]) * (x_c[i] - xs) - math.sin(a1[i]) * h_c[i]
        bend[i] = np.trapezoid(arm**2 / (Ep * inertia), xs)
        shear[i] = np.trapezoid(1.2 * math.cos(a1[i]) ** 2 / (G * area), xs)
        axial[i] = np.trapezoid(math.sin(a1[i]) ** 2 / (Ep * area), xs)
    # fillet foundation (Sainsot 2004): theta_f half angle of the tooth at the root circle
    s_f = 2.0 * rf * theta_f
    h_f = 1.0 / bore_ratio
    u_f = rb / np.cos(a1) - rf  # load line meets the centreline at rb / cos(alpha_1)
    Lc, Mc, Pc, Qc = (_sainsot(k, h_f, theta_f) for k in "LMPQ")
    found = (np.cos(a1) ** 2 / E) * (
        Lc * (u_f / s_f) ** 2 + Mc * (u_f / s_f) + Pc * (1.0 + Qc * np.tan(a1) ** 2)
    )
    return ToothCompliance(rho, bend, shear, axial, found, h_c, float(min(r_root_beam, rf)))


def weber_contact_approach(
    p: np.ndarray, R: np.ndarray, h1: np.ndarray, h2: np.ndarray, E: float, nu: float
) -> np.ndarray:
    """Return Weber's contact approach of two steel bodies under a line load ``p`` [m].

    ``w = sum_k 2 p (1 - nu^2)/(pi E) [ln(2 h_k / a) - nu/(2(1 - nu))]``,
    ``a = sqrt(8 p R (1 - nu^2) / (pi E))`` (same material), ``p`` in N/m, ``R`` the
    equivalent radius of the normal section [m], ``h_k`` half tooth thicknesses [m].
    ``p <= 0`` gives 0.
    """
    p = np.asarray(p, dtype=float)
    pp = np.maximum(p, 1e-30)
    a = np.sqrt(8.0 * pp * R * (1.0 - nu**2) / (math.pi * E))
    k = 2.0 * pp * (1.0 - nu**2) / (math.pi * E)
    c = nu / (2.0 * (1.0 - nu))
    w = k * (np.log(2.0 * h1 / a) + np.log(2.0 * h2 / a) - 2.0 * c)
    return np.where(p > 0.0, w, 0.0)


def kernel_cell_average(
    y: np.ndarray, lo: np.ndarray, hi: np.ndarray, lam: float, b: float
) -> np.ndarray:
    """Average of the mirrored exponential kernel at ``y`` over segments ``[lo, hi]`` [1/m].

    ``K(y, u) = k(y - u) + k(y + u) + k(y + u - 2b)``, ``k(x) = exp(-|x|/lam)/(2 lam)``;
    ``<K>_j = [int_lo^hi K(y, u) du] / (hi - lo)`` via the primitive
    ``Gk(x) = sign(x) (1 - exp(-|x|/lam)) / 2``. Broadcasting: ``y`` (..., n, 1), ``lo``,
    ``hi`` (..., 1, n). ``lam = 0`` gives the uncoupled slice model ``delta_ij / dy``.
    """
    width = np.where(hi - lo > 0.0, hi - lo, 1.0)  # empty (invalid) lines: any finite value
    if lam <= 0.0:
        inside = (y >= lo) & (y < hi)
        return np.where(inside, 1.0 / width, 0.0)

    def prim(x: np.ndarray) -> np.ndarray:
        return 0.5 * np.sign(x) * -np.expm1(-np.abs(x) / lam)

    direct = prim(y - lo) - prim(y - hi)
    img0 = prim(y + hi) - prim(y + lo)
    imgb = prim(y + hi - 2.0 * b) - prim(y + lo - 2.0 * b)
    return (direct + img0 + imgb) / width


@dataclass
class ComplianceModel:
    """Compliance model of the contact points (global matrix + local Hertz law).

    Parameters
    ----------
    pair : HelicalGearPair
        The gear pair.
    kind : {"potential_energy", "constant"}
        ``"potential_energy"``: the model of this module. ``"constant"``: a test oracle with
        a constant normal stiffness per unit contact-line length ``k_per_length`` [N/m^2],
        no coupling and no Hertz term (the STE is then exactly ``P / (k L)``).
    coupling_length : float or None
        Decay length ``lam`` of the face-width kernel [m]; ``None``: calibrated on the
        cantilever plate, :func:`gearuq.gears.face_coupling.plate_coupling_length`
        (1.85 ``mn`` for Yuan, Liu and Liu's pair; versions before 0.2 used ``1.0 mn``).
    hertz : bool
        Include Weber's nonlinear contact approach.
    E, nu : float
        Elastic constants of both gears [Pa], [-].
    plane_strain : bool
        ``E/(1-nu^2)`` in the beam terms.
    bore_ratio : float
        ``r_int / r_f`` for the Sainsot foundation.
    k_per_length : float
        Stiffness per unit contact-line length of the ``"constant"`` model [N/m^2].
    beam_root : {"root_circle", "base_circle"}
        See :func:`tooth_compliance` (``"base_circle"`` reproduces version 1).
    """

    pair: HelicalGearPair
    kind: str = "potential_energy"
    coupling_length: float | None = None
    hertz: bool = True
    E: float = 206e9
    nu: float = 0.3
    plane_strain: bool = True
    bore_ratio: float = 0.5
    k_per_length: float = 1.4e10
    beam_root: str = "root_circle"
    tooth1: ToothCompliance | None = field(default=None, repr=False)
    tooth2: ToothCompliance | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if self.kind not in ("potential_energy", "constant"):
            raise ValueError(
                f"kind={self.kind!r} is outside its valid set {{'potential_energy', 'constant'}}"
            )
        if self.coupling_length is None:
            # cantilever-plate calibration (gearuq.gears.face_coupling, docs/theory/ltca.md)
            self.coupling_length = plate_coupling_length(self.pair, nu=self.nu)
        if not (math.isfinite(self.coupling_length) and self.coupling_length >= 0.0):
            raise ValueError(
                f"coupling_length={self.coupling_length!r} is outside its valid range [0, inf) m"
            )
        if not (self.E > 0 and 0.0 <= self.nu < 0.5 and self.k_per_length > 0):
            raise ValueError(
                f"E={self.E!r} (valid (0, inf) Pa), nu={self.nu!r} (valid [0, 0.5)), "
                f"k_per_length={self.k_per_length!r} (valid (0, inf) N/m^2)"
            )
        if self.kind == "constant":
            self.hertz = False
        elif self.tooth1 is None:
            opts = dict(E=self.E, nu=self.nu, plane_strain=self.plane_strain,
                        bore_ratio=self.bore_ratio, beam_root=self.beam_root)
            self.tooth1 = tooth_compliance(self.pair, 1, **opts)
            self.tooth2 = tooth_compliance(self.pair, 2, **opts)

    def matrices(
        self, s: np.ndarray, y: np.ndarray, y_lo: np.ndarray, dy: np.ndarray, kin: MeshKinematics
    ) -> np.ndarray:
        """Return the influence blocks ``D`` [m/N], shape ``(..., n_pts, n_pts)`` per line.

        ``s``, ``y``: ``(..., n_pts)`` point coordinates; ``y_lo``, ``dy``: ``(...)`` line
        start and segment width.
        """
        n = s.shape[-1]
        if self.kind == "constant":
            dL = dy / kin.cos_bb
            diag = 1.0 / (self.k_per_length * np.maximum(dL, 1e-300))
            return diag[..., None, None] * np.eye(n)
        c1 = self.tooth1(s)
        c2 = self.tooth2(kin.T1T2 - s)
        lo = y_lo[..., None] + dy[..., None] * np.arange(n)
        kern = kernel_cell_average(
            y[..., :, None], lo[..., None, :], lo[..., None, :] + dy[..., None, None],
            float(self.coupling_length), kin.b,
        )
        amp = np.sqrt(c1[..., :, None] * c1[..., None, :]) + np.sqrt(
            c2[..., :, None] * c2[..., None, :]
        )
        D = kin.cos_bb**2 * amp * kern
        return 0.5 * (D + np.swapaxes(D, -1, -2))  # exact symmetry for the solver

    def hertz_params(self, s: np.ndarray, kin: MeshKinematics) -> tuple[np.ndarray, ...]:
        """Return ``(R_normal, h1, h2)`` at the points for :func:`weber_contact_approach`."""
        rho1 = np.maximum(s, 1e-6) / kin.cos_bb
        rho2 = np.maximum(kin.T1T2 - s, 1e-6) / kin.cos_bb
        R = rho1 * rho2 / (rho1 + rho2)
        if self.kind == "constant":
            return R, np.ones_like(s), np.ones_like(s)
        return R, self.tooth1.thickness(s), self.tooth2.thickness(kin.T1T2 - s)
