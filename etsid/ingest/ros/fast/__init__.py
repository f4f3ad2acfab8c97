"""The vectorised ROS path: whole batches of same-layout messages decoded with numpy.

======================  ===============================================================
module                  job
======================  ===============================================================
:mod:`.decode`          batch decoding of fixed-layout messages (ROS 1 and CDR);
                        the switch :data:`~.decode.ENABLED` and the :class:`~.decode.Batcher`
:mod:`.rows`            vectorised twins of the per-message row functions
:mod:`.ros1`            indexed ROS 1 bags read chunk by chunk
:mod:`.ros2`            one-file ROS 2 bags read straight from their storage
:mod:`.mcap`            complete MCAP files walked record by record
:mod:`.mcap_resync`     damaged or cut MCAP files: every record that decodes, before and
                        after the damage
======================  ===============================================================

Every function here gives the same signals, bit for bit, as the per-message path
(tested with ``ETSID_ROS_FAST=0``).
"""
