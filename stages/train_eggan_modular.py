"""DVC stage `train_eggan_modular`: EG-GAN-crowding, EG-GAN and the Fit2form, DQN and MolGAN baselines on modular
robots (thesis ch. 4, 5.1), each on the same problem and budget of real rollouts.

params (compute, modular, eggan_modular) -> models/eggan_modular_{crowding,ga,fit2form,dqn,molgan}.{pt,json}
(+ .mcap for the EG-GAN variants), their checkpoints (models/checkpoints/, persistent),
reports/plots/eggan_modular_*.csv, reports/metrics/eggan_modular.json.
Real rollouts go through the shared evaluation cache; a killed run resumes from its checkpoints.
"""

from functools import partial
from pathlib import Path

from robocompose.eggan.learners import baselines
from robocompose.fanout.compute import ComputeConfig
from robocompose.io import atomic_write_json
from robocompose.io.timings import timed
from robocompose.modular.eggan_experiments import train_baseline, train_variant
from robocompose.modular.eggan_params import VARIANTS, EgganModularParams
from robocompose.modular.params import ModularParams
from robocompose.params import load_section
from robocompose.stage import run_stage


def main() -> None:
    modular, params = load_section(ModularParams, "modular"), load_section(EgganModularParams, "eggan_modular")
    compute = load_section(ComputeConfig, "compute")
    cache = compute.open_cache()
    trainers = {**{variant: partial(train_variant, variant) for variant in VARIANTS},
                **{name: partial(train_baseline, name) for name in baselines("modular")}}
    metrics = {}
    with timed("train_eggan_modular") as timing, compute.executor() as executor:
        for method, train_method in trainers.items():
            started = timing.elapsed()
            metrics[method] = train_method(modular, params, cache, executor, Path("models"), progress=True)
            timing.setdefault("train_seconds", {})[method] = round(timing.elapsed() - started, 1)
        timing["real_evaluations"] = {v: m["real_evaluations"] for v, m in metrics.items()}
    atomic_write_json("reports/metrics/eggan_modular.json", metrics)

if __name__ == "__main__":
    run_stage(main)
