"""ROS 2 on our Zenoh bus, the way rmw_zenoh (ROS 2 Jazzy) writes it: type names, hashes and CDR
payloads (``types``), our state and readings as ROS 2 messages (``convert``), and the graph's
tokens, QoS strings and attachments (``graph``). Pure: no bus; ``iw_zenoh/nodes/ros2.py`` puts them
on keys built by ``iw_zenoh/keys.py`` (docs/ros2.md)."""
