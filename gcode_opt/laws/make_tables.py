"""Writes gcode_opt/laws/quad_tables.py: the Gauss-Legendre nodes and weights of the fixed
sizes the laws use (circle._graded_grid: 10 a panel, 24 the middle one), as
numpy.polynomial.legendre.leggauss gives them on this machine, each float written by repr
(read back to the same bits).  A run reads the table and does not import numpy.polynomial
for them (~9 M instructions with the eigenvalue solves).  Regenerate with
`python -m gcode_opt.laws.make_tables`; tests/test_speed51_boot51_tables.py checks that
the table is what this generates, bit for bit."""
import os

GAUSS_SIZES = (10, 24)
TABLE_PATH = os.path.join(os.path.dirname(os.path.abspath(__file__)), "quad_tables.py")


def table_text():
    """The text of quad_tables.py, made by numpy.polynomial itself."""
    from numpy.polynomial.legendre import leggauss
    out = ['"""Gauss-Legendre nodes and weights on [-1, 1] (numpy.polynomial.legendre.leggauss(n)),',
           'written by gcode_opt/laws/make_tables.py: do not edit."""', "", "GAUSS = {"]
    for n in GAUSS_SIZES:
        x, w = leggauss(n)
        out += [f"    {n}: ("] + _floats(x) + _floats(w) + ["    ),"]
    out.append("}")
    return "\n".join(out) + "\n"


def _floats(a):
    """Lines of a tuple of the floats of a, four a line."""
    v = [repr(f) for f in a.tolist()]
    rows = [", ".join(v[i:i + 4]) for i in range(0, len(v), 4)]
    return ["        (" + rows[0] + ","] + ["         " + r + "," for r in rows[1:]] + ["        ),"]


if __name__ == "__main__":
    with open(TABLE_PATH, "w") as f:
        f.write(table_text())
