"""What the `enumerate` stage shows of its dataset beside the tables: floor points per design and a gallery.

The report reads both (the counts from reports/metrics/enumerate.json, the picture from reports/plots/); it
renders nothing itself.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from robocompose.grammar.derivation import derive, parse_rules
from robocompose.grammar.references import REFERENCE_DESIGNS
from robocompose.grammar.tree import DesignTree
from robocompose.io.errors import check_field
from robocompose.sim.contacts import PAD_X


@dataclass(frozen=True)
class GalleryConfig:
    """The `gallery:` section of params.yaml."""

    designs: int = 12  # random dataset designs pictured beside the reference designs
    seed: int = 0  # which ones

    def __post_init__(self) -> None:
        check_field(self.designs >= 0, "designs", "an integer >= 0", self.designs)


def contact_counts(contacts: np.ndarray) -> np.ndarray:
    """Number of real (non-padding) points per design from (N, 16) contact vectors."""
    pts = contacts.reshape(len(contacts), -1, 2)
    return (~((pts[:, :, 0] == PAD_X) & (pts[:, :, 1] == 0.0))).sum(axis=1)


def floor_points(designs: pd.DataFrame) -> dict[str, int]:
    """How many designs of a `designs` table have each number of floor contact points at rest."""
    counts = contact_counts(np.stack(designs["contacts"].to_numpy()))
    values, designs_with = np.unique(counts, return_counts=True)
    return {str(int(v)): int(n) for v, n in zip(values, designs_with, strict=True)}


def draw_gallery(designs: pd.DataFrame, config: GalleryConfig, path: Path) -> Path:
    """The reference designs and `config.designs` random designs of the table, each at rest on flat ground."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from PIL import Image

    from robocompose.sim.render import render_design

    rng = np.random.default_rng(config.seed)
    picks = designs.iloc[np.sort(rng.choice(len(designs), size=min(config.designs, len(designs)), replace=False))]
    items = [(name, derive(parse_rules(rules)).tree) for name, rules in REFERENCE_DESIGNS.items()]
    items += [(f"{row.design_id}", DesignTree(tuple(int(p) for p in row.parents), tuple(int(t) for t in row.tokens)))
              for row in picks.itertuples()]
    cols = 4
    rows = -(-len(items) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 2.5 * rows))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tile.png")
    for ax, (name, tree) in zip(axes.ravel(), items, strict=False):
        render_design(tree, tmp, width=320, height=240)
        ax.imshow(np.asarray(Image.open(tmp)))
        ax.set_title(f"{name}\n{tree.n_links} links, {tree.n_joints} joints", fontsize=8)
    for ax in axes.ravel():
        ax.axis("off")
    tmp.unlink(missing_ok=True)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
