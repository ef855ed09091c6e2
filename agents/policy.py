"""``iwz agent policy``: a chair driven by a learned policy (``--policy MODULE:NAME``), from the
very observation the learning environments give (docs/learning.md), towards ``--goal``.

Its chair is ChairNav-v0's (the LIACC prototype with a 64-beam, 270-degree laser of 10 m) unless
``--spec`` says otherwise: the observation's layout follows the chair, so give it the chair the
policy was trained with. Needs the ``learn`` extra.
"""

from __future__ import annotations

import argparse
from dataclasses import replace

from iw_zenoh.agent.places import point_arg, pose_arg
from iw_zenoh.learn.chairnav import default_chair
from iw_zenoh.learn.nav import ACTIONS, Goal
from iw_zenoh.learn.policy import PolicyAgent, load_policy
from iw_zenoh.scenario.specfile import spec_with_args

__all__ = ["add_arguments", "make"]


def add_arguments(p: argparse.ArgumentParser) -> None:
    """Options of ``iwz agent policy``."""
    p.add_argument(
        "--policy",
        required=True,
        metavar="MODULE:NAME",
        help="the policy: a function obs -> action in [-1, 1]^2, or a model with predict() (Stable-Baselines3), "
        "e.g. my_pkg.policies:greedy or ./ppo_policy.py:model",
    )
    p.add_argument("--goal", required=True, type=point_arg, metavar="X,Y", help="where the chair goes, m")
    p.add_argument("--within", type=float, default=0.5, help="the goal's radius, m (default 0.5)")
    p.add_argument("--action", choices=ACTIONS, default="vw", help="the policy's action, as trained (default vw)")
    p.add_argument("--robot-name", default="learner", help="robot name (default learner)")
    p.add_argument("--id", type=int, default=0, help="robot id to ask for (default: first free grid slot)")
    p.add_argument("--start", type=pose_arg, help="start pose x,y,dir_deg (default: the grid position of its id)")


def make(args: argparse.Namespace) -> list[PolicyAgent]:
    """The agent the arguments ask for."""
    spec = replace(default_chair(), name=args.robot_name, id=args.id)
    if args.start is not None:
        x, y, d = args.start
        spec = replace(spec, x_m=x, y_m=y, dir_deg=d)
    goal = Goal(args.goal[0], args.goal[1], args.within)
    return [PolicyAgent(spec_with_args(spec, args), load_policy(args.policy), goal, action=args.action)]
