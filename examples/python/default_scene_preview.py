# %% [markdown]
# # The default scene from Python
#
# Reproduces `docs/images/preview.png` (the README's picture: `out/preview.png` of
# `superhelix run`) from Python: the built-in default scene — 100 wavy guides (N = 6)
# groomed over an ellipsoidal head, still for 1 s, then turned 45° each way — run for its
# 3 s, and its last frame drawn in front and side views with the head, neck and shoulders
# in grey. It prints the figures docs/performance.md gives for this run ("default
# (`src/default_scene.toml`) | 100 wavy | 6 | ... | 91 (3 s) | 4.5 s of stepping | 0.050 s
# per frame", both cores of the 2-vCPU reference machine) next to this machine's.
#
#     pip install ./python matplotlib      # from the repository's root
#     python3 examples/python/default_scene_preview.py [OUT.png]
#
# Without matplotlib it runs and prints, and skips the picture. Cells (`# %%`) run one by
# one in Jupyter or VS Code.

# %%
import pathlib
import sys
import time

import numpy as np

import superhelix

OUT = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "out/python-preview.png")

# %% [markdown]
# The scene `superhelix run` takes without a scene file (`src/default_scene.toml`), read
# and checked as `superhelix validate` checks it.

# %%
scene = superhelix.Scene.default()
check = scene.validate()
print(scene)
print(f"{check['strands']} strands, {check['steps']} steps, engine {check['engine']}")
for line in scene.groom_reports:
    print(line)

# %% [markdown]
# The run: every frame comes back as numpy arrays (`nodes`: frames × strands × points × 3,
# metres), with the summary `superhelix run` prints and the solver's counters.

# %%
started = time.perf_counter()
result = scene.run()
wall = time.perf_counter() - started
frames = result.frame_count
stepping = result.summary["wall_time"]
print(result.summary_line)
print(
    f"frames: {frames} ({result.times[-1]:.0f} s); stepping {stepping:.1f} s "
    f"({wall:.1f} s with the energies), {stepping / (frames - 1):.3f} s per frame"
)
print("docs/performance.md: 91 frames (3 s), 4.5 s of stepping, 0.050 s per frame")
stats = result.stats
print(
    f"implicit solves: {stats['attempts']} ({stats['attempts'] / (100 * scene.steps):.2f} "
    f"per strand-step), steps split: {stats['substeps']}, contacts predicted: "
    f"{stats['contacts_predicted']}"
)
deepest = result.summary["deepest_inside"]
print(f"deepest centreline point inside a body: {deepest:.2e} m")
print(
    f"energy of the hair at 3 s: kinetic {result.kinetic_energy[-1].sum():.3e} J, "
    f"potential {result.potential_energy[-1].sum():.3e} J (relative to each root)"
)

# %% [markdown]
# The picture: the last frame's centrelines, front view (x right, z up) and side view
# (y right, z up), over the bodies at the head's pose of that frame (the head is back at
# rest from 2.6 s on). The bodies are the scene's `[[bodies]]`: an ellipsoid on the head,
# a neck and shoulders fixed in the world.

# %%
def ellipse_outline(center, radii, rotation, axes, n=200):
    """Outline of an ellipsoid (center, half-axes along the columns of `rotation`)
    projected on the plane of the world axes `axes`: the image of the unit sphere's
    outline under the projected linear map."""
    m = (rotation * np.asarray(radii))[list(axes), :]  # 2 x 3
    u, s, _ = np.linalg.svd(m)
    t = np.linspace(0, 2 * np.pi, n)
    circle = np.stack([np.cos(t), np.sin(t)])
    return (u @ np.diag(s) @ circle).T + np.asarray(center)[list(axes)]


def capsule_outline(start, end, radius, axes, n=100):
    """Outline of a capsule's projection: two half circles joined."""
    a = np.asarray(start, float)[list(axes)]
    b = np.asarray(end, float)[list(axes)]
    d = b - a
    angle = np.arctan2(d[1], d[0]) if np.linalg.norm(d) > 0 else 0.0
    half = np.linspace(-np.pi / 2, np.pi / 2, n)
    cap_b = b + radius * np.stack([np.cos(angle + half), np.sin(angle + half)], 1)
    cap_a = a + radius * np.stack([np.cos(angle + np.pi + half), np.sin(angle + np.pi + half)], 1)
    return np.vstack([cap_b, cap_a, cap_b[:1]])


def bodies_of(scene):
    try:
        import tomllib
    except ImportError:  # Python < 3.11: no bodies drawn
        return []
    return tomllib.loads(scene.toml).get("bodies", [])


def draw(ax, axes, nodes, scene, t):
    x_head, r_head = scene.head_pose(t)
    for body in bodies_of(scene):
        on_head = body.get("attached", "head") == "head"
        to_world = (lambda p: x_head + r_head @ np.asarray(p)) if on_head else np.asarray
        turn = r_head if on_head else np.eye(3)
        if body["shape"] == "ellipsoid":
            outline = ellipse_outline(to_world(body.get("center", [0, 0, 0])), body["radii"], turn, axes)
        elif body["shape"] == "sphere":
            r = body["radius"]
            outline = ellipse_outline(to_world(body.get("center", [0, 0, 0])), [r, r, r], turn, axes)
        elif body["shape"] == "capsule":
            outline = capsule_outline(to_world(body["start"]), to_world(body["end"]), body["radius"], axes)
        else:
            continue
        ax.fill(outline[:, 0], outline[:, 1], color="0.85", zorder=0)
    for strand in nodes:
        ax.plot(strand[:, axes[0]], strand[:, axes[1]], color="#1f77b4", lw=0.8)
    ax.set_aspect("equal")
    ax.set_xlabel(f"{'xyz'[axes[0]]} (m)")
    ax.set_ylabel(f"{'xyz'[axes[1]]} (m)")


try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    print("matplotlib is not installed: no picture (pip install matplotlib)")
else:
    last = result.nodes[-1]
    fig, (front, side) = plt.subplots(1, 2, figsize=(10, 5.5))
    draw(front, (0, 2), last, scene, result.times[-1])
    draw(side, (1, 2), last, scene, result.times[-1])
    front.set_title("front")
    side.set_title("side")
    fig.suptitle(f"default scene at t = {result.times[-1]:.2f} s: 100 wavy guides")
    fig.tight_layout()
    OUT.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(OUT, dpi=120)
    print(f"wrote {OUT}")
