#!/usr/bin/env python3
"""Batch over MPI ranks (issue 26): sheet-frames per second of `mpirun -np 2 papertear batch --threads 1`
against one process with --threads 1, on the same batch.

As scripts/batch-scaling.py, each round runs, in this order (ABBA, so a drift inside the round cancels):
  T1   one process, --threads 1
  M2   mpirun -np 2, --threads 1 per rank (wall time of the batch from rank 0's batch.json, MPI's start
       excluded; the command's own wall time is printed too)
  P2   two 1-thread processes at once, each the whole batch (the control: what this machine gives two
       independent workers at that moment)
  M2, T1 again.
It prints per round M2/T1 and P2/T1, the medians and the ratio of the sums, rank 0's coordinating CPU per
sheet, and how evenly the sheets were spread: the sum of the sheets' times over the ranks against the
wall time, and what a static split (first half / second half, or even / odd sheets) would have given.

Usage: scripts/mpi-batch-scaling.py [--bin build/bin/papertear] [--mpirun mpirun] [--scenario S]
                                    [--sheets 32] [--frames 60] [--rounds 4] [--vary KEY=FROM:TO]... [--out FILE]
"""
import argparse
import datetime
import json
import os
import platform
import re
import statistics
import subprocess
import sys
import tempfile
import time


def batch_cmd(args, out_dir):
    cmd = [args.bin, "batch", args.scenario, "--sheets", str(args.sheets), "--frames", str(args.frames),
           "--threads", "1", "--out", out_dir]
    for v in args.vary:
        cmd += ["--vary", v]
    return cmd


def mpi_cmd(args, ranks, out_dir):
    return [args.mpirun, "--allow-run-as-root", "--oversubscribe", "-q", "-np", str(ranks)] + batch_cmd(args, out_dir)


def load(out_dir):
    with open(os.path.join(out_dir, "batch.json")) as f:
        return json.load(f)


def run(cmd):
    t0 = time.monotonic()
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if p.returncode != 0:
        sys.exit(f"mpi-batch-scaling: {' '.join(cmd)} failed ({p.returncode}): {p.stderr.strip()}")
    return p.stdout, time.monotonic() - t0


def one(args, tmp):
    d = os.path.join(tmp, "t1")
    run(batch_cmd(args, d))
    return load(d)["sheet_frames_per_s"]


def mpi(args, tmp, stats):
    d = os.path.join(tmp, "m2")
    out, command_s = run(mpi_cmd(args, 2, d))
    j = load(d)
    m = re.search(r"sheets (\d+) (\d+); sheet time ([\d.]+) ([\d.]+) s; rank 0 coordinating ([\d.]+) us CPU per "
                  r"sheet; ([\d.]+) messages, (\d+) B", out)
    if m:
        stats.append({"sheets": (int(m[1]), int(m[2])), "sheet_s": (float(m[3]), float(m[4])), "cpu_us": float(m[5]),
                      "messages": float(m[6]), "bytes": float(m[7]), "wall_s": j["wall_s"], "command_s": command_s,
                      "outcomes": j["outcomes"], "frames": j["frames"]})
    return j["sheet_frames_per_s"]


def pair(args, tmp):
    dirs = [os.path.join(tmp, "p0"), os.path.join(tmp, "p1")]
    procs = [subprocess.Popen(batch_cmd(args, d), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL) for d in dirs]
    if any(p.wait() != 0 for p in procs):
        sys.exit("mpi-batch-scaling: a control process failed")
    results = [load(d) for d in dirs]
    return sum(r["sheet_frames_per_s"] * r["wall_s"] for r in results) / max(r["wall_s"] for r in results)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default="build/bin/papertear")
    ap.add_argument("--mpirun", default="mpirun")
    ap.add_argument("--scenario", default="scenarios/start-inward.json")
    ap.add_argument("--sheets", type=int, default=32)
    ap.add_argument("--frames", type=int, default=60)
    ap.add_argument("--rounds", type=int, default=4)
    ap.add_argument("--vary", action="append", default=[])
    ap.add_argument("--out")
    args = ap.parse_args()
    lines = [f"# {datetime.datetime.now().isoformat(timespec='seconds')} host {platform.node()}, "
             f"{os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}",
             "# " + " ".join(mpi_cmd(args, 2, "DIR"))]
    t1s, m2s, p2s, stats = [], [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.rounds):
            a, m, p, m_, b = one(args, tmp), mpi(args, tmp, stats), pair(args, tmp), mpi(args, tmp, stats), one(args, tmp)
            t1, m2 = (a + b) / 2, (m + m_) / 2
            t1s.append(t1), m2s.append(m2), p2s.append(p)
            lines.append(f"round {r}: T1 {t1:.1f}  M2 {m2:.1f}  P2 {p:.1f} sheet-frames/s   M2/T1 {m2 / t1:.3f}  "
                         f"P2/T1 {p / t1:.3f}")
            print(lines[-1], flush=True)
    ratios = [m / t for m, t in zip(m2s, t1s)]
    controls = [p / t for p, t in zip(p2s, t1s)]
    lines.append(f"median M2/T1 {statistics.median(ratios):.3f}, P2/T1 {statistics.median(controls):.3f}; "
                 f"sums M2/T1 {sum(m2s) / sum(t1s):.3f}, P2/T1 {sum(p2s) / sum(t1s):.3f}")
    if stats:
        lines.append(f"rank 0 coordinating: {statistics.median(s['cpu_us'] for s in stats):.1f} us CPU per sheet "
                     f"(median of {len(stats)} runs); {statistics.median(s['messages'] for s in stats):.2f} messages, "
                     f"{statistics.median(s['bytes'] for s in stats):.0f} B per sheet of rank 1; mpirun's start and "
                     f"end: {statistics.median(s['command_s'] - s['wall_s'] for s in stats):.2f} s per command")
        # Balance: each sheet's time (frame_ms x frames) from the outcomes, against the wall time.
        s = stats[-1]
        times = [o["frame_ms"] * s["frames"] / 1000 for o in s["outcomes"]]
        half = len(times) // 2
        ideal = sum(times) / 2
        lines.append(f"balance (last M2 run): sheets per rank {s['sheets'][0]} / {s['sheets'][1]}, sheet time "
                     f"{s['sheet_s'][0]:.2f} / {s['sheet_s'][1]:.2f} s, wall {s['wall_s']:.2f} s against "
                     f"{ideal:.2f} s for a perfect split ({ideal / s['wall_s']:.3f}); a static split would take "
                     f"{max(sum(times[:half]), sum(times[half:])):.2f} s (halves), "
                     f"{max(sum(times[0::2]), sum(times[1::2])):.2f} s (even / odd), most costly sheet "
                     f"{max(times):.2f} s, cheapest {min(times):.2f} s")
    for line in lines[-3:]:
        print(line)
    if args.out:
        with open(args.out, "a") as f:
            f.write("\n".join(lines) + "\n\n")


if __name__ == "__main__":
    main()
