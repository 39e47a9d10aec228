#!/usr/bin/env python3
"""How far the defaults (`auto`: the strategy trial's choice) land behind the best fixed
setting, in expectation over the trial's random numbers and its timings.

Why not time the defaults' renders: with the same seed, `auto` renders bit for bit the image of
the setting it chose (tests/strategy.rs), so its render differs from that fixed render only by
the trial's seconds, and a render timed on a shared 2-core machine varies by 5 to 8% from run
to run, more than the differences this is meant to show. So this measures the two parts apart:
- each fixed setting's relMSE × seconds: its relMSE estimate averaged over --truth-seeds seeds,
  times its seconds averaged over those renders;
- each binary's choice and trial seconds over --seeds seeds: `clpt render --spp N --time
  0.001 -v` runs the trial of an N-sample render and stops after one pass.
A choice's cost is then its setting's relMSE × seconds over the best one's, plus the trial's
seconds over that setting's render seconds; the table gives its mean over the seeds, per scene.

  tools/expected-behind.py --clpt BIN [--clpt BIN ...] [--seeds 24] [--truth-seeds 3]
      [--truth CSV] [--out DIR] [--lines DIR] SCENE:SPP[:W:H] ...

With --lines DIR, each trial's candidate lines (`-v`: every candidate's relative variance, its
samples a pixel and its seconds a path) are kept in DIR/SCENE-SEED.txt (SCENE-BINARY-SEED.txt
with several binaries), to replay a change of the choice's rule on the same trials and truth
without a build.

The first --clpt renders the fixed settings; --truth takes them instead from the "fixed" rows
of an earlier run's CSV (same scenes, samples and sizes, same machine), to compare new trials
against settings measured once: whichever of a scene's settings it holds (a lit room's settings
without light sampling, far behind and never chosen, may be left out; a choice it lacks stops
the run). CLPT_DEVICE picks the device, as for clpt.
Besides the table, DIR/expected-behind.csv holds one row a fixed setting (binary "fixed": its
mean render seconds and relMSE × seconds) and one row a trial (the binary: its choice, seed,
trial seconds and cost behind the best).
"""
import argparse
import csv
import os
import re
import statistics
import subprocess
import sys
import tempfile

# The candidates of `auto` (src/render/strategy.rs: light sampling on and off, RR_THRESHOLDS).
SETTINGS = [("on", "0.5"), ("on", "0.3"), ("off", "0.5"), ("off", "0.3")]
CHOICE = re.compile(
    r"^estimator: light sampling (on|off), roulette below ([0-9.]+) \(chosen in a ([0-9.]+) s trial"
)


def render(clpt, scene, spp, size, seed, extra, tmp):
    args = [clpt, "render", scene, "--spp", str(spp), "--seed", str(seed), "-o",
            os.path.join(tmp, "image.pfm")] + size + extra
    return subprocess.run(args, capture_output=True, text=True, check=True)


def fixed(clpt, scene, spp, size, seed, light, rr, tmp):
    """(seconds, relMSE estimate) of one render with a fixed setting."""
    report = os.path.join(tmp, "report.csv")
    render(clpt, scene, spp, size, seed,
           ["-q", "--light-sampling", light, "--rr-threshold", rr, "--report", report], tmp)
    with open(report) as f:
        last = [line for line in f if line and not line.startswith("#")][-1].split(",")
    return float(last[1]), float(last[5])


def choice(clpt, scene, spp, size, seed, tmp):
    """(setting, trial seconds, the candidates' lines) of the trial of an spp-sample render."""
    out = render(clpt, scene, spp, size, seed, ["--time", "0.001", "-v"], tmp)
    lines = out.stderr.splitlines() + out.stdout.splitlines()
    for line in lines:
        m = CHOICE.match(line)
        if m:
            return (m.group(1), m.group(2)), float(m.group(3)), [l for l in lines if "trial:" in l]
    sys.exit(f"{scene}: no trial in the output of {clpt}:\n{out.stderr}")


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--clpt", action="append", required=True)
    p.add_argument("--seeds", type=int, default=24)
    p.add_argument("--truth-seeds", type=int, default=3)
    p.add_argument("--truth", help="an earlier expected-behind.csv whose fixed rows to reuse")
    p.add_argument("--out", default=".")
    p.add_argument("--lines", help="keep each trial's candidate lines in this folder")
    p.add_argument("scenes", nargs="+")
    a = p.parse_args()
    earlier = {}
    if a.truth:
        with open(a.truth, newline="") as f:
            for r in csv.DictReader(f):
                if r["binary"] == "fixed":
                    key = (r["scene"], r["spp"], tuple(r["setting"].split(":")))
                    earlier[key] = (float(r["seconds"]), float(r["relmse_x_seconds"]))
    os.makedirs(a.out, exist_ok=True)
    tmp = tempfile.mkdtemp()
    rows = []
    if a.lines:
        os.makedirs(a.lines, exist_ok=True)
    for entry in a.scenes:
        file, spp, *wh = entry.split(":")
        size = ["--width", wh[0], "--height", wh[1]] if wh else []
        name = os.path.basename(file).removesuffix(".txt")
        truth = {}
        settings = SETTINGS
        if a.truth:
            settings = [k[2] for k in earlier if k[:2] == (name, spp)]
            if not settings:
                sys.exit(f"{a.truth} has no fixed rows for {name}, {spp}")
        for light, rr in settings:
            if a.truth:
                seconds, product = earlier[(name, spp, (light, rr))]
            else:
                runs = [fixed(a.clpt[0], file, spp, size, s, light, rr, tmp)
                        for s in range(1, a.truth_seeds + 1)]
                seconds = statistics.mean(r[0] for r in runs)
                product = statistics.mean(r[1] for r in runs) * seconds
            truth[(light, rr)] = (seconds, product)
            rows.append([name, spp, "fixed", f"{light}:{rr}", "", seconds, product, ""])
        best = min(v[1] for v in truth.values())
        # The binaries alternate seed by seed, so that a slow spell of the machine falls on all.
        for seed in range(1, a.seeds + 1):
            for clpt in a.clpt:
                setting, trial, lines = choice(clpt, file, spp, size, seed, tmp)
                if setting not in truth:
                    sys.exit(f"{name}: {clpt} chose {setting}, which {a.truth} lacks")
                seconds, product = truth[setting]
                behind = product / best - 1 + trial / seconds
                if a.lines:
                    tag = f"-{os.path.basename(clpt)}" if len(a.clpt) > 1 else ""
                    with open(os.path.join(a.lines, f"{name}{tag}-{seed}.txt"), "w") as f:
                        f.write("\n".join(lines) + "\n")
                rows.append([name, spp, os.path.basename(clpt), ":".join(setting), seed,
                             trial, "", behind])
        print(f"{name}: done", file=sys.stderr)
    path = os.path.join(a.out, "expected-behind.csv")
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["scene", "spp", "binary", "setting", "seed", "seconds", "relmse_x_seconds",
                    "behind"])
        w.writerows(rows)
    table(rows, [os.path.basename(c) for c in a.clpt])


def table(rows, binaries):
    """One markdown row a scene: the best fixed setting, the others' distance, and for each
    binary the mean cost behind it with its choices."""
    print("| scene, spp | best fixed: relMSE × s | others behind | "
          + " | ".join(f"{b}: behind (choices; trial s)" for b in binaries) + " |")
    print("|---|---|---|" + "---|" * len(binaries))
    means = {b: [] for b in binaries}
    for name in dict.fromkeys(r[0] for r in rows):
        fixed_rows = {r[3]: r[6] for r in rows if r[0] == name and r[2] == "fixed"}
        best = min(fixed_rows, key=fixed_rows.get)
        others = ", ".join(f"{k.replace(':', ', ')} {100 * (v / fixed_rows[best] - 1):+.0f}%"
                           for k, v in fixed_rows.items() if k != best)
        spp = next(r[1] for r in rows if r[0] == name)
        cells = []
        for b in binaries:
            mine = [r for r in rows if r[0] == name and r[2] == b]
            behind = statistics.mean(r[7] for r in mine)
            means[b].append(behind)
            picks = {}
            for r in mine:
                picks[r[3]] = picks.get(r[3], 0) + 1
            picks_text = ", ".join(f"{k.replace(':', ', ')} ×{n}" for k, n in picks.items())
            trial = statistics.mean(r[5] for r in mine)
            cells.append(f"{100 * behind:+.1f}% ({picks_text}; {trial:.3f} s)")
        print(f"| {name}, {spp} | {best.replace(':', ', ')}: {fixed_rows[best]:.3g} | {others} | "
              + " | ".join(cells) + " |")
    print("| mean | | | " + " | ".join(f"{100 * statistics.mean(v):+.1f}%"
                                     for v in means.values()) + " |")


if __name__ == "__main__":
    main()
