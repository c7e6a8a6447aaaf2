#!/usr/bin/python3
"""study_plot.py - tables and plots of the accuracy study (tools/study.sh).

    /usr/bin/python3 tools/study_plot.py OUT_DIR WORK_DIR

Reads OUT_DIR/study.csv and OUT_DIR/meta.txt (written by tools/study.sh) and writes
into OUT_DIR:
  results.md          the headline figures, then every point as a Markdown table
  knobs_SCENE.png     error against the cost each knob drives, one panel per knob
  pareto.png          error against light-change time and against file size for every
                      direct-lighting point, with the Pareto front (nothing both cheaper
                      and more accurate)
  sh_vs_haar.png      SH against Haar at equal coefficient count, sharp and soft probe
  images.png          reference, PRT renders and error maps of a few points (from WORK_DIR)
Errors are prt compare's rel_rmse (compare.h) against the path-traced reference.
Needs Debian's python3-matplotlib (numpy); tools/study.sh installs it.
"""
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter  # noqa: E402

UNC = 24576
# knob -> (label, x column, x label, log x?, the knob's value for a row)
KNOBS = {
    "N": ("coefficients N (8-bit; last: uncompressed float)", "light_best_ms", "light change (ms, best frame)", True,
          lambda r: "unc." if int(r["N"]) == UNC else r["N"]),
    "quant": ("quantization (N = 128)", "file_mb", "file size (MB)", True,
              lambda r: {"8": "8-bit", "16": "16-bit", "32": "float"}[r["quant"]]),
    "vis": ("visibility supersampling", "visibility_s", "visibility ray casting (s)", True,
            lambda r: f"{int(r['vis_res']) // 64}x"),
    "K": ("BRDF terms K (glossy)", "view_best_ms", "view change (ms, best frame)", True, lambda r: f"K={r['K']}"),
    "bounces": ("interreflection bounces", "precompute_s", "precompute (s)", True, lambda r: f"{r['bounces']}b"),
    "gather": ("gathering cube resolution (1 bounce)", "bounce_s", "bounce pass (s)", True,
               lambda r: f"{r['gather_res']}^2"),
    "measure": ("Haar measure (N = 128, same bytes)", "file_mb", "file size (MB)", False,
                lambda r: "texel (paper)" if r.get("texel_measure") == "1" else "per sr"),
    "prior": ("light prior (N = 128, same bytes)", "precompute_s", "precompute (s)", False,
              lambda r: f"{r['light_prior']}'s" if r.get("light_prior") else "none"),
    "refine": ("refinement threshold (floor)", "precompute_s", "precompute (s)", True,
               lambda r: "off" if r.get("refine", "0") in ("0", "") else f"{int(r['refine']) / 10:g}% ({r['verts']} v)"),
}


def logaxes(ax, x=True, y=True):
    """Log axes labelled 1, 2, 5 x 10^k in plain numbers (narrow ranges keep readable ticks)."""
    fmt = FuncFormatter(lambda v, _: f"{v:g}")
    for on, axis, setter in ((x, ax.xaxis, ax.set_xscale), (y, ax.yaxis, ax.set_yscale)):
        if not on:
            continue
        setter("log")
        axis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
        axis.set_major_formatter(fmt)
        axis.set_minor_formatter(NullFormatter())


def fnum(x):
    try:
        return float(x)
    except (TypeError, ValueError):
        return float("nan")


def read(out):
    with open(os.path.join(out, "study.csv")) as f:
        rows = list(csv.DictReader(f))
    meta = {}
    with open(os.path.join(out, "meta.txt")) as f:
        for line in f:
            k, _, v = line.rstrip("\n").partition("=")
            meta[k] = v
    for r in rows:
        r["sweeps"] = r["sweeps"].split(";")
        for k in ("precompute_s", "precompute_cpu_s", "visibility_s", "transport_s", "bounce_s", "file_mb", "light_ms", "view_ms", "light_min_ms", "view_min_ms",
                  "vert_rel_rmse", "vert_max_rel_err", "img_rel_rmse", "img_max_rel_err", "ref_vert_noise",
                  "ref_img_noise", "shadow_rel_rmse", "ref_shadow_noise"):
            r[k] = fnum(r.get(k))
        # Best frame of prt bench where recorded (steadier on a shared machine), else the median.
        for what in ("light", "view"):
            best = r[what + "_min_ms"]
            r[what + "_best_ms"] = best if best == best else r[what + "_ms"]
        # The reference's own noise adds in quadrature to a measured rel_rmse (independent
        # errors): E[rel_rmse^2] = err^2 + noise^2, so this is the noise-corrected estimate.
        for e, n in (("vert_rel_rmse", "ref_vert_noise"), ("img_rel_rmse", "ref_img_noise")):
            d = r[e] ** 2 - r[n] ** 2
            r[e + "_corr"] = d ** 0.5 if d > 0 else 0.0
    return rows, meta


def is_default(r):
    return (r["basis"] == "haar" and r["N"] == "128" and r["quant"] == "8" and r["vis_res"] == "128"
            and r["bounces"] == "0" and r["K"] in ("1", "4") and r.get("refine", "0") in ("0", "")
            and r.get("texel_measure", "0") in ("0", "") and not r.get("light_prior"))


def pct(x, d=2):
    return "n/a" if x != x else f"{100 * x:.{d}f}"


def title_suffix(meta):
    return " [QUICK MODE: tiny scenes, not the study]" if meta.get("mode") == "quick" else ""


def plot_knobs(rows, meta, scene, out):
    sharp = meta["sharp"]
    knobs = [k for k in KNOBS if any(k in r["sweeps"] and r["scene"] == scene for r in rows)]
    if not knobs:
        return None
    ncol = 3
    nrow = (len(knobs) + ncol - 1) // ncol
    fig, axes = plt.subplots(nrow, ncol, figsize=(5.2 * ncol, 4.0 * nrow), squeeze=False)
    for ax, knob in zip(axes.flat, knobs):
        label, xcol, xlabel, logx, val = KNOBS[knob]
        pts = [r for r in rows if r["scene"] == scene and r["probe"] == sharp and knob in r["sweeps"]]
        pts.sort(key=lambda r: (r[xcol], r["N"]))
        xs = [r[xcol] for r in pts]
        ax.plot(xs, [r["vert_rel_rmse"] for r in pts], "o-", label="per vertex")
        ax.plot(xs, [r["img_rel_rmse"] for r in pts], "s--", label="image")
        if any(r["shadow_rel_rmse"] == r["shadow_rel_rmse"] for r in pts):
            ax.plot(xs, [r["shadow_rel_rmse"] for r in pts], "^:", label="floor shadow vertices")
        for r in pts:
            ax.annotate(val(r), (r[xcol], r["vert_rel_rmse"]), textcoords="offset points", xytext=(4, 4), fontsize=8)
        noise = [r["ref_vert_noise"] for r in pts if r["ref_vert_noise"] == r["ref_vert_noise"]]
        if noise:
            ax.axhline(max(noise), color="gray", lw=0.8, ls=":", label="reference noise (vertex)")
        logaxes(ax, x=logx and all(x > 0 for x in xs))
        ax.set_xlabel(xlabel)
        ax.set_ylabel("relative RMS error")
        ax.set_title(label, fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    for ax in list(axes.flat)[len(knobs):]:
        ax.axis("off")
    fig.suptitle(f"{scene} under {sharp}: error against cost, one knob at a time{title_suffix(meta)}")
    fig.tight_layout()
    name = f"knobs_{scene}.png"
    fig.savefig(os.path.join(out, name), dpi=90)
    plt.close(fig)
    return name


def pareto_front(pts, xcol):
    """Points not dominated (lower cost and lower error) sorted by cost."""
    front, best = [], float("inf")
    for r in sorted(pts, key=lambda r: (r[xcol], r["vert_rel_rmse"])):
        if r["vert_rel_rmse"] < best:
            front.append(r)
            best = r["vert_rel_rmse"]
    return front


def short(r):
    if r["basis"] == "sh":
        return f"SH{r['coeffs']}"
    s = "unc" if int(r["N"]) == UNC else f"N{r['N']}"
    if r["quant"] != "8" and int(r["N"]) != UNC:
        s += f" q{r['quant']}"
    if r["vis_res"] != "128":
        s += f" v{int(r['vis_res']) // 64}x"
    if r["K"] not in ("1", "4"):
        s += f" K{r['K']}"
    if r.get("refine", "0") not in ("0", ""):
        s += f" r{int(r['refine']) / 10:g}%"
    if r.get("texel_measure") == "1":
        s += " texel"
    if r.get("light_prior"):
        s += " prior"
    return s


def plot_pareto(rows, meta, out):
    sharp = meta["sharp"]
    scenes = [meta["diffuse_scene"], meta["glossy_scene"]]
    fig, axes = plt.subplots(len(scenes), 2, figsize=(12, 4.6 * len(scenes)), squeeze=False)
    colours = {"haar": "C0", "sh": "C3"}
    for row, scene in zip(axes, scenes):
        pts = [r for r in rows if r["scene"] == scene and r["probe"] == sharp and r["bounces"] == "0"]
        for ax, (xcol, xlabel) in zip(row, (("light_best_ms", "light change (ms, best frame)"),
                                            ("file_mb", "file size (MB)"))):
            for basis in ("haar", "sh"):
                b = [r for r in pts if r["basis"] == basis]
                ax.scatter([r[xcol] for r in b], [r["vert_rel_rmse"] for r in b], c=colours[basis], s=18,
                           label="Haar wavelets" if basis == "haar" else "spherical harmonics")
            front = pareto_front(pts, xcol)
            ax.plot([r[xcol] for r in front], [r["vert_rel_rmse"] for r in front], "k-", lw=1, drawstyle="steps-post",
                    label="Pareto front")
            for r in front:
                ax.annotate(short(r), (r[xcol], r["vert_rel_rmse"]), textcoords="offset points", xytext=(3, 3),
                            fontsize=7)
            logaxes(ax)
            ax.set_xlabel(xlabel)
            ax.set_ylabel("relative RMS error (per vertex)")
            ax.set_title(f"{scene} under {sharp}, direct lighting", fontsize=10)
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=7)
    fig.suptitle(f"Pareto fronts: every direct-lighting point{title_suffix(meta)}")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "pareto.png"), dpi=90)
    plt.close(fig)


def sh_haar_pairs(rows, scene, probe):
    """[(coeffs, sh row, haar row)] at equal coefficient count."""
    sh = {int(r["coeffs"]): r for r in rows if r["scene"] == scene and r["probe"] == probe and "sh" in r["sweeps"]}
    haar = {int(r["coeffs"]): r for r in rows
            if r["scene"] == scene and r["probe"] == probe and "haar" in r["sweeps"] and r["basis"] == "haar"}
    return [(c, sh[c], haar[c]) for c in sorted(sh) if c in haar]


def plot_sh_haar(rows, meta, out):
    scenes = [s for s in (meta["diffuse_scene"], meta["glossy_scene"])
              if any(r["scene"] == s and "sh" in r["sweeps"] for r in rows)]
    fig, axes = plt.subplots(1, 2 * len(scenes), figsize=(6 * len(scenes) * 2 / 1.3, 4.4), squeeze=False)
    axes = list(axes.flat)
    i = 0
    for scene in scenes:
        for probe in (meta["sharp"], meta["soft"]):
            ax = axes[i]
            i += 1
            pairs = sh_haar_pairs(rows, scene, probe)
            if not pairs:
                ax.axis("off")
                continue
            cs = [c for c, _, _ in pairs]
            # Haar beyond SH's largest order (the N sweep's 128..512, 8-bit): where wavelets go on.
            more = sorted((r for r in rows if r["scene"] == scene and r["probe"] == probe and "N" in r["sweeps"]
                           and cs[-1] < int(r["N"]) < UNC), key=lambda r: int(r["N"]))
            for col, ls, what in (("vert_rel_rmse", "-", "all vertices"), ("shadow_rel_rmse", "--", "floor shadow"),
                                  ("img_rel_rmse", ":", "image")):
                if not any(h[col] == h[col] for _, _, h in pairs):
                    continue
                ax.plot(cs, [s[col] for _, s, _ in pairs], "o" + ls, color="C3", label=f"SH ({what})")
                ax.plot(cs + [int(r["N"]) for r in more], [h[col] for _, _, h in pairs] + [r[col] for r in more],
                        "s" + ls, color="C0", label=f"Haar ({what})")
                cs_all = cs + [int(r["N"]) for r in more]
            logaxes(ax)
            ax.set_xticks(cs_all)
            ax.set_xticklabels([str(c) for c in cs_all], fontsize=7)
            ax.set_xlabel("coefficients per transport vector (8-bit)")
            ax.set_ylabel("relative RMS error")
            ax.set_title(f"{scene} under {probe}", fontsize=10)
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=6)
    fig.suptitle(f"Spherical harmonics against Haar wavelets at equal storage{title_suffix(meta)}")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "sh_vs_haar.png"), dpi=90)
    plt.close(fig)


def plot_images(rows, meta, out, work):
    """Reference | PRT | error map for the default point and the largest SH / Haar pair."""
    scene, probe = meta["diffuse_scene"], meta["sharp"]
    pick = [r for r in rows if r["scene"] == scene and r["probe"] == probe and is_default(r)][:1]
    pairs = sh_haar_pairs(rows, scene, probe)
    if pairs:
        pick += [pairs[-1][1], pairs[-1][2]]
    ref = os.path.join(work, "ref", f"{scene}-{probe}-b0.png")
    if not pick or not os.path.exists(ref):
        return False
    fig, axes = plt.subplots(len(pick), 3, figsize=(12, 3.2 * len(pick)), squeeze=False)
    for row, r in zip(axes, pick):
        base = os.path.join(work, "out", f"{r['id']}-{probe}")
        for ax, path, title in ((row[0], ref, "path-traced reference"),
                                (row[1], base + ".png", f"PRT {short(r)}: {pct(r['img_rel_rmse'], 1)}% image error"),
                                (row[2], base + ".err.png", "relative error (black <= 0.1%, red >= 100%)")):
            if os.path.exists(path):
                ax.imshow(plt.imread(path))
            ax.set_title(title, fontsize=9)
            ax.axis("off")
    fig.suptitle(f"{scene} under {probe}{title_suffix(meta)}")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "images.png"), dpi=80)
    plt.close(fig)
    return True


def read_vertex_csv(path):
    """{vertex id: (r, g, b)} of a per-vertex CSV (prt render / prt reference --vertices)."""
    with open(path) as f:
        return {int(r["vertex"]): (float(r["r"]), float(r["g"]), float(r["b"])) for r in csv.DictReader(f)}


def bounce_gaps(rows, meta, work):
    """What leaving interreflections out costs: the direct-only PRT point of the diffuse scene
    against the references with 1, 2, 3 bounces (rel_rmse over the vertices both compare)."""
    scene, probe = meta["diffuse_scene"], meta["sharp"]
    d = [r for r in rows if r["scene"] == scene and r["probe"] == probe and is_default(r)]
    if not d:
        return []
    prt = os.path.join(work, "out", f"{d[0]['id']}-{probe}.csv")
    out = []
    for b in sorted({r["bounces"] for r in rows if r["scene"] == scene and r["bounces"] != "0"}):
        ref = os.path.join(work, "ref", f"{scene}-{probe}-b{b}.front.csv")
        if not (os.path.exists(prt) and os.path.exists(ref)):
            continue
        a, r = read_vertex_csv(prt), read_vertex_csv(ref)
        num = sum((a[v][c] - r[v][c]) ** 2 for v in r if v in a for c in range(3))
        den = sum(r[v][c] ** 2 for v in r if v in a for c in range(3))
        with_b = [x for x in rows if x["scene"] == scene and x["probe"] == probe and "bounces" in x["sweeps"]
                  and x["bounces"] == b]
        out.append((b, (num / den) ** 0.5 if den > 0 else float("nan"), with_b[0] if with_b else None))
    return out


def headline(rows, meta, work):
    lines = []
    for b, gap, r in bounce_gaps(rows, meta, work):
        lines.append(f"- **{meta['diffuse_scene']}, {meta['sharp']}, interreflections**: the direct-only file is "
                     f"{pct(gap)}% off the {b}-bounce reference"
                     + (f"; with {b} bounce pass(es) (gather 32^2) the error is {pct(r['vert_rel_rmse'])}% for "
                        f"{r['precompute_s']:.1f} s of precompute ({r['bounce_s']:.1f} s in the passes)" if r else ""))
    sharp, soft = meta["sharp"], meta["soft"]
    for scene in (meta["diffuse_scene"], meta["glossy_scene"]):
        for probe in (sharp, soft):
            d = [r for r in rows if r["scene"] == scene and r["probe"] == probe and is_default(r)]
            if not d:
                continue
            r = d[0]
            lines.append(
                f"- **{scene}, {probe}, defaults** (N = 128, K = {r['K']}, 8-bit, visibility 2x, direct): "
                f"per-vertex error {pct(r['vert_rel_rmse'])}% ({pct(r['vert_rel_rmse_corr'])}% less the reference's noise; "
                f"max {pct(r['vert_max_rel_err'], 1)}%), image error {pct(r['img_rel_rmse'])}%; "
                f"precompute {r['precompute_s']:.1f} s ({r['precompute_cpu_s']:.1f} s CPU), "
                f"{r['file_mb']:.3g} MB, light change {r['light_ms']:.2f} ms, view change {r['view_ms']:.2f} ms "
                f"(reference noise {pct(r['ref_vert_noise'], 3)}% per vertex, {pct(r['ref_img_noise'], 2)}% image)")
        u = [r for r in rows if r["scene"] == scene and r["probe"] == sharp and r["N"] == str(UNC)]
        if u:
            r = u[0]
            lines.append(f"- **{scene}, {sharp}, uncompressed** (all 24,576 coefficients, float): per-vertex error "
                         f"{pct(r['vert_rel_rmse'])}% ({pct(r['vert_rel_rmse_corr'])}% less noise), image {pct(r['img_rel_rmse'])}%; "
                         f"{r['file_mb']:.3g} MB, "
                         f"light change {r['light_ms']:.1f} ms")
        for probe in (sharp, soft):
            pairs = sh_haar_pairs(rows, scene, probe)
            if pairs:
                txt = ", ".join(f"{c}: SH {pct(s['vert_rel_rmse'], 1)}% / Haar {pct(h['vert_rel_rmse'], 1)}%"
                                for c, s, h in pairs)
                lines.append(f"- **{scene}, {probe}, SH vs Haar** (per-vertex error at equal coefficient count) {txt}")
                if any(h["shadow_rel_rmse"] == h["shadow_rel_rmse"] for _, _, h in pairs):
                    txt = ", ".join(f"{c}: SH {pct(s['shadow_rel_rmse'], 1)}% / Haar {pct(h['shadow_rel_rmse'], 1)}%"
                                    for c, s, h in pairs)
                    more = sorted((r for r in rows if r["scene"] == scene and r["probe"] == probe
                                   and "N" in r["sweeps"] and pairs[-1][0] < int(r["N"])), key=lambda r: int(r["N"]))
                    txt2 = ", ".join(f"{'all (float)' if int(r['N']) == UNC else r['N']}: "
                                     f"{pct(r['shadow_rel_rmse'], 1)}%" for r in more)
                    lines.append(f"- **{scene}, {probe}, floor shadow region** (same, vertices in the shadow only) "
                                 f"{txt}; Haar beyond: {txt2}")
    return lines


def table(rows):
    cols = ["scene", "probe", "sweeps", "basis", "coeffs", "K", "quant", "vis", "bounces", "gather", "refine", "vertices",
            "precompute s",
            "CPU s", "MB", "light ms (best)", "view ms (best)", "vertex err %", "(corr.)", "vertex max %", "shadow err %",
            "image err %", "(corr.)", "image max %", "ref noise v/i %"]
    out = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for r in rows:
        coeffs = "all" if r["N"] == str(UNC) else r["coeffs"]
        if r.get("texel_measure") == "1":
            coeffs += " (texel)"
        if r.get("light_prior"):
            coeffs += f" ({r['light_prior']} prior)"
        q = {"8": "8-bit", "16": "16-bit", "32": "float"}[r["quant"]]
        out.append("| " + " | ".join([
            r["scene"], r["probe"], " ".join(r["sweeps"]), r["basis"], coeffs, r["K"], q,
            f"{int(r['vis_res']) // 64}x", r["bounces"], r["gather_res"],
            "-" if r.get("refine", "0") in ("0", "") else f"{int(r['refine']) / 10:g}%", r.get("verts", ""),
            f"{r['precompute_s']:.1f}",
            f"{r['precompute_cpu_s']:.1f}", f"{r['file_mb']:.3g}", f"{r['light_ms']:.3g} ({r['light_best_ms']:.3g})",
            f"{r['view_ms']:.3g} ({r['view_best_ms']:.3g})",
            pct(r["vert_rel_rmse"]), pct(r["vert_rel_rmse_corr"]), pct(r["vert_max_rel_err"], 1),
            pct(r["shadow_rel_rmse"]), pct(r["img_rel_rmse"]), pct(r["img_rel_rmse_corr"]), pct(r["img_max_rel_err"], 1),
            f"{pct(r['ref_vert_noise'], 3)} / {pct(r['ref_img_noise'], 2)}"]) + " |")
    return out


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: study_plot.py OUT_DIR WORK_DIR")
    out, work = sys.argv[1], sys.argv[2]
    rows, meta = read(out)
    if not rows:
        sys.exit("study_plot: no rows in study.csv")
    figs = [plot_knobs(rows, meta, s, out) for s in (meta["diffuse_scene"], meta["glossy_scene"])]
    plot_pareto(rows, meta, out)
    plot_sh_haar(rows, meta, out)
    have_images = plot_images(rows, meta, out, work)
    quick = meta.get("mode") == "quick"
    md = ["# Accuracy against cost: results" + (" (QUICK MODE: tiny scenes and sweeps, not the study)" if quick else ""),
          "",
          f"Generated by `{'STUDY_QUICK=1 ' if quick else ''}make study` (tools/study.sh) on {meta['date']}, "
          f"commit {meta['commit']}, in {int(meta['runtime_s']) // 60} min {int(meta['runtime_s']) % 60} s"
          f"{' (a STUDY_RESUME=1 pass: precomputed files, their timing logs and the references were reused)' if meta.get('resumed') == '1' else ''} on "
          f"{meta['machine']} (load average at start {meta.get('load_start', '?')}, at end "
          f"{meta.get('load_end', '?')}). Method and reading guide: [README.md]({'../' if quick else ''}README.md).", "",
          f"- scene `{meta['diffuse_scene']}`: {meta['scene_' + meta['diffuse_scene']]}",
          f"- scene `{meta['glossy_scene']}`: {meta['scene_' + meta['glossy_scene']]}",
          f"- probes: `{meta['sharp']}` (sun: sharp shadows), `{meta['soft']}` (soft); images {meta['size']} without "
          f"background; reference {meta['ref_vspp']} samples per vertex, {meta['ref_spp']} per pixel", "",
          "## Headline", ""] + headline(rows, meta, work) + ["", "## Plots", ""]
    for f in figs:
        if f:
            md.append(f"![{f}]({f})")
    md += ["![pareto](pareto.png)", "![SH vs Haar](sh_vs_haar.png)"]
    if have_images:
        md.append("![images](images.png)")
    md += ["", "## Every point", "",
           "Errors are prt compare's rel_rmse / max_rel_err against the reference with the same number of bounces "
           "(so bounce points are not comparable across bounce counts); `sweeps` names the one-knob sweeps the "
           "point belongs to; shadow err is rel_rmse over the floor vertices in the model's shadow (reference "
           "radiance below 60% of the floor's median); (corr.) is the error less the reference's own noise in quadrature. Costs: precompute "
           "wall time (s) and CPU time (user + system, s; steadier on a shared machine), file size (MB), CPU light- "
           "and view-change times of prt bench (wall clock, both cores): median, and in brackets the best frame, "
           "which the plots use because other processes on a shared machine disturb the median.", ""] + table(rows) + [""]
    with open(os.path.join(out, "results.md"), "w") as f:
        f.write("\n".join(md))
    print(f"study_plot: wrote {out}/results.md and plots")


if __name__ == "__main__":
    main()
