"""ROS 2 bags as a source of observations, read and written with ``rosbags`` (no ROS install).

Layer 6, beside ``sim``: a bag is a source of :class:`~code_as_monitor.core.observation.Observation`
exactly as the simulator is. ``reader.BagSource`` reads any RGB-D bag (``sensor_msgs/Image`` rgb8 /
bgr8 colour, 16UC1 millimetre or 32FC1 metre depth, ``CameraInfo``, ``tf2_msgs/TFMessage`` incl.
``/tf_static``, ``JointState``), synchronised by header stamps; ``writer.BagWriter`` writes one
(what ``cam record`` uses). Topic names come from a ``topics.TopicMap``. Needs the ``ros`` extra.
"""
