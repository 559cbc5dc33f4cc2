import json
import math
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from robocompose.io import (
    FRAME_TRANSFORMS,
    SCALARS,
    SCENE_UPDATE,
    ArtifactError,
    McapWriter,
    capsule_primitives,
    cube_primitive,
    frame_transform,
    pose,
    read_mcap,
    scene_entity,
    time_msg,
)
from robocompose.io.mcap_log import ENTITY_ARRAYS, schema_bytes


def write_rollout(path: Path, steps: int = 3) -> Path:
    with McapWriter(path) as log:
        box = cube_primitive(pose((0.1, 0, 0)), (0.2, 0.1, 0.1), (0.2, 0.4, 0.8))
        for k in range(steps):
            t = 0.25 * k
            log.frame_transforms(t, [frame_transform("world", "link0", (0.1 * k, 0, 0.3))])
            if k == 0:
                log.scene_update(t, [scene_entity("link0", "link0", cubes=[box])])
            log.scalars("/reward", t, {"reward": float(k), "speed": np.float32(0.5)})
    return path


def test_round_trip(tmp_path: Path) -> None:
    messages = read_mcap(write_rollout(tmp_path / "rollout.mcap"))
    assert [(m.topic, m.log_time_ns) for m in messages] == [
        ("/tf", 0),
        ("/scene", 0),
        ("/reward", 0),
        ("/tf", 250_000_000),
        ("/reward", 250_000_000),
        ("/tf", 500_000_000),
        ("/reward", 500_000_000),
    ]
    scene, tf, reward = messages[1], messages[3], messages[4]
    assert scene.schema_name == "foxglove.SceneUpdate"
    entity = scene.data["entities"][0]
    assert (entity["id"], entity["frame_id"], entity["frame_locked"]) == ("link0", "link0", True)
    assert entity["cubes"][0]["size"] == {"x": 0.2, "y": 0.1, "z": 0.1}
    assert entity["cubes"][0]["color"] == {"r": 0.2, "g": 0.4, "b": 0.8, "a": 1.0}
    assert tf.schema_name == "foxglove.FrameTransforms"
    assert tf.data["transforms"] == [
        {
            "timestamp": {"sec": 0, "nsec": 250_000_000},
            "parent_frame_id": "world",
            "child_frame_id": "link0",
            "translation": {"x": 0.1, "y": 0.0, "z": 0.3},
            "rotation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0},
        }
    ]
    assert reward.schema_name == "robocompose.Scalars"
    assert reward.data == {"timestamp": {"sec": 0, "nsec": 250_000_000}, "reward": 1.0, "speed": 0.5}


def test_channels_use_foxglove_json_schemas(tmp_path: Path) -> None:
    path = write_rollout(tmp_path / "rollout.mcap")
    with path.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    assert {c.topic: c.message_encoding for c in summary.channels.values()} == {
        "/scene": "json",
        "/tf": "json",
        "/reward": "json",
    }
    for schema in summary.schemas.values():
        assert schema.encoding == "jsonschema"
        text = json.loads(schema.data)
        assert text["title"] == schema.name
    names = {s.name: json.loads(s.data) for s in summary.schemas.values()}
    transform = names["foxglove.FrameTransforms"]["properties"]["transforms"]["items"]["properties"]
    assert set(transform) == {"timestamp", "parent_frame_id", "child_frame_id", "translation", "rotation"}
    entity = names["foxglove.SceneUpdate"]["properties"]["entities"]["items"]
    assert set(entity["required"]) == {"timestamp", "frame_id", "id", "lifetime", "frame_locked", *ENTITY_ARRAYS}
    deletion_type = names["foxglove.SceneUpdate"]["properties"]["deletions"]["items"]["properties"]["type"]
    assert [option["const"] for option in deletion_type["oneOf"]] == [0, 1]  # MATCHING_ID, ALL


def test_every_message_validates_against_the_official_schema(tmp_path: Path, valid_foxglove_log) -> None:
    assert valid_foxglove_log(write_rollout(tmp_path / "rollout.mcap")) == 7


def untyped_properties(schema: dict, where: str = "") -> list[str]:
    """Properties Foxglove's JSON-schema parser cannot read: neither `type` nor `oneOf` (as an `enum` alone,
    "Unsupported type undefined"). Foxglove drops a channel whose schema has one."""
    found = []
    for name, sub in schema.get("properties", {}).items():
        if "type" not in sub and "oneOf" not in sub:
            found.append(f"{where}{name}")
        found += untyped_properties(sub, f"{where}{name}.")
        found += untyped_properties(sub.get("items", {}), f"{where}{name}[].")
    return found


def test_schemas_pass_foxglove_parser_restriction() -> None:
    for name in (SCENE_UPDATE, FRAME_TRANSFORMS, SCALARS):
        assert untyped_properties(json.loads(schema_bytes(name))) == [], name
    # The hand-abridged schema this project used to write gave the deletion type an enum only:
    abridged = {"properties": {"deletions": {"type": "array", "items": {"type": "object", "properties": {
        "type": {"title": "foxglove.SceneEntityDeletionType", "enum": [0, 1]}}}}}}
    assert untyped_properties(abridged) == ["deletions[].type"]


def test_scene_entity_carries_every_required_array() -> None:
    entity = scene_entity("a", "world", cubes=[{"x": 1}])
    assert [k for k in entity if k in ENTITY_ARRAYS] == list(ENTITY_ARRAYS)
    assert entity["cubes"] == [{"x": 1}] and entity["models"] == []
    with pytest.raises(ValueError, match="no array 'capsules'"):
        scene_entity("a", "world", capsules=[])


def test_same_messages_give_same_bytes(tmp_path: Path) -> None:
    a = write_rollout(tmp_path / "a.mcap").read_bytes()
    assert write_rollout(tmp_path / "b.mcap").read_bytes() == a
    assert write_rollout(tmp_path / "c.mcap", steps=4).read_bytes() != a


def test_time_conversion() -> None:
    assert time_msg(1.25) == {"sec": 1, "nsec": 250_000_000}
    assert time_msg(0.1) == {"sec": 0, "nsec": 100_000_000}
    with pytest.raises(ValueError, match="non-negative"):
        time_msg(-1.0)


def test_capsule_is_a_cylinder_and_two_end_spheres() -> None:
    # Rotated 90 degrees about y, so the capsule axis (local z) points along world x.
    half = math.sqrt(0.5)
    parts = capsule_primitives(pose((1.0, 2.0, 3.0), (0.0, half, 0.0, half)), 0.05, 0.2, (1, 0, 0, 1))
    (body,) = parts["cylinders"]
    assert body["size"] == pytest.approx({"x": 0.1, "y": 0.1, "z": 0.2})
    assert body["pose"]["position"] == {"x": 1.0, "y": 2.0, "z": 3.0}
    centres = [tuple(s["pose"]["position"][k] for k in "xyz") for s in parts["spheres"]]
    assert centres[0] == pytest.approx((0.9, 2.0, 3.0)) and centres[1] == pytest.approx((1.1, 2.0, 3.0))
    assert all(s["size"] == pytest.approx({"x": 0.1, "y": 0.1, "z": 0.1}) for s in parts["spheres"])
    entity = scene_entity("leg", "link3", **parts)
    assert len(entity["cylinders"]) == 1 and len(entity["spheres"]) == 2


def test_exception_inside_writer_leaves_no_file(tmp_path: Path) -> None:
    path = tmp_path / "rollout.mcap"
    with pytest.raises(RuntimeError, match="simulation crashed"):
        with McapWriter(path) as log:
            log.scalars("/reward", 0.0, {"reward": 1.0})
            raise RuntimeError("simulation crashed")
    assert list(tmp_path.iterdir()) == []


def test_exception_inside_writer_keeps_previous_log(tmp_path: Path) -> None:
    path = write_rollout(tmp_path / "rollout.mcap")
    before = path.read_bytes()
    with pytest.raises(ValueError, match="'/reward'"):
        with McapWriter(path) as log:
            log.scalars("/reward", 0.0, {"reward": math.nan})  # NaN is not JSON
    assert path.read_bytes() == before
    assert list(tmp_path.iterdir()) == [path]


def test_writer_rejects_bad_messages(tmp_path: Path) -> None:
    with McapWriter(tmp_path / "log.mcap") as log:
        with pytest.raises(ValueError, match=r"transform 0 lacks \['rotation'\]"):
            log.frame_transforms(0.0, [{"parent_frame_id": "a", "child_frame_id": "b", "translation": {}}])
        log.scalars("/tf2", 0.0, {"x": 1.0})
        with pytest.raises(ValueError, match="'/tf2' carries robocompose.Scalars"):
            log.frame_transforms(0.0, [], topic="/tf2")
    with pytest.raises(RuntimeError, match="outside its `with` block"):
        log.scalars("/x", 0.0, {"x": 1.0})


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(ArtifactError, match=r"nope\.mcap: file not found"):
        read_mcap(tmp_path / "nope.mcap")


@pytest.mark.parametrize("corrupt", ["truncated", "random"])
def test_corrupted_file(tmp_path: Path, corrupt: str) -> None:
    path = write_rollout(tmp_path / "rollout.mcap")
    data = path.read_bytes()
    bad = data[: len(data) // 2] if corrupt == "truncated" else np.random.default_rng(1).bytes(900)
    path.write_bytes(bad)
    with pytest.raises(ArtifactError, match=r"rollout\.mcap: not a readable MCAP log"):
        read_mcap(path)


def test_flipped_bytes_are_detected_not_read_as_other_messages(tmp_path: Path) -> None:
    good = write_rollout(tmp_path / "good.mcap")
    expected = read_mcap(good)
    data = good.read_bytes()
    path = tmp_path / "bad.mcap"
    detected = 0
    # Chunk CRCs catch flips inside compressed messages. ~500 positions spread over the file: the summary's
    # uncompressed copy of Foxglove's schemas (~50 kB) would otherwise make this thousands of reads.
    for position in range(8, len(data) - 8, max(11, len(data) // 500) | 1):
        flipped = bytearray(data)
        flipped[position] ^= 0xFF
        path.write_bytes(bytes(flipped))
        try:
            messages = read_mcap(path)
        except ArtifactError:
            detected += 1
            continue
        assert messages == expected, f"flipped byte {position} changed the messages silently"
    assert detected > 0
