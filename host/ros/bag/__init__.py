"""rosbag2 recording of a run in MCAP storage, without a ROS installation.

:class:`BagRecorder` writes the topics the ROS 2 bridge publishes (Appendix C) into a rosbag2
folder that ``ros2 bag play``, Foxglove and :func:`read_bag` open:

======================  =======================================  =============================
topic                   type                                     content
======================  =======================================  =============================
``/wheel/odom``         ``nav_msgs/msg/Odometry``                dead-reckoned pose, v, w
``/imu/data``           ``sensor_msgs/msg/Imu``                  gyro and accelerometer (SI)
``/odometry/filtered``  ``nav_msgs/msg/Odometry``                EKF estimate (30 Hz)
``/joint_states``       ``sensor_msgs/msg/JointState``           wheel angles and speeds
``/diagnostics``        ``diagnostic_msgs/msg/DiagnosticArray``  link and sensor health (1 Hz)
``/tf``                 ``tf2_msgs/msg/TFMessage``               odom -> base_footprint (EKF)
``/tf_static``          ``tf2_msgs/msg/TFMessage``               the mounting transforms
``/jackson/telemetry``  ``std_msgs/msg/UInt8MultiArray``         every received frame's bytes
======================  =======================================  =============================

The raw frames use ``std_msgs/msg/UInt8MultiArray`` (empty layout, the bytes in ``data``):
ROS 2 has no plain byte-string message, and a standard type keeps the bag readable by any
tool without a custom message package; the frame format itself is the protocol's
(``protocol/spec.md``).

Time. ``header.stamp`` and the bag's receive timestamp both come from the ``t_s`` the caller
passes: the MCU's unwrapped clock on the robot, the simulated clock on the twin (never the
host's wall clock, so a replayed run's bag carries the original's times). The bag
timestamp is ``round(t_s * 1e9)`` ns; it starts near zero, so tools that show absolute dates
show 1970. Within a topic the bag timestamp never decreases: a sample older than the previous
one of its topic keeps its true ``header.stamp`` but is filed at the previous timestamp.

Crash safety. The MCAP writer (the ``mcap`` library's) keeps the open chunk in memory and
writes the summary, the footer and ``metadata.yaml`` in :meth:`BagRecorder.close`; a bag
that was never closed has no ``metadata.yaml`` and its last file no summary. Three things
keep a run's bag:

* The daemon's SIGINT and SIGTERM handlers only stop its loop, and the loop's ``finally:``
  closes the recorders (the run folder's and this one): a stopped daemon leaves a complete
  bag. ``close()`` is idempotent; called from a signal handler while a message is being
  written, it waits for that write to finish; writes after ``close()`` are ignored.
* Every ``flush_interval_s`` of message time the open chunk is written out and the file
  flushed, so a process killed outright (SIGKILL) loses at most that much.
* :func:`repair_bag` turns such a folder into a complete bag holding every message of the
  chunks that reached the disk whole, read with the mcap library's stream reader (``jackson
  bag repair``; the daemon repairs earlier runs' bags when it starts).

Size. With ``max_bytes`` the bag is split as ``ros2 bag record --max-bag-size`` does: the
files ``<name>_0.mcap``, ``<name>_1.mcap``... of one folder, each finished (summary and
footer) when the next starts, one ``metadata.yaml`` listing them all with each file's span
and count. /tf_static is in the first file only.

The package, one idea a module, as rosbags' ``rosbag2``:

- :mod:`~jackson.host.ros.bag.recorder`: :class:`BagRecorder`, the run's writer (time base,
  write claims against a closing signal handler, periodic flushes);
- :mod:`~jackson.host.ros.bag.files`: the MCAP files of one folder, their compression and
  the split at ``max_bytes``;
- :mod:`~jackson.host.ros.bag.chunk_index`: the writer's chunk indexes, kept on disk;
- :mod:`~jackson.host.ros.bag.topics`: each topic's name, type, definition, hash and QoS;
- :mod:`~jackson.host.ros.bag.metadata`: ``metadata.yaml`` and what it says of each file;
- :mod:`~jackson.host.ros.bag.reader`: reading a finished bag back (messages, info);
- :mod:`~jackson.host.ros.bag.repair`: making an unfinished bag readable;
- :mod:`~jackson.host.ros.bag.errors`: :class:`BagError`.
"""

from jackson.host.ros.bag.errors import BagError
from jackson.host.ros.bag.metadata import BAG_VERSION, BagFile
from jackson.host.ros.bag.reader import BagInfo, bag_folders, bag_info, needs_repair, read_bag
from jackson.host.ros.bag.recorder import DEFAULT_FLUSH_INTERVAL_S, BagRecorder, stamp_ns
from jackson.host.ros.bag.repair import repair_bag, repair_run, whole_records
from jackson.host.ros.bag.topics import BagTopic

__all__ = [
    "BAG_VERSION",
    "DEFAULT_FLUSH_INTERVAL_S",
    "BagError",
    "BagFile",
    "BagInfo",
    "BagRecorder",
    "BagTopic",
    "bag_folders",
    "bag_info",
    "needs_repair",
    "read_bag",
    "repair_bag",
    "repair_run",
    "stamp_ns",
    "whole_records",
]
