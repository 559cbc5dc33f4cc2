import json

from robocompose.dataset.enumerate import EnumerateConfig, enumerate_designs
from robocompose.dataset.nogram import NogramConfig, enumerate_nogram
from robocompose.dataset.summary import floor_points
from robocompose.io import write_table
from robocompose.report.dataset import section


def test_section_reports_counts_draws_histograms_and_links_the_stage_gallery(tmp_path):
    data, reports = tmp_path / "data", tmp_path / "reports"
    designs, stats = enumerate_designs(EnumerateConfig(n=5, seed=0, chunk=8), progress=None)
    nogram, nogram_stats = enumerate_nogram(NogramConfig(n=3), progress=None)
    write_table(designs, data / "designs.parquet", "designs")
    write_table(nogram, data / "designs_nogram.parquet", "designs")
    (reports / "metrics").mkdir(parents=True)
    points = floor_points(designs)
    (reports / "metrics" / "enumerate.json").write_text(json.dumps({"grammar": stats.as_dict(),
                                                                     "nogram": nogram_stats.as_dict(),
                                                                     "floor_points": points}))
    text = section(reports, data, {"designs": 2, "seed": 7})
    assert f"**5** distinct valid designs from **{stats.candidates}**" in text
    median = sorted(int(k) for k, n in points.items() for _ in range(n))[2]
    assert f"Floor points per kept design: median {median}." in text
    assert "Gallery: 2 random designs of the dataset (seed 7)" in text and "![gallery](plots/gallery.png)" in text
    assert (reports / "figures" / "dataset_histograms.png").exists()
    assert not (reports / "figures" / "gallery.png").exists()  # the enumerate stage draws it, not the report
