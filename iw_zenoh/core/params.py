"""Ciber-Rato simulation parameters (the ``<Parameters>`` of a reply and of a parameters file).

Defaults are the legacy simulator's built-in ones (fact sheet section 6.3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["SimParameters"]


@dataclass(frozen=True)
class SimParameters:
    """Every attribute of the legacy ``<Parameters>`` element, with its built-in default."""

    sim_time: int = 1800
    cycle_time_ms: int = 50
    key_time: int = 1350
    compass_noise: float = 2.0
    beacon_noise: float = 2.0
    obstacle_noise: float = 0.1
    motors_noise: float = 1.5
    gps: bool = False
    gps_lin_noise: float = 0.5
    gps_dir_noise: float = 5.0
    beacon_sensor: bool = False
    compass_sensor: bool = True
    score_sensor: bool = False
    show_actions: bool = True
    n_requests_per_cycle: int = 0
    obstacle_requestable: bool = False
    beacon_requestable: bool = False
    ground_requestable: bool = False
    compass_requestable: bool = False
    collision_requestable: bool = False
    obstacle_latency: int = 0
    beacon_latency: int = 0
    ground_latency: int = 0
    compass_latency: int = 0
    collision_latency: int = 0
    beacon_aperture_rad: float = math.pi
    return_time_penalty: int = 25
    arrival_time_penalty: int = 100
    collision_wall_penalty: int = 2
    collision_robot_penalty: int = 2
    target_reward: int = 100
    home_reward: int = 100
    lab_file: str | None = None
    grid_file: str | None = None
