"""The benchmarks of ``jackson bench`` (``make bench``): their registry, runner and output.

- :mod:`~jackson.bench.suites`: the registry, suite name -> the function that runs it;
- :mod:`~jackson.bench.runner`: runs suites and gives each figure the machine's speed;
- :mod:`~jackson.bench.report`: the table on screen and ``build/bench.json``;
- the suites that run several layers together, or the command's own processes:
  :mod:`~jackson.bench.firmware` (the firmware core, natively built),
  :mod:`~jackson.bench.lockstep` (the pty loop between ``jackson sim`` and the daemon),
  :mod:`~jackson.bench.host` (the host's frame and command work on the twin's frames),
  :mod:`~jackson.bench.daemon` (the ``jackson daemon`` process's CPU),
  :mod:`~jackson.bench.sil` (``jackson run`` as a user runs it),
  :mod:`~jackson.bench.soak` (memory over a patrol),
  :mod:`~jackson.bench.ros` (the ROS 2 bridge's latency).

The suites that measure one layer on its own sit beside its code and are registered here
(``jackson.protocol.bench``, ``jackson.sim.bench``, ``jackson.sim.bench_lidar``,
``jackson.experiments.bench``, ``jackson.experiments.bench_stage3``). This package may import
every layer; no layer imports it, and only the command line (``cli/``) does.
"""
