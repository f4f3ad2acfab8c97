"""Shipped ROS message definitions (``PACKAGE__Type.msg``) for bags that lack them.

mavros_msgs and px4_msgs types that :mod:`etsid.ingest.ros_messages` converts. They are
registered with rosbags' type system only when a bag carries no definition of its own.
"""
