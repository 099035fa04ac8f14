"""Mutation score of the modules that decide what the user is told (run by hand).

    python -m pip install -e ".[test,mutation]"
    python tools/mutation_score.py            # mutmut run, then the table and the survivors
    python tools/mutation_score.py --report   # only the table of the last run
    python tools/mutation_score.py --only 'sim.simulate*'   # one module's mutants (glob)

``mutmut`` (configured in pyproject.toml's ``[tool.mutmut]``: which files, which tests)
copies the project to ``mutants/``, makes every small change it knows to each line the
selected tests reach (a flipped comparison, a changed constant, a dropped call...), and runs
the tests that reach it. A mutant no test notices ("survived") is a behaviour nothing
guards. Printed: per file, killed / survived / other (timeouts, no tests) and the score
killed / (killed + survived); then every survivor by name (``mutmut show NAME`` shows its
diff). Each survivor in a core module is either killed by a new test or explained in the
issue note; the score is not a target to game.

Second pass, for JAX: mutmut maps a test to the functions it saw the test call, and a
jit-compiled function is called only by the test that first traces it (later tests hit the
compile cache), while tests that read a shared, already simulated run call nothing. So a
first-pass survivor of ``sim/`` may never have met the tests that would kill it. After the
first pass every selected test is mapped to every function of the jit-compiled modules
(``JIT_MODULES``) and the survivors are run again against all of them.
"""

from __future__ import annotations

import argparse
import fnmatch
import json
import subprocess
import sys
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
KILLED = {1, 3, 37}  # mutmut's exit codes meaning the tests (or the type check) caught it
SURVIVED = {0}
JIT_MODULES = ("sim.",)  # functions traced under jax.jit: mutmut's test map misses callers


def widen_test_map(stats_file: Path, prefixes=JIT_MODULES, mutants: Path | None = None) -> int:
    """Map every test mutmut ran to every function of the modules starting with ``prefixes``
    in mutmut's stats file (and to every such function with a mutant in ``mutants``' results,
    mapped or not); returns the number of functions widened."""
    stats = json.loads(stats_file.read_text())
    every = sorted(stats["duration_by_test"])
    table = stats["tests_by_mangled_function_name"]
    names = set(table)
    if mutants is not None:
        names |= {k.rsplit("__mutmut_", 1)[0] for codes in read_results(mutants).values() for k in codes}
    widened = sorted(k for k in names if k.startswith(prefixes))
    for k in widened:
        table[k] = every
    stats_file.write_text(json.dumps(stats))
    return len(widened)


def survivors_of(results: dict[str, dict[str, int | None]], prefixes=JIT_MODULES) -> list[str]:
    """Names of surviving mutants of the functions in modules starting with ``prefixes``."""
    return sorted(k for codes in results.values() for k, v in codes.items()
                  if v in SURVIVED and k.startswith(prefixes))


def read_results(mutants: Path) -> dict[str, dict[str, int | None]]:
    """source file -> {mutant name: exit code of its test run (None: not run)}."""
    out = {}
    for meta in sorted(mutants.rglob("*.py.meta")):
        data = json.loads(meta.read_text())
        codes = data.get("exit_code_by_key") or {}
        if codes:
            out[str(meta.relative_to(mutants))[: -len(".meta")]] = codes
    return out


def table(results: dict[str, dict[str, int | None]]) -> tuple[str, list[str], float]:
    rows = ["| file | killed | survived | other | score |", "| --- | --- | --- | --- | --- |"]
    survivors, total = [], Counter()
    for path, codes in results.items():
        c = Counter("killed" if v in KILLED else "survived" if v in SURVIVED else "other" for v in codes.values())
        total.update(c)
        score = c["killed"] / max(c["killed"] + c["survived"], 1)
        rows.append(f"| {path} | {c['killed']} | {c['survived']} | {c['other']} | {100 * score:.0f} % |")
        survivors += sorted(k for k, v in codes.items() if v in SURVIVED)
    score = total["killed"] / max(total["killed"] + total["survived"], 1)
    rows.append(f"| all | {total['killed']} | {total['survived']} | {total['other']} | {100 * score:.0f} % |")
    return "\n".join(rows), survivors, score


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--report", action="store_true", help="only print the last run's table")
    ap.add_argument("--max-children", type=int, default=2, help="mutants run at once (default 2: the 2 cores)")
    ap.add_argument("--only", nargs="+", default=[], metavar="GLOB",
                    help="run only the mutants whose names match, e.g. 'sim.simulate*' (default: all)")
    args = ap.parse_args(argv)
    if not args.report:
        run = [sys.executable, "-m", "mutmut", "run", "--max-children", str(args.max_children)]
        try:
            subprocess.run(run + args.only, cwd=ROOT, check=False)
        except FileNotFoundError:
            print("mutmut is not installed: python -m pip install -e '.[test,mutation]'", file=sys.stderr)
            return 2
        again = [k for k in survivors_of(read_results(ROOT / "mutants"))
                 if not args.only or any(fnmatch.fnmatch(k, g) for g in args.only)]
        if again:
            n = widen_test_map(ROOT / "mutants" / "mutmut-stats.json", mutants=ROOT / "mutants")
            print(f"second pass: {len(again)} survivors of the jit-compiled modules against every selected test"
                  f" ({n} functions re-mapped)")
            subprocess.run(run + again, cwd=ROOT, check=False)
    results = read_results(ROOT / "mutants")
    if not results:
        print("no mutation results in mutants/: run without --report first", file=sys.stderr)
        return 2
    text, survivors, _ = table(results)
    print(text)
    print(f"\n{len(survivors)} survivors (mutmut show NAME):")
    for name in survivors:
        print(f"  {name}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
