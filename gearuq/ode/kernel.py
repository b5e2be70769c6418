"""The compiled integration loop, specialised per method and event treatment, and its entry
points.

Compile only what a call needs
------------------------------
A kernel *variant* is one (method, events) pair: method ``dopri5`` / ``dop853`` / ``rk4``
and events ``"none"`` (no switching functions), ``"retake"`` (steps re-taken up to a located
crossing) or ``"frozen"`` (frozen sides, accepted steps truncated at the crossing). Each
variant is its own entry point, compiled on first use and cached on disk. The variant is a
compile-time constant: the per-sample loop is produced by an ``@overload`` whose
implementation is a closure over the variant's integer codes, and numba prunes the branches
of the other methods and treatments *before* typing, so a call types and optimises only the
code it runs. The entry points are closures over integers only (the variant codes and a
digest of this package's compiled sources), which keeps numba's cache key stable across
processes (a closure over a dispatcher would not be: see docs/ode.md).

The right-hand side reaches the kernel as a numba first-class function argument typed by
``RHS_SIGNATURE``, so a variant is compiled once for every ``rhs`` (see docs/ode.md).
"""

from __future__ import annotations

import hashlib
import math
import os
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit, types

from .constants import (
    EPS,
    HMIN_REL,
    ROOT_XTOL_REL,
    STATUS_NONFINITE,
    STATUS_OK,
    STATUS_STEP_LIMIT,
    STATUS_STEP_UNDERFLOW,
)
from .events import first_root, g_at, overshoot_tol, scan_crossing, sgn
from .stages import (
    all_finite,
    dense_dop853_extra,
    dense_dopri5,
    dense_eval,
    dense_eval_save,
    dense_hermite,
    eval_into,
    hinit,
    row_finite,
    step_dop853,
    step_dopri5,
    step_rk4,
    view1,
    view2,
    write_state,
)
from .tableaux import (
    DENSE_ROWS,
    DOP853,
    DOPRI5,
    END_STAGE,
    FAC_MAX,
    FAC_MIN,
    METHOD_CODE,
    N_STAGES,
    ORDER,
    PI_BETA,
)

#: A step cut at a crossing that ends this much shorter than the step the controller asked
#: for, without the crossing registering, marks a stall (see ``stalled`` in the kernel).
STALL_FRACTION = 1e-6

#: Event treatments (see the module docstring).
EVENTS_NONE = 0
EVENTS_RETAKE = 1
EVENTS_FROZEN = 2

_F1 = types.float64[::1]
#: numba signature every ``rhs`` and ``switch`` must compile to.
RHS_SIGNATURE = types.void(types.float64, _F1, _F1, _F1)
_FN = types.FunctionType(RHS_SIGNATURE)
#: Signature of every entry point (one per variant).
KERNEL_SIGNATURE = types.void(
    _FN, _FN,
    types.float64[:, ::1], types.float64[:, ::1], _F1, types.float64[:, ::1],
    types.int64[::1], types.float64[:, :, ::1],
    types.float64, _F1, types.float64, types.float64, types.int64, types.float64,
    types.int64, types.int8[::1], types.int64[:, ::1],
)


# --------------------------------------------------------------------------------------------
# One sample, specialised per variant
# --------------------------------------------------------------------------------------------

def _make_kernel(METHOD: int, EVENTS: int, DIGEST: int):
    """The compiled kernel of one variant (:func:`kernel_function`, compiled for
    ``KERNEL_SIGNATURE``: numba compiles it here, eagerly)."""
    return njit(KERNEL_SIGNATURE, cache=True, nogil=True, error_model="numpy")(
        kernel_function(METHOD, EVENTS, DIGEST))


def kernel_function(METHOD: int, EVENTS: int, DIGEST: int):
    """The Python function of one variant's kernel: every sample integrated in turn, serially.

    ``if METHOD == ...`` and ``if FROZEN`` are pruned by numba before typing (they are
    constants of the closure); ``DIGEST`` only keys the on-disk cache (see
    :func:`_source_digest`).

    One long function, on purpose: the step loop's state (t, h, y, the sides of the
    switching functions, the counters, the rows of the interpolant) is shared by the trial
    step, the event location and the output stage, which therefore stay in one loop;
    splitting them into compiled functions would pass some twenty scalars back and forth
    and add a typed function per piece to the cold compile. The self-contained parts are
    functions of their own (stages.py, events.py).
    """
    NK = N_STAGES[METHOD]
    KF = END_STAGE[METHOD]
    M_FULL = DENSE_ROWS[METHOD]
    Q = ORDER[METHOD]
    FAC1 = FAC_MIN[METHOD]
    FAC2 = FAC_MAX[METHOD]
    BETA = PI_BETA[METHOD]
    SWITCHING = EVENTS != EVENTS_NONE
    FROZEN = EVENTS == EVENTS_FROZEN
    SAFE = 0.9  # Hairer's safety factor
    EXPO1 = 1.0 / Q - 0.75 * BETA
    FACC1 = 1.0 / FAC1
    FACC2 = 1.0 / FAC2

    def kernel(rhs, switch, Y0, P, T0, TE, save_in, OUT, rtol, atol_in, max_step, first_step,
               max_steps, fixed_h, n_switch, status_out, counts):
        # One long loop on purpose (see the docstring of _make_kernel): per sample, set up the
        # work arrays, then step: trial step, event location, error test, outputs.
        if DIGEST < 0:  # never true (pruned): DIGEST only keys the on-disk cache
            return
        for sample in range(Y0.shape[0]):
            y0 = Y0[sample]
            p_in = P[sample]
            t0 = T0[sample]
            te_in = TE[0] if TE.shape[0] == 1 else TE[sample]
            out_in = OUT[sample]
            cnt = counts[sample]
            n = y0.size
            nt = te_in.size
            adaptive = fixed_h <= 0.0
            # All float work arrays are reference-count-free views into one buffer (see
            # stages.py); p and atol are private copies, so no thread touches a shared count.
            ns = max(n_switch, 1)
            npar = p_in.size
            # With frozen sides, p is extended by the side (+1/-1, 0 unknown) of every switching
            # function at the step start, so that the rhs can pick its branch from them.
            n_side = n_switch if FROZEN else 0
            work = np.zeros(8 * n + (NK + 7) * n + 12 * ns + npar + n_side)
            zero = np.int64(0)
            y = view1(work, zero, n)
            f = view1(work, n, n)
            ynew = view1(work, 2 * n, n)
            yt = view1(work, 3 * n, n)
            ym = view1(work, 4 * n, n)
            ev = view1(work, 5 * n, n)
            atol = view1(work, 6 * n, n)
            K = view2(work, 8 * n, np.int64(NK), n)
            R = view2(work, (8 + NK) * n, np.int64(7), n)
            o = (NK + 15) * n
            g0 = view1(work, o, ns)  # g at the current accepted state
            g1 = view1(work, o + ns, ns)  # g at the end of the step being taken
            g_base = view1(work, o + 2 * ns, ns)
            ga = view1(work, o + 3 * ns, ns)
            gb = view1(work, o + 4 * ns, ns)
            gw = view1(work, o + 5 * ns, ns)
            gs = view2(work, o + 6 * ns, np.int64(5), ns)  # samples of g within a step
            # last non-zero side (+1.0 / -1.0, 0.0 unknown) of each switching function
            side = view1(work, o + 11 * ns, ns)
            p = view1(work, o + 12 * ns, npar + n_side)
            for i in range(n):
                y[i] = y0[i]
                atol[i] = atol_in[i]
            for i in range(npar):
                p[i] = p_in[i]
            te = view1(te_in, zero, nt)
            out = view2(out_in, zero, nt, save_in.size)
            save = save_in

            n_acc = 0
            n_rej = 0
            n_att = 0
            n_rhs = 0
            n_ev = 0
            status = STATUS_OK

            t = t0
            t_end = te[nt - 1]
            j = 0
            while j < nt and te[j] <= t:
                write_state(y, save, out, j)
                j += 1

            if j < nt:
                eval_into(rhs, t, y, p, f, K, np.int64(0))
                n_rhs += 1
                if not row_finite(K, np.int64(0)):
                    status = STATUS_NONFINITE
            h = 0.0
            if status == STATUS_OK and j < nt:
                if SWITCHING:
                    switch(t, y, p, g0)
                    for s in range(n_switch):
                        side[s] = sgn(g0[s])
                        if FROZEN:
                            p[npar + s] = side[s]
                if adaptive:
                    hmax = min(max_step, t_end - t)
                    if first_step > 0.0:
                        h = min(first_step, hmax)
                    else:
                        h = hinit(rhs, t, y, p, f, Q, hmax, rtol, atol, yt, ym)
                        n_rhs += 1
                else:
                    h = fixed_h
            facold = 1e-4
            last_rejected = False
            nonfinite_reject = False
            # A switching function whose crossing the previous step was cut for but whose sign
            # at the accepted end did not flip (the surface lies within the rounding noise of g
            # there): its crossing is registered at the start of the next step instead of
            # cutting steps ever closer to it.
            stalled = -1
            stalled_len = 0.0
            while status == STATUS_OK and j < nt:
                if n_att >= max_steps:
                    status = STATUS_STEP_LIMIT
                    break
                if adaptive:
                    h = min(h, max_step)
                    if not h > HMIN_REL * abs(t):
                        status = STATUS_NONFINITE if nonfinite_reject else STATUS_STEP_UNDERFLOW
                        break
                    # Hairer: stretch the step by up to 1 % rather than leave a sliver at the end.
                    last = t + 1.01 * h >= t_end
                else:
                    last = t + (1.0 + 1e-9) * h >= t_end
                if last:
                    h = t_end - t
                    t_new = t_end
                else:
                    t_new = t + h
                h_trial = h
                hs = h
                tb = t_new  # end of the step as cut at a switching surface

                # ---- trial step, then (with switching functions) cut it at the first crossing.
                # Without frozen sides the cut comes before the error test (a step across a kink
                # has a large error estimate, and testing it first would cost a cascade of
                # rejections per kink) and the step is re-taken up to the root. With frozen
                # sides the trial integrates one smooth field, so it is error-tested as it is
                # and, if accepted, truncated at the root on its own interpolant (no re-take).
                shortened = False
                hd = hs  # size of the step the interpolant R belongs to
                finite = True
                err = 0.0
                dense_rows = 0  # rows of the interpolant filled for the current step (0: none)
                cut_comp = -1  # switching function the step was cut for
                cut_side = 0  # its side before the cut
                for attempt in range(9):
                    if attempt > 0:
                        # Redo the step: cut so that it ends just past the located root, or
                        # unchanged after a side flip at its start (frozen sides).
                        if tb < t_new:
                            shortened = True
                        t_new = tb
                        hs = t_new - t
                        hd = hs
                        dense_rows = 0
                    if METHOD == DOPRI5:
                        err, nf = step_dopri5(rhs, t, t_new, y, p, hs, K, yt, f, ynew, ev, atol,
                                              rtol, adaptive)
                    elif METHOD == DOP853:
                        err, nf = step_dop853(rhs, t, t_new, y, p, hs, K, yt, f, ynew, ev, atol,
                                              rtol, adaptive)
                    else:
                        err, nf = step_rk4(rhs, t, t_new, y, p, hs, K, yt, f, ynew, ev, atol,
                                           rtol, adaptive)
                    n_rhs += nf
                    n_att += 1
                    finite = math.isfinite(err) and all_finite(ynew)
                    if finite and METHOD != DOPRI5:
                        eval_into(rhs, t_new, ynew, p, f, K, np.int64(KF))
                        n_rhs += 1
                    finite = finite and row_finite(K, np.int64(KF))
                    if not SWITCHING:
                        break
                    if not finite or (FROZEN and adaptive and err > 1.0):
                        break
                    switch(t_new, ynew, p, g1)
                    t_base = t
                    for s in range(n_switch):
                        g_base[s] = g0[s]
                    first = -1
                    redo = False
                    dt_ok = 0.0
                    for _sub in range(n_switch + 1):
                        if dense_rows == 0:
                            if METHOD == DOPRI5:
                                dense_rows = dense_dopri5(R, y, hs, K, ynew)
                            else:
                                dense_rows = dense_hermite(R, y, hs, K, ynew, np.int64(KF))
                        if dense_rows < M_FULL:
                            # dop853: cheap Hermite test first, the 7th-order rows only on a hit.
                            found, ta, tq = scan_crossing(switch, R, dense_rows, y, t, hs, p,
                                                          t_base, g_base, t_new, g1, side,
                                                          n_switch, ym, gs, ga, gb, gw)
                            if not found:
                                first = -1
                                break
                            dense_rows = dense_dop853_extra(rhs, t, y, p, hs, K, yt, f, R)
                            n_rhs += 3
                        dt_ok = overshoot_tol(K, np.int64(KF), ynew, atol, rtol, hs)
                        found, ta, tq = scan_crossing(switch, R, dense_rows, y, t, hs, p, t_base,
                                                      g_base, t_new, g1, side, n_switch, ym, gs,
                                                      ga, gb, gw)
                        if not found:
                            first = -1
                            break
                        first, tb = first_root(switch, R, dense_rows, y, t, hs, p, ta, tq, side,
                                               n_switch, ym, ga, gb, gw, dt_ok)
                        if first < 0:
                            break
                        tol = 2.0 * (ROOT_XTOL_REL * hs + 4.0 * EPS * abs(tb))
                        if tb - t_base > tol and not (first == stalled
                                                      and tb - t_base <= 4.0 * stalled_len):
                            break
                        # A crossing within root tolerance of the step start (the previous step
                        # ended a hair short of the surface): register it at the accepted state
                        # and look for further crossings in the rest of the step.
                        n_ev += 1
                        side[first] = -side[first]
                        g0[first] = 0.0
                        stalled = -1
                        if FROZEN:
                            # The step was computed on the old side: redo it on the new one.
                            p[npar + first] = side[first]
                            redo = True
                            break
                        t_base = tb
                        g_at(switch, R, dense_rows, y, t, hs, p, t_base, ym, g_base)
                        first = -1
                    if redo:
                        tb = t_new
                        continue
                    if first < 0:
                        break
                    near = max(dt_ok, 2.0 * (ROOT_XTOL_REL * hs + 4.0 * EPS * abs(tb)))
                    if FROZEN:
                        if t_new - tb > near:
                            # Truncate the accepted trial at the root: the end state is the
                            # (error controlled) interpolant there, f is evaluated afresh at it.
                            cut_comp = first
                            cut_side = side[first]
                            dense_eval(R, dense_rows, y, (tb - t) / hd, ynew)
                            t_new = tb
                            hs = t_new - t
                            eval_into(rhs, t_new, ynew, p, f, K, np.int64(KF))
                            n_rhs += 1
                            finite = all_finite(ynew) and row_finite(K, np.int64(KF))
                            switch(t_new, ynew, p, g1)
                        break
                    # No crossing, or the step already ends just past the first root (by at most
                    # dt_ok, see overshoot_tol): accept; else re-take it up to the root.
                    if t_new - tb <= near:
                        break
                    cut_comp = first
                    cut_side = side[first]

                if not finite:
                    if adaptive:
                        # Overflow or NaN inside the step: shrink hard and retry. If it never
                        # recovers, the step size underflows and the status says non-finite.
                        n_rej += 1
                        h = hs * FAC1
                        last_rejected = True
                        nonfinite_reject = True
                        continue
                    status = STATUS_NONFINITE
                    break

                hnew = h
                if adaptive:
                    fac11 = err ** EXPO1
                    fac = fac11 / facold ** BETA
                    fac = max(FACC2, min(FACC1, fac / SAFE))
                    # hd: the size of the step err belongs to (a truncated step keeps its trial's).
                    hnew = hd / fac
                    if err > 1.0:
                        n_rej += 1
                        h = hd / min(FACC1, fac11 / SAFE)
                        last_rejected = True
                        nonfinite_reject = False
                        continue

                # ---- the step [t, t_new] is accepted
                if SWITCHING:
                    # Register the sides reached at the step end. The stage f(t_new, y_new) that
                    # starts the next step is already the new side's: a re-taken step evaluates
                    # it at its end, past the surface, and a truncated one evaluates it afresh.
                    for s in range(n_switch):
                        sg = sgn(g1[s])
                        if sg != 0:
                            if side[s] != 0 and sg != side[s]:
                                n_ev += 1
                            side[s] = sg
                            if FROZEN:
                                p[npar + s] = sg
                    stalled = -1
                    if (cut_comp >= 0 and side[cut_comp] == cut_side
                            and t_new - t <= STALL_FRACTION * h_trial):
                        stalled = cut_comp
                        stalled_len = t_new - t

                # ---- output instants inside (t, t_new] by dense output
                while j < nt and te[j] <= t_new:
                    if te[j] == t_new:
                        write_state(ynew, save, out, j)
                    else:
                        if dense_rows < M_FULL:
                            # (never for a truncated step: its rows were completed to find the root)
                            if METHOD == DOPRI5:
                                dense_rows = dense_dopri5(R, y, hs, K, ynew)
                            else:
                                dense_rows = dense_hermite(R, y, hs, K, ynew, np.int64(KF))
                                if METHOD == DOP853:
                                    dense_rows = dense_dop853_extra(rhs, t, y, p, hs, K, yt, f, R)
                                    n_rhs += 3
                        dense_eval_save(R, dense_rows, y, (te[j] - t) / hd, save, out, j)
                    j += 1

                n_acc += 1
                t = t_new
                for i in range(n):
                    y[i] = ynew[i]
                    K[0, i] = K[KF, i]
                for s in range(n_switch):
                    g0[s] = g1[s]
                if adaptive:
                    facold = max(err, 1e-4)
                    if last_rejected:
                        # Hairer: no step growth right after a rejection.
                        hnew = min(hnew, hd)
                    if shortened:
                        # A step cut at a surface says nothing about the step size beyond it;
                        # the size proposed before the cut does.
                        hnew = max(hnew, h_trial)
                    last_rejected = False
                    nonfinite_reject = False
                    h = hnew
                else:
                    h = fixed_h

            cnt[0] = n_acc
            cnt[1] = n_rej
            cnt[2] = n_rhs
            cnt[3] = n_ev
            # The views above do not own their memory: keep the buffer alive up to here.
            work[0] = 0.0
            status_out[sample] = status

    kernel.__qualname__ = kernel.__name__ = (
        f"solve_{_METHOD_NAME[METHOD]}_{_EVENTS_NAME[EVENTS]}")
    return kernel


# --------------------------------------------------------------------------------------------
# Entry points: one per variant, explicit signature, compiled on first use and cached
# --------------------------------------------------------------------------------------------

#: Names of the event treatments accepted by :func:`get_kernel`.
EVENT_TREATMENTS = {"none": EVENTS_NONE, "retake": EVENTS_RETAKE, "frozen": EVENTS_FROZEN}
_SOURCES = ("constants.py", "tableaux.py", "stages.py", "events.py", "kernel.py")
_KERNELS: dict[tuple[int, int], Any] = {}


def _source_digest() -> int:
    """A 60-bit digest of the compiled sources of this package.

    numba invalidates a cached entry point when the file that defines it changes, not when a
    function it calls from another file does. The entry points are closures over this
    digest, which is part of numba's cache key, so editing any of these files recompiles.
    """
    here = Path(__file__).resolve().parent
    digest = hashlib.sha256()
    for name in _SOURCES:
        digest.update((here / name).read_bytes())
    return int(digest.hexdigest()[:15], 16)


_METHOD_NAME = {code: name for name, code in METHOD_CODE.items()}
_EVENTS_NAME = {code: name for name, code in EVENT_TREATMENTS.items()}


def get_kernel(method: str, events: str) -> Any:
    """The compiled entry point of a variant, compiling it (or loading it from the cache) once.

    Parameters
    ----------
    method : {"dopri5", "dop853", "rk4"}
    events : {"none", "retake", "frozen"}

    Compilation is deferred to the first use so that ``import gearuq.ode`` stays cheap, and
    only the variants a process uses are compiled or loaded.
    """
    key = (METHOD_CODE[method], EVENT_TREATMENTS[events])
    if key not in _KERNELS:
        _KERNELS[key] = _make_kernel(*key, _source_digest())
    return _KERNELS[key]


def run_threads(kernel: Any, args: tuple, n_samples: int, n_threads: int) -> None:
    """Run ``kernel`` over sample blocks in ``n_threads`` threads (the kernel drops the GIL).

    Samples share nothing and every block writes only its own rows of ``out``, ``status``
    and ``counts``, so results are bit-identical to one serial call. More blocks than
    threads balance samples of unequal cost (contact loss, stiff draws).
    """
    from concurrent.futures import ThreadPoolExecutor

    (rhs, switch, y0, p, t0, te, save, out, rtol, atol, max_step, first_step, max_steps,
     fixed_h, n_switch, status, counts) = args
    n_blocks = min(n_samples, 8 * n_threads)
    edges = np.linspace(0, n_samples, n_blocks + 1).astype(np.int64)

    def block(k: int) -> None:
        sl = slice(int(edges[k]), int(edges[k + 1]))
        kernel(rhs, switch, y0[sl], p[sl], t0[sl], te if te.shape[0] == 1 else te[sl], save,
               out[sl], rtol, atol, max_step, first_step, max_steps, fixed_h, n_switch,
               status[sl], counts[sl])

    with ThreadPoolExecutor(max_workers=n_threads) as pool:
        for future in [pool.submit(block, k) for k in range(n_blocks)]:
            future.result()


def default_threads(n_samples: int, parallel: bool) -> int:
    """Threads used for a batch: one per core (at most one per sample), or 1."""
    return min(os.cpu_count() or 1, n_samples) if parallel else 1


def _nothing(t, y, p, g):  # pragma: no cover - never called (n_switch = 0)
    pass


_NO_SWITCH: list[Any] = []


def no_switch(compiled: bool = True) -> Any:
    """A do-nothing ``switch`` for the variants without switching functions (never called);
    its Python function for the plain-Python route (nothing to compile)."""
    if not compiled:
        return _nothing
    if not _NO_SWITCH:
        _NO_SWITCH.append(njit(RHS_SIGNATURE, cache=True)(_nothing))
    return _NO_SWITCH[0]


#: Plain-Python stand-ins for the raw-pointer views of stages.py (numpy views of the buffer).
_PYTHON_VIEWS = {"view1": lambda buf, offset, n: buf[offset:offset + n],
                 "view2": lambda buf, offset, n0, n1: buf[offset:offset + n0 * n1].reshape(
                     n0, n1)}
_ROUTES: dict[tuple[str, str], Any] = {}


def _lazy_variant(method: str, events: str) -> Any:
    """The variant as a lazy dispatcher: for its cache lookup and its Python twin only (the
    entry point of :func:`get_kernel` compiles on creation)."""
    key = (METHOD_CODE[method], EVENT_TREATMENTS[events])
    return njit(cache=True, nogil=True, error_model="numpy")(
        kernel_function(*key, _source_digest()))


def variant_ready(method: str, events: str) -> bool:
    """True when the variant is compiled in this process or stored in numba's disk cache."""
    from gearuq._firstcall import signature_cached

    if (METHOD_CODE[method], EVENT_TREATMENTS[events]) in _KERNELS:
        return True
    return signature_cached(_lazy_variant(method, events), KERNEL_SIGNATURE)


def first_call_route(method: str, events: str) -> Any:
    """The :class:`gearuq._firstcall.FirstCallRoute` of a variant: compiled, or its own
    Python source with the pointer views replaced by numpy views (units: the caller's
    estimate of the interpreted CPU seconds)."""
    from gearuq._firstcall import FirstCallRoute, interpreted

    if (method, events) not in _ROUTES:
        def compiled(*args: Any) -> Any:
            return get_kernel(method, events)(*args)

        _ROUTES[method, events] = FirstCallRoute(
            compiled, f"the batched ODE integrator ({method}, {events} events)",
            unit_cpu=1.0, compile_cpu=10.0, ready=lambda args: variant_ready(method, events),
            twin=lambda: interpreted(_lazy_variant(method, events), _PYTHON_VIEWS))
    return _ROUTES[method, events]
