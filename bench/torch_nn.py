#!/usr/bin/env python3
"""PyTorch side of icube-bench-nn --torch (benchmark only, never the icube runtime).

  torch_nn.py --threads N --runs R --warmup W CASE_DIR

CASE_DIR/case.json names the op and its arguments; its inputs are .npy files
beside it, written by icube-bench-nn from the same fixed-seed tensors the GPU
kernel gets:
  conv3d      x [B,Ci,X,Y,Z], w [Co,Ci,k,k,k], b [Co]        F.conv3d(padding=k//2)
  group_norm  x [B,C,S], mod [B,2C], groups, eps             silu(group_norm(x)*(1+scale)+shift)
  attention   q, k, v [B, H*D, N] channels-first, heads       scaled_dot_product_attention
Writes CASE_DIR/y.npy (the last run's output, for the correctness check in the
same run) and prints one JSON line: {"min_ms", "median_ms", "threads", "torch"}.
"""

import argparse
import json
import os
import sys
import time

import numpy as np
import torch
import torch.nn.functional as F


def attention(q, k, v, heads):
    b, c, n = q.shape
    d = c // heads
    # channels-first [B, H*D, N] -> [B, H, N, D]
    qh, kh, vh = (t.reshape(b, heads, d, n).transpose(2, 3) for t in (q, k, v))
    w = torch.softmax((qh @ kh.transpose(2, 3)) * (d ** -0.5), dim=-1)
    return (w @ vh).transpose(2, 3).reshape(b, c, n)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("case_dir")
    p.add_argument("--threads", type=int, required=True)
    p.add_argument("--runs", type=int, default=5)
    p.add_argument("--warmup", type=int, default=1)
    a = p.parse_args()
    torch.set_num_threads(a.threads)
    with open(os.path.join(a.case_dir, "case.json")) as f:
        case = json.load(f)

    def load(name):
        return torch.from_numpy(np.load(os.path.join(a.case_dir, name + ".npy")))

    op = case["op"]
    if op == "conv3d":
        x, w, b = load("x"), load("w"), load("b")
        run = lambda: F.conv3d(x, w, b, padding=w.shape[-1] // 2)
    elif op == "group_norm":
        x, mod = load("x"), load("mod")
        c = x.shape[1]
        scale, shift = mod[:, :c, None], mod[:, c:, None]
        run = lambda: F.silu(F.group_norm(x, case["groups"], eps=case["eps"]) * (1 + scale) + shift)
    elif op == "attention":
        q, k, v = load("q"), load("k"), load("v")
        run = lambda: attention(q, k, v, case["heads"])
    else:
        print(f"torch_nn: unknown op {op!r}", file=sys.stderr)
        return 2
    times = []
    with torch.no_grad():
        for r in range(a.warmup + a.runs):
            t0 = time.perf_counter()
            y = run()
            dt = (time.perf_counter() - t0) * 1e3
            if r >= a.warmup:
                times.append(dt)
    np.save(os.path.join(a.case_dir, "y.npy"), y.contiguous().numpy())
    times.sort()
    print(json.dumps({"min_ms": times[0], "median_ms": times[len(times) // 2], "threads": torch.get_num_threads(),
                      "torch": torch.__version__}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
