"""``jackson campaign fidelity``: statistics and verdicts, the page and its figure, the
mechanisms' patches, the ablation's runs, and one real run on the twin through the CLI."""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from jackson.experiments import fidelity as fd
from jackson.experiments.fidelity import (
    BRINGUP_CONFIG,
    FIGURES,
    MECHANISMS,
    STAGE3_FIGURES,
    FidelityError,
    FidelityReport,
    Mechanism,
    MechanismError,
    ablate,
    agreement,
    assess,
    deep_merge,
    fidelity_markdown,
    figure_result,
    nav_outcome,
    seed_set,
    seed_sets,
    write_report_files,
)
from jackson.experiments.fidelity import run as fidelity_run
from jackson.experiments.paper_figures import PAPER
from jackson.sim.config import load_robot

EKF_CLOSURE = FIGURES[0]  # square, 1.18 ± 0.96 cm
T_NAV = STAGE3_FIGURES[0]  # 22.405 ± 0.816 s


def _trials(key: str, values: Sequence[float | None], failed: Sequence[float] = ()) -> list[Any]:
    """Completed trials with ``values`` of ``key`` (None: the metric missing), then failed ones."""
    done = [{"completed": True, **({} if v is None else {key: v})} for v in values]
    return done + [{"completed": False, key: v} for v in failed]


SPREAD = (-1.5, -1.0, -0.5, -0.25, 0.0, 0.0, 0.25, 0.5, 1.0, 1.5)  # mean 0


def _synthetic(
    mean_in_sds: float = 0.5, sd_ratio: float = 1.0, spread: Sequence[float] = SPREAD
) -> dict[str, list[Any]]:
    """A trial per ``spread`` value and stage whose every figure lies ``mean_in_sds`` paper SDs
    above the paper's mean with ``sd_ratio`` times its SD."""
    k = sd_ratio / float(np.std(spread, ddof=1))
    runs: dict[str, list[Any]] = {"square": [], "figure8": [], "maze": []}
    for mission, trials in runs.items():
        for i, s in enumerate(spread):
            r: dict[str, Any] = {"trial": i, "completed": True, "collisions": 0}
            for f in (*FIGURES, *STAGE3_FIGURES):
                if f.mission == mission:
                    r[f.key] = f.paper_mean + (mean_in_sds + k * s) * f.paper_sd
            trials.append(r)
    return runs


def _report(runs: dict[str, list[Any]]) -> FidelityReport:
    """The report of ``runs`` (a stage missing from them: not run) on jackson_physical."""
    figures, stage3, nav = assess(runs)
    return FidelityReport(
        command="jackson campaign fidelity --trials 10 --seed 0 --docs docs/fidelity.md",
        robot="jackson_physical",
        trials=10,
        seed=0,
        stages=tuple(s for s in fd.STAGES if s in runs),
        figures=figures,
        stage3=stage3,
        nav=nav,
        mechanisms=MECHANISMS,
        robot_doc=yaml.safe_load(fd.robot_file("jackson_physical").read_text()),
    )


# ------------------------------------------------------------------------- the figures


def test_the_16_figures_are_the_pages_in_its_order() -> None:
    assert len(FIGURES) == 16
    assert [f.mission for f in FIGURES] == ["square"] * 7 + ["figure8"] * 9
    assert [f.table for f in FIGURES] == ["T5"] * 3 + ["T11"] + ["T5"] * 3 + ["T6"] * 4 + [
        "T7",
        "T13",
        "T6",
        "T6",
        "T6",
    ]
    assert FIGURES[11].paper_text == "207.00 ± 26.00" and FIGURES[7].paper_text == "1.0795 ± 0.0167"


def test_the_figures_agree_with_the_campaign_reports_paper_figures() -> None:
    """The paper's numbers are written twice (here and in paper_figures.PAPER): they must agree."""
    compared = 0
    for f in FIGURES:
        physical = PAPER[f.mission].get(f.key, (None, None))[0]
        if physical is not None:
            assert (physical.mean, physical.sd) == (f.paper_mean, f.paper_sd), f.heading
            compared += 1
    assert compared == 14  # all but the two cross-track RMSEs


# ------------------------------------------------------------------------- statistics


def test_only_completed_trials_enter_the_statistics() -> None:
    row = figure_result(EKF_CLOSURE, _trials("ekf_closure_cm", [1.0, 2.0, 3.0, None], [50.0]))
    assert (row.attempted, row.completed, row.n) == (5, 4, 3)
    assert row.mean == 2.0 and row.sd == 1.0
    assert row.z == pytest.approx((2.0 - 1.18) / 0.96)
    assert row.within is True
    assert row.sd_ratio == pytest.approx(1.0 / 0.96) and row.sd_ok is True
    assert row.quartiles == (2.0, 1.5, 2.5)


def test_a_stage_1_2_figure_is_within_one_sd_a_stage_3_figure_within_two() -> None:
    at_1_5_sd = 1.5
    square = figure_result(EKF_CLOSURE, _trials("ekf_closure_cm", [1.18 + at_1_5_sd * 0.96] * 2))
    nav = figure_result(T_NAV, _trials("t_nav_s", [22.405 + at_1_5_sd * 0.816] * 2))
    assert square.z == pytest.approx(1.5) and square.within is False
    assert nav.z == pytest.approx(1.5) and nav.within is True
    assert figure_result(T_NAV, _trials("t_nav_s", [22.405 - 2.1 * 0.816])).within is False


def test_the_sd_ratio_passes_within_half_to_twice_the_papers() -> None:
    def ratio_ok(sd: float) -> bool | None:
        return figure_result(EKF_CLOSURE, _trials("ekf_closure_cm", [1.0 - sd, 1.0 + sd])).sd_ok

    sd_for = 0.96 / math.sqrt(2)  # two values 1 -+ d have an SD of d sqrt(2)
    assert ratio_ok(0.49 * sd_for) is False
    assert ratio_ok(0.51 * sd_for) is True
    assert ratio_ok(1.99 * sd_for) is True
    assert ratio_ok(2.01 * sd_for) is False
    one = figure_result(EKF_CLOSURE, _trials("ekf_closure_cm", [1.0]))
    assert one.within is True and one.sd_ok is None and math.isnan(one.sd)


def test_a_figure_whose_trials_all_failed_says_so() -> None:
    failed = figure_result(EKF_CLOSURE, _trials("ekf_closure_cm", [], [1.0, 2.0, 3.0]))
    assert (failed.attempted, failed.completed, failed.n) == (3, 0, 0)
    assert failed.within is None and failed.sd_ok is None and math.isnan(failed.mean)
    assert failed.missing == "no completed trial (0/3)"
    assert figure_result(EKF_CLOSURE, []).missing == "not run"
    assert failed.as_json()["mean"] is None and failed.as_json()["within"] is None


def test_nan_and_missing_values_are_left_out() -> None:
    row = figure_result(T_NAV, _trials("t_nav_s", [22.0, math.nan, None, 23.0]))
    assert row.values == (22.0, 23.0) and row.completed == 4


def test_the_counts_need_the_mean_within_and_then_the_sd_too() -> None:
    rows = [
        figure_result(EKF_CLOSURE, _trials("ekf_closure_cm", [1.0, 1.9])),  # within, SD ok
        figure_result(EKF_CLOSURE, _trials("ekf_closure_cm", [1.0, 1.01])),  # within, SD small
        figure_result(EKF_CLOSURE, _trials("ekf_closure_cm", [9.0, 10.0])),  # outside
        figure_result(EKF_CLOSURE, _trials("ekf_closure_cm", [], [1.0])),  # all failed
    ]
    a = agreement(rows)
    assert (a.within, a.within_and_sd, a.total, a.sd_ok) == (2, 1, 4, 2)  # outside, SD ok


def test_each_set_of_ten_seeds_is_judged_alone() -> None:
    # 30 trials of one figure: the first ten far above the band, the other twenty in it
    values = [1.18 + 3 * 0.96] * 10 + [1.18 + 0.96 * s for s in SPREAD] * 2
    runs = [{"completed": True, "seed": 500 + i, "ekf_closure_cm": v} for i, v in enumerate(values)]
    row = figure_result(EKF_CLOSURE, runs)
    assert row.seeds == tuple(range(500, 530))
    sets = seed_sets([row], 500, 30)
    assert [(s.first, s.last, s.agreement.within) for s in sets] == [
        (500, 509, 0),
        (510, 519, 1),
        (520, 529, 1),
    ]
    assert seed_set(row, 510, 519).values == tuple(values[10:20])
    assert agreement([row]).within == 1  # pooled: 1.18 + 1.0 SD
    assert seed_sets([row], 500, 10) == ()  # one set: nothing to split
    unknown = figure_result(
        EKF_CLOSURE, [{k: v for k, v in r.items() if k != "seed"} for r in runs]
    )
    assert unknown.seeds == () and seed_sets([unknown], 500, 30) == ()


def test_stage_3_success_and_contacts_count_every_attempted_run() -> None:
    runs = [
        {"completed": True, "collisions": 0},
        {"completed": False, "collisions": 2},
        {"completed": True, "collisions": 0},
    ]
    nav = nav_outcome(runs)
    assert (nav.attempted, nav.completed, nav.contacts) == (3, 2, 2)
    assert not nav.success_within and not nav.contacts_within
    assert nav_outcome(runs[:1]).success_within and nav_outcome(runs[:1]).contacts_within


# ------------------------------------------------------------------------- the page and figure


def test_the_page_holds_the_tables_and_the_counts_line() -> None:
    runs = _synthetic(0.5, 1.0)
    runs["square"][0]["ekf_closure_cm"] = 1.18 + 9 * 0.96  # one far trial: outside, SD too big
    runs["figure8"] = [{**r, "completed": False} for r in runs["figure8"]]  # every trial failed
    report = _report(runs)
    page = fidelity_markdown(report, "page.png", "## Why\n\nHand-written.\n")
    lines = page.splitlines()
    assert lines[0] == "# Fidelity: `jackson_physical` against the paper's physical robot"
    assert "jackson campaign fidelity --trials 10 --seed 0 --docs docs/fidelity.md" in lines
    square_rmse = figure_result(FIGURES[2], runs["square"])
    assert (
        f"| square | EKF RMSE to the nominal square [cm] (T5) | 2.46 ± 0.36 | "
        f"{square_rmse.mean:.2f} ± {square_rmse.sd:.2f} | +0.50 (yes) | 1.00 (ok) |"
    ) in lines
    ekf = [line for line in lines if line.startswith("| square | EKF closure [cm] (T5) |")]
    assert len(ekf) == 1 and "(no)**" in ekf[0] and "(not)**" in ekf[0]
    assert (
        "| figure-eight | duration [s] (T6) | 96.43 ± 2.07 | no completed trial (0/10) | — | — |"
    ) in lines
    counts = (
        "6 of 16 within the paper's mean ± 1 SD; 6 of them also with an SD within 0.5\u20132\u00d7"
    )
    assert f"**{counts} the paper's (6 of 16 with such an SD).**" in lines
    assert not any(line.startswith("Each set of ten seeds") for line in lines)  # 10 trials
    assert (
        "Trials completed (only these enter the statistics): square 10/10, figure-eight 0/10, "
        "Stage 3 10/10."
    ) in lines
    assert "| success (P_success) (T14) | 10/10 | 10/10 | 10/10 | — | yes |" in lines
    assert "| contacts (C_count) (T14) | 0 | 0 | 0 | — | yes |" in lines
    t_nav = next(line for line in lines if line.startswith("| t_nav [s] (T14) | 22.405 ± 0.816 |"))
    assert "| median 13.317 |" in t_nav and t_nav.endswith("| +0.50 (yes) |")
    for m in MECHANISMS:
        assert any(line.startswith(f"| `{m.name}` |") for line in lines), m.name
    assert "| `caster_drag` |" in page and "robot `caster_rolling_coeff: 0.067 -> 0.0`" in page
    assert "robot `motor.gain.left: 0.992 -> 1.0`" in page
    assert "Ablation" not in page  # not run
    assert "](page.png)" in page
    assert page.endswith("\n## Why\n\nHand-written.\n")  # the notes verbatim, last


def test_a_campaign_of_thirty_shows_each_set_of_ten_seeds() -> None:
    runs: dict[str, list[Any]] = {"square": [], "figure8": [], "maze": []}
    for k, mean_in_sds in enumerate((0.5, 3.0, 0.5)):  # the second set far above every band
        for mission, trials in _synthetic(mean_in_sds).items():
            runs[mission] += [{**r, "seed": 100 + 10 * k + i} for i, r in enumerate(trials)]
    report = dataclasses.replace(_report(runs), trials=30, seed=100)
    page = fidelity_markdown(report, "page.png")
    assert (
        "Each set of ten seeds alone, within the paper's mean ± 1 SD: seeds 100-109: 16 of 16; "
        "seeds 110-119: 0 of 16; seeds 120-129: 16 of 16."
    ) in page.splitlines()


def test_the_report_files_hold_every_number_and_a_figure(tmp_path: Path) -> None:
    runs = _synthetic(1.2, 0.3)
    runs["maze"] = []  # not run
    runs["square"][3]["completed"] = False
    report = _report({k: v for k, v in runs.items() if v})
    write_report_files(tmp_path, report, "notes\n")
    png = tmp_path / "fidelity.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 50_000
    data = json.loads((tmp_path / "fidelity.json").read_text())
    assert data["agreement"] == {"within": 0, "within_and_sd": 0, "sd_ok": 0, "total": 16}
    assert data["seed_sets"] == []
    first = data["figures"][0]
    assert (first["attempted"], first["completed"], first["n"]) == (10, 9, 9)
    assert first["paper"] == {"mean": 1.18, "sd": 0.96, "isaac": None}
    assert first["within"] is False and first["sd_ok"] is False
    assert data["stage3"]["attempted"] == 0 and data["stage3"]["figures"][0]["missing"] == "not run"
    assert [m["name"] for m in data["mechanisms"]] == [m.name for m in MECHANISMS]
    page = (tmp_path / "fidelity.md").read_text()
    assert "Not run (`--stages` without `maze`)." in page and "](fidelity.png)" in page


# ------------------------------------------------------------------------- mechanisms


def test_deep_merge_merges_mappings_and_replaces_the_rest() -> None:
    base = {"a": 1, "motor": {"gain": {"left": 0.99, "right": 1.0}, "battery_v": 6.0}, "l": [1]}
    merged = deep_merge(base, {"motor": {"gain": {"left": 1.0}}, "l": [2], "new": {"x": 0}})
    assert merged == {
        "a": 1,
        "motor": {"gain": {"left": 1.0, "right": 1.0}, "battery_v": 6.0},
        "l": [2],
        "new": {"x": 0},
    }
    assert base["motor"] == {"gain": {"left": 0.99, "right": 1.0}, "battery_v": 6.0}  # unchanged


def test_every_mechanism_switches_off_something_of_jackson_physical() -> None:
    ablated = ablate(MECHANISMS, "jackson_physical", BRINGUP_CONFIG)
    assert [a.mechanism.name for a in ablated] == [m.name for m in MECHANISMS]
    by_name = {a.mechanism.name: a for a in ablated}
    assert by_name["tyre_creep_scrub"].robot["tyre"]["longitudinal_compliance"] == 0.0
    assert by_name["tyre_creep_scrub"].robot["tyre"]["scrub_saturation_curvature_1_m"] == 14.5
    assert by_name["left_drive_weaker"].robot["motor"]["gain"] == {"left": 1.0, "right": 1.0}
    assert by_name["trial_variation"].robot["variation"]["floor_patch_size_m"] == 5.0
    bringup = yaml.safe_load(BRINGUP_CONFIG.read_text())
    robot_only = [a for a in ablated if not a.mechanism.config_patch]
    assert robot_only and all(a.config == bringup for a in robot_only)
    assert by_name["deceleration_limits"].config["limits"] == {
        "max_decel_m_s2": 1.0,
        "max_alpha_decel_rad_s2": 6.0,
    }
    assert by_name["navigation_top_speed"].config["navigation"] == {"max_vel_x_m_s": None}
    assert by_name["navigation_top_speed"].robot == by_name["deceleration_limits"].robot


@pytest.mark.parametrize(
    ("robot_patch", "config_patch", "says"),
    [
        (
            {"tyre": {"scrub_arm": 0.0}},
            {},
            "mechanism bad: robot jackson_physical.yaml: tyre.scrub_arm: unknown field",
        ),
        (
            {"imu": {"yaw_scale": -1.0}},
            {},
            "mechanism bad: robot jackson_physical.yaml: imu.yaw_scale: expected a number in ",
        ),
        (
            {},
            {"limits": {"no_such_limit": 1.0}},
            "mechanism bad: config (the defaults): limits.no_such_limit: unknown field",
        ),
        ({}, {}, "mechanism bad: its patch is empty"),
    ],
)
def test_a_patch_that_does_not_fit_is_refused_before_anything_runs(
    robot_patch: dict[str, Any], config_patch: dict[str, Any], says: str, tmp_path: Path
) -> None:
    bad = Mechanism("bad", "what", "source", robot_patch, config_patch)
    with pytest.raises(MechanismError) as info:
        fd.run_fidelity(1, tmp_path / "out", ablation=True, mechanisms=(*MECHANISMS[:1], bad))
    assert str(info.value).startswith(says), str(info.value)
    assert not (tmp_path / "out").exists()


# ------------------------------------------------------------------------- the ablation's runs


def test_the_ablation_runs_each_mechanism_on_its_own_files_with_the_same_seeds(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The campaigns replaced by stand-ins that read the robot file they are given: the
    caster's drag sets the square's duration (0.067 -> the paper's, 0 -> 3 SD short)."""
    calls: list[tuple[str, str, int]] = []

    def campaign(mission: str, trials: int, out: Path, **kw: Any) -> list[dict[str, Any]]:
        robot = load_robot(kw["robot"])
        calls.append((mission, out.relative_to(tmp_path).as_posix(), kw["seed"]))
        runs = _synthetic(0.0, 1.0, (-0.5, 0.0, 0.5))[mission][:trials]
        for r in runs:
            if mission == "square" and robot.caster_rolling_coeff == 0.0:
                r["duration_s"] -= 3 * 0.26
        return runs

    def stage3(name: str, trials: int, out: Path, **kw: Any) -> list[dict[str, Any]]:
        return campaign("maze", trials, out, **kw)

    monkeypatch.setattr(fidelity_run, "run_campaign", campaign)
    monkeypatch.setattr(fidelity_run, "run_stage3_campaign", stage3)
    monkeypatch.setattr(fidelity_run, "plot_fidelity", lambda png, report: png.write_bytes(b"png"))
    mechanisms = (
        *MECHANISMS[1:3],
        Mechanism("latency_maze", "w", "s", {"actuation_latency_s": 0.0}, stage3=True),
    )
    report = fd.run_fidelity(
        3, tmp_path / "out", seed=7, ablation=True, mechanisms=mechanisms, progress=False
    )
    assert calls == [
        ("square", "out/square", 7),
        ("figure8", "out/figure8", 7),
        ("maze", "out/maze", 7),
        ("square", "out/ablation/caster_drag/square", 7),
        ("figure8", "out/ablation/caster_drag/figure8", 7),
        ("maze", "out/ablation/caster_drag/maze", 7),
        ("square", "out/ablation/left_drive_weaker/square", 7),
        ("figure8", "out/ablation/left_drive_weaker/figure8", 7),
        ("square", "out/ablation/latency_maze/square", 7),
        ("figure8", "out/ablation/latency_maze/figure8", 7),
        ("maze", "out/ablation/latency_maze/maze", 7),
    ]
    folder = tmp_path / "out" / "ablation" / "caster_drag"
    assert yaml.safe_load((folder / "robot.yaml").read_text())["caster_rolling_coeff"] == 0.0
    assert yaml.safe_load((folder / "config.yaml").read_text()) == {}
    assert load_robot(folder / "robot.yaml").tyre.scrub_arm_m == 0.0072  # the rest as it was
    columns = {c.mechanism.name: c for c in report.ablation}
    duration = 3  # the square's duration
    assert report.figures[duration].within and not columns["caster_drag"].figures[duration].within
    assert columns["left_drive_weaker"].figures[duration].within
    assert columns["left_drive_weaker"].figures[16].missing == "not run"  # no maze
    assert columns["latency_maze"].figures[16].n == 3
    page = (tmp_path / "out" / "fidelity.md").read_text()
    assert (
        "| square | duration [s] (T11) | 47.52 ± 0.26 | 47.52 | **46.74** | 47.52 | 47.52 |"
    ) in page.splitlines()
    assert "| Stage 3 | t_nav [s] (T14) |" in page  # a mechanism ran the maze
    assert "--ablation" in report.command


def test_an_ablation_on_fewer_trials_runs_the_first_seeds_and_compares_like_with_like(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    calls: list[tuple[str, int, int]] = []

    def campaign(mission: str, trials: int, out: Path, **kw: Any) -> list[dict[str, Any]]:
        calls.append((mission, trials, kw["seed"]))
        runs = _synthetic(0.0, 1.0, (-1.0, 0.0, 1.0))[mission][:trials]
        return [{**r, "seed": kw["seed"] + i} for i, r in enumerate(runs)]

    monkeypatch.setattr(fidelity_run, "run_campaign", campaign)
    monkeypatch.setattr(fidelity_run, "plot_fidelity", lambda png, report: png.write_bytes(b"png"))
    report = fd.run_fidelity(
        3,
        tmp_path / "out",
        seed=40,
        ablation=True,
        ablation_trials=2,
        stages=("square",),
        mechanisms=MECHANISMS[1:2],
        progress=False,
    )
    assert calls == [("square", 3, 40), ("square", 2, 40)]
    assert report.command.endswith("--ablation 2") and report.ablation_seeds == (40, 41)
    duration = report.figures[3]  # 47.52 - 0.26, 47.52, 47.52 + 0.26
    first_two = f"{(2 * 47.52 - 0.26) / 2:.2f}"
    row = next(
        line
        for line in (tmp_path / "out" / "fidelity.md").read_text().splitlines()
        if line.startswith("| square | duration [s] (T11) | 47.52 ± 0.26 |")
        and "±" not in line[40:]
    )
    assert row.split(" | ")[3] == first_two != f"{duration.mean:.2f}"  # the full model, seeds 40-41
    assert "on the full model's seeds 40-41;" in (tmp_path / "out" / "fidelity.md").read_text()
    with pytest.raises(FidelityError, match="the ablation's trials must be 1-3"):
        fd.run_fidelity(3, tmp_path / "x", ablation=True, ablation_trials=4, progress=False)


# ------------------------------------------------------------------------- on the twin


def test_jackson_campaign_fidelity_on_the_twin(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capfd: pytest.CaptureFixture[str]
) -> None:
    """One square through the command line (a figure-eight too would double the test's 20 s):
    the report folder, the page written to --docs with its PNG beside it, the notes at its
    end, the figures of the stages not run marked so."""
    from jackson.main import main

    monkeypatch.chdir(tmp_path)
    (tmp_path / "docs").mkdir()
    (tmp_path / "notes.md").write_text("## Notes\n\nWhy the misses.\n")
    rc = main(
        [
            "campaign",
            "fidelity",
            "--trials",
            "1",
            "--stages",
            "square",
            "--out",
            "build/fid",
            "--docs",
            "docs/twin.md",
            "--notes",
            "notes.md",
        ]
    )
    captured = capfd.readouterr()
    assert rc == 0, captured.err
    out = tmp_path / "build" / "fid"
    for name in ("square/runs.json", "square/summary.md", "fidelity.json", "fidelity.png"):
        assert (out / name).exists(), name
    assert not (out / "figure8").exists() and not (out / "maze").exists()
    data = json.loads((out / "fidelity.json").read_text())
    assert data["stages"] == ["square"]
    assert [f["n"] for f in data["figures"]] == [1] * 7 + [0] * 9
    assert data["figures"][3]["mean"] == pytest.approx(47.5, abs=1.0)  # the square's duration
    page = (tmp_path / "docs" / "twin.md").read_text()
    assert (tmp_path / "docs" / "twin.png").stat().st_size > 50_000
    command = (
        "jackson campaign fidelity --trials 1 --seed 0 --stages square --docs docs/twin.md "
        "--notes notes.md"
    )
    assert command in page.splitlines()
    assert "](twin.png)" in page and page.endswith("## Notes\n\nWhy the misses.\n")
    assert "| square | duration [s] (T11) | 47.52 ± 0.26 |" in page
    assert "| figure-eight | duration [s] (T6) | 96.43 ± 2.07 | not run | — | — |" in page
    assert str(tmp_path) not in page and str(tmp_path) not in (out / "fidelity.md").read_text()
    phases = [line for line in captured.err.splitlines() if line.startswith("fidelity: ")]
    assert phases[0] == "fidelity: square, 1 trial (seed 0) -> build/fid/square"
    assert phases[1].startswith("fidelity: report -> build/fid/fidelity.md")
    assert phases[2] == "fidelity: page -> docs/twin.md, docs/twin.png"
    assert any(line.startswith("[1/1] square seed 0") for line in captured.err.splitlines())


def test_a_failed_mapping_run_is_reported_not_raised(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from jackson.experiments.stage3 import MappingError

    def stage3(name: str, trials: int, out: Path, **kw: Any) -> list[dict[str, Any]]:
        raise MappingError("the mapping run failed: lockstep stalled")

    monkeypatch.setattr(fidelity_run, "run_stage3_campaign", stage3)
    monkeypatch.setattr(fidelity_run, "plot_fidelity", lambda png, report: png.write_bytes(b"png"))
    report = fd.run_fidelity(2, tmp_path / "out", stages=("maze",), progress=False)
    assert report.nav.failure == "the mapping run failed: lockstep stalled"
    assert report.nav.attempted == 0 and not report.nav.success_within
    page = (tmp_path / "out" / "fidelity.md").read_text().splitlines()
    assert "No navigation ran: the mapping run failed: lockstep stalled." in page
    assert "| success (P_success) (T14) | 10/10 | 10/10 | 0/0 | — | **no** |" in page
    assert all(r.missing == "not run" for r in report.figures)


def test_mechanisms_a_configuration_lacks_are_left_out_of_its_ablation() -> None:
    """With the packaged configuration (no bringup limits, square controller or top speed)
    those mechanisms are not ablated, and said so; without the list to collect them they are an
    error."""
    inactive: list[str] = []
    ablated = ablate(MECHANISMS, "jackson_physical", None, inactive)
    assert inactive == ["deceleration_limits", "square_controller", "navigation_top_speed"]
    assert [a.mechanism.name for a in ablated] == [
        m.name for m in MECHANISMS if m.name not in inactive
    ]
    with pytest.raises(MechanismError, match="deceleration_limits: its patch switches nothing"):
        ablate(MECHANISMS, "jackson_physical", None)


def test_the_checks_are_shown_but_not_counted() -> None:
    runs = _synthetic(0.5, 1.0)
    for r in runs["square"]:
        r["ekf_path_m"] = 4.133 + 0.1  # +5 SD: outside, and the count must not move
    report = dataclasses.replace(
        _report(runs),
        checks=tuple(figure_result(f, runs.get(f.mission, ())) for f in fd.CHECKS),
    )
    assert report.agreement.total == 16 and report.agreement.within == 16
    lines = fidelity_markdown(report).splitlines()
    assert (
        "| square | EKF path length [m] (T5) | 4.133 ± 0.020 | 4.233 ± 0.000 | **+5.00 (no)** |"
        in lines
    )
    assert not any(line.startswith("| figure-eight | EKF path length") for line in lines)  # none
    assert fd.report_json(report)["checks"][0]["key"] == "ekf_path_m"
