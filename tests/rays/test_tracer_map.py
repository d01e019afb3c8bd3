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


@pytest.mark.parametrize("first, last, size, parts, smallest", [(0, 10000, 129, 4, 16), (5, 300, 129, 4, 16),
                                                                 (0, 7, 129, 4, 16), (0, 1000, 50, 8, 1), (3, 3, 9, 4, 1)])
def test_tapered_spans_cover_the_rows_and_shrink_towards_the_end(first, last, size, parts, smallest):
    """Contiguous spans over exactly first..last-1, none above `size`, none below `smallest`
    but the last, none above 1/parts of the rows still left (or `smallest`): they never grow,
    and whichever worker takes the last finishes soon after the others."""
    from patchlight.rays.tracer import tapered_spans

    cut = tapered_spans(first, last, size, parts, smallest)
    assert [a for a, _ in cut[1:]] == [b for _, b in cut[:-1]]
    assert (cut[0][0], cut[-1][1]) == (first, last) if cut else first == last
    lengths = [b - a for a, b in cut]
    assert all(0 < n <= size for n in lengths) and all(n >= smallest for n in lengths[:-1])
    assert all(b - a <= max(smallest, -(-(last - a) // parts)) for a, b in cut)
    assert lengths == sorted(lengths, reverse=True)
    if last - first >= parts * size:
        assert lengths[0] == size and len(cut) < (last - first) // size + parts * 8
