"""Static branches followed by pseudo-arclength continuation (`sim.follow_branch`),
against the elastica: a column pushed slightly off its axis, followed through the fold
of its complementary branch; a pinned-pinned column loaded to twice Euler's load
without jumping; the same column shortened by its holder."""

import numpy as np
import pytest

import superhelix

L, R, E, RHO = 0.2, 1e-3, 2e11, 7800.0
EI = E * np.pi * R**4 / 4


def elliptic_f(phi, k, points=4000):
    """F(phi, k) = int_0^phi dt / sqrt(1 - k^2 sin^2 t), composite Gauss-Legendre (the
    integrand is smooth for k < 1)."""
    x, w = np.polynomial.legendre.leggauss(16)
    edges = np.linspace(0.0, phi, points // 16 + 1)
    total = 0.0
    for a, b in zip(edges[:-1], edges[1:]):
        t = 0.5 * (b - a) * x + 0.5 * (a + b)
        total += 0.5 * (b - a) * np.sum(w / np.sqrt(1 - (k * np.sin(t)) ** 2))
    return total


def elliptic_e(phi, k, points=4000):
    """E(phi, k) = int_0^phi sqrt(1 - k^2 sin^2 t) dt."""
    x, w = np.polynomial.legendre.leggauss(16)
    edges = np.linspace(0.0, phi, points // 16 + 1)
    total = 0.0
    for a, b in zip(edges[:-1], edges[1:]):
        t = 0.5 * (b - a) * x + 0.5 * (a + b)
        total += 0.5 * (b - a) * np.sum(w * np.sqrt(1 - (k * np.sin(t)) ** 2))
    return total


def complementary_load(alpha, psi):
    """The elastica of a cantilever column whose tip force makes the angle psi with its
    root's tangent, on the branch that bends against the force's lateral part: with u the
    tangent's angle from the force's line (u(0) = -psi, u(L) = alpha, EI u'' = -P sin u),
    sqrt(P/EI) L = K(k) + F(asin(sin(psi/2)/k), k), k = sin(alpha/2) (Frisch-Fay's
    first integral; Timoshenko & Gere, Theory of Elastic Stability, 2.7)."""
    k = np.sin(alpha / 2)
    return EI * ((elliptic_f(np.pi / 2, k) + elliptic_f(np.arcsin(np.sin(psi / 2) / k), k)) / L) ** 2


def golden_minimum(f, a, b, tol=1e-10):
    g = (np.sqrt(5) - 1) / 2
    c, d = b - g * (b - a), a + g * (b - a)
    fc, fd = f(c), f(d)
    while b - a > tol:
        if fc < fd:
            b, d, fd = d, c, fc
            c = b - g * (b - a)
            fc = f(c)
        else:
            a, c, fc = c, d, fd
            d = a + g * (b - a)
            fd = f(d)
    return 0.5 * (a + b), f(0.5 * (a + b))


def tip_angle(sim, q):
    """The angle of the tip's tangent d0 in the x-z plane, from +x."""
    sim.set_state(0, q, np.zeros_like(q))
    d0 = sim.directors()[0, -1, 0]
    return np.arctan2(d0[2], d0[0])


@pytest.mark.parametrize("engine", ["embedded", "runtime"])
def test_an_off_axis_column_is_followed_through_the_fold_of_its_complementary_branch(engine):
    # a steel cantilever along +x pushed at its tip by P at psi = 0.05 rad off its axis
    # (the lateral part toward -z). Bent up against it, it stands on the complementary
    # branch: as P falls the branch folds at P_fold (the minimum over alpha of the
    # elastica's load), then climbs on its unstable part. Load-stepped static solves
    # would jump to the principal branch there; the continuation follows it and reports
    # the fold.
    n, psi = 20, 0.05
    p_cr = np.pi**2 * EI / (4 * L**2)
    push = -p_cr * np.array([np.cos(psi), 0.0, np.sin(psi)])
    scene = superhelix.Scene.rod(length=L, radius=R, youngs_modulus=E, density=RHO,
                                 poisson=0.3, elements=n, normal=[0.0, 0.0, 1.0],
                                 engine=engine,
                                 point_loads=[{"s": L, "force": list(push)}])
    sim = scene.simulation()
    # the guess: an arc bent up by 2 rad (kappa_2 > 0 turns d0 toward +z here)
    q = np.zeros(3 * n)
    q[2::3] = 2.0 / L
    sim.set_state(0, q, np.zeros(3 * n))
    branch = sim.follow_branch(0, start=2.0, stop=0.5, step=0.02, max_points=80)
    assert branch["start"]["converged"]
    a = branch["parameter"]
    # the reference: the elastica's smallest load on the branch
    alpha_fold, p_fold = golden_minimum(lambda x: complementary_load(x, psi), psi * 1.0001, 3.0)
    assert len(branch["folds"]) == 1, [f["parameter"] for f in branch["folds"]]
    fold = branch["folds"][0]
    # the piecewise-constant curvature's error in a buckling load is ~1/N^2 (0.03 % at
    # N = 40 for Euler's load): 3e-3 at N = 20 is its scale
    assert abs(fold["parameter"] * p_cr / p_fold - 1) < 3e-3, (fold["parameter"] * p_cr, p_fold)
    # before the fold the load falls, after it rises: one branch, no jump
    k = fold["after"]
    assert np.all(np.diff(a[: k + 1]) < 0) and np.all(np.diff(a[k + 1 :]) > 0)
    # in 3D the planar branch has one unstable direction out of its plane (the rod can
    # swing round the push's line toward the other side); the fold adds one in the plane
    assert np.all(branch["unstable"][: k + 1] == 1)
    assert np.all(branch["unstable"][k + 1 :] == 2)
    # every point on the elastica's branch: the load at its tip angle (u(L) = theta - psi)
    for j in range(0, len(a), 4):
        alpha = tip_angle(sim, branch["q"][j]) - psi
        if alpha < 1.05 * psi:
            break
        p = complementary_load(alpha, psi)
        assert abs(a[j] * p_cr / p - 1) < 3e-3, (j, alpha, a[j] * p_cr, p)
    # the fold's tip angle
    alpha = tip_angle(sim, fold["q"]) - psi
    assert abs(alpha - alpha_fold) < 5e-3, (alpha, alpha_fold)
    # the simulation's loads are as they were
    np.testing.assert_allclose(sim.point_loads(0)[0]["force"], push, rtol=1e-15)


def test_a_pinned_column_loaded_to_twice_eulers_load_stays_on_its_branch():
    # pinned at both ends (the tip on a line along the axis), pushed by a load scaled
    # from 0.5 to 2 P_cr, a 1e-4 P_cr nudge at mid-span choosing the side: the branch
    # buckles and bows out as the elastica does, P/P_cr = (2K(k)/pi)^2 with mid-span
    # deflection k L / K(k) (Timoshenko & Gere 2.7), never to the inverted shape
    n = 40
    p_cr = np.pi**2 * EI / L**2
    scene = superhelix.Scene.rod(length=L, radius=R, youngs_modulus=E, density=RHO,
                                 poisson=0.3, elements=n, normal=[0.0, 0.0, 1.0],
                                 root_end="pinned",
                                 tip={"kind": "sliding", "axis": [1.0, 0.0, 0.0]},
                                 point_loads=[{"s": L, "force": [-p_cr, 0.0, 0.0]},
                                              {"s": L / 2, "force": [0.0, 0.0, 1e-4 * p_cr]}])
    sim = scene.simulation()
    branch = sim.follow_branch(0, start=0.5, stop=2.0, step=0.02, max_points=400)
    assert branch["end"] == "reached" and not branch["folds"]
    assert branch["parameter"][-1] == 2.0
    # P = 2 P_cr: K(k) = pi / sqrt(2)
    target = np.pi / np.sqrt(2)
    lo, hi = 0.0, 0.99
    for _ in range(60):
        k = 0.5 * (lo + hi)
        lo, hi = (k, hi) if elliptic_f(np.pi / 2, k) < target else (lo, k)
    sim.set_state(0, branch["q"][-1], np.zeros(3 * n + 3))
    bow = sim.nodes()[0][:, 2]
    # bowed up, the side the nudge chose; its size the elastica's (the nudge adds ~1e-4,
    # the discretisation ~1/N^2)
    assert bow.max() > 0 and bow.min() > -1e-12
    assert abs(bow.max() / (k * L / elliptic_f(np.pi / 2, k)) - 1) < 2e-3, (bow.max(), k)
    assert not branch["branch_points"] and np.all(branch["unstable"] == 0)
    # on the way, the load never fell (no fold) and the shape never flipped
    assert np.all(np.diff(branch["parameter"]) > 0)


def test_a_pinned_column_shortened_by_its_holder_follows_the_elastica():
    # the same column with its tip pinned, the holder moved toward the root by D: the
    # holder's force is P/P_cr = (2K(k)/pi)^2 at D/L = 2 (1 - E(k)/K(k)) (the pinned
    # elastica), here to D = 0.6 L
    n = 40
    p_cr = np.pi**2 * EI / L**2
    # held 1 % in from the start, bowed as a circular arc of chord 0.99 L (it turns by
    # sqrt(24 * 0.01) rad) that the pinned root's joint tilts onto the holder
    text = superhelix.Scene.rod(length=L, radius=R, youngs_modulus=E, density=RHO,
                                poisson=0.3, elements=n, normal=[0.0, 0.0, 1.0],
                                root_end="pinned").toml
    arc = [0.0, 0.0, float(np.sqrt(24 * 0.01) / L)] * n
    text = text.replace('initial = "natural"\n', "")
    text = text.replace("[strands.ends]\n", f"q0 = {arc}\n\n[strands.ends]\n")
    text += f"\n[strands.ends.tip]\nkind = \"pinned\"\nposition = [{0.99 * L}, 0.0, 0.0]\n"
    sim = superhelix.Scene.from_toml(text).simulation()
    branch = sim.follow_branch(0, parameter="holder", direction=[-1.0, 0.0, 0.0],
                               start=0.0, stop=0.59 * L, step=0.02, max_points=400)
    assert branch["end"] == "reached" and not branch["folds"]
    assert np.all(branch["unstable"] == 0)
    shortening = 0.01 * L + branch["parameter"]
    force = -branch["reaction"][:, 0]  # the holder pushes the tip toward the root
    for j in range(len(shortening)):
        # k from D/L = 2 (1 - E/K), by bisection
        lo, hi = 0.0, 0.99
        for _ in range(50):
            k = 0.5 * (lo + hi)
            d = 2 * (1 - elliptic_e(np.pi / 2, k, 800) / elliptic_f(np.pi / 2, k, 800))
            lo, hi = (k, hi) if d < shortening[j] / L else (lo, k)
        p = p_cr * (2 * elliptic_f(np.pi / 2, k, 800) / np.pi) ** 2
        # the discretisation's ~1/N^2: 5.5e-4 at N = 40
        assert abs(force[j] / p - 1) < 1e-3, (j, shortening[j] / L, force[j] / p_cr, p / p_cr)
