"""benchmarks/split_bound.py's arithmetic against closed forms: the splitting factor that minimises
(variance) x (cost) of a two-stage estimator, and roulette's variance."""
import numpy as np
import pytest

from benchmarks.split_bound import FACTORS, allocate, cont_variance, evaluate


def uniform(va, vb, cv, m2, shape=(3, 4)):
    return tuple(np.full(shape, float(x)) for x in (va, vb, cv, m2))


def test_the_optimal_split_of_identical_tiles_is_the_closed_form():
    # (a + b / n)(c1 + n c2) is least at n = sqrt(b c1 / (a c2)) = 4 here
    mom = uniform(1.0, 16.0, 0.0, 0.0)
    c1, c2 = np.full((3, 4), 1.0), np.full((3, 4), 1.0)
    n = allocate(mom, c1, c2, FACTORS)
    assert (n == 4.0).all()
    gain, vr, cr = evaluate(mom, c1, c2, n)
    assert gain == pytest.approx(17.0 * 2.0 / (5.0 * 5.0))
    assert vr == pytest.approx(5.0 / 17.0) and cr == pytest.approx(2.5)


def test_roulette_where_the_continuation_is_quiet_and_dear():
    # a tile whose continuation adds no variance but costs rays: roulette at the smallest factor, and
    # its variance is that of a survival probability n on a constant m: m^2 (1 / n - 1)
    mom = uniform(1.0, 0.0, 0.0, 0.25)
    c1, c2 = np.full((3, 4), 1.0), np.full((3, 4), 3.0)
    n = allocate(mom, c1, c2, FACTORS)
    lam = np.sum(c1 + n * c2) / np.sum(1.0 + cont_variance(mom[1], mom[3], n))
    best = min(FACTORS, key=lambda f: lam * (0.25 / f - 0.25) + 3.0 * f)
    assert (n == best).all() and best < 1.0
    assert cont_variance(np.array(0.0), np.array(0.25), 0.5) == pytest.approx(0.25)
    assert cont_variance(np.array(2.0), np.array(0.25), 2.0) == pytest.approx(1.0)   # split: VB / n
