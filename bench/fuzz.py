"""Fuzz the command line with thousands of seeded cases and print what broke.

Each case is a mutated glTF (JSON or GLB bytes), a damaged bake directory, light volume or
ground map, run through bake / render / volume / vertexbake / groundmap (see
tests/fuzz/fuzzing.py for the mutators and the property). Prints the number of cases, the
outcomes (exit 0, exit 2, broken) and each distinct failure signature with its count and one
example. `--save FILE` keeps the signatures as JSON, `--compare FILE` prints which are new and which
are gone since then (the cases themselves differ between versions whose seed outputs differ).
Run by hand: `.venv/bin/python bench/fuzz.py [--cases 2000] [--seed 1] [--no-hostile]`.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests" / "fuzz"))
from fuzzing import Cases, Runner, Seeds, hostile_cases  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=2000)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--no-hostile", action="store_true", help="leave out the hand-made hostile cases")
    parser.add_argument("--save", type=Path, help="write the signatures and counts as JSON")
    parser.add_argument("--compare", type=Path, help="a --save file of an earlier run")
    args = parser.parse_args()
    outcomes, examples, signatures = Counter(), {}, Counter()
    start = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="patchlight-fuzz-") as work, Runner() as runner:
        seeds = Seeds(Path(work) / "seeds", runner)
        cases = Cases(seeds, Path(work) / "random", args.seed)
        todo = [] if args.no_hostile else hostile_cases(seeds, Path(work) / "hostile")
        for index in range(len(todo) + args.cases):
            case = todo[index] if index < len(todo) else cases.make(index)
            outcome = runner.run(case)
            signature = outcome.signature
            outcomes["broken" if signature else f"exit {outcome.status}"] += 1
            if signature:
                signatures[signature] += 1
                examples.setdefault(signature, f"{case.kind} {case.note}".strip())
            if (index + 1) % 100 == 0:
                print(f"{index + 1} cases, {time.monotonic() - start:.0f} s, {len(signatures)} signatures",
                      file=sys.stderr, flush=True)
    total = sum(outcomes.values())
    print(f"{total} cases in {time.monotonic() - start:.0f} s (a shared, busy machine): "
          + ", ".join(f"{name} {count}" for name, count in sorted(outcomes.items())))
    print(f"{len(signatures)} distinct failure signatures:")
    for signature, count in signatures.most_common():
        print(f"  {count:5d}  {signature}    e.g. {examples[signature]}")
    if args.save:
        args.save.write_text(json.dumps({"outcomes": outcomes, "signatures": signatures, "examples": examples},
                                        indent=1))
    if args.compare:
        earlier = json.loads(args.compare.read_text())["signatures"]
        print(f"since {args.compare}: {len(set(earlier) - set(signatures))} gone, "
              f"{len(set(signatures) - set(earlier))} new")
        for signature in sorted(set(signatures) - set(earlier)):
            print(f"  new: {signature}")


if __name__ == "__main__":
    main()
