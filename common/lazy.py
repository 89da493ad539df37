"""Type tests that do not import what they test for.

A process that never imported a module holds no instance of its classes, so asking whether an
object is one need not import it: a daemon driving the square does not load the navigation
stack (0.1-0.3 s of imports) to learn that its mission does not navigate.
"""

from __future__ import annotations

import sys


def instance_of(obj: object, module: str, name: str) -> bool:
    """``isinstance(obj, module.name)``, False without importing ``module`` when it is not
    imported yet.

    Parameters
    ----------
    obj : object
        The object tested.
    module : str
        The class's module, dotted (``jackson.host.control.navigate``).
    name : str
        The class's name in it.

    Returns
    -------
    bool
    """
    loaded = sys.modules.get(module)
    return loaded is not None and isinstance(obj, getattr(loaded, name))
