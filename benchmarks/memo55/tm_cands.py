"""tracemalloc's peak during the windowed candidates and by line right after them (plan_windows.candidates_windowed,
where the windowed gyroid plate's peak is reached: mem_breakdown --rises), and the share of
the chains' candidate state: the memos, their rows, the kept laws (chains.py's lines).

    GCODE_OPT_WINDOWED=1 PYTHONPATH=TREE python benchmarks/memo55/tm_cands.py FILE PROFILE [TOP]
"""
import os
import sys
import tempfile
import tracemalloc

f, prof = sys.argv[1], sys.argv[2]
top = int(sys.argv[3]) if len(sys.argv) > 3 else 25
tracemalloc.start(1)
import gcode_opt.plan_windows as P  # noqa: E402
from gcode_opt import cli  # noqa: E402

orig = P.candidates_windowed


def wrap(*a, **k):
    tracemalloc.reset_peak()
    r = orig(*a, **k)
    peak = tracemalloc.get_traced_memory()[1]
    st = tracemalloc.take_snapshot().statistics("lineno")
    tot = sum(s.size for s in st)
    ch = sum(s.size for s in st if os.path.basename(s.traceback[0].filename) == "chains.py")
    print(f"== after the candidates: traced {tot / 1e6:.2f} MB, chains.py {ch / 1e6:.2f} MB; "
          f"traced peak during them {peak / 1e6:.2f} MB")
    for s in st[:top]:
        fr = s.traceback[0]
        print(f"  {s.size / 1e6:6.2f} MB {s.count:8d}  {os.path.basename(fr.filename)}:{fr.lineno}")
    return r


P.candidates_windowed = wrap
out = tempfile.mktemp(suffix=".gcode")
sys.argv = ["gcode-opt", "process", f, "-o", out, "-q", "--profile", prof]
try:
    cli.main()
except SystemExit:
    pass
os.unlink(out)
