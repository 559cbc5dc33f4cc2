"""The `modular_exhaustive` stage's picture of the test terrains: height maps over each terrain's exhaustive best
design at its start pose (pybullet CPU renderer). The report shows it; it renders nothing itself."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from robocompose.modular.params import ModularParams
from robocompose.modular.terrain import Terrain, generate_terrain, height_map


def plot_terrains(summary: pd.DataFrame, params: ModularParams, path: Path) -> Path:
    """One column per row of `summary` (`truth_summary` rows: terrain_seed, best_design, optimum)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(summary)
    fig, axes = plt.subplots(2, n, figsize=(5 * n, 5.5), squeeze=False)
    for k, row in enumerate(summary.itertuples()):
        terrain = generate_terrain(row.terrain_seed, params.eval.terrain)
        grid = height_map(terrain)
        (x0, x1), (y0, y1) = params.eval.terrain.x_range, params.eval.terrain.y_range
        top = axes[0, k].imshow(grid.T, origin="lower", extent=[x0, x1, y0, y1], cmap="copper", vmin=0,
                                vmax=params.eval.terrain.max_height_range[1])
        axes[0, k].set_title(f"terrain {row.terrain_seed} (max block {terrain.max_height * 100:.1f} cm)")
        axes[0, k].set_xlabel("x (m)")
        axes[0, k].set_ylabel("y (m)")
        axes[1, k].imshow(design_picture(row.best_design, terrain))
        axes[1, k].set_title(f"best: {row.best_design} ({row.optimum:.2f} m)")
        axes[1, k].axis("off")
    fig.subplots_adjust(hspace=0.35)
    fig.colorbar(top, ax=axes[0, :].tolist(), label="block height (m)", shrink=0.8)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def design_picture(design: str, terrain: Terrain) -> np.ndarray:
    """An RGB image of `design` at its start pose on `terrain`, from the front-left and above."""
    import pybullet as pb

    from robocompose.modular.robot import build_robot
    from robocompose.modular.terrain import add_terrain
    from robocompose.sim.physics import connect
    from robocompose.sim.render import camera_image

    client = connect()
    try:
        add_terrain(client, terrain, visual=True)
        build_robot(design, client, visual=True)
        return camera_image(client, (0.3, 0.0, 0.15), distance=1.6, yaw=-60.0, pitch=-30.0)
    finally:
        pb.disconnect(physicsClientId=client)
