"""scene.run(): shapes, the command line's frames bit for bit, stepping by hand, energies."""

import json
import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import superhelix
from conftest import SHAKING, TOUCHING, TOUCHING_EULER, hanging_strand


@pytest.fixture(scope="module")
def shaking():
    scene = superhelix.Scene.from_toml(SHAKING)
    return scene, scene.run()


def test_a_run_returns_arrays_of_the_layout(shaking):
    scene, r = shaking
    frames = scene.frame_count
    assert frames == 10  # 0.6 s at 15 fps: frames 0 .. 9
    points = [1 + 4 * n for n in scene.elements]  # samples_per_element = 4
    assert r.points.shape == (frames, sum(points), 3)
    assert r.offsets.tolist() == [0, 21, 42, 75]
    # the strands differ in N: per-strand lists
    assert isinstance(r.nodes, list) and isinstance(r.q, list)
    assert [a.shape for a in r.nodes] == [(frames, p, 3) for p in points]
    assert [a.shape for a in r.q] == [(frames, 3 * n) for n in scene.elements]
    assert [a.shape for a in r.qdot] == [(frames, 3 * n) for n in scene.elements]
    for i, a in enumerate(r.nodes):
        np.testing.assert_array_equal(a, r.points[:, r.offsets[i]:r.offsets[i + 1]])
    np.testing.assert_allclose(r.times, np.arange(frames) / 15.0, rtol=0, atol=1e-15)
    assert r.kinetic_energy.shape == r.potential_energy.shape == (frames, 3)
    for a in [r.points, r.times, r.state_times, r.kinetic_energy, r.potential_energy,
              *r.q, *r.qdot]:
        assert np.all(np.isfinite(a))
    assert r.strand_names == ["wavy", "curly", "smooth"]
    assert r.engine == "embedded" and r.completed
    s = r.summary
    assert (s["steps"], s["strands"], s["frames"], s["planned_frames"]) == (18, 3, 10, 10)
    assert s["error_control"] is None and r.frame_steps is None
    assert s["coulomb"] is None  # no [electrostatics]
    assert r.stats["attempts"] >= 3 * 18  # at least one solve per strand and step
    assert r.summary_line.startswith("18 steps x 3 strands in ")
    # roots stay on the head: the root of each strand moves on its circle (|x_root| const)
    for i in range(3):
        radius = np.linalg.norm(r.points[:, r.offsets[i], :2], axis=1)
        np.testing.assert_allclose(radius, radius[0], rtol=1e-12)


def test_shared_sizes_give_4d_nodes():
    scene = superhelix.Scene.from_dict(hanging_strand())
    r = scene.run(frames=5)
    assert r.nodes.shape == (5, 1, 21, 3)
    assert r.q.shape == r.qdot.shape == (5, 1, 15)
    np.testing.assert_array_equal(r.nodes[:, 0], r.points)


def run_cli(cli, tmp_path, text, *extra):
    path = tmp_path / "scene.toml"
    path.write_text(text)
    out_dir = tmp_path / "out"
    done = cli("run", path, "--out", out_dir, "--format", "npy", *extra)
    assert done.returncode == 0, done.stderr
    return out_dir, done.stdout


@pytest.mark.parametrize(
    "text",
    [SHAKING, TOUCHING_EULER, TOUCHING],
    ids=["embedded", "embedded-contacts", "runtime-contacts"],
)
def test_frames_match_the_command_lines_frames_npy_bit_for_bit(cli, tmp_path, text):
    out_dir, stdout = run_cli(cli, tmp_path, text)
    r = superhelix.Scene.from_toml(text).run(energies=False)
    frames = np.load(out_dir / "frames.npy")
    times = np.load(out_dir / "frames.times.npy")
    index = json.load(open(out_dir / "frames.index.json"))
    assert frames.dtype == np.float32
    # frames.npy is the float32 rounding of the f64 centrelines: equal to the bit
    np.testing.assert_array_equal(frames, r.points.astype(np.float32))
    np.testing.assert_array_equal(times[:, 0], r.times)
    np.testing.assert_array_equal(times[:, 1], r.state_times)
    assert [s["name"] for s in index["strands"]] == r.strand_names
    assert [s["radius"] for s in index["strands"]] == r.radii.tolist()
    # the summary line names the same steps and frames
    line = [l for l in stdout.splitlines() if " steps x " in l][0]
    assert line.split(" in ")[0] == r.summary_line.split(" in ")[0]


def test_error_controlled_frames_and_reports_match_the_command_line(cli, tmp_path):
    text = SHAKING
    out_dir, _ = run_cli(cli, tmp_path, text, "--tolerance", "1e-3")
    r = superhelix.Scene.from_toml(text).run(tolerance=1e-3, energies=False)
    np.testing.assert_array_equal(np.load(out_dir / "frames.npy"), r.points.astype(np.float32))
    np.testing.assert_array_equal(np.load(out_dir / "frames.steps.npy"), r.frame_steps)
    np.testing.assert_array_equal(np.load(out_dir / "strand_steps.npy"), r.strand_steps)
    e = r.summary["error_control"]
    assert e["tolerance"] == 1e-3 and 0 < e["largest_error"] <= 1e-3
    assert e["steps"] == r.frame_steps[:, 1].sum() == r.strand_steps[:, 0].sum()


def test_stepping_by_hand_gives_the_runs_states(shaking):
    scene, r = shaking
    sim = scene.simulation()
    assert sim.dt == scene.dt and sim.time == 0.0
    # output_fps = 15 at dt = 1/30: frame k is the state after 2k steps
    for k in range(scene.frame_count):
        if k:
            sim.step(steps=2)
        q, qdot = sim.q, sim.qdot
        for i in range(3):
            np.testing.assert_array_equal(q[i], r.q[i][k])
            np.testing.assert_array_equal(qdot[i], r.qdot[i][k])
        nodes = sim.nodes()
        for i in range(3):
            np.testing.assert_array_equal(nodes[i], r.nodes[i][k])
        assert sim.time == r.state_times[k]
    assert sim.steps_taken == 18
    assert sim.stats() == r.stats
    with pytest.raises(ValueError, match="^dt: this simulation steps by dt"):
        sim.step(0.01)
    sim.step(scene.dt)  # the simulation's own dt is accepted


@pytest.mark.parametrize(
    "text, engine", [(TOUCHING_EULER, "embedded"), (TOUCHING, "runtime")]
)
def test_an_engine_with_contacts_by_hand_matches_its_run(text, engine):
    scene = superhelix.Scene.from_toml(text)
    r = scene.run(frames=6)
    sim = scene.simulation()
    assert sim.engine == r.engine == engine
    sim.step(steps=5)
    np.testing.assert_array_equal(sim.q, r.q[5])
    np.testing.assert_array_equal(sim.qdot, r.qdot[5])
    # energies measured on the side leave the stepping simulation alone
    e = sim.energies()
    np.testing.assert_array_equal(e["kinetic"], r.kinetic_energy[5])
    np.testing.assert_array_equal(e["potential"], r.potential_energy[5])
    sim.step()
    again = scene.simulation()
    again.step(steps=6)
    np.testing.assert_array_equal(sim.q, again.q)


def test_energy_never_grows_on_a_still_head():
    """A strand released from 1.5 x its natural curvature under gravity on a still head:
    friction and drag dissipate, the checked step's energy balance forbids any gain, so the
    total energy (kinetic + elastic + gravity) falls monotonically from its start."""
    d = hanging_strand()
    d["strands"][0]["q0"] = [1.5 * x for x in [21.72, 163.8, 0.0] * 5]
    r = superhelix.Scene.from_dict(d).run()
    e = r.energy[:, 0]
    assert r.kinetic_energy[0, 0] == 0.0  # released at rest
    assert np.all(r.kinetic_energy >= 0.0)
    assert np.all(np.diff(e) <= 1e-12 * abs(e[0])), np.diff(e).max()
    # and it does fall: most of the energy released is dissipated within the second
    # (measured: all of it, the strand near rest)
    assert e[0] - e[-1] > 0.5 * abs(e[0])


def test_simulation_error_names_the_strand_and_the_state_stays():
    sim = superhelix.Scene.from_toml(SHAKING).simulation()
    sim.set_state(1, np.full(15, 1e300))
    with pytest.raises(superhelix.SimulationError, match=r"^strand 'curly' \(index 1\) failed at t = "):
        sim.step()
    with pytest.raises(IndexError):
        sim.set_state(3, np.zeros(15))
    with pytest.raises(ValueError, match=r"^q: expected 15 values"):
        sim.set_state(0, np.zeros(14))


def test_a_run_releases_the_gil():
    """Another Python thread runs while scene.run() computes: the main thread's 10 ms
    sleeps go on (with the GIL held they could not return until the run ended)."""
    scene = superhelix.Scene.from_toml(SHAKING)
    done = threading.Event()
    results = []

    def run():
        results.append(scene.run(duration=10.0, energies=False))
        done.set()

    worker = threading.Thread(target=run)
    started = time.perf_counter()
    worker.start()
    ticks = 0
    while not done.is_set():
        time.sleep(0.01)
        ticks += 1
    worker.join()
    elapsed = time.perf_counter() - started
    assert results and results[0].completed
    # a run of 150 steps of 3 strands takes about a second; ticks go on all along
    assert ticks >= min(10, elapsed / 0.02), (ticks, elapsed)


@pytest.mark.skipif(not hasattr(signal, "SIGINT") or os.name != "posix", reason="POSIX signals")
def test_ctrl_c_stops_a_run_and_keeps_its_frames():
    # a process started as a background job (`cmd &` in a script, as CI may run the tests)
    # inherits SIGINT ignored, and Python then leaves it ignored: the child takes
    # Python's own handler back, as an interactive session has it
    script = f"""
import signal, sys, superhelix
signal.signal(signal.SIGINT, signal.default_int_handler)
scene = superhelix.Scene.from_toml({SHAKING!r})
print("started", flush=True)
try:
    scene.run(duration=1000.0, energies=False)
    print("not interrupted")
except KeyboardInterrupt as e:
    r = e.result
    print("interrupted", r.completed, r.frame_count, r.points.shape[0], flush=True)
"""
    child = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    assert child.stdout.readline().strip() == "started"
    time.sleep(1.0)
    child.send_signal(signal.SIGINT)
    out, _ = child.communicate(timeout=60)
    words = out.split()
    assert words[:2] == ["interrupted", "False"], out
    frames = int(words[2])
    assert 1 <= frames < 15001 and int(words[3]) == frames


ROPE = """
[simulation]
dt = 0.01
duration = 0.2
output_fps = 50
[output]
nodes = 11
[[strands]]
name = "rope"
elements = 10
youngs_modulus = 1e7
polyline = [[0.0, 0.0, 0.0], [0.1, 0.0, -0.05], [0.2, 0.0, -0.07], [0.3, 0.0, -0.05], [0.4, 0.0, 0.0]]
[strands.ends]
root = "pinned"
[strands.ends.tip]
kind = "pinned"
position = [0.4, 0.0, 0.0]
"""


def test_a_held_rope_reports_its_holder_and_its_nodes():
    # a rope pinned at both ends, fitted to a polyline, written at 11 even nodes: the
    # holder's report and the nodes as the command line writes them
    r = superhelix.Scene.from_toml(ROPE).run(energies=False)
    frames = len(r.times)
    assert frames == 11
    assert r.held_tips == [0]
    assert r.held.shape == (frames, 1, 7)
    assert np.all(r.held[:, 0, 0] <= 1e-9)          # drift, over L
    assert np.all(r.held[1:, 0, 1] > 0.0)            # the rope pulls its tip inwards
    assert r.arc_nodes.shape == (frames, 1, 11, 3)
    assert r.d1.shape == (frames, 1, 10, 3)
    np.testing.assert_allclose(np.linalg.norm(r.d1, axis=-1), 1.0, atol=1e-12)
    # the nodes are evenly spaced along the rope: each chord at most the arc between
    chords = np.linalg.norm(np.diff(r.arc_nodes[-1, 0], axis=0), axis=-1)
    length = 0.4 * 1.0  # at least the span; the fitted length is in the scene report
    assert np.all(chords <= chords.sum() / 10 * 1.01)
    np.testing.assert_allclose(r.arc_nodes[:, 0, 0], 0.0, atol=1e-9)
    np.testing.assert_allclose(r.arc_nodes[:, 0, -1], [[0.4, 0.0, 0.0]] * frames, atol=1e-9)
    assert chords.sum() > length
    # a scene without them has none
    plain = superhelix.Scene.from_toml("[simulation]\nduration = 0.1\n[[strands]]\nlength = 0.1\n")
    r = plain.run(energies=False)
    assert r.held is None and r.arc_nodes is None and r.d1 is None and r.held_tips == []


def test_a_pinned_roots_whole_q_continues_a_run():
    # a pinned root's q has 3N + 3 entries (the root joint's first): fed back as q0 it
    # starts the rod exactly where the run left it
    d = hanging_strand()
    d["strands"][0]["ends"] = {"root": "pinned"}
    r = superhelix.Scene.from_dict(d).run(frames=5)
    q = r.q[-1, 0]
    assert q.shape == (3 * 5 + 3,)
    d["strands"][0]["q0"] = [float(x) for x in q]
    again = superhelix.Scene.from_dict(d).run(frames=1)
    np.testing.assert_array_equal(again.q[0, 0], q)
    np.testing.assert_allclose(again.points[0], r.points[-1], atol=1e-12)


def test_scenes_and_results_pickle():
    # a scene travels to a process pool's worker as its text; a result with its arrays
    import pickle

    scene = superhelix.Scene.from_dict(hanging_strand())
    copy = pickle.loads(pickle.dumps(scene))
    assert copy.toml == scene.toml
    r = scene.run(frames=3)
    back = pickle.loads(pickle.dumps(r))
    for name in ["times", "state_times", "points", "offsets", "nodes", "q", "qdot",
                 "kinetic_energy", "potential_energy", "energy", "radii"]:
        np.testing.assert_array_equal(getattr(back, name), getattr(r, name), err_msg=name)
    assert back.strand_names == r.strand_names and back.groups == r.groups
    assert back.summary == r.summary and back.stats == r.stats
    assert back.summary_line == r.summary_line and back.engine == r.engine
    assert back.completed and back.frame_count == 3
    # the unpickled scene runs to the same frames
    np.testing.assert_array_equal(copy.run(frames=3).points, r.points)


def test_gravity_set_between_static_solves_bends_a_cantilever_by_beam_theory():
    # a clamped steel-like rod held horizontal (L = 0.2 m, r = 1 mm, E = 200 GPa): its
    # tip sinks by w L^4 / (8 EI) under its weight w (Euler-Bernoulli; here 3.1e-4 m,
    # 0.15 % of L, so the geometric nonlinearity is ~1e-6). The Super-Helix model with
    # N = 10 elements is within 1 % of it, short by its discretisation's 1/(3 N^2); twice
    # the gravity set between two static solves doubles the sag (to 1e-4), and none puts
    # the tip back on the axis
    d = hanging_strand()
    strand = d["strands"][0]
    strand.update({"direction": [1.0, 0.0, 0.0], "normal": [0.0, 0.0, 1.0], "elements": 10,
                   "radius": 1e-3, "youngs_modulus": 2e11, "poisson": 0.3,
                   "density": 7800.0, "natural": [0.0, 0.0, 0.0], "initial": "straight",
                   "internal_friction": 0.0, "air_drag": 0.0})
    sim = superhelix.Scene.from_dict(d).simulation()
    np.testing.assert_array_equal(sim.gravity, [0.0, 0.0, -9.81])
    L, r, E, rho = 0.2, 1e-3, 2e11, 7800.0
    EI = E * np.pi * r**4 / 4
    w = rho * np.pi * r**2 * 9.81

    def sag():
        reports = sim.solve_static()
        assert all(rep["converged"] for rep in reports)
        return -sim.nodes()[0, -1, 2]

    one = sag()
    # measured: -0.3335 %, the piecewise-constant curvature's -1/(3 N^2) = -0.3333 %
    ratio = one / (w * L**4 / (8 * EI))
    assert abs(ratio - 1) < 0.01 and abs(ratio - (1 - 1 / (3 * 10**2))) < 1e-4, ratio
    sim.set_gravity([0.0, 0.0, -2 * 9.81])
    two = sag()
    assert abs(two / one - 2) < 1e-4, two / one
    sim.set_gravity(None)
    assert sim.gravity is None
    assert abs(sag()) < 1e-12
    with pytest.raises(ValueError, match="gravity"):
        sim.set_gravity([0.0, float("nan"), 0.0])
