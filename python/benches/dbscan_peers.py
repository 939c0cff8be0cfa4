"""Time octoquant.dbscan1d against R's dbscan and scikit-learn's DBSCAN on 1D data.

    python python/benches/dbscan_peers.py [--sizes 1e3,3e3,...] [--eps-n 1e6] [--out DIR]

(after ``pip install ./python`` plus numpy, scikit-learn and matplotlib, and Debian's
``r-cran-dbscan`` for ``Rscript``; see BENCHMARKS.md). A benchmark, not a test: it prints a
table, writes ``results.json`` and two PNG plots (time against N, time against eps: the line
paper's figures 7 and 8) into ``--out``.

Data (seeded): N values uniform in [0, N), so one value per unit length on average, handed
to every implementation in the same shuffled (generator) order. For the sweep over N,
eps = (ln N - 1) / 2, so a neighbourhood holds 2 eps + 1 = ln N values on average (the paper's
"small neighbourhoods, |N_eps| <= log N"), and min_points = round(ln N), so about half the
values are core points and there are many clusters, borders and noise values. The sweep over
eps keeps one N and its min_points and varies eps in log steps.

Timing: octoquant.dbscan1d gets the unsorted array; the binding sorts it (a stable indirect
sort of the indexes) before the linear pass and maps the labels back to input order, all inside
the timed call, so the time includes the sort as in the paper. scikit-learn's
``DBSCAN(eps, min_samples).fit`` gets the same values as an (N, 1) array (its default
algorithm, one job, OMP_NUM_THREADS=1 unless set). R's ``dbscan::dbscan`` (default kd-tree
search) runs in one ``Rscript`` per case, reading the values from a binary file; only the call
is timed, inside R. All three are single-threaded. For scale, the table also gives DBSCAN1D on the values
already sorted (the binding then skips its sort) and NumPy's ``np.sort`` of the values, both
untimed by the paper. The runs of a case follow each other back
to back (one garbage collection before the first, in Python and in R); each figure is the
median of ``--repeat`` runs (octoquant: more, up to 100, for calls under 0.1 s; peers: 20 for
cases predicted under 0.05 s, 3 or 1 for slow ones, see ``peer_repeats``). A peer is skipped
where the previous measurement predicts more than ``--max-seconds`` per run (time scaled by
N ln N in the sweep over N, by the neighbourhood size 2 eps + 1 in the sweep over eps), or
where scikit-learn's neighbourhood lists would exceed ``--max-sklearn-gb``.

Label check (every case a peer runs): a NumPy oracle gives the core points (neighbourhood
counts from ``searchsorted`` on the sorted values). Then, for each peer against octoquant:
the core points are the same, and the clusters on the core points are the same up to renaming
(a bijection between label sets); noise is identical; a border point (non-core within eps of a
core point) gets the same cluster, or, when two clusters reach it, possibly the other one: those
tie-rule differences are counted apart, and anything else is a mismatch. octoquant's
"first" policy gives a shared border to the cluster found first when visiting values in
ascending order; R and scikit-learn give it to the cluster found first when visiting in input
order, the same rule on sorted input. So at small N the peers also run on the sorted values
(expected: identical labels to ``border="first"``), and R with ``borderPoints = FALSE`` must
give exactly octoquant's ``border="noise"`` (DBSCAN*).
"""

import argparse
import gc
import json
import math
import os
import platform
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from importlib import metadata
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")  # before numpy / scikit-learn load their pools

import numpy as np  # noqa: E402

import octoquant  # noqa: E402

R_SCRIPT = r"""
args <- commandArgs(trailingOnly = TRUE)
path <- args[1]; n <- as.integer(args[2]); eps <- as.numeric(args[3])
min_pts <- as.integer(args[4]); reps <- as.integer(args[5]); out <- args[6]
extra <- if (length(args) > 6) args[7:length(args)] else character(0)
suppressPackageStartupMessages(library(dbscan))
con <- file(path, "rb"); v <- readBin(con, "double", n = n, size = 8, endian = "little"); close(con)
x <- matrix(v, ncol = 1)
times <- numeric(reps)
invisible(gc())
for (r in seq_len(reps)) {
  t0 <- Sys.time()
  res <- dbscan::dbscan(x, eps = eps, minPts = min_pts)
  times[r] <- as.numeric(difftime(Sys.time(), t0, units = "secs"))
}
writeBin(as.integer(res$cluster), paste0(out, ".labels"), size = 4, endian = "little")
if ("noise" %in% extra) {
  r2 <- dbscan::dbscan(x, eps = eps, minPts = min_pts, borderPoints = FALSE)
  writeBin(as.integer(r2$cluster), paste0(out, ".noise"), size = 4, endian = "little")
}
if ("sorted" %in% extra) {
  r3 <- dbscan::dbscan(matrix(sort(v), ncol = 1), eps = eps, minPts = min_pts)
  writeBin(as.integer(r3$cluster), paste0(out, ".sorted"), size = 4, endian = "little")
}
cat("TIMES", times, "\n")
cat("VERSION", as.character(packageVersion("dbscan")), R.version$major, R.version$minor, "\n")
"""


def make_data(n, seed):
    """N values uniform in [0, N) (density 1), in generator (unsorted) order."""
    return np.random.default_rng(seed).uniform(0.0, float(n), n)


def params_for(n):
    """eps and min_points of the sweep over N: mean neighbourhood ln N, min_points round(ln N)."""
    ln = math.log(n)
    return (ln - 1.0) / 2.0, max(2, round(ln))


def core_oracle(x, eps, min_points):
    """Core mask straight from the definition: count of values within eps, itself included."""
    s = np.sort(x)
    count = np.searchsorted(s, x + eps, side="right") - np.searchsorted(s, x - eps, side="left")
    return count >= min_points


def timed(fn, repeat):
    times = []
    out = None
    gc.collect()
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return times, out


def compare(first, second, peer, core):
    """Peer labels (-1 noise) against octoquant's (border="all": first and second cluster).

    Returns a dict: core_same_clusters (bijection on core points, all of them clustered),
    noise_diff (values noise in one and not the other), border (border values),
    shared_border (reached by two clusters), tie_diff (peer chose octoquant's other
    cluster), mismatch (any other difference), clusters (octoquant, peer).
    """
    a, b = first[core], peer[core]
    ok = bool((a >= 0).all() and (b >= 0).all())
    pairs = np.unique(np.stack([a, b]), axis=1) if a.size else np.zeros((2, 0), dtype=np.int64)
    na, nb = np.unique(a).size, np.unique(b).size
    ok = ok and pairs.shape[1] == na == nb
    mapping = np.full(int(max(first.max(), second.max(), 0)) + 2, -2, dtype=np.int64)
    if ok and a.size:
        mapping[pairs[0]] = pairs[1]
    mapping[-1] = -1  # index -1 (noise) maps to noise
    nc = ~core
    f, s, p = first[nc], second[nc], peer[nc]
    noise_diff = int(((f == -1) != (p == -1)).sum())
    bord = f >= 0
    mf = mapping[f[bord]]
    ms = mapping[s[bord]]
    pb = p[bord]
    same = pb == mf
    tie = (~same) & (s[bord] >= 0) & (pb == ms)
    return {
        "core_same_clusters": ok,
        "noise_diff": noise_diff,
        "border": int(bord.sum()),
        "shared_border": int((s[bord] >= 0).sum()),
        "tie_diff": int(tie.sum()),
        "mismatch": int((~same & ~tie).sum()) if ok else int(bord.sum()),
        "clusters": [int(np.unique(first[first >= 0]).size), int(np.unique(peer[peer >= 0]).size)],
    }


def same_up_to_renaming(a, b):
    """Identical partitions (noise -1 identical, clusters renamed one to one)."""
    if not np.array_equal(a == -1, b == -1):
        return False
    m = a >= 0
    pairs = np.unique(np.stack([a[m], b[m]]), axis=1)
    return pairs.shape[1] == np.unique(a[m]).size == np.unique(b[m]).size


class Peers:
    def __init__(self, args, tmp):
        self.args = args
        self.tmp = Path(tmp)
        self.rscript = shutil.which("Rscript")
        self.r_version = None
        self.sklearn_version = None
        if self.rscript:
            (self.tmp / "peer.R").write_text(R_SCRIPT)
        try:
            import sklearn

            self.sklearn_version = sklearn.__version__
        except ImportError:
            pass

    def run_r(self, x, eps, min_points, repeat, extra):
        data = self.tmp / "x.bin"
        x.astype("<f8").tofile(data)
        out = self.tmp / "r"
        cmd = [self.rscript, str(self.tmp / "peer.R"), str(data), str(x.size), repr(eps),
               str(min_points), str(repeat), str(out), *extra]
        proc = subprocess.run(cmd, capture_output=True, text=True,
                              timeout=self.args.max_seconds * (repeat + 2) + 120)
        if proc.returncode != 0:
            raise RuntimeError(f"Rscript failed: {proc.stderr.strip()}")
        times = None
        for line in proc.stdout.splitlines():
            if line.startswith("TIMES"):
                times = [float(t) for t in line.split()[1:]]
            elif line.startswith("VERSION"):
                v = line.split()
                self.r_version = f"dbscan {v[1]}, R {v[2]}.{v[3]}"

        def labels(suffix):
            f = Path(str(out) + suffix)
            if not f.exists():
                return None
            lab = np.fromfile(f, dtype="<i4").astype(np.int64) - 1  # R: 0 noise, clusters 1..k
            f.unlink()
            return lab

        return times, labels(".labels"), labels(".noise"), labels(".sorted")

    def run_sklearn(self, x, eps, min_points, repeat):
        from sklearn.cluster import DBSCAN

        xx = x.reshape(-1, 1)
        times, model = timed(lambda: DBSCAN(eps=eps, min_samples=min_points).fit(xx), repeat)
        core = np.zeros(x.size, dtype=bool)
        core[model.core_sample_indices_] = True
        return times, model.labels_.astype(np.int64), core


def peer_repeats(predicted, repeat):
    """Runs of a peer case: more for fast cases (timer noise), fewer for slow ones."""
    if predicted is None:
        return repeat
    if predicted < 0.05:
        return max(repeat, 20)
    if predicted < 2.0:
        return repeat
    return min(repeat, 3) if predicted < 15.0 else 1


def run_case(peers, args, x, eps, min_points, pred, log):
    """One (N, eps, min_points): times and label checks of all three. pred: predicted peer
    seconds per run (dict name -> seconds or None)."""
    n = x.size
    row = {"n": n, "eps": eps, "min_points": min_points, "mean_neighbourhood": 2 * eps + 1}
    once, _ = timed(lambda: octoquant.dbscan1d(x, eps, min_points), 1)
    rep_oq = min(100, max(args.repeat, int(0.5 / max(once[0], 1e-6))))
    t, _ = timed(lambda: octoquant.dbscan1d(x, eps, min_points), rep_oq)
    row["octoquant"] = {"times": t, "median": statistics.median(t)}
    xs_all = np.sort(x)
    t, _ = timed(lambda: octoquant.dbscan1d(xs_all, eps, min_points), rep_oq)
    row["octoquant_presorted"] = {"times": t, "median": statistics.median(t)}
    t, _ = timed(lambda: np.sort(x), rep_oq)
    row["numpy_sort"] = {"times": t, "median": statistics.median(t)}
    del xs_all
    first, second = octoquant.dbscan1d(x, eps, min_points, border="all")
    noise_pol = octoquant.dbscan1d(x, eps, min_points, border="noise")
    core = core_oracle(x, eps, min_points)
    row["core_points"] = int(core.sum())
    row["clusters"] = int(np.unique(first[first >= 0]).size)
    row["noise"] = int((first == -1).sum())
    row["octoquant_core_is_oracle"] = bool(np.array_equal(noise_pol >= 0, core))
    row["octoquant_first_is_all_first"] = bool(
        np.array_equal(octoquant.dbscan1d(x, eps, min_points), first))
    small = n <= args.sorted_check_max_n
    if small:
        order = np.argsort(x, kind="stable")
        xs = x[order]
        first_sorted = octoquant.dbscan1d(xs, eps, min_points)

    for name in ("sklearn", "R"):
        p = pred.get(name)
        if name == "sklearn" and (peers.sklearn_version is None or name in args.skip):
            continue
        if name == "R" and (peers.rscript is None or name in args.skip):
            continue
        if p is not None and p > args.max_seconds:
            row[name] = {"skipped": f"predicted {p:.0f} s per run > {args.max_seconds:.0f} s"}
            continue
        if name == "sklearn":
            gb = n * (2 * eps + 1) * 8 * 2 / 1e9 + n * 120 / 1e9
            if gb > args.max_sklearn_gb:
                row[name] = {"skipped": f"neighbourhood lists ~{gb:.0f} GB > {args.max_sklearn_gb:.0f} GB"}
                continue
        rep = peer_repeats(p, args.repeat)
        entry = {}
        if name == "sklearn":
            try:
                t, lab, sk_core = peers.run_sklearn(x, eps, min_points, rep)
            except MemoryError:
                row[name] = {"skipped": "out of memory"}
                continue
            entry["core_is_oracle"] = bool(np.array_equal(sk_core, core))
            if small:
                _, lab_s, _ = peers.run_sklearn(xs, eps, min_points, 1)
                entry["sorted_input_equals_first"] = bool(np.array_equal(lab_s, first_sorted))
        else:
            extra = []
            if n <= args.strict_max_n:
                extra.append("noise")
            if small:
                extra.append("sorted")
            try:
                t, lab, lab_noise, lab_sorted = peers.run_r(x, eps, min_points, rep, extra)
            except subprocess.TimeoutExpired:
                row[name] = {"skipped": "Rscript timed out"}
                continue
            if lab_noise is not None:
                entry["borderPoints_FALSE_equals_noise_policy"] = same_up_to_renaming(noise_pol, lab_noise)
            if lab_sorted is not None:
                entry["sorted_input_equals_first"] = same_up_to_renaming(first_sorted, lab_sorted)
        entry["times"] = t
        entry["median"] = statistics.median(t)
        entry["labels"] = compare(first, second, lab, core)
        row[name] = entry
    log(row)
    return row


def predict(prev, factor):
    if prev is None or "median" not in prev:
        return None
    return prev["median"] * factor


def fmt_s(v):
    if v >= 1:
        return f"{v:.2f} s"
    if v >= 1e-3:
        return f"{v * 1e3:.1f} ms"
    return f"{v * 1e6:.0f} us"


def describe(row, name):
    e = row.get(name)
    if e is None:
        return "not run", "", "not run"
    if "skipped" in e:
        return f"skipped ({e['skipped']})", "", f"skipped ({e['skipped']})"
    ratio = e["median"] / row["octoquant"]["median"]
    lab = e["labels"]
    ok = lab["core_same_clusters"] and lab["noise_diff"] == 0 and lab["mismatch"] == 0
    checks = []
    for k, v in e.items():
        if isinstance(v, bool):
            checks.append(f"{k}: {'yes' if v else 'NO'}")
    text = (f"{'same' if ok else 'DIFFERENT'}; {lab['tie_diff']} of {lab['shared_border']} "
            f"shared borders in the other cluster")
    if checks:
        text += "; " + ", ".join(checks)
    return fmt_s(e["median"]), f"{ratio:.0f}x" if ratio >= 10 else f"{ratio:.1f}x", text


def print_table(rows, key):
    second = "eps" if key == "N" else "N"
    print(f"| {key} | {second} | min_points | DBSCAN1D | DBSCAN1D, presorted input | np.sort | "
          "sklearn | sklearn / DBSCAN1D | R dbscan | R / DBSCAN1D |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        sk = describe(r, "sklearn")
        rr = describe(r, "R")
        n = f"{r['n']:,}".replace(",", " ")
        k, k2 = (n, f"{r['eps']:.3f}") if key == "N" else (f"{r['eps']:g}", n)
        print(f"| {k} | {k2} | {r['min_points']} | {fmt_s(r['octoquant']['median'])} | "
              f"{fmt_s(r['octoquant_presorted']['median'])} | {fmt_s(r['numpy_sort']['median'])} | "
              f"{sk[0]} | {sk[1]} | {rr[0]} | {rr[1]} |")
    print()
    for r in rows:
        k = f"N={r['n']}" if key == "N" else f"eps={r['eps']:g}"
        print(f"- {k}: {r['clusters']} clusters, {r['core_points']} core, {r['noise']} noise; "
              f"octoquant core = oracle: {r['octoquant_core_is_oracle']}; "
              f"sklearn: {describe(r, 'sklearn')[2]}; R: {describe(r, 'R')[2]}")
    print()


def plot(result, out):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    styles = [("octoquant", "DBSCAN1D (octoquant, sort included)", "o-"),
              ("octoquant_presorted", "DBSCAN1D on presorted values", "o-"),
              ("sklearn", "scikit-learn DBSCAN", "s--"), ("R", "R dbscan::dbscan", "^:")]
    for key, rows, fname, xlabel in (
        ("n", result["by_n"], "time-vs-n.png", "N (values)"),
        ("eps", result["by_eps"], "time-vs-eps.png", "eps"),
    ):
        if not rows:
            continue
        fig, ax = plt.subplots(figsize=(6, 4.2), dpi=100)
        for name, label, style in styles:
            pts = [(r[key], r[name]["median"]) for r in rows if "median" in r.get(name, {})]
            if pts:
                faint = {"color": "C0", "alpha": 0.4, "markersize": 3} if "presorted" in name else {}
                ax.plot(*zip(*pts), style, label=label, **faint)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(xlabel)
        ax.set_ylabel("time per call (s, median)")
        if key == "n":
            ax.set_title("Time against N (mean |N_eps| = ln N)")
        else:
            n = f"{rows[0]['n']:,}".replace(",", " ")
            ax.set_title(f"Time against eps, N = {n}, min_points {rows[0]['min_points']}")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
        fig.tight_layout()
        fig.savefig(out / fname)
        plt.close(fig)


def parse_list(s):
    return [float(v) for v in s.split(",") if v]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="1e3,3e3,1e4,3e4,1e5,3e5,1e6,3e6,1e7")
    ap.add_argument("--eps-n", type=float, default=1e6, help="N of the sweep over eps")
    ap.add_argument("--eps", default="1,3,10,30,100,300,1000,3000")
    ap.add_argument("--repeat", type=int, default=5, help="runs per case (more for fast cases)")
    ap.add_argument("--seed", type=int, default=2021)
    ap.add_argument("--max-seconds", type=float, default=60.0)
    ap.add_argument("--max-sklearn-gb", type=float, default=8.0)
    ap.add_argument("--strict-max-n", type=float, default=1e6,
                    help="R also runs with borderPoints = FALSE up to this N")
    ap.add_argument("--sorted-check-max-n", type=float, default=1e4,
                    help="the peers also run on sorted values up to this N")
    ap.add_argument("--skip", default="", help="comma list of peers not to run: sklearn,R")
    ap.add_argument("--out", default="dbscan-peers")
    ap.add_argument("--plot-only", action="store_true", help="re-plot OUT/results.json")
    args = ap.parse_args()
    args.skip = set(args.skip.split(",")) - {""}
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.plot_only:
        plot(json.loads((out / "results.json").read_text()), out)
        return

    def log(row):
        parts = [f"n={row['n']} eps={row['eps']:.4g} m={row['min_points']}",
                 f"oq {fmt_s(row['octoquant']['median'])}"]
        for name in ("sklearn", "R"):
            if name in row:
                e = row[name]
                parts.append(f"{name} " + (e["skipped"] if "skipped" in e else
                                           f"{fmt_s(e['median'])} {e['labels']}"))
        print("  ".join(parts), flush=True)

    with tempfile.TemporaryDirectory() as tmp:
        peers = Peers(args, tmp)
        result = {
            "started": time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime()),
            "machine": {"cpus": os.cpu_count(), "platform": platform.platform(),
                        "processor": cpu_model(), "python": platform.python_version(),
                        "numpy": np.__version__},
            "args": {k: (sorted(v) if isinstance(v, set) else v) for k, v in vars(args).items()},
            "by_n": [],
            "by_eps": [],
        }
        prev = None
        for n in [int(v) for v in parse_list(args.sizes)]:
            x = make_data(n, args.seed)
            eps, m = params_for(n)
            pred = {}
            if prev is not None:
                f = n / prev["n"] * math.log(n) / math.log(prev["n"])
                pred = {k: predict(prev.get(k), f) for k in ("sklearn", "R")}
            row = run_case(peers, args, x, eps, m, pred, log)
            prev = _for_prediction(row, prev)
            result["by_n"].append(row)
        n = int(args.eps_n)
        x = make_data(n, args.seed)
        _, m = params_for(n)
        prev = None
        for eps in parse_list(args.eps):
            pred = {}
            if prev is not None:
                f = (2 * eps + 1) / (2 * prev["eps"] + 1)
                pred = {k: predict(prev.get(k), f) for k in ("sklearn", "R")}
            row = run_case(peers, args, x, eps, m, pred, log)
            prev = _for_prediction(row, prev)
            result["by_eps"].append(row)
        result["versions"] = {"octoquant": metadata.version("octoquant"),
                              "sklearn": peers.sklearn_version, "R": peers.r_version}
        result["finished"] = time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime())
    (out / "results.json").write_text(json.dumps(result, indent=1) + "\n")
    print(f"# {result['started']} - {result['finished']}, {result['machine']}, {result['versions']}")
    print_table(result["by_n"], "N")
    print_table(result["by_eps"], "eps")
    plot(result, out)
    print(f"wrote {out / 'results.json'}, {out / 'time-vs-n.png'}, {out / 'time-vs-eps.png'}")


def _for_prediction(row, prev):
    """The row the next case predicts from: a skipped peer keeps its last measured time (and
    the N / eps it was measured at, so the scaling stays right)."""
    p = {"n": row["n"], "eps": row["eps"]}
    for k in ("sklearn", "R"):
        if "median" in row.get(k, {}):
            p[k] = {"median": row[k]["median"]}
        elif prev is not None and "median" in prev.get(k, {}):
            # scale the old time to this case so the next factor applies from here
            f = (row["n"] / prev["n"]) * (2 * row["eps"] + 1) / (2 * prev["eps"] + 1)
            p[k] = {"median": prev[k]["median"] * f}
    return p


def cpu_model():
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor()


if __name__ == "__main__":
    sys.exit(main())
