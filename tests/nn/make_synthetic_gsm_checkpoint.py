#!/usr/bin/env python3
"""Test helper: writes a synthetic checkpoint laid out as InfiniCube's released GSM
Lightning checkpoint (gsm_vs02_res512_view1_dual_branch_sky_mlp_modulator.ckpt,
PyTorch Lightning 1.9) from a GSM reference case folder (its weights.safetensors
and config.json):
  state_dict        every weight of the case (img_encoder.*, skybox.*, backbone.*;
                    num_batches_tracked int64) plus two loss.* tensors
  hyper_parameters  the case's hparams as the Lightning module saved them: an
                    OmegaConf DictConfig (hparams_type names its class) whose
                    dataset and supervision entries are the training configs'
                    unresolved interpolations ("${_attr_subfolders}", "${render_weight}")
                    where they equal their targets
  optimizer_states, lr_schedulers, callbacks, loops: junk the converter leaves out

  make_synthetic_gsm_checkpoint.py CASE_DIR OUT.ckpt [--set KEY=JSON]... [--drop PREFIX]...
      [--model NAME] [--weights-of-unet] [--emulate-omegaconf] [--plain-hparams]

--set edits hparams (dotted official key, JSON value); --drop removes the weights
under a prefix; --model sets hparams.model; --weights-of-unet replaces the GSM
weights with a diffusion UNet's (unet.*). With python3-omegaconf the DictConfig
is OmegaConf's own; without it (or with --emulate-omegaconf) stand-in classes
under OmegaConf's module and class names pickle the same state
({_metadata, _parent, _content} / {_metadata, _parent, _val}).
"""

import argparse
import copy
import json
import struct
import sys
import types
import typing

import numpy as np
import torch

DTYPES = {"F32": np.float32, "I64": np.int64, "I32": np.int32}


def read_safetensors(path):
    with open(path, "rb") as f:
        n = struct.unpack("<Q", f.read(8))[0]
        header = json.loads(f.read(n))
        base = 8 + n
        out = {}
        for name, info in header.items():
            if name == "__metadata__":
                continue
            a, b = info["data_offsets"]
            f.seek(base + a)
            arr = np.frombuffer(f.read(b - a), dtype=DTYPES[info["dtype"]]).reshape(info["shape"])
            out[name] = torch.from_numpy(arr.copy())
        return out


def set_key(tree, dotted, value):
    keys = dotted.split(".")
    for k in keys[:-1]:
        tree = tree[k]
    tree[keys[-1]] = value


def with_interpolations(hp):
    """The training configs' interpolations (train/gsm/gsm.yaml, dataset.yaml) back in place of their values."""
    hp = copy.deepcopy(hp)
    for key in ("render_weight", "alpha_weight", "depth_weight"):
        if hp.get("supervision", {}).get(key) == hp.get(key) and key in hp:
            hp["supervision"][key] = "${" + key + "}"
    for split in ("train_kwargs", "val_kwargs", "test_kwargs"):
        for key, value in hp.get(split, {}).items():
            for target in ("_" + key, key):
                if target in hp and hp[target] == value:
                    hp[split][key] = "${" + target + "}"
                    break
    return hp


def emulated_omegaconf():
    """Stand-ins for OmegaConf's containers: same module and class names, same pickled state."""
    classes = {}

    def module(name):
        return sys.modules.setdefault(name, types.ModuleType(name))

    module("omegaconf")
    for mod, cls in (("omegaconf.dictconfig", "DictConfig"), ("omegaconf.listconfig", "ListConfig"),
                     ("omegaconf.nodes", "AnyNode"), ("omegaconf.base", "ContainerMetadata"), ("omegaconf.base", "Metadata")):
        c = type(cls, (), {"__module__": mod})
        setattr(module(mod), cls, c)
        classes[cls] = c

    def metadata(cls, key):
        m = classes[cls]()
        m.__dict__.update(ref_type=typing.Any, object_type=dict if cls == "ContainerMetadata" else None, optional=True,
                          key=key, flags={}, flags_root=False)
        return m

    def build(value, parent, key):
        if isinstance(value, dict):
            node = classes["DictConfig"]()
            node.__dict__.update(_metadata=metadata("ContainerMetadata", key), _parent=parent, _content={})
            for k, v in value.items():
                node._content[k] = build(v, node, k)
        elif isinstance(value, list):
            node = classes["ListConfig"]()
            node.__dict__.update(_metadata=metadata("ContainerMetadata", key), _parent=parent, _content=[])
            node._content.extend(build(v, node, i) for i, v in enumerate(value))
        else:
            node = classes["AnyNode"]()
            node.__dict__.update(_metadata=metadata("Metadata", key), _parent=parent, _val=value)
        return node

    return lambda hp: build(hp, None, None), classes["DictConfig"], "emulated OmegaConf"


def main():
    p = argparse.ArgumentParser()
    p.add_argument("case")
    p.add_argument("out")
    p.add_argument("--set", action="append", default=[], help="KEY=JSON: change a hyper-parameter")
    p.add_argument("--drop", action="append", default=[], help="leave out the weights under this prefix")
    p.add_argument("--model", help="hparams.model")
    p.add_argument("--weights-of-unet", action="store_true", help="a diffusion UNet's weights instead of the GSM's")
    p.add_argument("--emulate-omegaconf", action="store_true")
    p.add_argument("--plain-hparams", action="store_true", help="hyper_parameters as a plain dict")
    a = p.parse_args()
    with open(a.case.rstrip("/") + "/config.json") as f:
        hp = json.load(f)["hparams"]
    for item in a.set:
        key, value = item.split("=", 1)
        set_key(hp, key, json.loads(value))
    if a.model:
        hp["model"] = a.model
    sd = read_safetensors(a.case.rstrip("/") + "/weights.safetensors")
    sd = {k: v for k, v in sd.items() if not any(k.startswith(d) for d in a.drop)}
    if a.weights_of_unet:
        sd = {"unet.input_blocks.0.0.weight": torch.ones(8, 4, 3, 3, 3), "unet.out.2.weight": torch.ones(4, 8, 3, 3, 3)}
    sd["loss.perceptual_loss.lin0.model.1.weight"] = torch.ones(1, 64, 1, 1)
    sd["loss.perceptual_loss.scaling_layer.shift"] = torch.zeros(1, 3, 1, 1)
    hp = with_interpolations(hp)
    if a.plain_hparams:
        stored, stored_type, how = hp, dict, "a plain dict"
    else:
        try:
            if a.emulate_omegaconf:
                raise ImportError
            import omegaconf
            from omegaconf import DictConfig, OmegaConf
            stored, stored_type, how = OmegaConf.create(hp), DictConfig, f"OmegaConf {omegaconf.__version__}"
        except ImportError:
            build, stored_type, how = emulated_omegaconf()
            stored = build(hp)
    weight = next(iter(sd.values()))
    ckpt = {
        "epoch": 11, "global_step": 52000, "pytorch-lightning_version": "1.9.4", "state_dict": sd,
        "loops": {"fit_loop": {"state_dict": {}, "epoch_progress": {"total": {"ready": 12, "completed": 11}}}},
        "callbacks": {"ModelCheckpoint{'monitor': None, 'mode': 'min'}": {"best_model_score": None,
                                                                         "best_model_path": "", "last_model_path": ""}},
        "optimizer_states": [{"state": {0: {"step": torch.tensor(52000.0), "exp_avg": torch.zeros_like(weight, dtype=torch.float32)}},
                              "param_groups": [{"lr": 1e-4, "betas": (0.9, 0.999), "params": [0]}]}],
        "lr_schedulers": [{"base_lrs": [1e-4], "last_epoch": 52000, "_step_count": 52001}],
        "hparams_name": "hparams", "hyper_parameters": stored,
    }
    if stored_type is not dict:
        ckpt["hparams_type"] = stored_type
    torch.save(ckpt, a.out)
    print(f"hyper_parameters stored as {how}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
