"""Cartesian paths and joint trajectories (issue 13 items 2-4), on the P-Rob of seed 001."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from ikcompiler.cli import main
from ikcompiler.compiler import compile_robot
from ikcompiler.errors import MotionError
from ikcompiler.motion import follow, quintic, straight_line, time_path, trapezoid, via_points
from ikcompiler.motion.poses import interpolate, pose_from_xyzrpy, rotation_exp

Q0 = np.radians([10, 30, 40, 20, 50, 10])  # a well-conditioned P-Rob configuration


@pytest.fixture(scope="module")
def prob():
    return compile_robot("prob")


def _goal(m):
    T1 = m.fk(Q0)
    T1[:3, 3] += [-0.08, 0.1, -0.05]
    T1[:3, :3] = T1[:3, :3] @ rotation_exp([0.2, 0.1, -0.3])
    return T1


def _errors(m, path):
    """Position and rotation (Frobenius) error of every row against its waypoint, from fk."""
    G = np.array([m.fk(q) for q in path.q])
    dp = np.linalg.norm(G[:, :3, 3] - path.targets[:, :3, 3], axis=1)
    dR = np.linalg.norm(G[:, :3, :3] - path.targets[:, :3, :3], axis=(1, 2))
    return dp.max(), dR.max()


def _branch(q):
    """P-Rob's branch labels: shoulder (front/back, from the sign of j2's offset), elbow (j3 vs its
    stretched value pi/2), wrist (sign of j5)."""
    return np.sign(np.pi / 2 - q[:, 2]), np.sign(q[:, 4])


def test_straight_line_keeps_one_branch_and_reproduces_every_pose(prob):
    m = prob
    T0, T1 = m.fk(Q0), _goal(m)
    largest = []
    for step in (0.02, 0.01, 0.005):
        poses = straight_line(T0, T1, max_step=step, max_angle=2 * step)
        path = follow(m, poses, Q0)
        assert path.complete and path.events == []
        assert np.array_equal(path.q[0], Q0) and np.allclose(path.poses[-1], T1, atol=1e-9)
        # the waypoints are on the straight line: recompute them from their place along it
        N = len(poses) - 1
        assert np.allclose(path.targets, interpolate(T0, T1, path.s / N), atol=1e-12)
        dp, dR = _errors(m, path)
        assert dp <= 1e-9 * m.SCALE and dR <= 1e-9
        for label in _branch(path.q):
            assert np.all(label == label[0])
        largest.append(np.abs(np.diff(path.q, axis=0)).max())
    assert largest[1] < 0.6 * largest[0] and largest[2] < 0.6 * largest[1]


def _line_through_wrist_singularity(m, offset=0.0, j6=10.0):
    """A straight line whose middle pose is P-Rob's wrist singularity (j5 = 0), shifted by ``offset``."""
    q_sing = np.radians([10, 30, 40, 20, 0, j6])  # j5 = 0: j4 and j6 aligned
    Ts = m.fk(q_sing)
    v, r = np.array([offset, 0.04, 0.0]), np.array([0.0, 0.3, 0.0])
    Ta, Tb = Ts.copy(), Ts.copy()
    Ta[:3, 3] += [offset, -0.04, 0.0]
    Ta[:3, :3] = Ts[:3, :3] @ rotation_exp(-r)
    Tb[:3, 3] += v
    Tb[:3, :3] = Ts[:3, :3] @ rotation_exp(r)
    return straight_line(Ta, Tb, max_step=0.01, max_angle=0.05), q_sing, Ts


def test_path_through_a_wrist_singularity_reports_it_at_that_waypoint(prob):
    m = prob
    poses, q_sing, Ts = _line_through_wrist_singularity(m)
    assert len(poses) % 2 == 1  # the middle waypoint is the singular pose
    mid = (len(poses) - 1) / 2
    assert np.allclose(poses[int(mid)], Ts, atol=1e-12)
    path = follow(m, poses, m.nearest(poses[0], q_sing))
    assert not path.complete
    sing = [e for e in path.events if e.kind == "singularity"]
    assert len(sing) == 1 and path.s[sing[0].index] == mid
    assert {"j4", "j6"} <= set(sing[0].joints)
    assert path.sigma_min[sing[0].index] < 1e-9
    # with j6 = 60 deg the solver's representative of the singular pose (j6 = 0, j4 = 80 deg) is 60 deg
    # from the path: the branch is continued by Newton steps instead of a jump, the singularity reported
    poses, q_sing, _ = _line_through_wrist_singularity(m, j6=60.0)
    assert abs(m.solve_info(poses[int(mid)]).q[0][5]) < 1e-9  # the representative the solver gives
    path = follow(m, poses, m.nearest(poses[0], q_sing))
    assert np.abs(np.diff(path.q, axis=0)).max() < np.radians(10)
    assert [(path.s[e.index], e.kind) for e in path.events] == [(mid, "singularity")]
    dp, dR = _errors(m, path)
    assert dp <= 1e-9 * m.SCALE and dR <= 1e-9
    # passing 0.1 mm beside it: j4 and j6 would have to spin by ~pi within a step of 40 um (the finest
    # refinement): the branch changes there, reported within one input step of the singular pose
    poses, q_sing, _ = _line_through_wrist_singularity(m, offset=1e-4)
    path = follow(m, poses, m.nearest(poses[0], q_sing))
    assert [(e.kind, e.joints) for e in path.events] == [("singularity", ("j4", "j6"))]
    assert abs(path.s[path.events[0].index] - mid) < 0.5


def test_path_out_of_reach_and_into_a_joint_limit(prob):
    m = prob
    T0 = m.fk(Q0)
    far = T0.copy()
    far[:3, 3] += [0.1, -0.15, 0.05]  # past the stretched elbow
    path = follow(m, straight_line(T0, far, max_step=0.01), Q0)
    assert not path.complete and [e.kind for e in path.events] == ["workspace"]
    assert path.events[0].index == len(path.q) - 1 and path.s[-1] < len(path.s)
    # j4 runs into its +170 deg stop; the path changes branch there and says so
    goal = pose_from_xyzrpy(0.3, 0.1, 0.6, 0, 3.1, 0)
    path = follow(m, straight_line(T0, goal, max_step=m.SCALE / 100), Q0)
    kinds = [(e.kind, e.joints) for e in path.events]
    assert kinds == [("joint_limit", ("j4",))]
    k = path.events[0].index
    assert path.q[k - 1, 3] > np.radians(165)  # at the stop when the branch changes
    dp, dR = _errors(m, path)
    assert dp <= 1e-9 * m.SCALE and dR <= 1e-9
    with pytest.raises(MotionError, match="poses\\[0\\]"):
        follow(m, straight_line(goal, T0, max_step=0.05), Q0)


def _dense(tr, n=4001):
    t = np.linspace(0, tr.duration, n)
    return t, tr.position(t), tr.velocity(t), tr.acceleration(t)


def test_quintic_and_trapezoid_boundaries_and_limits():
    q0, q1 = np.zeros(6), np.radians([30, 60, 90, 45, -90, 0])  # seed 001's move, 2 s
    tr = quintic(q0, q1, 2.0)
    t, q, qd, qdd = _dense(tr)
    assert np.array_equal(q[0], q0) and np.array_equal(q[-1], q1)
    assert np.abs(qd[[0, -1]]).max() < 1e-12 and np.abs(qdd[[0, -1]]).max() < 1e-12
    assert np.all(np.diff(q, axis=0) * np.sign(q1 - q0) >= -1e-15)  # monotone: no overshoot
    vpk, apk = tr.peaks()
    assert np.allclose(vpk, 15 / 8 * np.abs(q1 - q0) / 2) and np.all(np.abs(qd).max(0) <= vpk + 1e-12)
    vmax, amax = 1.0, 2.0
    for make in (quintic, trapezoid):
        tr = make(q0, q1, vmax=vmax, amax=amax)
        t, q, qd, qdd = _dense(tr)
        vpk, apk = tr.peaks()
        assert vpk.max() <= vmax and apk.max() <= amax  # exact peaks within the limits ...
        assert max(vpk.max() / vmax, np.sqrt(apk.max() / amax)) > 1 - 1e-6  # ... and one of them binding
        assert np.abs(qd).max() <= vmax and np.abs(qdd).max() <= amax + 1e-9
        assert np.array_equal(q[0], q0) and np.array_equal(q[-1], q1)
        assert np.abs(qd[[0, -1]]).max() < 1e-12
    # synchronised: every joint's trapezoid switches at the same times
    tr = trapezoid(q0, q1, vmax=vmax, amax=amax)
    moving = np.abs(q1 - q0) > 0
    cruise = tr.velocity([(tr.breaks[1] + tr.breaks[2]) / 2])[0]
    assert np.allclose(cruise[moving] / (q1 - q0)[moving], cruise[2] / (q1 - q0)[2])
    with pytest.raises(MotionError, match="at least"):
        quintic(q0, q1, 0.5, vmax=vmax)
    with pytest.raises(MotionError):
        trapezoid(q0, q1, 0.5, vmax=vmax, amax=amax)


def test_via_points_and_time_path(prob):
    Q = np.radians([[0, 0, 0], [20, 10, -5], [40, -10, 5], [30, 30, 0]])
    times = [0.0, 1.0, 2.5, 3.0]
    tr = via_points(Q, times)
    assert np.array_equal(tr.position(times), Q)
    for tb in times[1:-1]:  # continuous velocity and acceleration at the via points
        assert np.allclose(tr.velocity([tb - 1e-9]), tr.velocity([tb + 1e-9]), atol=1e-6)
        assert np.allclose(tr.acceleration([tb - 1e-9]), tr.acceleration([tb + 1e-9]), atol=1e-5)
    tr = via_points(Q, vmax=0.5, amax=1.0)
    vpk, apk = tr.peaks()
    assert vpk.max() <= 0.5 and apk.max() <= 1.0 and np.array_equal(tr.position(tr.breaks), Q)
    m = prob
    path = follow(m, straight_line(m.fk(Q0), _goal(m), max_step=0.01, max_angle=0.02), Q0)
    tr = time_path(path, vmax=1.0, amax=2.0)
    vpk, apk = tr.peaks()
    assert vpk.max() <= 1.0 and apk.max() <= 2.0
    assert np.array_equal(tr.position(tr.breaks), path.q)
    _, _, qd, _ = _dense(tr)
    assert np.abs(qd[[0, -1]]).max() < 1e-12


def test_cli_path_json_and_exit_codes(capsys, tmp_path):
    start = ",".join(f"{np.degrees(v):.17g}deg" for v in Q0)
    m = compile_robot("prob")
    T1 = _goal(m)
    from ikcompiler.motion.poses import matrix_to_rpy

    to = ",".join(repr(float(x)) for x in [*T1[:3, 3], *matrix_to_rpy(T1[:3, :3])])
    rc = main(["path", "prob", "--start", start, "--to", to, "--step", "0.01", "--json",
               "--csv", str(tmp_path / "p.csv"), "--png", str(tmp_path / "p.png")])
    out = json.loads(capsys.readouterr().out)
    assert rc == 0 and out["complete"] is True and out["events"] == []
    assert set(out) == {"joints", "q", "poses", "events", "complete"}
    assert out["joints"] == list(m.JOINT_NAMES) and np.allclose(out["q"][0], Q0)
    assert len(out["poses"]) == len(out["q"]) and np.allclose(out["poses"][-1], T1, atol=1e-9)
    assert (tmp_path / "p.png").stat().st_size > 0 and (tmp_path / "p.csv").read_text().startswith("row,s,j1")
    rc = main(["path", "prob", "--start", start, "--to", "0.3,0.1,0.6,0,3.1,0", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert rc == 1 and out["complete"] is False
    assert out["events"][0]["kind"] == "joint_limit" and set(out["events"][0]) == {"index", "kind", "joints"}
    assert main(["path", "prob", "--start", "0,0", "--to", to]) == 2  # wrong count: a clear error


def test_cli_trajectory_csv_png(capsys, tmp_path):
    goal = "30deg,60deg,90deg,45deg,-90deg,0"
    rc = main(["trajectory", "prob", "--start", "0,0,0,0,0,0", "--goal", goal, "--duration", "2",
               "--csv", str(tmp_path / "t.csv"), "--png", str(tmp_path / "t.png")])
    assert rc == 0
    rows = list(csv.reader(open(tmp_path / "t.csv")))
    assert rows[0] == ["t", "j1", "j2", "j3", "j4", "j5", "j6"]
    assert [float(x) for x in rows[1]] == [0.0] * 7
    assert [float(x) for x in rows[-1]] == [2.0, *np.radians([30, 60, 90, 45, -90, 0])]
    assert len(rows) == 202 and (tmp_path / "t.png").stat().st_size > 0
    capsys.readouterr()
    assert main(["trajectory", "prob", "--start", "0,0,0,0,0,0", "--goal", goal, "--profile", "trapezoid",
                 "--vmax", "1", "--amax", "2"]) == 0
    shortest = capsys.readouterr().out
    assert main(["trajectory", "prob", "--start", "0,0,0,0,0,0", "--goal", goal,
                 "--profile", "trapezoid"]) == 0
    assert capsys.readouterr().out == shortest  # the defaults are 1 rad/s and 2 rad/s^2
    assert main(["trajectory", "prob", "--start", "0,0,0,0,0,0", "--goal", goal, "--duration", "0.5",
                 "--vmax", "1"]) == 2  # too short for the limit
    assert main(["trajectory", "prob", "--start", "0,0,0,0,0,0", "--goal", "3,0,0,0,0,0",
                 "--duration", "2"]) == 2  # j1 = 3 rad is outside its +-170 deg
