"""Angular acceleration against differential thrust: control effectiveness, motor time
constant and command-to-response delay.

Euler's equation about each body axis with the per-rotor specific thrust f_j = K x_j²
(:mod:`etsid.fit.thrust`), unit-arm moment rows g (:func:`etsid.fit.layout.geometry_rows`):

    ṗ = (m l / Ixx) Σ g_roll,j f_j + (Iyy − Izz)/Ixx · q r − D_p p + S_v v + b_p
    q̇ = (m l / Iyy) Σ g_pitch,j f_j + (Izz − Ixx)/Iyy · p r − D_q q + S_u u + b_q
    ṙ = (m κ_Q / Izz) Σ s_j f_j + (J_r Ω_top / Izz) Σ s_j ẋ_j + (Ixx − Iyy)/Izz · p q
        − D_r r + b_r

(κ_Q = rotor torque per thrust, m; D the rotors' rate damping — a rotor rising with the
body's rotation sees more inflow and lifts less; S the speed stability — rotor H-forces
below or above the CG and the fore/aft inflow difference in translation, with u v the
body-axis velocities; b the moment of a CG offset or trim). The coefficients
m l/I and m κ_Q/Izz are what a log determines; l, m, κ_Q and I each alone are not.

Logged motor outputs are samples of a signal that jitters faster than the log (the rate
loop's D term on gyro noise): as regressors they carry noise that would bias every
coefficient towards zero. The regressions are therefore instrumental-variable ones
(two-stage least squares): regressors and target are projected on the history of the
pilot's commands (:meth:`etsid.fit.signals.Flight.instruments`). The motor lag τ and delay
d enter through x_j and are chosen on a grid by the projected residual of the roll and
pitch equations (their regressors are rotor-speed differences, the signal the lag shapes);
every standard error, τ's and d's included, is a delete-one-block jackknife over
:data:`etsid.fit.regress.N_BLOCKS` contiguous blocks (autocorrelation inside a block
does not fool it), combined with the grid's resolution for τ and d, and for the
coefficients with their shift when the same equations are fitted on half the bandwidth
(a model that holds gives the same coefficients at every frequency; the shift measures
what the unmodelled dynamics move). The jackknife cannot see a bias every block shares —
with weak instruments the (τ, d) minimum slides along the valley τ + d ≈ const — so τ's and
d's standard errors are widened to the projections of the Anderson–Rubin 95 % set over the
grid (:mod:`etsid.fit.weakiv`), whose coverage does not depend on the instruments'
strength; a set touching the grid's edge leaves both not determined. An empty AR set (the
model rejected at every (τ, d): not exact, strong instruments) is replaced by the
misfit-scaled distance set (:func:`etsid.fit.weakiv.distance_set`).

The coefficients are estimated at the point (τ, d): a two-step estimator, whose first
step's error moves every coefficient (0.9 % of the roll effectiveness per ms of τ on a
tarot680). A jackknife that holds (τ, d) fixed does not see it (the generated-regressor
problem of two-step estimators, Murphy and Topel 1985), so the coefficients' jackknife is
of the whole estimator: each left-out block's coefficients at that replicate's own (τ, d)
(2.6× the fixed-(τ, d) jackknife on a quad250 roll axis). It measures how (τ, d)
scatter between blocks, not a bias they share; so, where the (τ, d) set bounds them, the
coefficients are also refitted at the set's extreme points (the ends of τ, d, τ + d and
τ − d over its grid points), and their largest move / 1.96 is added to the standard
errors, as for the thrust curve's interval — a projection of the 95 % set, as conservative
as that. Where the set reaches the grid's edge (τ and d not determined) no bounded move
exists: the whole-estimator jackknife is then all, and τ's note says so.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.stats import norm

from etsid.errors import FitError
from etsid.fit.regress import N_BLOCKS, Moments, block_ids, instrument_basis, jackknife_se
from etsid.fit.signals import Flight, motor_state
from etsid.fit.weakiv import (
    LEVEL,
    ConfidenceSet,
    ar_statistic,
    confidence_set,
    distance_set,
    instrument_autocov,
    joint_statistic,
)

TAU_GRID = np.round(np.geomspace(0.005, 0.25, 29), 5)
"""s, motor time constants tried (log-spaced, 15 % apart)."""
DELAY_STEP = 0.002
"""s, delay grid step (:data:`DELAY_MIN` … :data:`DELAY_MAX`)."""
DELAY_MAX = 0.04
DELAY_MIN = -0.02
"""s: the delay is measured between two logged streams, whose stamps may be offset either
way: a log that stamps the state after the step its command already drove (PyFlyt's and the
``multirotor`` package's sets of ``benchmarks/thirdparty``) has the rotors lead the command
by a period; held at 0, the fitted τ took it up (−30 % on both). The vehicle file takes
max(0, d)."""
_Z_LEVEL = float(norm.ppf(0.5 + LEVEL / 2))
"""Two-sided normal quantile of :data:`etsid.fit.weakiv.LEVEL` (1.96)."""
MIN_ROWS = 50
"""Rows near hover a flight needs to enter the moment equations."""
MIN_MOTOR_HZ = 40.0
"""Hz: motor outputs logged slower cannot resolve a lag of tens of milliseconds."""


@dataclass
class AxisFit:
    """Coefficients of one axis (0 = effectiveness) with jackknife standard errors."""

    coef: np.ndarray
    se: np.ndarray
    alt: list[np.ndarray]   # coefficients refitted at the thrust curve's interval ends
    td_shift: np.ndarray | None = None
    """Largest move of the coefficients over the (τ, d) set's extreme points (included in
    ``se`` as shift / 1.96); None when the set gives none."""


@dataclass
class RotationFit:
    """Result of :func:`fit_rotation`."""

    tau: float
    tau_se: float
    delay: float
    delay_se: float
    axes: dict[str, AxisFit]
    tau_at_edge: bool
    instrumented: bool
    tau_set: tuple[float, float] = (float("nan"), float("nan"))
    """s, projection of the (τ, d) Anderson–Rubin 95 % set on τ (NaN: not computed)."""
    delay_set: tuple[float, float] = (float("nan"), float("nan"))
    """s, its projection on d."""
    set_open: str = ""
    """Why the set does not bound τ and d ("" when it does or is empty): it reaches the
    grid's edge."""
    set_misfit: float = float("nan")
    """Smallest AR statistic over its degrees of freedom on the grid (at least 1); the AR
    set is empty when this is large, and the distance set stands in."""
    set_kind: str = ""
    """"anderson-rubin", "distance" (the AR set empty) or "" (no set computed)."""
    ratio: float = float("nan")
    """Iyy / Ixx, roll over pitch effectiveness (:func:`_inertia_ratio`)."""
    ratio_se: float = float("nan")


class _Prep:
    """What does not depend on τ and d, per flight: kept rows, the instrument basis,
    projected targets and extra regressors, per block."""

    def __init__(self, f: Flight, blocks: np.ndarray) -> None:
        self.flight = f
        keep = f.hover.copy()
        keep[:5] = keep[-5:] = False
        self.keep = keep
        self.blocks = [int(b) for b in np.unique(blocks)]
        edges = np.searchsorted(blocks, np.arange(N_BLOCKS + 1))
        self.slices = {b: slice(edges[b], edges[b + 1]) for b in self.blocks}
        p, q, r = f.gyro.T
        one = np.ones(len(f.t))
        vb = f.vel_body if f.vel_body is not None else np.zeros((len(f.t), 3))
        extra = [f.lowpass(np.column_stack([q * r, p, vb[:, 1], one]))[keep],
                 f.lowpass(np.column_stack([p * r, q, vb[:, 0], one]))[keep],
                 f.lowpass(np.column_stack([p * q, r, one]))[keep]]
        z = f.instruments(np.column_stack([q * r, p * r, p * q]))
        self.instrumented = z is not None
        self.q = instrument_basis(z[keep]) if z is not None else None
        self.qt = np.ascontiguousarray(self.q.T) if self.q is not None else None
        self.gamma = instrument_autocov(self.q) if self.q is not None else None
        acc = f.lowpass(np.gradient(f.gyro, f.dt, axis=0))[keep]
        self.acc, self.extra_full = acc, extra
        self.target = self.reduce(acc)
        self.extra = [self.reduce(e) for e in extra]
        self.target_raw = {b: acc[sl] for b, sl in self.slices.items()}
        self.extra_raw = [{b: e[sl] for b, sl in self.slices.items()} for e in extra]
        # leave-one-block-out first stage (jackknife IV): block b's fitted regressors come
        # from the other blocks' first stage, so its own noise cannot leak in
        self.jive_ok = self.q is not None and len(self.blocks) >= 3
        if self.jive_ok:
            zb = {b: self.q[sl] for b, sl in self.slices.items()}
            gram = {b: zb[b].T @ zb[b] for b in self.blocks}
            total = sum(gram.values())
            self.zb = zb
            self.inv_rest = {b: np.linalg.pinv(total - gram[b]) for b in self.blocks}

    def jive(self, x: np.ndarray) -> dict[int, np.ndarray]:
        """Per block, x predicted from the instruments by the first stage fitted on the
        other blocks (x itself when there are no instruments)."""
        if not self.jive_ok:
            return self.reduce(x)
        cross = {b: self.zb[b].T @ x[sl] for b, sl in self.slices.items()}
        total = sum(cross.values())
        return {b: self.zb[b] @ (self.inv_rest[b] @ (total - cross[b])) for b in self.blocks}

    def reduce(self, x: np.ndarray) -> dict[int, np.ndarray]:
        """Per block, the rows of x's projection on the instruments (of x itself without
        instruments)."""
        if self.q is not None:
            x = self.q @ (self.qt @ x)
        return {b: x[sl] for b, sl in self.slices.items()}


def _prepare(flights: list[Flight], cutoff_scale: float = 1.0) -> list[_Prep]:
    sizes = []
    for f in flights:
        keep = f.hover.copy()
        keep[:5] = keep[-5:] = False
        sizes.append(int(keep.sum()))
    ids = block_ids(sum(sizes))
    out, start = [], 0
    for f, n in zip(flights, sizes, strict=True):
        if cutoff_scale != 1.0:
            f = replace(f, cutoff_scale=cutoff_scale, _sos=None)
        out.append(_Prep(f, ids[start:start + n]))
        start += n
    return out


def _roll_pitch_regressor(pr: _Prep, geom: np.ndarray, k: float, idle: float, tau: float,
                          delay: float) -> np.ndarray:
    """Low-passed Σ g f_j of the roll and pitch equations on the kept rows (n, 3)."""
    f = pr.flight
    x = motor_state(f, idle, tau, delay)
    return f.lowpass((k * x * x) @ geom.T)[pr.keep]


def _moments(preps: list[_Prep], geom: np.ndarray, k: float, idle: float, tau: float,
             delay: float, axes: tuple[int, ...],
             raw: list[np.ndarray] | None = None) -> list[Moments]:
    """Projected moments per block of each axis; ``raw``: the per-prep unprojected moment
    regressors Σ g f_j, when already computed."""
    p_cols = {0: 5, 1: 5, 2: 5}
    out = []
    per_axis = {a: Moments(np.zeros((N_BLOCKS, p_cols[a], p_cols[a])),
                           np.zeros((N_BLOCKS, p_cols[a])), np.zeros(N_BLOCKS)) for a in axes}
    for n_pr, pr in enumerate(preps):
        f = pr.flight
        x = motor_state(f, idle, tau, delay) if raw is None or 2 in axes else None
        fs_raw = raw[n_pr] if raw is not None else f.lowpass((k * x * x) @ geom.T)[pr.keep]
        fs = pr.reduce(fs_raw)
        dx = (pr.reduce(f.lowpass(np.gradient(x, f.dt, axis=0) @ geom[2])[pr.keep][:, None])
              if 2 in axes else None)
        for a in axes:
            m = per_axis[a]
            for b in pr.blocks:
                cols = [fs[b][:, a:a + 1]]
                if a == 2:
                    cols.append(dx[b])
                cols.append(pr.extra[a][b])
                xb = np.hstack(cols)
                yb = pr.target[b][:, a]
                m.xtx[b] += xb.T @ xb
                m.xty[b] += xb.T @ yb
                m.yty[b] += yb @ yb
    for a in axes:
        out.append(per_axis[a])
    return out


def _ar_joint(preps: list[_Prep], raw: list[np.ndarray]) -> tuple[float, float]:
    """Joint Anderson–Rubin statistic and degrees of freedom of the roll and pitch equations
    at the (τ, d) that made ``raw`` (:func:`etsid.fit.weakiv.joint_statistic`); NaN without
    instruments."""
    nan = (float("nan"), float("nan"))
    if any(pr.q is None for pr in preps):
        return nan
    stats = []
    for a in (0, 1):
        parts = [(np.column_stack([pr.acc[:, a], fs[:, a], pr.extra_full[a]]), pr.q)
                 for pr, fs in zip(preps, raw, strict=True)]
        st = ar_statistic(parts, [pr.gamma for pr in preps])
        if st is None:
            return nan
        stats.append(st)
    return joint_statistic(stats)


def _objective(preps: list[_Prep], geom: np.ndarray, k: float, idle: float,
               taus: np.ndarray, delays: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Σ log SSR of the projected roll and pitch equations on the (τ, d) grid: [0] with all
    blocks, [b + 1] with block b left out; and the Anderson–Rubin statistic and degrees of
    freedom tables."""
    obj = np.zeros((N_BLOCKS + 1, taus.size, delays.size))
    stat = np.full((taus.size, delays.size), np.nan)
    dof = np.full((taus.size, delays.size), np.nan)
    for i, tau in enumerate(taus):
        for j, d in enumerate(delays):
            raw = [_roll_pitch_regressor(pr, geom, k, idle, float(tau), float(d))
                   for pr in preps]
            for m in _moments(preps, geom, k, idle, float(tau), float(d), (0, 1), raw):
                obj[0, i, j] += np.log(m.solve()[1])
                for b in range(N_BLOCKS):
                    obj[b + 1, i, j] += np.log(m.solve(b)[1])
            stat[i, j], dof[i, j] = _ar_joint(preps, raw)
    return obj, stat, dof


def _jive_moments(preps: list[_Prep], geom: np.ndarray, k: float, idle: float, tau: float,
                  delay: float) -> list[Moments]:
    """Moments of the jackknife-IV estimator per axis (roll, pitch, yaw): X̂ᵀX and X̂ᵀy
    with X̂ from the leave-block-out first stage."""
    per_axis = [Moments(np.zeros((N_BLOCKS, 5, 5)), np.zeros((N_BLOCKS, 5)),
                        np.zeros(N_BLOCKS)) for _ in range(3)]
    for pr in preps:
        f = pr.flight
        x = motor_state(f, idle, tau, delay)
        fs_raw = f.lowpass((k * x * x) @ geom.T)[pr.keep]
        dx_raw = f.lowpass(np.gradient(x, f.dt, axis=0) @ geom[2])[pr.keep][:, None]
        for a in range(3):
            cols = [fs_raw[:, a:a + 1]] + ([dx_raw] if a == 2 else [])
            raw = np.hstack(cols)
            fitted = pr.jive(raw)
            extra_hat = pr.jive(np.vstack([pr.extra_raw[a][b] for b in pr.blocks]))
            m = per_axis[a]
            for b, sl in pr.slices.items():
                xb = np.hstack([raw[sl], pr.extra_raw[a][b]])
                xh = np.hstack([fitted[b], extra_hat[b]])
                yb = pr.target_raw[b][:, a]
                m.xtx[b] += xh.T @ xb
                m.xty[b] += xh.T @ yb
                m.yty[b] += yb @ yb
    return per_axis


def _inertia_ratio(full: list[Moments], half: list[Moments], alts: list[list[Moments]],
                   at_set: list[list[Moments]], at_reps: list[list[Moments]]
                   ) -> tuple[float, float]:
    """Iyy / Ixx = roll over pitch effectiveness, with its standard error from the same
    sources as the coefficients' (jackknife, half band, thrust curve's ends, (τ, d) set),
    each taken on the ratio itself: a τ, d or K error moves both axes alike and largely
    cancels in it, which treating the two axes' errors as independent would not see."""
    def r(ms: list[Moments], leave: int | None = None) -> float:
        return float(ms[0].solve(leave)[0][0] / ms[1].solve(leave)[0][0])

    ratio = r(full)
    if at_reps:
        pseudo = np.array([r(a, b) for b, a in enumerate(at_reps)])
    else:
        pseudo = np.array([r(full, b) for b in range(N_BLOCKS) if full[0].yty[b] > 0])
    parts = [jackknife_se(pseudo), abs(r(half) - ratio)]
    for group in (alts, at_set):
        if group:
            parts.append(max(abs(r(a) - ratio) for a in group) / _Z_LEVEL)
    return ratio, float(np.sqrt(np.sum(np.square(parts))))


def _argmin2(table: np.ndarray) -> tuple[int, int]:
    i, j = np.unravel_index(np.argmin(table), table.shape)
    return int(i), int(j)


def _refine(grid: np.ndarray, values: np.ndarray, i: int, log: bool) -> float:
    """Parabolic interpolation of the minimum around grid index i."""
    if i == 0 or i == len(grid) - 1:
        return float(grid[i])
    g = np.log(grid[i - 1:i + 2]) if log else grid[i - 1:i + 2]
    y = values[i - 1:i + 2]
    denom = y[0] - 2 * y[1] + y[2]
    if denom <= 0:
        return float(grid[i])
    step = g[1] - g[0]
    off = 0.5 * (y[0] - y[2]) / denom * step
    v = g[1] + float(np.clip(off, -step, step))
    return float(np.exp(v)) if log else float(v)


def _widen(tau_se: float, d_se: float, tau: float, delay: float, cs: ConfidenceSet
           ) -> tuple[float, float]:
    """Standard errors at least as wide as the (τ, d) set's projections: the farther end
    from the estimate is 1.96 se away (the projections are of the grid points bounding the
    set, so they include the grid's resolution)."""
    if cs.empty:
        return tau_se, d_se
    z = _Z_LEVEL
    half_tau = max(cs.hi[0] - tau, tau - cs.lo[0], 0.0)
    half_d = max(cs.hi[1] - delay, delay - cs.lo[1], 0.0)
    return max(tau_se, half_tau / z), max(d_se, half_d / z)


def set_extremes(points: np.ndarray) -> np.ndarray:
    """The (τ, d) points of a set at the ends of τ, d, τ + d and τ − d (unique rows)."""
    if points.size == 0:
        return np.zeros((0, 2))
    keys = (points[:, 0], points[:, 1], points[:, 0] + points[:, 1],
            points[:, 0] - points[:, 1])
    idx = sorted({int(f(k)) for k in keys for f in (np.argmin, np.argmax)})
    return points[idx]


def fit_rotation(flights: list[Flight], geom: np.ndarray, k: float, idle: float,
                 tau_default: float, fine: bool = True,
                 ends: tuple[tuple[float, float], ...] = (), spread: bool = True
                 ) -> RotationFit:
    """Fit τ, d and each axis's coefficients (module docstring).

    ``ends``: (K, ι) pairs at the ends of the thrust curve's 95 % interval; the
    coefficients are refitted with each (:attr:`AxisFit.alt`), since the regressors carry
    the thrust curve and its error moves every coefficient with it.

    With motor outputs logged slower than :data:`MIN_MOTOR_HZ` the lag and delay cannot be
    resolved: τ is held at ``tau_default``, d at 0, and their standard errors are infinite.

    ``spread``: False skips what only the standard errors need (the whole-estimator
    jackknife, the refits over the (τ, d) set, and the fine (τ, d) grid's half steps, which
    the set's bound is one step of), for a first pass.
    """
    flights = [f for f in flights if f.hover.sum() > MIN_ROWS]
    if not flights:
        raise FitError(f"{MIN_ROWS} rows near hover needed for the moment equations; the "
                       "log has fewer (too slow a log, or no slow flight)")
    preps = _prepare(flights)
    open_why = ""
    misfit = float("nan")
    sets = ((float("nan"), float("nan")), (float("nan"), float("nan")))
    kind = ""
    corners = np.zeros((0, 2))
    reps: list[tuple[float, float]] = []
    slow = min(f.motor_rate_hz for f in flights) < MIN_MOTOR_HZ
    delays = np.round(np.arange(DELAY_MIN, DELAY_MAX + 1e-9, DELAY_STEP), 4)
    if slow:
        tau, delay, tau_se, d_se, edge = tau_default, 0.0, float("inf"), float("inf"), False
    else:
        tau_c = TAU_GRID[::2]
        delay_c = delays[::2]
        coarse, st_c, df_c = _objective(preps, geom, k, idle, tau_c, delay_c)
        grids = [(tau_c, delay_c, st_c, df_c)]
        if fine:
            ic, jc = _argmin2(coarse[0])
            tau_f = TAU_GRID[max(0, 2 * ic - 3):2 * ic + 4]
            delays = delays[max(0, 2 * jc - 4):2 * jc + 5]
            if spread:
                # half steps: the set is bounded to one step of this grid (weakiv)
                tau_f = np.round(np.sort(np.concatenate(
                    [tau_f, np.sqrt(tau_f[:-1] * tau_f[1:])])), 6)
                delays = np.round(np.arange(delays[0], delays[-1] + 1e-9, DELAY_STEP / 2), 5)
            obj, st_f, df_f = _objective(preps, geom, k, idle, tau_f, delays)
            grids.append((tau_f, delays, st_f, df_f))
        else:
            tau_f, delays, obj = tau_c, delay_c, coarse
        i, j = _argmin2(obj[0])
        tau = _refine(tau_f, obj[0, :, j], i, True)
        delay = _refine(delays, obj[0, i, :], j, False)
        reps_tau, reps_d = [], []
        for b in range(1, N_BLOCKS + 1):
            ib, jb = _argmin2(obj[b])
            reps_tau.append(_refine(tau_f, obj[b, :, jb], ib, True))
            reps_d.append(_refine(delays, obj[b, ib, :], jb, False))
        # plus the grid's own resolution (a uniform error over one step, parabolic
        # interpolation notwithstanding)
        log_step = float(np.log(tau_f[1] / tau_f[0])) if tau_f.size > 1 else 0.0
        d_step = float(delays[1] - delays[0]) if delays.size > 1 else DELAY_STEP
        res_tau, res_d = tau * log_step / np.sqrt(12), d_step / np.sqrt(12)
        reps = list(zip(reps_tau, reps_d, strict=True))
        tau_se = float(np.hypot(jackknife_se(np.array(reps_tau)), res_tau))
        d_se = float(np.hypot(jackknife_se(np.array(reps_d)), res_d))
        edge = tau_f[i] in (TAU_GRID[0], TAU_GRID[-1])
        if all(np.isfinite(g[2]).all() for g in grids):
            bounds = ((TAU_GRID[0], TAU_GRID[-1]), (DELAY_MIN, DELAY_MAX))
            cs = confidence_set(grids, bounds)
            if cs.empty:
                # the model fails the over-identification test everywhere: the misfit is
                # taken as an over-dispersion and the distance set bounds τ and d
                cs = distance_set(grids, bounds)
            tau_se, d_se = _widen(tau_se, d_se, tau, delay, cs)
            open_why = "its 95 % set reaches the (τ, d) grid's edge" if cs.at_edge else ""
            sets = ((cs.lo[0], cs.hi[0]), (cs.lo[1], cs.hi[1]))
            misfit, kind = cs.misfit, cs.kind
            if not cs.at_edge and spread:
                corners = set_extremes(cs.points)
    axes = {}
    full = _jive_moments(preps, geom, k, idle, tau, delay)
    half = _jive_moments(_prepare(flights, cutoff_scale=0.5), geom, k, idle, tau, delay)
    alts = [_jive_moments(preps, geom, ka, ia, tau, delay) for ka, ia in ends]
    at_set = [_jive_moments(preps, geom, k, idle, float(t), float(d)) for t, d in corners]
    # the whole estimator's jackknife: block b left out of the (τ, d) choice and of the
    # coefficients alike
    at_reps = [_jive_moments(preps, geom, k, idle, tb, db) for tb, db in reps] if spread \
        else []
    for i, (name, m, mh) in enumerate(zip(("roll", "pitch", "yaw"), full, half, strict=True)):
        coef, se = m.jackknife()
        if at_reps:
            pseudo = np.array([a[i].solve(b)[0] for b, a in enumerate(at_reps)])
            se = np.sqrt((len(pseudo) - 1) / len(pseudo)
                         * np.sum((pseudo - pseudo.mean(0)) ** 2, axis=0))
        # model error: the same equation fitted on half the bandwidth must give the same
        # coefficients if the model holds; what unmodelled dynamics move is added
        shift = np.abs(coef - mh.solve()[0])
        se = np.hypot(se, shift)
        td = None
        if at_set:
            # the (τ, d) set's extreme points are its 95 % boundary: move / 1.96 = 1 se
            td = np.max([np.abs(a[i].solve()[0] - coef) for a in at_set], axis=0)
            se = np.hypot(se, td / _Z_LEVEL)
        axes[name] = AxisFit(coef=coef, se=se, alt=[a[i].solve()[0] for a in alts],
                             td_shift=td)
    ratio, ratio_se = _inertia_ratio(full, half, alts, at_set, at_reps)
    return RotationFit(tau=tau, tau_se=tau_se, delay=delay, delay_se=d_se, axes=axes,
                       tau_at_edge=edge, instrumented=all(p.instrumented for p in preps),
                       tau_set=sets[0], delay_set=sets[1], set_open=open_why,
                       set_misfit=misfit, set_kind=kind, ratio=ratio, ratio_se=ratio_se)
