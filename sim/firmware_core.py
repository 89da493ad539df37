"""The build of the firmware core as the twin's MCU (``firmware/twin/module.cpp``).

The twin's MCU is the firmware itself: ``firmware/core`` (the code the ESP32-S3 runs) compiled
with the twin as its HAL into a Python extension module, ``jackson_firmware_core``, with
pybind11. ``make setup`` builds it (``tools/build_compiled.py``) into
``build/compiled-firmware/<digest>/``, where ``<digest>`` is :func:`source_digest` of every
source it is made of (:func:`sources`): the core, the POSIX HAL parts it shares, the protocol's
C++ codec and the module. :func:`load` loads the build of the sources as they are now, so an
edited firmware is never simulated by a build of an older one.

``python -m jackson.sim.firmware_core`` prints the build in use.
"""

from __future__ import annotations

import hashlib
import importlib.util
import sys
import sysconfig
from pathlib import Path
from types import ModuleType

from jackson.common.errors import JacksonError

MODULE = "jackson_firmware_core"
DIGEST_HEX = 16
REPO = Path(__file__).resolve().parents[1]

_loaded: ModuleType | None = None


class McuBuildError(JacksonError, RuntimeError):
    """The compiled firmware core for the present sources is missing or does not load."""


def sources(repo: Path = REPO) -> list[Path]:
    """Every file the module is built from, in a fixed order.

    Parameters
    ----------
    repo : Path
        The checkout.

    Returns
    -------
    list of Path
        The module, the firmware core, the POSIX HAL and the protocol's C++ headers.
    """
    found = [repo / "firmware" / "twin" / "module.cpp"]
    found += sorted((repo / "firmware" / "core").glob("*.[ch]pp"))
    posix = ("advance.hpp", "posix_hal.cpp", "posix_hal.hpp")
    found += [repo / "firmware" / "posix" / name for name in posix]
    found += sorted((repo / "protocol" / "include" / "jackson" / "protocol").glob("*.hpp"))
    return found


def compile_units(repo: Path = REPO) -> list[Path]:
    """The translation units of the build (the ``.cpp`` of :func:`sources`)."""
    return [p for p in sources(repo) if p.suffix == ".cpp"]


def include_dirs(repo: Path = REPO) -> list[Path]:
    """The folders the sources include from (Eigen and pybind11 aside)."""
    return [repo / "firmware" / "core", repo / "firmware" / "posix", repo / "protocol" / "include"]


def source_digest(repo: Path = REPO) -> str:
    """A build's name: the first :data:`DIGEST_HEX` hex digits of the SHA-256 of the sources'
    paths (relative to the checkout) and bytes."""
    h = hashlib.sha256()
    for path in sources(repo):
        h.update(path.relative_to(repo).as_posix().encode() + b"\0")
        h.update(path.read_bytes() + b"\0")
    return h.hexdigest()[:DIGEST_HEX]


def builds_dir(repo: Path = REPO) -> Path:
    """``build/compiled-firmware`` of the checkout."""
    return repo / "build" / "compiled-firmware"


def build_path(builds: Path, digest: str) -> Path:
    """``<builds>/<digest>/jackson_firmware_core<EXT_SUFFIX>``."""
    return builds / digest / f"{MODULE}{sysconfig.get_config_var('EXT_SUFFIX')}"


def load_build(path: Path) -> ModuleType:
    """Import the module at ``path``.

    Raises
    ------
    ImportError
        It does not load.
    """
    spec = importlib.util.spec_from_file_location(MODULE, path)
    if spec is None or spec.loader is None:
        raise ImportError(f"cannot load {path}")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def load() -> ModuleType:
    """The compiled firmware core of the present sources (loaded once per process).

    Raises
    ------
    McuBuildError
        No build of these sources (one line: what to run).
    """
    global _loaded
    if _loaded is None:
        path = build_path(builds_dir(), source_digest())
        if not path.is_file():
            raise McuBuildError(
                f"the twin's MCU is the compiled firmware core and {path.relative_to(REPO)} is "
                f"missing (the firmware's sources changed or were never built): run make setup"
            )
        try:
            _loaded = load_build(path)
        except ImportError as e:
            raise McuBuildError(f"{path} does not load ({e}): run make setup again") from e
    return _loaded


def main() -> int:
    """Print the build in use, or why there is none."""
    try:
        module = load()
    except McuBuildError as e:
        print(f"jackson.sim.firmware_core: {e}", file=sys.stderr)
        return 1
    print(f"firmware core: {module.__file__}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
