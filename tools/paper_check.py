#!/usr/bin/env python3
"""Runs scenarios and prints how they behave as paper: tears (longer than 3 mm), pieces, the peak finger
force, the largest in-plane strain and the finger slips, one line each.

  tools/paper_check.py [--bin build/bin/papertear] [--set KEY=VALUE]... [--triangles N]... [SCENARIO...]

Without SCENARIO it runs every file of scenarios/. With several --triangles it runs each scenario at each
mesh density (the mesh-independence check of finger forces)."""
import argparse, json, math, os, subprocess, sys, tempfile, concurrent.futures

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def tear_length(t):
    p = t["tips"]
    return sum(math.dist(p[i], p[i + 1]) for i in range(len(p) - 1))


def run(binary, path, settings, out):
    cmd = [binary, "run", path, "--out", out, "--threads", "1"]
    for s in settings:
        cmd += ["--set", s]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        return {"error": p.stderr.strip().splitlines()[-1] if p.stderr.strip() else f"exit {p.returncode}"}
    with open(os.path.join(out, "result.json")) as f:
        return json.load(f)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default=os.path.join(ROOT, "build/bin/papertear"))
    ap.add_argument("--set", action="append", default=[])
    ap.add_argument("--triangles", action="append", type=int, default=[])
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("scenarios", nargs="*")
    a = ap.parse_args()
    files = a.scenarios or sorted(os.path.join(ROOT, "scenarios", f) for f in os.listdir(os.path.join(ROOT, "scenarios"))
                                  if f.endswith(".json") and f != "a4-10k-patch.json")
    jobs = []
    for f in files:
        for n in a.triangles or [None]:
            jobs.append((f, n))
    tmp = tempfile.mkdtemp(prefix="paper-check-")
    def one(job):
        f, n = job
        settings = list(a.set) + ([f"sheet.triangles={n}"] if n else [])
        out = os.path.join(tmp, os.path.basename(f)[:-5] + (f"-{n}" if n else ""))
        return job, run(a.bin, f, settings, out)
    print(f"{'scenario':<22} {'tri':>5} {'tears':>5} {'>3mm':>4} {'pieces':>6} {'peak N':>8} {'end N':>7} {'max_strain':>10} {'slips':>5} {'status':>6}")
    with concurrent.futures.ThreadPoolExecutor(a.jobs) as ex:
        for (f, n), r in ex.map(one, jobs):
            name = os.path.basename(f)[:-5]
            if "error" in r:
                print(f"{name:<22} {n or '':>5} error: {r['error']}")
                continue
            tears = r["tears"]
            long_tears = sum(1 for t in tears if tear_length(t) > 3e-3)
            peak = max((fi["max_force"] for fi in r["fingers"]), default=0)
            end = max((fi.get("force", 0) for fi in r["fingers"]), default=0)
            slips = sum(fi.get("slips", 0) for fi in r["fingers"])
            strain = r.get("max_strain", float("nan"))
            print(f"{name:<22} {r['mesh']['triangles']:>5} {len(tears):>5} {long_tears:>4} {r['mesh']['pieces']:>6} "
                  f"{peak:>8.3g} {end:>7.3g} {strain:>10.3g} {slips:>5} {r['status']:>6}", flush=True)


if __name__ == "__main__":
    main()
