"""The world's description sealed for the ``iwz run`` that started it: the launcher hands its
world a random key (in the world's environment only, never on the bus) and the world adds to
every ``WorldInfo`` it publishes or answers an HMAC-SHA256 of it under that key. The launcher
keeps a description for a restarted world only when its seal holds, so a forged one published
on ``world/info`` cannot become the restarted world's roster (it emptied the world). The key is
drawn anew by every ``iwz run``, so a description sealed in another run never holds; within the
run, the launcher adopts no description whose revision is older than the one it keeps (a genuine
one recorded off the bus and replayed before a crash would bring back an old roster), and a
resumed world's revisions go on from the description it resumed (``sim/resume.py``)."""

from __future__ import annotations

import hashlib
import hmac
import os
import secrets

import msgspec

from iw_zenoh.messages import WorldInfo, encode

__all__ = ["SEAL_ENV", "new_key", "seal", "sealed", "seal_key"]

SEAL_ENV = "IWZ_WORLD_SEAL"  # the key, hex, in the environment of the world iwz run starts


def new_key() -> str:
    """A fresh key for one run (hex, 256 bits)."""
    return secrets.token_hex(32)


def seal_key() -> bytes | None:
    """The key this process was given (a world started by ``iwz run``), or None."""
    raw = os.environ.get(SEAL_ENV, "")
    try:
        return bytes.fromhex(raw) if raw else None
    except ValueError:
        return None


def _mac(info: WorldInfo, key: bytes) -> str:
    bare = msgspec.structs.replace(info, seal=msgspec.UNSET)
    return hmac.new(key, encode(bare), hashlib.sha256).hexdigest()


def seal(info: WorldInfo, key: bytes | None) -> WorldInfo:
    """``info`` with its seal under ``key`` (unchanged without a key)."""
    return info if key is None else msgspec.structs.replace(info, seal=_mac(info, key))


def sealed(info: WorldInfo, key: bytes) -> bool:
    """Whether ``info`` carries the seal of ``key``."""
    return isinstance(info.seal, str) and hmac.compare_digest(info.seal, _mac(info, key))
