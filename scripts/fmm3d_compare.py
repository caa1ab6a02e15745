#!/usr/bin/env python3
"""Our multipole method against FMM3D (Flatiron Institute) on the same points, one run.

    pip install fmm3dpy numpy
    cargo build --release
    python3 scripts/fmm3d_compare.py [--fibres 2000] [--eps 1e-6] [--threads 1]

Hair-like particles: FIBRES curly fibres of 100 particles (30 cm, 3 mm apart) hanging
from the upper half of a sphere of radius 10 cm, charges uniform in [-1, 1]. Both codes
compute potential and gradient at every particle, on THREADS threads each, at the same
requested eps; the errors are measured against a direct sum at 2000 sampled particles.
fmm3dpy is a development tool for this comparison, not a dependency of superhelix.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

parser = argparse.ArgumentParser()
parser.add_argument("--fibres", type=int, default=2000)
parser.add_argument("--per-fibre", type=int, default=100)
parser.add_argument("--eps", type=float, default=1e-6)
parser.add_argument("--threads", type=int, default=1)
parser.add_argument("--binary", default=os.path.join(os.path.dirname(__file__), "..", "target", "release", "superhelix"))
parser.add_argument("--samples", type=int, default=2000)
parser.add_argument("--json", default=None, help="also write the results here")
args = parser.parse_args()

# FMM3D's thread count is fixed when its OpenMP runtime starts.
os.environ["OMP_NUM_THREADS"] = str(args.threads)
import numpy as np  # noqa: E402
import fmm3dpy  # noqa: E402


def curly_fibres(fibres, per_fibre, seed=7):
    rng = np.random.default_rng(seed)
    z = rng.uniform(0.0, 1.0, fibres)
    phi = rng.uniform(0.0, 2 * np.pi, fibres)
    s = np.sqrt(1 - z * z)
    normal = np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=1)
    root = 0.1 * normal
    phase = rng.uniform(0.0, 2 * np.pi, fibres)[:, None]
    radius, pitch, lead = 0.01, 0.025, 0.02
    turn = np.sqrt((2 * np.pi * radius) ** 2 + pitch**2)
    t = (np.arange(per_fibre) + 0.5) * (0.3 / per_fibre)
    u = np.maximum(t - lead, 0.0)[None, :]
    angle = phase + 2 * np.pi * u / turn
    straight = root[:, None, :] + np.minimum(t, lead)[None, :, None] * normal[:, None, :]
    helix = np.stack(
        [radius * (np.cos(angle) - np.cos(phase)), radius * (np.sin(angle) - np.sin(phase)), np.broadcast_to(-pitch * u / turn, angle.shape)],
        axis=2,
    )
    points = (straight + helix).reshape(-1, 3)
    charges = rng.uniform(-1.0, 1.0, len(points))
    return np.ascontiguousarray(points), charges


points, charges = curly_fibres(args.fibres, args.per_fibre)
n = len(points)
rng = np.random.default_rng(11)
sample = rng.choice(n, size=min(args.samples, n), replace=False)

# Direct sum at the sampled particles (kernel 1/r, self excluded).
ref_phi = np.zeros(len(sample))
ref_e = np.zeros((len(sample), 3))
for k0 in range(0, len(sample), 50):
    idx = sample[k0 : k0 + 50]
    d = points[idx][:, None, :] - points[None, :, :]
    r2 = np.einsum("ijk,ijk->ij", d, d)
    inv = np.where(r2 > 0, 1 / np.sqrt(np.where(r2 > 0, r2, 1)), 0.0)
    ref_phi[k0 : k0 + 50] = inv @ charges
    ref_e[k0 : k0 + 50] = np.einsum("ij,ijk->ik", inv**3 * charges[None, :], d)


def errors(phi, field):
    de = field[sample] - ref_e
    en = np.linalg.norm(ref_e, axis=1)
    cosang = np.einsum("ij,ij->i", field[sample], ref_e) / (np.linalg.norm(field[sample], axis=1) * en)
    return {
        "field_rel_l2": float(np.linalg.norm(de) / np.linalg.norm(ref_e)),
        "field_worst_rel": float(np.max(np.linalg.norm(de, axis=1) / en)),
        "mean_direction_error_rad": float(np.mean(np.arccos(np.clip(cosang, -1, 1)))),
        "potential_rel_l2": float(np.linalg.norm(phi[sample] - ref_phi) / np.linalg.norm(ref_phi)),
    }


results = {"particles": n, "eps": args.eps, "threads": args.threads}

# FMM3D: kernel 1/(4 pi r); potential and gradient at the sources (pg = 2).
start = time.perf_counter()
out = fmm3dpy.lfmm3d(eps=args.eps, sources=points.T.copy(order="F"), charges=charges, pg=2)
fmm3d_seconds = time.perf_counter() - start
results["fmm3dpy"] = {"seconds": fmm3d_seconds, **errors(4 * np.pi * out.pot, -4 * np.pi * out.grad.T)}

with tempfile.TemporaryDirectory() as tmp:
    np.save(os.path.join(tmp, "points.npy"), points)
    np.save(os.path.join(tmp, "charges.npy"), charges)
    cmd = [
        args.binary, "coulomb",
        "--points", os.path.join(tmp, "points.npy"),
        "--charges", os.path.join(tmp, "charges.npy"),
        "--eps", str(args.eps), "--constant", "1", "--threads", str(args.threads),
        "--out", os.path.join(tmp, "out"),
    ]
    run = subprocess.run(cmd, capture_output=True, text=True)
    if run.returncode != 0:
        sys.exit(f"superhelix coulomb failed:\n{run.stderr}")
    line = run.stdout.splitlines()[0]
    seconds = float(line.rsplit(": ", 1)[1].split(" s")[0])
    phi = np.load(os.path.join(tmp, "out", "potential.npy"))
    field = np.load(os.path.join(tmp, "out", "field.npy"))
    results["superhelix"] = {"seconds": seconds, "report": line, **errors(phi, field)}

print(f"{n} hair-like particles, eps = {args.eps}, {args.threads} thread(s)")
print(f"{'':12} {'seconds':>9} {'field rel l2':>13} {'field worst':>12} {'mean angle':>11} {'pot rel l2':>11}")
for name in ("fmm3dpy", "superhelix"):
    r = results[name]
    print(
        f"{name:12} {r['seconds']:9.3f} {r['field_rel_l2']:13.2e} {r['field_worst_rel']:12.2e} "
        f"{r['mean_direction_error_rad']:11.2e} {r['potential_rel_l2']:11.2e}"
    )
print(f"time ratio fmm3dpy / superhelix: {results['fmm3dpy']['seconds'] / results['superhelix']['seconds']:.2f}")
print(results["superhelix"]["report"])
if args.json:
    with open(args.json, "w") as f:
        json.dump(results, f, indent=2)
