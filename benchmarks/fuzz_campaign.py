"""Long mutation-fuzz campaign over the real samples (issue 7): N cases, counts per outcome.

    python benchmarks/fuzz_campaign.py [--cases 5000] [--seed 1] [--minutes M] [--save DIR]

Each case: a window of a sample, 1-3 random mutations (tests/test_fuzz.py's engine), a random
bundled profile, default features or `all`, `-o OUT` or (1 in 4) in place; processed in-process
by the CLI (a hang bound per case). Prints the count
of cases, ok, refused cleanly, tracebacks, silent corruptions (verify fails or a bad written
value), hangs and other failures, the refusal reasons seen most, and saves each failing input
to --save (default fuzz-failures/) as CASE.gcode plus CASE.txt (profile, features, mutations,
what failed).  Exit 1 when any case failed.
"""
from __future__ import annotations

import argparse
import collections
import random
import re
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from test_fuzz import FAILURES, OK, REFUSED, build_case, check_case, random_ops, seeds  # noqa: E402

GROUPS = {"tracebacks": ("traceback",),
          "silent corruptions": ("corruption", "bad-value", "accepted-nonfinite", "invalid-block"),
          "hangs": ("hang",), "other failures": ("bad-exit", "bad-message", "input-changed", "temp-left")}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=5000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--minutes", type=float, default=None, help="stop after this much wall time")
    ap.add_argument("--save", default="fuzz-failures")
    ap.add_argument("--only", help="comma-separated mutation names to draw from (default: all)")
    ap.add_argument("--corners", help="pass --corners R in half the cases (slower corners: junction commands)")
    a = ap.parse_args(argv)
    from gcode_opt.profile import profile_names
    profiles = list(profile_names())
    texts = seeds()
    names = sorted(texts)
    r = random.Random(a.seed)
    counts = collections.Counter()
    reasons = collections.Counter()
    seen = collections.Counter()          # failures by message shape: print the first few of each
    by_mutation = collections.defaultdict(collections.Counter)
    slowest = (0.0, None)
    t0 = time.monotonic()
    save = Path(a.save)
    n = 0
    for n in range(1, a.cases + 1):
        name, prof, all_, in_place = r.choice(names), r.choice(profiles), r.random() < 0.5, r.random() < 0.25
        ops = random_ops(r) if not a.only else [(r.choice(a.only.split(",")), r.randrange(1 << 31))
                                                for _ in range(r.randint(1, 2))]
        data = build_case(texts[name], ops)
        extra = ("--corners", a.corners) if a.corners and r.random() < 0.5 else ()
        t = time.monotonic()
        cat, detail = check_case(data, prof, all_, in_place=in_place, extra=extra)
        dt = time.monotonic() - t
        slowest = max(slowest, (dt, n))
        counts[cat] += 1
        for op, _ in ops:
            by_mutation[op][cat] += 1
        if cat == REFUSED:
            reasons[re.sub(r"^:\d+", ":N", detail)[:70]] += 1
        elif cat != OK:
            save.mkdir(parents=True, exist_ok=True)
            (save / f"case{n:05d}.gcode").write_bytes(data)
            (save / f"case{n:05d}.txt").write_text(
                f"seed window: {name}\nprofile: {prof}\nfeatures all: {all_}\nin place: {in_place}\nextra: {extra}\n"
                f"mutations: {ops!r}\n"
                f"outcome: {cat}\n{detail}\n")
            last = detail.splitlines()[-1] if detail else ""
            if re.match(r"(SyntaxError|ImportError|ModuleNotFoundError|IndentationError)\b", last):
                sys.exit(f"case {n}: the code under test does not import ({last}): campaign stopped")
            key = re.sub(r"[-\d.]+", "#", re.sub(r"\S*/(?:in|out)\.gcode", "FILE", f"{cat}: {last}"))[:100]
            seen[key] += 1
            if seen[key] <= 3:
                where = f"{name} {prof} {'all' if all_ else 'default'}{' in-place' if in_place else ''}"
                print(f"case {n}: {cat}: {last[:300]} [{where} {ops}]", flush=True)
        if n % 250 == 0:
            print(f"... {n} cases, {time.monotonic() - t0:.0f} s, {dict(counts)}", flush=True)
        if a.minutes and time.monotonic() - t0 > 60 * a.minutes:
            break
    wall = time.monotonic() - t0
    print(f"\ncases               {n}  ({wall:.0f} s wall, {wall / max(n, 1):.2f} s per case, "
          f"slowest {slowest[0]:.1f} s: case {slowest[1]})")
    print(f"ok                  {counts[OK]}")
    print(f"refused cleanly     {counts[REFUSED]}")
    for g, cats in GROUPS.items():
        print(f"{g:<19} {sum(counts[c] for c in cats)}" + "".join(f"  {c} {counts[c]}" for c in cats if counts[c]))
    if seen:
        print("\nfailures by kind:")
        for key, k in seen.most_common():
            print(f"  {k:5d}  {key}")
    print("\nmost frequent refusals:")
    for why, k in reasons.most_common(12):
        print(f"  {k:5d}  {why}")
    print("\nper mutation (cases containing it): ok / refused / failed")
    for op in sorted(by_mutation):
        c = by_mutation[op]
        print(f"  {op:<12} {c[OK]:5d} {c[REFUSED]:5d} {sum(c[f] for f in FAILURES):5d}")
    return 1 if any(counts[f] for f in FAILURES) else 0


if __name__ == "__main__":
    sys.exit(main())
