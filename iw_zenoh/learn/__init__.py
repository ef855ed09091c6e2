"""Learning and evaluation on the simulator's own tick (:class:`~iw_zenoh.sim.local.LocalWorld`):
Gymnasium and PettingZoo environments (:func:`parallel_env`). Needs the ``learn`` extra
(``pip install iw-zenoh[learn]``).

Importing it registers ``iw_zenoh/ChairNav-v0`` (and ``iw_zenoh/Scenario-v0``, :func:`make_env`'s)
with Gymnasium::

    import gymnasium as gym
    import iw_zenoh.learn

    env = gym.make("iw_zenoh/ChairNav-v0", action="vw", render_mode="rgb_array")
    obs, info = env.reset(seed=1)

See docs/learning.md.
"""

from __future__ import annotations

import gymnasium as gym

from iw_zenoh.learn.chairnav import ChairNavEnv, default_chair
from iw_zenoh.learn.nav import Goal, Reward
from iw_zenoh.learn.parallel import ChairsEnv, parallel_env
from iw_zenoh.learn.scenario import DISTRIBUTED_ID, SCENARIO_ID, ScenarioEnv, make_env
from iw_zenoh.learn.vector import ChairVectorEnv, vector_env

__all__ = [
    "ChairNavEnv",
    "ChairVectorEnv",
    "ChairsEnv",
    "Goal",
    "Reward",
    "ScenarioEnv",
    "default_chair",
    "make_env",
    "parallel_env",
    "vector_env",
]

ENV_ID = "iw_zenoh/ChairNav-v0"

if ENV_ID not in gym.registry:
    gym.register(id=ENV_ID, entry_point="iw_zenoh.learn.chairnav:ChairNavEnv")
if SCENARIO_ID not in gym.registry:  # make_env's: any scenario, one robot the learner's
    gym.register(id=SCENARIO_ID, entry_point="iw_zenoh.learn.scenario:ScenarioEnv")
if DISTRIBUTED_ID not in gym.registry:  # make_env(..., distributed=True)'s: over the real system
    gym.register(id=DISTRIBUTED_ID, entry_point="iw_zenoh.learn.distributed:DistributedEnv")
