"""The compiled build of :mod:`jackson.sim.physics`, used only when it is current.

``make setup`` compiles ``sim/physics.py`` with mypyc (``tools/build_compiled.py``) into
``build/compiled/<digest>/jackson_sim_physics<EXT_SUFFIX>``, where ``<digest>`` is
:func:`source_digest` of the source it compiled. At import this module hashes ``physics.py`` as
it is now and loads the build of that digest if there is one: a build of any other source is
never loaded, so an edited model runs interpreted until ``make setup`` builds it again. With no
build (no C compiler, a non-editable install, a build that does not load) or with
``JACKSON_SIM_INTERPRETED=1`` in the environment the twin runs ``physics.py`` interpreted; the
results are the same bit for bit either way, only the speed differs (docs/compiled.md).

``python -m jackson.sim.compiled`` prints which one is in use.

Attributes
----------
Dynamics : type
    The :class:`~jackson.sim.physics.DiffDriveDynamics` in use: the compiled class or the
    interpreted one.
SELECTION : Selection
    Which, and why.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import sys
import sysconfig
import warnings
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import cast

from jackson.sim import physics

MODULE = "jackson_sim_physics"  # the compiled module's name: its own, beside jackson.sim.physics
DIGEST_HEX = 16  # hex digits of the SHA-256 that name a build
ENV_INTERPRETED = "JACKSON_SIM_INTERPRETED"


@dataclass(frozen=True)
class Selection:
    """Which model the twin runs.

    Attributes
    ----------
    dynamics : type
        The dynamics class in use.
    build : Path or None
        The compiled module loaded (None: the interpreted ``physics.py``).
    reason : str
        Why: one line for a person.
    """

    dynamics: type[physics.DiffDriveDynamics]
    build: Path | None
    reason: str

    @property
    def compiled(self) -> bool:
        """True when the compiled build is in use."""
        return self.build is not None


def source_path() -> Path:
    """The model's source, ``sim/physics.py`` (links of an editable install resolved).

    Returns
    -------
    Path
        Its path.
    """
    return Path(physics.__file__).resolve()


def source_digest(source: bytes) -> str:
    """The name of the build of a source: the first :data:`DIGEST_HEX` hex digits of its
    SHA-256.

    Parameters
    ----------
    source : bytes
        The source file's bytes.

    Returns
    -------
    str
        The digest.
    """
    return hashlib.sha256(source).hexdigest()[:DIGEST_HEX]


def builds_dir(source: Path) -> Path:
    """Where the builds of a source live: ``build/compiled`` of its repository.

    Parameters
    ----------
    source : Path
        ``sim/physics.py`` of a checkout.

    Returns
    -------
    Path
        The folder (it may not exist).
    """
    return source.parents[1] / "build" / "compiled"


def build_path(builds: Path, digest: str) -> Path:
    """The compiled module built from the source of ``digest`` for this interpreter.

    Parameters
    ----------
    builds : Path
        The builds' folder (:func:`builds_dir`).
    digest : str
        The source's digest (:func:`source_digest`).

    Returns
    -------
    Path
        ``<builds>/<digest>/jackson_sim_physics<EXT_SUFFIX>`` (it may not exist).
    """
    return builds / digest / (MODULE + str(sysconfig.get_config_var("EXT_SUFFIX")))


def load_build(path: Path) -> ModuleType:
    """Import a compiled module from its file, under the name :data:`MODULE`.

    Parameters
    ----------
    path : Path
        The extension module.

    Returns
    -------
    ModuleType
        The module.

    Raises
    ------
    ImportError
        It does not load (built for another interpreter, not a module of the model, ...).
    """
    spec = importlib.util.spec_from_file_location(MODULE, path)
    if spec is None or spec.loader is None:
        raise ImportError(f"{path}: not an extension module")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    if not isinstance(getattr(module, "DiffDriveDynamics", None), type):
        raise ImportError(f"{path}: has no DiffDriveDynamics")
    return module


def select(source: Path, builds: Path, environ: dict[str, str] | None = None) -> Selection:
    """Choose the model: the build of ``source``'s present digest if it loads, else the
    interpreted one.

    Parameters
    ----------
    source : Path
        ``sim/physics.py``.
    builds : Path
        The builds' folder.
    environ : dict or None
        The environment (None: ``os.environ``); ``JACKSON_SIM_INTERPRETED=1`` refuses builds.

    Returns
    -------
    Selection
        The choice and its reason.
    """
    env = os.environ if environ is None else environ
    interpreted = physics.DiffDriveDynamics
    if env.get(ENV_INTERPRETED, "") not in ("", "0"):
        return Selection(interpreted, None, f"interpreted ({ENV_INTERPRETED} is set)")
    try:
        digest = source_digest(source.read_bytes())
    except OSError as e:
        return Selection(interpreted, None, f"interpreted (cannot read the source: {e})")
    path = build_path(builds, digest)
    if not path.is_file():
        return Selection(
            interpreted, None, f"interpreted (no build of physics.py {digest}; make setup)"
        )
    loaded = sys.modules.get(MODULE)
    if loaded is not None and Path(str(loaded.__file__)).resolve() != path.resolve():
        return Selection(interpreted, None, f"interpreted ({MODULE} already loaded from elsewhere)")
    try:
        module = loaded if loaded is not None else load_build(path)
    except ImportError as e:
        warnings.warn(f"jackson.sim: compiled physics not loaded: {e}", RuntimeWarning, 2)
        return Selection(interpreted, None, f"interpreted (the build does not load: {e})")
    dynamics = cast("type[physics.DiffDriveDynamics]", module.DiffDriveDynamics)
    return Selection(dynamics, path, f"compiled ({path})")


SELECTION = select(source_path(), builds_dir(source_path()))
Dynamics = SELECTION.dynamics


def main() -> None:
    """``python -m jackson.sim.compiled``: print which model the twin runs."""
    print(f"jackson.sim.physics: {SELECTION.reason}")


if __name__ == "__main__":
    main()
