"""The one angle wrap: [-pi, pi), identity inside, the same in Python and in numba kernels."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim_runtime import angles
from sim_runtime.angles import wrap_angle


def test_an_angle_already_in_range_comes_back_bit_for_bit():
    for a in np.random.default_rng(0).uniform(-math.pi, math.pi, 1000):
        assert wrap_angle(float(a)) == a
    assert wrap_angle(-math.pi) == -math.pi


def test_pi_is_minus_pi_and_the_range_is_half_open():
    assert wrap_angle(math.pi) == -math.pi
    for a in (math.nextafter(-math.pi, -4.0), 3 * math.pi, -3 * math.pi, 1e6, -1e6, 7.0, -7.0):
        w = wrap_angle(a)
        assert -math.pi <= w < math.pi
        assert math.remainder(w - a, 2 * math.pi) == pytest.approx(0.0, abs=1e-9)


def test_one_turn_too_far_is_one_exact_subtraction():
    assert wrap_angle(3.5) == 3.5 - 2 * math.pi
    assert wrap_angle(-3.5) == -3.5 + 2 * math.pi


def test_the_numba_kernel_wrap_equals_the_python_one():
    values = np.concatenate([np.random.default_rng(1).uniform(-50.0, 50.0, 500), [math.pi, -math.pi, 3 * math.pi, 0.0]])
    jit = angles.wrap_angle_jit
    assert [jit(float(a)) for a in values] == [wrap_angle(float(a)) for a in values]


def test_nan_stays_nan():
    assert math.isnan(wrap_angle(math.nan))
