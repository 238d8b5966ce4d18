"""Half of a batch on a spare core (uqdrive.numerics.threads.beside): the loop's results computed
by a forked child beside this process only where a caller declared a core spare, errors raised
here, the child reaped whatever happens; the simulator's RK4 passes split that way give every
pair the numbers of one pass, a search's lone item declares the spare core, and a map's last
items borrow the cores its idle workers left."""

import os
import time

import numpy as np
import pytest

from uqdrive.numerics import threads
from uqdrive.numerics.threads import beside, has_spare_core, spare_core
from uqdrive.settings import Settings
from uqdrive.vehicle import augmented
from uqdrive.vehicle.augmented import AugmentedSimulator
from uqdrive.vehicle.effects import ModelStructure, effect

pytestmark = [pytest.mark.skipif(not hasattr(os, "fork"), reason="a spare core's process needs fork (POSIX)"),
              pytest.mark.filterwarnings("ignore:os.fork\\(\\) was called:RuntimeWarning")]


def test_the_second_item_runs_in_a_child_only_within_spare_core():
    here = os.getpid()
    assert beside(lambda i: (i * 3, os.getpid()), [1, 2]) == [(3, here), (6, here)]
    with spare_core():
        assert has_spare_core()
        (a, pid_a), (b, pid_b) = beside(lambda i: (i * 3, os.getpid()), [1, 2])
        with spare_core(False):
            assert not has_spare_core()
        assert has_spare_core()
    assert not has_spare_core()
    assert (a, b, pid_a) == (3, 6, here) and pid_b != here
    with spare_core():
        assert beside(lambda i: i, [5]) == [5]  # not two items: a loop


def test_the_childs_arrays_are_this_processs_own_copy_on_write():
    """The child's arrays come back through a shared memory file, mapped privately: writable here,
    and a process forked later that writes into one changes its own copy only."""
    from uqdrive.inference.parallel import fork_map

    with spare_core():
        _, b = beside(lambda k: np.arange(1000.0) * k, [1, 2])
    np.testing.assert_array_equal(b, np.arange(1000.0) * 2)
    b[1] = 5.0
    assert fork_map(lambda _: (b.__setitem__(0, -1.0), float(b[0]))[1], [0, 1], 2) == [-1.0, -1.0]
    assert b[0] == 0.0 and b[1] == 5.0


def test_the_childs_exception_is_raised_here_with_its_type():
    def fn(i):
        if i == 2:
            raise KeyError("second item")
        return i

    with spare_core(), pytest.raises(KeyError, match="second item"):
        beside(fn, [1, 2])


def test_the_child_is_ended_and_reaped_when_the_first_item_fails(tmp_path):
    mark = tmp_path / "child.pid"

    def fn(i):
        if i == 2:
            mark.write_text(str(os.getpid()))
            time.sleep(60)
        while not mark.exists():
            time.sleep(0.01)
        raise ValueError("first item")

    with spare_core(), pytest.raises(ValueError, match="first item"):
        beside(fn, [1, 2])
    with pytest.raises(ProcessLookupError):  # ended and reaped: no such process, not a zombie
        os.kill(int(mark.read_text()), 0)


def _slalom(config, seed: int) -> AugmentedSimulator:
    """Six realisations of a car with a centre of gravity and a track, 2 s of a 3 deg slalom at 19.4 m/s."""
    t = np.arange(201) * 0.01
    delta = np.deg2rad(3.0) * np.sin(2 * np.pi * t / 1.5)
    settings = Settings.from_config({**config, "vehicle": {**config["vehicle"], "cg_height": 0.55, "track_width": 1.6}})
    return AugmentedSimulator.drawn(settings, t, delta, 19.4, 6, np.random.default_rng(seed))


def test_the_simulators_passes_in_halves_give_the_numbers_of_one_pass(config, monkeypatch):
    """Five pairs of one chassis kind (lateral transfer on the Magic Formula, the distributions
    and the transfer's size moved), one RK4 pass each way: the pairs computed in two halves, the
    second by the child, equal the one pass's bit for bit (the right-hand side is element-wise in
    the realisations); without a spare core one pass."""
    sim = _slalom(config, 0)
    base = effect("tyre_saturation").augment(ModelStructure(), [0.97])
    thetas = [[0.8 + 0.01 * k, 0.05, 1.55, 0.1, -50.0, 50.0] for k in range(5)]
    structures = [effect("lateral_load_transfer").augment(base, [0.5 + 0.05 * k, -0.2]) for k in range(5)]
    calls = []
    monkeypatch.setattr(augmented, "beside", lambda fn, items: calls.append([list(m) for m in items]) or threads.beside(fn, items))
    whole = sim.simulate_many(thetas, structures)
    assert calls == []
    with spare_core():
        halves = sim.simulate_many(thetas, structures)
    assert calls == [[[0, 1, 2], [3, 4]]]
    for a, b in zip(whole, halves):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(whole[0], whole[4])  # the pairs differ: a swapped half would show


def test_pairs_of_several_tyre_shapes_on_two_cores_get_the_numbers_of_one_process(config, monkeypatch):
    """A Jacobian's pairs on the tyre's whole shape with lateral transfer: five of one shape and
    the neighbours in b and C, one chassis pass (each realisation its pair's factors). On two cores
    the pass is cut in halves, each pair with the numbers of one process, bit for bit; a pass of
    single-track pairs (no chassis term) has one shape: its parts are shared out by cost."""
    sim = _slalom(config, 1)
    shapes = [[1.0, 1.6, 0.5]] * 5 + [[1.05, 1.6, 0.5], [1.0, 1.65, 0.5]]
    structures = [effect("lateral_load_transfer").augment(effect("tyre_shape").augment(ModelStructure(), v), [0.5 + 0.05 * k, -0.2])
                  for k, v in enumerate(shapes)]
    thetas = [[0.8 + 0.01 * k, 0.05, 1.55, 0.1, -50.0, 50.0] for k in range(7)]
    sides = []
    monkeypatch.setattr(augmented, "beside", lambda fn, items: sides.append(items) or threads.beside(fn, items))
    whole = sim.simulate_many(thetas, structures)
    with spare_core():
        shared = sim.simulate_many(thetas, structures)
    assert sides == [[[0, 1, 2, 3], [4, 5, 6]]]
    for a, b in zip(whole, shared):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(whole[5], whole[6])
    single = [effect("tyre_shape").augment(ModelStructure(), v) for v in shapes]
    sides.clear()
    whole = sim.simulate_many(thetas, single)
    with spare_core():
        shared = sim.simulate_many(thetas, single)
    assert sides == [([[0, 1, 2, 3, 4]], [[5], [6]])]  # a non-chassis part moves whole
    for a, b in zip(whole, shared):
        np.testing.assert_array_equal(a, b)


def test_a_search_step_with_one_item_on_workers_declares_the_spare_core():
    from uqdrive.inference.discrepancy.fitter import CandidateFitter

    fitter = CandidateFitter.__new__(CandidateFitter)
    fitter.jobs = 2
    assert fitter.map(lambda _: has_spare_core(), [0]) == [True]
    fitter.jobs = 1
    assert fitter.map(lambda _: has_spare_core(), [0]) == [False]
    assert not has_spare_core()


def _wait_for(condition, seconds: float = 20.0) -> bool:
    """Poll ``condition`` until it holds or ``seconds`` pass; whether it held."""
    end = time.monotonic() + seconds
    while not condition():
        if time.monotonic() > end:
            return False
        time.sleep(0.01)
    return True


def test_a_maps_last_item_borrows_the_core_a_worker_left_idle():
    """Two workers, two items: while the first worker holds its item, the second's has no core
    to borrow; once the first found no item left, the second's batch runs half in a child, and
    the borrowed core is counted again when the child is done."""
    from uqdrive.inference.parallel import fork_map

    def item(k):
        if k == 0:
            return None
        alone = has_spare_core()
        here = os.getpid()
        assert _wait_for(has_spare_core), "the idle worker's core was never lent"
        pids = [pid for _, pid in beside(lambda i: (i, os.getpid()), [0, 1])]
        return alone, here, pids, has_spare_core()

    _, (alone, here, pids, again) = fork_map(item, [0, 1], 2)
    assert pids[0] == here and pids[1] != here
    assert again
    # alone may be True only if the other worker had already finished; a worker with items left keeps its core
    busy = fork_map(lambda k: (time.sleep(0.3), has_spare_core())[1], [0, 1, 2, 3], 2)
    assert busy[:2] == [False, False]


def test_a_borrowed_core_is_not_lent_on_to_the_childs_half_or_outside_a_map():
    from uqdrive.inference.parallel import fork_map

    def item(k):
        if k == 0:
            return None
        assert _wait_for(has_spare_core)
        inner = beside(lambda i: (has_spare_core(), os.getpid()), [0, 1])
        with spare_core(False):
            held = has_spare_core()
        return [flag for flag, _ in inner], held, has_spare_core()

    assert fork_map(item, [0, 1], 2)[1] == ([False, False], False, True)
    assert not has_spare_core()
