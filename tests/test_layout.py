"""The import packages map onto the repository folders, and the layering holds."""

from __future__ import annotations

import ast
import importlib
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MAPPING = {
    "jackson": "cli",
    "jackson.bench": "bench",
    "jackson.common": "common",
    "jackson.protocol": "protocol",
    "jackson.host": "host",
    "jackson.sim": "sim",
    "jackson.calibration": "calibration",
    "jackson.experiments": "experiments",
}
FOLDERS = tuple(MAPPING.values())
# the command-line modules and subpackages (the top-level package, folder cli/): only cli/
# may import them
CLI = tuple(
    sorted(
        f"jackson.{p.stem}"
        for p in (ROOT / "cli").iterdir()
        if (p.suffix == ".py" and p.stem != "__init__") or (p / "__init__.py").is_file()
    )
)
BENCH = ("jackson.bench",)  # the benchmarks (folder bench/): they may import every layer
LAB = ("jackson.calibration", "jackson.experiments")  # what runs on the twin and in the lab
FORBIDDEN = {  # package folder -> packages it must never import
    "common": ("jackson.protocol", "jackson.host", "jackson.sim", *LAB, *BENCH, *CLI),
    "protocol": ("jackson.host", "jackson.sim", *LAB, *BENCH, *CLI),
    "host": ("jackson.sim", *LAB, *BENCH, *CLI),
    "sim": ("jackson.host", *LAB, *BENCH, *CLI),
    "calibration": ("jackson.experiments", *BENCH, *CLI),
    "experiments": (*BENCH, *CLI),
    "bench": CLI,
}


@pytest.mark.parametrize(("package", "folder"), MAPPING.items())
def test_package_maps_onto_its_folder(package: str, folder: str) -> None:
    module = importlib.import_module(package)
    assert module.__file__ is not None
    assert Path(module.__file__).resolve().parent == ROOT / folder


def test_every_package_folder_is_a_distributed_package() -> None:
    """A subpackage missing from pyproject.toml's list imports here (the folder is on the
    path) but not from an install: a fresh checkout's ``make setup`` would leave it out."""
    import tomllib

    listed = set(
        tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"]
    )
    folders = set()
    for package, folder in MAPPING.items():
        for init in (ROOT / folder).rglob("__init__.py"):
            rel = init.parent.relative_to(ROOT / folder).parts
            if "vectors" in rel or "__pycache__" in rel:
                continue
            folders.add(".".join([package, *rel]))
    assert folders - listed == set()


@pytest.mark.parametrize("folder", FORBIDDEN)
def test_layering(folder: str) -> None:
    for path in (ROOT / folder).rglob("*.py"):
        tree = ast.parse(path.read_text(), str(path))
        for node in ast.walk(tree):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            for name in names:
                bad = [f for f in FORBIDDEN[folder] if name == f or name.startswith(f + ".")]
                assert not bad, f"{path}: imports {name}"


def test_console_script_runs() -> None:
    exe = Path(sys.executable).parent / "jackson"
    out = subprocess.run([str(exe), "--version"], capture_output=True, text=True, check=True)
    assert out.stdout.startswith("jackson ")


def test_nothing_imports_rclpy_without_ros() -> None:
    """The daemon, its bag recorder and the command line load without rclpy (only --ros may)."""
    code = (
        "import sys, jackson.main as m; m.build_parser(); "
        "import jackson.host.daemon, jackson.host.ros.bag, jackson.host.ros.messages, "
        "jackson.host.ros.bridge, jackson.sim.ros, jackson.sim.runner; "
        "print(sorted(k for k in sys.modules if k.split('.')[0] in ('rclpy', 'rosidl_runtime_py')))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def _module_name(path: Path) -> str:
    folder = path.relative_to(ROOT).parts[0]
    package = {v: k for k, v in MAPPING.items()}[folder]
    rest = path.relative_to(ROOT / folder).with_suffix("").parts
    parts = [p for p in rest if p != "__init__"]
    return ".".join([package, *parts])


def _module_graph() -> tuple[dict[str, Path], dict[str, set[str]]]:
    """Every module of the project and the modules each imports, imports inside functions and
    under ``TYPE_CHECKING`` included."""
    modules = {
        _module_name(p): p
        for folder in MAPPING.values()
        for p in (ROOT / folder).rglob("*.py")
        if "vectors" not in p.parts
    }
    graph: dict[str, set[str]] = {m: set() for m in modules}
    for name, path in modules.items():
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                targets = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            for t in targets:
                if t in modules and t != name and not name.startswith(t + "."):
                    graph[name].add(t)
    return modules, graph


def _acyclic(graph: dict[str, set[str]], what: str) -> None:
    done: set[str] = set()

    def visit(node: str, stack: list[str]) -> None:
        if node in stack:
            cycle = [*stack[stack.index(node) :], node]
            raise AssertionError(f"{what} cycle: " + " -> ".join(cycle))
        if node in done:
            return
        for nxt in sorted(graph[node]):
            visit(nxt, [*stack, node])
        done.add(node)

    for m in sorted(graph):
        visit(m, [])


def test_no_import_cycles() -> None:
    """No two modules import each other, directly or round a loop, not even through an import
    inside a function (that only hides the knot)."""
    _acyclic(_module_graph()[1], "import")


def test_no_package_cycles() -> None:
    """Nor do packages: a package's own modules (a package's top level is one node, each
    subpackage another) never import a package that imports them back, so every package can be
    read, tested and replaced above the ones it uses (e.g. jackson.host's daemon above
    jackson.host.core above jackson.host.estimation)."""
    modules, graph = _module_graph()

    def package(name: str) -> str:
        return name if modules[name].name == "__init__.py" else name.rpartition(".")[0]

    packages: dict[str, set[str]] = {package(m): set() for m in modules}
    for name, targets in graph.items():
        for t in targets:
            if package(t) != package(name):
                packages[package(name)].add(package(t))
    assert {"jackson.host", "jackson.host.core", "jackson.host.estimation"} <= set(packages)
    _acyclic(packages, "package")


# an angle wrap or a world -> cell mapping written out again, anywhere but common/geometry.py
# (arithmetic written otherwise, e.g. a multiplication by 1 / resolution, is its own rounding
# and is not caught here)
RULES_WRITTEN_ONCE = (
    r"% \(2\.0 \* math\.pi\) - math\.pi",
    r"% TWO_PI - math\.pi",
    r"2\.0 \* math\.pi\) - math\.pi",
    r"atan2\((math|np)\.sin\(",
    r"floor\(\(.*origin_[xy]_m\) / (self\.)?resolution_m\)",
)


def test_angle_wrapping_and_world_to_cell_are_written_once() -> None:
    found = []
    for folder in FOLDERS:
        for path in sorted((ROOT / folder).rglob("*.py")):
            if path == ROOT / "common" / "geometry.py":
                continue
            text = path.read_text()
            found += [
                f"{path.relative_to(ROOT)}: {r}" for r in RULES_WRITTEN_ONCE if re.search(r, text)
            ]
    assert not found, "use jackson.common.geometry: " + "; ".join(found)
    geometry = (ROOT / "common" / "geometry.py").read_text()
    for rule in RULES_WRITTEN_ONCE:  # and there, once (x and y of world_to_cell: one rule each)
        assert len(re.findall(rule, geometry)) <= 2, rule


# the modules that may run a distance transform (scipy.ndimage.distance_transform_*), and why
DISTANCE_TRANSFORMS = {
    "host/nav/likelihood.py": "the likelihood field, and the mapper's nearest obstacle points",
    "host/nav/native.py": "the costmaps' inflation and clear reach, in cells (scipy's where the "
    "compiled transform is not built)",
}


def test_the_likelihood_field_is_written_once() -> None:
    """One likelihood field (host/nav/likelihood.py) serves the particle filter and the mapper:
    no other module turns a grid into distances to its obstacles, and there it is done once
    (the other transform there yields the nearest cells only, no distances)."""
    calls: dict[str, list[ast.Call]] = {}
    for folder in ("cli", "common", "protocol", "host", "sim", "calibration"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            found = [
                node
                for node in ast.walk(ast.parse(path.read_text(), str(path)))
                if isinstance(node, ast.Call)
                and ast.unparse(node.func).split(".")[-1].startswith("distance_transform_")
            ]
            if found:
                calls[path.relative_to(ROOT).as_posix()] = found
    assert sorted(calls) == sorted(DISTANCE_TRANSFORMS)
    distances = [
        call
        for call in calls["host/nav/likelihood.py"]
        if not any(
            k.arg == "return_distances" and ast.literal_eval(k.value) is False
            for k in call.keywords
        )
    ]
    assert len(distances) == 1, "a second likelihood field in host/nav/likelihood.py"


def test_every_error_of_the_project_is_a_jackson_error() -> None:
    # one base, caught once at the command line (common/errors.py)
    bases: dict[str, list[str]] = {}
    for folder in FOLDERS:
        for path in sorted((ROOT / folder).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.ClassDef) and node.name.endswith("Error"):
                    names = [ast.unparse(b).split(".")[-1] for b in node.bases]
                    if "IntEnum" not in names:  # NackError: a protocol field, not an exception
                        bases[node.name] = names

    def reaches(name: str, seen: frozenset[str] = frozenset()) -> bool:
        if name == "JacksonError":
            return True
        return (
            name in bases
            and name not in seen
            and any(reaches(b, seen | {name}) for b in bases[name])
        )

    assert len(bases) > 30
    assert [n for n in sorted(bases) if not reaches(n)] == []


def test_every_benchmark_is_registered_by_an_import_in_code() -> None:
    """``jackson bench``'s registry (bench/suites.py) reaches each suite through an import
    statement, never a module named in a string; every suite module (``bench*.py`` beside a
    layer's code, or a module of bench/ with a ``run``) is registered, and none sits in cli/."""
    registry = ROOT / "bench" / "suites.py"
    registered = {
        node.module
        for node in ast.walk(ast.parse(registry.read_text()))
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("jackson.")
    }
    suites = {
        _module_name(p)
        for folder in FOLDERS
        if folder != "cli"  # its `jackson bench` command, checked below to hold no suite
        for p in (ROOT / folder).rglob("*.py")
        if p.stem == "bench" or p.stem.startswith("bench_") or p.stem.endswith("_bench")
    }
    for path in (ROOT / "bench").glob("*.py"):
        tree = ast.parse(path.read_text())
        if any(isinstance(n, ast.FunctionDef) and n.name == "run" for n in tree.body):
            suites.add(_module_name(path))
    assert "jackson.protocol.bench" in suites and "jackson.bench.host" in suites
    assert suites - {"jackson.common.bench"} == registered - {"jackson.common.bench"}
    in_cli = [p for p in (ROOT / "cli").rglob("*.py") if "def run(quick" in p.read_text()]
    assert in_cli == [], "a suite in the command line's folder"
    for path in (ROOT / "bench").rglob("*.py"):
        assert "importlib" not in path.read_text(), f"{path}: loads a module by name"


# the PCA9685's datasheet facts (register map, bits, power-on values, oscillator, Eq. 1), which
# the host's driver and the twin's register model both import
PCA9685_FACTS = ROOT / "protocol" / "pca9685.py"


def test_the_pca9685_register_map_is_written_once() -> None:
    """Every name protocol/pca9685.py defines (``MODE1``, ``LED0_ON_L``, ``PRE_SCALE``,
    ``MODE1_SLEEP``, ``prescale_for``, ...) is assigned or defined nowhere else: the driver and
    the twin import them, so the two can never disagree about the chip."""
    facts = set()
    for node in ast.parse(PCA9685_FACTS.read_text()).body:
        if isinstance(node, ast.FunctionDef):
            facts.add(node.name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            facts |= {t.id for t in targets if isinstance(t, ast.Name) and t.id.isupper()}
    assert {"MODE1", "MODE2", "LED0_ON_L", "ALL_LED_OFF_H", "PRE_SCALE", "MODE1_SLEEP"} <= facts
    assert {"LED_FULL", "OSC_CLOCK_HZ", "prescale_for"} <= facts
    found = []
    folders = dict.fromkeys((*FOLDERS, "tools", "tests", "ros2"))
    for folder in folders:
        for path in sorted((ROOT / folder).rglob("*.py")):
            if path == PCA9685_FACTS:
                continue
            for node in ast.walk(ast.parse(path.read_text(), str(path))):
                names = set()
                if isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
                    names = {node.id}
                elif isinstance(node, (ast.FunctionDef, ast.ClassDef)):
                    names = {node.name}
                found += [f"{path.relative_to(ROOT)}:{node.lineno}: {n}" for n in names & facts]
    assert not found, "import it from jackson.protocol.pca9685: " + "; ".join(found)


def test_one_navstate_class_in_the_package() -> None:
    """The estimate a mission steers by is ``NavState`` (host/control/base.py); the navigator's
    own state machine has a name of its own (``NavigatorState``)."""
    found = [
        f"{path.relative_to(ROOT)}:{node.lineno}"
        for folder in FOLDERS
        for path in sorted((ROOT / folder).rglob("*.py"))
        for node in ast.walk(ast.parse(path.read_text(), str(path)))
        if isinstance(node, ast.ClassDef) and node.name == "NavState"
    ]
    assert [f.split(":")[0] for f in found] == ["host/control/base.py"], found


def test_dwb_controller_frequency_is_the_telemetry_rate_not_a_literal() -> None:
    """The navigator steps once per telemetry frame: DWB's control period comes from the
    schema's telemetry rate (protocol/schema.yaml), not from a number of its own."""
    from jackson.host.nav.dwb import DwbConfig
    from jackson.protocol.messages import TELEMETRY_RATE_HZ_DEFAULT

    path = ROOT / "host" / "nav" / "dwb" / "core" / "config.py"
    (cls,) = (
        n
        for n in ast.parse(path.read_text()).body
        if isinstance(n, ast.ClassDef) and n.name == "DwbConfig"
    )
    (default,) = (
        n.value
        for n in cls.body
        if isinstance(n, ast.AnnAssign)
        and isinstance(n.target, ast.Name)
        and n.target.id == "controller_frequency_hz"
    )
    assert default is not None
    literals = [n for n in ast.walk(default) if isinstance(n, ast.Constant)]
    assert not literals, f"{path}: controller_frequency_hz = {ast.unparse(default)}"
    assert DwbConfig().controller_frequency_hz == TELEMETRY_RATE_HZ_DEFAULT


def test_the_align_critics_derive_from_the_distance_critics() -> None:
    """As in Nav2's DWB: PathAlign is a PathDist and GoalAlign a GoalDist, each scored at a
    point projected ahead; all four read a distance map as MapGrid critics."""
    from jackson.host.nav.dwb.critics import (
        GoalAlignCritic,
        GoalDistCritic,
        PathAlignCritic,
        PathDistCritic,
    )
    from jackson.host.nav.dwb.critics.map_grid import MapGridCritic

    assert issubclass(PathAlignCritic, PathDistCritic)
    assert issubclass(GoalAlignCritic, GoalDistCritic)
    assert issubclass(PathDistCritic, MapGridCritic) and issubclass(GoalDistCritic, MapGridCritic)
    for cls in (PathAlignCritic, GoalAlignCritic, PathDistCritic, GoalDistCritic):
        assert "score" not in vars(cls), f"{cls.__name__} scores by a copy of MapGrid's score"


def test_the_a1m8_scan_period_is_written_once() -> None:
    """The A1M8's turn (0.13465 s, REFERENCE: LiDAR scan period) is
    ``jackson.protocol.rplidar.A1M8_SCAN_PERIOD_S``: the host's driver, its scan stamps, the
    health monitor's silence test, the ROS messages and the twin's emulator read it there
    (docstrings may quote it; code may not)."""
    found = sorted(
        path.relative_to(ROOT).as_posix()
        for folder in FOLDERS
        for path in (ROOT / folder).rglob("*.py")
        for node in ast.walk(ast.parse(path.read_text()))
        if isinstance(node, ast.Constant) and node.value == 0.13465
    )
    assert found == ["protocol/rplidar/packets.py"]
