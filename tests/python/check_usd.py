#!/usr/bin/env python3
"""Check OUTDIR/hair.usda with a real USD reader against OUTDIR/frames.npy.

Usage: python3 tests/python/check_usd.py OUTDIR

Opens the stage with pxr.Usd, checks its time metadata, that every strand group of
OUTDIR/frames.index.json is a BasisCurves prim under /hair with linear curves, one curve
per strand with the strand's point count (their sum is the frame's point count), widths
of 2 x radius per point, and that the points at the first, middle and last time codes
equal frames.npy to 1e-6 m. When OUTDIR/render/frames.npy exists (the render strands,
float32 [frames, R * M, 3]), /hair also holds a last BasisCurves prim "render" of R linear
curves of M points each, one constant width, one colour per curve, whose points at the
same time codes equal that file to 1e-6 m. Prints a summary; exits 1 on any failure, 2
when pxr or numpy is missing.
"""

import json
import os
import sys

try:
    import numpy as np
    from pxr import Usd, UsdGeom
except ImportError as e:  # pragma: no cover - depends on the machine
    print(f"check_usd: {e}: run `pip install usd-core numpy`", file=sys.stderr)
    sys.exit(2)

TOLERANCE = 1e-6  # m


def main(outdir):
    failures = []
    index = json.load(open(os.path.join(outdir, "frames.index.json")))
    frames = np.load(os.path.join(outdir, "frames.npy"))
    strands = index["strands"]
    total = sum(s["points"] for s in strands)
    if frames.ndim != 3 or frames.shape[1:] != (total, 3):
        failures.append(f"frames.npy has shape {frames.shape}, expected (n, {total}, 3)")
        return report(failures, 0, 0)
    count = frames.shape[0]
    offsets = np.concatenate([[0], np.cumsum([s["points"] for s in strands])])

    stage = Usd.Stage.Open(os.path.join(outdir, "hair.usda"))
    if stage is None:
        return report(["pxr.Usd cannot open hair.usda"], 0, 0)
    if UsdGeom.GetStageUpAxis(stage) != UsdGeom.Tokens.z:
        failures.append(f"upAxis is {UsdGeom.GetStageUpAxis(stage)}, expected Z")
    if UsdGeom.GetStageMetersPerUnit(stage) != 1.0:
        failures.append(f"metersPerUnit is {UsdGeom.GetStageMetersPerUnit(stage)}")
    if stage.GetStartTimeCode() != 0 or stage.GetEndTimeCode() != count - 1:
        failures.append(
            f"time codes {stage.GetStartTimeCode()}..{stage.GetEndTimeCode()}, expected 0..{count - 1}"
        )
    if abs(stage.GetTimeCodesPerSecond() - index["output_fps"]) > 1e-9:
        failures.append(f"timeCodesPerSecond {stage.GetTimeCodesPerSecond()} != output_fps")

    groups = []
    for s in strands:
        if s["group"] not in groups:
            groups.append(s["group"])
    hair = stage.GetPrimAtPath("/hair")
    prims = [p for p in hair.GetChildren()] if hair else []
    render_file = os.path.join(outdir, "render", "frames.npy")
    times = sorted({0, (count - 1) // 2, count - 1})
    render_note = ""
    if os.path.exists(render_file):
        if prims and prims[-1].GetName() == "render":
            render_note, render_worst = check_render(prims.pop(), np.load(render_file), times, failures)
        else:
            failures.append("no render prim last under /hair")
    if len(prims) != len(groups):
        failures.append(f"/hair has {len(prims)} children, expected one per group ({len(groups)})")
    curve_points = 0
    worst = 0.0
    for prim, group in zip(prims, groups):
        if prim.GetTypeName() != "BasisCurves":
            failures.append(f"{prim.GetPath()} is a {prim.GetTypeName()}, expected BasisCurves")
            continue
        curves = UsdGeom.BasisCurves(prim)
        members = [i for i, s in enumerate(strands) if s["group"] == group]
        if curves.GetTypeAttr().Get() != "linear":
            failures.append(f"{prim.GetPath()}: type {curves.GetTypeAttr().Get()}, expected linear")
        counts = list(curves.GetCurveVertexCountsAttr().Get())
        if counts != [strands[i]["points"] for i in members]:
            failures.append(f"{prim.GetPath()}: curveVertexCounts {counts} do not match the index")
        curve_points += sum(counts)
        widths = np.array(curves.GetWidthsAttr().Get())
        expected_w = np.concatenate([np.full(strands[i]["points"], 2 * strands[i]["radius"]) for i in members])
        if widths.shape != expected_w.shape or np.max(np.abs(widths - expected_w)) > 1e-6 * np.max(expected_w):
            failures.append(f"{prim.GetPath()}: widths are not 2 x radius per point")
        if curves.GetWidthsInterpolation() != UsdGeom.Tokens.vertex:
            failures.append(f"{prim.GetPath()}: widths interpolation {curves.GetWidthsInterpolation()}")
        expected_all = np.concatenate([frames[:, offsets[i]:offsets[i + 1], :] for i in members], axis=1)
        for t in times:
            got = np.array(curves.GetPointsAttr().Get(Usd.TimeCode(t)), dtype=np.float64)
            want = expected_all[t].astype(np.float64)
            if got.shape != want.shape:
                failures.append(f"{prim.GetPath()} at time {t}: {got.shape} points, expected {want.shape}")
                continue
            err = float(np.max(np.abs(got - want))) if got.size else 0.0
            worst = max(worst, err)
            if err > TOLERANCE:
                failures.append(f"{prim.GetPath()} at time {t}: points differ from frames.npy by {err:.3e} m")
    if curve_points != total:
        failures.append(f"curveVertexCounts sum to {curve_points}, frames.index.json has {total} points")
    return report(failures, len(prims), worst, count, times, render_note)


def check_render(prim, expected, times, failures):
    """The render prim against the render strands of render/frames.npy."""
    if prim.GetTypeName() != "BasisCurves":
        failures.append(f"{prim.GetPath()} is a {prim.GetTypeName()}, expected BasisCurves")
        return "", 0.0
    curves = UsdGeom.BasisCurves(prim)
    if curves.GetTypeAttr().Get() != "linear":
        failures.append(f"{prim.GetPath()}: type {curves.GetTypeAttr().Get()}, expected linear")
    counts = list(curves.GetCurveVertexCountsAttr().Get())
    total = expected.shape[1]
    if not counts or len(set(counts)) != 1 or sum(counts) != total:
        failures.append(f"{prim.GetPath()}: {len(counts)} curves of {set(counts)} points, expected {total} points in equal curves")
    widths = np.array(curves.GetWidthsAttr().Get())
    if widths.shape != (1,) or curves.GetWidthsInterpolation() != UsdGeom.Tokens.constant or not widths[0] > 0:
        failures.append(f"{prim.GetPath()}: expected one constant width > 0, got {widths} ({curves.GetWidthsInterpolation()})")
    colours = curves.GetDisplayColorPrimvar()
    if len(colours.Get()) != len(counts) or colours.GetInterpolation() != UsdGeom.Tokens.uniform:
        failures.append(f"{prim.GetPath()}: expected one colour per curve")
    worst = 0.0
    for t in times:
        got = np.array(curves.GetPointsAttr().Get(Usd.TimeCode(t)), dtype=np.float64)
        want = expected[t].astype(np.float64)
        if got.shape != want.shape:
            failures.append(f"{prim.GetPath()} at time {t}: {got.shape} points, expected {want.shape}")
            continue
        err = float(np.max(np.abs(got - want)))
        worst = max(worst, err)
        if err > TOLERANCE:
            failures.append(f"{prim.GetPath()} at time {t}: render points differ by {err:.3e} m")
    return f", render prim: {len(counts)} curves of {counts[0] if counts else 0} points, max |usd - npy| = {worst:.3e} m", worst


def report(failures, prims, worst, count=0, times=(), render_note=""):
    for f in failures:
        print(f"FAIL {f}")
    status = "FAILED" if failures else "ok"
    print(
        f"check_usd: {status}: {prims} BasisCurves prims, {count} frames, "
        f"time codes {list(times)} checked, max |usd - npy| = {worst:.3e} m{render_note}"
    )
    return 1 if failures else 0


if __name__ == "__main__":
    if len(sys.argv) != 2:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    sys.exit(main(sys.argv[1]))
