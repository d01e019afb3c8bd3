"""Tracer.map: the calling thread and the pool's take items in turn; results come back in
order, a failure is raised only once no item of the batch still runs, and a map inside a
task finishes."""
import threading
import time

import numpy as np
import pytest

from patchlight.rays.tracer import Tracer


@pytest.fixture
def two_workers(monkeypatch):
    monkeypatch.setenv("PATCHLIGHT_THREADS", "2")
    return Tracer(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32), np.array([[0, 1, 2]]))


def test_results_come_in_order_and_both_workers_take_items(two_workers):
    workers = set()

    def slow_square(x):
        workers.add(threading.get_ident())
        time.sleep(0.002 * (x % 3))  # sleeps release the GIL: the items finish out of order
        return x * x

    assert two_workers.map(slow_square, list(range(40))) == [x * x for x in range(40)]
    assert threading.get_ident() in workers and len(workers) == 2


def test_a_failure_is_raised_after_every_item_taken_has_finished(two_workers):
    running, started = [], []

    def item(x):
        started.append(x)
        running.append(x)
        time.sleep(0.01)
        running.remove(x)
        if x == 3:
            raise ValueError("item 3")
        return x

    with pytest.raises(ValueError, match="item 3"):
        two_workers.map(item, list(range(50)))
    assert running == []
    assert len(started) < 50  # the items after the failure were not run


def test_a_map_inside_a_task_finishes(two_workers):
    inner = lambda x: two_workers.map(lambda y: x * y, [1, 2, 3])  # noqa: E731
    out = []
    outer = threading.Thread(target=lambda: out.append(two_workers.map(inner, [1, 2, 3, 4])), daemon=True)
    outer.start()
    outer.join(timeout=30)  # a pool whose threads all wait on their own tasks never returns
    assert out == [[[x, 2 * x, 3 * x] for x in (1, 2, 3, 4)]]


def test_one_thread_runs_every_item_on_the_caller(monkeypatch, two_workers):
    monkeypatch.setenv("PATCHLIGHT_THREADS", "1")
    workers = set()
    assert two_workers.map(lambda x: workers.add(threading.get_ident()) or x, [1, 2, 3]) == [1, 2, 3]
    assert workers == {threading.get_ident()}
