"""ROS message types that both the ROS readers and the ROS log writers use.

One rosbags typestore per ROS generation (ROS 1 Noetic, ROS 2 Humble), extended with the
mavros_msgs and px4_msgs definitions shipped in :mod:`etsid.rosmsgs.msgdefs`. The readers
(:mod:`etsid.ingest.ros`) fall back on it for bags that carry no definitions of their own;
the writers (:mod:`etsid.sim.writers`) serialise with it. Neither side owns it, so it
lives here, below both.
"""

from __future__ import annotations

from functools import cache
from importlib import resources
from typing import Any


@cache
def shipped_types() -> dict[str, Any]:
    """rosbags type definitions parsed from ``etsid/rosmsgs/msgdefs/*.msg``."""
    from rosbags.typesys import get_types_from_msg

    types: dict[str, Any] = {}
    for entry in resources.files("etsid.rosmsgs.msgdefs").iterdir():
        if entry.name.endswith(".msg"):
            package, _, name = entry.name[:-4].partition("__")
            types.update(get_types_from_msg(entry.read_text(), f"{package}/msg/{name}"))
    return types


@cache
def typestore(ros1: bool = False) -> Any:
    """A rosbags typestore (ROS 1 Noetic or ROS 2 Humble) with the shipped types added.

    Cached and shared: callers must not register further types in it.
    """
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    store.register(shipped_types())
    return store
