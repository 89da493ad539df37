"""Compile the twin's per-step model, ``sim/physics.py``, with mypyc, the costmap's collision
tests, ``host/nav/native/collide.cpp`` (:func:`build_nav`), and the RPLIDAR's capsule decoding,
``protocol/native/capsules.cpp`` (:func:`build_protocol`), with the C++ compiler, and the
firmware core as the twin's MCU (:func:`build_firmware`) with pybind11 (run by ``make setup``).

The build is ``build/compiled/<digest>/jackson_sim_physics<EXT_SUFFIX>``, named by the digest
of the source it was compiled from (:mod:`jackson.sim.compiled` loads it only while
``physics.py`` still has that digest). Nothing is done when that build exists. Otherwise:

1. the source's bytes are hashed and copied, as they were hashed, into a scratch folder
   beside the builds, as the module ``jackson_sim_physics``;
2. mypyc (from the ``dev`` extra's mypy) translates it to C, and the system's C compiler
   builds the extension with ``-ffp-contract=off`` (no fused multiply-add: the same IEEE
   double operations, in the same order, as the interpreter's);
3. the extension is imported once in a fresh interpreter, then moved into place; builds of
   other digests are removed.

A build that cannot be made (no mypyc, no C compiler, no Python headers, a compile error) is
one line on stderr naming the reason, and the exit status is still 0: the twin then runs
``physics.py`` interpreted, with the same results. ``--force`` rebuilds an existing build.
Run it with the environment's interpreter (``.venv/bin/python tools/build_compiled.py``).
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

SETUP_PY = """\
from mypyc.build import mypycify
from setuptools import setup

extensions = mypycify(["{module}.py"], opt_level="3")
for extension in extensions:
    extension.extra_compile_args.append("-ffp-contract=off")
setup(name="{module}", ext_modules=extensions, script_args=["build_ext", "--inplace"])
"""
CHECK_PY = """\
import sys
from jackson.sim.compiled import load_build
from pathlib import Path
module = load_build(Path(sys.argv[1]))
sys.exit(0 if module.__file__ == sys.argv[1] else 1)
"""
FIRMWARE_CHECK_PY = """\
import sys
from pathlib import Path
from jackson.sim.firmware_core import load_build
module = load_build(Path(sys.argv[1]))
core = module.Core(lambda frame: True, lambda: (0, 0), False, True, 0, 1)
sys.exit(0 if not core.session else 1)
"""
TIMEOUT_S = 600


class BuildError(Exception):
    """The build cannot be made; the message is the reason, one line."""


def _missing_tool() -> str | None:
    """What the build needs and this machine lacks (None: nothing)."""
    if importlib.util.find_spec("mypyc") is None:
        return "mypyc is not installed (it comes with the dev extra's mypy)"
    cc = (os.environ.get("CC") or sysconfig.get_config_var("CC") or "cc").split()[0]
    if shutil.which(cc) is None:
        return f"no C compiler ({cc} not found)"
    include = sysconfig.get_paths()["include"]
    if not (Path(include) / "Python.h").exists():
        return f"no Python headers ({include}/Python.h; install python3-dev)"
    return None


def _last_error(output: str) -> str:
    """The line of a failed build's output that says why."""
    lines = [line.strip() for line in output.splitlines() if line.strip()]
    for line in lines:
        if "error" in line.lower():
            return line[:300]
    return lines[-1][:300] if lines else "no output"


def build(force: bool) -> Path | None:
    """Build the compiled model for the present source unless it exists.

    Parameters
    ----------
    force : bool
        Rebuild even when the build exists.

    Returns
    -------
    Path or None
        The new build (None: it existed).

    Raises
    ------
    BuildError
        It cannot be made.
    """
    from jackson.sim import compiled

    source = compiled.source_path()
    text, digest, builds, target = _wanted(compiled, source)
    if target.is_file() and not force:
        return None
    missing = _missing_tool()
    if missing is not None:
        raise BuildError(missing)

    def make(scratch: Path) -> Path:
        (scratch / f"{compiled.MODULE}.py").write_bytes(text)
        (scratch / "setup.py").write_text(SETUP_PY.format(module=compiled.MODULE))
        (scratch / "mypy.ini").write_text("[mypy]\n")  # not the repository's configuration
        try:
            out = subprocess.run(
                [sys.executable, "setup.py"],
                cwd=scratch,
                capture_output=True,
                text=True,
                timeout=TIMEOUT_S,
            )
        except subprocess.TimeoutExpired as e:
            raise BuildError(f"mypyc took over {TIMEOUT_S} s") from e
        built = scratch / target.name
        if out.returncode != 0 or not built.is_file():
            raise BuildError(f"mypyc failed: {_last_error(out.stdout + out.stderr)}")
        check = subprocess.run(
            [sys.executable, "-c", CHECK_PY, str(built)],
            capture_output=True,
            text=True,
            env={**os.environ, compiled.ENV_INTERPRETED: "1"},  # load nothing else
        )
        if check.returncode != 0:
            raise BuildError(f"the build does not import: {_last_error(check.stderr)}")
        return built

    return _place(builds, digest, target, make)


def build_nav(force: bool) -> Path | None:
    """Build the costmap's compiled collision tests (``host/nav/native/collide.cpp``) into
    ``build/compiled-nav/<digest>/libjackson_nav.so`` unless that build exists.

    A shared library loaded with ctypes (:mod:`jackson.host.nav.native`): it needs a C++17
    compiler, not Python's headers.

    Returns
    -------
    Path or None
        The new build (None: it existed).

    Raises
    ------
    BuildError
        It cannot be made.
    """
    from jackson.host.nav import native

    return _build_shared(native, force)


def build_protocol(force: bool) -> Path | None:
    """Build the RPLIDAR's compiled capsule decoding (``protocol/native/capsules.cpp``)
    into ``build/compiled-protocol/<digest>/libjackson_protocol.so`` unless that build exists
    (loaded with ctypes by :mod:`jackson.protocol.native`), as :func:`build_nav`.

    Raises
    ------
    BuildError
        It cannot be made.
    """
    from jackson.protocol import native

    return _build_shared(native, force)


def _build_shared(module: Any, force: bool) -> Path | None:
    """A C++ source compiled into a shared library for ctypes, as ``module`` names and loads
    it (``source_path``, ``source_digest``, ``builds_dir``, ``build_path``, ``load_library``)."""
    source = module.source_path()
    text, digest, builds, target = _wanted(module, source)
    if target.is_file() and not force:
        return None
    cxx = _cxx()

    def make(scratch: Path) -> Path:
        (scratch / source.name).write_bytes(text)
        built = scratch / target.name
        flags = ["-std=c++17", "-O2", "-ffp-contract=off", "-fPIC", "-shared", "-Wall"]
        out = subprocess.run(
            [*cxx, *flags, source.name, "-o", built.name],
            cwd=scratch,
            capture_output=True,
            text=True,
            timeout=TIMEOUT_S,
        )
        if out.returncode != 0 or not built.is_file():
            raise BuildError(f"{cxx[0]} failed: {_last_error(out.stdout + out.stderr)}")
        try:
            module.load_library(built)
        except OSError as e:
            raise BuildError(f"the build does not load: {e}") from e
        return built

    return _place(builds, digest, target, make)


def build_firmware(force: bool) -> Path | None:
    """Build the firmware core as the twin's MCU (``firmware/twin/module.cpp`` with
    ``firmware/core``) into ``build/compiled-firmware/<digest>/`` unless that build exists.

    A Python extension module made with pybind11 (:mod:`jackson.sim.firmware_core`). Unlike the
    builds above it has no interpreted stand-in: the twin cannot run without it.

    Returns
    -------
    Path or None
        The new build (None: it existed).

    Raises
    ------
    BuildError
        It cannot be made.
    """
    from jackson.sim import firmware_core as fc

    digest = fc.source_digest()
    builds = fc.builds_dir()
    target = fc.build_path(builds, digest)
    if target.is_file() and not force:
        return None
    cxx = _cxx()
    try:
        import pybind11
    except ImportError as e:
        raise BuildError("pybind11 is not installed (a dependency of the package)") from e
    include = Path(sysconfig.get_paths()["include"])
    if not (include / "Python.h").exists():
        raise BuildError(f"no Python headers ({include}/Python.h; install python3-dev)")
    eigen = Path("/usr/include/eigen3")
    if not (eigen / "Eigen" / "Core").exists():
        raise BuildError("no Eigen headers (/usr/include/eigen3; install libeigen3-dev)")

    def make(scratch: Path) -> Path:
        built = scratch / target.name
        flags = ["-std=c++17", "-O2", "-fPIC", "-shared", "-fvisibility=hidden", "-Wall"]
        flags += ["-DEIGEN_NO_MALLOC", f"-I{include}", f"-I{pybind11.get_include()}", f"-I{eigen}"]
        flags += [f"-I{d}" for d in fc.include_dirs()]
        out = subprocess.run(
            [*cxx, *flags, *(str(u) for u in fc.compile_units()), "-o", str(built)],
            capture_output=True,
            text=True,
            timeout=TIMEOUT_S,
        )
        if out.returncode != 0 or not built.is_file():
            raise BuildError(f"{cxx[0]} failed: {_last_error(out.stdout + out.stderr)}")
        check = subprocess.run(
            [sys.executable, "-c", FIRMWARE_CHECK_PY, str(built)], capture_output=True, text=True
        )
        if check.returncode != 0:
            raise BuildError(f"the build does not import: {_last_error(check.stderr)}")
        return built

    return _place(builds, digest, target, make)


def _cxx() -> list[str]:
    """The C++ compiler's command (``CXX`` from the environment, else ``c++``).

    Raises
    ------
    BuildError
        It is not installed.
    """
    cxx = (os.environ.get("CXX") or "c++").split()
    if shutil.which(cxx[0]) is None:
        raise BuildError(f"no C++ compiler ({cxx[0]} not found)")
    return cxx


def _wanted(module: Any, source: Path) -> tuple[bytes, str, Path, Path]:
    """A source's bytes as hashed, its digest, its builds' folder and the build it needs
    (``module`` names them: :mod:`jackson.sim.compiled`, :mod:`jackson.host.nav.native`)."""
    text = source.read_bytes()
    digest = str(module.source_digest(text))
    builds = Path(module.builds_dir(source))
    return text, digest, builds, Path(module.build_path(builds, digest))


def _place(builds: Path, digest: str, target: Path, make: Callable[[Path], Path]) -> Path:
    """Make a build in a scratch folder beside the builds (``make`` returns the file), move it
    into place, and remove the builds of older sources and dead scratch folders."""
    builds.mkdir(parents=True, exist_ok=True)
    scratch = Path(tempfile.mkdtemp(prefix=".scratch-", dir=builds))
    try:
        built = make(scratch)
        target.parent.mkdir(exist_ok=True)
        os.replace(built, target)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    for old in builds.iterdir():  # builds of older sources, scratch folders of dead builds
        if old.is_dir() and old.name != digest and not _in_progress(old):
            shutil.rmtree(old, ignore_errors=True)
    return target


def _in_progress(folder: Path) -> bool:
    """A scratch folder another build may still be using (younger than its timeout)."""
    return folder.name.startswith(".scratch-") and time.time() - folder.stat().st_mtime < TIMEOUT_S


def main() -> int:
    """Build it; one line on stderr when it cannot be made.

    Returns
    -------
    int
        0, or 1 when the firmware core cannot be built (the physics, the collision tests and
        the capsule decoding have interpreted stand-ins; the twin's MCU has none).
    """
    parser = argparse.ArgumentParser(
        description="Compile sim/physics.py (mypyc), the costmap's collision tests, the "
        "RPLIDAR's capsule decoding and the firmware core as the twin's MCU."
    )
    parser.add_argument("--force", action="store_true", help="rebuild an existing build")
    args = parser.parse_args()
    optional = (
        (build, "sim/physics.py with mypyc",
         "compiled physics not built, the twin runs interpreted"),
        (build_nav, "host/nav/native/collide.cpp",
         "compiled collision tests not built, the costmap uses numpy"),
        (build_protocol, "protocol/native/capsules.cpp",
         "compiled capsule decoding not built, the LiDAR's decoder uses numpy"),
    )  # fmt: skip
    for make, what, without in optional:
        t0 = time.monotonic()
        try:
            if make(args.force) is not None:
                print(f"setup: compiled {what} ({time.monotonic() - t0:.0f} s)")
        except Exception as e:  # never break make setup
            why = str(e) if isinstance(e, BuildError) else f"{type(e).__name__}: {e}"
            print(f"setup: {without}: {why}", file=sys.stderr)
    t0 = time.monotonic()
    try:
        fw = build_firmware(args.force)
        if fw is not None:
            took = time.monotonic() - t0
            print(f"setup: compiled the firmware core as the twin's MCU ({took:.0f} s)")
    except Exception as e:  # the twin cannot run without it: make setup stops here
        why = str(e) if isinstance(e, BuildError) else f"{type(e).__name__}: {e}"
        print(f"setup: the firmware core (the twin's MCU) cannot be built: {why}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
