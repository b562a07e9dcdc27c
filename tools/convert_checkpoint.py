#!/usr/bin/env python3
"""Converts an official InfiniCube PyTorch Lightning checkpoint (.ckpt) into the
files `icube` loads: .safetensors weights under the official state-dict names,
the model's configuration as JSON, and the latent scale factor.

  tools/convert_checkpoint.py diffusion.ckpt -o models/diffusion
  tools/convert_checkpoint.py vae.ckpt -o models/vae
  tools/convert_checkpoint.py gsm_vs02_res512_view1_dual_branch_sky_mlp_modulator.ckpt -o models/gsm

A diffusion checkpoint (state_dict keys `unet.*`, `unet_ema.*`, `scale_factor`,
optionally `vae.*`) gives
  unet.safetensors     the UNet's parameters under their bare official names:
                       the EMA copy when the checkpoint has one (the inference
                       scripts sample with --use_ema), the live weights with
                       --weights live; its __metadata__ holds scale_factor,
                       the copy taken and the source file
  unet_config.json     {"unet_kwargs": UNetModel's keyword arguments, "scale_factor": ...}:
                       channels, levels, attention levels and transformer depth read
                       off the weights, the rest from the checkpoint's hyper_parameters
                       (network.diffuser) or else the released model's values
  vae.safetensors      the frozen structure VAE's parameters (`vae.encoder.*`, `vae.unet.*`) under
                       their bare names, scale_factor in its __metadata__
  vae_config.json      {"vae_kwargs": StructPredictionNet's keyword arguments, "encoder_kwargs",
                       "scale_factor"}: widths, levels, residual blocks and cut_ratio read off
                       the weights, the rest (neck, pooling levels, ConvBlock order) the released
                       model's and named as assumed
A standalone VAE checkpoint (keys `encoder.*`, `unet.encoders.*`, ...) gives
vae.safetensors and vae_config.json, the arguments the weights cannot tell from
its hyper_parameters (cut_ratio, network.unet.params), checked against the
weights.
A GSM checkpoint (the stage-3 Gaussian reconstruction model, voxelgen/models/gsm.py:
state_dict keys `img_encoder.*`, `skybox.*`, `backbone.*`, or hyper_parameters with
model "gsm") gives
  gsm.safetensors      every tensor of gsm.Model.state_dict() under its name, as stored:
                       the conv encoder, the frozen Depth-Anything-V2 network and its
                       upsampler, the sky modulator, the voxel and pixel branches, and
                       BatchNorm's running statistics (num_batches_tracked as I64)
  gsm_config.json      {"hparams": the checkpoint's hyper_parameters under their official
                       names (OmegaConf interpolations resolved), "dav2_config": the
                       Depth-Anything-V2 configuration in Hugging Face's DepthAnythingConfig
                       form read off its weights (hidden size, layers, patch size, image
                       size from the position grid, MLP ratio, neck, fusion and head widths;
                       the release's reassemble factors 4, 2, 1, 1/2 checked against the
                       neck; the release's out_indices by depth), "dav2_name_registered"}.
                       The attention heads are not in the weights: the released model's
                       when hyper_parameters name one (depth-anything/Depth-Anything-V2-
                       Large-hf: 16), else DINOv2's 64-wide heads, or --dav2-heads.
                       Every width in hyper_parameters that the weights hold (conv encoder
                       filters and kernels, DAV2 upsampler widths, sky token and modulator
                       widths, voxel branch levels and widths, x-unet dims) is checked
                       against them; a disagreement is an error naming the key.
Everything else (optimizer state, condition encoders, loss modules' buffers) is
left out and listed.

Then:  icube nn info OUT/unet.safetensors --model OUT/unet_config.json
       icube nn vae decode LATENT.npy --model OUT/vae_config.json --weights OUT/vae.safetensors -o chunk.icw

Needs numpy only: not PyTorch, Lightning, OmegaConf or the InfiniCube sources. The
checkpoint (torch.save's zip format: data.pkl + one record per storage) is read
here with an unpickler that builds tensors, containers and plain values and
nothing else, so no code from the file ever runs; OmegaConf's DictConfig and
ListConfig (how InfiniCube's models store hyper_parameters) are read from their
pickled state as plain dicts and lists, and any other pickled class (callbacks)
becomes an inert placeholder and is reported. hyper_parameters are read when
they are OmegaConf configs, plain dicts, argparse.Namespace or Lightning's
AttributeDict.
Outputs are written to temporary names and renamed, so a failure leaves none.
"""

import argparse
import json
import os
import re
import struct
import sys
import tempfile

# The released model's UNetModel keyword arguments (shared/reference/models/diffusion_unet.tsv).
RELEASED_UNET_KWARGS = {
    "image_size": 64, "num_input_channels": 16, "out_channels": 8, "model_channels": 192,
    "num_res_blocks": 2, "attention_resolutions": [4, 8], "dropout": 0, "channel_mult": [1, 2, 4, 4],
    "conv_resample": True, "dims": 3, "num_classes": None, "use_checkpoint": False, "use_fp16": False,
    "num_heads": 8, "num_head_channels": -1, "num_heads_upsample": -1, "use_scale_shift_norm": True,
    "resblock_updown": True, "use_spatial_transformer": False, "transformer_depth": 12, "context_dim": None,
    "n_embed": None, "legacy": True, "middile_force_spatial_transformer": True, "middle_disable_first_sa": True,
}
# Keyword arguments the weights cannot tell; taken from hyper_parameters or the released model.
NOT_IN_WEIGHTS = ["image_size", "num_heads", "num_head_channels", "num_heads_upsample", "legacy", "dims",
                  "conv_resample", "dropout", "use_checkpoint", "use_fp16"]
CHANGE_INFERENCE = {"num_heads", "num_head_channels", "num_heads_upsample", "legacy", "conv_resample", "dims",
                    "transformer_depth", "middle_disable_first_sa"}
LEFT_OUT_BUFFERS = {"unet_ema.decay", "unet_ema.num_updates"}
# The released VAE's StructPredictionNet keyword arguments and encoder settings (shared/reference/models/vae.tsv).
RELEASED_VAE_KWARGS = {
    "cut_ratio": 32, "with_normal_branch": False, "with_semantic_branch": True, "in_channels": 32, "num_blocks": 3,
    "f_maps": 64, "neck_dense_type": "HAND_CRAFTED", "neck_bound": [32, 32, 32], "num_res_blocks": 1,
    "use_residual": True, "order": "gcs", "is_add_dec": True, "use_attention": False, "use_checkpoint": False,
    "pooling_level": [2],
}
# StructPredictionNet arguments the weights cannot tell (inference changes with all but use_checkpoint).
VAE_NOT_IN_WEIGHTS = ["neck_dense_type", "neck_bound", "pooling_level", "order", "num_groups", "use_residual",
                      "is_add_dec", "use_checkpoint"]


class ConvertError(Exception):
    """A one-line error naming the file and the place."""


def fail(path, where, what):
    raise ConvertError(f"{path}: {where + ': ' if where else ''}{what}")


# torch storage class -> (numpy dtype, safetensors dtype or None when not a float)
STORAGES = {
    "FloatStorage": ("<f4", "F32"), "HalfStorage": ("<u2", "F16"), "BFloat16Storage": ("<u2", "BF16"),
    "DoubleStorage": ("<f8", None), "LongStorage": ("<i8", None), "IntStorage": ("<i4", None),
    "ShortStorage": ("<i2", None), "CharStorage": ("i1", None), "ByteStorage": ("u1", None),
    "BoolStorage": ("?", None),
}


class Tensor:
    """A tensor read from a checkpoint: a C-ordered numpy array plus its safetensors dtype.

    F16 and BF16 keep their raw 16-bit patterns (uint16), written back unchanged."""

    def __init__(self, array, dtype):
        self.array, self.dtype = array, dtype

    @property
    def shape(self):
        return list(self.array.shape)

    @property
    def is_float(self):
        return self.dtype is not None

    def numel(self):
        return int(self.array.size)

    def as_f32(self):
        import numpy as np
        if self.dtype == "BF16":
            return (self.array.astype(np.uint32) << 16).view(np.float32)
        if self.dtype == "F16":
            return self.array.view(np.float16).astype(np.float32)
        return self.array.astype(np.float32)

    def finite(self):
        import numpy as np
        return bool(np.isfinite(self.as_f32()).all()) if self.is_float else True

    def item(self):
        if self.numel() != 1:
            raise ValueError(f"{self.numel()} elements")
        return float(self.as_f32().reshape(-1)[0]) if self.is_float else float(self.array.reshape(-1)[0])

    def tobytes(self):
        return self.array.tobytes()


class Storage:
    def __init__(self, kind, data):
        self.kind, self.data = kind, data  # data: 1-D numpy array of the storage's elements


class Placeholder:
    """An inert stand-in for any pickled class the reader does not build."""
    seen = set()

    def __init__(self, *args, **kwargs):
        pass

    def __setstate__(self, state):
        pass

    def __setitem__(self, key, value):
        pass

    def append(self, value):
        pass

    def extend(self, values):
        pass


def placeholder_class(module, name):
    Placeholder.seen.add(f"{module}.{name}")
    return type(name, (Placeholder,), {"__module__": "placeholder." + module})


class OmegaConfNode:
    """A pickled OmegaConf node kept as its pickled state, never its code. InfiniCube's Lightning
    modules save their hparams as an OmegaConf DictConfig, which pickles (NEWOBJ + BUILD) as the
    state {_metadata, _parent, _content} for DictConfig (_content: key -> node) and ListConfig
    (_content: list of nodes), {_metadata, _parent, _val} for a value node (AnyNode, IntegerNode, ...);
    _content may also be None, "???" (missing) or an interpolation string."""
    state = None
    holds = "_content"

    def __setstate__(self, state):
        self.state = state if isinstance(state, dict) else None

    def content(self):
        return (self.state or {}).get(self.holds)


class OmegaConfDict(OmegaConfNode):
    pass


class OmegaConfList(OmegaConfNode):
    pass


class OmegaConfValue(OmegaConfNode):
    holds = "_val"


class OmegaConfInert(Placeholder):
    """OmegaConf's node metadata and the typing annotations in it: not needed, not reported."""


def omegaconf_class(module, name):
    if name == "DictConfig":
        return OmegaConfDict
    if name == "ListConfig":
        return OmegaConfList
    if name.endswith("Node"):
        return OmegaConfValue
    return OmegaConfInert


def read_checkpoint(path):
    """torch.save's zip format read without torch and without running code from the file."""
    import _compat_pickle
    import collections
    import io
    import pickle
    import zipfile

    import numpy as np

    if not os.path.isfile(path):
        fail(path, "", "no such file")
    try:
        z = zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError) as e:
        fail(path, "", f"not a PyTorch checkpoint in torch.save's zip format ({' '.join(str(e).split())[:120]}); "
             "checkpoints from PyTorch older than 1.6 are not read")
    with z:
        pkl = [n for n in z.namelist() if n.endswith("data.pkl") and n.count("/") == 1]
        if len(pkl) != 1:
            fail(path, "", "not a PyTorch checkpoint (no single <archive>/data.pkl)")
        prefix = pkl[0][: -len("data.pkl")]
        if prefix + "byteorder" in z.namelist() and z.read(prefix + "byteorder").strip() != b"little":
            fail(path, "byteorder", "big-endian checkpoints are not read")
        storages = {}

        def persistent_load(pid):
            if not (isinstance(pid, tuple) and len(pid) == 5 and pid[0] == "storage"):
                raise pickle.UnpicklingError(f"unknown persistent id {str(pid)[:60]}")
            _, kind, key, _location, numel = pid
            if key not in storages:
                name = kind.__name__ if isinstance(kind, type) else str(kind)
                if name not in STORAGES:
                    raise pickle.UnpicklingError(f"storage type {name} is not read")
                np_dtype = np.dtype(STORAGES[name][0])
                try:
                    raw = z.read(f"{prefix}data/{key}")
                except KeyError:
                    raise pickle.UnpicklingError(f"storage record data/{key} is missing")
                if len(raw) < numel * np_dtype.itemsize:
                    raise pickle.UnpicklingError(f"storage record data/{key} holds {len(raw)} bytes, "
                                                 f"{numel} elements need {numel * np_dtype.itemsize}")
                storages[key] = Storage(name, np.frombuffer(raw, dtype=np_dtype, count=numel))
            return storages[key]

        def rebuild_tensor(storage, offset, size, stride, *_):
            if not isinstance(storage, Storage):
                raise pickle.UnpicklingError("a tensor without a storage")
            size, stride = tuple(int(v) for v in size), tuple(int(v) for v in stride)
            data = storage.data
            end = offset + sum((n - 1) * st for n, st in zip(size, stride)) + 1 if all(size) else offset
            if offset < 0 or any(st < 0 for st in stride) or end > data.size:
                raise pickle.UnpicklingError(f"a tensor of size {list(size)} reaches past its storage")
            view = np.lib.stride_tricks.as_strided(data[offset:], shape=size,
                                                   strides=[st * data.itemsize for st in stride])
            return Tensor(np.ascontiguousarray(view), STORAGES[storage.kind][1])

        def rebuild_parameter(data, *_):
            return data

        class AttributeDict(dict):
            """Lightning's AttributeDict, as a plain dict."""

        allowed = {
            ("collections", "OrderedDict"): collections.OrderedDict,
            ("torch._utils", "_rebuild_tensor_v2"): rebuild_tensor,
            ("torch._utils", "_rebuild_parameter"): rebuild_parameter,
            ("argparse", "Namespace"): argparse.Namespace,
            ("collections", "defaultdict"): collections.defaultdict,
            ("builtins", "set"): set, ("builtins", "frozenset"): frozenset, ("builtins", "dict"): dict,
            ("builtins", "list"): list, ("builtins", "tuple"): tuple, ("builtins", "int"): int,
            ("builtins", "float"): float, ("builtins", "str"): str, ("builtins", "bool"): bool,
        }

        class Unpickler(pickle.Unpickler):
            def find_class(self, module, name):
                # Protocol 2 (torch.save's) names Python 2 modules: __builtin__.dict, __builtin__.long, copy_reg.
                if (module, name) in _compat_pickle.NAME_MAPPING:
                    module, name = _compat_pickle.NAME_MAPPING[(module, name)]
                elif module in _compat_pickle.IMPORT_MAPPING:
                    module = _compat_pickle.IMPORT_MAPPING[module]
                if (module, name) in allowed:
                    return allowed[(module, name)]
                if module == "torch" and name.endswith("Storage"):
                    return type(name, (), {})  # the storage kind, read by persistent_load
                if name == "AttributeDict" and module.split(".")[0] in ("pytorch_lightning", "lightning",
                                                                       "lightning_fabric"):
                    return AttributeDict
                if module.split(".")[0] == "omegaconf":
                    return omegaconf_class(module, name)
                if module == "typing":
                    return OmegaConfInert
                if (module, name) == ("copyreg", "_reconstructor"):
                    return lambda cls, base, state: cls.__new__(cls) if isinstance(cls, type) and \
                        issubclass(cls, (Placeholder, OmegaConfNode, dict)) else Placeholder()
                return placeholder_class(module, name)

        up = Unpickler(io.BytesIO(z.read(pkl[0])), encoding="utf-8")
        up.persistent_load = persistent_load
        try:
            return up.load()
        except Exception as e:  # malformed pickles raise many kinds
            fail(path, "data.pkl", f"not readable ({type(e).__name__}: {' '.join(str(e).split())[:160]})")


def state_dict_of(ckpt, path):
    sd = ckpt.get("state_dict") if isinstance(ckpt, dict) else None
    if sd is None and isinstance(ckpt, dict) and ckpt and all(isinstance(k, str) for k in ckpt):
        sd = ckpt  # a bare state dict
    if not isinstance(sd, dict) or not sd:
        fail(path, "state_dict", "missing or empty (not a Lightning checkpoint or state dict)")
    return sd


def as_plain(obj, notes=None, where="hyper_parameters"):
    """hyper_parameters as plain dicts/lists/scalars: OmegaConf containers (by their pickled state),
    AttributeDict, argparse.Namespace. Anything else unreadable becomes None, its place added to `notes`."""
    if isinstance(obj, OmegaConfNode):
        obj = obj.content()
    if isinstance(obj, argparse.Namespace):
        obj = vars(obj)
    if isinstance(obj, dict):
        return {str(k): as_plain(v, notes, f"{where}.{k}") for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [as_plain(v, notes, f"{where}[{i}]") for i, v in enumerate(obj)]
    if obj is None or isinstance(obj, (str, bool, int, float)):
        return obj
    if notes is not None:
        notes.append(f"{where} ({type(obj).__name__})")
    return None


INTERPOLATION = re.compile(r"\$\{([^${}]*)\}")


def resolve_interpolations(root, unresolved_notes=None):
    """OmegaConf's node interpolations in plain hyper-parameters, resolved as OmegaConf.to_container(resolve=True)
    does: "${a.b}" (from the root), "${.x}" / "${..x}" (from the node's container / its parent), a whole-string
    reference taking the referenced value (containers copied), references inside a longer string as text.
    Resolver calls ("${name:...}"), missing keys and cycles stay as written and are added to `unresolved_notes`."""
    done, active = {}, set()

    def node_at(path):
        node = root
        for k in path:
            node = node[k]
        return node

    def find(ref, path):
        ref = re.sub(r"\[(\d+)\]", r".\1", ref.strip())
        if not ref or ":" in ref:
            return None
        dots = len(ref) - len(ref.lstrip("."))
        if dots > len(path):
            return None
        base = list(path[:len(path) - dots]) if dots else []
        node = node_at(base)
        for part in ref[dots:].split(".") if ref[dots:] else []:
            if isinstance(node, dict) and part in node:
                key = part
            elif isinstance(node, list) and part.isdigit() and int(part) < len(node):
                key = int(part)
            else:
                return None
            base.append(key)
            node = node[key]
        return tuple(base)

    def resolve(value, path):
        if isinstance(value, dict):
            return {k: resolve(v, path + (k,)) for k, v in value.items()}
        if isinstance(value, list):
            return [resolve(v, path + (i,)) for i, v in enumerate(value)]
        if not (isinstance(value, str) and "${" in value):
            return value
        if path in done:
            return done[path]
        if path in active:  # a cycle
            return value
        active.add(path)
        unresolved = []

        def target_of(m):
            target = find(m.group(1), path)
            if target is None or target in active:
                unresolved.append(m.group(0))
                return None
            return target

        whole = INTERPOLATION.fullmatch(value)
        if whole:
            target = target_of(whole)
            result = value if target is None else resolve(node_at(target), target)
        else:
            def text(m):
                target = target_of(m)
                return m.group(0) if target is None else str(resolve(node_at(target), target))
            result = INTERPOLATION.sub(text, value)
        active.discard(path)
        if unresolved and unresolved_notes is not None:
            unresolved_notes.append(".".join(str(k) for k in path) + " = " + json.dumps(value))
        done[path] = result
        return result

    return resolve(root, ())


def plain_hparams(ckpt, unreadable=None, unresolved=None):
    """The checkpoint's hyper_parameters as plain JSON values with interpolations resolved (None if absent);
    the places of values that are not plain data and of interpolations left as written go to the lists."""
    hp = ckpt.get("hyper_parameters") if isinstance(ckpt, dict) else None
    return resolve_interpolations(as_plain(hp, unreadable), unresolved)


def diffuser_hparams(ckpt):
    hp = plain_hparams(ckpt)
    if isinstance(hp, dict):
        net = hp.get("network")
        if isinstance(net, dict) and isinstance(net.get("diffuser"), dict):
            return net["diffuser"]
    return {}


def shape(sd, key):
    return list(sd[key].shape)


def infer_unet_kwargs(unet, path, hparams):
    """UNetModel kwargs from the bare-named UNet parameters, checked against hyper_parameters."""
    def need(key):
        if key not in unet:
            fail(path, f"tensor 'unet.{key}'", "missing: not an InfiniCube dense diffusion UNet")
        return shape(unet, key)

    conv_in, conv_out = need("input_blocks.0.0.weight"), need("out.2.weight")
    if len(conv_in) != 5 or len(conv_out) != 5:
        fail(path, "tensor 'unet.input_blocks.0.0.weight'", f"shape {conv_in}: not a 3-D convolution")
    mc = conv_in[0]
    blocks_in = {int(m.group(1)) for k in unet for m in [re.match(r"input_blocks\.(\d+)\.", k)] if m}
    n_in = max(blocks_in) + 1
    # Upsamplers: a sub-module after the first in an output block that is a ResBlock or an Upsample conv.
    ups = {(m.group(1), m.group(2)) for k in unet
           for m in [re.match(r"output_blocks\.(\d+)\.([1-9])\.(in_layers|conv)\.", k)] if m}
    levels = len(ups) + 1
    if n_in % levels != 0:
        fail(path, "input_blocks", f"{n_in} blocks do not split into {levels} levels")
    res = n_in // levels - 1
    if res < 1:
        fail(path, "input_blocks", f"{n_in} blocks for {levels} levels leave no ResBlocks")
    mult, attn = [], []
    for level in range(levels):
        first = 1 + level * (res + 1)
        ch = need(f"input_blocks.{first}.0.out_layers.3.weight")[0]
        if ch % mc != 0:
            fail(path, f"tensor 'unet.input_blocks.{first}.0.out_layers.3.weight'",
                 f"{ch} channels are not a multiple of model_channels {mc}")
        mult.append(ch // mc)
        if any(k.startswith(f"input_blocks.{first}.1.") for k in unet):
            attn.append(2 ** level)
    kw = {
        "num_input_channels": conv_in[1], "out_channels": conv_out[0], "model_channels": mc,
        "num_res_blocks": res, "channel_mult": mult, "attention_resolutions": attn,
        "use_scale_shift_norm": need("input_blocks.1.0.emb_layers.1.weight")[0] == 2 * mc * mult[0],
        "resblock_updown": any(k.startswith("output_blocks.") and ".in_layers." in k and
                               re.match(r"output_blocks\.\d+\.[1-9]\.in_layers", k) for k in unet),
    }
    depth = {int(m.group(1)) for k in unet for m in [re.match(r"middle_block\.1\.transformer_blocks\.(\d+)\.", k)] if m}
    kw["middile_force_spatial_transformer"] = bool(depth)
    if depth:
        kw["transformer_depth"] = max(depth) + 1
        kw["middle_disable_first_sa"] = not any(".attn1." in k for k in unet if k.startswith("middle_block.1."))
    out = dict(RELEASED_UNET_KWARGS)
    assumed = []
    for key in NOT_IN_WEIGHTS + ["transformer_depth", "middle_disable_first_sa"]:
        if key in hparams:
            out[key] = hparams[key]
        elif key not in kw and key in CHANGE_INFERENCE:
            assumed.append(key)
    for key, value in kw.items():
        if key in hparams and hparams[key] != value and key not in ("num_input_channels", "out_channels"):
            fail(path, f"hyper_parameters network.diffuser.{key}",
                 f"says {json.dumps(hparams[key])}, the weights hold {json.dumps(value)}")
        out[key] = value
    return out, assumed


def vae_hparams(ckpt):
    """The VAE Lightning module's hyper_parameters: StructPredictionNet's arguments are
    cut_ratio / with_*_branch at the top plus network.unet.params; the encoder's settings are top-level."""
    hp = plain_hparams(ckpt)
    if not isinstance(hp, dict):
        return {}, {}
    net = hp.get("network")
    params = net.get("unet", {}).get("params", {}) if isinstance(net, dict) and isinstance(net.get("unet"), dict) else {}
    out = dict(params) if isinstance(params, dict) else {}
    for key in ("cut_ratio", "with_normal_branch", "with_semantic_branch"):
        if key in hp:
            out[key] = hp[key]

    def resolve(v):  # an unresolved OmegaConf interpolation "${name}" from a plain-dict checkpoint
        m = re.fullmatch(r"\$\{([A-Za-z_][A-Za-z0-9_]*)\}", v) if isinstance(v, str) else None
        return hp.get(m.group(1), v) if m else v
    out = {k: resolve(v) for k, v in out.items()}
    enc = {k: hp[k] for k in ("num_semantic", "dim_semantic", "use_input_semantic", "use_input_normal",
                              "use_input_intensity") if k in hp}
    return out, enc


def infer_vae_kwargs(vae, path, where, hparams):
    """StructPredictionNet kwargs from the VAE's bare-named tensors (encoder.*, unet.*), checked against
    hyper_parameters; returns (vae_kwargs, encoder_kwargs, assumed)."""
    def need(key):
        if key not in vae:
            fail(path, f"tensor '{where}{key}'", "missing: not an InfiniCube structure VAE")
        return shape(vae, key)

    enc_levels = {int(m.group(1)) for k in vae for m in [re.match(r"unet\.encoders\.Enc(\d+)-Block", k)] if m}
    if not enc_levels or sorted(enc_levels) != list(range(max(enc_levels) + 1)):
        fail(path, f"'{where}unet.encoders'", f"levels {sorted(enc_levels)} are not Enc0..EncN")
    num_blocks = max(enc_levels) + 1
    res = {int(m.group(1)) for k in vae for m in [re.match(r"unet\.encoders\.Enc0-Block(\d+)\.", k)] if m}
    num_res_blocks = max(res) + 1
    first = need("unet.encoders.Enc0-Block0.conv1.Conv.weight")
    last = need(f"unet.encoders.Enc0-Block{num_res_blocks - 1}.conv2.Conv.weight")
    if len(first) != 5 or len(last) != 5:
        fail(path, f"tensor '{where}unet.encoders.Enc0-Block0.conv1.Conv.weight'", f"shape {first}: not a 3^3 sparse convolution")
    in_channels, f_maps = first[1], last[0]
    top = f_maps << (num_blocks - 1)
    latent = need("unet.post_kl_bottleneck.post_kl_bottleneck_0.conv1.Conv.weight")[1]
    if latent < 1 or top % latent != 0:
        fail(path, f"tensor '{where}unet.post_kl_bottleneck.post_kl_bottleneck_0.conv1.Conv.weight'",
             f"{latent} latent channels do not divide the {top} bottleneck channels")
    gn = "unet.encoders.Enc0-Block0.conv1.GroupNorm.weight"
    kw = {
        "in_channels": in_channels, "num_blocks": num_blocks, "f_maps": f_maps, "num_res_blocks": num_res_blocks,
        "cut_ratio": top // latent,
        "with_semantic_branch": any(k.startswith("unet.semantic_head.") for k in vae),
        "with_normal_branch": any(k.startswith("unet.normal_head.") for k in vae),
        "use_attention": any(".attention" in k or ".attn" in k for k in vae),
    }
    out = dict(RELEASED_VAE_KWARGS)
    assumed = []
    for key in VAE_NOT_IN_WEIGHTS:
        if key in hparams:
            out[key] = hparams[key]
        elif key in RELEASED_VAE_KWARGS and key != "use_checkpoint":
            assumed.append(key)
    # GroupNorm before the convolution (its width is the conv's input width) or after it (the output's),
    # told apart on a convolution that changes the width (the order's activation is not in the weights).
    order = out["order"]
    for conv in ("conv1", "conv2"):
        gn = f"unet.encoders.Enc0-Block0.{conv}.GroupNorm.weight"
        cw = need(f"unet.encoders.Enc0-Block0.{conv}.Conv.weight")
        if ("g" in order) != (gn in vae):
            fail(path, f"tensor '{where}{gn}'", f"{'missing' if gn not in vae else 'present'}: "
                 f"the ConvBlock order '{order}' {'has' if 'g' in order else 'has no'} GroupNorm")
        if gn in vae and cw[0] != cw[1]:
            width, g_first = shape(vae, gn)[0], order.index("g") < order.index("c")
            if width != (cw[1] if g_first else cw[0]):
                fail(path, f"tensor '{where}{gn}'", f"width {width} does not fit the ConvBlock order '{order}' "
                     f"(convolution {cw[1]} -> {cw[0]} channels)")
    for key, value in kw.items():
        if key in hparams and hparams[key] != value:
            fail(path, f"hyper_parameters {key}", f"says {json.dumps(hparams[key])}, the weights hold {json.dumps(value)}")
        out[key] = value
    emb = need("encoder.semantic_embed_fn.weight")
    mix = need("encoder.mix_fc.weight")
    if len(emb) != 2 or len(mix) != 2 or mix[1] != 3 + 6 * 5 + emb[1]:
        fail(path, f"tensor '{where}encoder.mix_fc.weight'", f"shape {mix} does not take the 33 position channels + "
             f"{emb[1] if len(emb) == 2 else '?'} semantic channels (semantic inputs only)")
    encoder = {"num_semantic": emb[0], "dim_semantic": emb[1], "use_input_semantic": True,
               "use_input_normal": False, "use_input_intensity": False}
    return out, encoder, assumed


def vae_outputs(path, src, vae, where, hparams, enc_hparams, scale, report):
    """vae.safetensors + vae_config.json for the VAE's bare-named float tensors."""
    kwargs, encoder, assumed = infer_vae_kwargs(vae, path, where, hparams)
    for key, value in enc_hparams.items():
        if key in encoder and value != encoder[key]:
            fail(path, f"hyper_parameters {key}", f"says {json.dumps(value)}, the weights hold {json.dumps(encoder[key])}")
    meta = {"source": src, "model": "vae"}
    if scale is not None:
        meta["scale_factor"] = repr(scale)
    config = {"description": f"InfiniCube structure VAE converted from {src}", "vae_kwargs": kwargs,
              "encoder_kwargs": encoder, "scale_factor": scale, "assumed_from_released_model": assumed}
    report.append(f"vae.safetensors: {len(vae)} tensors, {sum(t.numel() for t in vae.values()):,} parameters")
    report.append("vae_config.json: in_channels {in_channels}, f_maps {f_maps}, num_blocks {num_blocks}, "
                  "num_res_blocks {num_res_blocks}, cut_ratio {cut_ratio}".format(**kwargs) +
                  (f"; from the released model (not in the checkpoint): {', '.join(assumed)}" if assumed else ""))
    return {"vae.safetensors": ("safetensors", vae, meta), "vae_config.json": ("json", config, None)}


# --- The GSM (InfiniCube's stage-3 Gaussian reconstruction model, voxelgen/models/gsm.py) ------------------

GSM_PARTS = ("img_encoder.", "skybox.", "backbone.")
GSM_CONV = "img_encoder.encoders.conv.project_head."
GSM_DAV2 = "img_encoder.encoders.dav2.model."
GSM_UPSAMPLER = "img_encoder.encoders.dav2.upsampler."
GSM_VOXEL = "backbone.backbone_3d."
GSM_PIXEL = "backbone.backbone_2d."
GSM_VOXEL_HP = "backbone.params.backbone_3d_params."
GSM_PIXEL_HP = "backbone.params.backbone_2d_params."
GSM_SKY_HP = "skybox_mlp_modulator."
# The released Depth-Anything-V2 backbones (DINOv2 ViT-S/B/L/G): hidden size, layers, heads; and the
# layers whose outputs the neck reads (1-based hidden-state indices) by depth.
RELEASED_DAV2 = {"Small": (384, 12, 6), "Base": (768, 12, 12), "Large": (1024, 24, 16), "Giant": (1536, 40, 24)}
RELEASED_OUT_INDICES = {12: [3, 6, 9, 12], 24: [5, 12, 18, 24], 40: [10, 20, 30, 40]}
RELEASED_REASSEMBLE_FACTORS = [4, 2, 1, 0.5]
# The neck's resize per factor: a transposed conv of kernel k for k > 1, none for 1, a 3x3 stride-2 conv for 1/2.
RESIZE_KERNEL = {4: 4, 2: 2, 1: None, 0.5: 3}
# safetensors dtypes for the integer and boolean buffers (BatchNorm's num_batches_tracked is int64).
SAFETENSORS_INTS = {"int64": "I64", "int32": "I32", "uint8": "U8", "bool": "BOOL"}


class RawTensor:
    """A non-float tensor for write_safetensors: little-endian bytes under a safetensors dtype."""

    def __init__(self, array, dtype):
        self.array, self.dtype = array, dtype

    @property
    def shape(self):
        return list(self.array.shape)

    def numel(self):
        return int(self.array.size)

    def tobytes(self):
        return self.array.astype(self.array.dtype.newbyteorder("<")).tobytes()


def looks_like_gsm(ckpt, sd):
    """GSM tensor names, or hyper_parameters that say model "gsm"."""
    if any(k.startswith(GSM_PARTS) for k in sd):
        return True
    hp = as_plain(ckpt.get("hyper_parameters")) if isinstance(ckpt, dict) else None
    return isinstance(hp, dict) and hp.get("model") == "gsm"


def gsm_tensors(path, parts, report):
    """Every tensor of gsm.Model.state_dict() as stored (F32/F16/BF16; integer buffers as I64/I32/U8/BOOL),
    float64 narrowed to float32."""
    import numpy as np
    out, narrowed = {}, []
    for name, t in parts.items():
        if not isinstance(t, Tensor):
            fail(path, f"'{name}'", f"is a {type(t).__name__}, not a tensor")
        if t.is_float or t.array.dtype == np.float64:
            if not t.is_float:
                t = Tensor(t.array.astype("<f4"), "F32")
                narrowed.append(name)
            if not t.finite():
                fail(path, f"tensor '{name}'", "holds NaN or infinity")
            out[name] = t
        elif t.array.dtype.name in SAFETENSORS_INTS:
            out[name] = RawTensor(t.array, SAFETENSORS_INTS[t.array.dtype.name])
        else:
            fail(path, f"tensor '{name}'", f"dtype {t.array.dtype.name} is not written (F32, F16, BF16, I64, I32, U8, BOOL)")
    if narrowed:
        report.append(f"float64 tensors written as float32: {', '.join(sorted(narrowed))}")
    return out


def gsm_shape_reader(path, sd):
    """need(name) -> the tensor's shape, or a one-line error that the file is no complete GSM."""
    def need(name, rank=None):
        if name not in sd:
            fail(path, f"tensor '{name}'", "missing: not a complete InfiniCube GSM")
        s = shape(sd, name)
        if rank is not None and len(s) != rank:
            fail(path, f"tensor '{name}'", f"shape {s} is not {rank}-D")
        return s
    return need


def indices_under(sd, prefix):
    """The sorted integers i of names PREFIX<i>.*"""
    return sorted({int(m.group(1)) for k in sd for m in [re.match(re.escape(prefix) + r"(\d+)\.", k)] if m})


def gsm_encoder_facts(sd, need, path):
    """(hyper-parameter, value the weights hold) for the conv encoder and the DAV2 upsampler."""
    facts = []
    stages = indices_under(sd, GSM_CONV)
    if stages:
        if stages != list(range(len(stages))):
            fail(path, f"tensor '{GSM_CONV}{stages[-1]}'", f"the conv encoder's stages {stages} are not 0..N")
        filters, kernels, residual, gn = [], [], [], {}
        for i in stages:
            res = f"{GSM_CONV}{i}.in_layers.2.weight" in sd
            w = need(f"{GSM_CONV}{i}.in_layers.2.weight" if res else f"{GSM_CONV}{i}.0.weight", 4)
            if not filters:
                filters.append(w[1])
            filters.append(w[0])
            kernels.append(w[2])
            residual.append(res)
            if res:  # a residual stage's norm: BatchNorm has running statistics, GroupNorm none
                gn[i] = f"{GSM_CONV}{i}.in_layers.0.running_mean" not in sd
        facts += [("encoder.conv_params.n_filter_list", filters), ("encoder.conv_params.n_kernel_list", kernels),
                  ("encoder.conv_params.n_residual_list", residual),
                  ("encoder.conv_params.conv_encoder_out_dim", need(GSM_CONV + "conv_1x1.weight", 4)[0])]
        facts.append(("encoder.conv_params.n_use_gn_list", gn))  # only the residual stages' entries tell
    ups = indices_under(sd, GSM_UPSAMPLER)
    if ups:
        facts.append(("encoder.dav2_params.out_dim_list", [need(f"{GSM_UPSAMPLER}{i}.in_layers.2.weight", 4)[0] for i in ups]))
        facts.append(("encoder.dav2_params.out_use_gn_list",
                      [f"{GSM_UPSAMPLER}{i}.in_layers.0.running_mean" not in sd for i in ups]))
    return facts


def gsm_sky_facts(sd, need):
    if "skybox.sky_query" not in sd:
        return []
    embed = need("skybox.sky_query", 3)[2]
    patch = need("skybox.patch_embedder.weight", 4)
    layers = indices_under(sd, "skybox.transformer.layers.")
    facts = [(GSM_SKY_HP + "embed_dim", embed), (GSM_SKY_HP + "patch_size", patch[2]),
             (GSM_SKY_HP + "hidden_channels", need("skybox.modulator.condition_mapping.weight", 2)[0]),
             (GSM_SKY_HP + "out_channels", need("skybox.modulator.output.weight", 2)[0])]
    if layers:
        facts += [(GSM_SKY_HP + "transformer.num_layers", len(layers)),
                  (GSM_SKY_HP + "transformer.dim_feedforward", need("skybox.transformer.layers.0.linear1.weight", 2)[0])]
    return facts


def gsm_voxel_facts(sd, need, hp, path):
    if not any(k.startswith(GSM_VOXEL) for k in sd):
        return []
    lifter = need(GSM_VOXEL + "lifter.mix_fc.weight", 2)
    levels = indices_under(sd, GSM_VOXEL + "encoders.Enc")
    if not levels:
        need(GSM_VOXEL + "encoders.Enc0.conv1.Conv.weight")
    f_maps = need(GSM_VOXEL + "encoders.Enc0.conv2.Conv.weight", 5)[0]
    facts = [(GSM_VOXEL_HP + "lifter_params.img_in_dim", lifter[1]), (GSM_VOXEL_HP + "lifter_params.voxel_out_dim", lifter[0]),
             (GSM_VOXEL_HP + "in_channels", need(GSM_VOXEL + "encoders.Enc0.conv1.Conv.weight", 5)[1]),
             (GSM_VOXEL_HP + "num_blocks", len(levels)), (GSM_VOXEL_HP + "f_maps", f_maps)]
    if GSM_VOXEL + "render_head_hybrid.SingleConv.Conv.weight" in sd:
        facts.append((GSM_VOXEL_HP + "f_maps_2d", need(GSM_VOXEL + "render_head_hybrid.SingleConv.Conv.weight", 5)[1] - f_maps))
    if GSM_VOXEL + "render_head_3D.OutConv.weight" in sd:
        per_voxel = need(GSM_VOXEL + "render_head_3D.OutConv.weight", 2)[0]
        gs_dim = hp_value(hp, GSM_VOXEL_HP + "gs_dim", 14)  # Pure3DUnet's default
        if not isinstance(gs_dim, int) or gs_dim < 1 or per_voxel % gs_dim:
            fail(path, f"hyper_parameters {GSM_VOXEL_HP}gs_dim", f"says {json.dumps(gs_dim)}, which does not divide the "
                 f"{per_voxel} values per voxel of tensor '{GSM_VOXEL}render_head_3D.OutConv.weight'")
        facts.append((GSM_VOXEL_HP + "gsplat_upsample", per_voxel // gs_dim))
    return facts


def gsm_pixel_facts(sd, need, hp, path):
    if not any(k.startswith(GSM_PIXEL) for k in sd):
        return []
    u = GSM_PIXEL + "net."
    init = need(u + "init_conv.weight", 5)
    final = need(u + "final_conv.1.weight", 5)
    out = need(GSM_PIXEL + "linear_out.weight", 2)
    stages = indices_under(sd, u + "downs.")
    dim = final[1]
    widths = [need(f"{u}downs.{i}.3.1.weight", 5)[0] for i in stages]
    if any(w % dim for w in widths):
        fail(path, f"tensor '{u}downs'", f"stage widths {widths} are not multiples of dim {dim}")
    blocks = [1 + len(indices_under(sd, f"{u}downs.{i}.1.")) for i in stages]
    p = GSM_PIXEL_HP + "unet2d_params."
    facts = [(p + "channels", init[1]), (p + "init_dim", init[0]), (p + "dim", dim), (p + "out_dim", final[0]),
             (p + "dim_mults", [w // dim for w in widths])]
    per_stage = hp_value(hp, p + "num_blocks_per_stage", None)
    facts.append((p + "num_blocks_per_stage", blocks[0] if isinstance(per_stage, int) and len(set(blocks)) == 1 else blocks))
    gs_dim = hp_value(hp, GSM_PIXEL_HP + "gs_dim", None)
    if gs_dim is not None:
        if not isinstance(gs_dim, int) or gs_dim < 1 or out[0] % gs_dim:
            fail(path, f"hyper_parameters {GSM_PIXEL_HP}gs_dim", f"says {json.dumps(gs_dim)}, which does not divide the "
                 f"{out[0]} outputs per pixel of tensor '{GSM_PIXEL}linear_out.weight'")
        facts.append((GSM_PIXEL_HP + "gs_per_pixel", out[0] // gs_dim))
    if out[1] != final[0]:
        fail(path, f"tensor '{GSM_PIXEL}linear_out.weight'", f"takes {out[1]} channels, the x-unet gives {final[0]}")
    return facts


def hp_value(hp, dotted, default):
    node = hp
    for key in dotted.split("."):
        if not isinstance(node, dict) or key not in node:
            return default
        node = node[key]
    return node


def check_gsm_facts(path, hp, facts):
    """Each hyper-parameter that is present must equal what the weights hold."""
    missing = object()
    for key, held in facts:
        said = hp_value(hp, key, missing)
        if said is missing:
            continue
        if isinstance(held, dict):  # only some entries of a list tell (n_use_gn_list: the residual stages')
            if not isinstance(said, list) or any(i >= len(said) or bool(said[i]) != v for i, v in held.items()):
                shown = [held.get(i, s) for i, s in enumerate(said)] if isinstance(said, list) else held
                fail(path, f"hyper_parameters {key}", f"says {json.dumps(said)}, the weights hold {json.dumps(shown)}")
            continue
        if said != held:  # == also takes 0/1 for false/true, as the official code's truth tests do
            fail(path, f"hyper_parameters {key}", f"says {json.dumps(said)}, the weights hold {json.dumps(held)}")


def gsm_dav2_config(path, sd, need, heads_given, name):
    """The Depth-Anything-V2 configuration (HF DepthAnythingConfig form) read off the weights; returns
    (config, notes on what the weights cannot tell)."""
    b = GSM_DAV2 + "backbone."
    hidden = need(b + "embeddings.cls_token", 3)[2]
    patch = need(b + "embeddings.patch_embeddings.projection.weight", 4)
    positions = need(b + "embeddings.position_embeddings", 3)[1] - 1
    grid = int(round(positions ** 0.5))
    if grid * grid != positions or grid < 1:
        fail(path, f"tensor '{b}embeddings.position_embeddings'", f"{positions} positions are not a square grid")
    layers = indices_under(sd, b + "encoder.layer.")
    if not layers:
        need(b + "encoder.layer.0.norm1.weight")
    if b + "encoder.layer.0.mlp.weights_in.weight" in sd:
        fail(path, f"tensor '{b}encoder.layer.0.mlp.weights_in.weight'", "a SwiGLU feed-forward (ViT-G) is not read")
    mlp = need(b + "encoder.layer.0.mlp.fc1.weight", 2)[0]
    n = GSM_DAV2 + "neck."
    maps = indices_under(sd, n + "reassemble_stage.layers.")
    neck = [need(f"{n}reassemble_stage.layers.{i}.projection.weight", 4)[0] for i in maps]
    if len(maps) != len(RELEASED_REASSEMBLE_FACTORS):
        fail(path, f"tensor '{n}reassemble_stage.layers'", f"{len(maps)} maps; the release's neck has 4")
    # The release's factors 4, 2, 1, 1/2: transposed convs of kernel 4 and 2, no resize, a 3x3 stride-2 conv.
    for i, f in zip(maps, RELEASED_REASSEMBLE_FACTORS):
        resize = f"{n}reassemble_stage.layers.{i}.resize.weight"
        kernel = shape(sd, resize)[2] if resize in sd else None
        if kernel != RESIZE_KERNEL[f]:
            fail(path, f"tensor '{resize}'", f"{'kernel ' + str(kernel) if kernel else 'absent'}: not the release's "
                 f"reassemble factor {f}")
    # Heads are not in the weights: the released model's by name, else DINOv2's 64-wide heads, unless given.
    notes = []
    released = [v for k, v in RELEASED_DAV2.items() if isinstance(name, str) and "Depth-Anything-V2" in name and f"-{k}" in name]
    if released and released[0][:2] != (hidden, len(layers)):
        fail(path, "hyper_parameters encoder.dav2_params.depth_anything_model",
             f"says {json.dumps(name)} (hidden {released[0][0]}, {released[0][1]} layers), the weights hold "
             f"hidden {hidden}, {len(layers)} layers")
    if heads_given:
        heads = heads_given
    elif released:
        heads = released[0][2]
    else:
        if hidden % 64:
            fail(path, "--dav2-heads", f"needed: the DAV2 backbone's width {hidden} is not DINOv2's 64 per head")
        heads = hidden // 64
        notes.append(f"num_attention_heads {heads} (DINOv2's 64-wide heads; --dav2-heads sets it)")
    if hidden % heads:
        fail(path, "--dav2-heads", f"{heads} heads do not divide the DAV2 backbone's width {hidden}")
    # The layers the neck reads: the released models' by depth, else evenly spaced.
    depth = len(layers)
    out_indices = RELEASED_OUT_INDICES.get(depth, [depth * (i + 1) // len(maps) for i in range(len(maps))])
    if depth not in RELEASED_OUT_INDICES:
        notes.append(f"out_indices {out_indices} (evenly spaced over {depth} layers)")
    backbone = {
        "mlp_ratio": mlp // hidden if mlp % hidden == 0 else mlp / hidden, "hidden_act": "gelu", "layer_norm_eps": 1e-6,
        "image_size": grid * patch[2], "patch_size": patch[2], "num_channels": patch[1],
        "qkv_bias": b + "encoder.layer.0.attention.attention.query.bias" in sd, "layerscale_value": 1.0,
        "drop_path_rate": 0.0, "use_swiglu_ffn": False, "apply_layernorm": True, "reshape_hidden_states": False,
        "use_mask_token": b + "embeddings.mask_token" in sd, "hidden_dropout_prob": 0.0,
        "attention_probs_dropout_prob": 0.0, "initializer_range": 0.02, "hidden_size": hidden,
        "num_hidden_layers": len(layers), "num_attention_heads": heads, "out_indices": out_indices,
    }
    config = {
        "backbone_config": backbone, "patch_size": patch[2], "reassemble_factors": list(RELEASED_REASSEMBLE_FACTORS),
        "head_in_index": -1, "depth_estimation_type": "relative", "max_depth": None, "initializer_range": 0.02,
        "neck_hidden_sizes": neck, "fusion_hidden_size": need(n + "convs.0.weight", 4)[0],
        "head_hidden_size": need(GSM_DAV2 + "head.conv2.weight", 4)[0], "reassemble_hidden_size": hidden,
    }
    return config, notes


def convert_gsm(args, ckpt, sd, src):
    """gsm.safetensors + gsm_config.json; returns (outputs, report)."""
    path = args.checkpoint
    report, unreadable, unresolved = [], [], []
    heads = getattr(args, "dav2_heads", None)
    if heads is not None and heads < 1:
        fail(path, "--dav2-heads", f"{heads} is not a positive number of heads")
    if args.weights == "ema":
        fail(path, "--weights ema", "a GSM checkpoint has no EMA copy")
    if not isinstance(ckpt, dict) or ckpt.get("hyper_parameters") is None:
        fail(path, "hyper_parameters", "missing: a GSM's configuration is not all in its weights (use the Lightning "
             "checkpoint, which holds them)")
    hp = plain_hparams(ckpt, unreadable, unresolved)
    if not isinstance(hp, dict) or not hp:
        fail(path, "hyper_parameters", "not a mapping of hyper-parameters")
    if hp.get("model") != "gsm":
        fail(path, "hyper_parameters model", f"says {json.dumps(hp.get('model'))}, the weights are a GSM's "
             "(img_encoder.*, skybox.*, backbone.*)")
    parts = {k: v for k, v in sd.items() if k.startswith(GSM_PARTS)}
    for prefix in ("img_encoder.", "backbone."):
        if not any(k.startswith(prefix) for k in parts):
            fail(path, "state_dict", f"has no {prefix}* tensors: not an InfiniCube GSM's weights, though "
                 "hyper_parameters say model \"gsm\"")
    need = gsm_shape_reader(path, parts)
    tensors = gsm_tensors(path, parts, report)
    # Which parts exist, against the switches that build them.
    encoders = sorted({k.split(".")[2] for k in parts if k.startswith("img_encoder.encoders.")})
    said = hp_value(hp, "encoder.encoder_modules", None)
    if said is not None and sorted(said if isinstance(said, list) else [said]) != encoders:
        fail(path, "hyper_parameters encoder.encoder_modules", f"says {json.dumps(said)}, the weights hold "
             f"{json.dumps(encoders)}")
    facts = [("backbone.params.use_3d", any(k.startswith(GSM_VOXEL) for k in parts)),
             ("backbone.params.use_2d", any(k.startswith(GSM_PIXEL) for k in parts))]
    if hp.get("use_skybox") and hp.get("skybox_target") == "mlp_modulator":
        need("skybox.modulator.output.weight")
    facts += gsm_encoder_facts(parts, need, path) + gsm_sky_facts(parts, need)
    facts += gsm_voxel_facts(parts, need, hp, path) + gsm_pixel_facts(parts, need, hp, path)
    check_gsm_facts(path, hp, facts)
    name = hp_value(hp, "encoder.dav2_params.depth_anything_model", None)
    dav2, dav2_notes = (None, [])
    if any(k.startswith(GSM_DAV2) for k in parts):
        dav2, dav2_notes = gsm_dav2_config(path, parts, need, heads, name)
    elif heads:
        fail(path, "--dav2-heads", "the checkpoint has no Depth-Anything model")
    config = {"description": f"InfiniCube GSM converted from {src}", "hparams": hp, "dav2_config": dav2,
              "dav2_name_registered": name if dav2 is not None else None,
              "dav2_config_assumed": dav2_notes}
    meta = {"source": src, "model": "gsm"}
    outputs = {"gsm.safetensors": ("safetensors", tensors, meta), "gsm_config.json": ("json", config, None)}
    groups = sorted({k.split(".")[0] for k in tensors})
    params = sum(t.numel() for t in tensors.values() if isinstance(t, Tensor))
    report.append(f"gsm.safetensors: {len(tensors)} tensors ({', '.join(groups)}), {params:,} float values"
                  f" + {len(tensors) - sum(isinstance(t, Tensor) for t in tensors.values())} integer buffers")
    f = dict(facts)
    summary = []
    if "encoder.conv_params.n_filter_list" in f:
        summary.append(f"conv encoder {f['encoder.conv_params.n_filter_list']} -> {f['encoder.conv_params.conv_encoder_out_dim']}")
    if dav2 is not None:
        bb = dav2["backbone_config"]
        summary.append(f"DAV2 {bb['num_hidden_layers']} layers x {bb['hidden_size']} ({bb['num_attention_heads']} heads), "
                       f"neck {dav2['neck_hidden_sizes']}, fusion {dav2['fusion_hidden_size']}")
    if GSM_VOXEL_HP + "f_maps" in f:
        summary.append(f"voxel branch f_maps {f[GSM_VOXEL_HP + 'f_maps']} x {f[GSM_VOXEL_HP + 'num_blocks']} levels")
    if GSM_PIXEL_HP + "unet2d_params.dim" in f:
        summary.append(f"pixel x-unet dim {f[GSM_PIXEL_HP + 'unet2d_params.dim']} x {f[GSM_PIXEL_HP + 'unet2d_params.dim_mults']}")
    if GSM_SKY_HP + "embed_dim" in f:
        summary.append(f"sky tokens {f[GSM_SKY_HP + 'embed_dim']}")
    report.append("gsm_config.json: " + "; ".join(summary) + " (the hyper_parameters' widths agree with the weights)")
    if dav2_notes:
        report.append("dav2_config: not in the weights, assumed: " + "; ".join(dav2_notes))
    if unresolved:
        report.append("hyper_parameters: interpolations left as written: " + ", ".join(unresolved))
    if unreadable:
        report.append("hyper_parameters: entries not readable (written as null): " + ", ".join(unreadable))
    return outputs, report


def write_safetensors(path, tensors, metadata):
    """safetensors: 8-byte little-endian header length, JSON header, then the tensors' bytes."""
    header, blobs, offset = {"__metadata__": {k: str(v) for k, v in metadata.items()}}, [], 0
    for name in sorted(tensors):
        t = tensors[name]
        data = t.tobytes()
        header[name] = {"dtype": t.dtype, "shape": t.shape,
                        "data_offsets": [offset, offset + len(data)]}
        blobs.append(data)
        offset += len(data)
    text = json.dumps(header, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 8)
    with open(path, "wb") as f:
        f.write(struct.pack("<Q", len(text)))
        f.write(text)
        for b in blobs:
            f.write(b)


def float_tensors(path, items, prefix_in_file):
    out = {}
    for name, t in items:
        if not isinstance(t, Tensor):
            fail(path, f"'{prefix_in_file}{name}'", f"is a {type(t).__name__}, not a tensor")
        if not t.is_float:
            fail(path, f"tensor '{prefix_in_file}{name}'", "is not float32, float16 or bfloat16")
        if not t.finite():
            fail(path, f"tensor '{prefix_in_file}{name}'", "holds NaN or infinity")
        out[name] = t
    return out


def convert(args):
    Placeholder.seen.clear()
    ckpt = read_checkpoint(args.checkpoint)
    sd = state_dict_of(ckpt, args.checkpoint)
    src = os.path.basename(args.checkpoint)
    if looks_like_gsm(ckpt, sd):
        outputs, report = convert_gsm(args, ckpt, sd, src)
        return outputs, report + left_out_report(sd, {k for k in sd if k.startswith(GSM_PARTS)})
    if getattr(args, "dav2_heads", None):
        fail(args.checkpoint, "--dav2-heads", "only for a GSM checkpoint")
    is_vae = any(k.startswith("encoder.") or k.startswith("unet.encoders.") or k.startswith("unet.decoders.")
                 for k in sd)
    outputs, used = {}, set()
    report = []
    if is_vae:
        # The Lightning module's encoder.* and unet.* (its loss module's tensors, if any, are left out).
        vae = float_tensors(args.checkpoint, [(k, v) for k, v in sd.items() if isinstance(v, Tensor) and v.is_float
                                              and (k.startswith("encoder.") or k.startswith("unet."))], "")
        used.update(vae)
        hp, enc_hp = vae_hparams(ckpt)
        outputs.update(vae_outputs(args.checkpoint, src, vae, "", hp, enc_hp, None, report))
        report.append("scale_factor: a standalone VAE has none (icube uses 1 unless --scale-factor)")
    else:
        live = {k[5:]: v for k, v in sd.items() if k.startswith("unet.")}
        ema_flat = {k[9:]: v for k, v in sd.items() if k.startswith("unet_ema.") and k not in LEFT_OUT_BUFFERS}
        if not live and not ema_flat:
            fail(args.checkpoint, "state_dict", "has neither unet.* nor unet_ema.* nor a VAE's encoder.* keys")
        if not live:
            fail(args.checkpoint, "state_dict", "has unet_ema.* but no unet.*: the EMA names cannot be mapped back")
        # LitEma's buffer names drop every '.', so map them through the live names.
        flat_to_name = {}
        for name in live:
            flat = name.replace(".", "")
            if flat in flat_to_name:
                fail(args.checkpoint, f"tensor 'unet.{name}'", f"collides with 'unet.{flat_to_name[flat]}' without dots")
            flat_to_name[flat] = name
        take = args.weights
        if take == "auto":
            take = "ema" if ema_flat else "live"
        if take == "ema":
            if not ema_flat:
                fail(args.checkpoint, "--weights ema", "the checkpoint has no EMA copy (no unet_ema.* tensors)")
            items = []
            for flat, t in ema_flat.items():
                if flat not in flat_to_name:
                    fail(args.checkpoint, f"tensor 'unet_ema.{flat}'", "matches no unet.* parameter")
                items.append((flat_to_name[flat], t))
            missing = sorted(set(n for n, t in live.items() if isinstance(t, Tensor) and t.is_float) -
                             {n for n, _ in items})
            if missing:
                fail(args.checkpoint, f"tensor 'unet_ema.{missing[0].replace('.', '')}'",
                     f"missing (the EMA copy lacks unet.{missing[0]})")
            used.update("unet_ema." + f for f in ema_flat)
        else:
            items = list(live.items())
        used.update("unet." + k for k in live)
        unet = float_tensors(args.checkpoint, items, "unet." if take == "live" else "unet_ema.")
        for n in live:
            if n not in unet:
                fail(args.checkpoint, f"tensor 'unet.{n}'", "is not a floating-point parameter")
        kwargs, assumed = infer_unet_kwargs(unet, args.checkpoint, diffuser_hparams(ckpt))
        scale = None
        if "scale_factor" in sd:
            s = sd["scale_factor"]
            try:
                scale = float(s.item() if isinstance(s, Tensor) else s)
            except (TypeError, ValueError) as e:
                fail(args.checkpoint, "tensor 'scale_factor'", f"is not one number ({e})")
            used.add("scale_factor")
            if not (scale == scale and abs(scale) != float("inf") and scale > 0):
                fail(args.checkpoint, "tensor 'scale_factor'", f"{scale} is not a positive finite number")
        meta = {"source": src, "model": "diffusion_unet", "weights": take}
        if scale is not None:
            meta["scale_factor"] = repr(scale)
        outputs["unet.safetensors"] = ("safetensors", unet, meta)
        config = {"description": f"InfiniCube dense diffusion UNet converted from {src} ({take} weights)",
                  "unet_kwargs": kwargs, "scale_factor": scale, "weights": take,
                  "assumed_from_released_model": assumed}
        outputs["unet_config.json"] = ("json", config, None)
        report.append(f"unet.safetensors: {len(unet)} tensors ({take} weights), "
                      f"{sum(t.numel() for t in unet.values()):,} parameters")
        report.append("unet_config.json: model_channels {model_channels}, channel_mult {channel_mult}, "
                      "num_res_blocks {num_res_blocks}, attention_resolutions {attention_resolutions}, "
                      "transformer_depth {transformer_depth}".format(**kwargs) +
                      (f"; from the released model (not in the checkpoint): {', '.join(assumed)}" if assumed else ""))
        report.append("scale_factor: " + (repr(scale) if scale is not None else
                                          "not in the checkpoint (icube uses 1 with a warning unless --scale-factor)"))
        vae = {k[4:]: v for k, v in sd.items() if k.startswith("vae.encoder.") or k.startswith("vae.unet.")}
        if vae:
            vae = float_tensors(args.checkpoint, [(k, v) for k, v in vae.items() if isinstance(v, Tensor) and
                                                  v.is_float], "vae.")
            used.update("vae." + k for k in vae)
            # The diffusion checkpoint's hyper_parameters describe the diffusion model, not the VAE.
            outputs.update(vae_outputs(args.checkpoint, src, vae, "vae.", {}, {}, scale, report))
    return outputs, report + left_out_report(sd, used)


def left_out_report(sd, used):
    """The pickled classes not built, and the state_dict entries not written, grouped by their first name part."""
    report = []
    if Placeholder.seen:
        report.append("pickled objects not built (inert placeholders): " + ", ".join(sorted(Placeholder.seen)))
    left = sorted(k for k in sd if k not in used)
    if left:
        groups = sorted({k.split(".")[0] for k in left})
        report.append(f"left out: {len(left)} entries ({', '.join(groups)})")
    return report


def current_umask():
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_outputs(out_dir, outputs):
    os.makedirs(out_dir, exist_ok=True)
    staged = []
    try:
        for name, (kind, payload, meta) in outputs.items():
            fd, tmp = tempfile.mkstemp(prefix="." + name + ".", dir=out_dir)
            os.close(fd)
            staged.append((tmp, os.path.join(out_dir, name)))
            if kind == "safetensors":
                write_safetensors(tmp, payload, meta)
            else:
                with open(tmp, "w") as f:
                    json.dump(payload, f, indent=1)
                    f.write("\n")
        mode = 0o666 & ~current_umask()
        for tmp, final in staged:
            os.chmod(tmp, mode)
            os.replace(tmp, final)
    finally:
        for tmp, _ in staged:
            if os.path.exists(tmp):
                os.remove(tmp)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter,
                                epilog="\n\n".join(__doc__.split("\n\n")[1:]))
    p.add_argument("checkpoint", help="official Lightning .ckpt (diffusion, VAE or GSM), or a bare state dict")
    p.add_argument("-o", "--output", required=True, help="output folder (created)")
    p.add_argument("--weights", choices=["auto", "ema", "live"], default="auto",
                   help="the UNet copy to write: auto = EMA when present (default), else live")
    p.add_argument("--dav2-heads", type=int, metavar="N",
                   help="GSM: the Depth-Anything backbone's attention heads (not in the weights; default: the "
                        "released model's, else DINOv2's 64-wide heads)")
    args = p.parse_args(argv)
    try:
        import numpy  # noqa: F401
    except ImportError:
        print("convert_checkpoint: needs numpy (apt install python3-numpy)", file=sys.stderr)
        return 2
    try:
        outputs, report = convert(args)
        write_outputs(args.output, outputs)
    except ConvertError as e:
        print(f"convert_checkpoint: {e}", file=sys.stderr)
        return 1
    for line in report:
        print(f"convert_checkpoint: {line}")
    print(f"convert_checkpoint: wrote {', '.join(sorted(outputs))} to {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
