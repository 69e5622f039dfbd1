#!/usr/bin/env python3
"""Batch scaling (issue 6): sheet-frames per second of `papertear batch` on 2 threads against 1 thread.

The machine's speed drifts by tens of percent within minutes, so one pair of runs says little. Each round
runs, in this order (ABBA, so a drift inside the round cancels):
  T1   one process, --threads 1
  T2   one process, --threads 2
  P2   two 1-thread processes at once, each the whole batch (the control: the same work on two cores with
       nothing shared inside the process, so P2/T1 is what this machine gives two independent workers)
  P2, T2, T1 again.
It prints per round the threads' ratio T2/T1 and the control's P2/T1, then the medians and the ratio of
the sums. If T2/T1 falls short of 1.8x while P2/T1 falls short as much, the cores, not the engine, set
the limit at that moment.

Usage: scripts/batch-scaling.py [--bin build/bin/papertear] [--scenario scenarios/start-inward.json]
                                [--sheets 32] [--frames 60] [--rounds 8] [--out FILE]
"""
import argparse
import datetime
import json
import os
import statistics
import subprocess
import sys
import tempfile


def batch(args, threads, out_dir):
    cmd = [args.bin, "batch", args.scenario, "--sheets", str(args.sheets), "--frames", str(args.frames),
           "--threads", str(threads), "--out", out_dir]
    return subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def batch_json(out_dir):
    with open(os.path.join(out_dir, "batch.json")) as f:
        return json.load(f)


def sheet_frames_per_s(out_dir):
    return batch_json(out_dir)["sheet_frames_per_s"]


def run_one(args, threads, tmp):
    d = os.path.join(tmp, f"t{threads}")
    if batch(args, threads, d).wait() != 0:
        sys.exit(f"batch-scaling: papertear batch --threads {threads} failed")
    return sheet_frames_per_s(d)


def run_pair(args, tmp):
    dirs = [os.path.join(tmp, "p0"), os.path.join(tmp, "p1")]
    procs = [batch(args, 1, d) for d in dirs]
    if any(p.wait() != 0 for p in procs):
        sys.exit("batch-scaling: a control process failed")
    # All the sheet-frames of both over the slower one's time: summing the two rates would count the
    # faster one's rate for the whole interval, and the slower one ran alone (faster) at its end.
    results = [batch_json(d) for d in dirs]
    return sum(r["sheet_frames_per_s"] * r["wall_s"] for r in results) / max(r["wall_s"] for r in results)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default="build/bin/papertear")
    ap.add_argument("--scenario", default="scenarios/start-inward.json")
    ap.add_argument("--sheets", type=int, default=32)
    ap.add_argument("--frames", type=int, default=60)
    ap.add_argument("--rounds", type=int, default=8)
    ap.add_argument("--out", default=None, help="also write the report here")
    args = ap.parse_args()

    lines = [f"# {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, "
             f"scripts/batch-scaling.py --scenario {args.scenario} --sheets {args.sheets} "
             f"--frames {args.frames} --rounds {args.rounds}",
             "# sheet-frames/s per run (T1 T2 P2 P2 T2 T1), then T2/T1 and the control P2/T1"]

    def say(s):
        print(s, flush=True)
        lines.append(s)

    for line in lines:
        print(line)
    t1s, t2s, p2s, r_threads, r_procs = [], [], [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.rounds):
            a = run_one(args, 1, tmp)
            b = run_one(args, 2, tmp)
            c = run_pair(args, tmp)
            d = run_pair(args, tmp)
            e = run_one(args, 2, tmp)
            f = run_one(args, 1, tmp)
            t1, t2, p2 = a + f, b + e, c + d
            t1s.append(t1 / 2)
            t2s.append(t2 / 2)
            p2s.append(p2 / 2)
            r_threads.append(t2 / t1)
            r_procs.append(p2 / t1)
            say(f"round {r + 1}: {a:.0f} {b:.0f} {c:.0f} {d:.0f} {e:.0f} {f:.0f}   "
                f"threads {t2 / t1:.3f}x   control {p2 / t1:.3f}x")
    say(f"median of rounds: threads {statistics.median(r_threads):.3f}x, "
        f"control {statistics.median(r_procs):.3f}x")
    say(f"on the means: T1 {statistics.mean(t1s):.1f}, T2 {statistics.mean(t2s):.1f}, P2 {statistics.mean(p2s):.1f} "
        f"sheet-frames/s; threads {sum(t2s) / sum(t1s):.3f}x, control {sum(p2s) / sum(t1s):.3f}x")
    if args.out:
        with open(args.out, "a") as f:
            f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
