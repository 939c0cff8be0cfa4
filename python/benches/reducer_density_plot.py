"""Plot the density reducer experiment (issue 27): points per square metre against range,
before and after the reducer, from the ``density.csv`` written by the Rust example
``reducer_experiment`` (``cargo run --release --example reducer_experiment -- OUT_DIR``).

Usage: ``python reducer_density_plot.py OUT_DIR/density.csv OUT.png`` (needs matplotlib).
One panel per source; per stage the median density in each range bin as a line, the 10th to
90th percentiles as a band; the dashed line is one point per 0.07 m cell face,
1 / 0.07^2 = 204 points per square metre.
"""

import csv
import sys
from collections import defaultdict


def main() -> None:
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = defaultdict(list)
    with open(sys.argv[1], newline="") as f:
        for r in csv.DictReader(f):
            rows[(r["source"], r["stage"])].append(r)
    sources = list(dict.fromkeys(s for s, _ in rows))
    stages = ["input", "grid stage", "output stage"]
    colours = {"input": "tab:grey", "grid stage": "tab:blue", "output stage": "tab:red"}
    fig, axes = plt.subplots(1, len(sources), figsize=(6 * len(sources), 4.5), squeeze=False)
    for ax, source in zip(axes[0], sources):
        for stage in stages:
            bins = rows.get((source, stage), [])
            if not bins:
                continue
            mid = [(float(b["range_lo"]) * float(b["range_hi"])) ** 0.5 for b in bins]
            med = [float(b["median"]) for b in bins]
            lo = [max(float(b["p10"]), 1e-1) for b in bins]
            hi = [float(b["p90"]) for b in bins]
            ax.plot(mid, med, "o-", color=colours[stage], label=stage)
            ax.fill_between(mid, lo, hi, color=colours[stage], alpha=0.15)
        ax.axhline(1 / 0.07**2, color="black", linestyle="--", linewidth=1,
                   label="1 / 0.07² m²")
        ax.set_xscale("log", base=2)
        ax.set_yscale("log")
        ax.set_xlabel("range from the scanner (m)")
        ax.set_ylabel("points per m² (within 0.2 m)")
        ax.set_title(source)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize="small")
    fig.suptitle("Online grid density reducer, cell 0.07 m: density against range")
    fig.tight_layout()
    fig.savefig(sys.argv[2], dpi=110)


if __name__ == "__main__":
    main()
