#!/usr/bin/env python3
"""The BENCHMARKS table from tools/estimators.sh CSV files (run with BEFORE set).

For each scene, each run's time to the relMSE that the previous `--no-nee` (the `before-off:1`
row: light sampling off, roulette below 1, the binary of that time) reached at the same
samples: relMSE x seconds over that relMSE (a setting not run shows as a dash; the best fixed
setting is the best of those run). Columns: the defaults' choice and time, the
previous `--no-nee`'s time, the same setting with this binary (`off, 1`, what the sampler
alone bought), the best fixed setting, and the ratios.

    python3 tools/estimators-table.py OUT.csv [MORE.csv ...]
"""
import csv
import sys


def main():
    rows = {}
    order = []
    for path in sys.argv[1:]:
        with open(path) as f:
            for r in csv.DictReader(f):
                scene = r["scene"].removesuffix(".txt")
                if scene not in rows:
                    order.append(scene)
                    rows[scene] = {}
                rows[scene][r["setting"]] = r
    print("| scene | spp | defaults chose | defaults | `--no-nee` before | off, 1 now | best fixed "
          "| defaults against `--no-nee` before | behind the best fixed |")
    print("|---|---|---|---|---|---|---|---|---|")
    for scene in order:
        s = rows[scene]
        target = float(s["before-off:1"]["relmse_estimate"])
        to_target = {k: float(v["relmse_x_seconds"]) / target for k, v in s.items()}
        fixed = {k: t for k, t in to_target.items() if k not in ("auto", "before-off:1")}
        best = min(fixed, key=fixed.get)
        chose = s["auto"]["estimator"].split(" (")[0]
        chose = chose.replace("light sampling ", "").replace("; roulette below ", ", ")
        fmt = lambda t: f"{t:.3g} s"
        off_1 = fmt(to_target["off:1"]) if "off:1" in to_target else "—"
        print(f"| {scene} | {s['auto']['spp']} | {chose} | {fmt(to_target['auto'])} "
              f"| {fmt(to_target['before-off:1'])} | {off_1} "
              f"| {best.replace(':', ', ')}: {fmt(fixed[best])} "
              f"| {to_target['before-off:1'] / to_target['auto']:.2f}x "
              f"| {100 * (to_target['auto'] / fixed[best] - 1):+.0f}% |")


if __name__ == "__main__":
    main()
