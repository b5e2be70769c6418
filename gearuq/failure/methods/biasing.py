"""The biasing densities of multi-fidelity importance sampling, one class per family, each
owning its settings (as OpenTURNS' importance samplers do).

A family explores the cheap model's failure set ``{g_LF <= delta}`` (``delta`` = 0, or the
widening of :mod:`gearuq.failure.methods.mfis`) and returns a :class:`CheapFit`: the
defensive density, the cheap model's own estimate and the ``g_LF`` level the density was
fitted to reach.

* :class:`Gaussian`: a Gaussian mixture (components by BIC) fitted to subset simulation's last
  level on the cheap model (:func:`~gearuq.failure.methods.mixtures.fit_mixture`).
* :class:`VMFN`: a von Mises-Fisher-Nakagami mixture (Papaioannou, Geyer and Straub,
  "Improved cross entropy-based importance sampling with a flexible mixture model", RESS
  2019), fitted to subset simulation's last level or by multi-level cross-entropy
  (``explore="ce"``): direction and radius apart, for round shell-like failure sets.
* :class:`Quadratic`: the standard normal exponentially tilted by a quadratic form fitted on
  the cheap model (:mod:`gearuq.failure.methods.quadratic`), for an RMS response nearly
  linear in a random germ (the outside of an ellipsoid).
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from gearuq.failure.evaluator import LimitStateEvaluator
from gearuq.failure.methods import subset
from gearuq.failure.methods.importance import Mixture
from gearuq.failure.methods.mixtures import fit_mixture, informative_directions, weighted_directions
from gearuq.failure.methods.quadratic import fit_quadratic, tilted_gaussian
from gearuq.failure.methods.vmfn import VMFNMixture, fit_vmfn
from gearuq.failure.report import Reason
from gearuq.model import Option

LOG = logging.getLogger("gearuq.failure.mfis")

__all__ = ["BiasingDensity", "Gaussian", "VMFN", "Quadratic", "CheapFit", "FAMILIES",
           "FAMILY_SETTINGS", "Widened", "resolve_biasing", "cheap_estimate"]

#: Largest number of cross-entropy levels on the cheap model.
MAX_CE_LEVELS = 25


@dataclasses.dataclass
class CheapFit:
    """What a family learnt on the cheap model.

    Attributes
    ----------
    density : Mixture or VMFNMixture
        The defensive biasing density.
    pf : float
        The cheap model's failure probability (subset simulation or its importance estimate;
        NaN where it found no failure).
    found_failure : bool
        Whether the cheap model failed anywhere the exploration went.
    covered : float
        The ``g_LF`` level whose set the density was fitted to (``inf``: plain normal draws).
    info : dict
        The cheap model's importance estimate with the density (``pf``, ``cov``, ``ess``,
        ``n_fail``) where one was made, and family-specific numbers.
    reasons : list of Reason
        What the exploration could not vouch for.
    """

    density: Any
    pf: float
    found_failure: bool
    covered: float
    info: dict[str, float] = dataclasses.field(default_factory=dict)
    reasons: list[Reason] = dataclasses.field(default_factory=list)


class Widened:
    """The cheap evaluator seen with ``g - delta``: its failure set is ``{g_LF <= delta}``."""

    def __init__(self, ev: LimitStateEvaluator, delta: float) -> None:
        self._ev, self.delta = ev, float(delta)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._ev, name)

    def evaluate(self, u: np.ndarray, tag: str) -> dict[str, np.ndarray]:
        """The cheap model's limit state at ``u``, lowered by ``delta``."""
        res = dict(self._ev.evaluate(u, f"{tag}/widened{self.delta:.6g}"))
        res["g"] = res["g"] - self.delta
        res["g_half"] = res["g_half"] - self.delta
        res["g_bound"] = res["g_bound"] - self.delta  # a censored run's bound moves alike
        return res


def _defensive_only(dim: int) -> Mixture:
    """The standard normal alone: crude Monte Carlo on the expensive model."""
    return Mixture(np.zeros((1, dim)), np.eye(dim)[None], np.ones(1), 1.0 - 1e-12)


def cheap_estimate(c: np.ndarray) -> dict[str, float]:
    """The cheap model's importance estimate from ``c`` (the weight of each failing draw, 0
    elsewhere): pf, its CoV, the effective sample size and the number of failing draws."""
    pf = float(c.mean())
    pos = c[c > 0]
    return {"pf": pf, "cov": float(c.std(ddof=1) / math.sqrt(c.size) / pf) if pf > 0
            else math.inf, "ess": float(pos.sum() ** 2 / np.sum(pos**2)) if pos.size else 0.0,
            "n_fail": float(pos.size)}


_DEFENSIVE = Option("defensive", 0.1, "share of the defensive standard normal component",
                    lower=0.01, upper=0.9)
_N_PER_LEVEL = Option("n_per_level", 2000, "samples per level of the exploration on the cheap "
                      "model", lower=100)
_FIT_TO = Option("fit_to", "last_level", "samples the density is fitted to: 'last_level' "
                 "(every valid sample of subset simulation's last level, a superset of the "
                 "cheap model's failure domain that reaches back to its boundary) or 'failing' "
                 "(only its failing samples)", kind="str", choices=("last_level", "failing"))
_SUBSPACE = Option("subspace", "auto", "fit in the directions where the explored samples "
                   "differ from standard normal draws by more than sampling noise ('auto'), "
                   "standard normal across them; or in every direction ('full')", kind="str",
                   choices=("auto", "full"))
_MAX_COMPONENTS = Option("max_components", 4, "largest number of mixture components (chosen "
                         "by BIC)", lower=1, upper=20)
_LF_REFINE = Option("lf_refine", 0, "cross-entropy steps of the density on the cheap model "
                    "after the fit to subset simulation's samples (each n_refine cheap runs: the "
                    "density is refitted to the importance-weighted failing draws)", lower=0,
                    upper=10)
_N_REFINE = Option("n_refine", 1000, "cheap-model draws per cross-entropy step", lower=50)


@dataclasses.dataclass(frozen=True)
class BiasingDensity:
    """A family of biasing densities for multi-fidelity importance sampling, with its
    settings (validated at construction; :attr:`SETTINGS` declares them)."""

    #: The family's name, as ``biasing=`` spells it.
    name: ClassVar[str] = ""
    #: The family's declared settings.
    SETTINGS: ClassVar[tuple[Option, ...]] = ()

    def __post_init__(self) -> None:
        for o in self.SETTINGS:
            object.__setattr__(self, o.name, o.validate(getattr(self, o.name),
                                                        f"biasing {self.name!r}"))

    @classmethod
    def from_settings(cls, s: Mapping[str, Any]) -> BiasingDensity:
        """The family built from flat method settings (the ones it owns)."""
        return cls(**{o.name: s[o.name] for o in cls.SETTINGS})

    def settings(self) -> dict[str, Any]:
        """The family's settings by name."""
        return {o.name: getattr(self, o.name) for o in self.SETTINGS}

    def __str__(self) -> str:
        return f"{self.name}({', '.join(f'{k}={v!r}' for k, v in self.settings().items())})"

    def fit(self, ev_lf: LimitStateEvaluator | Widened, seed: int) -> CheapFit:
        """Explore the cheap model's failure set and fit the density to it."""
        raise NotImplementedError

    def widened(self, first: CheapFit, ev_lf: LimitStateEvaluator, seed: int, delta: float
                ) -> CheapFit:
        """The density refitted to ``{g_LF <= delta}`` (by default a new exploration of the
        widened set; ``first`` is the fit to ``{g_LF <= 0}``)."""
        return self.fit(Widened(ev_lf, delta), seed)


def _walk(ev_lf: Any, n_per_level: int, seed: int) -> tuple[subset.Walk, float]:
    """Subset simulation on the cheap model; the ``g_LF`` level its last level reaches back
    to (``inf`` when level 0, plain normal draws, was the last)."""
    sub = {o.name: o.default for o in subset.SETTINGS}
    sub["n_per_level"] = n_per_level
    walk = subset.simulate(ev_lf, sub, seed)
    levels = walk.levels or []
    covered = levels[-2]["threshold"] if len(levels) >= 2 else math.inf
    return walk, covered + getattr(ev_lf, "delta", 0.0)


def _refine(ev_lf: Any, mix: Any, steps: int, n: int, seed: int, refit: Any
            ) -> tuple[Any, dict[str, float]]:
    """Cross-entropy steps on the cheap model: draw the density, weight the failing draws by
    ``phi / h``, refit (``refit(u, c, step)``). Returns the density and the last step's
    cheap-model importance estimate, which says how well the density fits the cheap model's
    failure set before any expensive run."""
    info: dict[str, float] = {}
    for step in range(steps):
        rng = np.random.default_rng(np.random.SeedSequence([seed, 37, step]))
        u = mix.sample(n, rng)
        res = ev_lf.evaluate(u, f"mfis/refine{step}")
        c = np.where((res["status"] == 0) & (res["g"] <= 0.0), np.exp(mix.log_weights(u)), 0.0)
        info = cheap_estimate(c)
        if info["n_fail"] < 10:
            break  # too few failing draws to refit: keep the density
        mix = refit(mix, u, c, step)
    return mix, info


def _from_walk(fam: Gaussian | VMFN, ev_lf: Any, seed: int, fit: Any) -> CheapFit:
    """Subset simulation on the cheap model, the density fitted to its last level."""
    walk, covered = _walk(ev_lf, fam.n_per_level, seed)
    fail_u = walk.failing() if walk.levels else np.empty((0, ev_lf.dim))
    if fail_u.shape[0] == 0:
        return CheapFit(_defensive_only(ev_lf.dim), math.nan, False, covered, reasons=[(
            8, "the low-fidelity model found no failure: the expensive model is sampled by "
            "crude Monte Carlo (the defensive component alone)")])
    if fam.fit_to == "failing":
        fit_u, covered = fail_u, getattr(ev_lf, "delta", 0.0)
    else:
        fit_u = walk.u[np.isfinite(walk.g)]
    mix = fit(fit_u)
    mix, info = _refine(ev_lf, mix, fam.lf_refine, fam.n_refine, seed,
                        lambda m, u, c, step: m.adapted(u, c) if isinstance(m, Mixture)
                        else fam.refit(u, c, seed + step + 1, m.basis))
    return CheapFit(mix, walk.pf, True, covered, info)


@dataclasses.dataclass(frozen=True)
class Gaussian(BiasingDensity):
    """A Gaussian mixture (components by BIC) with a defensive standard normal component,
    fitted to subset simulation's last level on the cheap model, in the directions where its
    samples differ from standard normal draws (:func:`fit_mixture`)."""

    name: ClassVar[str] = "gaussian"
    SETTINGS: ClassVar[tuple[Option, ...]] = (
        _N_PER_LEVEL, _FIT_TO,
        Option("min_std", 1.0, "smallest standard deviation of a mixture component along any "
               "axis (standard normal units); 1 keeps the weights' tail light where the "
               "failure domain reaches behind the component's mean", lower=0.05, upper=3.0),
        _SUBSPACE, _MAX_COMPONENTS, _LF_REFINE, _N_REFINE, _DEFENSIVE)

    n_per_level: int = 2000
    fit_to: str = "last_level"
    min_std: float = 1.0
    subspace: str = "auto"
    max_components: int = 4
    lf_refine: int = 0
    n_refine: int = 1000
    defensive: float = 0.1

    def fit(self, ev_lf: LimitStateEvaluator | Widened, seed: int) -> CheapFit:
        """Subset simulation on the cheap model and the mixture fitted to its last level."""
        return _from_walk(self, ev_lf, seed, lambda u: fit_mixture(
            u, self.max_components, self.defensive, seed, self.min_std, self.subspace))


@dataclasses.dataclass(frozen=True)
class VMFN(BiasingDensity):
    """A von Mises-Fisher-Nakagami mixture with a defensive component
    (:mod:`gearuq.failure.methods.vmfn`), fitted to subset simulation's last level or by
    multi-level cross-entropy on the cheap model (``explore="ce"``: independent weighted
    draws from the standard normal on; subset simulation's few Markov-chain seeds crowd a
    shell into one direction)."""

    name: ClassVar[str] = "vmfn"
    SETTINGS: ClassVar[tuple[Option, ...]] = (
        _N_PER_LEVEL,
        Option("explore", "subset", "how the cheap model's failure domain is explored: "
               "'subset' (subset simulation; the density is fitted to its last level) or 'ce' "
               "(multi-level cross-entropy with the family itself, from the standard normal)",
               kind="str", choices=("subset", "ce")),
        _FIT_TO, _SUBSPACE, _MAX_COMPONENTS,
        Option("whiten", False, "fit each component in coordinates scaled by the square root "
               "of the failing draws' second moment (an elliptical shell, for a failure set "
               "{u^T A u > c} with unequal eigenvalues of A)"),
        _LF_REFINE, _N_REFINE, _DEFENSIVE)

    n_per_level: int = 2000
    explore: str = "subset"
    fit_to: str = "last_level"
    subspace: str = "auto"
    max_components: int = 4
    whiten: bool = False
    lf_refine: int = 0
    n_refine: int = 1000
    defensive: float = 0.1

    def refit(self, u: np.ndarray, weights: np.ndarray | None, seed: int,
              basis: np.ndarray | None = None) -> VMFNMixture:
        """The mixture fitted to (weighted) points ``u``."""
        if basis is None:
            basis = informative_directions(u) if self.subspace == "auto" else np.eye(u.shape[1])
        return fit_vmfn(u, weights, basis, self.defensive, self.max_components, seed,
                        whiten=self.whiten)

    def fit(self, ev_lf: LimitStateEvaluator | Widened, seed: int) -> CheapFit:
        """Subset simulation or cross-entropy on the cheap model, then the mixture."""
        if self.explore == "subset":
            return _from_walk(self, ev_lf, seed, lambda u: self.refit(u, None, seed))
        first = self._cross_entropy(ev_lf, seed)
        if not first.found_failure:
            first.density = _defensive_only(ev_lf.dim)
            return first
        mix, more = _refine(ev_lf, first.density, self.lf_refine, self.n_refine, seed,
                            lambda m, u, c, step: self.refit(u, c, seed + step + 1, m.basis))
        first.density, first.info = mix, more or first.info
        return first

    def _cross_entropy(self, ev_lf: Any, seed: int) -> CheapFit:
        """Multi-level cross-entropy (Rubinstein and Kroese 2004): level ``t`` draws
        ``n_per_level`` points of ``h_t`` (``h_0`` the standard normal), takes the threshold at
        the 0.1 quantile of ``g`` (0 once reached) and refits to the draws below it weighted by
        ``phi / h_t``. Invalid cheap runs count as safe here (the cheap model only shapes the
        density; the estimate is the expensive model's)."""
        d = ev_lf.dim
        mix = VMFNMixture(np.eye(d)[:1], np.zeros(1), np.array([d / 2.0]), np.array([float(d)]),
                          np.ones(1), self.defensive, np.eye(d))
        reasons: list[Reason] = []
        info: dict[str, float] = {"n_fail": 0.0}
        for t in range(MAX_CE_LEVELS):
            rng = np.random.default_rng(np.random.SeedSequence([seed, 41, t]))
            u = mix.sample(self.n_per_level, rng)
            res = ev_lf.evaluate(u, f"mfis/ce{t}")
            g = np.where(res["status"] == 0, res["g"], np.inf)
            gamma = max(float(np.quantile(g, 0.1)), 0.0)
            c = np.where(g <= gamma, np.exp(mix.log_weights(u)), 0.0)
            LOG.info("cross-entropy level %d: threshold %.4g, %d elite draws, %d cheap runs", t,
                     gamma, np.count_nonzero(c), ev_lf.n_runs)
            if gamma <= 0.0:
                info = cheap_estimate(c)
            if not np.isfinite(gamma) or np.count_nonzero(c) < 2:
                reasons.append((8, f"cross-entropy level {t}: too few finite cheap-model values "
                                "to go on; the density may miss part of the failure domain"))
                break
            basis = weighted_directions(u, c) if self.subspace == "auto" else mix.basis
            mix = fit_vmfn(u, c, basis, self.defensive, self.max_components, seed + t,
                           whiten=self.whiten)
            if gamma <= 0.0:
                break
        else:
            reasons.append((8, "cross-entropy did not reach the failure domain of the cheap "
                            f"model in {MAX_CE_LEVELS} levels"))
        info["levels"] = float(t + 1)
        found = info["n_fail"] > 0
        if not found:
            reasons.append((8, "the low-fidelity model found no failure: the expensive model is "
                            "sampled by crude Monte Carlo (the defensive component alone)"))
        return CheapFit(mix, info.get("pf", math.nan), found, getattr(ev_lf, "delta", 0.0),
                        info, reasons)


@dataclasses.dataclass(frozen=True)
class Quadratic(BiasingDensity):
    """The standard normal exponentially tilted by a quadratic form ``Q(u)`` fitted on the
    cheap model: ``N((I - 2tA)^-1 t b, (I - 2tA)^-1)`` with ``E_t[Q]`` on the failure level
    (:mod:`gearuq.failure.methods.quadratic`). ``n_fit`` cheap runs (half on a widened
    standard normal, half on the first tilt) fit the ``(d + 1)(d + 2) / 2`` coefficients."""

    name: ClassVar[str] = "quadratic"
    SETTINGS: ClassVar[tuple[Option, ...]] = (
        Option("n_fit", 2400, "cheap runs for the quadratic fit (half on a widened standard "
               "normal, half on the first tilted density)", lower=50),
        Option("fit_std", 1.5, "standard deviation of the first fit design", lower=0.5,
               upper=5.0),
        Option("response_offset", None, "a with the response a - g (e.g. the limit X of "
               "g = X - y); its square is fitted as the quadratic form (an RMS response), or g "
               "itself when None", kind="any", allow_none=True), _DEFENSIVE)

    n_fit: int = 2400
    fit_std: float = 1.5
    response_offset: float | None = None
    defensive: float = 0.1

    def __post_init__(self) -> None:
        super().__post_init__()
        off = self.response_offset
        if off is not None and not (isinstance(off, (int, float)) and math.isfinite(off)):
            raise ValueError(f"response_offset: expected a finite number or None, got {off!r}")

    def _target(self, g: np.ndarray, delta: float = 0.0) -> tuple[np.ndarray, float]:
        """The fitted quantity and its failure level on ``{g_LF <= delta}``."""
        off = self.response_offset
        if off is None:
            return -g, -delta
        return (float(off) - g) ** 2, max(float(off) - delta, 0.0) ** 2

    def fit(self, ev_lf: LimitStateEvaluator | Widened, seed: int) -> CheapFit:
        """Fit ``Q(u)`` on the cheap model, tilt, refit with the tilted draws, tilt again; the
        second stage's draws also give the cheap model's importance estimate."""
        d = ev_lf.dim
        n1 = self.n_fit // 2
        rng = np.random.default_rng(np.random.SeedSequence([seed, 53]))
        u1 = self.fit_std * rng.standard_normal((n1, d))
        g1 = ev_lf.evaluate(u1, "mfis/quadratic_fit0")["g"]
        ok = np.isfinite(g1)
        q1, level = self._target(g1[ok])
        a, b, c0, r2 = fit_quadratic(u1[ok], q1)
        mu, sigma, t = tilted_gaussian(a, b, c0, level)
        mix = Mixture(mu[None], sigma[None], np.ones(1), self.defensive)
        u2 = mix.sample(self.n_fit - n1, rng)
        res = ev_lf.evaluate(u2, "mfis/quadratic_fit1")
        c = np.where((res["status"] == 0) & (res["g"] <= 0.0), np.exp(mix.log_weights(u2)), 0.0)
        fin = np.isfinite(res["g"])
        q_all, _ = self._target(np.concatenate([g1[ok], res["g"][fin]]))
        a, b, c0, r2 = fit_quadratic(np.vstack([u1[ok], u2[fin]]), q_all)
        info = {**cheap_estimate(c), "r2": r2}
        return self._tilt(a, b, c0, 0.0, info)

    def _tilt(self, a: np.ndarray, b: np.ndarray, c0: float, delta: float,
              info: dict[str, Any]) -> CheapFit:
        mu, sigma, t = tilted_gaussian(a, b, c0, self._target(np.zeros(1), delta)[1])
        LOG.info("quadratic fit R^2 %.4f, tilt %.4g, largest variance %.3g, cheap pf %.3g",
                 info["r2"], t, float(np.linalg.eigvalsh(sigma).max()), info["pf"])
        mix = Mixture(mu[None], sigma[None], np.ones(1), self.defensive)
        mix.n_directions = mu.size
        return CheapFit(mix, info["pf"], True, delta, {**info, "tilt": t,
                                                         "form": (a, b, c0)})

    def widened(self, first: CheapFit, ev_lf: LimitStateEvaluator, seed: int, delta: float
                ) -> CheapFit:
        """The same fitted form tilted to the widened level (no new cheap runs)."""
        a, b, c0 = first.info["form"]
        return self._tilt(a, b, c0, delta, {k: v for k, v in first.info.items()
                                            if k not in ("tilt", "form")})


#: The families by the name ``biasing=`` accepts.
FAMILIES: dict[str, type[BiasingDensity]] = {c.name: c for c in (Gaussian, VMFN, Quadratic)}

#: Each family setting once, in the order the families declare them (the flat keywords of
#: method "mfis").
FAMILY_SETTINGS: tuple[Option, ...] = tuple(
    {o.name: o for c in FAMILIES.values() for o in c.SETTINGS}.values())


def resolve_biasing(s: Mapping[str, Any]) -> BiasingDensity:
    """The biasing family of validated settings ``s``: the ``biasing`` instance, or the named
    family built from the flat keywords it owns (a keyword another family owns, changed from
    its default, is refused)."""
    b = s["biasing"]
    changed = [o for o in FAMILY_SETTINGS if not _same(s[o.name], o.default)]
    if isinstance(b, BiasingDensity):
        if changed:
            raise ValueError(f"{changed[0].name}: give it to {type(b).__name__}(...), which owns "
                             "its settings, not as a keyword beside biasing=")
        return b
    cls = FAMILIES[b]
    for o in changed:
        if o not in cls.SETTINGS:
            owner = next(c.name for c in FAMILIES.values() if o in c.SETTINGS)
            raise ValueError(f"{o.name}: {s[o.name]!r} needs biasing={owner!r}, got "
                             f"biasing={b!r}")
    return cls.from_settings(s)


def _same(a: Any, b: Any) -> bool:  # a setting left at its default
    return a is b or (type(a) is type(b) and a == b)
