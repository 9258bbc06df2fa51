"""quad_tables (session 51): the Gauss-Legendre nodes and weights the laws read from a table
are numpy.polynomial's own, bit for bit: the table file is what make_tables writes from
numpy.polynomial.legendre.leggauss now, and circle._gauss gives leggauss's numbers mapped
to [0, 1] for the tabled sizes and the others alike."""
import numpy as np
import pytest
from numpy.polynomial.legendre import leggauss

from gcode_opt.laws import circle, make_tables, quad_tables


def test_the_table_file_is_what_numpy_polynomial_generates():
    with open(make_tables.TABLE_PATH) as f:
        assert f.read() == make_tables.table_text()
    assert tuple(quad_tables.GAUSS) == make_tables.GAUSS_SIZES


@pytest.mark.parametrize("n", make_tables.GAUSS_SIZES)
def test_the_tabled_nodes_and_weights_are_leggauss_bit_for_bit(n):
    x, w = leggauss(n)
    tx, tw = (np.array(v) for v in quad_tables.GAUSS[n])
    assert tx.dtype == x.dtype and tx.tobytes() == x.tobytes() and tw.tobytes() == w.tobytes()


@pytest.mark.parametrize("n", make_tables.GAUSS_SIZES + (7, 13))
def test_gauss_is_leggauss_on_0_1(n):
    """The old _gauss: ((x + 1) / 2, w / 2) of leggauss(n); sizes outside the table too."""
    circle._GL_CACHE.pop(n, None)
    x, w = leggauss(n)
    gx, gw = circle._gauss(n)
    assert gx.tobytes() == ((x + 1) / 2).tobytes() and gw.tobytes() == (w / 2).tobytes()
