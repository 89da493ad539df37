"""The topics of a run's bag: name, type, message definition, type hash and offered QoS
(Appendix C), as ``metadata.yaml`` and the MCAP channels carry them."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import yaml
from rosbags.interfaces import (
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.rosbag2.metadata import dump_qos_v9
from rosbags.typesys.store import Typestore

from jackson.host.ros.msgtypes import typestore
from jackson.host.ros.settings import TOPIC_TYPES, RosSettings


@dataclass(frozen=True)
class TopicSpec:
    """A topic's type and offered QoS (reliability, durability, depth)."""

    msgtype: str
    reliability: QosReliability
    durability: QosDurability
    depth: int


def topic_specs(settings: RosSettings) -> dict[str, tuple[str, TopicSpec]]:
    """Name, type and offered QoS (Appendix C) of each topic by its key, in registration order
    (every topic the live node publishes or receives, and the raw frames)."""
    rel, be = QosReliability.RELIABLE, QosReliability.BEST_EFFORT
    vol, latched = QosDurability.VOLATILE, QosDurability.TRANSIENT_LOCAL
    kinds = {"reliable": (rel, vol), "sensor": (be, vol), "latched": (rel, latched)}
    kinds["map"] = kinds["latched"]
    out = {}
    for key, (_, kind, depth) in TOPIC_TYPES.items():
        reliability, durability = kinds[kind]
        out[key] = (
            settings.topic(key),
            TopicSpec(settings.topic_type(key), reliability, durability, depth),
        )
    return out


def _qos(spec: TopicSpec) -> Qos:
    never = QosTime(0, 0)
    return Qos(
        QosHistory.KEEP_LAST,
        spec.depth,
        spec.reliability,
        spec.durability,
        never,
        never,
        QosLiveliness.AUTOMATIC,
        never,
        False,
    )


@dataclass(frozen=True)
class BagTopic:
    """A topic as ``metadata.yaml`` and the MCAP channel describe it.

    Attributes
    ----------
    name : str
        Topic name.
    msgtype : str
        ROS 2 message type, e.g. ``nav_msgs/msg/Odometry``.
    qos : str
        The offered QoS profiles as the channel's YAML text.
    type_hash : str
        RIHS01 hash of the type ('' if unknown).
    msgdef : str
        The ``ros2msg`` definition of the type.
    """

    name: str
    msgtype: str
    qos: str
    type_hash: str
    msgdef: str = ""

    def channel_metadata(self) -> dict[str, str]:
        """The MCAP channel metadata rosbag2 writes."""
        return {"offered_qos_profiles": self.qos, "topic_type_hash": self.type_hash}


def _qos_text(qos: Sequence[Qos]) -> str:
    return str(yaml.safe_dump(dump_qos_v9(list(qos)), default_flow_style=False)).strip()


_TYPE_INFO: dict[str, tuple[str, str]] = {}  # msgtype -> (msgdef, RIHS01 hash), Jazzy's


def _type_info(msgtype: str, store: Typestore) -> tuple[str, str]:
    """The message definition and type hash of ``msgtype`` (computed once per process: a bag
    registers every topic when it opens, and each takes milliseconds)."""
    info = _TYPE_INFO.get(msgtype)
    if info is None:
        msgdef, _ = store.generate_msgdef(msgtype, ros_version=2)
        info = _TYPE_INFO[msgtype] = (msgdef, store.hash_rihs01(msgtype))
    return info


_QOS_TEXTS: dict[TopicSpec, str] = {}  # a topic's offered QoS -> its text
_JAZZY: list[Typestore] = []  # the process's one type store


def jazzy_store() -> Typestore:
    """Jazzy's types the daemon writes (:mod:`jackson.host.ros.msgtypes`), one store per
    process: rosbags builds a type's serializer once per store (7 ms for /map's), and a
    long-running daemon opens a bag at each split of its run folders (docs/recording.md)."""
    if not _JAZZY:
        from jackson.host.ros.cdr import ENCODERS

        store = typestore()
        # the serializers of the types rosbags packs (/map, /diagnostics, /plan's poses...)
        # built now, before the frame loop, not at their first message (a 10-40 ms frame)
        for msgtype, _, _ in TOPIC_TYPES.values():
            if msgtype not in ENCODERS:
                store.get_msgdef(msgtype)
        _JAZZY.append(store)
    return _JAZZY[0]


def bag_topics(specs: Mapping[str, TopicSpec], store: Typestore) -> list[BagTopic]:
    """The bag's topics from their specs by name, with Jazzy's definitions and hashes."""
    out = []
    for name, spec in specs.items():
        msgdef, type_hash = _type_info(spec.msgtype, store)
        # the QoS text once per process too: yaml takes 2 ms a topic, and a long-running
        # daemon opens a bag at each split of its run folders (docs/recording.md)
        qos = _QOS_TEXTS.get(spec)
        if qos is None:
            qos = _QOS_TEXTS[spec] = _qos_text([_qos(spec)])
        out.append(BagTopic(name, spec.msgtype, qos, type_hash, msgdef))
    return out
