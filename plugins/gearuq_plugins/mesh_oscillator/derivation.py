"""Symbolic second-order multiple-scales derivation of the mesh oscillator (needs sympy).

This reproduces, from the equation of motion alone, the slow flow that :mod:`.slowflow`
implements by hand (Eritenel and Parker (2013) Eqs. 20-31 and the terms the paper omits), so
that the implementation can be checked term by term (``tests/test_mesh_oscillator_perturbation.py``)
and the derivation of docs/theory/mesh_oscillator.md re-run. It is a development tool:
sympy is not a runtime dependency of gearuq, and nothing in the plugin imports this module.

Equation (EP Eq. 11 with ``C = 1 + H``)::

    u'' + 2 mu u' + u + alpha20 u^2 + alpha30 u^3
        + [alpha11 cos(W - phi11) + alpha12 cos(2W - phi12)] u + alpha21 cos(W - phi21) u^2
        + alpha01 cos(W) + alpha02 cos(2W - phi02) - q1 cos(W - rho1)
        + H [alpha00 + alpha01 cos(W) + alpha02 cos(2W - phi02) + u + ... ] = 0

with ``W = Omega T``, ``Omega = 1 + eps sigma``, ``H = Delta0 + Delta1 cos(W - nu1) +
Delta2 cos(2W - nu2)``. Ordering: ``O(eps)``: mu, sigma, alpha01, alpha02, q1, alpha20,
alpha30, alpha11, alpha12, Delta0; ``O(eps^2)``: alpha21, Delta1, Delta2 (the paper's Eqs.
18-19, extended by alpha11, alpha12, alpha02).

Usage::

    from gearuq_plugins.mesh_oscillator.derivation import derive
    d = derive()          # dict of sympy expressions (about 5 s)
    d["Ga2"], d["Gg2"]    # second-order terms of da/dT and a dgamma/dT

EP: Eritenel and Parker (2013), the paper this model follows (docs/models.md).
"""

from __future__ import annotations

from typing import Any


def derive() -> dict[str, Any]:
    """Run the derivation; return ``f1``, ``f2`` (complex slow flows dA/dT1, dA/dT2), ``u1``
    and the polar forms ``Ga1``, ``Gg1``, ``Ga2``, ``Gg2`` (``Gg`` is ``a dgamma/dT`` without
    the ``a sigma`` of the rotating frame), and the symbols used."""
    import sympy as sp

    i_ = sp.I
    eps, e_, s_, a_, ab_ = sp.symbols("epsilon E S A Ab")
    real = dict(real=True)
    mu, sig, a00, a01, a02, q1, a20, a30, a11, a12, a21, d0, d1, d2 = sp.symbols(
        "mu sigma alpha00 alpha01 alpha02 q1 alpha20 alpha30 alpha11 alpha12 alpha21 "
        "Delta0 Delta1 Delta2", **real)
    # phase factors P = exp(-i phase)
    p02, r1, p11, p12, p21, n1, n2 = sp.symbols("P02 R1 P11 P12 P21 N1 N2")
    da1, dab1 = sp.symbols("DA1 DAb1")
    u1s, u2s = sp.symbols("U1 U2")
    phases = (p02, r1, p11, p12, p21, n1, n2)

    def conj(expr):
        rep = {a_: ab_, ab_: a_, s_: 1 / s_, e_: 1 / e_, da1: dab1, dab1: da1}
        rep.update({p: 1 / p for p in phases})
        return sp.expand(sp.expand(expr).xreplace(rep).subs(i_, -i_))

    def cos_(r, p=1):
        return (s_**r * e_**r * p + 1 / (s_**r * e_**r * p)) / 2

    def harmonics(expr):
        out: dict[int, Any] = {}
        for term in sp.Add.make_args(sp.expand(expr)):
            k = term.as_powers_dict().get(e_, 0)
            out[k] = out.get(k, 0) + term / e_**k
        return {k: sp.expand(v) for k, v in out.items()}

    def nonlinear(u):
        stiff = (a20 * u**2 + a30 * u**3 + a11 * cos_(1, p11) * u + a12 * cos_(2, p12) * u
                 + a21 * cos_(1, p21) * u**2)
        exc = a01 * cos_(1) + a02 * cos_(2, p02) - q1 * cos_(1, r1)
        sep = d0 + d1 * cos_(1, n1) + d2 * cos_(2, n2)
        force = (a00 + a01 * cos_(1) + a02 * cos_(2, p02) + u + a20 * u**2 + a30 * u**3
                 + a11 * cos_(1, p11) * u + a12 * cos_(2, p12) * u + a21 * cos_(1, p21) * u**2)
        return stiff + exc + sep * force

    scale = {mu: eps * mu, a01: eps * a01, a02: eps * a02, q1: eps * q1, a20: eps * a20,
             a30: eps * a30, a11: eps * a11, a12: eps * a12, a21: eps**2 * a21,
             d0: eps * d0, d1: eps**2 * d1, d2: eps**2 * d2}
    u0 = a_ * e_ + ab_ / e_
    series = sp.expand(sp.series(nonlinear(u0 + eps * u1s + eps**2 * u2s).xreplace(scale),
                                 eps, 0, 3).removeO())
    n1e, n2e = series.coeff(eps, 1), series.coeff(eps, 2)
    # order eps: D0^2 u1 + u1 + R1 = 0, secular terms give dA/dT1
    r1e = 2 * (i_ * da1 * e_ - i_ * dab1 / e_) + 2 * mu * (i_ * a_ * e_ - i_ * ab_ / e_) + n1e
    f1 = sp.expand(sp.solve(sp.Eq(sp.expand(r1e).coeff(e_, 1), 0), da1)[0])
    f1b = conj(f1)
    u1 = sp.expand(sum(-v * e_**k / (1 - k**2) for k, v in
                       harmonics(r1e.subs({da1: f1, dab1: f1b})).items() if abs(k) != 1))

    def dt1(expr):  # chain rule: A(T1), explicit S = exp(i sigma T1)
        expr = sp.expand(expr)
        return sp.expand(sp.diff(expr, a_) * f1 + sp.diff(expr, ab_) * f1b
                         + sp.diff(expr, s_) * i_ * sig * s_)

    def dt0(expr):
        return sp.expand(sum(i_ * k * v * e_**k for k, v in harmonics(expr).items()))

    r2 = (dt1(f1) * e_ + dt1(f1b) / e_ + 2 * dt0(dt1(u1))
          + 2 * mu * (dt0(u1) + f1 * e_ + f1b / e_) + n2e.subs(u1s, u1))
    f2 = sp.expand(-sp.expand(r2).coeff(e_, 1) / (2 * i_))
    # polar form: A = a/2 exp(i(sigma T1 - gamma))
    amp, gam = sp.symbols("a", positive=True), sp.symbols("gamma", **real)
    ph = sp.symbols("phi02 rho1 phi11 phi12 phi21 nu1 nu2", **real)
    rep = {a_: amp / 2 * s_ * sp.exp(-i_ * gam), ab_: amp / 2 / s_ * sp.exp(i_ * gam)}
    rep.update({p: sp.exp(-i_ * v) for p, v in zip(phases, ph, strict=True)})

    def polar(f):
        w = sp.expand(2 / s_ * sp.exp(i_ * gam) * f.xreplace(rep))
        re_, im_ = sp.expand(sp.expand_complex(w.rewrite(sp.cos))).as_real_imag()
        return sp.expand(re_), sp.expand(-im_)

    ga1, gg1 = polar(f1)
    ga2, gg2 = polar(f2)
    symbols = {"a": amp, "gamma": gam, "sigma": sig, "mu": mu, "alpha00": a00, "alpha01": a01,
               "alpha02": a02, "q1": q1, "alpha20": a20, "alpha30": a30, "alpha11": a11,
               "alpha12": a12, "alpha21": a21, "Delta0": d0, "Delta1": d1, "Delta2": d2,
               **{str(v): v for v in ph}}
    return {"f1": f1, "f2": f2, "u1": u1, "Ga1": ga1, "Gg1": gg1, "Ga2": ga2, "Gg2": gg2,
            "symbols": symbols}
