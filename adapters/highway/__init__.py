"""highway-env's world as Discern's scenes: ground truth read from the simulator, a perception with injectable
faults, the scene conversion and the meta-action mapping. The closed loop that drives with them is
scenarios/highway.

Needs the `planner` extra (gymnasium, highway-env, ...): the monitor itself never imports it.
"""
