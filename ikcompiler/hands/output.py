"""Outputs of a manipulation run: the JSON of issue 14, a CSV table, the Fig. 3 plot, the text summary.

Units: lengths in the spec's unit, angles (joints, the planar object angle, rotation vectors, psi) in
radians, chart coordinates as the surface defines them (arc length for circle and line, radians for the
sphere/ellipsoid/cylinder angle, length for the cylinder height and the plane).  Contact points are world
coordinates, once computed from the finger and once from the object (they coincide to the residual).
"""

from __future__ import annotations

import csv
import math

import numpy as np

from ikcompiler.hands.trajectory import Trajectory


def _rotvec(R: np.ndarray) -> np.ndarray:
    """Rotation vector (axis * angle) of a rotation matrix, angle in [0, pi]."""
    c = max(-1.0, min(1.0, (np.trace(R) - 1) / 2))
    ang = math.acos(c)
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if ang < 1e-12:
        return 0.5 * w
    if math.pi - ang < 1e-6:  # near pi: axis from the symmetric part
        B = (R + np.eye(3)) / 2
        axis = B[:, int(np.argmax(np.diag(B)))]
        axis = axis / np.linalg.norm(axis)
        return axis * ang * (1 if axis @ w >= 0 else -1)
    return w * (ang / (2 * math.sin(ang)))


def object_coordinates(run: Trajectory) -> np.ndarray:
    """(N, 3) ``[x, y, phi]`` (phi unwrapped) in the plane; (N, 6) position + rotation vector in space."""
    g = run.object_pose
    if run.system.planar:
        phi = np.unwrap(np.arctan2(g[:, 1, 0], g[:, 0, 0]))
        return np.column_stack([g[:, 0, 3], g[:, 1, 3], phi])
    return np.column_stack([g[:, :3, 3], np.array([_rotvec(R) for R in g[:, :3, :3]])])


def object_radius(run: Trajectory) -> float:
    """The object's radius (circle, sphere, cylinder) or otherwise its size (largest semi-axis, extent)."""
    s = run.system.object_surface
    return float(getattr(s, "radius", s.size))


def to_json(run: Trajectory) -> dict:
    """The issue's JSON: t, object, joints, contacts, object_radius, max_constraint_residual.

    3-D runs also give ``beta_o`` and ``beta_f`` per contact (the second chart coordinate).
    """
    dim = 2 if run.system.planar else 3
    contacts = []
    for i in range(len(run.system.fingers)):
        c = {
            "object_point": run.object_point[:, i, :dim].tolist(),
            "finger_point": run.finger_point[:, i, :dim].tolist(),
            "alpha_o": run.U[:, i, 2].tolist(),
            "alpha_f": run.U[:, i, 0].tolist(),
        }
        if not run.system.planar:
            c["beta_o"] = run.U[:, i, 3].tolist()
            c["beta_f"] = run.U[:, i, 1].tolist()
        contacts.append(c)
    return {
        "t": run.t.tolist(),
        "object": object_coordinates(run).tolist(),
        "joints": {n: run.theta[:, k].tolist() for k, n in enumerate(run.system.joint_names)},
        "contacts": contacts,
        "object_radius": object_radius(run),
        "max_constraint_residual": run.max_residual,
    }


def write_csv(run: Trajectory, path) -> None:
    """One row per sample: t, object coordinates, joints, per contact (alpha_f, beta_f, alpha_o, beta_o,
    psi, contact point), residual."""
    planar = run.system.planar
    obj_cols = ["x", "y", "phi"] if planar else ["x", "y", "z", "rx", "ry", "rz"]
    dims = "xy" if planar else "xyz"
    head = ["t"] + [f"object_{c}" for c in obj_cols] + list(run.system.joint_names)
    for f in run.system.fingers:
        head += [f"{f.name}_{k}" for k in ("alpha_f", "beta_f", "alpha_o", "beta_o", "psi")]
        head += [f"{f.name}_contact_{d}" for d in dims]
    head.append("constraint_residual")
    obj = object_coordinates(run)
    with open(path, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(head)
        for k in range(len(run.t)):
            row = [run.t[k], *obj[k], *run.theta[k]]
            for i in range(len(run.system.fingers)):
                row += [*run.U[k, i], run.psi[k, i], *run.object_point[k, i, : len(dims)]]
            row.append(run.residual[k])
            w.writerow([repr(float(x)) for x in row])


def summary(run: Trajectory, seconds: float) -> str:
    """A few lines: what ran, the residual, the contacts' drift on the object."""
    n = len(run.system.fingers)
    lines = [
        f"{run.system.name}: {len(run.t) - 1} steps of {run.t[1] - run.t[0]:.4g} s to t = {run.t[-1]:.4g} s "
        f"({run.method}, {'self-motion: ' + run.objective if run.self_motion else 'no self-motion'}), "
        f"class {run.kind}, {seconds:.2f} s",
        f"max constraint residual {run.max_residual:.2e} of the object's size "
        f"(initial projection moved the joints {run.initial_adjustment:.1e} rad)",
    ]
    for i in range(1, n):
        d = run.U[:, i, 2] - run.U[:, 0, 2]
        lines.append(
            f"alpha_o[{run.system.fingers[0].name}] - alpha_o[{run.system.fingers[i].name}]: "
            f"start {-d[0]:.6g}, end {-d[-1]:.6g}, largest change {np.abs(d - d[0]).max():.3e}"
        )
    lines += [f"note: {n}" for n in run.notes]
    return "\n".join(lines)


def _displacements(run: Trajectory) -> tuple[np.ndarray, np.ndarray]:
    """(N, n) contact displacement on the fingertips and on the object: the signed arc length in the plane
    (alpha - alpha(0)), in space the distance from the starting point in the body's own frame."""
    if run.system.planar:
        return run.U[:, :, 0] - run.U[0, :, 0], run.U[:, :, 2] - run.U[0, :, 2]
    s = run.system
    fin = np.zeros(run.U.shape[:2])
    obj = np.zeros(run.U.shape[:2])
    for i, f in enumerate(s.fingers):
        pf = np.array([f.surface.chart(u) for u in run.U[:, i, :2]])
        po = np.array([s.object_surface.chart(u) for u in run.U[:, i, 2:]])
        fin[:, i] = np.linalg.norm(pf - pf[0], axis=1)
        obj[:, i] = np.linalg.norm(po - po[0], axis=1)
    return fin, obj


def plot(runs: list[Trajectory], path) -> None:
    """Fig. 3 of seed 002: joint angles per finger, contact positions on the fingers and on the object.

    ``runs``: the run with self-motion (solid) and, optionally, without (dashed).
    """
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as exc:  # pragma: no cover - depends on the environment
        from ikcompiler.errors import IkcError

        raise IkcError('--png needs matplotlib: pip install "ikcompiler[plot]"') from exc
    sys = runs[0].system
    nf = len(sys.fingers)
    panels = nf + 2
    cols = 2
    rows = (panels + 1) // 2
    fig, axes = plt.subplots(rows, cols, figsize=(11, 3.6 * rows), squeeze=False)
    axes = axes.ravel()
    styles = {True: "-", False: "--"}
    slices = sys.joint_slices()
    letters = "abcdefghij"
    unit = sys.units or "length"
    for run in runs:
        ls = styles[run.self_motion]
        tag = "self-motion" if run.self_motion else "no self-motion"
        for i, (f, sl) in enumerate(zip(sys.fingers, slices)):
            ax = axes[i]
            for k, name in zip(range(sl.start, sl.stop), f.chain.independent_names):
                ax.plot(
                    run.t, np.degrees(run.theta[:, k]), ls, color=f"C{k - sl.start}", label=f"{name} ({tag})"
                )
            ax.set_title(f"({letters[i]}) joints of finger {f.name}")
            ax.set_ylabel("deg")
        fin_d, obj_d = _displacements(run)
        ax = axes[nf]
        for i, f in enumerate(sys.fingers):
            ax.plot(run.t, fin_d[:, i], ls, color=f"C{i}", label=f"{f.name} ({tag})")
        ax.set_title(f"({letters[nf]}) contact displacement on the fingertips")
        ax.set_ylabel(f"alpha_f - alpha_f(0) [{unit}]" if sys.planar else f"distance from the start [{unit}]")
        ax = axes[nf + 1]
        for i, f in enumerate(sys.fingers):
            ax.plot(run.t, obj_d[:, i], ls, color=f"C{i}", label=f"{f.name} ({tag})")
        if nf >= 2 and sys.planar:
            d = (run.U[:, 0, 2] - run.U[:, 1, 2]) - (run.U[0, 0, 2] - run.U[0, 1, 2])
            ax.plot(run.t, d, ls, color="k", label=f"change of alpha_1 - alpha_2 ({tag})")
        ax.set_title(f"({letters[nf + 1]}) contact displacement on the object")
        ax.set_ylabel(f"alpha_o - alpha_o(0) [{unit}]" if sys.planar else f"distance from the start [{unit}]")
    for ax in axes[:panels]:
        ax.set_xlabel("t [s]")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    for ax in axes[panels:]:
        ax.axis("off")
    cases = {r.self_motion for r in runs}
    title = (
        "solid with self-motion, dashed without"
        if len(cases) == 2
        else ("with self-motion" if True in cases else "without self-motion")
    )
    fig.suptitle(f"{sys.name}: {title}")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
