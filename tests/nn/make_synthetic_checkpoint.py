#!/usr/bin/env python3
"""Test helper: builds a small synthetic checkpoint laid out as InfiniCube's
Lightning diffusion checkpoint from bare UNet weights in a .safetensors file:
state_dict with unet.<name> (live), unet_ema.<name without dots> (EMA copy =
live x 2, plus LitEma's decay/num_updates buffers), scale_factor, a few vae.*
and cond_stage_model.* tensors, hyper_parameters.network.diffuser, and
optimizer entries the converter must leave out.

  make_synthetic_checkpoint.py W.safetensors OUT.ckpt [--kwargs K.json] [--scale S]
      [--no-ema] [--namespace-hparams] [--bf16] [--nan NAME] [--foreign-object]
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
    p.add_argument("--foreign-object", action="store_true",
                   help="pickle an object of a class the converter must leave unbuilt")
    a = p.parse_args()
    w = read_safetensors(a.weights)
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
    sd["vae.encoder.mix_fc.weight"] = torch.arange(65 * 32, dtype=torch.float32).reshape(32, 65) / 100.0
    sd["vae.encoder.mix_fc.bias"] = torch.zeros(32)
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
