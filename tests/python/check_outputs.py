"""Open the outputs a killed `superhelix run` left in each folder given: frames.npy and
frames.times.npy with numpy, frames.json (when present) with Python's json module,
hair.usda (when present) with pxr. Prints one line per folder; exit 1 when a file does
not open or its frame counts disagree, 2 when numpy or pxr is missing."""

import json
import os
import sys

try:
    import numpy as np
    from pxr import Usd, UsdGeom
except ImportError as e:  # the check cannot run
    print(f"cannot import: {e}: pip install numpy usd-core")
    sys.exit(2)

failed = False
for d in sys.argv[1:]:
    seen = []
    try:
        points = np.load(os.path.join(d, "frames.npy"))
        times = np.load(os.path.join(d, "frames.times.npy"))
        assert points.ndim == 3 and points.shape[2] == 3, points.shape
        assert np.isfinite(points).all(), "non-finite point"
        # a frame counts once its points are published, its time first
        assert times.shape[0] >= points.shape[0], (times.shape, points.shape)
        seen.append(f"npy {points.shape[0]} frames")
        path = os.path.join(d, "frames.json")
        if os.path.exists(path):
            with open(path) as f:
                frames = json.load(f)["frames"]
            seen.append(f"json {len(frames)} frames")
        path = os.path.join(d, "hair.usda")
        if os.path.exists(path):
            stage = Usd.Stage.Open(path)
            assert stage is not None, "pxr cannot open it"
            curves = [p for p in stage.Traverse() if p.IsA(UsdGeom.BasisCurves)]
            assert curves, "no curves"
            seen.append(f"usda {len(curves)} curves")
        print(f"{d}: {', '.join(seen)}")
    except Exception as e:  # report every folder
        failed = True
        print(f"{d}: FAILED: {e!r}")
sys.exit(1 if failed else 0)
