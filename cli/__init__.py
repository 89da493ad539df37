"""jackson: firmware-plus-host stack for low-cost differential-drive robots.

The import packages map onto the repository's folders: ``jackson.protocol`` is
``protocol/``, ``jackson.host`` is ``host/``, ``jackson.sim`` is ``sim/``,
``jackson.calibration`` is ``calibration/``, ``jackson.experiments`` is ``experiments/``,
``jackson.bench`` is ``bench/`` (the benchmarks); this package (``cli/``) holds the ``jackson``
command and, in ``jackson.commands``, its own subcommands.
"""

__version__ = "0.1.0"
