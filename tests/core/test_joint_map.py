"""Identified, locked and mimic joints: q_full = P q + c, and every bad choice."""

import numpy as np
import pytest

from drake_dynid.core.joint_map import joint_map

MOVABLE = ("j1", "j2", "finger_a", "finger_b", "head", "wheel")
MIMIC = {"finger_b": ("finger_a", -2.0, 0.5)}


def test_default_identifies_every_movable_joint():
    jmap = joint_map(MOVABLE[:3])
    assert jmap.names == MOVABLE[:3] and jmap.is_identity
    np.testing.assert_array_equal(jmap.matrix, np.eye(3))
    assert dict(jmap.locked) == {} and dict(jmap.mimic) == {}


def test_mimic_follows_an_identified_leader():
    jmap = joint_map(MOVABLE, mimic=MIMIC, locked={"head": 0.3})
    assert jmap.names == ("j1", "j2", "finger_a", "wheel")  # not the mimic, not head
    assert jmap.moving == ("j1", "j2", "finger_a", "wheel", "finger_b")
    assert dict(jmap.locked) == {"head": 0.3}
    assert dict(jmap.mimic) == {"finger_b": ("finger_a", -2.0, 0.5)}
    q = np.array([0.1, 0.2, 0.03, 4.0])
    q_full = jmap.matrix @ q + jmap.offset
    np.testing.assert_allclose(q_full, [0.1, 0.2, 0.03, -2 * 0.03 + 0.5, 0.3, 4.0])
    p, c = jmap.rows(["finger_b", "j2"])
    np.testing.assert_allclose(p @ q + c, [-0.06 + 0.5, 0.2])
    with pytest.raises(ValueError, match="read-only"):
        jmap.matrix[0, 0] = 2.0


def test_locked_joints_default_to_zero_and_mimic_of_locked_is_locked():
    mimic = {**MIMIC, "x": ("finger_b", 3.0, 1.0)}  # a chain: x -> finger_b -> a
    movable = (*MOVABLE, "x")
    jmap = joint_map(
        movable, joints=["j2", "j1"], locked={"finger_a": 0.01}, mimic=mimic
    )
    assert jmap.names == ("j1", "j2")  # the plant's order, not the given one
    assert dict(jmap.mimic) == {}
    finger_b = -2.0 * 0.01 + 0.5
    assert dict(jmap.locked) == pytest.approx(
        {
            "finger_a": 0.01,
            "finger_b": finger_b,
            "head": 0.0,
            "wheel": 0.0,
            "x": 3.0 * finger_b + 1.0,
        }
    )
    np.testing.assert_array_equal(jmap.matrix[2:], 0.0)


def test_mimic_chain_composes_multipliers_and_offsets():
    mimic = {"b": ("a", 2.0, 1.0), "c": ("b", 3.0, -1.0)}
    jmap = joint_map(("a", "b", "c"), mimic=mimic)
    assert jmap.names == ("a",)
    assert dict(jmap.mimic) == {"b": ("a", 2.0, 1.0), "c": ("a", 6.0, 2.0)}
    np.testing.assert_allclose(jmap.matrix[:, 0] * 0.5 + jmap.offset, [0.5, 2, 5])


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"joints": ["j1", "nope"]}, r"'nope' is not a movable joint.*available: j1"),
        ({"locked": {"nope": 0.0}}, r"locked joint 'nope' .* available: j1, j2"),
        ({"joints": ["j1"], "locked": {"j1": 0.2}}, "both identified and locked"),
        ({"joints": ["finger_b"]}, "mimic of 'finger_a' .* identify 'finger_a'"),
        ({"locked": {"finger_b": 0.1}}, "mimic of 'finger_a' .* lock 'finger_a'"),
        ({"joints": ["j1", "j1"]}, "j1 more than once"),
        ({"joints": []}, "at least one of"),
        ({"locked": {"head": float("nan")}}, "locked position of 'head' must be"),
        ({"locked": {"head": "up"}}, "locked position of 'head' must be"),
        # Found by a review: a prismatic joint locked at 1e300 m gave NaN a-priori
        # values (exit 0) and a simulate that did not end.
        ({"locked": {"head": 1e300}}, r"'head' must be within ±10000 \[rad or m\]"),
        (
            {"locked": dict.fromkeys(("j1", "j2", "finger_a", "head", "wheel"), 0)},
            "no joint left to identify",
        ),
        ({"mimic": {"j1": ("j2", 1, 0), "j2": ("j1", 1, 0)}}, "form a cycle"),
        ({"mimic": {"j1": ("base_weld", 1, 0)}}, "mimics 'base_weld', which is not"),
        ({"mimic": {"j1": ("j2", float("inf"), 0)}}, "finite multiplier"),
    ],
)
def test_errors(kwargs, match):
    kwargs = {"mimic": MIMIC, **kwargs}
    with pytest.raises(ValueError, match=match):
        joint_map(MOVABLE, owner="RobotModel", **kwargs)


def test_joints_must_not_be_a_string():
    with pytest.raises(TypeError, match="sequence of joint names"):
        joint_map(MOVABLE, joints="j1")


def test_a_urdf_of_many_joints_is_listed_in_one_short_line():
    """2000 movable joints: the first 20 named and the rest counted (a 20 kB
    message before)."""
    movable = [f"joint_{k}" for k in range(2000)]
    with pytest.raises(ValueError) as raised:
        joint_map(movable, joints=["elbow"], owner="RobotModel")
    text = str(raised.value)
    assert text.endswith("joint_18, joint_19 and 1980 more.")
    assert len(text) < 400
