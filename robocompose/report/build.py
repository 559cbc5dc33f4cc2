"""The report stage: every section, as reports/report.md and a self-contained reports/report.html.

The report reads artifacts only: the stages simulate, render and run models; it tabulates and plots what they
wrote, and quotes the params it is given (`ReportParams`; the stage reads them from params.yaml).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from robocompose.control.mppi import MPPIConfig
from robocompose.io import atomic_write_text


@dataclass(frozen=True)
class ReportParams:
    """The params the report quotes beside the results: those the stages that made them ran with."""

    mppi: MPPIConfig  # evaluation.mppi
    eval_cache: Path | None  # evaluation.cache: the measured seconds per evaluation (None: no cache kept)
    gallery: dict  # the `gallery:` section (the enumerate stage's picture)
    train_vae: dict  # the `train_vae:` section
    modular: dict  # the `modular:` section


def build_report(params: ReportParams, reports_dir: Path = Path("reports"), data_dir: Path = Path("data")) -> Path:
    from robocompose.report import (
        dataset,
        eggan,
        evaluation,
        fidelity,
        gate,
        glso,
        latent,
        metadata,
        modular,
        serve,
        teams,
        verdicts,
    )

    body = [
        dataset.section(reports_dir, data_dir, params.gallery),
        evaluation.section(reports_dir, data_dir, params.mppi, params.eval_cache),
        fidelity.section(reports_dir, params.mppi),
        latent.section(reports_dir, data_dir, params.train_vae),
        glso.section(reports_dir, data_dir),
        glso.campaign_section(reports_dir),
        modular.section(reports_dir, data_dir, params.modular),
        eggan.section(reports_dir, data_dir),
        gate.section(reports_dir),
        teams.section(reports_dir, data_dir),
        serve.section(reports_dir),
        metadata.section(reports_dir),
    ]
    sections = "\n\n".join(s.strip() for s in body)
    lead = ["# robocompose report",
            "Thesis numbers stand beside ours with the settings used; every figure of ours is measured with the "
            "evaluator named in its section.", verdicts.summary(sections)]
    text = "\n\n".join(s.strip() for s in lead) + "\n\n" + sections + "\n"
    atomic_write_text(reports_dir / "report.md", text)
    atomic_write_text(reports_dir / "report.html", to_html(text, "robocompose report"))
    return reports_dir / "report.md"


def to_html(markdown: str, title: str) -> str:
    from markdown_it import MarkdownIt

    body = MarkdownIt("commonmark").enable("table").render(markdown)
    style = ("body{font-family:sans-serif;max-width:60em;margin:2em auto;line-height:1.45}"
             "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:.25em .6em}img{max-width:100%}")
    return (f"<!doctype html>\n<html><head><meta charset='utf-8'><title>{title}</title><style>{style}</style>"
            f"</head><body>\n{body}</body></html>\n")
