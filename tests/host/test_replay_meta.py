"""What a navigation run's ``meta.json`` records of its particle filter and of the mapper's map
handed to the planner, and what a replay of a run from before it was recorded takes instead."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

from jackson.host.control.navigate import NavigateConfig, navigate_meta
from jackson.host.nav.amcl import AmclConfig
from jackson.host.nav.types import Pose2D
from jackson.host.recording import RecordingError
from jackson.host.replay import _navigation_from_meta


def _meta(config: NavigateConfig) -> dict[str, object]:
    entry = navigate_meta(config)
    entry["map"] = None  # no map file in these folders
    return {"navigate": json.loads(json.dumps(entry))}  # through JSON, as on disk


def test_a_run_replays_with_the_particle_filter_it_recorded(tmp_path: Path) -> None:
    amcl = AmclConfig(alpha3=0.07, max_beams=45)
    config = NavigateConfig(start=Pose2D(0.5, 0.2, 0.1), goals=(Pose2D(1.0, 1.0, 0.0),), amcl=amcl)
    back, grid = _navigation_from_meta(tmp_path, _meta(config))
    assert back.amcl == amcl and back == config and grid is None


def test_a_run_from_before_the_filter_was_recorded_replays_with_nav2s_translation_noise(
    tmp_path: Path,
) -> None:
    meta = _meta(NavigateConfig(start=Pose2D(0.0, 0.0, 0.0), goals=()))
    del meta["navigate"]["amcl"]  # type: ignore[attr-defined]
    back, _ = _navigation_from_meta(tmp_path, meta)
    assert back.amcl == dataclasses.replace(AmclConfig(), alpha3=0.2, alpha4=0.2)
    assert AmclConfig().alpha3 == 0.05  # what runs record now


@pytest.mark.parametrize("entry", [[1, 2], {"alpha3": -1.0}, {"no_such": 1}])
def test_a_damaged_filter_entry_is_one_clear_error(tmp_path: Path, entry: object) -> None:
    meta = _meta(NavigateConfig(start=Pose2D(0.0, 0.0, 0.0), goals=()))
    meta["navigate"]["amcl"] = entry  # type: ignore[index]
    with pytest.raises(RecordingError, match=r"meta\.json: navigate"):
        _navigation_from_meta(tmp_path, meta)


def test_a_mapping_run_replays_with_the_map_hand_over_it_recorded(tmp_path: Path) -> None:
    config = NavigateConfig(
        start=Pose2D(0.0, 0.0, 0.0), goals=(), localisation="slam", map_update_s=2.5
    )
    back, _ = _navigation_from_meta(tmp_path, _meta(config))
    assert back.map_update_s == 2.5 and back == config
    meta = _meta(config)
    del meta["navigate"]["map_update_s"]  # type: ignore[attr-defined]
    back, _ = _navigation_from_meta(tmp_path, meta)
    assert back.map_update_s == 0.0  # from before: the planner never took the mapper's map
    meta["navigate"]["map_update_s"] = -1.0  # type: ignore[index]
    with pytest.raises(RecordingError, match=r"meta\.json: navigate: .*map_update_s"):
        _navigation_from_meta(tmp_path, meta)
