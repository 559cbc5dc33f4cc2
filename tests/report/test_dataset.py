import json

import numpy as np

from robocompose.dataset.enumerate import EnumerateConfig, enumerate_designs
from robocompose.dataset.nogram import NogramConfig, enumerate_nogram
from robocompose.io import write_table
from robocompose.report.dataset import contact_counts, section


def test_contact_counts_ignore_padding():
    contacts = np.array([[0.1, 0.2, -0.3, 0.4] + [2.0, 0.0] * 6, [2.0, 0.0] * 8])
    assert contact_counts(contacts).tolist() == [2, 0]


def test_section_reports_counts_and_writes_figures(tmp_path):
    data, reports = tmp_path / "data", tmp_path / "reports"
    designs, stats = enumerate_designs(EnumerateConfig(n=5, seed=0, chunk=8), progress=None)
    nogram, nogram_stats = enumerate_nogram(NogramConfig(n=3), progress=None)
    write_table(designs, data / "designs.parquet", "designs")
    write_table(nogram, data / "designs_nogram.parquet", "designs")
    (reports / "metrics").mkdir(parents=True)
    (reports / "metrics" / "enumerate.json").write_text(json.dumps({"grammar": stats.as_dict(),
                                                                     "nogram": nogram_stats.as_dict()}))
    text = section(reports, data, gallery=2, gallery_seed=0)
    assert f"**5** distinct valid designs from **{stats.candidates}**" in text
    assert (reports / "figures" / "gallery.png").stat().st_size > 10_000
    assert (reports / "figures" / "dataset_histograms.png").exists()
