"""The :class:`ETS` estimator: parameters, input checks, state and the calls into the kernels."""

from __future__ import annotations

import inspect
from collections.abc import Sequence
from contextlib import nullcontext
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from etsid.ets import layout as L
from etsid.ets.history import History, HistoryRecorder, raw_consequents
from etsid.ets.kernels import (
    learn_kernel,
    predict_kernel,
    predict_row,
    predict_setup,
    slp_vectorised,
)
from etsid.ets.kernels_lanes import learn_lanes
from etsid.ets.normalisation import scales
from etsid.ets.params import BLENDS, CLUSTERINGS, DEFAULTS, RLS_KINDS, VARIANTS
from etsid.ets.state import LearnedState

if TYPE_CHECKING:  # pragma: no cover
    import pandas as pd

#: one learning-kernel call buffers at most this many bytes of consequent snapshots (at
#: least 16 snapshots) and this many events; it returns when a buffer is full
_SNAPSHOT_BYTES_PER_CALL = 1 << 20
_EVENTS_PER_CALL = 4096
#: rule counts where learning switches kernels: the rule-major ``learn_kernel`` runs while
#: R <= _RULE_MAJOR_MAX, ``learn_lanes`` (vectorised across rules) while R >= _LANES_MIN;
#: in between whichever ran last goes on (docs/performance.md measured the crossover)
_RULE_MAJOR_MAX = 6
_LANES_MIN = 4


def _finite_2d(a: Any, name: str, width: int | None = None) -> np.ndarray:
    """Return ``a`` as a C-contiguous float64 (N, width) array or raise ValueError."""
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim != 2:
        raise ValueError(f"{name} must be a 2-D array (samples, columns); got shape {arr.shape}")
    if width is not None and arr.shape[1] != width:
        raise ValueError(f"{name} must have {width} columns, got {arr.shape[1]}")
    if arr.shape[1] == 0:
        raise ValueError(f"{name} has no columns")
    # one sum is NaN or inf when any value is (or, rarely, when finite values overflow):
    # the element-wise test runs only then, and allocates nothing on the common path
    with np.errstate(over="ignore", invalid="ignore"):
        total = np.add.reduce(arr, axis=None)
    if not np.isfinite(total) and not np.isfinite(arr).all():
        bad = ~np.isfinite(arr)
        row, col = np.argwhere(bad)[0]
        raise ValueError(
            f"{name} contains {int(bad.sum())} non-finite value(s) (NaN or inf), "
            f"first at row {row}, column {col}"
        )
    return np.ascontiguousarray(arr)


class ETS:
    """Evolving Takagi–Sugeno model with MIMO first-order rules (eTS 2004 / eTS+ 2010).

    Rule i: IF x is near x*_i THEN y_i = x_e^T Pi_i, x_e = [1, (x - lo) / s]. Learning is
    online: every sample is first predicted, then learned (structure, then consequents).

    Parameters
    ----------
    radius : float or sequence of float
        Zone of influence r (per input if a sequence), in normalised units (fraction of the
        input range). Firing tau = exp(-4 sum_j (dx_j / (s_j r_j))^2).
    omega : float
        Initial covariance C = omega I of a new rule's RLS (large = weak prior).
    variant : {"ets", "ets+"}
        "ets": Angelov & Filev (2004) structure test, no pruning. "ets+": Angelov (2010):
        births also at low potential in uncovered regions, utility/support pruning.
    max_rules : int
        Cap on the number of rules; at the cap a birth moves the nearest rule's focal point
        instead (a "replace" event; the consequent is kept).
    rls : {"local", "global"}
        Fuzzily weighted local RLS per rule, or one global RLS over all consequents.
    forgetting : float
        RLS forgetting factor in (0, 1]; 1 means no forgetting. Weighted by each rule's
        firing, and guarded against wind-up on held inputs: a rule forgets only while
        trace(C_i) <= omega (n + 1) (docs/ets.md, "Consequents").
    utility_threshold : float
        eTS+: a rule whose utility (mean normalised firing since birth) falls below this is removed.
    min_support : int
        eTS+: a rule that has won fewer than this many samples after ``prune_after`` steps
        is removed.
    prune_after : int
        eTS+: steps a rule lives before utility and support are checked (samples).
    adaptive_spread : bool
        exTS (Angelov & Zhou 2006): adapt per-rule, per-input radii to the local scatter
        (on by default; ``radius`` is then the width a rule is born with).
    coverage : bool
        eTS+ only (an etsid extension, see docs/ets.md): also add a rule for any sample that
        no rule covers (within r/2 of a focal point in every input), whatever its potential.
    x_range, y_range : array-like of shape (n, 2) / (m, 2), optional
        Fixed [low, high] normalisation ranges in original units. When omitted the range is
        the running min/max of the data (focal points are kept in original units, so they
        never drift; consequents are re-expressed exactly when a range widens).
    s_range : array-like of shape (na, 2), optional
        Fixed [low, high] ranges of the scheduling inputs S of a scheduled model (the radius
        is a fraction of them); omitted: their running min/max. Only with ``run(X, Y, S)``.
    history_every : int
        Record a snapshot of all consequents every this many learned samples.
    clustering : {"potential", "evq"}
        How the rule base evolves. "potential": births and focal-point moves driven by the
        potentials, as ``variant`` says (eTS / eTS+). "evq": evolving vector quantisation
        (Lughofer 2008, FLEXFIS): a rule is born on every sample no rule covers (within r/2
        of a focal point in every antecedent input) and otherwise the winning rule's focal
        point moves to the running mean of the samples it has won, so focal points sit at
        the centres of the regimes visited instead of chasing the global data mean; the
        potentials are still recorded and the eTS+ pruning still applies (variant "ets+").
    blend : {"firing", "interpolate"}
        How the rule outputs make the model's output (every prediction: ``run``'s one-step
        predictions, ``predict``, ``predict_one``). "firing": weighted by the normalised
        firing λ_i. "interpolate" (a scheduled model with one antecedent input only):
        linear interpolation in s between the two rules whose focal points enclose it,
        y = (1 − w) y_lo + w y_hi with w = (s − s*_lo) / (s*_hi − s*_lo), the outermost
        rule alone beyond them — the local models are the regimes' own and the model
        between two regimes is their linear interpolation, as in gain scheduling. Learning
        (firing, potentials, births, consequent RLS weights λ_i) is the same for both.
    input_names, output_names : sequence of str, optional
        Names used by :meth:`rules` and the rule-base JSON (default x1.., y1..).
    antecedent_names : sequence of str, optional
        Names of the scheduling inputs S of a scheduled model (default s1..).

    Notes
    -----
    Scheduling: ``run(X, Y, S)`` puts the antecedents (potentials, firing, births and
    the radius) on the scheduling vector ``S`` (N, na) while the consequents stay local
    linear models on the full ``X``: rule i reads IF s is near s*_i THEN y_i = x_e^T Pi_i.
    The potentials are then computed on s alone. Without ``S`` the antecedents are on x
    and the potentials on z = [x; y], as in eTS.

    Examples
    --------
    >>> import numpy as np
    >>> from etsid.ets import ETS
    >>> rng = np.random.default_rng(0)
    >>> X = rng.uniform(-1.0, 1.0, size=(2000, 1))
    >>> Y = np.where(X[:, 0] < 0.0, -2.0 * X[:, 0], 0.5 * X[:, 0])
    >>> model = ETS(radius=0.3, adaptive_spread=False)  # fixed spreads: radius is the width
    >>> Yhat = model.run(X, Y)
    >>> Yhat.shape
    (2000,)
    >>> bool(np.sqrt(np.mean((Yhat[1000:] - Y[1000:]) ** 2)) < 0.1)
    True
    >>> model.n_rules == len(model) >= 2
    True
    >>> bool(model.predict(np.array([[0.5]]))[0] == model.predict_one([0.5])[0])
    True
    """

    def __init__(
        self,
        radius: float | Sequence[float] = DEFAULTS.radius,
        omega: float = DEFAULTS.omega,
        variant: str = DEFAULTS.variant,
        max_rules: int = DEFAULTS.max_rules,
        rls: str = DEFAULTS.rls,
        forgetting: float = DEFAULTS.forgetting,
        utility_threshold: float = DEFAULTS.utility_threshold,
        min_support: int = DEFAULTS.min_support,
        prune_after: int = DEFAULTS.prune_after,
        adaptive_spread: bool = DEFAULTS.adaptive_spread,
        coverage: bool = DEFAULTS.coverage,
        x_range: Any = None,
        y_range: Any = None,
        s_range: Any = None,
        history_every: int = DEFAULTS.history_every,
        clustering: str = DEFAULTS.clustering,
        blend: str = DEFAULTS.blend,
        input_names: Sequence[str] | None = None,
        output_names: Sequence[str] | None = None,
        antecedent_names: Sequence[str] | None = None,
        shared_outputs: Sequence[int] = (),
    ) -> None:
        self.radius = radius
        self.omega = omega
        self.variant = variant
        self.max_rules = max_rules
        self.rls = rls
        self.forgetting = forgetting
        self.utility_threshold = utility_threshold
        self.min_support = min_support
        self.prune_after = prune_after
        self.adaptive_spread = adaptive_spread
        self.coverage = coverage
        self.x_range = x_range
        self.y_range = y_range
        self.s_range = s_range
        self.history_every = history_every
        self.clustering = clustering
        self.blend = blend
        self.input_names = input_names
        self.output_names = output_names
        self.antecedent_names = antecedent_names
        self.shared_outputs = shared_outputs

    # ------------------------------------------------------------------ parameters
    def get_params(self) -> dict[str, Any]:
        """The constructor parameters as a dict (scikit-learn convention)."""
        names = list(inspect.signature(type(self).__init__).parameters)[1:]
        return {name: getattr(self, name) for name in names}

    def _check_params(self) -> None:
        if self.variant not in VARIANTS:
            raise ValueError(f"variant must be one of {VARIANTS}, got {self.variant!r}")
        if self.clustering not in CLUSTERINGS:
            raise ValueError(f"clustering must be one of {CLUSTERINGS}, "
                             f"got {self.clustering!r}")
        if self.blend not in BLENDS:
            raise ValueError(f"blend must be one of {BLENDS}, got {self.blend!r}")
        if self.rls not in RLS_KINDS:
            raise ValueError(f"rls must be one of {RLS_KINDS}, got {self.rls!r}")
        r = np.atleast_1d(np.asarray(self.radius, dtype=np.float64))
        if r.ndim != 1 or not np.all(np.isfinite(r)) or np.any(r <= 0):
            raise ValueError(f"radius must be positive and finite, got {self.radius!r}")
        if not (np.isfinite(self.omega) and self.omega > 0):
            raise ValueError(f"omega must be positive, got {self.omega!r}")
        if not (0.0 < self.forgetting <= 1.0):
            raise ValueError(f"forgetting must be in (0, 1], got {self.forgetting!r}")
        if int(self.max_rules) < 1:
            raise ValueError(f"max_rules must be >= 1, got {self.max_rules!r}")
        if int(self.history_every) < 1:
            raise ValueError(f"history_every must be >= 1, got {self.history_every!r}")
        if int(self.prune_after) < 0 or int(self.min_support) < 0:
            raise ValueError("prune_after and min_support must be >= 0")

    # ------------------------------------------------------------------ state
    def _init_state(self, n: int, m: int, na: int | None = None) -> None:
        """Allocate the state for n consequent inputs, m outputs and, if ``na`` is given,
        na scheduling inputs (z = [s; y; x]); otherwise z = [x; y]."""
        self._check_params()
        scheduled = na is not None
        if self.blend == "interpolate" and na != 1:
            raise ValueError("blend='interpolate' needs a scheduled model with one antecedent "
                             f"input (run(X, Y, S) with S of one column); got "
                             f"{'no S' if na is None else f'{na} columns'}")
        na = n if na is None else na
        r = np.atleast_1d(np.asarray(self.radius, dtype=np.float64))
        if r.size == 1:
            r = np.full(na, r[0])
        if r.size != na:
            what = "scheduling inputs" if scheduled else "inputs"
            raise ValueError(f"radius has {r.size} values but the model has {na} {what}")
        rmax = int(self.max_rules)
        xo = na + m if scheduled else 0
        d = na + m + (n if scheduled else 0)
        lo = np.zeros(d)
        hi = np.zeros(d)
        fixed = np.zeros(d, dtype=np.int8)
        if self.s_range is not None and not scheduled:
            raise ValueError("s_range is for a scheduled model: pass S to run()")
        for rng_, sl, name, width in (
            (self.x_range, slice(xo, xo + n), "x_range", n),
            (self.y_range, slice(na, na + m), "y_range", m),
            (self.s_range, slice(0, na), "s_range", na),
        ):
            if rng_ is None:
                continue
            a = np.asarray(rng_, dtype=np.float64).reshape(-1, 2)
            if a.shape != (width, 2) or not np.all(np.isfinite(a)) or np.any(a[:, 1] < a[:, 0]):
                raise ValueError(f"{name} must be {width} finite [low, high] pairs, got {rng_!r}")
            lo[sl], hi[sl], fixed[sl] = a[:, 0], a[:, 1], 1
        glob = self.rls == "global"
        shared = np.zeros(m, dtype=np.int8)
        for o in self.shared_outputs:
            if isinstance(o, bool) or not isinstance(o, int | np.integer) or not 0 <= o < m:
                raise ValueError(f"shared_outputs must be output indices 0..{m - 1}, "
                                 f"got {list(self.shared_outputs)!r}")
            shared[o] = 1
        if shared.any() and glob:
            raise ValueError("shared_outputs need local RLS (rls='local')")
        pg = rmax * (n + 1) if glob else 1
        self.n_inputs_ = n
        self.n_outputs_ = m
        self.n_antecedents_ = na
        self.scheduled_ = scheduled
        self.x_offset_ = xo
        self.radius_ = r
        self.state_ = {
            "si": np.zeros(3, dtype=np.int64),
            "lo": lo,
            "hi": hi,
            "fixed": fixed,
            "mean": np.zeros(d),
            "m2": np.zeros(d),
            "ids": np.zeros(rmax, dtype=np.int64),
            "cz": np.zeros((rmax, d)),
            "rad": np.zeros((rmax, na)),
            "scat": np.zeros((rmax, na)),
            "pot": np.zeros(rmax),
            "birth": np.zeros(rmax, dtype=np.int64),
            "support": np.zeros(rmax, dtype=np.int64),
            "lamsum": np.zeros(rmax),
            "tsum": np.zeros(rmax),
            "Pi": np.zeros((rmax, n + 1, m)),
            "Cl": np.zeros((1, 1, 1) if glob else (rmax, n + 1, n + 1)),
            "Cg": np.zeros((pg, pg)),
            "sh": shared,
            "Cs": (float(self.omega) * np.eye(n + 1) if shared.any() else np.zeros((1, 1))),
        }
        self.recorder_ = HistoryRecorder()
        self._predictor: tuple[np.ndarray, np.ndarray] | None = None

    def _kernel_params(self) -> tuple[np.ndarray, np.ndarray]:
        ip = np.zeros(L.N_IP, dtype=np.int64)
        ip[L.IP_VARIANT] = VARIANTS.index(self.variant)
        ip[L.IP_GLOBAL] = RLS_KINDS.index(self.rls)
        ip[L.IP_MAX_RULES] = int(self.max_rules)
        ip[L.IP_MIN_SUPPORT] = int(self.min_support)
        ip[L.IP_PRUNE_AFTER] = int(self.prune_after)
        ip[L.IP_ADAPTIVE] = int(bool(self.adaptive_spread))
        ip[L.IP_COVERAGE] = int(bool(self.coverage))
        ip[L.IP_SCHEDULED] = int(self.scheduled_)
        ip[L.IP_CLUSTERING] = CLUSTERINGS.index(self.clustering)
        ip[L.IP_BLEND] = BLENDS.index(self.blend)
        fp = np.zeros(L.N_FP)
        fp[L.FP_OMEGA] = float(self.omega)
        fp[L.FP_FORGET] = float(self.forgetting)
        fp[L.FP_UTILITY] = float(self.utility_threshold)
        fp[L.FP_SPREAD_RHO] = 0.5
        return ip, fp

    @property
    def _fitted(self) -> bool:
        return hasattr(self, "state_")

    def _check_xy(self, X: Any, Y: Any) -> tuple[np.ndarray, np.ndarray, bool]:
        y_arr = np.asarray(Y, dtype=np.float64)
        y1d = y_arr.ndim == 1
        if y1d:
            y_arr = y_arr[:, None]
        n = self.n_inputs_ if self._fitted else None
        m = self.n_outputs_ if self._fitted else None
        Xa = _finite_2d(X, "X", n)
        Ya = _finite_2d(y_arr, "Y", m)
        if Xa.shape[0] != Ya.shape[0]:
            raise ValueError(f"X has {Xa.shape[0]} rows but Y has {Ya.shape[0]}")
        return Xa, Ya, y1d

    def _check_s(self, S: Any, rows: int, X: np.ndarray) -> np.ndarray:
        """The antecedent array: ``X`` itself when unscheduled, else S checked."""
        if self._fitted and self.scheduled_ != (S is not None):
            raise ValueError(
                "this model was learned with a scheduling vector S; pass S"
                if self.scheduled_ else "this model was learned without S; do not pass S"
            )
        if S is None:
            return X
        Sa = _finite_2d(S, "S", self.n_antecedents_ if self._fitted else None)
        if Sa.shape[0] != rows:
            raise ValueError(f"X has {rows} rows but S has {Sa.shape[0]}")
        return Sa

    # ------------------------------------------------------------------ learning
    def run(self, X: Any, Y: Any, S: Any = None) -> np.ndarray:
        """Online predict-then-learn over all samples.

        Parameters
        ----------
        X : array-like, shape (N, n)
            Inputs (consequent regressors) in original units.
        Y : array-like, shape (N, m) or (N,)
            Targets in original units (1-D for a single output).
        S : array-like, shape (N, na), optional
            Scheduling inputs for the antecedents (see Notes of the class); None (the
            default) puts the antecedents on ``X``. A model keeps the choice it was first
            run with.

        Returns
        -------
        numpy.ndarray, shape like ``Y``
            The one-step prediction of each sample made *before* learning from it
            (NaN for the very first sample of a new model, which has no rule yet).
        """
        Xa, Ya, y1d = self._check_xy(X, Y)
        Sa = self._check_s(S, Xa.shape[0], Xa)
        if not self._fitted:
            self._init_state(Xa.shape[1], Ya.shape[1], None if S is None else Sa.shape[1])
            self.y_1d_ = y1d
        st = self.state_
        self._predictor = None  # the state changes: the frozen one-row predictor is stale
        ip, fp = self._kernel_params()
        N = Xa.shape[0]
        n, m = self.n_inputs_, self.n_outputs_
        Yhat = np.empty_like(Ya)
        hist = np.empty((N, 4))
        every = int(self.history_every)
        rmax = int(self.max_rules)
        k0 = int(st["si"][0])
        # buffers the kernel fills; it returns early when one is full and is called again
        per_call = max(16, _SNAPSHOT_BYTES_PER_CALL // (rmax * (n + 1) * m * 8))
        n_snap = min(max(1, (k0 + N) // every - k0 // every), per_call)
        snap_k = np.empty(n_snap, dtype=np.int64)
        snap_ids = np.empty((n_snap, rmax), dtype=np.int64)
        snap_pi = np.empty((n_snap, rmax, n + 1, m))
        snap_lo = np.empty((n_snap, n))
        snap_s = np.empty((n_snap, n))
        ev = np.empty((min(4 * N, _EVENTS_PER_CALL) + rmax + 3, 3), dtype=np.int64)
        counts = np.zeros(2, dtype=np.int64)  # events, snapshots written by the last call
        rec = self.recorder_
        start = 0
        while start < N:
            k0 = int(st["si"][0])
            counts[:] = 0
            # blend="interpolate" stays in learn_kernel (the lanes kernel has no
            # interpolation: with it, its global RLS ran 1.5x slower, docs/performance.md)
            interp = self.blend == "interpolate"
            lanes = not interp and int(st["si"][1]) > _RULE_MAJOR_MAX
            kernel, bound = ((learn_lanes, _LANES_MIN) if lanes else
                             (learn_kernel, rmax if interp else _RULE_MAJOR_MAX))
            # learn_kernel is compiled with the SLP vectoriser on; once compiled (or loaded
            # from numba's cache) it needs no switch (8 µs a call)
            slp = kernel is learn_kernel and not learn_kernel.overloads
            with slp_vectorised() if slp else nullcontext():
                done = kernel(
                    Xa[start:], Sa[start:], Ya[start:], Yhat[start:], hist[start:], ev,
                    counts[0:1], snap_k, snap_ids, snap_pi, snap_lo, snap_s, counts[1:2],
                    every, bound, *(st[name] for name in L.STATE_ARRAYS), self.radius_, fp,
                    ip,
                )  # fmt: skip
            rec.add(k0 + 1, hist[start : start + done])
            # kept as the kernel wrote them; dicts and original units when history is read
            rec.add_events(ev[: counts[0]])
            q = int(counts[1])
            rec.add_snapshots(snap_k[:q], snap_ids[:q], snap_pi[:q], snap_lo[:q], snap_s[:q])
            start += done
        return Yhat[:, 0] if y1d else Yhat

    def learn_one(self, x: Any, y: Any, s: Any = None) -> ETS:
        """Learn one sample (predict-then-learn); ``x`` shape (n,), ``y`` scalar or (m,),
        ``s`` shape (na,) for a scheduled model."""
        y_arr = np.atleast_1d(np.asarray(y, dtype=np.float64))
        S = None if s is None else np.atleast_2d(np.asarray(s, dtype=np.float64))
        self.run(np.atleast_2d(np.asarray(x, dtype=np.float64)), y_arr[None, :], S)
        return self

    def predict(self, X: Any, S: Any = None) -> np.ndarray:
        """Predict every row of ``X`` (N, n) with the current rules, without learning;
        ``S`` (N, na) are the scheduling inputs of a scheduled model.

        Returns an (N, m) array, or (N,) if the model was trained with 1-D ``Y``;
        NaN if the model has no rule yet.
        """
        if not self._fitted:
            raise ValueError("the model has not learned anything yet; call run() or learn_one()")
        Xa = _finite_2d(X, "X", self.n_inputs_)
        Sa = self._check_s(S, Xa.shape[0], Xa)
        st = self.state_
        Yhat = np.empty((Xa.shape[0], self.n_outputs_))
        R = int(st["si"][1])
        predict_kernel(Xa, Sa, Yhat, R, st["lo"], st["hi"], st["cz"], st["rad"], st["Pi"],
                       self.x_offset_, self.blend == "interpolate")
        return Yhat[:, 0] if self.y_1d_ else Yhat

    def predict_one(self, x: Any, s: Any = None) -> np.ndarray:
        """Predict one sample ``x`` (n,) (and ``s`` (na,) if scheduled); shape (m,).

        Bit-identical to ``predict`` on one row; the frozen model's widths and firing
        coefficients are kept between calls (until the model learns again), so a free-run
        simulation that calls this once per step pays little more than the arithmetic."""
        fast = self._predict_fast(x, s)
        if fast is not None:
            return fast
        S = None if s is None else np.atleast_2d(np.asarray(s, dtype=np.float64))
        y = self.predict(np.atleast_2d(np.asarray(x, dtype=np.float64)), S)
        return np.atleast_1d(y[0])

    def _predict_fast(self, x: Any, s: Any) -> np.ndarray | None:
        """``predict_one`` through :func:`~etsid.ets.kernels.predict_row`; None when the
        checked path must run (not fitted, no rule, wrong shape, non-finite input)."""
        if not self._fitted or self.n_rules == 0 or self.scheduled_ != (s is not None):
            return None
        xa = np.asarray(x, dtype=np.float64)
        if xa.shape != (self.n_inputs_,):
            return None
        sv = xa if s is None else np.asarray(s, dtype=np.float64)
        if sv.shape != (self.n_antecedents_,):
            return None
        frozen, work = self.frozen_predictor()
        out = np.empty(self.n_outputs_)
        ok = predict_row(np.ascontiguousarray(xa), np.ascontiguousarray(sv), out, frozen, work)
        return out if ok else None

    def frozen_predictor(self) -> tuple[np.ndarray, np.ndarray]:
        """The frozen rule base packed for :func:`~etsid.ets.kernels.predict_row` and its
        work array (kept until the model learns again); the model must have a rule.

        Returns
        -------
        frozen : ndarray
            Flat: the consequent inputs' ``lo`` (n) and ``1/s`` (n), then per rule its focal
            point on the antecedents (na), firing coefficients (na; negated when ``blend``
            is "interpolate") and consequents (n + 1, m).
        work : ndarray, shape (2 R + n + 1,)
            Scratch space of ``predict_row``.
        """
        if not self._fitted or self.n_rules == 0:
            raise ValueError("the model has no rule to predict with")
        if self._predictor is None:
            st, R, n, xo = self.state_, self.n_rules, self.n_inputs_, self.x_offset_
            na = self.n_antecedents_
            isx, ac = predict_setup(st["lo"], st["hi"], st["rad"], R, n, xo)
            if self.blend == "interpolate":
                ac = -ac  # the sign tells predict_row to interpolate
            per_rule = np.concatenate([st["cz"][:R, :na], ac, st["Pi"][:R].reshape(R, -1)],
                                      axis=1)
            self._predictor = (np.concatenate([st["lo"][xo : xo + n], isx, per_rule.ravel()]),
                               np.empty(2 * R + n + 1))
        return self._predictor

    # ------------------------------------------------------------------ inspection
    @property
    def n_rules(self) -> int:
        """Current number of rules (0 before learning)."""
        return int(self.state_["si"][1]) if self._fitted else 0

    def __len__(self) -> int:
        return self.n_rules

    @property
    def history(self) -> History:
        """Per-step structure, events and consequent snapshots (see :class:`History`)."""
        if not self._fitted:
            return HistoryRecorder().build()
        return self.recorder_.build()

    def history_frame(self) -> pd.DataFrame:
        """History as a DataFrame: step, n_rules, potential, focal_max, focal_min."""
        return self.history.to_frame()

    def scales(self) -> np.ndarray:
        """Normalisation widths s = hi - lo of z = [x; y], raw units (1 where the range is
        zero), shape (n + m,)."""
        st = self.state_
        s = np.empty_like(st["lo"])
        scales(st["lo"], st["hi"], s)
        return s

    def consequents_raw(self) -> np.ndarray:
        """Consequents of the live rules in original units, shape (R, n + 1, m).

        Row 0 is the intercept and row j the coefficient of input j: y_i = c_0 + sum_j c_j x_j.
        """
        st = self.state_
        n, R, xo = self.n_inputs_, self.n_rules, self.x_offset_
        return raw_consequents(st["Pi"][:R], st["lo"][xo : xo + n], self.scales()[xo : xo + n])

    def names(self) -> tuple[list[str], list[str]]:
        """Input and output names (defaults x1.., y1..)."""
        n, m = self.n_inputs_, self.n_outputs_
        xin = list(self.input_names) if self.input_names is not None else []
        yout = list(self.output_names) if self.output_names is not None else []
        if len(xin) != n:
            xin = [f"x{j + 1}" for j in range(n)]
        if len(yout) != m:
            yout = [f"y{o + 1}" for o in range(m)]
        return xin, yout

    def antecedents(self) -> list[str]:
        """Names of the antecedent inputs: the scheduling names (default s1..) of a
        scheduled model, else the input names."""
        if not self.scheduled_:
            return self.names()[0]
        na = self.n_antecedents_
        names = list(self.antecedent_names) if self.antecedent_names is not None else []
        return names if len(names) == na else [f"s{j + 1}" for j in range(na)]

    def leading_rule(self, A: Any) -> np.ndarray:
        """Index of the rule that fires most on each row of antecedent inputs ``A`` (raw
        units, shape (N, na), na = ``len(self.antecedents())``), shape (N,): the smallest
        firing exponent Σ_j ((a_j − a*_ij) / (s_j r_ij))²."""
        state = self.export_state()
        na = len(self.antecedents())
        A = np.asarray(A, dtype=float).reshape(-1, na)
        width = self.scales()[None, :na] * state.radii  # (R, na)
        d = (A[:, None, :] - state.focal_points[None, :, :na]) / width[None, :, :]
        return np.argmin(np.sum(d * d, axis=2), axis=1)

    def export_state(self) -> LearnedState:
        """The learned state as read-only views trimmed to the live rules (see
        :class:`~etsid.ets.state.LearnedState`); :meth:`restore_state` is the inverse.

        Raises
        ------
        ValueError
            The model has not learned anything yet.
        """
        if not self._fitted:
            raise ValueError("the model has not learned anything yet; call run() or learn_one()")
        st, R, n = self.state_, self.n_rules, self.n_inputs_
        p = R * (n + 1)
        glob = self.rls == "global"

        def view(a: np.ndarray) -> np.ndarray:
            v = a.view()
            v.flags.writeable = False
            return v

        return LearnedState(
            n_inputs=n, n_outputs=self.n_outputs_, y_1d=bool(self.y_1d_),
            samples=int(st["si"][0]), next_rule_id=int(st["si"][2]),
            low=view(st["lo"]), high=view(st["hi"]), fixed=view(st["fixed"]),
            mean=view(st["mean"]), m2=view(st["m2"]), rule_ids=view(st["ids"][:R]),
            focal_points=view(st["cz"][:R]), radii=view(st["rad"][:R]),
            scatter=view(st["scat"][:R]), potentials=view(st["pot"][:R]),
            births=view(st["birth"][:R]), support=view(st["support"][:R]),
            firing_sums=view(st["lamsum"][:R]), time_sums=view(st["tsum"][:R]),
            consequents=view(st["Pi"][:R]),
            covariances=None if glob else view(st["Cl"][:R]),
            global_covariance=view(st["Cg"][:p, :p]) if glob else None,
            scheduled=bool(self.scheduled_), n_antecedents=int(self.n_antecedents_),
            shared_covariance=view(st["Cs"]) if st["sh"].any() else None,
        )

    def restore_state(self, state: LearnedState) -> ETS:
        """Replace the learned state by ``state`` (e.g. read from a rule-base file); the
        model then predicts and learns on exactly as the one it was exported from.

        Raises
        ------
        ValueError
            Invalid parameters, or arrays whose shapes do not fit the parameters.
        """
        n, m, R = state.n_inputs, state.n_outputs, state.n_rules
        self._init_state(n, m, state.n_antecedents if state.scheduled else None)
        if int(self.max_rules) < R:
            raise ValueError(f"{R} rules exceed max_rules = {self.max_rules}")
        glob = self.rls == "global"
        p = R * (n + 1)
        st = self.state_
        pairs = [("lo", state.low, None), ("hi", state.high, None),
                 ("fixed", state.fixed, None), ("mean", state.mean, None),
                 ("m2", state.m2, None), ("ids", state.rule_ids, R),
                 ("cz", state.focal_points, R), ("rad", state.radii, R),
                 ("scat", state.scatter, R), ("pot", state.potentials, R),
                 ("birth", state.births, R), ("support", state.support, R),
                 ("lamsum", state.firing_sums, R), ("tsum", state.time_sums, R),
                 ("Pi", state.consequents, R)]
        if glob:
            if state.global_covariance is None:
                raise ValueError("global RLS needs global_covariance")
        elif state.covariances is None:
            raise ValueError("local RLS needs covariances")
        else:
            pairs.append(("Cl", state.covariances, R))
        for name, value, rows in pairs:
            target = st[name] if rows is None else st[name][:rows]
            arr = np.asarray(value)
            if arr.shape != target.shape:
                raise ValueError(f"{name} has shape {arr.shape}, expected {target.shape}")
            target[...] = arr
        if glob:
            arr = np.asarray(state.global_covariance)
            if arr.shape != (p, p):
                raise ValueError(f"global_covariance has shape {arr.shape}, expected {(p, p)}")
            st["Cg"][:p, :p] = arr
        if st["sh"].any():
            if state.shared_covariance is None:
                raise ValueError("shared outputs need shared_covariance")
            arr = np.asarray(state.shared_covariance)
            if arr.shape != st["Cs"].shape:
                raise ValueError(f"shared_covariance has shape {arr.shape}, "
                                 f"expected {st['Cs'].shape}")
            st["Cs"][...] = arr
        st["si"][:] = (state.samples, R, state.next_rule_id)
        self.y_1d_ = bool(state.y_1d)
        return self

    def rules(self, precision: int = 4) -> str:
        """Readable IF … THEN … rules in the original units of the data."""
        from etsid.ets.text import format_rules

        return format_rules(self, precision)

    # ------------------------------------------------------------------ persistence
    def to_dict(self) -> dict[str, Any]:
        """The rule base and learner state as a JSON-ready dict (schema ``etsid.rules/2``)."""
        from etsid.ets.serialize import model_to_dict

        return model_to_dict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any], trusted: bool = False) -> ETS:
        """Rebuild a model from :meth:`to_dict` output; raises ModelError if invalid.

        ``trusted``: ``data`` was made by :meth:`to_dict` in this process (or already read
        and validated from a file): the JSON-Schema check, whose cost grows with the size of
        the rule base, is skipped; the shape and consistency checks are kept."""
        from etsid.ets.serialize import model_from_dict

        return model_from_dict(cls, data, trusted=trusted)

    def save(self, path: str | Path, **extra: Any) -> None:
        """Write the rule base to ``path`` (JSON); ``extra`` adds e.g. ``regressors=...``."""
        from etsid.ets.serialize import save

        save(self, path, **extra)

    @classmethod
    def load(cls, path: str | Path) -> ETS:
        """Read a rule base written by :meth:`save`; raises ModelError if invalid."""
        from etsid.ets.serialize import load

        return load(cls, path)
