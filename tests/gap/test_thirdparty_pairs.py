"""A third-party simulator pair (benchmarks/gap_thirdparty.py) is an ingestible log pair
whose hidden effect is physically present in the raw data.

PyFlyt (PyBullet) flies its Crazyflie quadrotor twice, the "recording" with 15 % less
thrust per rotor; both flights go through etsid's MCAP writer and back through its reader.
A thrust-scaled vehicle needs more rotor speed for the same weight: PyFlyt's thrust is
k (throttle · max rpm)², so its hover motor output must rise by 1/√0.85 ≈ 1.085.
"""

from __future__ import annotations

import sys
from functools import partial
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("PyFlyt", reason="third-party simulator PyFlyt not installed "
                                     "(pip install -e '.[bench]')")

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

from thirdparty import pyflyt_pairs as pf
from thirdparty.common import to_table

from etsid.gap.signals import prepare
from etsid.ingest import read_log
from etsid.sim.writers import write_log

SCALE = 0.85
SEEN_PAIR_MISSED = partial(pytest.mark.xfail, strict=True, raises=AssertionError)
"""Seen PyFlyt pairs the round-4 tiers named with mechanisms of their own (the response
gain, the loop's innovations, its low band, its yaw noise) and the likelihood criterion
does not: kept as strict expected failures, each with what the criterion answers, so that
the day one passes it is noticed (docs/gap_results.md, session 10)."""


def _hover_command(path: Path) -> tuple[float, float, int]:
    """(median mean motor output while airborne, airborne s, motor count) of a log."""
    flight = prepare(read_log(path), path.name)
    assert flight.inputs == "motors"
    motors = flight.motors[flight.airborne]
    return float(np.median(motors.mean(axis=1))), flight.airborne_s, motors.shape[1]


def test_thrust_scaled_recording_hovers_at_a_higher_command(tmp_path: Path) -> None:
    rng = np.random.default_rng(5)
    vehicle = pf.random_vehicle(rng)
    commands = []
    for name, fx, seed in (("sim", {}, 11), ("real", {"thrust_scale": SCALE}, 12)):
        sensors = pf.sensors(rng, name == "real", {})
        rec = pf.fly("hover", 24.0, seed, vehicle, fx, sensors)
        table = to_table(rec, sensors, rng, f"pyflyt {name}")
        path = write_log(table, tmp_path / f"{name}{pf.LOG_SUFFIX}", rates=pf.LOG_RATES)
        command, airborne_s, n_motors = _hover_command(path)
        assert n_motors == 4
        assert airborne_s > 8.0, f"{name}: only {airborne_s:.1f} s airborne"
        commands.append(command)
    ratio = commands[1] / commands[0]
    assert ratio == pytest.approx(1.0 / np.sqrt(SCALE), abs=0.025), commands


def _gap_on_pair(label: str, seed: int) -> dict:
    """etsid gap on one PyFlyt pair of the benchmark (label, pair seed), made in-process."""
    import gap_thirdparty

    from etsid.gap.run import analyse

    sim, real, _truth = gap_thirdparty.make_pair("pyflyt", label, seed)
    return analyse(sim, real, "sim", "real").data


def test_pyflyt_ground_effect_is_named_on_the_scale_of_its_rotors() -> None:
    """PyFlyt's Crazyflie hovering 3-10 cm up with a per-rotor T(1 + a e^(-b z/R)) law (not
    etsid's): named ground effect, not a thrust scale, in either form with a height scale of
    centimetres (the exponential form's decay R/b ≈ 0.023 m / 0.5-0.65, or the generalised
    Cheeseman-Bennett form's effective radius: since step 21, 0.024 m against the 0.023 m
    propeller), located in height."""
    data = _gap_on_pair("ground_effect", 900090)
    names = [e["name"] for e in data["effects"] if e["name"] != "unexplained"]
    assert names == ["ground_effect"], data["summary"]
    p = {k: v["value"] for k, v in data["effects"][0]["parameters"].items()}
    assert 0.01 < p.get("decay", p.get("R", 0.0)) < 0.1, p
    assert data["mismatch"]["regime"]["variable"] == "alt"


def test_its_look_alike_a_pyflyt_thrust_scale_is_not_ground_effect() -> None:
    data = _gap_on_pair("thrust_scale", 900010)
    names = [e["name"] for e in data["effects"] if e["name"] != "unexplained"]
    assert names == ["thrust_scale"], data["summary"]


def test_a_wind_beyond_the_speeds_sim_flew_gets_no_drag_companion() -> None:
    """PyFlyt's Crazyflie flies its legs at ≤ 1.9 m/s in SIM; a 3.6 m/s wind (towards
    225°, third-party set 300, seen in round 2) puts REAL up to ≈ 5 m/s through the air, where
    SIM's drag law is extrapolated. Named: the wind alone (a rotor-drag companion took up the
    extrapolation before), its direction right."""
    data = _gap_on_pair("wind", 300120)
    names = [e["name"] for e in data["effects"] if e["name"] != "unexplained"]
    assert names == ["wind"], data["summary"]
    wind = data["effects"][0]
    p = {k: v["value"] for k, v in wind["parameters"].items()}
    towards = np.degrees(np.arctan2(p["east"], p["north"])) % 360.0
    truth = np.degrees(np.arctan2(-2.528, -2.558)) % 360.0  # ENU (-2.53, -2.56) → 225°
    assert abs((towards - truth + 180.0) % 360.0 - 180.0) < 30.0, p


def test_a_wind_on_an_axis_sim_barely_flew_is_found_through_one_drag_law() -> None:
    """Third-party pair 334-16 (fresh in session 9, answered `consistent` then): SIM flew
    its Crazyflie ≤ 0.9 m/s sideways, where PyFlyt's quadratic body drag is below the
    noise, so a lateral drag law of its own came out zero and a 3.7 m/s wind towards 161°
    (mostly lateral in REAL's headings) was invisible to the wind law. One quadratic law
    for both axes, fitted where SIM flew fastest, names the wind: its direction within
    15°, its speed within 25 % (the truth is PyFlyt's, ENU (1.22, −3.54) m/s)."""
    data = _gap_on_pair("wind", 334120)
    assert data["nominal"]["drag_law"] == "one linear + quadratic law for x and y"
    names = [e["name"] for e in data["effects"] if e["name"] != "unexplained"]
    assert names == ["wind"], data["summary"]
    p = {k: v["value"] for k, v in data["effects"][0]["parameters"].items()}
    towards = np.degrees(np.arctan2(p["east"], p["north"])) % 360.0
    truth = np.degrees(np.arctan2(1.218, -3.541)) % 360.0
    assert abs((towards - truth + 180.0) % 360.0 - 180.0) < 15.0, p
    assert np.hypot(p["north"], p["east"]) == pytest.approx(np.hypot(1.218, 3.541), rel=0.25)


def test_a_wind_the_linear_drag_law_cannot_reach_is_found_under_the_quadratic_one(
        tmp_path: Path) -> None:
    """A 3.9 m/s wind towards 217° (seed 346120, set 346's pair 5, fresh in session 11 and
    left an unnamed mismatch there): SIM flew at ≤ 1.8 m/s, where its linear drag law was
    as good as the quadratic one, and under the linear law the wind ran to its 15 m/s bound.
    Under the speed-squared law SIM could not reject (step 24) it is named, its direction
    within 15°. Fails without step 24."""
    names, p, data = _named("pyflyt", "wind", 346120, tmp_path)
    assert data["nominal"]["drag_law"] == "one linear law for x and y", data["nominal"]
    assert names == ["wind"], data["summary"]
    towards = np.degrees(np.arctan2(p["east"], p["north"])) % 360.0
    truth = np.degrees(np.arctan2(-2.343, -3.062)) % 360.0  # ENU (-2.34, -3.06) → 217°
    assert abs((towards - truth + 180.0) % 360.0 - 180.0) < 15.0, p


def test_its_look_alike_a_crazyflie_rotor_drag_is_no_wind(tmp_path: Path) -> None:
    """A rotor drag on the same kind of forward flight (seed 345040, fresh in session 11):
    body-frame drag that does not turn with the heading stays a rotor drag, the quadratic
    wind form notwithstanding."""
    names, _, data = _named("pyflyt", "rotor_drag", 345040, tmp_path)
    assert names == ["rotor_drag"], data["summary"]


def _logged_pair(simulator: str, label: str, seed: int, tmp_path: Path) -> tuple:
    """(SIM, REAL) FlightTables of one benchmark pair, written to the simulator's own log
    format and read back (as the benchmark scores them)."""
    if simulator == "multirotor":
        pytest.importorskip("multirotor", reason="third-party simulator multirotor not "
                                                 "installed (pip install -e '.[test]')")
    import gap_thirdparty

    mod = gap_thirdparty.simulator(simulator)
    tables = gap_thirdparty.make_pair(simulator, label, seed)[:2]
    return tuple(read_log(write_log(t, tmp_path / f"{n}{mod.LOG_SUFFIX}", rates=mod.LOG_RATES))
                 for n, t in zip(("sim", "real"), tables, strict=True))


def _named(simulator: str, label: str, seed: int, tmp_path: Path
           ) -> tuple[list[str], dict, dict]:
    """(names of the effects named, the first one's parameter values, gap.json) of one
    benchmark pair."""
    from etsid.gap.run import analyse

    sim, real = _logged_pair(simulator, label, seed, tmp_path)
    data = analyse(sim, real, "sim", "real").data
    names = [e["name"] for e in data["effects"] if e["name"] != "unexplained"]
    params = ({k: v["value"] for k, v in data["effects"][0]["parameters"].items()}
              if data["effects"] else {})
    return names, params, data


def test_look_alikes_the_data_do_not_tell_apart_are_both_said(tmp_path: Path) -> None:
    """PyFlyt's motor 4 at 84 % thrust on a hovering Crazyflie (set 307, seen): its trims
    shift as under a torque offset and its 4 % collective loss is near the floors. Through
    step 20 the two explained the data equally well and the torque offset was named with the
    weak motor as its caveat; with the pack voltage in the speed law (step 21) the weak
    motor leaves a floor unit less on the dynamic channels and is named. Either way the
    answer is never the torque offset without its look-alike, nor more than half confident in
    it; the weak motor, when named, is motor 4 at its thrust within 5 % (session 11: named
    at 1.00 with 0.86, above the detectable size the calibrated mismatch rule gives; the hint
    cap had held it at 0.45 below the older, larger size)."""
    from etsid.gap.run import analyse

    sim, real = _logged_pair("pyflyt", "weak_motor", 307130, tmp_path)
    data = analyse(sim, real, "sim", "real").data
    named = [e for e in data["effects"] if e["name"] != "unexplained"]
    assert [e["name"] for e in named] in (["torque_offset"], ["weak_motor"]), data["summary"]
    if named[0]["name"] == "torque_offset":
        assert "weak motor" in named[0].get("caveat", ""), named[0]
        assert named[0]["confidence"] <= 0.5
    else:
        p = named[0]["parameters"]
        assert p["motor"]["value"] == 4, p["motor"]
        assert p["scale"]["value"] == pytest.approx(0.84, abs=0.05), p


def test_rate_damping_is_named_in_roll_pitch_and_yaw(tmp_path: Path) -> None:
    """The octocopter with 3.9 1/s more rate damping on every axis (set 306, seen): named
    rate damping alone, roll/pitch and yaw factors within 15 % (it was named with a yaw torque
    scale as companion while the law had no yaw term)."""
    names, p, data = _named("multirotor", "rate_damping", 306140, tmp_path)
    assert names == ["rate_damping"], data["summary"]
    assert p["damping"] == pytest.approx(3.886, rel=0.15), p
    assert p["yaw"] == pytest.approx(3.886, rel=0.15), p


def test_its_look_alike_an_inertia_scale_is_not_rate_damping(tmp_path: Path) -> None:
    """×1.43 inertia (set 305, seen) also shrinks the angular accelerations, by one factor
    whatever the rate: named inertia_scale, not rate damping."""
    from etsid.gap.run import analyse

    sim, real = _logged_pair("multirotor", "inertia_scale", 305050, tmp_path)
    data = analyse(sim, real, "sim", "real").data
    names = [e["name"] for e in data["effects"] if e["name"] != "unexplained"]
    assert names == ["inertia_scale"], data["summary"]
    scale = data["effects"][0]["parameters"]["scale"]["value"]
    assert scale == pytest.approx(1.427, rel=0.1)


def test_a_gyro_bias_leaning_the_attitude_estimate_is_one_effect(tmp_path: Path) -> None:
    """PyFlyt's Crazyflie with a (-20, -28, 0) mrad/s gyro bias under a complementary filter
    of gain 1/s (set 302, seen): its attitude estimate leans with the bias, so the
    accelerometer also disagrees with the velocity in x and y. Named gyro bias alone, with
    the estimator's correction time near 1 s (it was named with an accelerometer-bias
    companion)."""
    names, p, data = _named("pyflyt", "gyro_bias", 302070, tmp_path)
    assert names == ["gyro_bias"], data["summary"]
    assert p["bx"] == pytest.approx(-0.0202, abs=0.004) and p["by"] == pytest.approx(
        -0.0281, abs=0.004), p
    assert p["lean"] == pytest.approx(1.0, abs=0.2), p
    assert "leans" in data["summary"]


def test_its_look_alike_an_accelerometer_bias_is_not_a_leaning_gyro_bias(
        tmp_path: Path) -> None:
    """PyFlyt's accelerometer off by (0.13, -0.11, 0.50) m/s² (set 305, seen): x and y as a
    lean would show, but the gyro agrees with the attitude and z is off too. Named
    accelerometer bias alone."""
    names, p, data = _named("pyflyt", "accel_bias", 305110, tmp_path)
    assert names == ["accel_bias"], data["summary"]
    assert p["bz"] == pytest.approx(0.497, abs=0.1), p


def test_a_less_predictable_recording_is_consistent_not_a_mismatch(tmp_path: Path) -> None:
    """The multirotor package's octocopter flown twice with nothing changed (set 301, seen):
    REAL's roll and pitch accelerations sit ≈ 2.2× their floors, within what the no-effect
    pairs of the calibration show, and no effect predicts its held-out blocks: consistent."""
    names, _, data = _named("multirotor", "none", 301230, tmp_path)
    assert data["verdict"] == "consistent" and names == [], data["summary"]


def test_a_yaw_torque_change_within_the_floors_is_named(tmp_path: Path) -> None:
    """The octocopter's yaw torque ×1.47 (set 307, seen): yaw acceleration stays within 2× its
    floor, yet the yaw torque scale raises the held-out likelihood of every block; named,
    its scale within 10 %."""
    names, params, data = _named("multirotor", "yaw_torque_scale", 307150, tmp_path)
    assert names == ["yaw_torque_scale"], data["summary"]
    assert params["scale"] == pytest.approx(1.469, rel=0.1), params


def test_its_look_alike_a_noisy_no_effect_crazyflie_stays_consistent(tmp_path: Path) -> None:
    """PyFlyt's Crazyflie flown twice with nothing changed (set 305, seen), the no-effect pair
    whose pitch response strayed most (a broadband gain of 0.93 at 3.5 standard errors):
    consistent."""
    names, _, data = _named("pyflyt", "none", 305170, tmp_path)
    assert data["verdict"] == "consistent" and names == [], data["summary"]


@SEEN_PAIR_MISSED(reason="answered consistent: the yaw torque scale does not pass the gain "
                         "threshold on this noise-driven loop")
def test_a_crazyflie_yaw_torque_change_is_named(tmp_path: Path) -> None:
    """PyFlyt's Crazyflie with ×0.575 yaw torque (set 306, seen): within the floors, named a
    yaw torque scale below 1."""
    names, params, data = _named("pyflyt", "yaw_torque_scale", 306150, tmp_path)
    assert names == ["yaw_torque_scale"], data["summary"]
    assert params["scale"] < 0.9, params


def test_its_look_alike_a_crazyflie_rotor_inertia_is_said_undecided(tmp_path: Path) -> None:
    """A rotor inertia added to the Crazyflie (set 309, seen) moves yaw's response alone, as a
    yaw torque scale does (its spin-up torque follows the reaction torques). Named one of
    the two with the other said as a look-alike, at most 0.5 confident, or neither."""
    names, _, data = _named("pyflyt", "rotor_inertia", 309160, tmp_path)
    assert len(names) <= 1 and set(names) <= {"rotor_inertia", "yaw_torque_scale"}, names
    if names:
        other = "yaw torque" if names[0] == "rotor_inertia" else "rotor inertia"
        assert other in data["effects"][0].get("caveat", ""), data["summary"]
        assert data["effects"][0]["confidence"] <= 0.5


def test_a_crazyflie_delay_under_its_noise_driven_loop_is_named(tmp_path: Path) -> None:
    """PyFlyt's Crazyflie with a 16.7 ms command delay (set 321, seen): its rate loop answers
    its motor noise (SIM reads 0.72× its model at 1-4 Hz, 1.55× at 4-8 Hz), so roll and
    pitch are scored as prediction errors under SIM's noise model (:mod:`etsid.gap.pem`);
    named a delay of 3-25 ms (its size is not pinned down: the loop's changed answer to its
    noise takes up part of it)."""
    names, params, data = _named("pyflyt", "time_delay", 321002, tmp_path)
    assert names == ["time_delay"], data["summary"]
    assert 0.003 <= params["delay"] <= 0.025, params


def test_its_look_alike_a_crazyflie_motor_lag_is_named_a_lag(tmp_path: Path) -> None:
    """The same vehicle with its motors 3.65× slower (set 321, seen), which an 8 Hz fit named
    a 12 ms delay: named a motor lag."""
    names, _, data = _named("pyflyt", "motor_lag", 321020, tmp_path)
    assert names == ["motor_lag"], data["summary"]


def test_a_crazyflie_delay_within_the_floors_is_named(tmp_path: Path) -> None:
    """A delayed Crazyflie whose angular accelerations all stay within their 8 Hz floors
    (seed 302022): its prediction errors under SIM's noise model are 1.7× SIM's, and the
    delay is named from them."""
    names, params, data = _named("pyflyt", "time_delay", 302022, tmp_path)
    assert names == ["time_delay"], data["summary"]
    assert params["delay"] > 0.002, params


def test_its_look_alike_a_no_effect_crazyflie_stays_consistent(tmp_path: Path) -> None:
    """The same vehicle flown twice with nothing changed (seed 319002): consistent."""
    names, _, data = _named("pyflyt", "none", 319002, tmp_path)
    assert data["verdict"] == "consistent" and names == [], data["summary"]


@SEEN_PAIR_MISSED(reason="named a mass ×1.16 (a partial explanation, 0.45); the delay not found")
def test_a_delay_beside_a_crazyflie_thrust_scale_is_named_with_it(tmp_path: Path) -> None:
    """Thrust ×1.16 and a command delay together (seed 321023): only the vertical force is
    beyond its floor; both are named, the delay second."""
    names, _, data = _named("pyflyt", "thrust_scale+time_delay", 321023, tmp_path)
    assert names == ["thrust_scale", "time_delay"], data["summary"]


def test_its_look_alike_a_crazyflie_thrust_scale_alone_gets_no_companion(
        tmp_path: Path) -> None:
    """A thrust scale alone on the same vehicle (seed 321008): nothing joins it. (Named a
    mass ×0.883 at 1.00 until session 12, while the ingest held the MCAP file's 60 Hz motor
    outputs one sample late at a share of its grid points.)"""
    names, _, data = _named("pyflyt", "thrust_scale", 321008, tmp_path)
    assert names == ["thrust_scale"], data["summary"]


@SEEN_PAIR_MISSED(reason="answered consistent")
def test_a_crazyflie_rate_damping_within_the_floors_is_named(tmp_path: Path) -> None:
    """PyFlyt's Crazyflie with a linear rate damping of 7.1 /s (seed 321140, set 321's pair
    17, seen): every channel within its floor; named a rate damping of 3-10 /s."""
    names, params, data = _named("pyflyt", "rate_damping", 321140, tmp_path)
    assert names == ["rate_damping"], data["summary"]
    assert 3.0 <= params["damping"] <= 10.0, params


def test_its_look_alike_a_crazyflie_inertia_change_is_no_rate_damping(
        tmp_path: Path) -> None:
    """An inertia ×1.52 on the same kind of vehicle (seed 321050, seen) also changes how the
    rates answer the commands: named an inertia scale, not a rate damping."""
    names, _, data = _named("pyflyt", "inertia_scale", 321050, tmp_path)
    assert names == ["inertia_scale"], data["summary"]


def test_a_crazyflie_rotor_inertia_is_named_or_said_unseeable(tmp_path: Path) -> None:
    """A rotor inertia added to the Crazyflie (seed 329160, set 329's pair 3, seen): its
    spin-up reaction opposes the yaw kick of each motor's speed fluctuations; named a rotor
    inertia (or, at most 0.5 confident, its look-alike the yaw torque scale). Under the
    calibration of session 19 (mismatch ratio 2.20, gain 0.0292 per sample) the pair is
    `consistent` and says that no rotor inertia within its range could be seen: honest,
    never another name."""
    names, _, data = _named("pyflyt", "rotor_inertia", 329160, tmp_path)
    unseeable = data["detectable"]["rotor_inertia"]["status"] == "insufficient"
    assert names == ["rotor_inertia"] or (
        names == ["yaw_torque_scale"] and data["effects"][0]["confidence"] <= 0.5) or (
        not names and data["verdict"] == "consistent" and unseeable), data["summary"]


@SEEN_PAIR_MISSED(reason="named a 5 ms delay (a hint, below the detectable size) with an "
                         "inertia ×0.747")
def test_a_thrust_scale_and_delay_without_the_pack_voltage_are_both_named(
        tmp_path: Path) -> None:
    """Thrust ×1.19 and a 12.5 ms delay on the Crazyflie (seed 313180, set 313's pair 5,
    seen), both logs without their pack voltage (the command-only speed law): an 8 Hz fit
    named the thrust scale with an inertia ×0.60, the loop's answer to its noise read as a
    law. Named the thrust scale (within 5 %) and the delay."""
    from etsid.gap.run import analyse

    sim, real = (t.drop(columns=["vbat"]) for t in _logged_pair(
        "pyflyt", "thrust_scale+time_delay", 313180, tmp_path))
    data = analyse(sim, real, "sim", "real").data
    names = [e["name"] for e in data["effects"] if e["name"] != "unexplained"]
    params = {k: v["value"] for k, v in data["effects"][0]["parameters"].items()}
    assert "pack voltage not in the law" in data["nominal"]["speed_law"]
    assert names == ["thrust_scale", "time_delay"], data["summary"]
    assert params["scale"] == pytest.approx(1.186, rel=0.05), params


def test_a_crazyflie_ground_effect_is_named_once_the_pack_voltage_is_in_the_law() -> None:
    """PyFlyt's Crazyflie hovering at 4-9 cm with a ground effect (seed 340090, set 340's
    pair 1, named a thrust scale through step 20): its motors slow as the pack drains, and
    SIM's command-only law had absorbed that drift into its thrust curve, leaving REAL a
    constant offset no height law could take. With the voltage in the rotor-speed law
    (step 21, chosen on SIM's own data), the residual follows height and the ground effect
    is named."""
    data = _gap_on_pair("ground_effect", 340090)
    names = [e["name"] for e in data["effects"] if e["name"] != "unexplained"]
    assert "× V /" in data["nominal"]["speed_law"], data["nominal"]
    assert names == ["ground_effect"], data["summary"]


def test_its_look_alike_a_crazyflie_on_a_sagging_pack_keeps_the_command_law(
        tmp_path: Path) -> None:
    """A sagging, half-charged pack (seed 339080, set 339's pair 17): REAL flies at voltages
    SIM never reached, so SIM's voltage law (whose idle offset only SIM's own span fixes)
    is not extrapolated; the command-only law stays and the sag is named from the thrust
    that follows the voltage."""
    names, _, data = _named("pyflyt", "battery_sag", 339080, tmp_path)
    assert "pack voltage not in the law" in data["nominal"]["speed_law"], data["nominal"]
    assert any("never reached" in n for n in data["notes"]), data["notes"]
    assert names == ["battery_sag"], data["summary"]


def test_a_ground_effect_in_a_narrow_band_of_heights_is_told_from_a_thrust_scale() -> None:
    """A Crazyflie ground effect held out at 5-7 cm (seed 335090, set 335's pair 0): a
    thrust scale scores first on its one parameter fewer, but the ground-effect law explains
    more of the held-out excess and changes the thrust by more than a fifth across those
    heights: named a ground effect."""
    data = _gap_on_pair("ground_effect", 335090)
    names = [e["name"] for e in data["effects"] if e["name"] != "unexplained"]
    assert names == ["ground_effect"], data["summary"]


def test_its_look_alike_a_crazyflie_thrust_scale_is_no_ground_effect(tmp_path: Path) -> None:
    """A thrust scale hovering at about 1 m (seed 341010, the seen thrust scale whose ground-
    effect law came closest, 0.010 of the held-out excess short): stays a thrust scale.
    (Named a mass ×0.89 at 1.00 until session 12, as the pair above.)"""
    names, _, data = _named("pyflyt", "thrust_scale", 341010, tmp_path)
    assert names == ["thrust_scale"], data["summary"]
