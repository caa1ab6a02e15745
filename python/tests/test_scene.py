"""Scenes from TOML text, files and dicts; validation; errors as the command line gives them."""

import math
import pathlib

import numpy as np
import pytest

import superhelix
from conftest import REPO, SHAKING, hanging_strand


def test_import_names_the_api():
    for name in ("Scene", "Simulation", "RunResult", "Batch", "StepReport",
                 "SceneError", "SimulationError", "StepError", "supported_elements"):
        assert hasattr(superhelix, name), name
    assert issubclass(superhelix.SceneError, ValueError)
    assert issubclass(superhelix.SimulationError, RuntimeError)
    assert issubclass(superhelix.StepError, RuntimeError)
    assert superhelix.Scene.__module__ == "superhelix"
    assert superhelix.Scene.run.__doc__ and superhelix.Batch.__doc__
    # the checked-in fixed-N sizes (generated/src): 1 to 20 at least include 5 and 10
    sizes = superhelix.supported_elements()
    assert {5, 6, 8, 10}.issubset(sizes), sizes


def test_a_scene_from_a_dict_is_the_scene_of_its_toml_text():
    d = hanging_strand()
    from_dict = superhelix.Scene.from_dict(d)
    from_text = superhelix.Scene.from_toml(from_dict.toml)
    for scene in (from_dict, from_text):
        assert scene.strand_names == ["fibre"]
        assert scene.elements == [5]
        assert scene.dt == 1.0 / 30.0
        assert scene.steps == 30
        assert scene.frame_count == 31
        assert scene.engine == "embedded"
    report = from_dict.validate()
    assert report["strands"] == 1 and report["steps"] == 30
    assert report["engine"] == "embedded" and report["engine_reason"] is None
    assert report["output"].startswith("output: ")
    # the same runs: the dict's text is the scene
    a, b = from_dict.run(energies=False), from_text.run(energies=False)
    np.testing.assert_array_equal(a.points, b.points)


def test_dict_values_numpy_and_tuples_convert_and_none_is_refused():
    d = hanging_strand()
    d["strands"][0]["root"] = np.zeros(3)
    d["strands"][0]["direction"] = (0.0, 0.0, -1.0)
    d["strands"][0]["elements"] = np.int64(5)
    scene = superhelix.Scene.from_dict(d)
    assert scene.elements == [5]
    d["strands"][0]["seed"] = None
    with pytest.raises(TypeError, match=r"^strands\[0\]\.seed: None has no TOML value"):
        superhelix.Scene.from_dict(d)
    with pytest.raises(TypeError, match="keys must be strings"):
        superhelix.Scene.from_dict({1: 2})


def test_a_scene_from_a_file_resolves_paths_against_its_folder(tmp_path):
    path = tmp_path / "shaking.toml"
    path.write_text(SHAKING)
    scene = superhelix.Scene.from_file(path)
    assert scene.strand_names == ["wavy", "curly", "smooth"]
    assert scene.elements == [5, 5, 8]
    assert scene.base_dir == tmp_path
    assert scene.validate()["strands"] == 3
    # a scene with a mesh body beside it: the relative path is the file's folder's
    mesh_scene = REPO / "scenes" / "imported-curves.toml"
    if mesh_scene.exists():
        assert superhelix.Scene.from_file(mesh_scene).strand_count > 0
    with pytest.raises(FileNotFoundError, match="nothing.toml"):
        superhelix.Scene.from_file(tmp_path / "nothing.toml")


def test_the_default_scene_is_the_commands():
    scene = superhelix.Scene.default()
    assert scene.strand_count == 100
    assert set(scene.elements) == {6}
    assert scene.steps == 90 and scene.frame_count == 91
    # bodies and hair-hair contacts on the fixed-N step
    assert scene.engine == "embedded"
    assert scene.validate()["engine_reason"] is None


BAD = """
[simulation]
dt = -0.1
duration = 1.0

[[strands]]
length = -0.2
elements = 5
colour = "red"
"""


def expected_problems():
    # written from docs/scene-format.md's ranges: dt in (0, 1], length in (0, 100]
    return [
        ("simulation.dt", "must be in (0, 1], got -0.1"),
        ("strands[0].length", "must be in (0, 100], got -0.2"),
    ]


def test_a_bad_scene_raises_scene_error_with_every_problem():
    with pytest.raises(superhelix.SceneError) as info:
        superhelix.Scene.from_toml(BAD)
    e = info.value
    assert isinstance(e, ValueError)
    fields = [f for f, _ in e.problems]
    assert fields == ["simulation.dt", "strands[0].length", "strands[0].colour"]
    assert e.problems[:2] == expected_problems()
    assert str(e).splitlines()[:2] == [f"{f}: {m}" for f, m in expected_problems()]
    assert str(e).splitlines()[2].startswith("strands[0].colour: unknown field")


def validate_stderr(cli, path):
    """What `superhelix validate PATH` prints on stderr before its count line."""
    out = cli("validate", path)
    assert out.returncode == 1, out
    lines = out.stderr.rstrip("\n").splitlines()
    assert lines[-1] == f"{path}: {len(lines) - 1} problem(s)"
    return "\n".join(lines[:-1])


@pytest.mark.parametrize(
    "text",
    [
        BAD,
        "[simulation\ndt = 1",  # a syntax error: the field <toml>, line and column
        SHAKING.replace('preset = "curly"', 'preset = "frizzy"'),
        # parsed, refused when the simulation is built: no strands
        "[simulation]\ndt = 0.01\n",
    ],
)
def test_scene_error_text_is_what_validate_prints(cli, tmp_path, text):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(superhelix.SceneError) as from_file:
        superhelix.Scene.from_file(path).validate()
    assert str(from_file.value) == validate_stderr(cli, path)
    with pytest.raises(superhelix.SceneError) as from_text:
        superhelix.Scene.from_toml(text).validate()
    assert str(from_text.value) == str(from_file.value)


def test_syntax_error_names_line_and_column():
    with pytest.raises(superhelix.SceneError) as info:
        superhelix.Scene.from_toml("[simulation\ndt = 1")
    assert info.value.problems[0][0] == "<toml>"
    assert str(info.value).startswith("<toml>: line 1, column ")


def test_run_overrides_are_checked():
    scene = superhelix.Scene.from_dict(hanging_strand())
    with pytest.raises(ValueError, match="^duration: must be finite"):
        scene.run(duration=-1.0)
    with pytest.raises(ValueError, match="^duration, frames: give one"):
        scene.run(duration=1.0, frames=3)
    with pytest.raises(ValueError, match=r"^dt: must be in \(0, 1\]"):
        scene.simulation(dt=math.inf)
    with pytest.raises(superhelix.SceneError, match="^simulation.tolerance: must be in"):
        scene.run(tolerance=2.0)
    assert scene.run(frames=4, energies=False).points.shape[0] == 4
    with pytest.raises(ValueError, match=r"^duration / dt = 30000000 steps, more than the cap"):
        scene.run(duration=1e6)
    coarse = superhelix.Scene.from_dict(hanging_strand(simulation={"dt": 1.0}))
    with pytest.raises(ValueError, match=r"^duration \* output_fps = 3000000 frames, more than"):
        coarse.run(duration=1e5)
    # 31 frames of 21 points: 31 * (3 * 21 + 2 * 15 + 3) * 8 * 2 bytes = 47616
    with pytest.raises(ValueError, match=r"^max_bytes: the run's arrays would take about 4\.762e4 bytes"):
        scene.run(max_bytes=4e4)
    assert scene.run(max_bytes=4.8e4).completed
