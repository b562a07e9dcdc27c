#!/usr/bin/env python3
"""PyTorch side of icube-bench-nn's whole-UNet rows (benchmark only, never the icube runtime).

  torch_unet.py --config CONFIG.json --weights W.safetensors --input x.npy --timestep t.npy
                --threads N [--runs R] [--warmup W] -o y.npy

InfiniCube's dense diffusion UNet (the official UNetModel's forward: ResBlocks
with scale-shift norm and resblock up/down, legacy AttentionBlocks, the middle
SpatialTransformer with GEGLU feed-forward) written here with torch.nn.functional
on the official state-dict names, for timing PyTorch on the same weights and
input as the engine. Prints one JSON line {"min_ms", "median_ms", "threads"}.
"""

import argparse
import json
import math
import struct
import sys
import time

import numpy as np
import torch
import torch.nn.functional as F


def read_safetensors(path):
    with open(path, "rb") as f:
        n = struct.unpack("<Q", f.read(8))[0]
        header = json.loads(f.read(n))
        data = f.read()
    out = {}
    for name, info in header.items():
        if name == "__metadata__":
            continue
        if info["dtype"] != "F32":
            raise SystemExit(f"torch_unet: {path}: tensor '{name}' is {info['dtype']}, this bench reads F32")
        a, b = info["data_offsets"]
        out[name] = torch.from_numpy(np.frombuffer(data[a:b], dtype="<f4").reshape(info["shape"]).copy())
    return out


class UNet:
    def __init__(self, kw, w):
        self.kw, self.w = kw, w
        self.heads = kw.get("num_heads", 8)
        self.head_channels = kw.get("num_head_channels", -1)
        self.heads_up = kw.get("num_heads_upsample", -1)
        if self.heads_up == -1:
            self.heads_up = self.heads
        if not kw.get("use_scale_shift_norm", True) or not kw.get("resblock_updown", True):
            raise SystemExit("torch_unet: only use_scale_shift_norm and resblock_updown = true (the released model)")
        # The block plan, as the official constructor builds it.
        mc, attn_res, mult = kw["model_channels"], kw["attention_resolutions"], kw["channel_mult"]
        self.inp = [[("conv", "input_blocks.0.0")]]
        skips, ch, ds = [mc], mc, 1
        for level, m in enumerate(mult):
            for _ in range(kw["num_res_blocks"]):
                p = f"input_blocks.{len(self.inp)}."
                blk = [("res", p + "0", None)]
                ch = m * mc
                if ds in attn_res:
                    blk.append(("attn", p + "1", self.attn_heads(ch, self.heads)))
                self.inp.append(blk)
                skips.append(ch)
            if level != len(mult) - 1:
                self.inp.append([("res", f"input_blocks.{len(self.inp)}.0", "down")])
                skips.append(ch)
                ds *= 2
        self.mid_heads = self.attn_heads(ch, self.heads)
        self.out = []
        for level in reversed(range(len(mult))):
            for i in range(kw["num_res_blocks"] + 1):
                skips.pop()
                p = f"output_blocks.{len(self.out)}."
                blk = [("res", p + "0", None)]
                ch = mult[level] * mc
                if ds in attn_res:
                    blk.append(("attn", p + "1", self.attn_heads(ch, self.heads_up)))
                if level and i == kw["num_res_blocks"]:
                    blk.append(("res", p + str(len(blk)), "up"))
                    ds //= 2
                self.out.append(blk)

    def attn_heads(self, ch, heads):
        return heads if self.head_channels == -1 else ch // self.head_channels

    def res(self, p, x, emb, updown):
        w = self.w
        h = F.silu(F.group_norm(x, 32, w[p + ".in_layers.0.weight"], w[p + ".in_layers.0.bias"]))
        if updown == "up":
            h, x = F.interpolate(h, scale_factor=2, mode="nearest"), F.interpolate(x, scale_factor=2, mode="nearest")
        elif updown == "down":
            h, x = F.avg_pool3d(h, 2), F.avg_pool3d(x, 2)
        h = F.conv3d(h, w[p + ".in_layers.2.weight"], w[p + ".in_layers.2.bias"], padding=1)
        e = F.linear(F.silu(emb), w[p + ".emb_layers.1.weight"], w[p + ".emb_layers.1.bias"])[:, :, None, None, None]
        scale, shift = e.chunk(2, dim=1)
        h = F.group_norm(h, 32, w[p + ".out_layers.0.weight"], w[p + ".out_layers.0.bias"]) * (1 + scale) + shift
        h = F.conv3d(F.silu(h), w[p + ".out_layers.3.weight"], w[p + ".out_layers.3.bias"], padding=1)
        if p + ".skip_connection.weight" in w:
            x = F.conv3d(x, w[p + ".skip_connection.weight"], w[p + ".skip_connection.bias"])
        return x + h

    @staticmethod
    def sdpa(q, k, v):  # [B, H, N, D]
        a = torch.softmax((q @ k.transpose(-1, -2)) * (q.shape[-1] ** -0.5), dim=-1)
        return a @ v

    def attn(self, p, x, heads):
        w = self.w
        b, c = x.shape[:2]
        h = F.group_norm(x, 32, w[p + ".norm.weight"], w[p + ".norm.bias"]).reshape(b, c, -1)
        qkv = F.conv1d(h, w[p + ".qkv.weight"], w[p + ".qkv.bias"])
        q, k, v = (t.reshape(b, heads, c // heads, -1).transpose(2, 3) for t in qkv.chunk(3, dim=1))
        a = self.sdpa(q, k, v).transpose(2, 3).reshape(b, c, -1)
        return x + F.conv1d(a, w[p + ".proj_out.weight"], w[p + ".proj_out.bias"]).reshape(x.shape)

    def transformer(self, p, x):
        w, heads = self.w, self.mid_heads
        b, c = x.shape[:2]
        h = F.group_norm(x, 32, w[p + ".norm.weight"], w[p + ".norm.bias"], eps=1e-6)
        h = F.conv3d(h, w[p + ".proj_in.weight"], w[p + ".proj_in.bias"])
        inner = h.shape[1]
        t = h.reshape(b, inner, -1).transpose(1, 2)  # [B, N, C]

        def self_attention(a, y):
            q, k, v = (F.linear(y, w[f"{a}.to_{n}.weight"]).reshape(b, -1, heads, inner // heads).transpose(1, 2)
                       for n in "qkv")
            o = self.sdpa(q, k, v).transpose(1, 2).reshape(b, -1, inner)
            return F.linear(o, w[a + ".to_out.0.weight"], w[a + ".to_out.0.bias"])

        blocks = sorted({int(k.split(".")[3]) for k in w if k.startswith(p + ".transformer_blocks.")})
        for i in blocks:
            q = f"{p}.transformer_blocks.{i}."
            if q + "attn1.to_q.weight" in w:
                t = self_attention(q + "attn1", F.layer_norm(t, (inner,), w[q + "norm1.weight"], w[q + "norm1.bias"])) + t
            t = self_attention(q + "attn2", F.layer_norm(t, (inner,), w[q + "norm2.weight"], w[q + "norm2.bias"])) + t
            proj = F.linear(F.layer_norm(t, (inner,), w[q + "norm3.weight"], w[q + "norm3.bias"]),
                            w[q + "ff.net.0.proj.weight"], w[q + "ff.net.0.proj.bias"])
            value, gate = proj.chunk(2, dim=-1)
            t = F.linear(value * F.gelu(gate), w[q + "ff.net.2.weight"], w[q + "ff.net.2.bias"]) + t
        h = t.transpose(1, 2).reshape(b, inner, *x.shape[2:])
        return F.conv3d(h, w[p + ".proj_out.weight"], w[p + ".proj_out.bias"]) + x

    def run(self, layer, h, emb):
        kind = layer[0]
        if kind == "conv":
            return F.conv3d(h, self.w[layer[1] + ".weight"], self.w[layer[1] + ".bias"], padding=1)
        if kind == "res":
            return self.res(layer[1], h, emb, layer[2])
        return self.attn(layer[1], h, layer[2])

    def forward(self, x, t):
        w, mc = self.w, self.kw["model_channels"]
        half = mc // 2
        freqs = torch.exp(-math.log(10000) * torch.arange(half, dtype=torch.float32) / half)
        args = t[:, None].float() * freqs[None]
        t_emb = torch.cat([torch.cos(args), torch.sin(args)], dim=-1)
        emb = F.linear(F.silu(F.linear(t_emb, w["time_embed.0.weight"], w["time_embed.0.bias"])),
                       w["time_embed.2.weight"], w["time_embed.2.bias"])
        hs, h = [], x
        for blk in self.inp:
            for layer in blk:
                h = self.run(layer, h, emb)
            hs.append(h)
        h = self.res("middle_block.0", h, emb, None)
        if "middle_block.1.proj_in.weight" in w:
            h = self.transformer("middle_block.1", h)
        else:
            h = self.attn("middle_block.1", h, self.mid_heads)
        h = self.res("middle_block.2", h, emb, None)
        for blk in self.out:
            h = torch.cat([h, hs.pop()], dim=1)
            for layer in blk:
                h = self.run(layer, h, emb)
        h = F.silu(F.group_norm(h, 32, w["out.0.weight"], w["out.0.bias"]))
        return F.conv3d(h, w["out.2.weight"], w["out.2.bias"], padding=1)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    for a in ("--config", "--weights", "--input", "--timestep"):
        p.add_argument(a, required=True)
    p.add_argument("-o", "--output", required=True)
    p.add_argument("--threads", type=int, required=True)
    p.add_argument("--runs", type=int, default=5)
    p.add_argument("--warmup", type=int, default=1)
    a = p.parse_args()
    torch.set_num_threads(a.threads)
    if a.config == "infinicube-diffusion":
        kw = {"model_channels": 192, "num_res_blocks": 2, "attention_resolutions": [4, 8], "channel_mult": [1, 2, 4, 4],
              "num_heads": 8}
    else:
        with open(a.config) as f:
            kw = json.load(f)
        kw = kw.get("unet_kwargs", kw)
    net = UNet(kw, read_safetensors(a.weights))
    x = torch.from_numpy(np.load(a.input))
    t = torch.from_numpy(np.load(a.timestep))
    times = []
    with torch.no_grad():
        for r in range(a.warmup + a.runs):
            t0 = time.perf_counter()
            y = net.forward(x, t)
            if r >= a.warmup:
                times.append((time.perf_counter() - t0) * 1e3)
    np.save(a.output, y.numpy())
    times.sort()
    print(json.dumps({"min_ms": times[0], "median_ms": times[len(times) // 2], "threads": torch.get_num_threads()}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
