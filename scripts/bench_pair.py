#!/usr/bin/env python3
"""Pair two atmosim builds on the figure-of-merit suite.

The suite's job files come from `atmosim bench --suite --write-jobs DIR`
(any build that reads them can be paired: they use only keys that every
build since 2026-11-20 knows). Each round renders every case once with each
build, in alternating order, one thread, on a seed of its own
(`render.seed` = the round), and takes the whole process's CPU time
(user + system, from the kernel's accounting of the child).

Per case and direction the figure of merit of a build is

    FOM_I = 1 / (mean over rounds of (se_I / I)^2  x  median CPU seconds)
    FOM_Q = 1 / (mean over rounds of (se_Q / I)^2  x  median CPU seconds)

(Q's error relative to I: Q crosses zero). A direction of a case with
several channels or albedos takes its worst channel (the lowest FOM). The
script prints per case the median and minimum over directions of the
ratio FOM_A / FOM_B, then the median over every direction of the suite,
and with --detail every direction; --json writes all of it.

    python3 scripts/bench_pair.py --jobs /tmp/suite \
        --a target/release/atmosim --b /path/to/old/atmosim --rounds 5

With --cost instructions the cost is not CPU time but the instructions
each build executes for the case, counted by valgrind's callgrind (the
same count whatever else the machine runs: for a shared, noisy machine).
Each build renders each case twice under callgrind, at 1/40 and 1/20 of
its paths (seed 1); the count is extrapolated linearly to the full paths
(the scene's build is the intercept). Variances still come from the
native rounds. Instructions are not cycles (cache misses and divisions
cost more than one), so quote both.

Standard library only (and valgrind for --cost instructions).
"""

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import time


def with_seed(text, seed):
    """The job text with render.seed set (replacing one if present)."""
    lines = [l for l in text.splitlines() if not re.match(r"\s*seed\s*=", l)]
    out, placed = [], False
    for l in lines:
        out.append(l)
        if l.strip() == "[render]" and not placed:
            out.append(f"seed = {seed}")
            placed = True
    if not placed:
        out += ["[render]", f"seed = {seed}"]
    return "\n".join(out) + "\n"


def run_case(binary, job_path, threads):
    """(rows, cpu seconds, wall seconds) of one render of job_path."""
    start = time.monotonic()
    proc = subprocess.Popen(
        [binary, "render", job_path, "--stdout", "--threads", str(threads), "-q"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        cwd=os.path.dirname(job_path),
    )
    out = proc.stdout.read()
    err = proc.stderr.read()
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.monotonic() - start
    if status != 0:
        sys.exit(f"{binary} failed on {job_path}:\n{err.decode(errors='replace')}")
    lines = out.decode().strip().splitlines()
    header = lines[0].split(",")
    rows = [dict(zip(header, l.split(","))) for l in lines[1:]]
    return rows, usage.ru_utime + usage.ru_stime, wall


def with_samples(text, fraction):
    """The job text with render.samples scaled by `fraction`."""
    def scale(m):
        return f"samples = {max(2, int(int(m.group(1)) * fraction))}"
    return re.sub(r"^samples\s*=\s*(\d+)", scale, text, flags=re.M)


def instructions(binary, folder, case, seed):
    """Instructions of `binary` rendering `case` at its full paths,
    extrapolated from callgrind counts at 1/40 and 1/20 of them."""
    text = with_seed(open(os.path.join(folder, case + ".toml")).read(), seed)
    if with_samples(text, 1 / 40) == with_samples(text, 1 / 20):
        sys.exit(f"{case}: 1/40 and 1/20 of its samples are the same count: "
                 "no per-path cost to extrapolate; give the case more samples")
    counts = []
    for fraction in (1 / 40, 1 / 20):
        path = os.path.join(folder, f".cg_{case}.toml")
        out = os.path.join(folder, f".cg_{case}.out")
        with open(path, "w") as fh:
            fh.write(with_samples(text, fraction))
        # Children traced (a build may be a wrapper script that execs
        # the binary): every process's count summed.
        subprocess.run(["valgrind", "--tool=callgrind", "--trace-children=yes",
                        f"--callgrind-out-file={out}.%p", binary,
                        "render", path, "--stdout", "--threads", "1", "-q"],
                       check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                       cwd=folder)
        total = 0
        for name in os.listdir(folder):
            if name.startswith(os.path.basename(out) + "."):
                with open(os.path.join(folder, name)) as fh:
                    total += next((int(l.split()[1]) for l in fh if l.startswith("summary:")), 0)
                os.remove(os.path.join(folder, name))
        counts.append((fraction, total))
        os.remove(path)
    (f1, c1), (f2, c2) = counts
    if c2 <= c1:
        # Twice the paths must cost more: else the per-path part is lost in
        # the start-up's (a noise target that stops early, too few paths),
        # and a line through the two would say nothing (or less than zero).
        sys.exit(f"{case}: {binary} executed {c2} instructions at {f2:g} of the paths and {c1} at "
                 f"{f1:g}: no per-path cost to extrapolate; give the case more samples")
    slope = (c2 - c1) / (f2 - f1)
    return c1 + slope * (1.0 - f1)


def direction_key(row):
    return (float(row["view_zenith_deg"]), float(row["azimuth_deg"]))


def fom_table(runs, cost=None):
    """Per direction: (FOM_I, FOM_Q), worst channel, from a build's rounds
    (cost: the median CPU seconds, or the given cost)."""
    cpu = statistics.median(r[1] for r in runs) if cost is None else cost
    rel = {}
    for rows, _, _ in runs:
        for row in rows:
            i = float(row["I"])
            if i <= 0:
                continue
            chan = (row["wavelength_nm"], row.get("albedo", ""))
            key = direction_key(row)
            vi = (float(row["I_se"]) / i) ** 2
            vq = (float(row["Q_se"]) / i) ** 2
            rel.setdefault(key, {}).setdefault(chan, []).append((vi, vq))
    table = {}
    for key, chans in rel.items():
        fi, fq = [], []
        for vals in chans.values():
            mi = statistics.fmean(v[0] for v in vals)
            mq = statistics.fmean(v[1] for v in vals)
            fi.append(1.0 / (mi * cpu) if mi > 0 else float("inf"))
            fq.append(1.0 / (mq * cpu) if mq > 0 else float("inf"))
        table[key] = (min(fi), min(fq))
    return table, cpu


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--jobs", required=True, help="folder of the suite's job files")
    ap.add_argument("--jobs-b", help="build B renders the same cases from this folder instead "
                    "(two settings of one build: switch a part off in B's copies)")
    ap.add_argument("--a", required=True, help="build A (the numerator)")
    ap.add_argument("--b", required=True, help="build B")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--cases", nargs="*", help="only these cases (file stems)")
    ap.add_argument("--detail", action="store_true", help="print every direction")
    ap.add_argument("--json", help="write the figures here")
    ap.add_argument("--cost", choices=["cpu", "instructions"], default="cpu",
                    help="the cost in the FOM: CPU seconds (default) or instructions (callgrind)")
    args = ap.parse_args()

    args.jobs = os.path.abspath(args.jobs)
    jobs = sorted(f[:-5] for f in os.listdir(args.jobs) if f.endswith(".toml") and not f.startswith("."))
    if args.cases:
        unknown = set(args.cases) - set(jobs)
        if unknown:
            sys.exit(f"no such case in {args.jobs}: {', '.join(sorted(unknown))}")
        jobs = [j for j in jobs if j in args.cases]
    jobs_b = os.path.abspath(args.jobs_b) if args.jobs_b else args.jobs
    builds = {"A": os.path.abspath(args.a), "B": os.path.abspath(args.b)}
    runs = {(c, b): [] for c in jobs for b in builds}
    if True:
        for r in range(args.rounds):
            for k, case in enumerate(jobs):
                paths = {}
                for b, folder in (("A", args.jobs), ("B", jobs_b)):
                    text = open(os.path.join(folder, case + ".toml")).read()
                    paths[b] = os.path.join(folder, f".pair_{b}_{case}_{r}.toml")
                    with open(paths[b], "w") as fh:
                        fh.write(with_seed(text, r + 1))
                order = ["A", "B"] if (r + k) % 2 == 0 else ["B", "A"]
                for b in order:
                    runs[(case, b)].append(run_case(builds[b], paths[b], args.threads))
                for path in paths.values():
                    os.remove(path)
                print(f"round {r + 1}/{args.rounds} {case}: "
                      + ", ".join(f"{b} {runs[(case, b)][-1][1]:.2f} s" for b in order),
                      file=sys.stderr)
    cost = {}
    if args.cost == "instructions":
        for case in jobs:
            for b, folder in (("A", args.jobs), ("B", jobs_b)):
                cost[(case, b)] = instructions(builds[b], folder, case, 1) / 1e9
                print(f"{case} {b}: {cost[(case, b)]:.2f} G instructions", file=sys.stderr)
    unit = "G instructions" if args.cost == "instructions" else "CPU s"
    result = {"a": builds["A"], "b": builds["B"], "rounds": args.rounds, "cases": {}}
    every_i, every_q = [], []
    print(f"# FOM ratio A / B per direction (A = {args.a}, B = {args.b}, {args.rounds} rounds)")
    unit = "G instructions" if args.cost == "instructions" else "CPU s"
    print(f"case, {unit} A, {unit} B, I median, I min, Q median, Q min")
    for case in jobs:
        ta, ca = fom_table(runs[(case, "A")], cost.get((case, "A")))
        tb, cb = fom_table(runs[(case, "B")], cost.get((case, "B")))
        ratios = {k: (ta[k][0] / tb[k][0], ta[k][1] / tb[k][1]) for k in ta if k in tb}
        ri = [v[0] for v in ratios.values()]
        rq = [v[1] for v in ratios.values() if v[1] == v[1] and v[1] not in (0.0, float("inf"))]
        every_i += ri
        every_q += rq
        print(f"{case}, {ca:.2f}, {cb:.2f}, {statistics.median(ri):.3f}, {min(ri):.3f}, "
              + (f"{statistics.median(rq):.3f}, {min(rq):.3f}" if rq else "-, -"))
        if args.detail:
            for k in sorted(ratios):
                print(f"  {case} vza {k[0]:g} az {k[1]:g}: I {ratios[k][0]:.3f}  Q {ratios[k][1]:.3f}"
                      f"  (FOM_I A {ta[k][0]:.4g}, B {tb[k][0]:.4g})")
        result["cases"][case] = {
            "cost_unit": unit, "cost_a": ca, "cost_b": cb,
            "directions": [{"view_zenith_deg": k[0], "azimuth_deg": k[1],
                            "fom_i_a": ta[k][0], "fom_i_b": tb[k][0],
                            "fom_q_a": ta[k][1], "fom_q_b": tb[k][1]} for k in sorted(ratios)],
        }
    print(f"suite, -, -, {statistics.median(every_i):.3f}, {min(every_i):.3f}, "
          f"{statistics.median(every_q):.3f}, {min(every_q):.3f}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(result, fh, indent=1)


if __name__ == "__main__":
    main()
