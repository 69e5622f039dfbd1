#!/usr/bin/env python3
"""Runs scenarios and prints how they behave as paper: tears (longer than 3 mm), pieces, the peak finger
force, the largest in-plane strain and the finger slips, one line each.

  tools/paper_check.py [--bin build/bin/papertear] [--set KEY=VALUE]... [--triangles N]... [--seeds N]
                       [--pad R] [--summary] [SCENARIO...]

Without SCENARIO it runs every file of scenarios/. With several --triangles it runs each scenario at each
mesh density (the mesh-independence check of finger forces). --seeds N runs each on N meshes of the same
density (sheet.mesh_seed 0..N-1, the meshing frame turned 17 degrees per seed, as papertear-path-claims
does). --pad R gives every finger of every scenario a pad of radius R (m). --summary prints, instead of a line per run, one line per scenario over its meshes (min / median /
max) and then how many runs break each of the paper checks: a passive scene (pushed, bent or waved: it
must not tear) holding more than 0.3 N or tearing, a tearing scene peaking above 5 N, a finger slipping,
max_strain above 2%, and above 2% beyond 5 mm of the tear tips and the outline's untorn inward corners
(max_strain_beyond_tips). The "run cm"
column is the longest path a tear grew within one frame (max_advance_per_frame): a notched sheet pulled
in its own plane tears across at once, as paper does, but a tear made by hands moving out of the plane
follows them (a few millimetres per frame), so a long run there means it ran away from them."""
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


def with_pads(files, radius, folder):
    """Copies of the scenario files in `folder` with "pad": radius on every finger (docs/physics.md, "Pads")."""
    copies = []
    for f in files:
        with open(f) as src:
            d = json.load(src)
        for finger in d.get("fingers", []):
            finger["pad"] = radius
        copies.append(os.path.join(folder, os.path.basename(f)))
        with open(copies[-1], "w") as dst:
            json.dump(d, dst)
    return copies


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default=os.path.join(ROOT, "build/bin/papertear"))
    ap.add_argument("--set", action="append", default=[])
    ap.add_argument("--triangles", action="append", type=int, default=[])
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--seeds", type=int, default=0)
    ap.add_argument("--summary", action="store_true")
    ap.add_argument("--pad", type=float, default=None, help="give every finger this pad radius, m")
    ap.add_argument("scenarios", nargs="*")
    a = ap.parse_args()
    files = a.scenarios or sorted(os.path.join(ROOT, "scenarios", f) for f in os.listdir(os.path.join(ROOT, "scenarios"))
                                  if f.endswith(".json") and f != "a4-10k-patch.json")
    if a.pad is not None:
        files = with_pads(files, a.pad, tempfile.mkdtemp(prefix="paper-check-pads-"))
    jobs = []
    for f in files:
        for n in a.triangles or [None]:
            for seed in range(a.seeds) if a.seeds else [None]:
                jobs.append((f, n, seed))
    tmp = tempfile.mkdtemp(prefix="paper-check-")
    def one(job):
        f, n, seed = job
        settings = list(a.set) + ([f"sheet.triangles={n}"] if n else [])
        if seed is not None:
            settings += [f"sheet.mesh_seed={seed}", f"sheet.mesh_rotation_deg={17 * seed}"]
        out = os.path.join(tmp, os.path.basename(f)[:-5] + (f"-{n}" if n else "") + (f"-s{seed}" if seed is not None else ""))
        return job, run(a.bin, f, settings, out)
    if not a.summary:
        print(f"{'scenario':<22} {'tri':>5} {'tears':>5} {'>3mm':>4} {'pieces':>6} {'peak N':>8} {'end N':>7} {'max_strain':>10} {'>5mm':>6} {'slips':>5} {'run cm':>6} {'status':>6}")
    rows = {}
    with concurrent.futures.ThreadPoolExecutor(a.jobs) as ex:
        for (f, n, seed), r in ex.map(one, jobs):
            name = os.path.basename(f)[:-5]
            if "error" in r:
                print(f"{name:<22} {n or '':>5} error: {r['error']}")
                rows.setdefault(name, []).append(None)
                continue
            tears = r["tears"]
            long_tears = sum(1 for t in tears if tear_length(t) > 3e-3)
            peak = max((fi["max_force"] for fi in r["fingers"]), default=0)
            end = max((fi.get("force", 0) for fi in r["fingers"]), default=0)
            slips = sum(fi.get("slips", 0) for fi in r["fingers"])
            strain = r.get("max_strain", float("nan"))
            beyond = r.get("max_strain_beyond_tips", float("nan"))
            run_cm = 100 * max((t.get("max_advance_per_frame", 0) for t in tears), default=0)
            rows.setdefault(name, []).append(dict(triangles=r["mesh"]["triangles"], tears=len(tears), long=long_tears,
                                                  pieces=r["mesh"]["pieces"], peak=peak, end=end, strain=strain, beyond=beyond,
                                                  slips=slips, run=run_cm))
            if not a.summary:
                print(f"{name:<22} {r['mesh']['triangles']:>5} {len(tears):>5} {long_tears:>4} {r['mesh']['pieces']:>6} "
                      f"{peak:>8.3g} {end:>7.3g} {strain:>10.3g} {beyond:>6.3g} {slips:>5} {run_cm:>6.2g} {r['status']:>6}", flush=True)
    if a.summary:
        summarize(rows)


# The scenes that must not tear: a sheet pushed together, bent, waved or folded (docs/physics.md).
PASSIVE = {"push-together", "bent-cylinder", "waved-corners", "fold-half"}


def spread(values, fmt):
    v = sorted(values)
    return f"{fmt(v[0])}/{fmt(v[len(v) // 2])}/{fmt(v[-1])}" if v else "-"


def summarize(rows):
    print(f"{'scenario':<18} {'runs':>4} {'triangles':>14} {'tears >3mm':>10} {'pieces':>7} {'peak N min/med/max':>20} "
          f"{'max_strain %':>16} {'beyond tips %':>16} {'slips (runs)':>12} {'run cm':>15}")
    broken = {"passive > 0.3 N or torn": 0, "tearing scene > 5 N": 0, "slips": 0, "max_strain > 2%": 0,
              "beyond tips > 2%": 0, "errors": 0}
    runs = 0
    for name in sorted(rows):
        ok = [x for x in rows[name] if x]
        broken["errors"] += len(rows[name]) - len(ok)
        runs += len(rows[name])
        if not ok:
            continue
        for x in ok:
            if name in PASSIVE:
                broken["passive > 0.3 N or torn"] += x["peak"] > 0.3 or x["tears"] > 0
            else:
                broken["tearing scene > 5 N"] += x["peak"] > 5
            broken["slips"] += x["slips"] > 0
            broken["max_strain > 2%"] += x["strain"] > 0.02
            broken["beyond tips > 2%"] += x["beyond"] > 0.02
        print(f"{name:<18} {len(ok):>4} {spread([x['triangles'] for x in ok], str):>14} "
              f"{spread([x['long'] for x in ok], str):>10} {spread([x['pieces'] for x in ok], str):>7} "
              f"{spread([x['peak'] for x in ok], lambda v: f'{v:.2f}'):>20} "
              f"{spread([100 * x['strain'] for x in ok], lambda v: f'{v:.1f}'):>16} "
              f"{spread([100 * x['beyond'] for x in ok], lambda v: f'{v:.1f}'):>16} "
              f"{sum(x['slips'] for x in ok):>6} ({sum(1 for x in ok if x['slips']):>2}) "
              f"{spread([x['run'] for x in ok], lambda v: f'{v:.1f}'):>15}")
    print(f"runs {runs}; breaking: " + ", ".join(f"{k} {v}" for k, v in broken.items()))


if __name__ == "__main__":
    main()
