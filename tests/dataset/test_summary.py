import numpy as np
import pandas as pd
import pytest
from PIL import Image

from robocompose.dataset.enumerate import EnumerateConfig, enumerate_designs
from robocompose.dataset.summary import GalleryConfig, contact_counts, draw_gallery, floor_points
from robocompose.io.errors import InputError


def test_contact_counts_ignore_padding():
    contacts = np.array([[0.1, 0.2, -0.3, 0.4] + [2.0, 0.0] * 6, [2.0, 0.0] * 8])
    assert contact_counts(contacts).tolist() == [2, 0]


def test_floor_points_count_designs_per_number_of_points():
    rows = [[0.1, 0.2, -0.3, 0.4] + [2.0, 0.0] * 6, [2.0, 0.0] * 8, [0.5, 0.1] + [2.0, 0.0] * 7,
            [0.1, 0.2, -0.3, 0.4] + [2.0, 0.0] * 6]
    assert floor_points(pd.DataFrame({"contacts": [np.array(r, dtype=np.float32) for r in rows]})) == \
        {"0": 1, "1": 1, "2": 2}


def test_gallery_pictures_the_references_and_the_picked_designs_the_same_way_twice(tmp_path):
    designs, _ = enumerate_designs(EnumerateConfig(n=3, seed=0, chunk=8), progress=None)
    first = draw_gallery(designs, GalleryConfig(designs=2, seed=0), tmp_path / "a" / "gallery.png")
    second = draw_gallery(designs, GalleryConfig(designs=2, seed=0), tmp_path / "b" / "gallery.png")
    assert first.stat().st_size > 10_000 and not (tmp_path / "a" / "gallery.tile.png").exists()
    assert np.array_equal(np.asarray(Image.open(first)), np.asarray(Image.open(second)))
    fewer = draw_gallery(designs, GalleryConfig(designs=1, seed=0), tmp_path / "c" / "gallery.png")
    assert not np.array_equal(np.asarray(Image.open(fewer)), np.asarray(Image.open(first)))  # one tile left empty


def test_a_negative_gallery_size_is_an_input_error():
    with pytest.raises(InputError, match="designs: expected an integer >= 0, found -1"):
        GalleryConfig(designs=-1)
