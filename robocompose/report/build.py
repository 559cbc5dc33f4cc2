"""The report stage: every section, as reports/report.md and a self-contained reports/report.html."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from robocompose.io import atomic_write_text


@dataclass(frozen=True)
class ReportConfig:
    """The `report:` section of params.yaml."""

    gallery: int = 12  # random designs pictured
    gallery_seed: int = 0


def build_report(config: ReportConfig, reports_dir: Path = Path("reports"), data_dir: Path = Path("data")) -> Path:
    from robocompose.report import dataset, eggan, evaluation, fidelity, glso, latent, metadata, modular, teams

    sections = [
        "# robocompose report",
        "Thesis numbers stand beside ours with the settings used; every figure of ours is measured with the "
        "evaluator named in its section.",
        dataset.section(reports_dir, data_dir, config.gallery, config.gallery_seed),
        evaluation.section(reports_dir, data_dir),
        fidelity.section(reports_dir),
        latent.section(reports_dir, data_dir),
        glso.section(reports_dir, data_dir),
        modular.section(reports_dir, data_dir),
        eggan.section(reports_dir, data_dir),
        teams.section(reports_dir, data_dir),
        metadata.section(reports_dir),
    ]
    text = "\n\n".join(s.strip() for s in sections) + "\n"
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
