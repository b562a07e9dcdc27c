#!/usr/bin/env python3
"""Test helper: builds a small synthetic checkpoint laid out as InfiniCube's
Lightning diffusion checkpoint from bare UNet weights in a .safetensors file:
state_dict with unet.<name> (live), unet_ema.<name without dots> (EMA copy =
live x 2, plus LitEma's decay/num_updates buffers), scale_factor, the VAE's
tensors under vae.* (--vae), cond_stage_model.* tensors,
hyper_parameters.network.diffuser, and optimizer entries the converter must
leave out.

  make_synthetic_checkpoint.py W.safetensors OUT.ckpt [--kwargs K.json] [--scale S] [--vae VAE.safetensors]
      [--no-ema] [--namespace-hparams] [--bf16] [--nan NAME] [--foreign-object]

With --standalone-vae, W holds a VAE's bare tensors (encoder.*, unet.*) and OUT
is laid out as the VAE's own Lightning checkpoint (autoencoder.py Model: those
names plus a loss module's buffer, hyper_parameters with cut_ratio and
network.unet.params from --kwargs's vae_kwargs, num_blocks as the training
config's unresolved "${tree_depth}" interpolation).
"""

import argparse
import json
import struct
import sys

import numpy as np
import torch


class ForeignObject:
    """Stands for any pickled class (an OmegaConf config, a callback) outside the safe set."""


def read_safetensors(path):
    with open(path, "rb") as f:
        n = struct.unpack("<Q", f.read(8))[0]
        header = json.loads(f.read(n))
        base = 8 + n
        out = {}
        for name, info in header.items():
            if name == "__metadata__":
                continue
            assert info["dtype"] == "F32", "the helper reads float32 only"
            a, b = info["data_offsets"]
            f.seek(base + a)
            arr = np.frombuffer(f.read(b - a), dtype="<f4").reshape(info["shape"])
            out[name] = torch.from_numpy(arr.copy())
        return out


def main():
    p = argparse.ArgumentParser()
    p.add_argument("weights")
    p.add_argument("out")
    p.add_argument("--kwargs", help="JSON file whose unet_kwargs become hyper_parameters.network.diffuser")
    p.add_argument("--scale", type=float, default=0.73)
    p.add_argument("--no-ema", action="store_true")
    p.add_argument("--namespace-hparams", action="store_true", help="hparams as an argparse.Namespace object")
    p.add_argument("--bf16", action="store_true", help="store the live UNet weights as bfloat16")
    p.add_argument("--nan", help="put a NaN into this live UNet tensor")
    p.add_argument("--vae", help="bare VAE weights (.safetensors) to store under vae.*")
    p.add_argument("--standalone-vae", action="store_true", help="W is a VAE: write the VAE's own checkpoint")
    p.add_argument("--foreign-object", action="store_true",
                   help="pickle an object of a class the converter must leave unbuilt")
    a = p.parse_args()
    w = read_safetensors(a.weights)
    if a.standalone_vae:
        sd = dict(w)
        sd["loss.semantic_weight_buffer"] = torch.ones(23)
        ckpt = {"epoch": 7, "global_step": 6250, "state_dict": sd}
        if a.kwargs:
            with open(a.kwargs) as f:
                kw = dict(json.load(f)["vae_kwargs"])
            hp = {"cut_ratio": kw.pop("cut_ratio"), "with_normal_branch": kw.pop("with_normal_branch", False),
                  "with_semantic_branch": kw.pop("with_semantic_branch", True), "tree_depth": kw["num_blocks"],
                  "num_semantic": 23, "dim_semantic": 32, "use_input_semantic": True, "use_input_normal": False,
                  "network": {"unet": {"target": "StructPredictionNet", "params": kw}}}
            hp["network"]["unet"]["params"]["num_blocks"] = "${tree_depth}"
            ckpt["hyper_parameters"] = hp
        torch.save(ckpt, a.out)
        return 0
    sd = {}
    for name, t in w.items():
        sd["unet." + name] = t.to(torch.bfloat16) if a.bf16 else t
        if not a.no_ema:
            sd["unet_ema." + name.replace(".", "")] = t * 2.0
    if a.nan:
        sd["unet." + a.nan].view(-1)[0] = float("nan")
    if not a.no_ema:
        sd["unet_ema.decay"] = torch.tensor(0.9999)
        sd["unet_ema.num_updates"] = torch.tensor(1234, dtype=torch.int32)
    sd["scale_factor"] = torch.tensor(a.scale)
    if a.vae:
        for name, t in read_safetensors(a.vae).items():
            sd["vae." + name] = t
    sd["cond_stage_model.embed.weight"] = torch.ones(4, 3)
    ckpt = {"epoch": 7, "global_step": 6250, "state_dict": sd, "optimizer_states": [{"lr": 1e-4}]}
    if a.kwargs:
        with open(a.kwargs) as f:
            kw = json.load(f)["unet_kwargs"]
        hp = {"network": {"diffuser": kw}, "scale_by_std": True}
        ckpt["hyper_parameters"] = argparse.Namespace(**hp) if a.namespace_hparams else hp
    if a.foreign_object:
        ckpt["callbacks"] = {"cb": ForeignObject()}
    torch.save(ckpt, a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
