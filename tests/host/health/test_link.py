"""The link: frames lost by SEQ over ``link_window_s`` make it suspect, and it recovers."""

from __future__ import annotations

from jackson.host.health import Health

from .synthetic import DT, monitor


def test_one_frame_lost_now_and_then_is_no_fault() -> None:
    mon = monitor()
    for k in range(2000):  # 100 s, a frame lost every 10 s: 0.5 % of a window
        mon.link(k * DT, 1 if k % 200 == 199 else 0)
    assert mon.state("link") is Health.OK and mon.transitions == []


def test_lost_frames_make_the_link_suspect_until_well_under_the_fraction() -> None:
    mon = monitor()
    t = 0.0
    for k in range(200):  # 10 s clean
        t = k * DT
        mon.link(t, 0)
    mon.link(t + DT, 3)  # 3 lost of the window's ~100: 3 %
    assert mon.state("link") is Health.SUSPECT and "3 of" in mon.reason("link")
    assert mon.state("imu") is Health.OK  # the link only
    for k in range(2, 200):
        mon.link(t + k * DT, 0)
    # the loss leaves the 5 s window, then recover_s of passing frames
    assert mon.state("link") is Health.OK
    assert [x.new for x in mon.transitions] == [Health.SUSPECT, Health.OK]
