import numpy as np
import pytest
from PIL import Image

from robocompose.io.errors import InputError
from robocompose.teams.chips import (
    CLASS_TO_TERRAIN,
    IGNORE_COLOUR_RGB,
    generate_chip,
    load_chips,
    write_label_png,
    write_synthetic_chips,
)


def test_loader_reads_generated_chips_back_to_the_same_class_map(tmp_path):
    paths = write_synthetic_chips(tmp_path, n_chips=3, seed=7, size=60)
    chips = list(load_chips(tmp_path, chip_size=60))
    assert [chip.chip_id for chip in chips] == [f"{p.stem}-000000" for p in paths]
    for index, chip in enumerate(chips):
        expected = generate_chip(np.random.default_rng([7, index]), size=60)
        np.testing.assert_array_equal(chip.classes, expected)
        np.testing.assert_array_equal(chip.terrain, CLASS_TO_TERRAIN[expected])


def test_generated_chips_show_several_terrains_and_are_seeded():
    chip = generate_chip(np.random.default_rng(3))
    np.testing.assert_array_equal(chip, generate_chip(np.random.default_rng(3)))
    terrains = np.stack([CLASS_TO_TERRAIN[generate_chip(np.random.default_rng(s), 120)] for s in range(8)])
    assert set(np.unique(terrains)) == {0, 1, 2, 3}


def test_scenes_are_cut_into_windows_and_ignore_windows_skipped(tmp_path):
    classes = np.zeros((40, 60), dtype=np.uint8)  # two 20-px rows x three columns of windows
    classes[:, 20:40] = 3
    write_label_png(classes, tmp_path / "scene.png")
    rgb = np.array(Image.open(tmp_path / "scene.png"))
    rgb[25, 45] = IGNORE_COLOUR_RGB  # spoils window 5 (second row, third column)
    Image.fromarray(rgb).save(tmp_path / "scene.png")
    chips = list(load_chips(tmp_path, chip_size=20))
    assert [chip.chip_id for chip in chips] == [f"scene-{i:06d}" for i in range(5)]
    assert (chips[1].classes == 3).all() and (chips[0].classes == 0).all()


def test_unknown_colour_names_file_pixel_and_colour(tmp_path):
    Image.fromarray(np.full((4, 4, 3), 7, dtype=np.uint8)).save(tmp_path / "odd.png")
    with pytest.raises(ValueError, match=r"odd\.png: pixel \(row 0, col 0\) has colour \(7, 7, 7\)"):
        list(load_chips(tmp_path, chip_size=4))


def test_empty_directory_is_an_error_naming_it(tmp_path):
    with pytest.raises(InputError, match="no \\*.png"):
        list(load_chips(tmp_path))
