"""The fuzzer, bounded for the suite: the hand-made hostile inputs, then a seeded sample of
mutated glTF files, GLB bytes, bake directories, light volumes and ground maps, each run
through the command line in a child process. Every run must keep the property (exit 0 or 2,
no traceback, at most three lines on stderr, nothing left in the output after a failure,
under 60 s and 2 GiB; fuzzing.Outcome.signature). bench/fuzz.py runs thousands of cases."""
from __future__ import annotations

import time

from fuzzing import Cases, hostile_cases

SEED = 16
CASES = 60
BUDGET_S = 70  # the sample stops early on a slow machine; its cases come in a fixed order


def _report(outcomes) -> str:
    return "\n".join(f"{o.signature}  [{o.case.kind} {o.case.note}]: {o.stderr.strip()[-400:]}" for o in outcomes)


def test_hostile_inputs_are_refused_in_one_line(runner, seeds, tmp_path):
    outcomes = [runner.run(case) for case in hostile_cases(seeds, tmp_path)]
    broken = [o for o in outcomes if o.signature or o.status != 2]
    assert not broken, _report(broken)
    assert all(len(o.stderr.strip().splitlines()) == 1 for o in outcomes), _report(outcomes)


def test_mutated_inputs_keep_the_property(runner, seeds, tmp_path):
    cases, start, outcomes = Cases(seeds, tmp_path, SEED), time.monotonic(), []
    for index in range(CASES):
        if time.monotonic() - start > BUDGET_S:
            break
        outcomes.append(runner.run(cases.make(index)))
    broken = [o for o in outcomes if o.signature]
    assert not broken, _report(broken)
    assert len({o.status for o in outcomes}) == 2 or len(outcomes) < 10, "the sample should hold successes and failures"
