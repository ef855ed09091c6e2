"""Train a PPO policy (stable-baselines3) on ``iw_zenoh/ChairNav-v0`` and evaluate it.

    pip install -e '.[learn,examples]'
    python docs/examples/ppo_chairnav.py train --steps 1000000 --envs 64 --out ppo_chairnav.zip
    python docs/examples/ppo_chairnav.py evaluate --model ppo_chairnav.zip --episodes 100
    python docs/examples/ppo_chairnav.py evaluate --random --episodes 20    # the baseline

``train`` prints the wall time it took and, every ``--every`` steps, the success rate on a fixed
set of evaluation episodes (seeds 1,000,000 on, never seen in training: ChairNav draws the room,
start and goal from the seed). ``evaluate`` prints one JSON object: success rate, collision
rate, time-outs, mean steps of the successes. The same trained policy runs as a chair's agent
on the real, distributed system with ``iwz agent policy`` (see ``ppo_policy.py`` beside this file
and ``docs/learning.md``).

The observation is scaled by :data:`SCALE` (each part by its bound, at most 10) before the
network sees it; :class:`Scaled` does it in training and :func:`scaled_policy` in evaluation and
in the agent, so a policy needs no statistics kept beside it.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import iw_zenoh.learn  # registers iw_zenoh/ChairNav-v0

EVAL_SEED = 1_000_000  # evaluation episodes' seeds start here (training draws its own)
ENV_ID = "iw_zenoh/ChairNav-v0"

Policy = Callable[[np.ndarray], np.ndarray]


def _scale() -> np.ndarray:
    box = iw_zenoh.learn.ChairNavEnv().observation_space
    assert isinstance(box, gym.spaces.Box)
    return np.asarray(np.clip(box.high, 1.0, 10.0), dtype=np.float32)


SCALE = _scale()


class Scaled(gym.ObservationWrapper[np.ndarray, np.ndarray, np.ndarray]):
    """ChairNav's observation divided by :data:`SCALE` (roughly within [-1, 1])."""

    def __init__(self, env: gym.Env[np.ndarray, np.ndarray]) -> None:
        super().__init__(env)
        box = env.observation_space
        assert isinstance(box, gym.spaces.Box)
        self.observation_space = gym.spaces.Box(box.low / SCALE, box.high / SCALE, dtype=np.float32)

    def observation(self, observation: np.ndarray) -> np.ndarray:
        """The scaled observation."""
        return np.asarray(observation / SCALE, dtype=np.float32)


def scaled_policy(model: Any) -> Policy:
    """A trained model (anything with SB3's ``predict``) as a function of ChairNav's raw observation."""

    def act(obs: np.ndarray) -> np.ndarray:
        action, _ = model.predict(np.asarray(obs, dtype=np.float32) / SCALE, deterministic=True)
        return np.asarray(action, dtype=np.float32)

    return act


def random_policy(seed: int = 0) -> Policy:
    """Uniform random actions (the baseline a trained policy must beat)."""
    g = np.random.default_rng(seed)
    return lambda obs: g.uniform(-1.0, 1.0, 2).astype(np.float32)


@dataclass
class Evaluation:
    """How a policy did on ``episodes`` ChairNav episodes."""

    episodes: int
    success_rate: float  # reached the goal
    collision_rate: float
    timeout_rate: float  # truncated: neither in time
    mean_steps_to_goal: float  # of the successes (0 with none)
    wall_s: float


def evaluate(policy: Policy, episodes: int = 100, *, seed: int = EVAL_SEED, **env_kwargs: Any) -> Evaluation:
    """Runs ``policy`` on ``episodes`` ChairNav episodes of seeds ``seed``, ``seed + 1``...

    Args:
        policy: ChairNav's (raw) observation -> action in ``[-1, 1]^2``.
        episodes: How many.
        seed: The first episode's seed (each episode's room, start and goal come from its seed).
        env_kwargs: ChairNav's keywords (``action``, ``max_steps``, ``maps``...).
    """
    env = gym.make(ENV_ID, disable_env_checker=True, **env_kwargs)
    reached = collided = timeouts = 0
    steps_to_goal: list[int] = []
    t0 = time.perf_counter()
    for k in range(episodes):
        obs, _ = env.reset(seed=seed + k)
        for n in range(1, 10**9):  # noqa: B007 (n: the episode's length, read after)
            obs, _, terminated, truncated, info = env.step(policy(obs))
            if terminated or truncated:
                break
        if info["reached"]:
            reached += 1
            steps_to_goal.append(n)
        elif info["collided"]:
            collided += 1
        else:
            timeouts += 1
    env.close()
    return Evaluation(
        episodes,
        reached / episodes,
        collided / episodes,
        timeouts / episodes,
        float(np.mean(steps_to_goal)) if steps_to_goal else 0.0,
        time.perf_counter() - t0,
    )


def batched(num_envs: int, seed: int) -> Any:
    """``iw_zenoh.learn.vector_env(num_envs)`` (every chair in one world, stepped in one call) as
    an SB3 ``VecEnv``, observations scaled by :data:`SCALE`.

    SB3 expects a sub-environment that ends to start again in the same step; the vector env starts
    it at its next step (Gymnasium's ``NEXT_STEP``). So the step that ends one reports its last
    observation as ``terminal_observation`` and again as the next one, and the step after (the new
    start: reward 0, its action not applied) is one transition of no consequence at the head of
    each episode.
    """
    from stable_baselines3.common.vec_env import VecEnv  # noqa: PLC0415 (the examples extra)

    class Batched(VecEnv):  # type: ignore[misc,unused-ignore]  # Any without the examples extra
        def __init__(self) -> None:
            self.venv = iw_zenoh.learn.vector_env(num_envs)
            box = self.venv.single_observation_space
            assert isinstance(box, gym.spaces.Box)
            space = gym.spaces.Box(box.low / SCALE, box.high / SCALE, dtype=np.float32)
            super().__init__(num_envs, space, self.venv.single_action_space)
            self._seed, self._actions = seed, np.zeros((num_envs, 2), dtype=np.float32)

        def reset(self) -> np.ndarray:
            obs, _ = self.venv.reset(seed=self._seed)
            return np.asarray(obs / SCALE, dtype=np.float32)

        def step_async(self, actions: np.ndarray) -> None:
            self._actions = actions

        def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict[str, Any]]]:
            obs, reward, term, trunc, _ = self.venv.step(self._actions)
            obs = np.asarray(obs / SCALE, dtype=np.float32)
            done = term | trunc
            infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
            for i in np.flatnonzero(done).tolist():
                infos[i] = {"terminal_observation": obs[i], "TimeLimit.truncated": bool(trunc[i] and not term[i])}
            return obs, reward.astype(np.float32), done, infos

        def close(self) -> None:
            self.venv.close()

        def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
            return [getattr(self.venv, attr_name)] * self.num_envs

        def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
            setattr(self.venv, attr_name, value)

        def env_method(self, method_name: str, *args: Any, indices: Any = None, **kwargs: Any) -> list[Any]:
            return [getattr(self.venv, method_name)(*args, **kwargs)]

        def env_is_wrapped(self, wrapper_class: Any, indices: Any = None) -> list[bool]:
            return [False] * self.num_envs

    return Batched()


def train(
    steps: int, envs: int, seed: int, out: Path, every: int, eval_episodes: int, minutes: float = 0.0
) -> dict[str, Any]:
    """Trains PPO for ``steps`` environment steps (or ``minutes`` of wall time, if sooner) on
    ``envs`` chairs of the vector environment; saves it to ``out``; returns the figures (steps
    done, wall time, and every ``every`` steps the evaluation's figures, ``eval_*``: ``elapsed_s``
    counts the evaluations' own time too)."""
    import torch  # noqa: PLC0415 (the examples extra)
    from stable_baselines3 import PPO  # noqa: PLC0415
    from stable_baselines3.common.callbacks import BaseCallback  # noqa: PLC0415

    torch.set_num_threads(1)  # small networks: more threads cost more than they give
    curve: list[dict[str, Any]] = []
    t0 = time.perf_counter()

    class Progress(BaseCallback):  # type: ignore[misc,unused-ignore]  # Any without the examples extra
        def _on_step(self) -> bool:
            if self.num_timesteps // every > len(curve):
                e = evaluate(scaled_policy(self.model), eval_episodes)
                row = {"steps": self.num_timesteps, "elapsed_s": round(time.perf_counter() - t0, 1)}
                row |= {f"eval_{k}": v for k, v in asdict(e).items()}  # eval_wall_s: the evaluation's own
                curve.append(row)
                print(json.dumps(row), file=sys.stderr, flush=True)
            return not minutes or time.perf_counter() - t0 < 60.0 * minutes

    model = PPO(
        "MlpPolicy", batched(envs, seed), n_steps=128, batch_size=1024, n_epochs=4, gamma=0.99, seed=seed, verbose=0
    )
    model.learn(total_timesteps=steps, callback=Progress())
    wall = time.perf_counter() - t0
    model.save(out)
    done = int(model.num_timesteps)
    return {"steps": done, "envs": envs, "seed": seed, "train_wall_s": round(wall, 1), "curve": curve}


def main(argv: list[str] | None = None) -> int:
    """The command line (see the module doc)."""
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    t = sub.add_parser("train", help="train PPO and save it")
    t.add_argument("--steps", type=int, default=1_000_000, help="environment steps (default 1000000)")
    t.add_argument("--envs", type=int, default=64, help="chairs of the vector env stepped together (default 64)")
    t.add_argument("--seed", type=int, default=1)
    t.add_argument("--minutes", type=float, default=0.0, help="stop after this wall time (default: no limit)")
    t.add_argument("--out", type=Path, default=Path("ppo_chairnav.zip"), help="where the model goes")
    t.add_argument("--every", type=int, default=200_000, help="evaluate every this many steps (default 200000)")
    t.add_argument("--eval-episodes", type=int, default=30, help="episodes per evaluation (default 30)")
    e = sub.add_parser("evaluate", help="success rate of a saved model (or of random actions)")
    e.add_argument("--model", type=Path, help="a model saved by train")
    e.add_argument("--random", action="store_true", help="random actions instead (the baseline)")
    e.add_argument("--episodes", type=int, default=100)
    e.add_argument("--seed", type=int, default=EVAL_SEED, help=f"first episode's seed (default {EVAL_SEED})")
    args = p.parse_args(argv)
    if args.cmd == "train":
        figures = train(args.steps, args.envs, args.seed, args.out, args.every, args.eval_episodes, args.minutes)
        print(json.dumps(figures))
        return 0
    if args.random == (args.model is not None):
        p.error("evaluate takes --model FILE or --random")
    if args.random:
        policy = random_policy()
    else:
        from stable_baselines3 import PPO  # noqa: PLC0415 (the examples extra)

        policy = scaled_policy(PPO.load(args.model, device="cpu"))
    print(json.dumps(asdict(evaluate(policy, args.episodes, seed=args.seed))))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
