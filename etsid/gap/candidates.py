"""The library of named physics candidates: small pluggable objects, one per phenomenon.

Each :class:`Candidate` has a ``name`` from the gap vocabulary, its parameters with units
and bounds, the channels it acts on, a one-line physical signature and its equation, and
``mods(theta, ctx)``: the change it makes to the nominal model (:class:`~etsid.gap.nominal.Mods`).
Fitting and scoring are generic (:mod:`etsid.gap.fitting`, :mod:`etsid.gap.criterion`), so
adding a candidate is adding one object to :data:`LIBRARY`. None of these laws is the one the
simulator uses to generate data (see docs/gap.md).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from etsid.gap.nominal import GRAVITY, Mods, NominalModel, air_velocity
from etsid.gap.signals import Flight

GE_MAX_RATIO = 2.0
MAX_ESTIMATOR_TIME_S = 2.0
"""Longest gravity-correction time constant of an attitude estimate, s (complementary
filters run at 0.5-2 s); the bound keeps a gyro bias below the gyro's floor from leaning
the estimate enough to pose as an accelerometer bias."""


@dataclass(frozen=True)
class Param:
    """One parameter of a candidate: name, unit, search bounds, start value and the value
    that means "no effect" (``null``; a bound equal to it is not a range limit)."""

    name: str
    unit: str
    lo: float
    hi: float
    x0: float
    null: float | None = None


@dataclass(frozen=True)
class SearchMap:
    """Coordinates a local search moves in, for laws whose parameters trade off.

    Attributes
    ----------
    to_theta, to_search : callable
        ``s → θ`` and ``θ → s`` (ndarray to ndarray, same size).
    step : ndarray
        Initial step of the search along each coordinate of ``s``.
    """

    to_theta: Callable[[np.ndarray], np.ndarray]
    to_search: Callable[[np.ndarray], np.ndarray]
    step: np.ndarray


@dataclass
class Context:
    """What a candidate may use besides its parameters.

    Attributes
    ----------
    flight : Flight
        The flight the model predicts (REAL).
    nominal : NominalModel
        The model fitted on SIM.
    v_ref : float or None
        Mean airborne battery voltage of SIM, V (None: SIM has no voltage).
    rotor_dirs : ndarray or None
        (N, 2) unit directions (x forward, y right) of the rotors in the body, estimated
        from the nominal moment coefficients (None when the inputs are commands).
    arm : float or None
        Hub distance from the CG, m, if a vehicle file gave it.
    """

    flight: Flight
    nominal: NominalModel
    v_ref: float | None
    rotor_dirs: np.ndarray | None
    arm: float | None = None
    cache: dict[str, np.ndarray] = field(default_factory=dict)


@dataclass(frozen=True)
class Candidate:
    """A named physical effect with a parametric law.

    Attributes
    ----------
    name : str
        Vocabulary name (``ground_effect`` …).
    params : tuple of Param
        Parameters, in the order of ``theta``.
    channels : tuple of str
        Channels the effect acts on.
    signature : str
        How it shows in the data (one sentence).
    equation : str
        Its law in plain text.
    build : callable
        ``build(theta, ctx) -> Mods``.
    needs : tuple of str
        Signals the REAL flight must have (``alt``, ``vbat``, ``vel``, ``roll``).
    search : callable, optional
        ``search(ctx) -> SearchMap``: coordinates in which the local search of a
        multi-parameter law is well conditioned (default: each parameter scaled to its
        bounds).
    """

    name: str
    params: tuple[Param, ...]
    channels: tuple[str, ...]
    signature: str
    equation: str
    build: Callable[[np.ndarray, Context], Mods]
    needs: tuple[str, ...] = ()
    search: Callable[[Context], SearchMap] | None = None

    motor: int | None = None
    """For a per-motor law (``weak_motor``): the motor (0-based) it acts on."""
    law_needs: tuple[str, ...] | None = None
    """Signals the law itself reads (None: all of ``needs``). A sensor offset's law reads
    nothing: it needs the velocity or attitude only for the channels that show it whole."""

    def null_theta(self) -> np.ndarray:
        """Parameters of no effect: each one's ``null``, its start where it has none."""
        return np.array([p.null if p.null is not None else p.x0 for p in self.params], float)

    def partly_seen(self, ctx: Context) -> bool:
        """Whether the flight lacks a signal this candidate needs to be told apart, yet has
        what its law reads: it then acts on the channels REAL has, unnamed (an
        accelerometer bias on the vertical specific force of a log without velocity)."""
        law = self.needs if self.law_needs is None else self.law_needs
        return (not self.available(ctx) and self.motor is None
                and all(s in ctx.flight.have for s in law))

    def available(self, ctx: Context) -> bool:
        """Whether the flight has the signals this candidate needs."""
        if self.name == "battery_sag" and ctx.v_ref is None:
            return False
        if self.build is _battery_governed_idle and ctx.flight.inputs != "motors":
            return False
        if self.build is _wind_quadratic and not ctx.nominal.drag_quadratic:
            return False
        if self.build is _rotor_twist and "az" not in ctx.nominal.coef:
            return False
        if self.motor is not None and (ctx.flight.inputs != "motors"
                                       or self.motor >= ctx.flight.motors.shape[1]):
            return False
        return all(s in ctx.flight.have for s in self.needs)

    def mods(self, theta: np.ndarray, ctx: Context) -> Mods:
        """The nominal-model change for parameters ``theta``."""
        return self.build(np.asarray(theta, dtype=float), ctx)


def _times(a: float | np.ndarray, b: float | np.ndarray) -> float | np.ndarray:
    x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if x.ndim == 1 and y.ndim == 2:
        x = x[:, None]
    if y.ndim == 1 and x.ndim == 2:
        y = y[:, None]
    return x * y


def merge(a: Mods, b: Mods) -> Mods:
    """Two effects at once: gains multiply, offsets and drags add, lag/delay combine."""
    tau = a.tau if b.tau is None else (b.tau if a.tau is None else max(a.tau, b.tau))
    offset = dict(a.offset)
    for k, v in b.offset.items():
        offset[k] = offset.get(k, 0.0) + v
    return Mods(tau=tau, delay=a.delay + b.delay, thrust_gain=_times(a.thrust_gain, b.thrust_gain),
                torque_gain=_times(a.torque_gain, b.torque_gain), inertia=a.inertia * b.inertia,
                mass=a.mass * b.mass,
                offset=offset, drag=a.drag + b.drag,
                drag_moment=a.drag_moment + b.drag_moment, spinup=a.spinup * b.spinup,
                spin_gain=_times(a.spin_gain, b.spin_gain),
                spin_torque=a.spin_torque + b.spin_torque,
                yaw_per_thrust=a.yaw_per_thrust + b.yaw_per_thrust,
                damping=a.damping + b.damping, yaw_damping=a.yaw_damping + b.yaw_damping,
                wind=(a.wind[0] + b.wind[0], a.wind[1] + b.wind[1]),
                rate_bias=tuple(x + y for x, y in zip(a.rate_bias, b.rate_bias, strict=True)))


def ground_ratio(z: np.ndarray, radius: float, exponent: float = 2.0) -> np.ndarray:
    """T_IGE/T_OGE = 1/(1 − (R/4z)^n), clipped at :data:`GE_MAX_RATIO` (z, R in m).

    n = 2 is Cheeseman–Bennett's image-rotor law; a free n lets one law describe a whole
    multirotor, whose neighbouring rotors and body make the excess decay more slowly.
    """
    x = radius / (4.0 * np.maximum(z, 1e-3))
    den = np.maximum(1.0 - x**exponent, 1.0 / GE_MAX_RATIO)
    return 1.0 / den


def ground_ratio_exp(z: np.ndarray, excess: float, decay: float) -> np.ndarray:
    """T_IGE/T_OGE = 1 + a e^(−z/λ) (z, λ in m), clipped at :data:`GE_MAX_RATIO`: the
    exponential form some simulators and fits use, which decays faster far from the ground
    and stays finite at it."""
    return np.minimum(1.0 + excess * np.exp(-np.maximum(z, 0.0) / max(decay, 1e-6)),
                      GE_MAX_RATIO)


def ground_excess(theta: np.ndarray, exponential: bool):
    """z (m) → thrust excess ratio − 1 of a fitted ground-effect law (either form)."""
    if exponential:
        return lambda z: ground_ratio_exp(z, float(theta[0]), float(theta[1])) - 1.0
    return lambda z: ground_ratio(z, float(theta[0]), float(theta[1])) - 1.0


def hub_heights(ctx: Context, arm: float) -> np.ndarray:
    """(n, N) height of every hub above ground, m, from altitude, attitude and geometry."""
    f = ctx.flight
    alt = f.alt[:, None]
    if ctx.rotor_dirs is None or arm <= 0:
        return np.broadcast_to(alt, (f.n, max(f.motors.shape[1], 1)))
    phi, th = f.att[:, 0:1], f.att[:, 1:2]
    x = arm * ctx.rotor_dirs[None, :, 0]
    y = arm * ctx.rotor_dirs[None, :, 1]
    return alt + x * np.sin(th) - y * np.sin(phi) * np.cos(th)


def _ground_effect(theta: np.ndarray, ctx: Context) -> Mods:
    radius, n = theta[0], theta[1]
    if ctx.arm is not None and ctx.rotor_dirs is not None:
        return Mods(thrust_gain=ground_ratio(hub_heights(ctx, ctx.arm), radius, n))
    return Mods(thrust_gain=ground_ratio(ctx.flight.alt, radius, n))


def _ground_effect_exp(theta: np.ndarray, ctx: Context) -> Mods:
    """Exponential law per hub: at the vehicle file's arm, else at the fitted ``theta[2]``
    (0: every hub at the logged height, no restoring moment)."""
    excess, decay = theta[0], theta[1]
    arm = ctx.arm if ctx.arm is not None else float(theta[2])
    if arm > 0 and ctx.rotor_dirs is not None:
        return Mods(thrust_gain=ground_ratio_exp(hub_heights(ctx, arm), excess, decay))
    return Mods(thrust_gain=ground_ratio_exp(ctx.flight.alt, excess, decay))


def ground_search(ctx: Context) -> SearchMap:
    """Search coordinates of the ground-effect law: ``s = (n ln(R / 4 z_ref), n)``.

    ``s[0]`` is the log of the law's term ``(R/4z)^n`` at the flight's median airborne
    height ``z_ref`` (m): the thrust excess there, which the data fix well. In ``(R, n)``
    the data only fix a narrow curved valley of equal excess (a larger ``R`` with a steeper
    ``n``), along which a bounded local search stalls — on a small quadrotor it settled on
    the lower bound of ``R`` with a law flatter than the data's best.
    """
    alt = ctx.flight.alt[ctx.flight.airborne] if np.any(ctx.flight.airborne) else ctx.flight.alt
    z_ref = max(float(np.median(alt)), 0.05)

    def to_theta(s: np.ndarray) -> np.ndarray:
        n = max(float(s[1]), 0.1)  # the fit clips θ to its bounds afterwards
        return np.array([4.0 * z_ref * np.exp(np.clip(s[0] / n, -50.0, 50.0)), n])

    def to_search(theta: np.ndarray) -> np.ndarray:
        return np.array([theta[1] * np.log(theta[0] / (4.0 * z_ref)), theta[1]])
    return SearchMap(to_theta, to_search, np.array([0.1, 0.1]))


def _voltage_ratio(ctx: Context) -> np.ndarray:
    """``V / V_sim`` per sample, the measured pack voltage held within 0.3-3× SIM's."""
    return np.clip(ctx.flight.vbat, 0.3 * ctx.v_ref, 3.0 * ctx.v_ref) / ctx.v_ref


def _battery(theta: np.ndarray, ctx: Context) -> Mods:
    """Thrust and reaction torque ∝ Ω² follow ``(V/V_sim)^n``, so the rotor speed and its
    spin-up (the yaw reaction of the rotors' inertia) follow its square root."""
    gain = _voltage_ratio(ctx) ** theta[0]
    return Mods(thrust_gain=gain, torque_gain=gain, spin_gain=np.sqrt(gain))


def _battery_governed_idle(theta: np.ndarray, ctx: Context) -> Mods:
    """An ESC that holds the rotors' idle speed: only the commanded part of the speed law
    ``Ω ∝ m + k`` follows ``(V/V_sim)^(n/2)``, per rotor and sample."""
    speed = _voltage_ratio(ctx) ** (0.5 * theta[0])
    m = np.clip(ctx.flight.motors, 0.0, 1.0)
    k = max(float(ctx.nominal.k), 1e-6)
    ratio = (k + m * speed[:, None]) / (k + m)
    gain = ratio * ratio
    return Mods(thrust_gain=gain, torque_gain=gain, spin_gain=ratio)


def _offsets(channels: tuple[str, ...]) -> Callable[[np.ndarray, Context], Mods]:
    def build(theta: np.ndarray, ctx: Context) -> Mods:
        return Mods(offset={c: float(v) for c, v in zip(channels, theta, strict=True)})
    return build


def _gyro_bias_leaning(theta: np.ndarray, ctx: Context) -> Mods:
    """Gyro bias b (rad/s) and the lean τ_e b (rad) it leaves in an attitude estimate that
    corrects towards gravity with time constant τ_e (s): the accelerometer then differs from
    the velocity by g times the lean, −g τ_e b_y along x and +g τ_e b_x along y."""
    bx, by, bz, lean = (float(v) for v in theta)
    return Mods(offset={"gyro_p": bx, "gyro_q": by, "gyro_r": bz,
                        "kin_x": -GRAVITY * lean * by, "kin_y": GRAVITY * lean * bx},
                rate_bias=(bx, by, bz))


def _gyro_bias(theta: np.ndarray, ctx: Context) -> Mods:
    """Gyro bias b (rad/s): the gyro reads the attitude's rate plus b, and the rate terms
    of SIM's angular-acceleration laws (rotor damping, gyroscopic products) see the logged
    rates less b."""
    bx, by, bz = (float(v) for v in theta)
    return Mods(offset={"gyro_p": bx, "gyro_q": by, "gyro_r": bz}, rate_bias=(bx, by, bz))


def _rotor_twist(theta: np.ndarray, ctx: Context) -> Mods:
    """A yaw angular acceleration ``theta[0]`` rad/s² at 1 g of thrust, in proportion to the
    thrust: rotors twisted about their arms in one sense (κ = yaw / g)."""
    return Mods(yaw_per_thrust=float(theta[0]) / GRAVITY)


def _weak_motor(index: int) -> Callable[[np.ndarray, Context], Mods]:
    def build(theta: np.ndarray, ctx: Context) -> Mods:
        n_rotors = ctx.flight.motors.shape[1]
        thrust, torque = np.ones((1, n_rotors)), np.ones((1, n_rotors))
        thrust[0, index], torque[0, index] = theta[0], theta[0] * theta[1]
        return Mods(thrust_gain=np.repeat(thrust, ctx.flight.n, axis=0),
                    torque_gain=np.repeat(torque, ctx.flight.n, axis=0))
    return build


MAX_MOTORS = 8
TORQUE_PER_THRUST = (0.7, 1.4)
"""Bounds of one rotor's reaction torque per unit thrust against the others': a propeller of
the same diameter with another pitch, wear or a chipped blade changes it by tens of per cent
(a 10×4.7 against a 10×7 propeller: ×1.3), not by halves; a yaw the law could only meet
beyond them is another effect's (a twisted rotor's, a yaw offset's)."""


def _weak_motors() -> tuple[Candidate, ...]:
    return tuple(Candidate(
        "weak_motor", (Param("scale", "1", 0.3, 1.5, 1.0, 1.0),
                       Param("torque_per_thrust", "1", *TORQUE_PER_THRUST, 1.0, 1.0)),
        ("az", "p", "q", "r"),
        "one rotor gives less (or more) thrust than the others at the same command: the "
        "others' trims hold a differential that grows with thrust (a chipped propeller, a "
        "worn motor); its reaction torque per unit thrust may change a little (a slower "
        "motor loses both alike, a damaged or other-pitch propeller changes their ratio)",
        f"T_{i + 1} = s · T_{i + 1},nom, Q_{i + 1} = s ρ · Q_{i + 1},nom (motor {i + 1} only; "
        "ρ the torque per thrust against the others')",
        _weak_motor(i),
        motor=i)
        for i in range(MAX_MOTORS))


def _wind(theta: np.ndarray, ctx: Context) -> Mods:
    """Drag on the air-relative velocity, and the translational lift the extra airspeed
    gives the rotors: thrust × (1 + c (|v_air,h|² − |v_h|²))."""
    wind = (float(theta[0]), float(theta[1]))
    va = air_velocity(ctx.flight, wind)
    vb = ctx.flight.v_body
    extra = va[:, 0] ** 2 + va[:, 1] ** 2 - vb[:, 0] ** 2 - vb[:, 1] ** 2
    return Mods(wind=wind, thrust_gain=1.0 + theta[2] * extra)


def _wind_quadratic(theta: np.ndarray, ctx: Context) -> Mods:
    """:func:`_wind` under SIM's drag law with its speed-squared terms."""
    return replace(_wind(theta, ctx), drag_shape="quadratic")


WIND_PARAMS = (Param("north", "m/s", -15.0, 15.0, 0.0, 0.0),
               Param("east", "m/s", -15.0, 15.0, 0.0, 0.0),
               Param("lift", "1/(m/s)²", 0.0, 0.02, 0.0, 0.0))
"""The steady wind (towards north and east) and its translational lift, in either drag form."""

LIBRARY: tuple[Candidate, ...] = (
    Candidate(
        "ground_effect",
        (Param("R", "m", 0.02, 1.5, 0.3, 0.02), Param("exponent", "1", 0.6, 3.0, 2.0)),
        ("az", "p", "q"),
        "thrust excess that grows as the hubs near the ground (vertical force and the "
        "restoring moments of a tilted rotor plane), independent of command",
        "T = T_nom / (1 − (R / 4 z)^n), z height above ground (Cheeseman–Bennett for n = 2; "
        "effective radius R and decay exponent n)",
        _ground_effect, ("alt",), ground_search),
    Candidate(
        "ground_effect",
        (Param("excess", "1", 0.0, 1.0, 0.2, 0.0), Param("decay", "m", 0.005, 2.0, 0.2),
         Param("arm", "m", 0.0, 1.5, 0.0, 0.0)),
        ("az", "p", "q"),
        "thrust excess that grows as the hubs near the ground, independent of command "
        "(exponential form: finite at the ground, gone within a few decay lengths); a "
        "tilted vehicle's lower hubs gain more, a restoring moment",
        "T_i = T_i,nom (1 + a e^(−z_i/λ)), z_i the height of hub i (excess a at the ground, "
        "decay length λ; hubs at the vehicle file's arm, else at a fitted effective arm)",
        _ground_effect_exp, ("alt",)),
    Candidate(
        "thrust_scale", (Param("scale", "1", 0.4, 2.0, 1.0, 1.0),), ("az", "p", "q"),
        "thrust everywhere too high or low by the same factor: vertical force and roll/pitch "
        "authority change together, yaw does not",
        "T_i = s · T_i,nom", lambda th, ctx: Mods(thrust_gain=th[0])),
    Candidate(
        "mass", (Param("ratio", "1", 0.5, 2.0, 1.0, 1.0),), ("az", "ax", "ay"),
        "the vehicle heavier or lighter at the same thrust (a payload, a bigger pack): the "
        "specific forces change, roll/pitch authority does not (which tells it from a thrust "
        "scale; from the vertical force alone the two are one thrust-to-weight ratio)",
        "a = F_nom / (r m_nom): specific forces ÷ r",
        lambda th, ctx: Mods(mass=th[0])),
    Candidate(
        "battery_sag", (Param("exponent", "1", 0.0, 6.0, 2.0, 0.0),), ("az", "p", "q", "r"),
        "thrust and torque follow the measured pack voltage (drops under load and with charge)",
        "T_i = T_i,nom · (V / V_sim)^n, Ω_i and dΩ_i/dt · (V / V_sim)^(n/2), V_sim the "
        "simulation's mean voltage",
        _battery, ("vbat",)),
    Candidate(
        "battery_sag", (Param("exponent", "1", 0.0, 6.0, 2.0, 0.0),), ("az", "p", "q", "r"),
        "thrust and torque follow the measured pack voltage above the idle speed an ESC "
        "holds",
        "Ω_i = Ω_idle + (Ω_i,nom − Ω_idle) · (V / V_sim)^(n/2), Ω_idle the speed law's "
        "zero-command speed",
        _battery_governed_idle, ("vbat",)),
    Candidate(
        "motor_lag", (Param("tau", "s", 0.003, 0.5, 0.08),), ("az", "p", "q", "r"),
        "response to motor commands smaller and later the faster the command changes "
        "(a first-order roll-off), steady state unchanged",
        "Ω̇_i = (Ω_i,cmd − Ω_i)/τ (symmetric first-order lag)",
        lambda th, ctx: Mods(tau=th[0])),
    Candidate(
        "time_delay", (Param("delay", "s", 0.0, 0.3, 0.02, 0.0),), ("az", "p", "q", "r"),
        "response to motor commands later by a fixed time at every frequency, gain unchanged",
        "m_i(t) → m_i(t − d)", lambda th, ctx: Mods(delay=th[0])),
    Candidate(
        "rotor_drag", (Param("drag", "1/s", 0.0, 3.0, 0.2, 0.0),
                       Param("moment", "rad/s² per m/s", -5.0, 5.0, 0.0, 0.0),
                       Param("yaw", "1/s", 0.0, 20.0, 0.0, 0.0)),
        ("ax", "ay", "p", "q", "r"),
        "horizontal specific force opposing the body velocity, growing with speed, the "
        "pitching/rolling moment it makes at the rotor plane above or below the CG, and the "
        "yaw damping of the same in-plane force on rotors swept round by a yaw rate",
        "a_xy = a_xy,nom − k v_xy,body (linear blade-flapping/H-force drag); "
        "q̇ += h v_x, ṗ −= h v_y; ṙ −= d_r r (d_r ≥ 0: H-force at the arm's end)",
        lambda th, ctx: Mods(drag=th[0], drag_moment=th[1], yaw_damping=th[2]), ("vel",)),
    Candidate(
        "inertia_scale", (Param("scale", "1", 0.3, 3.0, 1.0, 1.0),), ("p", "q", "r"),
        "all angular accelerations smaller or larger by one factor; vertical force unchanged",
        "ω̇ = ω̇_nom / s (inertia s times the simulation's)",
        lambda th, ctx: Mods(inertia=th[0])),
    Candidate(
        "torque_offset",
        (Param("p_offset", "rad/s²", -20.0, 20.0, 0.0, 0.0), Param("q_offset", "rad/s²", -20.0,
                                                            20.0, 0.0, 0.0),
         Param("r_offset", "rad/s²", -20.0, 20.0, 0.0, 0.0)), ("p", "q", "r"),
        "a constant angular acceleration the motors must hold against (steady differential "
        "thrust in level flight): a CG offset or a constant moment",
        "ω̇ = ω̇_nom + J⁻¹ M_0", _offsets(("p", "q", "r"))),
    Candidate(
        "gyro_bias",
        (Param("bx", "rad/s", -0.5, 0.5, 0.0, 0.0), Param("by", "rad/s", -0.5, 0.5, 0.0, 0.0),
         Param("bz", "rad/s", -0.5, 0.5, 0.0, 0.0)),
        ("gyro_p", "gyro_q", "gyro_r", "p", "q", "r"),
        "the gyro reads a constant rate the attitude does not follow (the controller's "
        "integrator hides it in the rate loop); the rate-dependent moments (rotor damping, "
        "gyroscopic) act on the true rate, so SIM's laws fed the logged rate are off by "
        "their rate coefficient times b",
        "ω_gyro = ω_attitude + b; ω̇ = f(u, ω_gyro − b)", _gyro_bias, ("roll",)),
    Candidate(
        # the estimator's lean: a complementary filter or an EKF that does not (yet) know
        # the bias settles where the gravity correction cancels it
        "gyro_bias",
        (Param("bx", "rad/s", -0.5, 0.5, 0.0, 0.0), Param("by", "rad/s", -0.5, 0.5, 0.0, 0.0),
         Param("bz", "rad/s", -0.5, 0.5, 0.0, 0.0),
         Param("lean", "s", 0.0, MAX_ESTIMATOR_TIME_S, 0.0, 0.0)),
        ("gyro_p", "gyro_q", "gyro_r", "kin_x", "kin_y", "p", "q", "r"),
        "the gyro reads a constant rate the attitude does not follow, and the attitude "
        "estimate, pulled towards gravity, leans by that rate times its correction time: "
        "the accelerometer then disagrees with the velocity in x and y by g times the lean "
        "(no z part, unlike an accelerometer bias)",
        "ω_gyro = ω_attitude + b; ω̇ = f(u, ω_gyro − b); lean = τ_e b: "
        "f − f_kin = g τ_e (−b_y, b_x, 0)",
        _gyro_bias_leaning, ("roll", "vel")),
    Candidate(
        "yaw_torque_scale", (Param("scale", "1", 0.3, 3.0, 1.0, 1.0),), ("r",),
        "yaw authority too high or low by one factor (propeller drag torque, motor "
        "constant), roll, pitch and vertical force unchanged",
        "Q_i = s · Q_i,nom (rotor reaction torque)",
        lambda th, ctx: Mods(torque_gain=th[0])),
    Candidate(
        "rotor_inertia", (Param("scale", "1", 0.2, 8.0, 1.0, 1.0),), ("r",),
        "yaw kicks when the motors speed up or slow down, larger or smaller than simulated; "
        "steady yaw authority unchanged",
        "Q_spin,i = s · I_rotor,nom dΩ_i/dt",
        lambda th, ctx: Mods(spinup=th[0])),
    Candidate(
        # c ≥ 0: a rotor spun up pushes the body back the way its drag torque does
        "rotor_inertia", (Param("added", "rad/s² per 1/s", 0.0, 20.0, 0.0, 0.0),), ("r",),
        "yaw kicks when the motors speed up or slow down where the simulation has none (a "
        "simulator that neglects rotor inertia); steady yaw authority unchanged",
        "ṙ += c Σ_i sgn(h_i) dΩ_i/dt (h_i: rotor i's yaw-torque coefficient in SIM)",
        lambda th, ctx: Mods(spin_torque=th[0])),
    Candidate(
        "rotor_twist", (Param("yaw", "rad/s² at 1 g", -100.0, 100.0, 0.0, 0.0),), ("r",),
        "a yaw moment in proportion to the total thrust, whatever the rotors' differences: "
        "rotor axes twisted about their arms in one sense (bent arms, motor mounts turned "
        "on their tubes) tilt every thrust vector sideways, and the yaw controller holds "
        "the heading with a steady reaction-torque differential that grows with thrust",
        "ṙ = ṙ_nom + κ |a_T|, a_T the rotors' thrust specific force (κ = m L tan δ / I_z; "
        "reported as κ g, the yaw acceleration at hover thrust)",
        _rotor_twist),
    Candidate(
        "rate_damping", (Param("damping", "1/s", -5.0, 20.0, 0.0, 0.0),
                         Param("yaw", "1/s", -5.0, 20.0, 0.0, 0.0)), ("p", "q", "r"),
        "body rates die out faster (or slower) than simulated, in proportion to the rate: "
        "the rotors' aerodynamic damping of a rotating rotor plane (blade flapping) in roll "
        "and pitch, and its own factor in yaw (the rotors' drag meeting a yawing airflow)",
        "ṗ = ṗ_nom − d p, q̇ = q̇_nom − d q, ṙ = ṙ_nom − d_r r",
        lambda th, ctx: Mods(damping=th[0], yaw_damping=th[1])),
    Candidate(
        "wind", WIND_PARAMS, ("ax", "ay", "az"),
        "a horizontal force that depends on the heading and on the velocity relative to a "
        "fixed direction of the earth (drag on the air-relative velocity), not on the body "
        "velocity alone; the airspeed also lifts the rotors (translational lift)",
        "v_air = v − w (w steady, north-east), drag terms on v_air; "
        "T = T_nom (1 + c (|v_air,h|² − |v_h|²))",
        _wind, ("vel",)),
    Candidate(
        "wind", WIND_PARAMS, ("ax", "ay", "az"),
        "the same steady wind, under SIM's drag law with its speed-squared terms: the shape "
        "SIM's own speeds could not reject when it chose a linear law (through the air a "
        "wind flies the vehicle faster than SIM flew, where the two shapes part)",
        "v_air = v − w, drag c1 Ω̄ v_air + c2 |v_air,j| v_air,j + c3 |v_air| v_air,j (one law "
        "for x and y, fitted on SIM); T = T_nom (1 + c (|v_air,h|² − |v_h|²))",
        _wind_quadratic, ("vel",)),
    *_weak_motors(),
    Candidate(
        "accel_bias",
        (Param("bx", "m/s²", -3.0, 3.0, 0.0, 0.0), Param("by", "m/s²", -3.0, 3.0, 0.0, 0.0),
         Param("bz", "m/s²", -3.0, 3.0, 0.0, 0.0)), ("kin_x", "kin_y", "kin_z", "ax", "ay", "az"),
        "the accelerometer reads a constant specific force the velocity and attitude do not "
        "follow; unlike a thrust scale it does not grow with thrust and leaves roll/pitch "
        "authority alone",
        "f_accel = f_true + b (body axes)",
        lambda th, ctx: Mods(offset={"kin_x": th[0], "kin_y": th[1], "kin_z": th[2],
                                     "ax": th[0], "ay": th[1], "az": th[2]}), ("vel",),
        law_needs=()),
)

BY_NAME: dict[str, Candidate] = {
    name: next(c for c in LIBRARY if c.name == name)
    for name in dict.fromkeys(c.name for c in LIBRARY)}
"""Name → the first candidate of that name (ground effect's Cheeseman–Bennett form,
motor 1's weak motor)."""
VOCABULARY = (*BY_NAME, "unexplained")
