"""The nominal model's rotor-speed law: whether rotor speed scales with the pack voltage,
chosen on the simulation's own held-out samples (:func:`etsid.gap.nominal.speed_law`), and
used only where REAL flies at voltages SIM reached (:func:`voltage_covered`).

Synthetic hover flights with a known law: the answers are the laws they were made with.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import butter, filtfilt

from etsid.gap.nominal import MIN_VOLTAGE_COVER, speed_law, voltage_covered
from etsid.gap.signals import Flight

FS = 100.0
"""Hz."""
N = 6000
G = 9.80665
"""m/s²."""


def _hover(rng: np.random.Generator, volts: np.ndarray, k: float, scales_with_voltage: bool,
           v_nominal: float = 4.0) -> Flight:
    """A four-rotor hover with climbs and descents: each rotor's thrust is
    ``c ((m + k) V / v_nominal)²`` (or ``c (m + k)²`` for an ESC that compensates the
    voltage), the command ``m`` is whatever holds the wandering vertical acceleration, and
    ``az`` carries 0.15 m/s² of accelerometer noise."""
    b, a = butter(2, 0.5 / (FS / 2))
    climb = filtfilt(b, a, rng.standard_normal(N + 400))[200:-200]
    climb = 1.5 * climb / np.max(np.abs(climb))  # vertical acceleration, m/s²
    thrust = G + climb  # specific force the rotors make, m/s²
    c = G / (4 * 0.4**2)  # hover at m + k = 0.4 (at v_nominal)
    gain = volts / v_nominal if scales_with_voltage else np.ones(N)
    m = np.sqrt(thrust / (4 * c)) / gain - k
    motors = np.repeat(m[:, None], 4, axis=1)
    acc = np.zeros((N, 3))
    acc[:, 2] = -thrust + 0.15 * rng.standard_normal(N)
    return Flight(name="synthetic", t=np.arange(N) / FS, fs=FS, motors=motors, inputs="motors",
                  rates=np.zeros((N, 3)), acc=acc, att=np.full((N, 3), np.nan),
                  v_body=np.zeros((N, 3)), alt=np.full(N, 1.0),
                  vbat=volts + 0.005 * rng.standard_normal(N), airborne=np.ones(N, dtype=bool),
                  have={"alt", "vbat"})


def _draining(top: float = 4.05, bottom: float = 3.85) -> np.ndarray:
    """A pack falling linearly from ``top`` to ``bottom`` V over the flight."""
    return np.linspace(top, bottom, N)


def test_a_pack_whose_drain_slows_the_rotors_gives_the_voltage_scaled_law() -> None:
    """An ESC that sets a duty cycle (rotor speed ∝ command × voltage, no idle offset) on a
    pack draining 5 %: the voltage-scaled law, its idle offset near the truth."""
    flight = _hover(np.random.default_rng(1), _draining(), k=0.0, scales_with_voltage=True)
    k, v_ref = speed_law(flight, flight.airborne, None, tau=0.01, delay=0.0)
    assert v_ref == pytest.approx(3.95, abs=0.02)
    assert k == pytest.approx(0.0, abs=0.03)


def test_its_look_alike_a_compensating_esc_on_the_same_pack_keeps_the_command_law() -> None:
    """The same drain under an ESC (or autopilot) that compensates the voltage: thrust
    follows the command alone, and the voltage law predicts SIM's later samples no better."""
    flight = _hover(np.random.default_rng(2), _draining(), k=0.1, scales_with_voltage=False)
    assert speed_law(flight, flight.airborne, None, tau=0.01, delay=0.0)[1] is None


def test_a_pack_that_does_not_drain_cannot_show_a_voltage_law() -> None:
    """A constant 4 V (SIM without a battery model): nothing to choose from."""
    flight = _hover(np.random.default_rng(3), np.full(N, 4.0), k=0.0, scales_with_voltage=True)
    assert speed_law(flight, flight.airborne, None, tau=0.01, delay=0.0) == (0.1, None)


def test_a_real_flight_on_a_pack_sim_never_flew_is_not_covered() -> None:
    """REAL on a pack 8 % lower than any voltage SIM reached: the law would extrapolate;
    REAL on the same pack: covered."""
    rng = np.random.default_rng(4)
    sim = _hover(rng, _draining(), k=0.0, scales_with_voltage=True)
    low = _hover(rng, _draining(3.72, 3.55), k=0.0, scales_with_voltage=True)
    same = _hover(rng, _draining(4.04, 3.86), k=0.0, scales_with_voltage=True)
    assert voltage_covered(sim, low) < MIN_VOLTAGE_COVER
    assert voltage_covered(sim, same) > 0.9
