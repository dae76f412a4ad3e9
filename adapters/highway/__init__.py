"""Closed loop in highway-env: adapter, perception faults, DQN planner, Discern shield, evaluation.

Needs the `planner` extra (gymnasium, highway-env, torch, ...): the monitor itself never imports it.
"""
