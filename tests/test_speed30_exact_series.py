"""laws/chain.py's series coefficients are written out as hex (_EX_COEF_HEX) so the import
does not redo the Fraction arithmetic; they must be _exact_series()'s doubles, bit for bit."""
import numpy as np

from gcode_opt.laws import chain


def test_written_coefficients_are_the_series_bits():
    made = chain._exact_series()
    assert made.shape == chain._EX_COEF.shape == (chain.EXACT_TERMS, 6)
    assert np.array_equal(made.view(np.int64), chain._EX_COEF.view(np.int64))


def test_a_changed_term_is_seen():
    # the check above can fail: one ulp off in one coefficient
    c = chain._EX_COEF.copy()
    c[7, 3] = np.nextafter(c[7, 3], np.inf)
    assert not np.array_equal(chain._exact_series().view(np.int64), c.view(np.int64))
