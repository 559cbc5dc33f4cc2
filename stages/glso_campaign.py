"""DVC stage `glso_campaign`: the seeded GLSO campaign's statistics from its committed runs.

params (glso_campaign) + measured/glso_campaign/ (finished runs, re-scores, held-out scores) and
measured/glso_pilot/ (the pilot of GLSO's variants, `robocompose glso-campaign pilot`) ->
reports/metrics/glso_campaign.json, reports/plots/glso_campaign.png. With `run: false` (default profile) it only
summarises what is committed (seconds; it never simulates, missing held-out pieces are reported as missing);
with `run: true` (paper profile) it first runs every missing run, re-score and held-out piece (core-hours,
resumable, over `compute:`).
"""

from robocompose.glso import campaign
from robocompose.io import atomic_write_json
from robocompose.io.timings import timed
from robocompose.params import load_section
from robocompose.stage import run_stage


def main() -> None:
    config = load_section(campaign.CampaignConfig, "glso_campaign")
    with timed("glso_campaign") as timing:
        if config.run:
            from robocompose.evaluation.evaluate import EvaluationConfig
            from robocompose.fanout.compute import ComputeConfig
            from robocompose.glso.runs import GLSOConfig

            with load_section(ComputeConfig, "compute").executor() as executor:
                campaign.run_campaign(config, load_section(GLSOConfig, "glso"),
                                      load_section(EvaluationConfig, "evaluation"), campaign.campaign_rung(config),
                                      executor)
        summary = campaign.summarise(config)
        timing["runs"] = summary["runs"]
        campaign.plot(summary, "reports/plots/glso_campaign.png")
        summary["pilot"] = campaign.pilot_summary(config)  # GLSO's variants, committed beside the campaign
        atomic_write_json("reports/metrics/glso_campaign.json", {k: v for k, v in summary.items() if k != "curves"})


if __name__ == "__main__":
    run_stage(main)
