"""Scenario files the tests share."""

from __future__ import annotations

SCENARIO = """
name = "judged"
[world]
map = "lab.xml"
mode = "lockstep"
[[agents]]
program = "waypoint"
args = ["--id", "1", "--waypoints", "9,5"]
[[criteria.reach]]
robot = 1
x_m = 9.0
y_m = 5.0
within_m = 0.5
"""
