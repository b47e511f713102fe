"""Hosts of the runtime other than ROS: the same runtimes driven from another simulator's loop.

A host does what a node does — parameters in, the runtime, its output out —
for a simulator that owns the clock and the spacecraft (:mod:`pmv_ros.hosts.basilisk`).
The ROS 2 host is :mod:`pmv_ros.nodes` (its module paths are names users
depend on: console scripts, launch files). Hosts and nodes stand side by
side: neither imports the other, and only a host imports its simulator.
"""
