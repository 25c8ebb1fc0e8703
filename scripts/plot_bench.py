#!/usr/bin/python3
"""Plots and tables for `cdsm bench` results (results.csv).

  plot_bench.py RESULTS.csv OUT_DIR
      one PNG per scene, OUT_DIR/<scene_name>.png: time (DSM build + camera
      pass, median, min-max bars) and memory against the transmittance RMSE,
      the Pareto front of each marked, the reference renderer's time as a
      line; and time against the map error p99 (|T - T_filtered_exact|: the
      part of the error epsilon controls, without resolution error).

  plot_bench.py --equal-memory RESULTS.csv [--scene NAME] [--eps E]
      prints the Markdown table "equal memory": per resolution of the DSM at
      epsilon E (default 0.01), its memory M, and per other method family the
      configuration of the sweep whose memory is nearest M (any N, any
      resolution), with its memory against M and its errors.

  plot_bench.py --epsilon-table RESULTS.csv [--scene NAME] [--res R] [--clusters M]
      prints the Markdown table of nodes per texel against epsilon beside the
      paper's Table 4 (Bornik et al. 2012; thesis Table 5.10).

Needs matplotlib (Debian: python3-matplotlib) for plots only.
"""
import argparse
import csv
import math
import os
import sys

# Paper Table 4 / thesis Table 5.10: "virtual X-ray" scene, 4 x 256^2 DSMs.
PAPER_TABLE4 = {0.01: (4.01, 28), 0.05: (3.32, 21), 0.1: (3.12, 21), 0.2: (3.00, 21)}

FAMILY_STYLE = {  # method family -> (colour, label)
    "dsm": ("tab:blue", "deep shadow map (ε)"),
    "sm": ("tab:red", "shadow map"),
    "osm": ("tab:orange", "opacity shadow map (N slices)"),
    "avsm": ("tab:green", "AVSM-style (N nodes)"),
    "dom": ("tab:purple", "deep opacity map (N layers)"),
    "fom": ("tab:brown", "Fourier opacity map (N coefficients)"),
    "mom": ("tab:pink", "moments (N power moments)"),
    "pssm": ("tab:cyan", "parallel-split DSMs"),
}
FAMILIES = ("dsm", "sm", "osm", "avsm", "dom", "fom", "mom", "pssm")
RES_MARKERS = ["o", "s", "^", "D", "v", "P", "X"]


def family(method):
    for f in ("avsm", "osm", "pssm", "dsm", "sm", "dom", "fom", "mom"):
        if method.startswith(f):
            return f
    return method


def fnum(s, default=float("nan")):
    try:
        return float(s)
    except (TypeError, ValueError):
        return default


def read_rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def short_label(r):
    m = r["method"]
    if m == "dsm":
        return "ε=%g" % fnum(r["epsilon"])
    return m


def front_line(points):
    """Staircase through Pareto points (x ascending, y descending)."""
    pts = sorted(points)
    xs, ys = [], []
    for i, (x, y) in enumerate(pts):
        if i:
            xs.append(x)
            ys.append(pts[i - 1][1])
        xs.append(x)
        ys.append(y)
    return xs, ys


def plot_scene(plt, name, rows, out_dir):
    refs = [r for r in rows if r["method"] == "reference"]
    rows = [r for r in rows if r["method"] != "reference"]
    if not rows:
        return None
    resolutions = sorted({int(r["resolution"]) for r in rows})
    marker_of = {res: RES_MARKERS[i % len(RES_MARKERS)] for i, res in enumerate(resolutions)}
    clusters = sorted({int(r["clusters"]) for r in rows})
    floor = 1e-6
    fig, axes = plt.subplots(1, 3, figsize=(20, 6))
    time_label = "DSM build + camera pass [ms] (median; bars: min–max)"
    rmse_label = "transmittance RMSE against the reference"
    panels = [
        (axes[0], "time_ms", time_label, "pareto_time", "t_rmse", rmse_label),
        (axes[1], "memory_bytes", "shadow-map memory: index + nodes + slack + tags + pyramids [KiB]", "pareto_memory", "t_rmse",
         rmse_label),
        (axes[2], "time_ms", time_label, None, "map_err_p99",
         "map error p99: |T - T_filtered_exact| (what ε controls)"),
    ]
    from matplotlib.lines import Line2D
    for ax, xkey, xlabel, pkey, ykey, ylabel in panels:
        seen = set()
        for r in rows:
            fam = family(r["method"])
            colour, flabel = FAMILY_STYLE.get(fam, ("tab:gray", fam))
            x = fnum(r[xkey])
            if xkey == "memory_bytes":
                x /= 1024.0
            y = max(fnum(r.get(ykey)), floor)
            seen.add(fam)
            on_front = pkey is not None and r[pkey] == "1"
            xerr = None
            if xkey == "time_ms":
                lo = fnum(r["build_ms_min"]) + fnum(r["camera_ms_min"])
                hi = fnum(r["build_ms_max"]) + fnum(r["camera_ms_max"])
                xerr = [[max(0.0, x - lo)], [max(0.0, hi - x)]]
            ax.errorbar([x], [y], xerr=xerr, fmt=marker_of[int(r["resolution"])], color=colour, ms=7 if on_front else 5,
                        mec="black" if on_front else colour, mew=1.4 if on_front else 0.5, elinewidth=0.7,
                        capsize=2, alpha=0.95)
            text = short_label(r) + ("" if len(resolutions) == 1 else " r%d" % int(r["resolution"]))
            if len(clusters) > 1:
                text += " m%s" % r["clusters"]
            ax.annotate(text, (x, y), textcoords="offset points", xytext=(4, 3), fontsize=6, color=colour)
        handles = [Line2D([], [], ls="", marker="o", color=FAMILY_STYLE.get(f, ("tab:gray", f))[0],
                          label=FAMILY_STYLE.get(f, ("tab:gray", f))[1]) for f in FAMILIES if f in seen]
        pts = []
        for r in rows:
            if pkey is not None and r[pkey] == "1":
                x = fnum(r[xkey]) / (1024.0 if xkey == "memory_bytes" else 1.0)
                pts.append((x, max(fnum(r[ykey]), floor)))
        if pts:
            xs, ys = front_line(pts)
            handles += ax.plot(xs, ys, "-", color="black", lw=1.0, alpha=0.6, label="Pareto front (outlined)", zorder=0)
        if xkey == "time_ms" and refs:
            rt = fnum(refs[0]["reference_ms"])
            if rt > 0 and not math.isnan(rt):
                ax.axvline(rt, color="gray", ls="--", lw=1)
                ax.annotate("reference renderer (exact): %.0f ms" % rt, (rt, 0.02), xycoords=("data", "axes fraction"),
                            rotation=90, fontsize=7, color="gray", ha="right", va="bottom")
        for res in resolutions:
            handles.append(Line2D([], [], ls="", marker=marker_of[res], color="gray", label="%d² texels" % res))
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.grid(True, which="both", alpha=0.25)
        ax.legend(handles=handles, fontsize=7, loc="best")
    fig.suptitle("%s — speed and memory against error (lower left is better; outlined: on the Pareto front)" % name)
    fig.tight_layout()
    path = os.path.join(out_dir, name + ".png")
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plots(csv_path, out_dir):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = read_rows(csv_path)
    by_scene = {}
    for r in rows:
        by_scene.setdefault(r["scene_name"], []).append(r)
    for name, rs in by_scene.items():
        path = plot_scene(plt, name, rs, out_dir)
        if path:
            print("wrote", path)


def epsilon_table(csv_path, scene, res, clusters):
    rows = [r for r in read_rows(csv_path) if r["method"] == "dsm"]
    if scene:
        rows = [r for r in rows if r["scene_name"] == scene]
    if res:
        rows = [r for r in rows if int(r["resolution"]) == res]
    if clusters:
        rows = [r for r in rows if int(r["clusters"]) == clusters]
    if not rows:
        sys.exit("plot_bench.py: no dsm rows match (scene %r, res %r, clusters %r)" % (scene, res, clusters))
    rows.sort(key=lambda r: fnum(r["epsilon"]))
    print("| ε | avg nodes/texel (this run) | max nodes/texel (this run) | avg layers (paper) | max layers (paper) "
          "| maps × texels | T RMSE |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        e = fnum(r["epsilon"])
        paper = PAPER_TABLE4.get(round(e, 6))
        print("| %g | %.2f | %s | %s | %s | %s × %d² | %.4f |" % (
            e, fnum(r["avg_nodes_per_texel"]), r["max_nodes_per_texel"],
            "%.2f" % paper[0] if paper else "–", str(paper[1]) if paper else "–", r["maps"],
            int(round(math.sqrt(fnum(r["texels"]) / max(1.0, fnum(r["maps"]))))), fnum(r["t_rmse"])))


def equal_memory(csv_path, scene, eps):
    rows = [r for r in read_rows(csv_path) if r["method"] != "reference"]
    if scene:
        rows = [r for r in rows if r["scene_name"] == scene]
    dsm = sorted([r for r in rows if r["method"] == "dsm" and abs(fnum(r["epsilon"]) - eps) < 1e-9],
                 key=lambda r: int(r["resolution"]))
    if not dsm:
        sys.exit("plot_bench.py: no dsm rows at epsilon %g (scene %r)" % (eps, scene))
    others = [r for r in rows if family(r["method"]) not in ("dsm", "pssm")]
    print("| DSM ε=%g | its memory | method | nearest in memory | memory / DSM's | T RMSE | T p99 | PSNR | time ms |"
          % eps)
    print("|---|---|---|---|---|---|---|---|---|")
    for d in dsm:
        M = fnum(d["memory_bytes"])
        print("| res %s | %.0f KiB | **dsm** | ε=%g res=%s | 1.00 | **%.4f** | %.4f | %.1f | %.1f |" % (
            d["resolution"], M / 1024.0, eps, d["resolution"], fnum(d["t_rmse"]), fnum(d["t_p99"]),
            fnum(d["image_psnr_db"]), fnum(d["time_ms"])))
        for fam in FAMILIES:
            cands = [r for r in others if family(r["method"]) == fam and fnum(r["memory_bytes"]) > 0]
            if not cands:
                continue
            best = min(cands, key=lambda r: (abs(math.log(fnum(r["memory_bytes"]) / M)), fnum(r["t_rmse"])))
            print("| | | %s | %s | %.2f | %.4f | %.4f | %.1f | %.1f |" % (
                fam, best["label"], fnum(best["memory_bytes"]) / M, fnum(best["t_rmse"]), fnum(best["t_p99"]),
                fnum(best["image_psnr_db"]), fnum(best["time_ms"])))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("csv")
    ap.add_argument("out_dir", nargs="?")
    ap.add_argument("--epsilon-table", action="store_true")
    ap.add_argument("--equal-memory", action="store_true")
    ap.add_argument("--eps", type=float, default=0.01)
    ap.add_argument("--scene")
    ap.add_argument("--res", type=int)
    ap.add_argument("--clusters", type=int)
    a = ap.parse_args()
    if a.epsilon_table:
        epsilon_table(a.csv, a.scene, a.res, a.clusters)
    elif a.equal_memory:
        equal_memory(a.csv, a.scene, a.eps)
    else:
        if not a.out_dir:
            ap.error("OUT_DIR is required for plots")
        plots(a.csv, a.out_dir)


if __name__ == "__main__":
    main()
