"""`robocompose sample | encode | decode`: a trained graph VAE from the command line (one JSON object per line)."""

from __future__ import annotations

import argparse
import json
import math

from robocompose.arguments import input_file, int_between, non_negative_int
from robocompose.io.errors import InputError

MAX_SAMPLE = 10_000  # designs `sample` decodes at once, ~0.5 MB each (hidden 450, 50 nodes): about 5 GB at most
MODEL_FILE = input_file("a trained VAE (e.g. models/vae_full.pt)")


def register(subparsers: argparse._SubParsersAction) -> None:
    sample = subparsers.add_parser("sample", help="decode N designs from the prior z ~ N(0, I)")
    sample.add_argument("--model", type=MODEL_FILE, required=True, help="a trained VAE, e.g. models/vae_full.pt")
    sample.add_argument("--n", type=int_between(1, MAX_SAMPLE, "decoded at once, about 0.5 MB each"), required=True,
                        help=f"designs to decode (at most {MAX_SAMPLE:,})")
    sample.add_argument("--seed", type=non_negative_int, default=0)
    sample.set_defaults(handler=_sample)

    encode = subparsers.add_parser("encode", help="print the latent mean of a design given by its rule sequence")
    encode.add_argument("--model", type=MODEL_FILE, required=True)
    encode.add_argument("--rules", required=True, help="comma-separated rule indices")
    encode.set_defaults(handler=_encode)

    decode = subparsers.add_parser("decode", help="decode one latent point, e.g. --z 0.1,-1.2,...")
    decode.add_argument("--model", type=MODEL_FILE, required=True)
    decode.add_argument("--z", required=True, help="comma-separated latent coordinates (--z=-0.3,... if negative)")
    decode.set_defaults(handler=_decode)


def design_json(tree) -> dict:
    """A decoded design: its rule sequence (None if the grammar cannot make it), id and tree."""
    from robocompose.latent.constraints import grammar_rules, is_derivable

    rules = list(grammar_rules(tree)) if is_derivable(tree) else None
    return {"design_id": tree.design_id, "rules": rules, "n_links": tree.n_links, "n_joints": tree.n_joints,
            "parents": list(tree.parents), "tokens": list(tree.tokens)}


def parse_latent(text: str, dims: int) -> list[float]:
    """Parse --z "0.1,-1.2,...": exactly `dims` finite numbers."""
    try:
        z = [float(v) for v in text.split(",")]
    except ValueError:
        raise InputError(f"--z: expected {dims} comma-separated numbers, found {text!r}") from None
    if len(z) != dims:
        raise InputError(f"--z: expected {dims} coordinates (the model's latent space), found {len(z)}")
    bad = next((v for v in z if not math.isfinite(v)), None)
    if bad is not None:
        raise InputError(f"--z: expected finite numbers, found {bad}")
    return z


def _sample(args: argparse.Namespace) -> int:
    from robocompose.latent.metrics import prior_decodes
    from robocompose.latent.train import load_model

    for tree in prior_decodes(load_model(args.model), args.n, args.seed):
        print(json.dumps(design_json(tree)))
    return 0


def _encode(args: argparse.Namespace) -> int:
    import numpy as np
    import torch

    from robocompose.grammar.derivation import derive, parse_rules
    from robocompose.latent.batch import collate
    from robocompose.latent.constraints import replay
    from robocompose.latent.train import load_model

    tree = derive(parse_rules(args.rules, "--rules")).tree  # the flag first: no model is loaded to reject it
    model = load_model(args.model)
    with torch.no_grad():
        mean, _ = model.encoder(collate([replay(tree, model.config.constraints, model.config.max_nodes)],
                                        np.zeros((1, 16))))
    print(json.dumps({"design_id": tree.design_id, "z": [round(float(v), 6) for v in mean[0]]}))
    return 0


def _decode(args: argparse.Namespace) -> int:
    import torch

    from robocompose.latent.train import load_model

    model = load_model(args.model)
    z = parse_latent(args.z, model.config.latent)
    print(json.dumps(design_json(model.decoder.decode(torch.tensor([z]))[0].tree())))
    return 0
