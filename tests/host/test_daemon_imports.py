"""A daemon loads only what its mission uses: driving the square, neither the navigation stack
(0.1-0.3 s of imports) at start nor anything inside the frame loop, where an import is a
stall of several frames."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from jackson.common.lazy import instance_of

CODE = """
import sys
from jackson.main import main
sys.argv = ["jackson", "run", "square", "--out", sys.argv[1]]
code = main()
print("NAVIGATION", sorted(m for m in sys.modules if m.startswith(("jackson.host.control.navigat",
      "jackson.host.service.navigation", "jackson.host.nav.costmap", "jackson.host.nav.dwb"))))
sys.exit(code)
"""


def test_a_square_run_loads_no_navigation(tmp_path: Path) -> None:
    done = subprocess.run(
        [sys.executable, "-c", CODE, str(tmp_path / "square")],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert done.returncode == 0, done.stdout + done.stderr
    assert "NAVIGATION []" in done.stdout, done.stdout[-500:]
    assert (tmp_path / "square" / "bag").is_dir()  # the run recorded (and sent diagnostics)


def test_instance_of_tests_loaded_classes_and_loads_nothing() -> None:
    assert instance_of(Path("x"), "pathlib", "PurePath")
    assert not instance_of(3, "pathlib", "PurePath")
    assert not instance_of(3, "jackson.no_such_module", "Anything")
    assert "jackson.no_such_module" not in sys.modules
