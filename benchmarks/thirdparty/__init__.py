"""Concealed-effect flight pairs flown in third-party multirotor simulators.

One module per simulator (:mod:`.pyflyt_pairs`: PyFlyt on PyBullet, a Crazyflie-size
quadrotor; :mod:`.multirotor_pairs`: the ``multirotor`` package, a Tarot T18 octocopter),
and :mod:`.common` for what they share: the effect labels and their expected names, the
sensor model applied to a simulator's true state, and the conversion to a FlightTable.
Used by ``benchmarks/gap_thirdparty.py``; the labels never reach the analysis.
"""
