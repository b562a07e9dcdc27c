#!/usr/bin/env python3
"""Turn an InfiniCube-VK world into the `voxel.pt` that InfiniCube's Stage 3 loads.

InfiniCube's clip folders carry a copy of the Stage-1 voxel world as
`voxel.pt` = torch.save({"points": fvdb.GridBatch, "semantics": int64[N]})
(inference/voxel_world_generation.py), and Stage 3
(inference/scene_gaussian_generation.py) reads `torch.load(...)["points"]` as
`data_dict["scene_grid"]`. That file is a pickle of fVDB objects, which the C++
engine does not write; this script, run where the official stack (PyTorch +
fVDB) is installed, writes it.

The grid is in InfiniCube's voxel world (the clip's first camera, FLU axes):
voxel size 0.2 m, origin 0.1 m, i.e. voxel ijk has its centre at ijk*0.2 + 0.1.
The engine's world is in its own frame (any origin, rotated against the voxel
world), so the voxels are moved the way InfiniCube moves a generated chunk into
the voxel world (`transform_grid_and_semantic(subdivide=True)`,
voxelgen/utils/extrap_util.py): every voxel is split into 8 sub-voxels, their
centres are transformed (float64) and re-voxelised, and each new voxel takes the
semantic class of the nearest transformed original voxel centre (exact nearest
neighbour; the nearest lies in the 3x3x3 neighbourhood of the point's cell in
the original grid, since rigid transforms keep distances).

Inputs:
  WORLD             an engine world: .icw (engine/world/world_file.h), or a
                    labelled-point .npy, N x 4|5 float32/64 (x, y, z, class[, instance]),
                    voxelised at 0.2 m with the origin at 0 (one class per voxel: the first point's)
  --clip DIR        a clip folder `icube buffers` wrote: its world_to_voxel_world.npy
                    gives the transform, and voxel.pt goes into DIR by default
  --world-to-voxel  a 4x4 .npy instead of --clip
Outputs:
  -o FILE           the voxel.pt (needs torch and fvdb)
  --arrays DIR      the arrays handed to fVDB, without torch or fvdb:
                    ijk.npy int32 [M, 3] (ascending x, then y, then z),
                    semantics.npy int64 [M], meta.json (voxel size, origin, counts)

Errors name the file and the place, exit with status 1, and leave no
half-written output (files are written to a temporary name and renamed).
"""

import argparse
import json
import os
import struct
import sys
import zlib

VOXEL_SIZE = 0.2  # InfiniCube's voxel world
GRID_ORIGIN = 0.1
ICW_MAGIC = b"ICW1"
ICW_VERSION = 1
ICW_HEADER = 48
MAX_CLASS = 22


class InputError(Exception):
    def __init__(self, path, where, what):
        super().__init__(f"{path}: {where + ': ' if where else ''}{what}")


def need_numpy():
    try:
        import numpy  # noqa: F401
    except ImportError:
        sys.exit("export_infinicube_voxel: needs numpy (Debian: apt install python3-numpy)")


def read_icw(path):
    """Returns (ijk int64 [N,3], classes int64 [N], origin float64 [3], voxel_size)."""
    import numpy as np

    try:
        data = open(path, "rb").read()
    except OSError as e:
        raise InputError(path, "", f"cannot read: {e.strerror}")
    if len(data) < ICW_HEADER + 4:
        raise InputError(path, "byte 0", f"{len(data)} bytes, shorter than the 52-byte minimum of an .icw file")
    if data[:4] != ICW_MAGIC:
        raise InputError(path, "byte 0", "not an .icw world (magic is not ICW1)")
    (version,) = struct.unpack_from("<I", data, 4)
    if version != ICW_VERSION:
        raise InputError(path, "byte 4", f"version {version}; this script reads version {ICW_VERSION}")
    (crc,) = struct.unpack_from("<I", data, len(data) - 4)
    if zlib.crc32(data[:-4]) & 0xFFFFFFFF != crc:
        raise InputError(path, f"byte {len(data) - 4}", "CRC32 mismatch: the file is damaged")
    origin = np.array(struct.unpack_from("<3d", data, 8), dtype=np.float64)
    (voxel_size,) = struct.unpack_from("<d", data, 32)
    (bricks,) = struct.unpack_from("<Q", data, 40)
    if not np.all(np.isfinite(origin)) or not (voxel_size > 0 and np.isfinite(voxel_size)):
        raise InputError(path, "byte 8", "origin or voxel size is not finite and positive")
    brick_min = 12 + 64  # coordinates + mask, no voxel
    if bricks > (len(data) - ICW_HEADER - 4) // brick_min:
        raise InputError(path, "byte 40", f"{bricks} bricks cannot fit in {len(data)} bytes")
    bit = np.arange(512, dtype=np.int64)
    local = np.stack([bit & 7, (bit >> 3) & 7, bit >> 6], axis=1)
    ijks, classes = [], []
    pos = ICW_HEADER
    end = len(data) - 4
    for b in range(bricks):
        if pos + brick_min > end:
            raise InputError(path, f"byte {pos}", f"brick {b} is cut off")
        coord = np.array(struct.unpack_from("<3i", data, pos), dtype=np.int64)
        words = np.frombuffer(data, dtype="<u8", count=8, offset=pos + 12)
        occupied = np.unpackbits(words.view(np.uint8), bitorder="little").astype(bool)
        n = int(occupied.sum())
        pos += brick_min
        if n == 0:
            raise InputError(path, f"byte {pos - 64}", f"brick {b} is empty")
        if pos + 3 * n > end:
            raise InputError(path, f"byte {pos}", f"brick {b}'s {n} voxels are cut off")
        cls = np.frombuffer(data, dtype=np.uint8, count=n, offset=pos).astype(np.int64)
        pos += 3 * n  # classes, then uint16 instances (not part of voxel.pt)
        if cls.min() < 1 or cls.max() > MAX_CLASS:
            raise InputError(path, f"brick {b}", f"class id outside 1..{MAX_CLASS}")
        ijks.append(coord * 8 + local[occupied])
        classes.append(cls)
    if pos != end:
        raise InputError(path, f"byte {pos}", f"{end - pos} bytes after the last brick")
    if not ijks:
        raise InputError(path, "", "the world has no voxel")
    return np.concatenate(ijks), np.concatenate(classes), origin, voxel_size


def read_points_npy(path, voxel_size=VOXEL_SIZE):
    """A labelled-point .npy (x, y, z, class[, instance]) of voxel centres."""
    import numpy as np

    try:
        a = np.load(path, allow_pickle=False)
    except (OSError, ValueError) as e:
        raise InputError(path, "", f"not a readable .npy: {e}")
    if a.ndim != 2 or a.shape[1] not in (4, 5) or a.dtype not in (np.float32, np.float64):
        raise InputError(path, "shape", f"{a.dtype} {list(a.shape)}; expected float32/64 N x 4 or N x 5")
    if a.shape[0] == 0:
        raise InputError(path, "", "no point")
    a = a.astype(np.float64)
    bad = ~np.all(np.isfinite(a), axis=1)
    if bad.any():
        raise InputError(path, f"row {int(np.argmax(bad))}", "not finite")
    cls = a[:, 3]
    wrong = (cls != np.round(cls)) | (cls < 1) | (cls > MAX_CLASS)
    if wrong.any():
        raise InputError(path, f"row {int(np.argmax(wrong))}", f"class {cls[int(np.argmax(wrong))]} is not an id 1..{MAX_CLASS}")
    origin = np.zeros(3)
    ijk = np.floor(a[:, :3] / voxel_size).astype(np.int64)
    # One class per voxel: the first point's.
    key = ijk_keys(ijk)
    _, first = np.unique(key, return_index=True)
    return ijk[first], cls[first].astype(np.int64), origin, voxel_size


def ijk_keys(ijk):
    """Packs int ijk in [-2^20, 2^20) into one sortable int64 (x major, then y, then z)."""
    import numpy as np

    off = ijk.astype(np.int64) + (1 << 20)
    return (off[:, 0] << 42) | (off[:, 1] << 21) | off[:, 2]


def read_matrix(path):
    import numpy as np

    try:
        m = np.load(path, allow_pickle=False)
    except (OSError, ValueError) as e:
        raise InputError(path, "", f"not a readable .npy: {e}")
    if m.shape != (4, 4) or not np.all(np.isfinite(m)):
        raise InputError(path, "", f"expected a finite 4x4 matrix, got shape {list(m.shape)}")
    if not np.allclose(m[3], [0, 0, 0, 1]) or not np.allclose(m[:3, :3] @ m[:3, :3].T, np.eye(3), atol=1e-6):
        raise InputError(path, "", "not a rigid transform (rotation and translation)")
    return m.astype(np.float64)


def to_voxel_world(ijk, classes, origin, voxel_size, world_to_voxel):
    """The arrays InfiniCube's transform_grid_and_semantic(subdivide=True) would hand to fVDB."""
    import numpy as np

    rot, trans = world_to_voxel[:3, :3], world_to_voxel[:3, 3]
    centres = origin + (ijk + 0.5) * voxel_size
    # 8 sub-voxel centres per voxel, at +-voxel_size/4.
    corners = np.array([[dx, dy, dz] for dx in (-1, 1) for dy in (-1, 1) for dz in (-1, 1)], dtype=np.float64)
    fine = (centres[:, None, :] + corners[None, :, :] * (voxel_size / 4)).reshape(-1, 3)
    fine = fine @ rot.T + trans
    new_ijk = np.unique(np.floor((fine - GRID_ORIGIN) / VOXEL_SIZE + 0.5).astype(np.int64), axis=0)
    # Nearest original voxel centre to each new centre, found in the original grid.
    new_centres = new_ijk * VOXEL_SIZE + GRID_ORIGIN
    back = (new_centres - trans) @ rot  # inverse of the rigid transform
    cell = np.floor((back - origin) / voxel_size).astype(np.int64)
    keys = ijk_keys(ijk)
    order = np.argsort(keys)
    sorted_keys = keys[order]
    best_d = np.full(len(new_ijk), np.inf)
    best_cls = np.zeros(len(new_ijk), dtype=np.int64)
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            for dz in (-1, 0, 1):
                cand = cell + np.array([dx, dy, dz])
                ck = ijk_keys(cand)
                at = np.clip(np.searchsorted(sorted_keys, ck), 0, len(sorted_keys) - 1)
                hit = sorted_keys[at] == ck
                d = np.sum((origin + (cand + 0.5) * voxel_size - back) ** 2, axis=1)
                better = hit & (d < best_d)
                best_d[better] = d[better]
                best_cls[better] = classes[order[at[better]]]
    if np.isinf(best_d).any():  # cannot happen for a rigid transform; guards a bad matrix
        raise RuntimeError("a re-voxelised voxel has no original voxel within one cell")
    return new_ijk.astype(np.int32), best_cls


def write_atomic(path, write):
    tmp = f"{path}.tmp-{os.getpid()}"
    try:
        write(tmp)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise


def write_arrays(out_dir, ijk, semantics, source):
    import numpy as np

    os.makedirs(out_dir, exist_ok=True)

    def save_npy(name, arr):
        def write(tmp):
            with open(tmp, "wb") as f:
                np.save(f, arr)

        write_atomic(os.path.join(out_dir, name), write)

    save_npy("ijk.npy", ijk)
    save_npy("semantics.npy", semantics)
    meta = {"voxel_size": VOXEL_SIZE, "origin": GRID_ORIGIN, "voxels": int(len(ijk)), "source": source,
            "frame": "InfiniCube voxel world (first camera, FLU)"}

    def write_meta(tmp):
        with open(tmp, "w") as f:
            json.dump(meta, f, indent=2)
            f.write("\n")

    write_atomic(os.path.join(out_dir, "meta.json"), write_meta)


def write_voxel_pt(path, ijk, semantics):
    try:
        import torch
        import fvdb
    except ImportError as e:
        sys.exit(f"export_infinicube_voxel: writing {path} needs torch and fvdb (the official InfiniCube "
                 f"environment): {e}; --arrays DIR writes the arrays without them")
    import numpy as np

    centres = torch.from_numpy(ijk.astype(np.float64) * VOXEL_SIZE + GRID_ORIGIN).float()
    # As InfiniCube builds its grids (gridbatch_from_points, voxel size 0.2, origin 0.1).
    grid = fvdb.gridbatch_from_points(centres, voxel_sizes=VOXEL_SIZE, origins=GRID_ORIGIN)
    grid_ijk = grid.ijk.jdata.cpu().numpy().astype(np.int64)
    if len(grid_ijk) != len(ijk):
        sys.exit(f"export_infinicube_voxel: fVDB built {len(grid_ijk)} voxels from {len(ijk)} centres")
    # fVDB orders voxels its own way: semantics follow the grid's order.
    ours = ijk_keys(ijk.astype(np.int64))
    order = np.argsort(ours)
    at = np.searchsorted(ours[order], ijk_keys(grid_ijk))
    sem = torch.from_numpy(semantics[order[at]]).long()
    write_atomic(path, lambda tmp: torch.save({"points": grid.to("cpu"), "semantics": sem}, tmp))


def main(argv=None):
    ap = argparse.ArgumentParser(
        prog="export_infinicube_voxel.py",
        description="Turn an InfiniCube-VK world (.icw, or a labelled-point .npy) into the voxel.pt that "
                    "InfiniCube's Stage 3 loads (PyTorch + fVDB), or the arrays handed to fVDB (numpy only).",
        epilog="Example: export_infinicube_voxel.py build/demo/world.icw --clip build/demo/buffers/demo")
    ap.add_argument("world", help="engine world: .icw, or .npy N x 4|5 (x, y, z, class[, instance])")
    ap.add_argument("--clip", help="clip folder from `icube buffers` (world_to_voxel_world.npy; default output there)")
    ap.add_argument("--world-to-voxel", help="4x4 .npy: engine world frame -> InfiniCube voxel world")
    ap.add_argument("-o", "--output", help="voxel.pt to write (default: CLIP/voxel.pt when --clip is given)")
    ap.add_argument("--arrays", metavar="DIR", help="write ijk.npy, semantics.npy, meta.json instead (no torch)")
    args = ap.parse_args(argv)
    need_numpy()
    import numpy as np

    if bool(args.clip) == bool(args.world_to_voxel):
        ap.error("give exactly one of --clip and --world-to-voxel")
    try:
        m_path = args.world_to_voxel or os.path.join(args.clip, "world_to_voxel_world.npy")
        world_to_voxel = read_matrix(m_path)
        if args.world.lower().endswith(".npy"):
            ijk, classes, origin, vs = read_points_npy(args.world)
        else:
            ijk, classes, origin, vs = read_icw(args.world)
        if abs(vs - VOXEL_SIZE) > 1e-9:
            raise InputError(args.world, "voxel size", f"{vs} m; InfiniCube's voxel world is {VOXEL_SIZE} m")
    except InputError as e:
        print(f"export_infinicube_voxel: {e}", file=sys.stderr)
        return 1
    new_ijk, semantics = to_voxel_world(ijk, classes, origin, vs, world_to_voxel)
    print(f"export_infinicube_voxel: {len(ijk)} voxels -> {len(new_ijk)} voxels in the voxel world", file=sys.stderr)
    if args.arrays:
        write_arrays(args.arrays, new_ijk, semantics, os.path.basename(args.world))
        print(f"export_infinicube_voxel: wrote {args.arrays}/ijk.npy, semantics.npy, meta.json", file=sys.stderr)
    output = args.output or (os.path.join(args.clip, "voxel.pt") if args.clip and not args.arrays else None)
    if output:
        write_voxel_pt(output, new_ijk, semantics)
        print(f"export_infinicube_voxel: wrote {output}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
