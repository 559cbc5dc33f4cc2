"""DVC stage `report`: every stage's outputs -> reports/report.md, reports/report.html, reports/figures/."""

from robocompose.io.timings import timed
from robocompose.params import load_section
from robocompose.report.build import ReportConfig, build_report
from robocompose.stage import run_stage


def main() -> None:
    with timed("report"):
        build_report(load_section(ReportConfig, "report"))


if __name__ == "__main__":
    run_stage(main)
