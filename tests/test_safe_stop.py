"""The safe-stop state machine on its own, tick by tick, without a loop or a rig."""
import pytest

from rig.safe_stop import SAFE_SPEED, SETTLE_S, SafeStop


def ticks(stop, t0=0.0, dt=1e-3, n=100000):
    """[(t, command, x)] until done."""
    out = []
    for k in range(n):
        t = t0 + k * dt
        cmd, x = stop.step(t)
        if stop.done:
            return out
        out.append((t, cmd, x))
    raise AssertionError("never done")


def test_a_trip_with_trusted_feedback_moves_slowly_to_the_safe_position_then_settles():
    stop = SafeStop(safe_position=0.040)
    stop.trip("limit: force", x=0.050)
    seq = ticks(stop)
    xs = [x for _, cmd, x in seq if cmd == "follow"]
    assert all(cmd == "follow" for _, cmd, _ in seq) and xs[-1] == 0.040
    steps = [abs(b - a) for a, b in zip(xs, xs[1:])]
    assert max(steps) <= SAFE_SPEED * 1e-3 + 1e-12  # never faster than the safe speed
    t_reached = next(t for t, _, x in seq if x == 0.040)
    assert t_reached == pytest.approx(0.010 / SAFE_SPEED, abs=2e-3)
    assert seq[-1][0] - t_reached == pytest.approx(SETTLE_S, abs=2e-3)


def test_untrusted_feedback_holds_and_the_first_reason_is_kept():
    stop = SafeStop(safe_position=0.040)
    stop.trip("watchdog: x (conditioner): no new data")
    stop.trip("recorder: No space left on device", x=0.03)  # later: neither reason nor state change
    assert stop.reason.startswith("watchdog: x")
    seq = ticks(stop)
    assert {cmd for _, cmd, _ in seq} == {"hold"} and len(seq) == pytest.approx(SETTLE_S / 1e-3, abs=2)


def test_an_error_while_moving_holds_where_it_is():
    stop = SafeStop(safe_position=0.040)
    stop.trip("limit: force", x=0.060)
    assert stop.step(0.0) == ("follow", 0.060)
    stop.step(0.5)
    stop.trip("device 'actuator': CAN send failed")  # the position can no longer be trusted
    assert stop.state == "holding" and stop.reason == "limit: force"
    assert stop.step(0.6) == ("hold", None)
    assert stop.step(0.7) == ("hold", None) and not stop.done
    assert stop.step(0.6 + SETTLE_S) == (None, None) and stop.done


def test_a_later_trusted_error_while_moving_keeps_moving():
    stop = SafeStop(safe_position=0.040)
    stop.trip("T_body (tc): open thermocouple", x=0.045)
    stop.step(0.0)
    stop.trip("device 'tc': Modbus request failed", x=0.0449)
    assert stop.state == "moving"


@pytest.mark.parametrize("x", [float("nan"), float("inf"), None])
def test_a_position_that_is_not_a_number_is_not_trusted(x):
    stop = SafeStop(safe_position=0.040)
    stop.trip("limit", x=x)
    assert stop.state == "holding"


def test_a_virtual_plant_that_fails_every_step_ends_the_run_with_its_fault(monkeypatch):
    """The simulated clock stands still when the plant raises: the stop could never settle
    (the offline prove run once spun forever on a diverged plant)."""
    from proof.on_plant import offline_recording
    from rig.errors import RigError
    from sim_backend.plant import Plant
    step = Plant._step

    def failing(self):
        if self.t > 0.3:
            raise FloatingPointError("plant diverged")
        step(self)
    monkeypatch.setattr(Plant, "_step", failing)
    with pytest.raises(RigError, match="plant diverged"):
        offline_recording()
