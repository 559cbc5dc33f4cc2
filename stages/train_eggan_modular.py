"""DVC stage `train_eggan_modular`: EG-GAN-crowding, EG-GAN and the Fit2form, DQN and MolGAN baselines on modular
robots (thesis ch. 4, 5.1), each on the same problem and budget of evaluations.

params (compute, modular, eggan_modular) + the pool's tables -> models/eggan_modular_{crowding,ga,fit2form,dqn,
molgan}.{pt,json} (+ .mcap for the EG-GAN variants), their checkpoints (models/checkpoints/, persistent),
reports/plots/eggan_modular_*.csv, reports/metrics/eggan_modular.json. On the pool's tables the learners train
side by side on the compute workers; a killed run resumes from its checkpoints.
"""

from pathlib import Path

from robocompose.fanout.compute import ComputeConfig
from robocompose.io import atomic_write_json
from robocompose.io.timings import timed
from robocompose.modular.eggan_params import EgganModularParams
from robocompose.modular.experiments.generative import train_all
from robocompose.modular.params import ModularParams
from robocompose.params import load_section
from robocompose.stage import run_stage


def main() -> None:
    modular, params = load_section(ModularParams, "modular"), load_section(EgganModularParams, "eggan_modular")
    compute = load_section(ComputeConfig, "compute")
    with timed("train_eggan_modular") as timing, compute.executor("train_eggan_modular") as executor:
        metrics, timing["train_seconds"] = train_all(modular, params, compute.open_cache(), executor, Path("models"))
        timing["real_evaluations"] = {method: m["real_evaluations"] for method, m in metrics.items()}
    atomic_write_json("reports/metrics/eggan_modular.json", metrics)


if __name__ == "__main__":
    run_stage(main)
