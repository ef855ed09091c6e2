"""Writing recordings: one MCAP channel per Zenoh key, a JSON Schema per message type, and the
derived Foxglove channels (protobuf).

Log time is the receive wall time (ns); publish time is the message's simulation time. The
payload is stored byte for byte as it was published, malformed or not: nothing is dropped.
Chunks are zstd-compressed and closed at least every ``flush_s`` seconds, so a crash loses at
most that much; :meth:`Recorder.finish` writes the indexes and a sim-time index (metadata
``iw.sim_time_index``) that replay uses to seek.
"""

from __future__ import annotations

import logging
from typing import IO

from mcap.writer import CompressionType, Writer

from iw_zenoh import __version__, keys
from iw_zenoh.messages import stamp_of
from iw_zenoh.record.channels import ChannelSpec, Derivation, key_channel

__all__ = ["PROFILE", "SIM_INDEX", "Recorder"]

logger = logging.getLogger(__name__)

PROFILE = "iw-zenoh"
SIM_INDEX = "iw.sim_time_index"  # metadata: sim time -> log time, one entry per simulated second and the last state
SIM_INDEX_STEP_NS = 1_000_000_000


class Recorder:
    """Writes deliveries to an MCAP stream.

    Args:
        stream: A binary stream opened for writing.
        metadata: Named string maps written up front (scenario, map, seed, versions...).
        chunk_size: Close a chunk past this many bytes.
    """

    def __init__(
        self,
        stream: IO[bytes],
        metadata: dict[str, dict[str, str]] | None = None,
        *,
        chunk_size: int = 4 * 1024 * 1024,
        scene: bool = True,
    ) -> None:
        # the data section CRC lets doctor find damage anywhere, metadata included
        self._w = Writer(stream, chunk_size=chunk_size, compression=CompressionType.ZSTD, enable_data_crcs=True)
        self._w.start(profile=PROFILE, library=f"iw-zenoh {__version__}")
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._seq: dict[str, int] = {}
        self.counts: dict[str, int] = {}
        self.bytes = 0
        self._sim_index: list[tuple[int, int]] = []
        self._last_state: tuple[int, int] | None = None  # (sim ns, log ns) of the last state recorded
        self._finished = False
        self._scene = Derivation() if scene else None
        base = {"iw-zenoh": __version__}
        self._w.add_metadata("iw.versions", base)
        for name, data in (metadata or {}).items():
            self._w.add_metadata(name, {k: str(v) for k, v in data.items()})

    def _register(self, spec: ChannelSpec) -> int:
        """Declares a channel (and its schema, once per schema name) in the file."""
        sid = self._schemas.get(spec.schema_name, 0) if spec.schema_name else 0
        if spec.schema_name and not sid:
            sid = self._w.register_schema(name=spec.schema_name, encoding=spec.schema_encoding, data=spec.schema)
            self._schemas[spec.schema_name] = sid
        cid = self._w.register_channel(
            topic=spec.topic, message_encoding=spec.encoding, schema_id=sid, metadata=spec.metadata
        )
        self._channels[spec.topic] = cid
        return cid

    def _channel(self, key: str) -> int:
        cid = self._channels.get(key)
        return cid if cid is not None else self._register(key_channel(key))

    def add(self, key: str, data: bytes, log_time_ns: int) -> None:
        """Records one delivery.

        Args:
            key: The Zenoh key it came on.
            data: The payload, exactly as received.
            log_time_ns: When it was received (wall clock, ns).
        """
        cid = self._channel(key)
        tick, sim_ns = stamp_of(data)
        seq = self._seq.get(key, 0)
        self._seq[key] = seq + 1
        self._w.add_message(channel_id=cid, log_time=log_time_ns, data=data, publish_time=sim_ns, sequence=seq)
        self.counts[key] = self.counts.get(key, 0) + 1
        self.bytes += len(data)
        if self._scene is not None:
            self._derive(key, data, log_time_ns, sim_ns)
        if keys.topic_kind(key) == "state":
            self._last_state = (sim_ns, log_time_ns)
            if not self._sim_index or sim_ns >= self._sim_index[-1][0] + SIM_INDEX_STEP_NS:
                self._sim_index.append((sim_ns, log_time_ns))

    def _derive(self, key: str, data: bytes, log_time_ns: int, sim_ns: int) -> None:
        """Adds the Foxglove scene messages a world message implies (never fails the recording)."""
        assert self._scene is not None
        for spec, payload in self._scene.derive(key, data):
            cid = self._channels.get(spec.topic)
            if cid is None:
                cid = self._register(spec)
            self._w.add_message(channel_id=cid, log_time=log_time_ns, data=payload, publish_time=sim_ns, sequence=0)

    def flush(self) -> None:
        """Closes the chunk in progress and writes it out (a crash then loses nothing before)."""
        self._w.flush()  # type: ignore[no-untyped-call]

    def finish(self, extra: dict[str, dict[str, str]] | None = None) -> None:
        """Writes the sim-time index, the counts and the file's indexes."""
        if self._finished:
            return
        self._finished = True
        last = self._last_state
        ends = [last] if last is not None and last[0] > self._sim_index[-1][0] else []
        self._w.add_metadata(SIM_INDEX, {str(s): str(t) for s, t in self._sim_index + ends})
        self._w.add_metadata("iw.counts", {k: str(v) for k, v in sorted(self.counts.items())})
        for name, data in (extra or {}).items():
            self._w.add_metadata(name, data)
        self._w.finish()  # type: ignore[no-untyped-call]
