import numpy as np
import torch

from robocompose.latent.batch import collate
from robocompose.latent.constraints import replay
from robocompose.latent.model import GraphVAE, VAEConfig, level_sweeps
from robocompose.latent.model import gather as gather_rows


def test_label_accuracy_counts_only_labels_the_mask_leaves_open(trees):
    torch.manual_seed(0)
    replays = [replay(t, "grammar", 50) for t in trees[:16]]
    batch = collate(replays, np.zeros((len(replays), 16)))
    model = GraphVAE(VAEConfig(hidden=16, latent=4))
    with torch.no_grad():
        messages = level_sweeps([model.encoder.gru, model.decoder.gru], batch)
        mean, _ = model.encoder(batch, messages[0])
        out = model.decoder(batch, mean, messages[1])
        logits = model.decoder.label_logits(mean, batch.label_tree, gather_rows(messages[1], batch.label_incoming),
                                            batch.label_mask)
    hits = logits.argmax(1) == batch.label_target
    free = batch.label_mask.sum(1) > 1
    assert 0 < int(free.sum()) < len(free)  # the root and the mirrored side are forced
    assert hits[~free].all()  # a forced label is always "right": counting it would inflate the accuracy
    torch.testing.assert_close(out["label_acc"], hits[free].float().mean())


def test_stop_head_has_glsos_extra_hidden_layer():
    decoder = GraphVAE(VAEConfig(hidden=8, latent=3)).decoder
    # x and message -> hidden (U_i), then with z -> hidden (U), then -> 1 (U_o)
    assert decoder.stop_x.in_features == decoder.stop_h.in_features == 8
    assert (decoder.stop_hidden.in_features, decoder.stop_z.in_features, decoder.stop_u.out_features) == (8, 3, 1)
