"""The sensors' states: ok -> suspect -> excluded -> recovered -> ok, with their hysteresis."""

from __future__ import annotations

from jackson.host.health import Health, HealthConfig, Transition
from jackson.host.health.states import Recent, SensorStates
from jackson.host.health.types import failing, passing


def _run(states: SensorStates, *found: object) -> list[Transition]:
    out: list[Transition] = []
    states.apply(found, out)  # type: ignore[arg-type]
    states.commit(out)
    return out


def test_a_suspect_sensor_is_ok_again_after_recover_s_without_a_failure() -> None:
    st = SensorStates(HealthConfig())  # recover_s 2 s
    _run(st, failing("imu", 1.0, "a spike", exclude=False))
    assert st["imu"] is Health.SUSPECT and st.reason("imu") == "a spike"
    _run(st, *(passing("imu", 1.0 + 0.05 * k) for k in range(1, 40)))
    assert st["imu"] is Health.SUSPECT  # 1.9 s of passing samples
    (back,) = _run(st, passing("imu", 3.05))
    assert back == Transition(3.05, "imu", Health.SUSPECT, Health.OK, "passed its tests for 2.0 s")


def test_an_excluded_sensor_recovers_then_is_ok_after_recovered_hold_s() -> None:
    st = SensorStates(HealthConfig())
    _run(st, failing("encoder_left", 0.0, "cut", exclude=True))
    _run(st, failing("encoder_left", 0.5, "still cut", exclude=False))  # no change, clean run ends
    assert st["encoder_left"] is Health.EXCLUDED and st.reason("encoder_left") == "cut"
    _run(st, passing("encoder_left", 1.0), passing("encoder_left", 3.0))
    assert st["encoder_left"] is Health.RECOVERED and st["encoder_left"].usable
    _run(st, passing("encoder_left", 12.9))
    assert st["encoder_left"] is Health.RECOVERED
    _run(st, passing("encoder_left", 13.0))
    assert st["encoder_left"] is Health.OK
    assert st.excluded == 1 and [t.new for t in st.transitions] == [
        Health.EXCLUDED,
        Health.RECOVERED,
        Health.OK,
    ]


def test_quiet_and_all_ok_read_the_recorded_transitions_and_states() -> None:
    st = SensorStates(HealthConfig())
    assert st.quiet(0.0) and st.all_ok()
    _run(st, failing("lidar", 5.0, "rough", exclude=False))
    assert not st.all_ok() and not st.quiet(14.9) and st.quiet(15.0)


def test_the_record_keeps_only_the_newest_transitions() -> None:
    kept = Recent(3)
    kept += [1, 2]
    kept.append(3)
    kept += [4, 5]
    assert kept == [3, 4, 5]
    assert kept.added == 5


def test_a_reader_finds_what_was_added_since_even_after_the_record_was_trimmed() -> None:
    kept: Recent[int] = Recent(3)
    kept += [1, 2]
    seen = kept.added
    assert kept.since(seen) == []
    kept.append(3)
    assert kept.since(seen) == [3]
    for k in range(4, 2000):  # far more than the record keeps
        seen = kept.added
        kept.append(k)
        assert kept.since(seen) == [k]
    assert kept.since(kept.added - 10) == [1997, 1998, 1999]  # only the newest are left
