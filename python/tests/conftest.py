"""Shared fixtures of the Python module's tests: the repository, the CLI binary, scenes."""

import os
import pathlib
import subprocess

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]


def cli_binary():
    """The release `superhelix` command built from this checkout (`cargo build --release`,
    or `cargo test --workspace --release` as .ci/run runs it), or $SUPERHELIX_BIN."""
    path = os.environ.get("SUPERHELIX_BIN") or str(REPO / "target" / "release" / "superhelix")
    return pathlib.Path(path)


@pytest.fixture
def cli():
    """A function running the CLI with arguments, returning the CompletedProcess; the test
    is skipped when the release binary has not been built, and fails instead under
    SUPERHELIX_REQUIRE_TOOLS=1 (as .ci/run sets it): a comparison that cannot run there
    must not pass silently."""
    binary = cli_binary()
    if not binary.exists():
        if os.environ.get("SUPERHELIX_REQUIRE_TOOLS") == "1":
            pytest.fail(
                f"{binary} not built and SUPERHELIX_REQUIRE_TOOLS=1: build it first "
                "(`cargo build --release`) or set SUPERHELIX_BIN"
            )
        pytest.skip(
            f"{binary} not built: run `cargo build --release` (or set SUPERHELIX_BIN) "
            "for the comparisons with the command line"
        )

    def run(*args):
        return subprocess.run(
            [str(binary), *map(str, args)], capture_output=True, text=True, timeout=600
        )

    return run


def hanging_strand(**extra):
    """A scene of one strand hanging from a still head under gravity (the C example's
    fibre: 20 cm, N = 5, r = 50 µm, E = 1.5 GPa), 1 s at dt = 1/30 s."""
    strand = {
        "name": "fibre",
        "root": [0.0, 0.0, 0.0],
        "direction": [0.0, 0.0, -1.0],
        "normal": [1.0, 0.0, 0.0],
        "length": 0.2,
        "elements": 5,
        "radius": 50e-6,
        "ellipticity": 1.0,
        "youngs_modulus": 1.5e9,
        "poisson": 0.48,
        "density": 1300.0,
        "natural": [21.72, 163.8, 0.0],
        "internal_friction": 5e-11,
        "air_drag": 5e-6,
    }
    scene = {
        "simulation": {"dt": 1.0 / 30.0, "duration": 1.0, "output_fps": 30.0},
        "environment": {"gravity": [0.0, 0.0, -9.81]},
        "strands": [strand],
    }
    for table, values in extra.items():
        scene.setdefault(table, {}).update(values)
    return scene


# Three strands of three presets and two sizes on a head shaking at 2 Hz by ±30°, under
# gravity: the embedded engine under engine = "auto". Frames every other step.
SHAKING = """
[simulation]
dt = 0.03333333333333333
duration = 0.6
output_fps = 15

[environment]
gravity = [0.0, 0.0, -9.81]

[head]
motion = { kind = "oscillate", axis = [0.0, 0.0, 1.0], angle_deg = 30.0, frequency_hz = 2.0 }

[[strands]]
name = "wavy"
root = [0.0, 0.05, 0.0]
direction = [0.0, 0.3, -1.0]
length = 0.2
elements = 5
preset = "wavy"

[[strands]]
name = "curly"
root = [0.0, -0.05, 0.0]
direction = [0.0, -0.3, -1.0]
length = 0.15
elements = 5
preset = "curly"

[[strands]]
name = "smooth"
root = [-0.05, 0.0, 0.0]
direction = [-1.0, 0.0, -0.2]
length = 0.25
elements = 8
preset = "smooth"
"""

# Two strands resting on a sphere on a nodding head, with body and hair-hair contacts and
# BDF2, on the runtime engine (named).
# TOUCHING_EULER: the same scene by linearly implicit Euler, on the engine `auto` gives it
# (the embedded one).
TOUCHING = """
[simulation]
dt = 0.03333333333333333
duration = 0.5
output_fps = 30
integrator = "bdf2"
engine = "runtime"

[environment]
gravity = [0.0, 0.0, -9.81]

[head]
motion = { kind = "oscillate", axis = [1.0, 0.0, 0.0], angle_deg = 20.0, frequency_hz = 1.0 }

[[bodies]]
name = "head"
shape = "sphere"
radius = 0.09

[contacts]
radius = 0.002

[contacts.hair_hair]
radius = 0.002

[[strands]]
name = "a"
root = [0.0, 0.0, 0.092]
direction = [1.0, 0.0, 0.2]
length = 0.2
elements = 6
preset = "wavy"

[[strands]]
name = "b"
root = [0.0, 0.03, 0.088]
direction = [-1.0, 0.3, 0.2]
length = 0.18
elements = 6
preset = "smooth"
"""

TOUCHING_EULER = TOUCHING.replace(
    'integrator = "bdf2"\nengine = "runtime"', 'integrator = "linearly-implicit-euler"'
)
