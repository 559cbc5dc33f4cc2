"""Report section for the grammar dataset: counts, histograms, and the gallery with the reference designs.

Built from the `enumerate` stage's outputs: the design tables, reports/metrics/enumerate.json (with the floor
points per design) and its gallery picture, reports/plots/gallery.png.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robocompose.io import read_table
from robocompose.io.atomic import read_json


def section(reports_dir: Path, data_dir: Path, gallery: dict) -> str:
    """`gallery`: the `gallery:` params the enumerate stage drew its picture with."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figures = Path(reports_dir) / "figures"
    figures.mkdir(parents=True, exist_ok=True)
    designs = read_table(Path(data_dir) / "designs.parquet", "designs")
    nogram = read_table(Path(data_dir) / "designs_nogram.parquet", "designs")
    stats = read_json(Path(reports_dir) / "metrics" / "enumerate.json")
    grammar = stats["grammar"]
    points = stats["floor_points"]  # number of floor points -> designs
    counts = np.repeat([int(k) for k in points], list(points.values()))

    fig, axes = plt.subplots(1, 2, figsize=(9, 3.2))
    sizes = np.concatenate([designs["n_links"], nogram["n_links"]])
    bins = np.arange(sizes.min(), sizes.max() + 2) - 0.5
    axes[0].hist(designs["n_links"], bins=bins, color="#3b6fc4", label="grammar")
    axes[0].hist(nogram["n_links"], bins=bins, histtype="step", color="#d95f02", label="no grammar")
    axes[0].set(xlabel="links per design", ylabel="designs", title="Design size")
    axes[0].legend()
    axes[1].hist(counts, bins=np.arange(0, 10) - 0.5, color="#3b6fc4")
    axes[1].set(xlabel="floor contact points at rest (max 8)", ylabel="designs", title="Rest contacts")
    fig.tight_layout()
    fig.savefig(figures / "dataset_histograms.png", dpi=110)
    plt.close(fig)

    from robocompose.io.timings import read_timings

    timing = read_timings(Path(reports_dir) / "timings.json").get("enumerate", {})
    speed = (f" at {timing['designs_per_s']} designs/s on this machine (thesis: 5e5 designs in ~4 h on 8 cores, "
             "~35/s)" if "designs_per_s" in timing else "")
    rejected = ", ".join(f"{k.replace('_', ' ')} {v}" for k, v in grammar["rejected"].items())
    nogram_stats = stats["nogram"]
    return "\n".join([
        "## Grammar dataset (thesis 7.1)",
        "",
        f"- **{grammar['kept']}** distinct valid designs from **{grammar['candidates']}** random derivations "
        f"(uniform over applicable rules, depth limit 40){speed}. Rejected, each candidate under the first rule "
        f"it fails: {rejected}.",
        f"- **{grammar['duplicates']}** duplicates removed (same canonical design tree); the thesis did not "
        "deduplicate.",
        f"- Links per design: median {int(designs['n_links'].median())}, range {designs['n_links'].min()}-"
        f"{designs['n_links'].max()}; actuated joints: median {int(designs['n_joints'].median())}.",
        "- Contact vector as GLSO computes it: front at x = 0, lowest point on the floor, 10 rest steps at dt "
        "1/24 s; one point per contact pair among the first 8 pairs, off-floor points dropped "
        f"({grammar.get('dropped_points', 0)} points from {grammar.get('designs_with_dropped_points', 0)} kept "
        "designs); (forward, lateral) x 10, sorted by forward position (the thesis; GLSO's code keeps Bullet's "
        "pair order), padded with (2, 0). Rejected when fewer than 4 floor points or a floor point lies on the "
        f"mid-plane away from the front. Floor points per kept design: median {int(np.median(counts))}.",
        f"- No-grammar ablation set (GLSO's `collect_random_data.py`): {len(nogram)} random graphs of 2-24 nodes, "
        "any of the 42 tokens anywhere, parents uniform among earlier nodes (at most 3 children, 4 at the root); "
        f"not simulated, no contacts ({nogram_stats['duplicates']} repeated designs drawn again).",
        "",
        "![dataset histograms](figures/dataset_histograms.png)",
        "",
        f"Gallery: {gallery['designs']} random designs of the dataset (seed {gallery['seed']}) and the two "
        "reference designs (blue: body links, orange: limb links), at rest on flat ground, pybullet CPU renderer "
        "(drawn by the `enumerate` stage).",
        "",
        "![gallery](plots/gallery.png)",
        "",
    ])
