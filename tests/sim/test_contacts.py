import numpy as np
import pybullet as pb
import pytest

from robocompose.grammar.derivation import derive, parse_rules
from robocompose.grammar.tree import DesignTree
from robocompose.sim.contacts import PAD, contact_features
from robocompose.sim.physics import connect


@pytest.fixture(scope="module")
def client():
    c = connect()
    yield c
    pb.disconnect(physicsClientId=c)


def test_reference_designs_have_valid_contacts(client, reference_rules):
    result = contact_features(derive(parse_rules(reference_rules)).tree, client)
    assert result.valid and result.reason == "" and 4 <= result.n_points <= 8
    assert result.features.shape == (16,) and result.features.dtype == np.float32
    xs = result.features[0: 2 * result.n_points: 2]
    assert list(xs) == sorted(xs)  # sorted by forward position
    pads = result.features[2 * result.n_points:].reshape(-1, 2)
    assert (pads == np.array(PAD, dtype=np.float32)).all()


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
    assert skipped.n_points == 0 and (skipped.features.reshape(-1, 2) == np.array(PAD, dtype=np.float32)).all()
