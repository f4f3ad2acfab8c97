"""Shipped ROS message definitions (``PACKAGE__Type.msg``) for bags that lack them.

mavros_msgs and px4_msgs types that :mod:`etsid.ingest.ros.messages` converts and
:mod:`etsid.sim.writers` writes. The readers register them with rosbags' type system only
when a bag carries no definition of its own (see :func:`etsid.rosmsgs.typestore`).
"""
