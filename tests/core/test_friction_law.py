"""core.friction: the one friction law, with a pluggable Coulomb sign function."""

import math
from dataclasses import dataclass

import numpy as np
import pytest

from drake_dynid.core.friction import (
    EXACT_SIGN,
    ExactSign,
    SignLaw,
    TanhSign,
    check_friction,
    friction_force,
    friction_force_scalar,
    friction_idim_columns,
    friction_names,
    friction_power_columns,
    friction_value,
    sign_law,
)
from drake_dynid.core.planar2r import Planar2RRows
from drake_dynid.core.rows import model_rows_from_parts


@dataclass(frozen=True)
class DeadZone:
    """A standstill dead zone: s(v) = 0 for |v| < width, else sign(v)."""

    width: float

    def __call__(self, v):
        return np.where(np.abs(v) < self.width, 0.0, np.sign(v))

    def scalar(self, v):
        return 0.0 if abs(v) < self.width else math.copysign(1.0, v)


V = np.array([[-2.0, 0.0], [1e-3, 3.0], [0.5, -1e-4]])


def test_sign_laws_agree_with_their_scalar_form():
    for law in (EXACT_SIGN, TanhSign(0.01), DeadZone(0.01)):
        assert isinstance(law, SignLaw)
        for v in (-2.0, -1e-3, 0.0, 1e-3, 0.5):
            assert law.scalar(v) == pytest.approx(float(law(np.array(v))), abs=1e-15)
    assert math.isnan(ExactSign().scalar(math.nan))
    assert sign_law(0.0) is EXACT_SIGN and sign_law(0.02) == TanhSign(0.02)
    with pytest.raises(ValueError, match=r"TanhSign: width must be > 0"):
        TanhSign(0.0)


def test_columns_and_force_follow_the_sign_law():
    kinds = ("viscous", "coulomb", "offset")
    exact = friction_idim_columns(V, kinds)
    assert exact.shape == (3, 2, 6)
    # Joint i's row holds [v_i, sign v_i, 1] in joint i's columns only.
    np.testing.assert_array_equal(
        exact[:, 0, :3].T, [V[:, 0], np.sign(V[:, 0]), [1] * 3]
    )
    np.testing.assert_array_equal(exact[:, 0, 3:], 0.0)
    zone = DeadZone(0.01)
    plugged = friction_idim_columns(V, kinds, zone)
    np.testing.assert_array_equal(
        plugged[:, :, [0, 2, 3, 5]], exact[:, :, [0, 2, 3, 5]]
    )
    np.testing.assert_array_equal(plugged[:, 0, 1], zone(V[:, 0]))
    # Power: v·(IDIM columns): v², v s(v) (= |v| for the exact sign), v.
    power = friction_power_columns(V, kinds)
    np.testing.assert_array_equal(power[:, 1], np.abs(V[:, 0]))
    np.testing.assert_array_equal(
        friction_power_columns(V, kinds, zone)[:, 4], [0, 3, 0]
    )
    fv, fc, off = np.array([0.3, 0.1]), np.array([0.4, 0.2]), np.array([0.0, 0.05])
    force = friction_force(V, fv, fc, off, zone)
    np.testing.assert_allclose(force, fv * V + fc * zone(V) + off, rtol=1e-15)
    assert friction_force_scalar(1e-3, 0.3, 0.4, 0.0, zone) == pytest.approx(3e-4)
    assert friction_value("coulomb", -0.5) == -1.0 and friction_value("offset", 2) == 1


def test_the_2r_rows_take_the_coulomb_law_from_the_module():
    rows = Planar2RRows(L1=1.0)
    q = np.zeros((3, 2))
    tau = np.ones((3, 2))
    _, g, _ = rows.model_rows("lagrangian", q, V, tau)
    np.testing.assert_array_equal(g[:, 0, 5], np.sign(V[:, 0]))  # FC1 column
    zone = DeadZone(0.01)
    _, g_zone, _ = model_rows_from_parts(
        "lagrangian",
        "test",
        V,
        tau,
        lambda: rows.energy_rows(q, V),
        lambda: rows.lagrangian_rows(q, V),
        slice(4, None),
        rows.friction,
        rows.num_parameters,
        zone,
    )
    np.testing.assert_array_equal(g_zone[:, 0, 5], [-1.0, 0.0, 1.0])
    np.testing.assert_array_equal(g_zone[:, :, :5], g[:, :, :5])


def test_kinds_and_names():
    assert check_friction("o", "offset, viscous") == ("viscous", "offset")
    assert friction_names(("viscous", "coulomb"), 2) == ("FV1", "FC1", "FV2", "FC2")
    with pytest.raises(ValueError, match="o: friction kinds must be among"):
        check_friction("o", ["dry"])
    with pytest.raises(TypeError, match="o: friction must be a sequence"):
        check_friction("o", 3)
