import numpy as np
import pybullet as pb
import pytest

from robocompose.grammar.derivation import derive, parse_rules
from robocompose.grammar.tree import DesignTree
from robocompose.sim.builder import aabb, build_at_rest
from robocompose.sim.contacts import (
    PAD_X,
    REST_SETTINGS,
    contact_features,
    contact_vector,
    pair_points,
    rejection,
)
from robocompose.sim.physics import add_floor, configure, connect

# A grammar design (11 links) that rests on its limbs without a belly touch: valid under GLSO's rule.
STANDING = "0,10,6,2,17,4,8,19,4,7,8,4,19,8,5,16,8"


@pytest.fixture(scope="module")
def client():
    c = connect()
    yield c
    pb.disconnect(physicsClientId=c)


def _contact(body_a, body_b, link_a, link_b, on_a, on_b):
    """A pybullet contact-point tuple with the fields `pair_points` reads."""
    return (0, body_a, body_b, link_a, link_b, on_a, on_b, (0, 0, 1), -1e-3)


def test_contact_vector_sorts_by_forward_scales_and_pads_beyond_the_data():
    points = np.array([[-0.05, 0.1], [-0.3, -0.1], [-0.1, 0.0], [-0.3, -0.2]])  # metres, front at x = 0
    v = contact_vector(points).reshape(8, 2)
    np.testing.assert_allclose(v[:4], [[-3.0, -2.0], [-3.0, -1.0], [-1.0, 0.0], [-0.5, 1.0]], rtol=1e-6)
    assert (v[4:] == [PAD_X, 0.0]).all()  # padding after the real points, forward 2.0 > every real x (<= 0)
    assert list(v[:, 0]) == sorted(v[:, 0])


def test_rejection_rule_of_glso():
    feet = np.array([[-0.3, -0.1], [-0.3, 0.1], [-0.05, -0.1], [-0.05, 0.1]])
    assert rejection(feet) == ""
    assert rejection(feet[:3]) == "too_few_contacts"
    belly = np.vstack([feet, [[-0.2, 0.005]]])  # on the mid-plane, away from the front
    assert rejection(belly) == "midline_contact"
    nose = np.vstack([feet, [[-0.005, 0.0]]])  # on the mid-plane but at the front: allowed
    assert rejection(nose) == ""
    beside = np.vstack([feet, [[-0.2, 0.02]]])  # off the mid-plane
    assert rejection(beside) == ""


def test_one_point_per_pair_first_eight_pairs_world_side():
    robot, floor = 1, 0
    contacts = [
        _contact(robot, floor, 3, -1, (0.0, 0.0, -0.02), (-0.1, 0.2, 0.0)),  # pair (3, floor): first point kept
        _contact(robot, floor, 3, -1, (9.0, 9.0, -0.02), (-0.9, 0.9, 0.0)),  # second point of the same pair
        _contact(robot, robot, 2, 5, (-0.2, 0.0, 0.05), (-0.2, 0.0, 0.05)),  # robot-robot, listed from A ...
        _contact(robot, robot, 5, 2, (7.0, 7.0, 7.0), (7.0, 7.0, 7.0)),  # ... and again from B: same pair
    ] + [_contact(robot, floor, k, -1, (0, 0, -0.01), (-0.01 * k, 0.0, 0.0)) for k in range(10, 20)]
    points = pair_points(contacts)
    assert len(points) == 8  # GLSO reads the first 8 manifolds
    np.testing.assert_allclose(points[0], [-0.1, 0.2, 0.0])  # on the floor's side
    np.testing.assert_allclose(points[1], [-0.2, 0.0, 0.05])
    np.testing.assert_allclose(points[2:, 0], [-0.01 * k for k in range(10, 16)])


def test_standing_design_frame_ordering_and_padding(client):
    tree = derive(parse_rules(STANDING)).tree
    result = contact_features(tree, client)
    assert result.valid and result.reason == "" and 4 <= result.n_points <= 8
    assert result.features.shape == (16,) and result.features.dtype == np.float32
    real = result.features.reshape(8, 2)[: result.n_points]
    assert (real[:, 0] <= 0).all()  # the front is at x = 0, the robot behind it
    assert list(real[:, 0]) == sorted(real[:, 0])
    assert (result.features.reshape(8, 2)[result.n_points:] == [PAD_X, 0.0]).all()
    # The feet are mirrored: lateral positions come in +/- pairs.
    np.testing.assert_allclose(np.sort(real[:, 1]), -np.sort(real[:, 1])[::-1], atol=0.05)


def test_placement_puts_the_front_at_zero_and_the_lowest_point_on_the_floor(client):
    configure(client, REST_SETTINGS)
    add_floor(client)
    robot = build_at_rest(derive(parse_rules(STANDING)).tree, client)
    lo, hi = aabb(robot.body, client)
    assert hi[0] == pytest.approx(0.0, abs=1e-9) and lo[2] == pytest.approx(0.0, abs=1e-9)


def test_reference_designs_drag_their_body_and_fail_the_midline_rule(client, reference_rules):
    result = contact_features(derive(parse_rules(reference_rules)).tree, client)
    assert result.reason == "midline_contact" and result.n_points >= 4


def test_contacts_are_deterministic(client, reference_rules):
    tree = derive(parse_rules(reference_rules)).tree
    a, b = contact_features(tree, client), contact_features(tree, client)
    assert a.features.tobytes() == b.features.tobytes()


def test_legless_body_touches_too_few_points(client):
    result = contact_features(derive(parse_rules("0,7,3,6")).tree, client)
    assert not result.valid and result.reason == "too_few_contacts"


def test_self_penetrating_design_is_rejected_with_or_without_resting(client):
    tree = DesignTree((-1, 0, 0), (14, 2 * 14 + 4, 2 * 14 + 5))  # overlapping siblings (test_builder)
    rested, skipped = contact_features(tree, client), contact_features(tree, client, rest_self_penetrating=False)
    assert rested.reason == skipped.reason == "self_collision" and not rested.valid and not skipped.valid
    assert skipped.n_points == 0 and (skipped.features.reshape(-1, 2) == [PAD_X, 0.0]).all()
