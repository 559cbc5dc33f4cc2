"""DVC stage `vae_landscape`: latent means of dataset designs (full and nopred VAEs) in 2-D, with flat-terrain
scores from the evaluator and the designs the committed fidelity searches and the GLSO campaign scored ->
data/vae_landscape.parquet (thesis Fig. 7.1); the k-NN predictability of those scores in latent space
(`knn_predictability`) and the gate a thesis-scale VAE must pass before a campaign uses it (`gate`, issue 42: the
latent k-NN Spearman beats a node-type-count baseline's by >= 0.1, and a 0.5-wide window around the best designs
decodes to >= 10 distinct designs; from the scores already there, no simulation) -> reports/metrics/vae_landscape.json.
The VAE at the thesis's scale (vae_thesis, committed pieces) is gated beside them once finished (variant `thesis`);
the JSON says how far its measurement is and which model file it gated (`thesis_scale`).
"""

from robocompose.evaluation.evaluate import EvaluationConfig
from robocompose.fanout.compute import ComputeConfig
from robocompose.io import atomic_write_json, write_table
from robocompose.io.timings import timed
from robocompose.latent import thesis_scale
from robocompose.latent.landscape import LandscapeConfig, landscape
from robocompose.latent.train import load_designs, load_model
from robocompose.params import load_section
from robocompose.stage import run_stage


def main() -> None:
    evaluation = load_section(EvaluationConfig, "evaluation")
    config = load_section(LandscapeConfig, "train_vae.landscape")
    compute = load_section(ComputeConfig, "compute")
    thesis = load_section(thesis_scale.ThesisScaleConfig, "vae_thesis")
    models = {name: load_model(f"models/vae_{name}.pt") for name in ("full", "nopred")}
    if (finished := thesis_scale.finished_model(thesis)) is not None:
        models[thesis_scale.VARIANT] = load_model(finished)
    designs = load_designs("data/designs.parquet", "grammar", models["full"].config.max_nodes)
    with timed("vae_landscape") as timing, compute.executor("vae_landscape") as executor:
        table, knn, gate = landscape(models, designs, config, evaluation, compute.open_cache(), executor)
        timing["evaluated"] = config.evaluated
        write_table(table, "data/vae_landscape.parquet", "vae_landscape")
        atomic_write_json("reports/metrics/vae_landscape.json", {"knn_predictability": knn, "gate": gate,
                                                                  "thesis_scale": thesis_scale.progress(thesis)})


if __name__ == "__main__":
    run_stage(main)
