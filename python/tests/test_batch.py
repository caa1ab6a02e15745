"""superhelix.Batch: the embedded fixed-N step with the head pose per step, against the
runtime's Simulation and against itself.

Tolerance: the runtime's steps and the fixed-N step are the same linearly implicit Euler
step with the same checks, assembled by the same code (superhelix-kernels); the C library
is held to 1e-12 of max(max |q|, 1) against `Simulation` (capi/tests/c_example.rs), and
so is this batch. A difference above it is a difference of steps, not of round-off."""

import numpy as np
import pytest

import superhelix
from conftest import SHAKING, hanging_strand

DT = 1.0 / 30.0
GRAVITY = (0.0, 0.0, -9.81)
NATURAL = (21.72, 163.8, 0.0)


def relative(a, b):
    """Largest |a - b| relative to max(max |a|, 1), as capi/tests/c_example.rs measures."""
    a, b = np.asarray(a), np.asarray(b)
    return np.max(np.abs(a - b)) / max(np.max(np.abs(a)), 1.0)


def the_c_examples_fibre(count=1, **kw):
    """The C example's strand (capi/examples/step_strand.c): the scene's hanging_strand."""
    return superhelix.Batch(
        5, count, length=0.2, radius=50e-6, ellipticity=1.0, youngs_modulus=1.5e9,
        poisson_ratio=0.48, density=1300.0, natural=NATURAL, internal_friction=5e-11,
        air_drag=5e-6, **kw,
    )


@pytest.mark.parametrize("engine", ["embedded", "runtime"])
def test_the_batch_takes_the_runtimes_steps(engine):
    d = hanging_strand(simulation={"engine": engine})
    scene = superhelix.Scene.from_dict(d)
    r = scene.run(energies=False)
    assert r.engine == engine
    for batch in (superhelix.Batch.from_scene(scene), the_c_examples_fibre(gravity=GRAVITY)):
        np.testing.assert_array_equal(batch.q, r.q[0])  # at rest in the natural shape
        for k in range(1, scene.frame_count):
            batch.step(DT)
            assert relative(r.q[k], batch.q) <= 1e-12, (k, relative(r.q[k], batch.q))
        assert relative(r.qdot[-1], batch.qdot) <= 1e-12
        # element ends: every samples_per_element-th centreline point
        ends = r.nodes[-1, 0, ::scene.samples_per_element]
        assert np.max(np.abs(batch.centrelines()[0] - ends)) <= 1e-12 * 0.2


def test_error_controlled_steps_match_the_runtimes():
    scene = superhelix.Scene.from_dict(hanging_strand(simulation={"tolerance": 1e-3}))
    r = scene.run(energies=False)
    batch = superhelix.Batch.from_scene(scene)
    batch.set_tolerance(1e-3)
    assert batch.tolerance == 1e-3
    steps = rejected = 0
    for k in range(1, scene.frame_count):
        report = batch.step(DT)
        steps += report.steps
        rejected += report.rejected
        assert 0 < report.largest_error <= 1e-3 and report.largest_step <= DT * (1 + 1e-12)
        assert relative(r.q[k], batch.q) <= 1e-12
    # the same steps accepted and rejected as the runtime's
    assert steps == r.summary["error_control"]["steps"]
    assert rejected == r.summary["error_control"]["rejected"]
    for bad in (-1e-3, 1e-9, 0.6, float("nan")):
        with pytest.raises(ValueError, match="tolerance"):
            batch.set_tolerance(bad)
    assert batch.tolerance == 1e-3
    batch.set_tolerance(0)
    assert batch.tolerance is None


def rotation(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def test_a_still_head_moved_and_turned_changes_nothing_but_the_frame():
    """A head held still at X, R with gravity g steps q as the head at rest with gravity
    Rᵀ g does (the strand lives in head coordinates), and its centreline is X + R y."""
    x = np.array([0.3, -0.2, 1.5])
    rot = rotation([1.0, 2.0, 0.5], 0.7)
    g = np.array(GRAVITY)
    moved = the_c_examples_fibre(gravity=g)
    rest = the_c_examples_fibre(gravity=rot.T @ g)
    for _ in range(20):
        moved.step(DT, x, rot)
        rest.step(DT)
    assert relative(rest.q, moved.q) <= 1e-12
    y = rest.centrelines()[0]
    world = moved.centrelines()[0]
    assert np.max(np.abs(world - (x + y @ rot.T))) <= 1e-12


def test_a_moving_head_swings_the_strand_and_reports():
    batch = the_c_examples_fibre(3, gravity=GRAVITY)
    w = 2 * np.pi * 2.0  # 2 Hz by ±30° about z
    amplitude = np.radians(30)
    most = 0.0
    for k in range(1, 31):
        t = k * DT
        angle = amplitude * np.sin(w * t)
        rate = amplitude * w * np.cos(w * t)
        accel = -amplitude * w * w * np.sin(w * t)
        report = batch.step(
            DT, (0.0, 0.0, 0.0), rotation([0, 0, 1], angle),
            velocity=(0, 0, 0), acceleration=(0, 0, 0),
            angular_velocity=(0, 0, rate), angular_acceleration=(0, 0, accel),
        )
        assert report.stepped == 3 and report.failed == 0 and report.first_failed is None
        assert report.max_element_rotation > 0.0
        most = max(most, np.max(np.abs(batch.qdot)))
    assert most > 1.0  # the shaking set the strands moving (rad/(m s))
    # three identical strands, stepped alike
    np.testing.assert_array_equal(batch.q[0], batch.q[1])
    np.testing.assert_array_equal(batch.q[0], batch.q[2])
    assert batch.last_step.as_dict()["stepped"] == 3


def test_a_failing_strand_keeps_its_state_and_the_others_step():
    for tolerance in (0.0, 1e-3):
        batch = the_c_examples_fibre(3, gravity=GRAVITY)
        single = the_c_examples_fibre(1, gravity=GRAVITY)
        batch.set_tolerance(tolerance)
        single.set_tolerance(tolerance)
        wild = np.full(15, 1e300)
        batch.set_state(1, wild)
        with pytest.raises(superhelix.StepError, match=r"^strand 1: .*; it kept its state$") as info:
            batch.step(DT)
        report = info.value.report
        assert (report.stepped, report.failed, report.first_failed) == (3, 1, 1)
        assert (report.steps > 0) == (tolerance > 0)
        np.testing.assert_array_equal(batch.q[1], wild)
        np.testing.assert_array_equal(batch.qdot[1], np.zeros(15))
        single.step(DT)
        np.testing.assert_array_equal(batch.q[0], single.q[0])
        np.testing.assert_array_equal(batch.q[2], single.q[0])


def test_parameters_out_of_range_name_the_strand_and_the_field():
    with pytest.raises(ValueError, match=r"^strand 1: lengths: must be finite, > 0"):
        superhelix.Batch(5, 2, element_lengths=[[0.04] * 5, [0.04, 0.04, -0.04, 0.04, 0.04]])
    with pytest.raises(ValueError, match=r"^strand 0: root_frame: must be a rotation"):
        superhelix.Batch(5, root_frame=np.eye(3) * 2)
    with pytest.raises(ValueError, match=r"^poisson_ratio: must be in \(-1, 0.5\]"):
        superhelix.Batch(5, poisson_ratio=0.7)
    with pytest.raises(ValueError, match=r"^elements: no generated fixed-N code for N = 999"):
        superhelix.Batch(999)
    with pytest.raises(ValueError, match=r"^root_position: expected shape \(3,\) or \(2, 3\)"):
        superhelix.Batch(5, 2, root_position=np.zeros((3, 2)))
    batch = superhelix.Batch(5)
    with pytest.raises(ValueError, match="^dt: must be finite and > 0"):
        batch.step(0.0)
    with pytest.raises(ValueError, match="^head_rotation: must be a rotation"):
        batch.step(DT, (0, 0, 0), np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(ValueError, match="give both"):
        batch.step(DT, (0, 0, 0))
    with pytest.raises(ValueError, match="^gravity: expected 3 values"):
        batch.set_gravity([0, -9.81])
    with pytest.raises(IndexError):
        batch.set_state(1, np.zeros(15))
    with pytest.raises(ValueError, match="must be finite"):
        batch.set_state(0, np.full(15, np.nan))


def test_from_scene_refuses_mixed_sizes():
    with pytest.raises(ValueError, match=r"^strands\[2\]: strand 'smooth' has N = 8"):
        superhelix.Batch.from_scene(superhelix.Scene.from_toml(SHAKING))


def test_energies_of_the_batch_are_the_runtimes():
    """The fixed-N step's energy measure (superhelix-kernels) and the runtime's (its strand
    system) on the same state: kinetic, elastic and potential (elastic + gravity), under the
    same names in `Batch.energies()` and `Simulation.energies()`.
    Different code on states that agree to 1e-12 (measured: to the bit here, the energies
    to 6e-18 of the energy scale): held to 1e-12 of the scale."""
    d = hanging_strand(simulation={"engine": "runtime"})
    d["strands"][0]["q0"] = [1.2 * x for x in NATURAL * 5]
    scene = superhelix.Scene.from_dict(d)
    r = scene.run(frames=11)
    batch = superhelix.Batch.from_scene(scene)
    for _ in range(10):
        batch.step(DT)
    e = batch.energies()
    scale = abs(r.energy[0, 0]) + abs(r.kinetic_energy).max()
    assert abs(e["kinetic"][0] - r.kinetic_energy[-1, 0]) <= 1e-12 * scale
    assert abs(e["potential"][0] - r.potential_energy[-1, 0]) <= 1e-12 * scale
    assert e["potential"][0] == e["elastic"][0] + e["gravity"][0]
    # a simulation names them alike: its elastic energy on the same state is the batch's
    sim = scene.simulation()
    sim.set_state(0, batch.q[0], batch.qdot[0])
    s = sim.energies()
    assert abs(s["elastic"][0] - e["elastic"][0]) <= 1e-12 * scale
    assert abs(s["potential"][0] - e["potential"][0]) <= 1e-12 * scale
    assert r.kinetic_energy[-1, 0] > 1e-6 * scale  # it is moving: the check is not vacuous
