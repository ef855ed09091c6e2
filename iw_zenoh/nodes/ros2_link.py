"""The ROS 2 side of ``iwz ros2``: its nodes, publishers and subscriptions declared on the Zenoh
session the way rmw_zenoh (Jazzy) declares them, so ``ros2 node list`` and ``ros2 topic list``
see them and ROS 2 nodes read and write them with no bridge.

A publisher puts CDR payloads on its topic key with rmw_zenoh's attachment (a sequence number,
the wall time, its GID); a subscription hands every sample (payload and attachment, if any) to a
callback. Each declares its liveliness token (``@ros2_lv/...``) for the graph.
"""

from __future__ import annotations

import contextlib
import itertools
import time
from collections.abc import Callable

import zenoh

from iw_zenoh import keys
from iw_zenoh.ros2 import graph
from iw_zenoh.ros2 import types as t

__all__ = ["Ros2Link", "Ros2Node", "Ros2Publisher"]

Sample = tuple[bytes, bytes | None]  # a ROS 2 sample: its CDR payload and its attachment (None: none)


class Ros2Publisher:
    """One ROS 2 publisher: a Zenoh publisher on the topic's key and its token."""

    def __init__(self, session: zenoh.Session, key: str, token: str) -> None:
        self.key = key
        self.token = token
        self.gid = graph.gid_of(token)
        self.seq = 0
        self._pub = session.declare_publisher(key)
        self._token = session.liveliness().declare_token(token)

    def put(self, payload: bytes) -> None:
        """Publishes one CDR payload with rmw_zenoh's attachment."""
        self.seq += 1
        self._pub.put(payload, attachment=graph.Attachment(self.seq, time.time_ns(), self.gid).encode())

    def undeclare(self) -> None:
        """Undeclares the publisher and its liveliness token (the topic leaves the ROS 2 graph)."""
        self._pub.undeclare()  # type: ignore[no-untyped-call]
        self._token.undeclare()  # type: ignore[no-untyped-call]


class Ros2Node:
    """A ROS 2 node of this process: its token, and the publishers and subscriptions it declares.

    Args:
        link: The process's ROS 2 link.
        namespace: The node's namespace (``/robot1``; ``/`` the root).
        name: The node's name.
    """

    def __init__(self, link: Ros2Link, namespace: str, name: str) -> None:
        self.link = link
        self.namespace = namespace or "/"
        self.name = name
        self.id = link.next_id()
        self.token = keys.ros2_token(link.domain, graph.node_parts(link.zid, self.id, self.namespace, name))
        self._handles: list[object] = [link.session.liveliness().declare_token(self.token)]
        self.publishers: list[Ros2Publisher] = []

    def _parts(self, kind: str, topic: str, type_name: str, qos: graph.Qos) -> tuple[str, str]:
        """(data key, token) of an entity of this node on ``topic``."""
        dds, rihs = t.dds_name(type_name), t.type_hash(type_name)
        key = keys.ros2_topic(self.link.domain, topic, dds, rihs)
        parts = graph.entity_parts(
            self.link.zid, self.id, self.link.next_id(), kind, self.namespace, self.name, topic, dds, rihs, qos
        )
        return key, keys.ros2_token(self.link.domain, parts)

    def publisher(self, topic: str, type_name: str, qos: graph.Qos) -> Ros2Publisher:
        """Declares a publisher on ``topic`` (a fully qualified name)."""
        key, token = self._parts(graph.PUBLISHER, topic, type_name, qos)
        pub = Ros2Publisher(self.link.session, key, token)
        self.publishers.append(pub)
        return pub

    def subscription(self, topic: str, type_name: str, qos: graph.Qos, on_sample: Callable[[Sample], None]) -> str:
        """Declares a subscription on ``topic``; ``on_sample`` gets each sample on Zenoh's thread.
        Returns the data key."""
        key, token = self._parts(graph.SUBSCRIPTION, topic, type_name, qos)

        def deliver(sample: zenoh.Sample) -> None:
            att = sample.attachment
            on_sample((sample.payload.to_bytes(), att.to_bytes() if att is not None else None))

        self._handles.append(self.link.session.declare_subscriber(key, deliver))
        self._handles.append(self.link.session.liveliness().declare_token(token))
        return key

    def undeclare(self) -> None:
        """Undeclares the node's publishers, subscriptions and tokens, the node's own last."""
        for p in self.publishers:
            p.undeclare()
        for h in reversed(self._handles):
            h.undeclare()  # type: ignore[attr-defined]


class Ros2Link:
    """This process's place in a ROS 2 domain: its session's id and its entities' ids.

    Args:
        session: The process's Zenoh session.
        domain: ``ROS_DOMAIN_ID``.
    """

    def __init__(self, session: zenoh.Session, domain: int) -> None:
        self.session = session
        self.domain = domain
        self.zid = str(session.info.zid())
        self._ids = itertools.count()
        self.nodes: list[Ros2Node] = []

    def next_id(self) -> int:
        """A new entity id, unique in this process's session (rmw_zenoh's graph keys carry it)."""
        return next(self._ids)

    def node(self, namespace: str, name: str) -> Ros2Node:
        """A new ROS 2 node ``namespace/name`` of this session, closed with it."""
        n = Ros2Node(self, namespace, name)
        self.nodes.append(n)
        return n

    def close(self) -> None:
        """Undeclares every node, newest first (quietly when the session closed first)."""
        for n in reversed(self.nodes):
            with contextlib.suppress(zenoh.ZError):  # the session closed first
                n.undeclare()
        self.nodes.clear()
