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


def test_stop_logit_is_glsos_equation_for_each_predictions_own_token_tree_and_messages():
    torch.manual_seed(0)
    decoder = GraphVAE(VAEConfig(hidden=8, latent=3)).decoder
    tokens, tree = torch.tensor([3, 0, 3, 41, 7]), torch.tensor([0, 1, 1, 2, 0])
    z, incoming = torch.randn(3, 3), torch.randn(5, 8)
    x = decoder.gru.embedding.weight[tokens]  # (P, H): each prediction's node token
    # u . tau(V tau(W1 x + W3 sum h) + W2 z), GLSO's U_i = (W1, W3), U = (V, W2), U_o = u
    inner = torch.relu(x @ decoder.stop_x.weight.T + decoder.stop_x.bias + incoming @ decoder.stop_h.weight.T)
    hidden = torch.relu(inner @ decoder.stop_hidden.weight.T + decoder.stop_hidden.bias
                        + z[tree] @ decoder.stop_z.weight.T)
    expected = (hidden @ decoder.stop_u.weight.T + decoder.stop_u.bias).squeeze(1)
    with torch.no_grad():
        torch.testing.assert_close(decoder.stop_logits(tokens, tree, z, incoming), expected)
