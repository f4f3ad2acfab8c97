"""The source each real log's columns are filled from, pinned (rules of
etsid/ingest/mapping.py, content checks of etsid/ingest/source_check.py).

Logs in tests/data always run; the others in ../shared/data/logs run where that folder is
(CI has it), else skip. A change of any chosen source must be a decision, not an accident:
update the pin and say why in the commit."""

from __future__ import annotations

from pathlib import Path

import pytest

from etsid.ingest import read_raw
from etsid.ingest.mapping import choose_signals

DATA = Path(__file__).parents[1] / "data"
SHARED = Path(__file__).parents[2].parent / "shared" / "data" / "logs"

PX4_GYRO = {c: f"sensor_combined.gyro_rad[{i}]" for i, c in enumerate("pqr")}
PX4_RATES = {c: f"vehicle_angular_velocity.xyz[{i}]" for i, c in enumerate("pqr")}
PINS: dict[str, dict[str, str]] = {
    "ardupilot_copter33_loiter_acro_flips_real.bin": {
        **{c: f"IMU.Gyr{a}" for c, a in zip("pqr", "XYZ", strict=True)},
        "roll": "ATT.Roll", "alt": "CTUN.BarAlt", "landed": "EV.Id",
        "u_thrust": "RCIN.C3"},
    "ardupilot_copter403_hexa_loiter_real.bin": {
        **{c: f"IMU.Gyr{a}" for c, a in zip("pqr", "XYZ", strict=True)},
        "roll": "ATT.Roll", "alt": "CTUN.BAlt", "landed": "EV.Id", "vbat": "BAT.Volt",
        "u_thrust": "RCIN.C3"},
    "arduplane_truncated.BIN": {"p": "IMU.GyrX", "alt": "BARO.Alt", "vbat": "BAT.Volt"},
    "ardupilot_sitl_quadplane.tlog": {
        "p": "ATTITUDE.rollspeed", "alt": "LOCAL_POSITION_NED.z",
        "landed": "HEARTBEAT.base_mode", "ax": "SCALED_IMU2.xacc"},
    "px4_coaxocto_manual_real.ulg": {
        **PX4_GYRO, "alt": "vehicle_local_position.z",
        "landed": "vehicle_land_detected.landed", "vz": "vehicle_local_position.vz"},
    "px4_coaxocto_stabilized_real.ulg": {
        **PX4_GYRO, "alt": "vehicle_local_position.z",
        "landed": "vehicle_land_detected.landed"},
    "px4_cubeorange_real.ulg": {
        **PX4_RATES, "alt": "vehicle_local_position.dist_bottom",
        "landed": "vehicle_land_detected.landed"},
    "px4_quad_mission_lowrate_real.ulg": {
        **PX4_GYRO, "alt": "distance_sensor.current_distance",
        "landed": "vehicle_land_detected.landed"},
    "px4_sitl_tagged.ulg": {
        **PX4_RATES, "alt": "vehicle_local_position.dist_bottom",
        "vbat": "battery_status.voltage_filtered_v"},
    "px4_v6c_quad_lowhover_real.ulg": {
        **PX4_RATES, "alt": "vehicle_local_position.z", "vbat": "battery_status.voltage_v",
        "landed": "vehicle_land_detected.landed"},
    "xsens_imu_real.bag": {"p": "/imu_data.angular_velocity.x", "roll": "/imu_data.orientation"},
}


def _path(name: str) -> Path:
    for folder in (DATA, DATA / "ros", SHARED):
        if (folder / name).exists():
            return folder / name
    pytest.skip(f"{name} is not in tests/data and ../shared/data/logs is absent")


@pytest.mark.parametrize("name", sorted(PINS))
def test_chosen_sources_are_pinned(name: str) -> None:
    raw = read_raw(_path(name))
    chosen, _ = choose_signals(raw.signals, [], raw.path)
    got = {c: chosen[c].source for c in PINS[name] if c in chosen}
    assert got == PINS[name]
