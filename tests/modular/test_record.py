from PIL import Image

from robocompose.io import FRAME_TRANSFORMS, SCALARS, SCENE_UPDATE, read_mcap
from robocompose.modular.evaluate import EvalSettings, rollout
from robocompose.modular.record import record_rollout
from robocompose.modular.terrain import generate_terrain

TINY = EvalSettings(control_steps=10)


def test_mcap_and_gif_record_the_same_rollout(tmp_path, valid_foxglove_log):
    result = record_rollout("lwbnlw", 2, TINY, mcap=tmp_path / "r.mcap", gif=tmp_path / "r.gif")
    plain = rollout("lwbnlw", generate_terrain(2, TINY.terrain), TINY)
    assert (result.distance, result.status) == (plain.distance, plain.status)
    messages = read_mcap(tmp_path / "r.mcap")
    assert valid_foxglove_log(tmp_path / "r.mcap") == len(messages)
    assert [m.topic for m in messages[:2]] == ["/tf", "/scene"]  # no scene before the frames it is locked to
    schemas = {m.topic: m.schema_name for m in messages}
    assert schemas == {"/scene": SCENE_UPDATE, "/tf": FRAME_TRANSFORMS, "/robot": SCALARS}
    tf = [m for m in messages if m.topic == "/tf"]
    assert len(tf) == 11  # t = 0 and every control step
    frames = {t["child_frame_id"] for t in tf[0].data["transforms"]}
    scene = next(m for m in messages if m.topic == "/scene").data
    assert {e["frame_id"] for e in scene["entities"]} - {"world"} == frames
    last_x = [m for m in messages if m.topic == "/robot"][-1].data["x"]
    assert abs(last_x - tf[-1].data["transforms"][0]["translation"]["x"]) < 1e-9
    gif = Image.open(tmp_path / "r.gif")
    assert gif.n_frames == 3  # steps 0, 5, 10
