"""`dvc plots show` renders the training curves dvclive writes, offline (vega inlined in the repository's page)."""

import shutil
import subprocess
import sys

from robocompose.io.provenance import ROOT
from robocompose.latent.curves import LOG_FIELDS
from robocompose.latent.train import log_row, training_log

# Waits until vega-embed has drawn every chart, then tells how many plot divs hold a drawn chart.
CHARTS_DRAWN = """new Promise(resolve => {
  const divs = () => Array.from(document.querySelectorAll('body > div[id]'));  // vega-embed fills them
  const drawn = () => divs().filter(d => d.querySelector('canvas, svg'));
  const wait = (n) => drawn().length === divs().length || n > 200
    ? resolve(JSON.stringify({divs: divs().length, drawn: drawn().length, vega: typeof vegaEmbed}))
    : setTimeout(() => wait(n + 1), 50);
  wait(0);
})"""


def test_dvc_plots_show_renders_the_vae_curves_offline(tmp_path, monkeypatch, in_browser):
    from dvc.repo import Repo

    shutil.copy(ROOT / "dvc.yaml", tmp_path / "dvc.yaml")
    Repo.init(str(tmp_path), no_scm=True).close()
    shutil.copy(ROOT / ".dvc" / "config", tmp_path / ".dvc" / "config")
    shutil.copytree(ROOT / ".dvc" / "plots", tmp_path / ".dvc" / "plots")
    monkeypatch.chdir(tmp_path)
    for variant in ("full", "nopred", "nogram"):
        with training_log(f"reports/training/vae_{variant}") as live:  # where the train_vae stage logs
            for step in (100, 200):
                log_row(live, {**dict.fromkeys(LOG_FIELDS, 1.0), "step": step, "heldout_reconstruction": step / 1000})
    done = subprocess.run([sys.executable, "-m", "dvc", "plots", "show", "-o", "out"], capture_output=True,
                          text=True)
    assert done.returncode == 0, done.stderr
    page = (tmp_path / "out" / "index.html").read_text()
    assert "<script src=" not in page and "cdn.jsdelivr" not in page  # nothing fetched from the network
    assert "vega-embed 6.18.2" in page and page.count("vegaEmbed(") >= 2
    assert "Graph VAE, held-out exact reconstruction" in page and '"reconstruction": "0.2"' in page
    assert "vegaEmbed('#reports_training_vae_nogram_plots_metrics_heldout_reconstruction_tsv'" in page
    shown = in_browser(tmp_path / "out" / "index.html", CHARTS_DRAWN)  # no network: only the inlined vega
    assert shown["vega"] == "function" and shown["divs"] >= 2 and shown["drawn"] == shown["divs"], shown


def test_dvc_plots_diff_overlays_an_older_revision_offline(tmp_path, monkeypatch):
    from dvc.repo import Repo

    def git(*args):
        subprocess.run(["git", "-c", "user.name=t", "-c", "user.email=t@t", *args], cwd=tmp_path, check=True,
                       capture_output=True)

    def curves(reconstruction: float) -> None:
        with training_log("reports/training/vae_full") as live:
            for step in (100, 200):
                log_row(live, {**dict.fromkeys(LOG_FIELDS, 1.0), "step": step,
                               "heldout_reconstruction": reconstruction + step / 1000})

    git("init", "-q")
    shutil.copy(ROOT / "dvc.yaml", tmp_path / "dvc.yaml")
    Repo.init(str(tmp_path)).close()
    shutil.copy(ROOT / ".dvc" / "config", tmp_path / ".dvc" / "config")
    shutil.copytree(ROOT / ".dvc" / "plots", tmp_path / ".dvc" / "plots")
    monkeypatch.chdir(tmp_path)
    git("add", "-A")
    git("commit", "-qm", "pipeline")  # dvclive reads the revision it logs at
    curves(0.0)
    git("add", "-A")
    git("commit", "-qm", "run 1")
    curves(0.5)
    git("commit", "-qam", "run 2")
    done = subprocess.run([sys.executable, "-m", "dvc", "plots", "diff", "HEAD~1", "-o", "out"], capture_output=True,
                          text=True)
    assert done.returncode == 0, done.stderr
    page = (tmp_path / "out" / "index.html").read_text()
    assert "<script src=" not in page and "cdn.jsdelivr" not in page  # offline, as `plots show`
    assert '"rev": "HEAD~1"' in page and '"rev": "workspace"' in page
    assert '"reconstruction": "0.2"' in page and '"reconstruction": "0.7"' in page  # both revisions' curves
