"""The closed loop in highway-env: a torch-trained DQN planner, Discern shielding it (in-process or over zenoh),
the RSS peer, the ground-truth judge of vetoes, the evaluation and its `discern eval highway` command, the planner
interface it takes (policy.py), and the planner's trainer (`python -m discern.scenarios.highway.train`). It drives
on the scenes of adapters/highway and consumes the monitor: nothing upstream imports it.

Needs the `planner` extra (torch, gymnasium, highway-env, ...): the monitor itself never imports it.
"""
