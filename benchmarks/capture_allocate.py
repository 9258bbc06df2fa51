"""Capture the arguments of plan._allocate during a run (by hand, for tests on big plates).

    PYTHONPATH=. python benchmarks/capture_allocate.py OUT.npz FILE.gcode [--profile NAME]

Writes every call's (Tx, Ix, finite, T_orig, budget_t, settle) as arrays a0_Tx, a0_Ix, ...
(copies taken before the call: _allocate writes inf into Ix in place)."""
import sys
import numpy as np
from gcode_opt import plan


def main(argv):
    out, rest = argv[0], argv[1:]
    calls = []
    orig = plan._allocate

    def spy(Tx, Ix, finite, T_orig, budget_t, settle):
        calls.append((Tx.copy(), Ix.copy(), finite.copy(), np.array(T_orig, float), budget_t, settle))
        return orig(Tx, Ix, finite, T_orig, budget_t, settle)

    plan._allocate = spy
    from gcode_opt.cli import main as cli
    import tempfile, os
    tmp = tempfile.mktemp(suffix=".gcode")
    try:
        try:
            cli(["process", rest[0], "-o", tmp, "-q"] + rest[1:])
        except SystemExit:
            pass
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    d = {}
    for i, (Tx, Ix, f, To, b, s) in enumerate(calls):
        d.update({f"a{i}_Tx": Tx, f"a{i}_Ix": Ix, f"a{i}_finite": f, f"a{i}_T_orig": To,
                  f"a{i}_budget": np.float64(b), f"a{i}_settle": np.bool_(s)})
    np.savez(out, **d)
    print(len(calls), "calls", [c[0].shape for c in calls])


if __name__ == "__main__":
    main(sys.argv[1:])
