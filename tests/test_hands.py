"""Rolling manipulation (issue 14, seed 002): geometry, hand-object equations, the trajectory algorithm.

Everything checked here is recomputed outside the code under test where it can be: surface curvature from
finite differences of the chart and from closed forms, contact points put back into the fingertip and
object frames and tested against the surfaces' implicit equations, normals from the circle and sphere
centres, arc lengths from the points' angles about those centres, the object's pose from the commanded
twist in closed form, contact rates from finite differences of the projected contacts.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from ikcompiler.cli import main
from ikcompiler.errors import RobotInputError
from ikcompiler.hands import (
    Circle,
    ContactError,
    Cylinder,
    Ellipsoid,
    HandSystem,
    Line,
    Plane,
    Sphere,
    load_manipulation,
    local_geometry,
    manipulate,
    planar_finger,
)
from ikcompiler.hands.fingers import Finger
from ikcompiler.hands.trajectory import rates
from ikcompiler.inputs import load_robot
from ikcompiler.inputs.zoo import zoo_names

DT = 0.02  # the seed example at 150 steps: every check below holds at this step already


@pytest.fixture(scope="module")
def disk():
    return load_manipulation("two_finger_disk")


@pytest.fixture(scope="module")
def run_self(disk):
    return disk.run(dt=DT)


@pytest.fixture(scope="module")
def run_plain(disk):
    return disk.run(dt=DT, self_motion=False)


@pytest.fixture(scope="module")
def sphere_spec():
    return load_manipulation("three_finger_sphere")


@pytest.fixture(scope="module")
def sphere_run(sphere_spec):
    return sphere_spec.run(duration=0.6, dt=0.02)


# ---- surfaces -----------------------------------------------------------------------------------------


SURFACES = [Sphere(2.0), Ellipsoid(3.0, 2.0, 1.5), Cylinder(1.5), Plane(4.0), Circle(10.0), Line(5.0)]


def _fd_geometry(s, u, h=1e-5):
    """Normal, frame and derivatives by central differences of the chart point alone."""

    def frame(uu):
        p = lambda a, b: s.chart((a, b))  # noqa: E731
        fu = (p(uu[0] + h, uu[1]) - p(uu[0] - h, uu[1])) / (2 * h)
        fv = (p(uu[0], uu[1] + h) - p(uu[0], uu[1] - h)) / (2 * h)
        n = np.cross(fu, fv)
        n /= np.linalg.norm(n)
        x = fu / np.linalg.norm(fu)
        return fu, fv, n, x

    fu, fv, n, x = frame(u)
    y = np.cross(n, x)
    H = 1e-4
    nu = (frame((u[0] + H, u[1]))[2] - frame((u[0] - H, u[1]))[2]) / (2 * H)
    nv = (frame((u[0], u[1] + H))[2] - frame((u[0], u[1] - H))[2]) / (2 * H)
    xu = (frame((u[0] + H, u[1]))[3] - frame((u[0] - H, u[1]))[3]) / (2 * H)
    xv = (frame((u[0], u[1] + H))[3] - frame((u[0], u[1] - H))[3]) / (2 * H)
    M = np.array([[np.linalg.norm(fu), x @ fv], [0, y @ fv]])
    Mi = np.linalg.inv(M)
    K = np.column_stack([x, y]).T @ np.column_stack([nu, nv]) @ Mi
    T = y @ np.column_stack([xu, xv]) @ Mi
    return n, M, K, T


@pytest.mark.parametrize("surface", SURFACES, ids=lambda s: s.name)
def test_metric_curvature_torsion_match_finite_differences(surface):
    rng = np.random.default_rng(3)
    for _ in range(5):
        u = np.array([rng.uniform(-2.5, 2.5), rng.uniform(-1.0, 1.0)])
        g = local_geometry(surface, u)
        n, M, K, T = _fd_geometry(surface, u)
        assert np.allclose(g.normal, n, atol=1e-8)
        assert np.allclose(g.M, M, atol=1e-7)
        assert np.allclose(g.K, K, atol=1e-6)
        assert np.allclose(g.T, T, atol=1e-6)
        assert abs(surface.implicit(g.point)) < 1e-12 * surface.size


def test_curvature_closed_forms():
    assert np.allclose(local_geometry(Sphere(2.0), (0.4, 0.3)).K, np.eye(2) / 2)
    assert np.allclose(local_geometry(Cylinder(4.0), (1.0, 2.0)).K, np.diag([0.25, 0.0]))
    assert np.allclose(local_geometry(Plane(), (1.0, 2.0)).K, 0.0)
    a, b, c = 3.0, 2.0, 1.5
    g = local_geometry(Ellipsoid(a, b, c), (0.7, -0.4))
    x, y, z = g.point
    gauss = 1.0 / (a * b * c * (x**2 / a**4 + y**2 / b**4 + z**2 / c**4)) ** 2
    assert np.linalg.det(g.K) == pytest.approx(gauss, rel=1e-12)
    # the sphere chart's torsion: the east axis turns towards north by sin(latitude) per unit longitude
    g = local_geometry(Sphere(2.0), (0.0, 0.5))
    assert g.T[0] * g.M[0, 0] == pytest.approx(math.sin(0.5), abs=1e-12)
    assert g.T[1] == pytest.approx(0.0, abs=1e-15)


def test_finger_kinematics_are_the_chain_models():
    spec = load_manipulation("three_finger_sphere")
    rng = np.random.default_rng(0)
    for f in spec.system.fingers:
        q = rng.uniform(-1, 1, f.dof)
        assert np.allclose(f.tip_pose(q), f.tip_pose_reference(q), atol=1e-12)
        assert np.allclose(f.spatial_jacobian(q), f.spatial_jacobian_reference(q), atol=1e-12)
    f = planar_finger("p", [20, 20, 10], base=(1.0, 2.0))
    q = np.radians([150, 240, 330])
    a = np.cumsum(q)
    want = np.array([1.0, 2.0]) + sum(
        L * np.array([math.cos(t), math.sin(t)]) for L, t in zip([20, 20, 10], a)
    )
    assert np.allclose(f.tip_pose(q)[:2, 3], want, atol=1e-12)


# ---- along the runs: contacts on both surfaces, opposed normals, rolling, commanded motion --------------


def _local(g, p):
    return g[:3, :3].T @ (p - g[:3, 3])


def _check_contacts(run):
    s = run.system
    L = s.length_scale
    for k in range(len(run.t)):
        g_obj = run.object_pose[k] @ s.object_frame
        for i, (f, sl) in enumerate(zip(s.fingers, s.joint_slices())):
            g_tip = s.fingers[i].tip_pose_reference(run.theta[k, sl])
            pf, po = run.finger_point[k, i], run.object_point[k, i]
            assert np.linalg.norm(pf - po) < 1e-9 * L
            assert abs(f.surface.implicit(_local(g_tip, pf))) < 1e-9 * L
            assert abs(s.object_surface.implicit(_local(g_obj, po))) < 1e-9 * L
            # circles and spheres: the normal is the direction from the centre
            nf = (pf - g_tip[:3, 3]) / np.linalg.norm(pf - g_tip[:3, 3])
            no = (po - g_obj[:3, 3]) / np.linalg.norm(po - g_obj[:3, 3])
            assert np.linalg.norm(nf + no) < 1e-9


def test_seed_example_contacts_stay_on_both_surfaces(run_self, run_plain):
    for run in (run_self, run_plain):
        assert run.max_residual < 1e-9
        _check_contacts(run)


def test_sphere_example_contacts_stay_on_both_surfaces(sphere_run):
    assert sphere_run.kind == "non-redundant"
    assert sphere_run.max_residual < 1e-9
    _check_contacts(sphere_run)


def _arc(points, poses, radius):
    """Cumulative arc length travelled, from the points' angle about the circle centre in its frame."""
    loc = np.array([_local(g, p) for g, p in zip(poses, points)])
    ang = np.unwrap(np.arctan2(loc[:, 1], loc[:, 0]))
    return np.cumsum(np.r_[0.0, np.abs(np.diff(ang))]) * radius


@pytest.mark.parametrize("which", ["run_self", "run_plain"])
def test_rolling_without_slipping_equal_arc_lengths(which, request):
    run = request.getfixturevalue(which)
    s = run.system
    for i, (f, sl) in enumerate(zip(s.fingers, s.joint_slices())):
        tips = [f.tip_pose_reference(q[sl]) for q in run.theta]
        s_f = _arc(run.finger_point[:, i], tips, f.surface.radius)
        s_o = _arc(run.object_point[:, i], run.object_pose, s.object_surface.radius)
        assert s_o[-1] > 0.5  # the contacts do travel (cm)
        # RK4 + projection: ~4e-11 cm at dt = 0.02 (the paper's Euler steps slip by ~1e-2 cm)
        assert np.abs(s_f - s_o).max() < 1e-9 * s.length_scale


@pytest.mark.parametrize("which", ["run_self", "sphere_run"])
def test_no_slip_velocity_at_the_contacts(which, request):
    """The body-fixed points at the contact move alike on finger and object (central differences)."""
    run_self = request.getfixturevalue(which)
    s = run_self.system
    h = run_self.t[1] - run_self.t[0]
    worst = 0.0
    for k in range(1, len(run_self.t) - 1):
        for i, (f, sl) in enumerate(zip(s.fingers, s.joint_slices())):
            p = run_self.object_point[k, i]
            gk_f = f.tip_pose_reference(run_self.theta[k, sl])
            bf = _local(gk_f, p)
            bo = _local(run_self.object_pose[k], p)
            gf = [f.tip_pose_reference(run_self.theta[j, sl]) for j in (k - 1, k + 1)]
            go = [run_self.object_pose[j] for j in (k - 1, k + 1)]
            vf = (gf[1][:3, :3] @ bf + gf[1][:3, 3] - gf[0][:3, :3] @ bf - gf[0][:3, 3]) / (2 * h)
            vo = (go[1][:3, :3] @ bo + go[1][:3, 3] - go[0][:3, :3] @ bo - go[0][:3, 3]) / (2 * h)
            worst = max(worst, float(np.linalg.norm(vf - vo)))
    # central differences are O(h^2): 1e-3 cm/s against contact-point speeds of ~1-3 cm/s
    assert worst < 1e-3


def test_object_follows_the_commanded_twist(run_self):
    t = run_self.t
    g = run_self.object_pose
    assert np.allclose(g[:, 0, 3], t - 0.75 * t**2, atol=1e-12)
    assert np.allclose(g[:, 1, 3], 2 * t - 0.5 * t**2, atol=1e-12)
    assert np.allclose(np.unwrap(np.arctan2(g[:, 1, 0], g[:, 0, 0])), 0.05 * t**2, atol=1e-12)


def test_sphere_follows_the_commanded_rotation(sphere_spec, sphere_run):
    # independent reference: many small Rodrigues steps at the midpoint angular velocity
    R, t, n = np.eye(3), 0.0, 20000
    T = sphere_run.t[-1]
    h = T / n
    for _ in range(n):
        w = sphere_spec.twist(t + h / 2)[3:]
        a = np.linalg.norm(w) * h
        k = w / np.linalg.norm(w)
        K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
        R = (np.eye(3) + math.sin(a) * K + (1 - math.cos(a)) * K @ K) @ R
        t += h
    assert np.abs(sphere_run.object_pose[-1][:3, :3] - R).max() < 1e-8
    assert np.abs(sphere_run.object_pose[:, :3, 3]).max() < 1e-15


def test_self_motion_keeps_the_grasp_antipodal(run_self, run_plain):
    d_self = run_self.U[:, 0, 2] - run_self.U[:, 1, 2]
    d_plain = run_plain.U[:, 0, 2] - run_plain.U[:, 1, 2]
    R = run_self.system.object_surface.radius
    assert d_self[0] == pytest.approx(math.pi * R, abs=1e-12)  # antipodal start
    assert np.abs(d_self - d_self[0]).max() < 1e-6
    assert np.abs(d_plain - d_plain[0]).max() > 0.05  # without self-motion the contacts drift apart
    assert run_plain.kind == run_self.kind == "redundant"


def test_contact_rates_match_finite_differences(sphere_spec):
    """Montana's equations (finger-frame form) against the exact contacts found by projection."""
    h = 0.005
    run = sphere_spec.run(duration=0.02, dt=h)
    k = 2
    r = rates(
        run.system, run.t[k], run.theta[k], run.object_pose[k], run.U[k], sphere_spec.twist(run.t[k]), None
    )
    assert np.abs(r.dU - (run.U[k + 1] - run.U[k - 1]) / (2 * h)).max() < 1e-5
    psi = np.unwrap(run.psi, axis=0)
    assert np.abs(r.deta[:, 4] - (psi[k + 1] - psi[k - 1]) / (2 * h)).max() < 1e-5
    assert np.abs(r.dtheta - (run.theta[k + 1] - run.theta[k - 1]) / (2 * h)).max() < 1e-5


# ---- classification ------------------------------------------------------------------------------


def _planar_hand(n1: int, n2: int) -> tuple[HandSystem, np.ndarray]:
    """Two planar fingers of n1 and n2 links (bent, not singular) touching a disk of radius 10 antipodally."""
    fingers, theta = [], []
    for name, n, side in (("a", n1, -1.0), ("b", n2, 1.0)):
        lengths = [12.0, 9.0, 6.0][:n]
        q = np.radians([40.0, -50.0, -30.0][:n])
        probe = planar_finger(name, lengths)
        end = probe.tip_pose(q)
        heading = math.atan2(end[1, 0], end[0, 0])
        # turn and place the finger so its tip circle (radius 2) centre is at (side * 12, 0), facing the disk
        turn = (0.0 if side < 0 else math.pi) - heading
        c, s = math.cos(turn), math.sin(turn)
        tip_xy = np.array([[c, -s], [s, c]]) @ end[:2, 3]
        base = np.array([side * 12.0, 0.0]) - tip_xy
        f = planar_finger(name, lengths, base=base, base_angle=turn, surface=Circle(2.0))
        fingers.append(Finger(f.name, f.chain, f.base, f.tip, f.surface))
        theta.extend(q)
    return HandSystem(tuple(fingers), Circle(10.0), ("point", "point"), True), np.array(theta)


@pytest.mark.parametrize(
    "n1, n2, kind, rank_D, rank_NJ",
    [
        # one-link fingers point at the disk centre, so they move their contacts only tangentially: the
        # object can translate along y and turn (rank D = 2), never along x
        (1, 1, "degenerate", 2, 0),
        # the second finger adds the normal direction at its contact only: v_x still impossible
        (1, 3, "degenerate", 2, 1),
        (2, 2, "non-redundant", 3, 0),
        (3, 3, "redundant", 3, 2),
        (2, 3, "redundant", 3, 1),
    ],
)
def test_classification_of_hand_made_systems(n1, n2, kind, rank_D, rank_NJ):
    system, theta = _planar_hand(n1, n2)
    g0 = np.eye(4)
    U = system.find_contacts(theta, g0)
    theta, U, c, res = system.project(theta, g0, U)
    assert res < 1e-12
    m = system.matrices(theta, g0, c)
    jo = system.analyse(m)
    assert (jo.kind, jo.rank_D, jo.rank_NJ, jo.indeterminate) == (kind, rank_D, rank_NJ, 0)
    # (14) solves (7): every [u; th'] it generates meets the contact constraint, N_J is in N(J)
    rng = np.random.default_rng(1)
    y = rng.normal(size=jo.D.shape[1])
    yJ = rng.normal(size=jo.N_J.shape[1])
    u, dth = jo.D @ y, jo.E @ y + jo.N_J @ yJ
    assert np.abs(m.Gt @ u - m.J @ dth).max() < 1e-12 * max(1.0, np.abs(u).max(), np.abs(dth).max()) * 100
    assert jo.N_J.shape[1] == 0 or np.abs(m.J @ jo.N_J).max() < 1e-12 * 100


def test_degenerate_system_refuses_an_unreachable_twist():
    system, theta = _planar_hand(1, 1)
    with pytest.raises(ContactError, match=r"R\(D\)"):
        manipulate(system, theta, np.eye(4), lambda t: np.array([1.0, 1.0, 0.3]), duration=0.02, dt=0.01)


# ---- specs, zoo, CLI ---------------------------------------------------------------------------------


def _spec_text(**repl) -> str:
    from ikcompiler.inputs.zoo import zoo_dir

    text = (zoo_dir() / "two_finger_disk.toml").read_text()
    for a, b in repl.items():
        assert a in text
        text = text.replace(a, b)
    return text


@pytest.mark.parametrize(
    "old, new, match",
    [
        ('vy = "2 - t"', 'vy = "2 - __import__(1)"', "only t"),
        ('vy = "2 - t"', 'vq = "2 - t"', "unknown field"),
        ('contact = "point"', 'contact = "soft"', "point contacts only"),
        ("radius = 10.0", "radius = -1.0", "positive"),
        ("base = [22.0, -20.0]", "base = [30.0, -20.0]", "do not touch"),
    ],
)
def test_bad_specs_raise_clear_errors(tmp_path, old, new, match):
    p = tmp_path / "bad.toml"
    p.write_text(_spec_text(**{old: new}))
    with pytest.raises((RobotInputError, ContactError), match=match):
        load_manipulation(p).run(duration=0.02, dt=0.01)


def test_zoo_leaves_manipulation_specs_out():
    assert "two_finger_disk" not in zoo_names() and "three_finger_sphere" not in zoo_names()
    with pytest.raises(RobotInputError, match="ikc manipulate"):
        load_robot("two_finger_disk")
    from ikcompiler.inputs.zoo import zoo_dir

    with pytest.raises(RobotInputError, match="ikc manipulate"):
        load_robot(zoo_dir() / "two_finger_disk.toml")


def test_cli_json_csv_png_describe(tmp_path, capsys):
    png, csvf = tmp_path / "fig3.png", tmp_path / "run.csv"
    args = ["manipulate", "two_finger_disk", "--duration", "0.04", "--dt", "0.02"]
    assert main(args + ["--json", "--csv", str(csvf), "--png", str(png)]) == 0
    data = json.loads(capsys.readouterr().out)
    assert set(data) == {"t", "object", "joints", "contacts", "object_radius", "max_constraint_residual"}
    assert set(data["contacts"][0]) == {"object_point", "finger_point", "alpha_o", "alpha_f"}
    assert (
        len(data["t"]) == 3
        and len(data["object"][0]) == 3
        and len(data["contacts"][0]["object_point"][0]) == 2
    )
    assert data["object_radius"] == 10.0 and data["max_constraint_residual"] < 1e-9
    assert list(data["joints"]) == ["f1.q1", "f1.q2", "f1.q3", "f2.q1", "f2.q2", "f2.q3"]
    assert png.stat().st_size > 10000 and csvf.read_text().count("\n") == 4
    assert main(["manipulate", "three_finger_sphere", "--describe"]) == 0
    out = capsys.readouterr().out
    assert "non-redundant" in out and "rank D (object motions) = 6" in out
    assert main(["manipulate", "robots/nothing.toml"]) == 2


def test_a_user_objective_plugs_in():
    """Any object with rows(ctx) is an objective: here, keep contact 1 still on its fingertip."""

    class HoldFingertipPoint:
        name = "hold_fingertip_point"

        def rows(self, ctx):
            S = np.zeros((1, 5 * ctx.U.shape[0]))
            S[0, 0] = 1.0  # alpha_f' of contact 1
            return S, np.zeros(1)

    system, theta = _planar_hand(3, 3)
    twist = lambda t: np.array([0.5, -0.3, 0.05])  # noqa: E731
    held = manipulate(system, theta, np.eye(4), twist, duration=0.3, dt=0.05, objective=HoldFingertipPoint())
    free = manipulate(system, theta, np.eye(4), twist, duration=0.3, dt=0.05)
    assert held.objective == "hold_fingertip_point" and held.max_residual < 1e-9
    assert np.abs(held.U[:, 0, 0] - held.U[0, 0, 0]).max() < 1e-9
    assert np.abs(free.U[:, 0, 0] - free.U[0, 0, 0]).max() > 1e-3


def test_cli_three_dimensional_json(capsys):
    assert main(["manipulate", "three_finger_sphere", "--duration", "0.02", "--dt", "0.02", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert len(data["object"][0]) == 6 and len(data["contacts"]) == 3
    assert len(data["contacts"][0]["finger_point"][0]) == 3 and "beta_o" in data["contacts"][0]
    assert data["object_radius"] == 3.0 and data["max_constraint_residual"] < 1e-9


def test_a_non_planar_finger_in_a_planar_spec_is_refused():
    f = planar_finger("x", [10.0, 5.0], surface=Circle(1.0))
    tilted = f.base.copy()
    tilted[:3, :3] = [[1, 0, 0], [0, 0, -1], [0, 1, 0]]  # joints about -y: out of the plane
    bad = Finger("x", f.chain, tilted, f.tip, f.surface)
    with pytest.raises(ContactError, match="planar problem needs every joint"):
        HandSystem((bad,), Circle(5.0), ("point",), True)


def test_describe_gives_R_D_of_a_degenerate_hand():
    from ikcompiler.hands.cli import describe
    from ikcompiler.hands.spec import ManipulationSpec

    system, theta = _planar_hand(1, 1)
    spec = ManipulationSpec(system, theta, np.eye(4), lambda t: np.zeros(3), {}, 1.0, 0.1, "none", "test")
    text = describe(spec)
    assert "class: degenerate" in text and "basis of R(D)" in text
    basis = np.array(
        [json.loads(line.strip()) for line in text.split("basis of R(D) in (vx, vy, wz):\n")[1].splitlines()]
    )
    assert basis.shape == (2, 3) and np.abs(basis[:, 0]).max() < 1e-9  # v_x is not among them
