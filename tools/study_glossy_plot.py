#!/usr/bin/env python3
"""Plots and tables of tools/study_glossy.sh (issue 9): vMF lobes against the SVD path.

usage: study_glossy_plot.py glossy.csv OUTDIR meta.txt

Writes OUTDIR/results.md (one table per scene and probe, and the finding computed from
the rows, never typed in), OUTDIR/error_time.png (per-vertex and image error against
precompute seconds) and OUTDIR/error_mb.png (the same against file MB). Debian's
python3-matplotlib; no other dependency.
"""
import csv
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def num(v):
    """A CSV field as a float, None when empty or not a number."""
    try:
        return float(v)
    except (TypeError, ValueError):
        return None


def label(r):
    """Short name of a row's configuration."""
    if r["path"] == "svd":
        return "SVD K=%s" % r["K"]
    if r["path"] == "vmf":
        return "vMF level %s" % r["view_level"]
    return {"svd-default": "SVD defaults (K=4, bounces)", "auto-default": "auto defaults (vMF, bounces)"}[r["path"]]


def table(rows):
    """Markdown table of one scene and probe."""
    out = ["| configuration | bounces | precompute s | vMF s | file MB | light ms | view ms | vertex rel_rmse | image rel_rmse | load |",
           "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    order = {"svd": 0, "vmf": 1, "svd-default": 2, "auto-default": 3}
    rows = sorted(rows, key=lambda r: (order[r["path"]], num(r["K"]) or 0, num(r["view_level"]) or 0))
    for r in rows:
        out.append("| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |" % (
            label(r), r["bounces"], r["precompute_s"], r["vmf_s"], r["file_mb"], r["light_ms"], r["view_ms"],
            r["vert_rel_rmse"], r["img_rel_rmse"], r["load1"]))
    r = rows[0]
    out.append("")
    out.append("Reference noise (relative): vertices %s, image %s (bounces 0); defaults rows against a "
               "reference of %s bounce(s)." % (r["ref_vert_noise"], r["ref_img_noise"],
                                              next((x["ref_bounces"] for x in rows if x["path"].endswith("default")), "0")))
    return out


def finding(rows):
    """One sentence per scene/probe from the numbers: best SVD against the vMF levels."""
    svd = [r for r in rows if r["path"] == "svd" and num(r["vert_rel_rmse"]) is not None]
    vmf = [r for r in rows if r["path"] == "vmf" and num(r["vert_rel_rmse"]) is not None]
    if not svd or not vmf:
        return ""
    bs = min(svd, key=lambda r: num(r["vert_rel_rmse"]))
    bi = min(svd, key=lambda r: num(r["img_rel_rmse"]))
    bv = min(vmf, key=lambda r: num(r["vert_rel_rmse"]))
    cheap = min(vmf, key=lambda r: num(r["precompute_s"]))
    return ("best SVD (K=%s) vertex error %s, image %s (best image: K=%s, %s) at %s s / %s MB; "
            "vMF level %s vertex error %s, image %s at %s s / %s MB (cheapest vMF: level %s, vertex %s, %s s / %s MB)."
            % (bs["K"], bs["vert_rel_rmse"], bs["img_rel_rmse"], bi["K"], bi["img_rel_rmse"], bs["precompute_s"], bs["file_mb"],
               bv["view_level"], bv["vert_rel_rmse"], bv["img_rel_rmse"], bv["precompute_s"], bv["file_mb"],
               cheap["view_level"], cheap["vert_rel_rmse"], cheap["precompute_s"], cheap["file_mb"]))


def plot(groups, xkey, xlabel, path):
    """Per-vertex and image error against one cost, a line per scene/probe and path."""
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8))
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for gi, (key, rows) in enumerate(groups):
        c = colors[gi % len(colors)]
        for ax, ykey in zip(axes, ("vert_rel_rmse", "img_rel_rmse")):
            for kind, marker, ls in (("svd", "o", "-"), ("vmf", "s", "--")):
                pts = [(num(r[xkey]), num(r[ykey]), r) for r in rows if r["path"] == kind]
                pts = [p for p in pts if p[0] is not None and p[1] is not None]
                if not pts:
                    continue
                pts.sort(key=lambda p: p[0])
                ax.plot([p[0] for p in pts], [p[1] for p in pts], ls, marker=marker, color=c,
                        label="%s %s" % ("/".join(key), "SVD K" if kind == "svd" else "vMF level"))
                for x, y, r in pts:
                    ax.annotate(r["K"] if kind == "svd" else "L" + r["view_level"], (x, y), fontsize=7,
                                textcoords="offset points", xytext=(3, 3))
            for r in rows:
                if r["path"].endswith("default") and num(r[xkey]) and num(r[ykey]):
                    ax.plot(num(r[xkey]), num(r[ykey]), "*" if r["path"] == "auto-default" else "x", color=c, ms=10)
    for ax, t in zip(axes, ("per-vertex rel_rmse", "image rel_rmse (400x300)")):
        ax.set_xlabel(xlabel)
        ax.set_ylabel(t)
        ax.set_yscale("log")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_title("bounces 0: numbers = SVD K, L = vMF view level; x/* = defaults (with bounces)", fontsize=8)
    axes[1].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    if len(sys.argv) != 4:
        sys.stderr.write("usage: study_glossy_plot.py glossy.csv OUTDIR meta.txt\n")
        return 2
    with open(sys.argv[1], newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        sys.stderr.write("study_glossy_plot.py: %s: no rows\n" % sys.argv[1])
        return 1
    groups = {}
    for r in rows:
        groups.setdefault((r["scene"], r["probe"]), []).append(r)
    groups = list(groups.items())
    out = ["# Glossy study: vMF lobes against the SVD path (issue 9)", "",
           "Written by `tools/study_glossy.sh` (`make study-glossy`); method in its header and in "
           "[../README.md](../README.md). Rows marked bounces 0 compare the representations alone "
           "(`--bounces 0`); the two defaults rows use the plan's interreflection passes. "
           "Timings are wall clock on a shared 2-core machine (load column: 1-minute load average "
           "when the precompute started); light/view ms are `prt bench --backend cpu --frames 20` medians.", "",
           "```"] + open(sys.argv[3]).read().rstrip().split("\n") + ["```", "", "## Finding (computed from the rows)", ""]
    for key, g in groups:
        fnd = finding(g)
        if fnd:
            out.append("- **%s, %s**: %s" % (key[0], key[1], fnd))
    out.append("")
    for key, g in groups:
        out += ["## %s under %s" % key, ""] + table(g) + [""]
    out += ["![error against precompute time](error_time.png)", "", "![error against file size](error_mb.png)", ""]
    with open(sys.argv[2] + "/results.md", "w") as f:
        f.write("\n".join(out))
    plot(groups, "precompute_s", "precompute seconds (timing summary total)", sys.argv[2] + "/error_time.png")
    plot(groups, "file_mb", "file MB", sys.argv[2] + "/error_mb.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
