"""The ``jackson`` command's own subcommands, one module each: its parser and what it runs.

:func:`jackson.main.build_parser` registers them beside the subcommands the layers bring
(``jackson.host.cli``, ``jackson.sim.cli``, ``jackson.calibration.cli``, ...). Each module
imports what its command needs when it runs, so ``jackson --help`` stays fast.
"""
