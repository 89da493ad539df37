"""Build a ROS 2 interface package (tf2_msgs, nav2_msgs) into this virtual environment.

/tf and /tf_static carry ``tf2_msgs/msg/TFMessage`` and the navigation service's action is
``nav2_msgs/action/NavigateToPose``, and the PyPI wheels of the ``ros`` extra (Jazzy) have
neither package. They do have the rosidl tool chain, so ``make setup`` builds each package
here, the way ``rosidl_generate_interfaces`` does in a ROS workspace:

1. the interface definitions in ``tools/ros_interfaces/<package>`` (msg, srv, action) are
   translated to IDL and their type hashes (RIHS01) computed;
2. the C structures, the Python classes and the three C type supports rclpy and Fast DDS use
   (``rosidl_typesupport_c`` dispatching to ``rosidl_typesupport_fastrtps_c`` and
   ``rosidl_typesupport_introspection_c``) are generated;
3. the system's C and C++ compilers build them against the wheels' headers and libraries;
4. the result is installed with the wheels' own layout: ``<venv>/lib/lib<package>__*.so``,
   ``<site-packages>/<package>`` (the Python package and its ``<package>_s__*`` extension
   modules), ``<venv>/include/<package>``, ``<venv>/share/<package>`` and the ament index.

A package's definitions are those of its ROS 2 Jazzy release; a package may hold only the
interfaces the project uses (nav2_msgs: ``NavigateToPose``), since a type's hash depends on
its own fields and the types they name, never on the rest of its package.

Run it with the environment's interpreter (``.venv/bin/python tools/build_ros_msgs.py
tf2_msgs``). A failure prints one line on stderr (the full compiler output goes to a log
file) and exits 1.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import shutil
import subprocess
import sys
import sysconfig
import tempfile
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

DEFINITIONS = Path(__file__).resolve().parent / "ros_interfaces"
# Interface packages the definitions use, directly or through services and actions (every one
# comes with the wheels: action_msgs and unique_identifier_msgs with rclpy's rcl_action).
DEPENDENCIES = (
    "builtin_interfaces",
    "geometry_msgs",
    "std_msgs",
    "service_msgs",
    "action_msgs",
    "unique_identifier_msgs",
)


@dataclass(frozen=True)
class InterfacePackage:
    """One interface package to build: its definitions in ``tools/ros_interfaces/<name>``.

    Attributes
    ----------
    name : str
        The ROS package (``tf2_msgs``).
    version : str
        The Jazzy release whose definitions ``tools/ros_interfaces/<name>`` holds.
    interfaces : tuple of str
        The definitions built, relative to the package (``msg/TFMessage.msg``).
    smoke_test : str
        Python run in a fresh interpreter once it is installed: it must import the package,
        load its type supports and round-trip a message through the RMW's serializer.
    """

    name: str
    version: str
    interfaces: tuple[str, ...]
    smoke_test: str

    @property
    def source(self) -> Path:
        return DEFINITIONS / self.name


# The installed package must import, load its type support and round-trip a message through
# the RMW's serializer (which loads the Fast DDS type support through the C dispatch).
TF2_MSGS = InterfacePackage(
    "tf2_msgs",
    "0.36.4",
    (
        "msg/TF2Error.msg",
        "msg/TFMessage.msg",
        "srv/FrameGraph.srv",
        "action/LookupTransform.action",
    ),
    """
from rclpy.serialization import deserialize_message, serialize_message
from rclpy.type_support import check_for_type_support
from geometry_msgs.msg import TransformStamped
from tf2_msgs.msg import TF2Error, TFMessage
from tf2_msgs.srv import FrameGraph
from tf2_msgs.action import LookupTransform
for t in (TFMessage, TF2Error, FrameGraph, LookupTransform):
    check_for_type_support(t)
msg = TFMessage(transforms=[TransformStamped(child_frame_id="base_link")])
msg.transforms[0].transform.translation.x = 1.5
assert deserialize_message(serialize_message(msg), TFMessage) == msg
""",
)
NAV2_MSGS = InterfacePackage(
    "nav2_msgs",
    "1.3.13",
    ("action/NavigateToPose.action",),
    """
from rclpy.serialization import deserialize_message, serialize_message
from rclpy.type_support import check_for_type_support
from nav2_msgs.action import NavigateToPose
check_for_type_support(NavigateToPose)
impl = NavigateToPose.Impl
fb = impl.FeedbackMessage()
fb.feedback.distance_remaining = 1.5
fb.feedback.number_of_recoveries = 2
assert deserialize_message(serialize_message(fb), impl.FeedbackMessage) == fb
res = impl.GetResultService.Response(status=4)
res.result.error_msg = "unreachable"
assert deserialize_message(serialize_message(res), impl.GetResultService.Response) == res
assert NavigateToPose.Result.NONE == 0
""",
)
PACKAGES = {p.name: p for p in (TF2_MSGS, NAV2_MSGS)}
# The C type supports the Python extension modules are built for (rclpy imports the first).
TYPESUPPORTS = (
    "rosidl_typesupport_c",
    "rosidl_typesupport_fastrtps_c",
    "rosidl_typesupport_introspection_c",
)
# The generated visibility headers export a package's symbols when <MACRO>_BUILDING_DLL_<pkg>.
VISIBILITY_MACROS = (
    "ROSIDL_GENERATOR_C",
    "ROSIDL_TYPESUPPORT_FASTRTPS_C",
    "ROSIDL_TYPESUPPORT_INTROSPECTION_C",
    "ROSIDL_GENERATOR_PY",
)


class BuildError(Exception):
    """A step of the build failed; the message is one line."""


@dataclass(frozen=True)
class Prefix:
    """Where the wheels live and where the package goes: a virtual environment's prefix."""

    root: Path

    @property
    def lib(self) -> Path:
        return self.root / "lib"

    @property
    def include(self) -> Path:
        return self.root / "include"

    @property
    def share(self) -> Path:
        return self.root / "share"

    @property
    def site_packages(self) -> Path:
        return Path(sysconfig.get_paths(vars={"base": str(self.root)})["purelib"])


# ------------------------------------------------------------------------------ generation


@contextlib.contextmanager
def _quiet(log: io.StringIO) -> Iterator[None]:
    """The generators print every file they read and write: into the log, not the terminal."""
    with contextlib.redirect_stdout(log):
        yield


def translate(pkg: InterfacePackage, work: Path) -> list[str]:
    """Translate the interface definitions to IDL (``rosidl_adapter``).

    Parameters
    ----------
    pkg : InterfacePackage
        The package.
    work : Path
        The build's scratch folder; the IDL files go to ``work/idl/<msg|srv|action>``.

    Returns
    -------
    list of str
        The IDL files as ``prefix:relative/path.idl``, the form the generators take.
    """
    from rosidl_adapter.action import convert_action_to_idl
    from rosidl_adapter.msg import convert_msg_to_idl
    from rosidl_adapter.srv import convert_srv_to_idl

    convert = {".msg": convert_msg_to_idl, ".srv": convert_srv_to_idl}
    convert[".action"] = convert_action_to_idl
    out = work / "idl"
    idl: list[str] = []
    for name in pkg.interfaces:
        rel = Path(name)
        convert[rel.suffix](pkg.source, pkg.name, rel, out / rel.parent)
        idl.append(f"{out}:{rel.with_suffix('.idl').as_posix()}")
    return idl


def generate(pkg: InterfacePackage, prefix: Prefix, work: Path, idl: list[str]) -> Path:
    """Compute the type hashes and generate the sources of every layer.

    Parameters
    ----------
    pkg : InterfacePackage
        The package.
    prefix : Prefix
        The wheels' prefix: the dependencies' ``.idl`` and type descriptions (``share/<pkg>``).
    work : Path
        The build's scratch folder.
    idl : list of str
        The package's IDL files, from :func:`translate`.

    Returns
    -------
    Path
        ``work/gen``, holding ``<layer>/<package>/...`` for each generator and type support.
    """
    from rosidl_generator_c.cli import GenerateC
    from rosidl_generator_py.cli import GeneratePython
    from rosidl_generator_type_description.cli import HashTypeDescription
    from rosidl_typesupport_c.cli import GenerateCTypesupport
    from rosidl_typesupport_fastrtps_c.cli import GenerateFastRTPSCTypesupport
    from rosidl_typesupport_introspection_c.cli import GenerateIntrospectionCTypesupport

    gen = work / "gen"
    name = pkg.name
    includes = [str(prefix.share / dep) for dep in DEPENDENCIES]
    hashes = HashTypeDescription("type_description").generate_type_hashes(
        name, idl, includes, gen / "rosidl_generator_type_description" / name
    )
    GenerateC("c").generate(
        name, idl, includes, gen / "rosidl_generator_c" / name, type_description_files=hashes
    )
    supports = list(TYPESUPPORTS[1:])
    GenerateCTypesupport("c", typesupport_implementations=supports).generate(
        name, idl, includes, gen / "rosidl_typesupport_c" / name
    )
    GenerateFastRTPSCTypesupport("fastrtps_c").generate(
        name, idl, includes, gen / "rosidl_typesupport_fastrtps_c" / name
    )
    GenerateIntrospectionCTypesupport("introspection_c").generate(
        name, idl, includes, gen / "rosidl_typesupport_introspection_c" / name
    )
    GeneratePython("py", typesupport_implementations=list(TYPESUPPORTS)).generate(
        name, idl, includes, gen / "rosidl_generator_py" / name
    )
    return gen


# ------------------------------------------------------------------------------ compilation


@dataclass(frozen=True)
class Library:
    """One shared library of the package: its generated sources and what it links against."""

    package: str
    layer: str  # the generator or type support, e.g. rosidl_typesupport_fastrtps_c
    sources: tuple[Path, ...]
    own: tuple[str, ...]  # the package's own layers it needs, built before it
    per_dependency: tuple[str, ...]  # layers linked from every dependency (and its C structs)
    system: tuple[str, ...]  # the wheels' runtime libraries
    python: bool = False  # sees Python's and NumPy's headers; Python's symbols stay undefined

    @property
    def name(self) -> str:
        return f"lib{self.package}__{self.layer}.so"


def libraries(package: str, gen: Path) -> list[Library]:
    """The package's libraries in link order, as ``rosidl_generate_interfaces`` defines them."""

    def sources(layer: str, pattern: str) -> tuple[Path, ...]:
        return tuple(sorted((gen / layer / package).rglob(pattern)))

    runtime = ("rosidl_runtime_c", "rcutils")
    py = gen / "rosidl_generator_py" / package
    return [
        Library(
            package,
            "rosidl_generator_c",
            sources("rosidl_generator_c", "*.c"),
            (),
            (),
            runtime,
        ),
        Library(
            package,
            "rosidl_typesupport_introspection_c",
            sources("rosidl_typesupport_introspection_c", "*.c"),
            ("rosidl_generator_c",),
            ("rosidl_typesupport_introspection_c",),
            ("rosidl_typesupport_introspection_c", *runtime),
        ),
        Library(
            package,
            "rosidl_typesupport_fastrtps_c",
            sources("rosidl_typesupport_fastrtps_c", "*.cpp"),
            ("rosidl_generator_c",),
            ("rosidl_typesupport_fastrtps_c",),
            (
                "rosidl_typesupport_fastrtps_c",
                "rosidl_typesupport_fastrtps_cpp",
                "fastcdr",
                "rmw",
                "rosidl_dynamic_typesupport",
                *runtime,
            ),
        ),
        Library(
            package,
            "rosidl_typesupport_c",
            sources("rosidl_typesupport_c", "*.cpp"),
            ("rosidl_generator_c",),
            ("rosidl_typesupport_c",),
            ("rosidl_typesupport_c", *runtime),
        ),
        Library(
            package,
            "rosidl_generator_py",
            tuple(sorted(py.glob("*/_*_s.c"))),
            ("rosidl_typesupport_c", "rosidl_generator_c"),
            ("rosidl_generator_py", "rosidl_typesupport_c"),
            ("rosidl_typesupport_c", *runtime),
            python=True,
        ),
    ]


def extension_name(package: str, typesupport: str) -> str:
    """The file name of the Python extension module for one C type support."""
    return f"{package}_s__{typesupport}{sysconfig.get_config_var('EXT_SUFFIX')}"


def _include_dirs(prefix: Prefix, gen: Path, python: bool) -> list[str]:
    dirs = [str(d) for d in sorted(gen.iterdir())]  # <layer>/<pkg>/... as "<pkg>/..."
    # the wheels' headers: <pkg>/<pkg>/... for ROS packages, fastcdr/... for Fast DDS
    dirs += [str(d) for d in sorted(prefix.include.iterdir()) if d.is_dir()]
    dirs.append(str(prefix.include))
    if python:
        import numpy

        dirs += [sysconfig.get_paths()["include"], numpy.get_include()]
    return [f"-I{d}" for d in dirs]


def _run(cmd: Sequence[str], what: str, log: io.StringIO) -> None:
    log.write("$ " + " ".join(cmd) + "\n")
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    except OSError as e:
        raise BuildError(f"{what}: cannot run {cmd[0]}: {e.strerror}") from e
    log.write(done.stdout + done.stderr)
    if done.returncode != 0:
        lines = done.stderr.strip().splitlines()
        errors = [ln for ln in lines if "error" in ln] or lines or [f"exit {done.returncode}"]
        raise BuildError(f"{what} failed: {errors[0].strip()}")


def link(
    package: str,
    prefix: Prefix,
    gen: Path,
    out: Path,
    staged_lib: Path,
    sources: Sequence[Path],
    libs: Sequence[str],
    python: bool,
    rpath: str,
    log: io.StringIO,
) -> None:
    """Compile ``sources`` into one shared object with the system's compiler.

    Parameters
    ----------
    package : str
        The package the sources are of (its symbols are exported).
    prefix : Prefix
        The wheels' prefix: headers from ``include``, libraries from ``lib``.
    gen : Path
        The generated sources (their folders are include paths too).
    out : Path
        The shared object to write.
    staged_lib : Path
        Where the package's own libraries were built.
    sources : sequence of Path
        C files, or C++ files (``.cpp``: compiled as C++17).
    libs : sequence of str
        Libraries to link, without ``lib`` and ``.so``.
    python : bool
        Add Python's and NumPy's headers and leave Python's symbols undefined (they come from
        the interpreter); everything else must resolve at link time.
    rpath : str
        Where the loader looks first for ``libs`` (``$ORIGIN``-relative).
    log : io.StringIO
        Receives the command and the compiler's output.

    Raises
    ------
    BuildError
        The compiler failed; the message quotes its first error line.
    """
    cxx = any(s.suffix == ".cpp" for s in sources)
    compiler = os.environ.get("CXX", "c++") if cxx else os.environ.get("CC", "cc")
    cmd = [compiler, "-shared", "-fPIC", "-O2", "-std=c++17" if cxx else "-std=gnu11"]
    cmd += [f"-D{m}_BUILDING_DLL_{package}" for m in VISIBILITY_MACROS]
    cmd += _include_dirs(prefix, gen, python)
    cmd += [str(s) for s in sources]
    cmd += ["-o", str(out), f"-L{staged_lib}", f"-L{prefix.lib}", f"-Wl,-rpath,{rpath}"]
    if not python:
        cmd.append("-Wl,--no-undefined")
    cmd += [f"-l{lib}" for lib in libs]
    _run(cmd, f"compiling {out.name}", log)


def compile_package(package: str, prefix: Prefix, gen: Path, stage: Path, log: io.StringIO) -> None:
    """Build every library into ``stage/lib`` and the extension modules into ``stage/py``."""
    (stage / "lib").mkdir(parents=True)
    (stage / "py").mkdir(parents=True)
    for lib in libraries(package, gen):
        if not lib.sources:
            raise BuildError(f"the generator wrote no sources for {lib.layer}")
        libs = [f"{package}__{layer}" for layer in lib.own]
        layers = dict.fromkeys((*lib.per_dependency, "rosidl_generator_c"))
        libs += [f"{dep}__{layer}" for layer in layers for dep in DEPENDENCIES]
        libs += list(lib.system)
        link(
            package,
            prefix,
            gen,
            stage / "lib" / lib.name,
            stage / "lib",
            lib.sources,
            libs,
            lib.python,
            "$ORIGIN",
            log,
        )
    py = gen / "rosidl_generator_py" / package
    for typesupport in TYPESUPPORTS:
        entry = py / f"_{package}_s.ep.{typesupport}.c"
        libs = [f"{package}__rosidl_generator_py", f"{package}__{typesupport}"]
        libs += [f"{package}__rosidl_generator_c", "rosidl_runtime_c", "rcutils"]
        out = stage / "py" / extension_name(package, typesupport)
        # site-packages/<package> -> <prefix>/lib
        rpath = "$ORIGIN/" + os.path.relpath(prefix.lib, prefix.site_packages / package)
        link(package, prefix, gen, out, stage / "lib", [entry], libs, True, rpath, log)


# ------------------------------------------------------------------------------ installation


def _put(src: Path, dst: Path, installed: list[Path]) -> None:
    """Copy one file into place atomically (a running process may have the old one mapped)."""
    dst.parent.mkdir(parents=True, exist_ok=True)
    tmp = dst.with_name(dst.name + ".tmp")
    shutil.copyfile(src, tmp)
    shutil.copymode(src, tmp)
    os.replace(tmp, dst)
    installed.append(dst)


def _write(dst: Path, text: str, installed: list[Path]) -> None:
    dst.parent.mkdir(parents=True, exist_ok=True)
    dst.write_text(text, encoding="utf-8")
    installed.append(dst)


def install(pkg: InterfacePackage, work: Path, gen: Path, stage: Path, dest: Prefix) -> list[Path]:
    """Install the build with the wheels' layout, replacing an earlier build.

    Parameters
    ----------
    pkg : InterfacePackage
        The package.
    work : Path
        The build's scratch folder (``work/idl``).
    gen : Path
        The generated sources (Python modules, headers, type descriptions).
    stage : Path
        The compiled libraries (``stage/lib``) and extension modules (``stage/py``).
    dest : Prefix
        The environment to install into.

    Returns
    -------
    list of Path
        Every file written, as the distribution's RECORD lists them.
    """
    installed: list[Path] = []
    name = pkg.name
    for so in sorted((stage / "lib").iterdir()):
        _put(so, dest.lib / so.name, installed)

    pkg_dir = dest.site_packages / name
    shutil.rmtree(pkg_dir, ignore_errors=True)
    py = gen / "rosidl_generator_py" / name
    _write(pkg_dir / "__init__.py", "", installed)
    for f in sorted(py.rglob("*.py")):
        _put(f, pkg_dir / f.relative_to(py), installed)
    for so in sorted((stage / "py").iterdir()):
        _put(so, pkg_dir / so.name, installed)

    headers = dest.include / name / name
    for layer in sorted(gen.iterdir()):
        for h in sorted((layer / name).rglob("*.h")):
            _put(h, headers / h.relative_to(layer / name), installed)

    share = dest.share / name
    interfaces: list[str] = []
    for interface in pkg.interfaces:
        rel = Path(interface)
        idl = rel.with_suffix(".idl")
        _put(pkg.source / rel, share / rel, installed)
        _put(work / "idl" / idl, share / idl, installed)
        interfaces += [idl.as_posix(), rel.as_posix()]
    descriptions = gen / "rosidl_generator_type_description" / name
    for j in sorted(descriptions.rglob("*.json")):
        _put(j, share / j.relative_to(descriptions), installed)
    index = dest.share / "ament_index" / "resource_index"
    _write(index / "packages" / name, "", installed)
    _write(index / "rosidl_interfaces" / name, "\n".join(interfaces), installed)

    # A distribution record, so that pip lists the package and `pip uninstall` removes it.
    dist = dest.site_packages / f"ros_{name}-{pkg.version}.dist-info"
    shutil.rmtree(dist, ignore_errors=True)
    metadata = (
        f"Metadata-Version: 2.1\nName: ros-{name.replace('_', '-')}\nVersion: {pkg.version}\n"
        f"Summary: {name} for ROS 2 Jazzy, built by tools/build_ros_msgs.py\n"
    )
    _write(dist / "METADATA", metadata, installed)
    _write(dist / "INSTALLER", "jackson\n", installed)
    records = [os.path.relpath(f, dest.site_packages) for f in installed]
    records.append(os.path.relpath(dist / "RECORD", dest.site_packages))
    _write(dist / "RECORD", "".join(f"{r},,\n" for r in records), installed)
    return installed


def smoke_test(pkg: InterfacePackage, dest: Prefix, log: io.StringIO) -> None:
    """Run the package's smoke test in a fresh interpreter that sees ``dest``."""
    env = dict(os.environ)
    for var, path in (("PYTHONPATH", dest.site_packages), ("LD_LIBRARY_PATH", dest.lib)):
        env[var] = os.pathsep.join(filter(None, [str(path), env.get(var)]))
    done = subprocess.run(
        [sys.executable, "-c", pkg.smoke_test], capture_output=True, text=True, env=env, check=False
    )
    log.write(done.stdout + done.stderr)
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["no output"])[-1]
        raise BuildError(f"the installed {pkg.name} does not work: {last}")


# ------------------------------------------------------------------------------ command line


def build(pkg: InterfacePackage, wheels: Prefix, dest: Prefix, log: io.StringIO) -> list[Path]:
    """Generate, compile, install and check the package.

    Parameters
    ----------
    pkg : InterfacePackage
        The package.
    wheels : Prefix
        The environment whose rosidl wheels generate and whose libraries it links against.
    dest : Prefix
        Where to install (the same environment for ``make setup``).
    log : io.StringIO
        Receives the generators' and compilers' output.

    Returns
    -------
    list of Path
        The installed files.

    Raises
    ------
    BuildError
        A step failed (no compiler, generation, compilation, or the installed package does not
        work); the message is one line.
    """
    for tool in (os.environ.get("CC", "cc"), os.environ.get("CXX", "c++")):
        if shutil.which(tool) is None:
            raise BuildError(f"no compiler {tool}; install it: sudo apt-get install -y g++")
    # the generators find their templates through the ament index of the wheels' prefix
    ament = [str(wheels.root), os.environ.get("AMENT_PREFIX_PATH")]
    os.environ["AMENT_PREFIX_PATH"] = os.pathsep.join(filter(None, ament))
    with tempfile.TemporaryDirectory(prefix=f"{pkg.name}-") as tmp:
        work = Path(tmp)
        try:
            with _quiet(log):
                gen = generate(pkg, wheels, work, translate(pkg, work))
        except ImportError as e:
            raise BuildError(
                f"the rosidl generators do not import ({e}); install the ros extra"
            ) from e
        except Exception as e:  # a generator's own error: name it in one line
            raise BuildError(f"generating the sources failed: {type(e).__name__}: {e}") from e
        compile_package(pkg.name, wheels, gen, work / "stage", log)
        installed = install(pkg, work, gen, work / "stage", dest)
    smoke_test(pkg, dest, log)
    return installed


def main(argv: Sequence[str] | None = None) -> int:
    """Build and install one package; 0 on success, 1 with one line on stderr on failure."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("package", choices=sorted(PACKAGES), help="the package to build")
    parser.add_argument(
        "--prefix",
        type=Path,
        default=Path(sys.prefix),
        help="where to install (default: this interpreter's environment, whose wheels it uses)",
    )
    args = parser.parse_args(argv)
    pkg = PACKAGES[args.package]
    wheels, dest = Prefix(Path(sys.prefix)), Prefix(args.prefix.resolve())
    log_path = dest.root / f"{pkg.name}-build.log"
    log = io.StringIO()
    try:
        installed = build(pkg, wheels, dest, log)
    except BuildError as e:
        print(f"building {pkg.name} failed: {e} (log: {log_path})", file=sys.stderr)
        return 1
    finally:
        dest.root.mkdir(parents=True, exist_ok=True)
        log_path.write_text(log.getvalue(), encoding="utf-8")
    print(f"{pkg.name} {pkg.version}: {len(installed)} files installed under {dest.root}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
