import math

from robocompose.latent.curves import LOG_FIELDS, read_curves


def test_curves_merge_into_one_row_per_step_with_gaps_where_a_curve_was_not_logged(tmp_path):
    metrics = tmp_path / "plots" / "metrics"
    (metrics / "train").mkdir(parents=True)
    (metrics / "heldout").mkdir()
    (metrics / "train" / "loss.tsv").write_text("step\tloss\n100\t2.0\n200\t1.5\n")
    (metrics / "heldout" / "reconstruction.tsv").write_text("step\treconstruction\n200\t0.25\n")
    frame = read_curves(tmp_path)
    assert list(frame.columns) == list(LOG_FIELDS) and frame["step"].tolist() == [100, 200]
    assert frame["loss"].tolist() == [2.0, 1.5]
    assert math.isnan(frame["heldout_reconstruction"][0]) and frame["heldout_reconstruction"][1] == 0.25
    assert frame["kl"].isna().all()  # not logged at all
