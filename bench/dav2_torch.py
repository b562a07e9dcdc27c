#!/usr/bin/env python3
"""PyTorch's CPU run of the GSM's Depth-Anything-V2 image features, for icube-bench-gsm.

The module of engine/nn/gsm/dav2_reference.h written with torch.nn.functional on
the official state-dict names (img_encoder.encoders.dav2.*): bilinear resize of the
[0, 1] image to the target input size and ImageNet normalisation; DINOv2 (patch
embedding, CLS token, the position grid resized bicubically by output size,
pre-norm layers with layer scale and exact GELU, the final LayerNorm on the
selected hidden states); the DPT neck (reassemble, 3x3 convs, fusion from the
coarsest map up with pre-activation residual units and corner-aligned bilinear
upsampling); InfiniCube's upsampler (residual blocks with inference BatchNorm,
SiLU and nearest x2). The depth head is not run.

--matmul onednn (default) runs the transformer's linear layers and attention
products through oneDNN (torch._C._nn.mkldnn_linear with the weights converted
once, the path torch.utils.mkldnn gives nn.Linear): Debian's python3-torch is
built with the generic reference BLAS (torch.__config__: BLAS_INFO=generic), so
F.linear and torch.matmul, which --matmul blas uses, run at a few GFLOP/s there.
Convolutions go through oneDNN either way.

Reads from --dir (written by icube-bench-gsm): dav2.safetensors (float32 weights),
dav2.json (sizes), image.npy [V, 3, H, W]. Writes y.npy [V, C, h, w] there and
prints one JSON line: {"min_ms", "median_ms", "runs", "threads", "torch"}.
Debian's python3-torch; transformers is not needed.
"""
import argparse
import json
import os
import struct
import time

import numpy as np
import torch
import torch.nn.functional as F

MODEL = "img_encoder.encoders.dav2.model."
UPSAMPLER = "img_encoder.encoders.dav2.upsampler."
IMAGENET_MEAN = (0.485, 0.456, 0.406)
IMAGENET_STD = (0.229, 0.224, 0.225)


def read_safetensors(path):
    """Every tensor of a .safetensors file (header length, JSON header, raw little-endian data)."""
    dtypes = {"F32": np.float32, "F16": np.float16, "I64": np.int64, "I32": np.int32, "U8": np.uint8, "BOOL": np.bool_}
    size = os.path.getsize(path)
    with open(path, "rb") as f:
        (header_len,) = struct.unpack("<Q", f.read(8))
        header = json.loads(f.read(header_len))
        data = bytearray(size - 8 - header_len)
        f.readinto(data)
    tensors = {}
    for name, info in header.items():
        if name == "__metadata__":
            continue
        begin, end = info["data_offsets"]
        dtype = np.dtype(dtypes[info["dtype"]]).newbyteorder("<")
        array = np.frombuffer(data, dtype=dtype, count=(end - begin) // dtype.itemsize, offset=begin)
        tensors[name] = torch.from_numpy(array.astype(np.float32, copy=False)).reshape(info["shape"])
    return tensors


def onednn_linear(x, weight, bias):
    """x [..., K] times weight [N, K] (+ bias) through oneDNN; weight and bias already oneDNN tensors."""
    shape = x.shape
    y = torch._C._nn.mkldnn_linear(x.reshape(-1, shape[-1]).to_mkldnn(), weight, bias).to_dense()
    return y.reshape(*shape[:-1], y.shape[-1])


class Dav2:
    def __init__(self, cfg, w, matmul="onednn"):
        self.cfg = cfg
        self.w = w
        self.onednn = matmul == "onednn"
        self.onednn_weights = {}
        if self.onednn:  # the transformer's linear layers, converted once
            for name, t in w.items():
                if name.startswith(MODEL + "backbone.encoder.layer.") and t.dim() <= 2:
                    self.onednn_weights[name] = t.contiguous().to_mkldnn()

    def linear(self, x, prefix):
        """F.linear with the weight and (optional) bias at prefix.weight / prefix.bias."""
        weight, bias = MODEL + prefix + ".weight", MODEL + prefix + ".bias"
        if self.onednn:
            return onednn_linear(x, self.onednn_weights[weight], self.onednn_weights.get(bias))
        return F.linear(x, self.w[weight], self.w.get(bias))

    def products(self, a, b_t):
        """a [..., M, K] times b_t [..., N, K] transposed -> [..., M, N] (a batch of small matrix products)."""
        if not self.onednn:
            return torch.matmul(a, b_t.transpose(-1, -2))
        lead = a.shape[:-2]
        a2, b2 = a.reshape(-1, *a.shape[-2:]), b_t.reshape(-1, *b_t.shape[-2:])
        out = [onednn_linear(a2[i], b2[i].contiguous().to_mkldnn(), None) for i in range(a2.shape[0])]
        return torch.stack(out).reshape(*lead, a.shape[-2], b_t.shape[-2])

    def p(self, name):
        return self.w[MODEL + name]

    def pixel_values(self, images):
        h, w = self.cfg["input_size"]
        x = F.interpolate(images, size=(h, w), mode="bilinear", align_corners=False)
        mean = torch.tensor(IMAGENET_MEAN, dtype=x.dtype).view(1, 3, 1, 1)
        std = torch.tensor(IMAGENET_STD, dtype=x.dtype).view(1, 3, 1, 1)
        return (x - mean) / std

    def embeddings(self, pixel_values):
        e = "backbone.embeddings."
        patch = self.cfg["patch_size"]
        x = F.conv2d(pixel_values, self.p(e + "patch_embeddings.projection.weight"),
                     self.p(e + "patch_embeddings.projection.bias"), stride=patch)
        views, channels, gh, gw = x.shape
        tokens = x.flatten(2).transpose(1, 2)
        cls = self.p(e + "cls_token").expand(views, 1, channels)
        tokens = torch.cat([cls, tokens], dim=1)
        pos = self.p(e + "position_embeddings")
        grid = self.cfg["position_grid"]
        if gh * gw != grid * grid or pixel_values.shape[2] != pixel_values.shape[3]:
            table = pos[:, 1:].reshape(1, grid, grid, channels).permute(0, 3, 1, 2)
            table = F.interpolate(table, size=(gh, gw), mode="bicubic", align_corners=False)
            pos = torch.cat([pos[:, :1], table.flatten(2).transpose(1, 2)], dim=1)
        return tokens + pos, gh, gw

    def layer(self, x, i):
        l = "backbone.encoder.layer.%d." % i
        heads = self.cfg["num_heads"]
        eps = self.cfg["layer_norm_eps"]
        views, tokens, channels = x.shape
        h = F.layer_norm(x, (channels,), self.p(l + "norm1.weight"), self.p(l + "norm1.bias"), eps)
        a = l + "attention.attention."

        def project(name):
            y = self.linear(h, a + name)
            return y.view(views, tokens, heads, channels // heads).transpose(1, 2)

        q, k, v = project("query"), project("key"), project("value")
        scores = self.products(q, k) / float(np.sqrt(channels // heads))
        context = self.products(torch.softmax(scores, dim=-1), v.transpose(-1, -2))
        context = context.transpose(1, 2).reshape(views, tokens, channels)
        attn = self.linear(context, l + "attention.output.dense")
        x = x + attn * self.p(l + "layer_scale1.lambda1")
        h = F.layer_norm(x, (channels,), self.p(l + "norm2.weight"), self.p(l + "norm2.bias"), eps)
        h = F.gelu(self.linear(h, l + "mlp.fc1"))
        h = self.linear(h, l + "mlp.fc2")
        return x + h * self.p(l + "layer_scale2.lambda1")

    def feature_maps(self, pixel_values):
        x, gh, gw = self.embeddings(pixel_values)
        hidden = [x]
        for i in range(min(max(self.cfg["out_indices"]), self.cfg["num_layers"])):
            hidden.append(self.layer(hidden[-1], i))
        channels = x.shape[2]
        maps = [F.layer_norm(hidden[k], (channels,), self.p("backbone.layernorm.weight"),
                             self.p("backbone.layernorm.bias"), self.cfg["layer_norm_eps"])
                for k in self.cfg["out_indices"]]
        return maps, gh, gw

    def reassemble(self, tokens, k, gh, gw):
        r = "neck.reassemble_stage.layers.%d." % k
        x = tokens[:, 1:].transpose(1, 2).reshape(tokens.shape[0], tokens.shape[2], gh, gw)
        x = F.conv2d(x, self.p(r + "projection.weight"), self.p(r + "projection.bias"))
        factor = self.cfg["reassemble_factors"][k]
        if factor > 1:
            return F.conv_transpose2d(x, self.p(r + "resize.weight"), self.p(r + "resize.bias"), stride=int(factor))
        if factor == 1:
            return x
        return F.conv2d(x, self.p(r + "resize.weight"), self.p(r + "resize.bias"), stride=int(round(1 / factor)), padding=1)

    def residual_unit(self, x, prefix):
        h = F.conv2d(F.relu(x), self.p(prefix + "convolution1.weight"), self.p(prefix + "convolution1.bias"), padding=1)
        h = F.conv2d(F.relu(h), self.p(prefix + "convolution2.weight"), self.p(prefix + "convolution2.bias"), padding=1)
        return h + x

    def fusion_layer(self, i, hidden, residual, size):
        f = "neck.fusion_stage.layers.%d." % i
        if residual is not None:
            if residual.shape != hidden.shape:
                residual = F.interpolate(residual, size=hidden.shape[2:], mode="bilinear", align_corners=False)
            hidden = hidden + self.residual_unit(residual, f + "residual_layer1.")
        hidden = self.residual_unit(hidden, f + "residual_layer2.")
        hidden = F.interpolate(hidden, size=size, mode="bilinear", align_corners=True)
        return F.conv2d(hidden, self.p(f + "projection.weight"), self.p(f + "projection.bias"))

    def neck(self, maps, gh, gw):
        features = []
        for k, tokens in enumerate(maps):
            r = self.reassemble(tokens, k, gh, gw)
            features.append(F.conv2d(r, self.p("neck.convs.%d.weight" % k), padding=1))
        n = len(features)
        fused = None
        for i in range(n):
            feature = features[n - 1 - i]
            base = feature if fused is None else fused
            size = (2 * base.shape[2], 2 * base.shape[3]) if i + 1 == n else tuple(features[n - 2 - i].shape[2:])
            fused = self.fusion_layer(i, feature, None, size) if fused is None else self.fusion_layer(i, fused, feature, size)
        return fused

    def upsampler_block(self, x, j, block):
        u = UPSAMPLER + "%d." % j
        w = self.w

        def norm(t, prefix):
            return F.batch_norm(t, w[prefix + "running_mean"], w[prefix + "running_var"], w[prefix + "weight"],
                                w[prefix + "bias"], training=False, eps=1e-5)

        def resample(t):
            return F.interpolate(t, scale_factor=2, mode="nearest") if block["up"] else t

        h = resample(F.silu(norm(x, u + "in_layers.0.")))
        h = F.conv2d(h, w[u + "in_layers.2.weight"], w[u + "in_layers.2.bias"], padding=1)
        h = F.silu(norm(h, u + "out_layers.0."))
        h = F.conv2d(h, w[u + "out_layers.3.weight"], w[u + "out_layers.3.bias"], padding=1)
        xs = resample(x)
        if u + "skip_connection.weight" in w:
            xs = F.conv2d(xs, w[u + "skip_connection.weight"], w[u + "skip_connection.bias"])
        return xs + h

    def __call__(self, images):
        maps, gh, gw = self.feature_maps(self.pixel_values(images))
        x = self.neck(maps, gh, gw)
        for j, block in enumerate(self.cfg["upsampler"]):
            x = self.upsampler_block(x, j, block)
        return x


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--dir", required=True, help="folder with dav2.safetensors, dav2.json, image.npy")
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--warmup", type=int, default=1)
    parser.add_argument("--matmul", choices=("onednn", "blas"), default="onednn",
                        help="route of the transformer's linear layers and attention products")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    with open(os.path.join(args.dir, "dav2.json")) as f:
        cfg = json.load(f)
    model = Dav2(cfg, read_safetensors(os.path.join(args.dir, "dav2.safetensors")), args.matmul)
    images = torch.from_numpy(np.load(os.path.join(args.dir, "image.npy")).astype(np.float32))
    times = []
    with torch.no_grad():
        for r in range(args.warmup + args.runs):
            t0 = time.perf_counter()
            y = model(images)
            if r >= args.warmup:
                times.append((time.perf_counter() - t0) * 1e3)
    np.save(os.path.join(args.dir, "y.npy"), y.numpy().astype(np.float32))
    times.sort()
    n = len(times)
    median = times[n // 2] if n % 2 else 0.5 * (times[n // 2 - 1] + times[n // 2])
    print(json.dumps({"min_ms": times[0], "median_ms": median, "runs": n, "threads": torch.get_num_threads(),
                      "torch": torch.__version__, "matmul": args.matmul}))


if __name__ == "__main__":
    main()
