#!/usr/bin/python3
"""study_mesh.py - a smaller copy of an OBJ model for the accuracy study (tools/study.sh).

    /usr/bin/python3 tools/study_mesh.py IN.obj OUT.obj TARGET_VERTICES

Why: the study precomputes the same scene some fifty times; at the bunny's full
35,947 vertices each direct pass costs minutes on two cores, so the study uses a
copy with about TARGET_VERTICES vertices. Method: uniform-grid vertex clustering
(Rossignac & Borrel 1993): every vertex snaps to the mean position of the vertices
sharing its grid cell, triangles whose corners fall into fewer than three cells are
dropped, duplicates removed. The cell size is found by bisection so that the
number of surviving vertices is within 3% of the target. Only `v` and `f` lines
are read (polygons are fanned); normals are recomputed by prt's loader anyway.
Needs numpy (Debian's python3-numpy, pulled in by python3-matplotlib).
"""
import sys

import numpy as np


def read_obj(path):
    """Returns (positions [n,3] float64, triangles [m,3] int64) of an OBJ file."""
    pos, tris = [], []
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                pos.append([float(x) for x in line.split()[1:4]])
            elif line.startswith("f "):
                idx = []
                for tok in line.split()[1:]:
                    i = int(tok.split("/")[0])
                    idx.append(i - 1 if i > 0 else len(pos) + i)
                for k in range(1, len(idx) - 1):
                    tris.append([idx[0], idx[k], idx[k + 1]])
    if not pos or not tris:
        sys.exit(f"study_mesh: {path}: no vertices or faces")
    return np.asarray(pos), np.asarray(tris, dtype=np.int64)


def cluster(pos, tris, cell):
    """Vertex clustering at grid cell size `cell`; returns (positions, triangles)."""
    used = np.unique(tris)
    key = np.floor((pos - pos.min(axis=0)) / cell).astype(np.int64)
    _, cid = np.unique(key, axis=0, return_inverse=True)
    cid = cid.reshape(-1)
    t = cid[tris]
    keep = (t[:, 0] != t[:, 1]) & (t[:, 1] != t[:, 2]) & (t[:, 0] != t[:, 2])
    t = t[keep]
    # Drop duplicate triangles (same corner set, any order or orientation).
    _, first = np.unique(np.sort(t, axis=1), axis=0, return_index=True)
    t = t[np.sort(first)]
    # Cluster representative: mean of the (used) vertices in the cell.
    ncl = cid.max() + 1
    w = np.zeros(ncl)
    acc = np.zeros((ncl, 3))
    np.add.at(w, cid[used], 1.0)
    np.add.at(acc, cid[used], pos[used])
    rep = acc / np.maximum(w, 1.0)[:, None]
    # Renumber to the clusters that triangles still use.
    live = np.unique(t)
    remap = np.full(ncl, -1, dtype=np.int64)
    remap[live] = np.arange(live.size)
    return rep[live], remap[t]


def main():
    if len(sys.argv) != 4:
        sys.exit("usage: study_mesh.py IN.obj OUT.obj TARGET_VERTICES")
    src, dst, target = sys.argv[1], sys.argv[2], int(sys.argv[3])
    pos, tris = read_obj(src)
    diag = float(np.linalg.norm(pos.max(axis=0) - pos.min(axis=0)))
    lo, hi = diag * 1e-5, diag * 0.5  # cell sizes giving too many / too few vertices
    best = (pos, tris)
    if target < len(pos):
        for _ in range(40):
            mid = np.sqrt(lo * hi)
            p, t = cluster(pos, tris, mid)
            best = (p, t)
            if abs(len(p) - target) <= 0.03 * target:
                break
            if len(p) > target:
                lo = mid
            else:
                hi = mid
    p, t = best
    with open(dst, "w") as f:
        f.write(f"# {src} reduced by uniform vertex clustering to {len(p)} vertices, {len(t)} triangles\n")
        f.write("".join(f"v {x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in p))
        f.write("".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in t))
    print(f"{dst}: {len(p)} vertices, {len(t)} triangles (from {len(pos)}, {len(tris)})")


if __name__ == "__main__":
    main()
