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
    "jackson.common": "common",
    "jackson.protocol": "protocol",
    "jackson.host": "host",
    "jackson.sim": "sim",
    "jackson.calibration": "calibration",
    "jackson.experiments": "experiments",
}
FOLDERS = tuple(MAPPING.values())
# the command-line modules (the top-level package, folder cli/): only cli/ may import them
CLI = tuple(
    sorted(f"jackson.{p.stem}" for p in (ROOT / "cli").glob("*.py") if p.stem != "__init__")
)
LAB = ("jackson.calibration", "jackson.experiments")  # what runs on the twin and in the lab
FORBIDDEN = {  # package folder -> packages it must never import
    "common": ("jackson.protocol", "jackson.host", "jackson.sim", *LAB, *CLI),
    "protocol": ("jackson.host", "jackson.sim", *LAB, *CLI),
    "host": ("jackson.sim", *LAB, *CLI),
    "sim": ("jackson.host", *LAB, *CLI),
    "calibration": ("jackson.experiments", *CLI),
    "experiments": CLI,
}


@pytest.mark.parametrize(("package", "folder"), MAPPING.items())
def test_package_maps_onto_its_folder(package: str, folder: str) -> None:
    module = importlib.import_module(package)
    assert module.__file__ is not None
    assert Path(module.__file__).resolve().parent == ROOT / folder


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
    "host/nav/costmap.py": "the costmaps' inflation, in cells",
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
