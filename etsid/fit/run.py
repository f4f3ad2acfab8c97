"""``fit_tables``: pooled flights of one airframe → parameters with standard errors and
verdicts, and the vehicle file the simulator flies."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pandas as pd

from etsid.errors import FitError
from etsid.fit.drag import fit_drag, rotor_speed_ratio
from etsid.fit.layout import active_motors, geometry_rows, rotor_layout
from etsid.fit.regress import N_BLOCKS, block_ids, jackknife_se
from etsid.fit.result import FitResult, Param, judge
from etsid.fit.rotation import fit_rotation
from etsid.fit.signals import MIN_AIRBORNE_S, Flight, prepare
from etsid.fit.sticks import stick_scales
from etsid.fit.thrust import fit_thrust, hover_command
from etsid.fit.truth import vehicle_truth
from etsid.fit.vehicle_file import build_vehicle
from etsid.sim.vehicle import Vehicle, load_vehicle

SMALL_ARM = 0.2
"""m: frames with shorter arms get the 250-class template, others the 680-class one."""


def choose_template(layout: dict) -> Vehicle:
    """The packaged vehicle whose declared fields (mass, blades, torque ratio) stand in."""
    return load_vehicle("quad250" if layout["arm"] < SMALL_ARM else "tarot680")


def _flights(tables: Sequence[pd.DataFrame], max_rate_hz: float | None
             ) -> tuple[list[Flight], dict, dict[str, int]]:
    counts: dict[str, int] = {}
    motors0: list[str] | None = None
    layout: dict | None = None
    prepared = []
    for table in tables:
        src = str(table.attrs.get("source", "table"))
        motors, parked = active_motors(table)
        counts["parked_outputs"] = counts.get("parked_outputs", 0) + len(parked)
        if motors0 is None:
            motors0 = motors
            layout = rotor_layout(table, motors)
        elif len(motors) != len(motors0):
            raise FitError(f"{src}: {len(motors)} active motors, the first log has "
                           f"{len(motors0)}; pooled flights must be one airframe")
        prepared.append((table, motors))
    assert layout is not None
    layout["motors"] = motors0
    v0 = None
    vb = [float(np.nanmedian(t["vbat"].to_numpy(dtype=float))) for t in tables if "vbat" in t]
    if vb:
        v0 = float(np.median(vb))
    flights = [prepare(t, m, v0, max_rate_hz) for t, m in prepared]
    for f in flights:
        for k, v in f.counts.items():
            counts[k] = counts.get(k, 0) + v
    layout["v0"] = v0
    if sum(int(f.hover.sum()) * f.dt for f in flights) < MIN_AIRBORNE_S:
        for f in flights:
            f.hover = f.airborne.copy()
        counts["near_hover_fallback"] = 1
    return flights, layout, counts


def motor_shares(flights: list[Flight]) -> list[tuple[int, float, float]]:
    """(motor index, mean output / mean of all motors, jackknife se) over airborne rows."""
    m = np.vstack([f.motors[f.hover] for f in flights])
    ids = block_ids(len(m))
    out = []
    for j in range(m.shape[1]):
        share = float(m[:, j].mean() / m.mean())
        reps = [m[ids != b, j].mean() / m[ids != b].mean() for b in range(N_BLOCKS)]
        out.append((j, share, jackknife_se(np.array(reps))))
    return out


def _param(name: str, value: float, se: float, unit: str, meaning: str,
           verdict: str | None = None, note: str = "") -> Param:
    return Param(name=name, value=float(value), se=float(se), unit=unit,
                 verdict=verdict or judge(name, value, se), meaning=meaning, note=note)


def _with_curve(value: float, se: float, alt: list[float]) -> float:
    """Standard error of a moment coefficient with the thrust curve's uncertainty added:
    the coefficient refitted at the ends of the curve's 95 % interval moves by ±1.96 se."""
    if not alt:
        return se
    return float(np.hypot(se, max(abs(a - value) for a in alt) / 1.96))


QUICK_RATE_HZ = 100.0
"""Hz: the grid of a quick fit (the regressions are low-passed at ≤ 15 Hz anyway)."""


def fit_tables(tables: Sequence[pd.DataFrame], *, template: Vehicle | None = None,
               name: str = "fitted", quick: bool = False) -> FitResult:
    """Fit one airframe from its flights (module docstring of :mod:`etsid.fit`).

    ``quick``: the flights on a ≤ 100 Hz grid, one pass of thrust and moment fits (not
    two), and the (τ, d) grid without its fine stage — about 5× faster, for fleets of many
    flights; τ and d are then known to the coarse grid's resolution (their se says so).

    Raises
    ------
    FitError
        A log without motor outputs, gyro or airborne data; logs of different rotor counts.
    """
    if not tables:
        raise FitError("no flight to fit")
    try:  # skinny least squares: BLAS threads only contend (2 cores shared here)
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover
        return _fit(tables, template, name, quick)
    with threadpool_limits(limits=1, user_api="blas"):
        return _fit(tables, template, name, quick)


def _fit(tables: Sequence[pd.DataFrame], template: Vehicle | None, name: str,
         quick: bool) -> FitResult:
    flights, layout, counts = _flights(tables, QUICK_RATE_HZ if quick else None)
    tmpl = template or choose_template(layout)
    base = vehicle_truth(tmpl)
    g = tmpl["environment"]["gravity"]
    geom = geometry_rows(layout)
    n = layout["n"]
    notes: list[str] = []
    if counts.get("near_hover_fallback"):
        notes.append("under 5 s near hover (horizontal speed < 1.5 m/s): the thrust and "
                     "moment laws are fitted on fast flight too, where translational lift "
                     "biases them")
    k, idle, tau, delay = base["k"] * n / tmpl.n_rotors, base["idle_ratio"], \
        base["motor_time_constant"], 0.0
    thrust = rot = None
    passes = 1 if quick else 2
    for i in range(passes):
        thrust = fit_thrust(flights, tau, delay)
        if thrust is not None:
            k, idle = thrust.k, thrust.idle
        rot = fit_rotation(flights, geom, k, idle, base["motor_time_constant"], fine=not quick,
                           ends=thrust.ends if thrust is not None else (),
                           spread=i == passes - 1)
        tau, delay = rot.tau, rot.delay
    assert rot is not None
    params: dict[str, Param] = {}
    add = params.__setitem__
    hc = hover_command(flights, g)
    if hc is not None:
        add("hover_command", _param("hover_command", hc[0], hc[1], "0..1",
                                    "mean motor output in level unaccelerated flight at V0"))
        if layout["v0"] and math.isfinite(hc[3]):
            add("hover_command_per_volt", _param(
                "hover_command_per_volt", hc[2] / layout["v0"], hc[3] / layout["v0"], "1/V",
                "change of the hover command per volt of pack voltage"))
    if thrust is not None:
        lo, hi = thrust.k_range
        k_se = (hi - lo) / 3.92
        add("thrust_to_weight", _param("thrust_to_weight", thrust.k * n / g, k_se * n / g, "-",
                                       "all rotors at full command at V0, over the weight"))
        il, ih = thrust.idle_interval
        add("idle_ratio", _param("idle_ratio", thrust.idle, (ih - il) / 3.92 or 0.005, "-",
                                 "rotor speed at zero command over top speed at V0"))
        x_h = math.sqrt(g / (thrust.k * n))
        slope = 2.0 * thrust.k * n * x_h * (1.0 - thrust.idle) / g
        add("thrust_slope", _param("thrust_slope", slope, slope * (k_se / (2 * thrust.k) + (
            ih - il) / 3.92 / max(1 - thrust.idle, 0.05)), "1/command",
            "d(thrust/weight)/d(command) at hover"))
    else:
        notes.append("no accelerometer: thrust curve and drag not fitted (template values)")
    slow = not math.isfinite(rot.tau_se)
    motor_hz = min(f.motor_rate_hz for f in flights)
    def set_note(lo_hi: tuple[float, float]) -> str:
        if rot.set_open:
            return (f"Anderson–Rubin: {rot.set_open} (the moment coefficients carry τ's "
                    "and d's scatter between blocks only)")
        if not math.isfinite(rot.set_misfit) or not all(math.isfinite(v) for v in lo_hi):
            return ""
        lo, hi = (1000 * v for v in lo_hi)
        if rot.set_kind == "distance":
            return (f"Anderson–Rubin set empty (misfit ×{rot.set_misfit:.2f} at the best "
                    f"(τ, d)): misfit-scaled distance 95 % set {lo:.1f}…{hi:.1f} ms")
        return f"Anderson–Rubin 95 % set {lo:.1f}…{hi:.1f} ms"

    add("motor_time_constant", _param(
        "motor_time_constant", rot.tau, rot.tau_se, "s", "first-order rotor-speed lag",
        verdict="not-determined" if slow or rot.tau_at_edge or rot.set_open else None,
        note=(f"motor outputs logged at {motor_hz:.0f} Hz: too slow to resolve" if slow
              else "at the grid's edge" if rot.tau_at_edge else set_note(rot.tau_set))))
    add("time_delay", _param("time_delay", rot.delay, rot.delay_se, "s",
                             "command-to-rotor transport delay",
                             verdict="not-determined" if slow or rot.set_open else None,
                             note="" if slow else set_note(rot.delay_set)))
    if not rot.instrumented:
        notes.append("no pilot commands to instrument the rotation fit: its coefficients "
                     "are biased towards zero by the motor outputs' sampling noise")
    ends = thrust.ends if thrust is not None else ()
    for axis in ("roll", "pitch", "yaw"):
        fit = rot.axes[axis]
        meaning = ("mass × arm / Ixx" if axis == "roll" else "mass × arm / Iyy"
                   if axis == "pitch" else "mass × rotor torque-per-thrust / Izz")
        add(f"{axis}_effectiveness", _param(
            f"{axis}_effectiveness", fit.coef[0], _with_curve(fit.coef[0], fit.se[0],
                                                              [a[0] for a in fit.alt]),
            "1/m", meaning))
    # what a hover flight determines without the thrust curve: angular acceleration per
    # unit of motor-output difference, c × ∂f/∂m at hover (K's error cancels in it)
    m_h = params["hover_command"].value if "hover_command" in params else \
        (math.sqrt(g / (k * n)) - idle) / (1.0 - idle)
    def dfdm_at(k_: float, idle_: float) -> float:
        return 2.0 * k_ * (idle_ + (1.0 - idle_) * m_h) * (1.0 - idle_)

    dfdm = dfdm_at(k, idle)
    loose_curve = params.get("thrust_to_weight") is None or \
        params["thrust_to_weight"].verdict != "identified"
    for axis in ("roll", "pitch", "yaw"):
        fit = rot.axes[axis]
        key = f"{axis}_accel_per_command"
        alt = [a[0] * dfdm_at(ka, ia) for a, (ka, ia) in zip(fit.alt, ends, strict=True)]
        add(key, _param(key, fit.coef[0] * dfdm, _with_curve(fit.coef[0] * dfdm,
                                                             fit.se[0] * dfdm, alt), "rad/s²",
                        f"{axis} angular acceleration per unit of Σ (moment row × motor "
                        "output) at hover"))
        if loose_curve and params[f"{axis}_effectiveness"].verdict == "identified":
            params[f"{axis}_effectiveness"].verdict = "not-determined"
            params[f"{axis}_effectiveness"].note = "scales with the thrust curve, which " \
                "this flight does not determine"
    ratio, rse = rot.ratio, rot.ratio_se
    add("inertia_ratio_yx", _param("inertia_ratio_yx", ratio, rse, "-", "Iyy / Ixx"))
    drag = None
    if thrust is not None:
        x_hover = math.sqrt(g / (n * thrust.k)) if thrust.k > 0 else float("nan")
        tau_s = rot.tau if math.isfinite(rot.tau) else 0.0
        delay_s = rot.delay if math.isfinite(rot.delay) else 0.0
        speeds = ([rotor_speed_ratio(f, thrust.idle, tau_s, delay_s, x_hover)
                   for f in flights] if math.isfinite(x_hover) else None)
        drag = fit_drag(flights, speeds)
    if drag is not None:
        for ax, fit in drag.items():
            add(f"drag_{ax}", _param(f"drag_{ax}", -fit.coef[0], fit.se[0], "1/s",
                                     f"linear drag / mass along body {ax} (body + rotor H-force)"))
            add(f"drag_quad_{ax}", _param(f"drag_quad_{ax}", -fit.coef[1], fit.se[1], "1/m",
                                          f"quadratic drag / mass along body {ax}"))
    for key, (val, se) in stick_scales(list(tables), layout["motors"]).items():
        add(key, _param(key, val, se, "deg" if key == "max_tilt_deg" else "deg/s",
                        "full stick: attitude setpoint" if key == "max_tilt_deg" else
                        "full yaw stick: yaw-rate setpoint",
                        verdict="identified" if 1.96 * se < 0.2 * val else "not-determined"))
    for j, share, se in motor_shares(flights):
        add(f"motor{j + 1}_share", _param(
            f"motor{j + 1}_share", share, se, "-", f"motor {j + 1}'s mean output over the "
            "mean of all (a weak motor or a CG offset works it harder)",
            verdict="identified" if 1.96 * se < 0.02 else "not-determined"))
    # declared: what no log of accelerations and rates can separate
    add("mass", _param("mass", tmpl.mass, float("nan"), "kg", "take-off mass",
                       verdict="unidentifiable", note=f"declared ({tmpl.name}): only thrust/"
                       "mass is seen, never either alone"))
    add("arm_length", _param("arm_length", layout["arm"], float("nan"), "m", "rotor arm",
                             verdict="declared" if layout["arm_known"] else "unidentifiable",
                             note="from the log's geometry" if layout["arm_known"] else
                             "declared: inertia and arm appear only as arm/inertia"))
    add("kappa_q", _param("kappa_q", base["kappa_q"], float("nan"), "m",
                          "rotor torque per thrust", verdict="unidentifiable",
                          note=f"declared ({tmpl.name}): only its ratio to Izz is seen"))
    values = {key: p.value for key, p in params.items() if p.verdict == "identified"}
    if thrust is not None and "thrust_to_weight" in values:
        values["k"] = thrust.k
        values["idle_ratio"] = thrust.idle   # the profile's best, even when loose
    elif "hover_command" in params:
        # the thrust curve is loose: keep the template's idle ratio and put the curve
        # through the log's hover command, so the twin hovers where the vehicle did
        idle = base["idle_ratio"]
        values["idle_ratio"] = idle
        m_h = params["hover_command"].value
        values["k"] = g / (n * (idle + (1.0 - idle) * m_h) ** 2)
        notes.append("thrust curve not determined: the template's idle ratio, scaled "
                     "through the fitted hover command")
    for key in ("motor_time_constant", "time_delay"):
        if key not in values and not slow and not rot.tau_at_edge:
            values[key] = params[key].value    # the best estimate, loose or not
    # the twin's effectiveness reproduces the measured acceleration per command with the
    # thrust curve the vehicle file gets
    k_v = values.get("k", base["k"])
    idle_v = values.get("idle_ratio", base["idle_ratio"])
    x_v = math.sqrt(g / (k_v * n))
    dfdm_v = 2.0 * k_v * x_v * (1.0 - idle_v)
    for axis in ("roll", "pitch", "yaw"):
        p = params[f"{axis}_accel_per_command"]
        if p.value > 0 and p.se < 0.5 * p.value:
            values[f"{axis}_effectiveness"] = p.value / dfdm_v
    v0 = layout["v0"] or base["v0"]
    vehicle = build_vehicle(tmpl, values, layout, v0, name,
                            f"fitted by etsid fit from {len(tables)} flight(s); template "
                            f"{tmpl.name}", notes)
    layout_out = {k: v for k, v in layout.items()}
    return FitResult(params=params, vehicle=vehicle.to_dict(),
                     sources=[f.source for f in flights], layout=layout_out, counts=counts,
                     notes=notes)
