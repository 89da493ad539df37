"""What the planner and its critics share: the configuration and the command, the velocity
window, the roll-outs, the global path's transform and the distance maps.

The critics (:mod:`jackson.host.nav.dwb.critics`) build on these, and the planner
(:mod:`jackson.host.nav.dwb.planner`) on both, so neither package imports the one above it.
"""
