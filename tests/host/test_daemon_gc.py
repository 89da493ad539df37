"""The daemon's garbage-collector settings for the frame loop (``GcSettled``)."""

from __future__ import annotations

import gc

from jackson.host.daemon import GC_GEN0_THRESHOLD, GcSettled


def test_set_up_is_frozen_young_collections_are_rare_and_restore_puts_both_back() -> None:
    before = gc.get_threshold()
    settled = GcSettled()
    try:
        assert gc.get_freeze_count() > 0
        assert gc.get_threshold() == (GC_GEN0_THRESHOLD, before[1], before[2])
    finally:
        settled.restore()
    assert gc.get_threshold() == before and gc.get_freeze_count() == 0
