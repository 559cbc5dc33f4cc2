import numpy as np
import pybullet as pb
import pytest
from PIL import Image

from robocompose.control.mppi import MPPIConfig
from robocompose.evaluation.evaluate import EvaluationConfig, evaluate
from robocompose.evaluation.rollout_log import RolloutRecorder, link_frames
from robocompose.grammar.derivation import derive, parse_rules
from robocompose.io import read_mcap

RIDGED_BEST = "0,7,1,13,1,2,16,12,13,6,4,19,4,17,5,3,2,16,4,5,18,9,8,9,9,8"
CONFIG = EvaluationConfig(mppi=MPPIConfig(samples=2, first_samples=2, horizon=2, episode=5))


@pytest.fixture(scope="module")
def recorded():
    tree = derive(parse_rules(RIDGED_BEST)).tree
    recorder = RolloutRecorder(step_seconds=16 / 240, frame_every=2, image_size=(64, 48))
    row = evaluate(tree, "flat", CONFIG, seed=0, observer=recorder, visual=True)
    return tree, recorder, row


def test_recording_does_not_change_the_result(recorded):
    tree, recorder, row = recorded
    assert evaluate(tree, "flat", CONFIG, seed=0)["reward"] == row["reward"]
    assert np.mean(recorder.rewards) == pytest.approx(row["reward"])


def test_mcap_holds_scene_transforms_and_rewards(tmp_path, recorded, valid_foxglove_log):
    tree, recorder, _ = recorded
    messages = read_mcap(recorder.write_mcap(tmp_path / "a.mcap"))
    assert valid_foxglove_log(tmp_path / "a.mcap") == len(messages)
    assert [m.topic for m in messages[:2]] == ["/tf", "/scene"]  # no scene before the frames it is locked to
    assert messages[0].log_time_ns == messages[1].log_time_ns
    scene = [m for m in messages if m.topic == "/scene"]
    tf = [m for m in messages if m.topic == "/tf"]
    assert len(scene) == 1 and len(scene[0].data["entities"]) == tree.n_links + 1  # terrain + links
    assert len(tf) == 5 and len(tf[0].data["transforms"]) == tree.n_links
    assert [m.log_time_ns for m in tf] == [round((k + 1) * 16 / 240 * 1e9) for k in range(5)]
    assert [m.data["reward"] for m in messages if m.topic == "/reward"] == pytest.approx(recorder.rewards)
    recorder.write_mcap(tmp_path / "b.mcap")
    assert (tmp_path / "a.mcap").read_bytes() == (tmp_path / "b.mcap").read_bytes()


def test_gif_has_one_frame_per_frame_every_steps(tmp_path, recorded):
    _, recorder, _ = recorded
    gif = Image.open(recorder.write_gif(tmp_path / "a.gif"))
    assert gif.n_frames == 3 and gif.size == (64, 48)


def test_link_frames_place_each_child_at_its_joint_on_the_parent():
    from robocompose.control.world import RobotWorld
    from robocompose.tasks.terrains import get_task

    tree = derive(parse_rules(RIDGED_BEST)).tree
    with RobotWorld(tree, get_task("flat")) as world:
        frames = link_frames(world)
    links = tree.links()
    for i, link in enumerate(links[1:], start=1):
        parent_pos, parent_orn = frames[link.parent]
        joint = pb.multiplyTransforms(parent_pos, parent_orn, [link.joint_pos * links[link.parent].length, 0, 0],
                                      [0, 0, 0, 1])[0]
        np.testing.assert_allclose(frames[i][0], joint, atol=1e-5)


def test_wall_task_gif_sees_the_robot_over_the_walls(tmp_path):
    tree = derive(parse_rules(RIDGED_BEST)).tree
    recorder = RolloutRecorder(step_seconds=16 / 240, frame_every=1, image_size=(64, 48))
    evaluate(tree, "wall", CONFIG, seed=0, observer=recorder, visual=True)
    frames = np.stack(recorder.frames).astype(int)
    assert np.abs(np.diff(frames, axis=0)).sum() > 0  # the robot moves in view (a side wall would hide it)
