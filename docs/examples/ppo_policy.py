"""The PPO policy that ``ppo_chairnav.py train`` saved (``ppo_chairnav.zip`` beside this file),
as ``iwz agent policy --policy ./ppo_policy.py:policy`` takes it: a function of ChairNav's raw
observation (scaled here as in training) to an action. Needs the ``examples`` extra."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

from stable_baselines3 import PPO

_here = Path(__file__).resolve().parent
_spec = importlib.util.spec_from_file_location("ppo_chairnav", _here / "ppo_chairnav.py")
assert _spec is not None
assert _spec.loader is not None
_example = importlib.util.module_from_spec(_spec)
sys.modules["ppo_chairnav"] = _example  # its dataclasses look their module up there
_spec.loader.exec_module(_example)

policy = _example.scaled_policy(PPO.load(_here / "ppo_chairnav.zip", device="cpu"))
