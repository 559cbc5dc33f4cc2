import numpy as np
from PIL import Image

from robocompose.grammar.derivation import derive, parse_rules
from robocompose.sim.builder import BODY_COLOR, LIMB_COLOR
from robocompose.sim.render import render_design


def test_render_shows_body_and_limbs(tmp_path, reference_rules):
    path = render_design(derive(parse_rules(reference_rules)).tree, tmp_path / "d.png", width=160, height=120)
    image = np.asarray(Image.open(path)).astype(int)
    assert image.shape == (120, 160, 3)

    def share(color) -> float:
        # pixels whose hue is close to the link colour (shading changes brightness, not the channel order)
        target = np.array(color[:3]) * 255
        direction = target / np.linalg.norm(target)
        norms = np.linalg.norm(image, axis=2) + 1e-9
        return float(((image @ direction) / norms > 0.985).mean())

    assert share(BODY_COLOR) > 0.002 and share(LIMB_COLOR) > 0.002
