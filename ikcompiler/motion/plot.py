"""PNG figures of trajectories and paths (seed 001's Fig. 6-9): joint angle, velocity and acceleration
against time, and the tool path in 3-D.  matplotlib is imported only here, when a figure is asked for."""

from __future__ import annotations

import numpy as np

from ikcompiler.errors import IkcError

__all__ = ["plot_trajectory", "plot_path"]


def _pyplot():
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise IkcError('PNG output needs matplotlib: pip install "ikcompiler[plot]"') from exc
    return plt


def _tool_path(ax, P, title, marks=()):
    ax.plot(P[:, 0], P[:, 1], P[:, 2], lw=1.5)
    ax.scatter(*P[0], color="green", s=25, label="start")
    ax.scatter(*P[-1], color="red", s=25, label="end")
    for k in marks:
        ax.scatter(*P[k], color="black", marker="x", s=40)
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.set_zlabel("z")
    ax.set_title(title)
    ax.legend(loc="upper left", fontsize=7)


def plot_trajectory(traj, fk, joints, png, *, dt: float = 0.01, title: str = "") -> None:
    """Write ``png``: angle, velocity, acceleration of each joint against time and the tool path in 3-D
    (``fk(q)`` -> 4x4 gives the tool pose)."""
    plt = _pyplot()
    t, q, qd, qdd = traj.sample(dt)
    P = np.array([fk(row)[:3, 3] for row in q])
    fig = plt.figure(figsize=(11, 8))
    for i, (data, label) in enumerate(((q, "angle [rad]"), (qd, "velocity [rad/s]"),
                                       (qdd, "acceleration [rad/s^2]"))):
        ax = fig.add_subplot(2, 2, i + 1)
        for j, name in enumerate(joints):
            ax.plot(t, data[:, j], label=name)
        ax.set_xlabel("t [s]")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
        if i == 0:
            ax.legend(fontsize=7, ncol=2)
    _tool_path(fig.add_subplot(2, 2, 4, projection="3d"), P, "tool path")
    fig.suptitle(title or f"joint trajectory, {traj.duration:.3g} s")
    fig.tight_layout()
    fig.savefig(png, dpi=100)
    plt.close(fig)


def plot_path(path, png, *, title: str = "") -> None:
    """Write ``png``: each joint against the place along the path and the tool path in 3-D, events
    marked (x)."""
    plt = _pyplot()
    fig = plt.figure(figsize=(11, 4.5))
    ax = fig.add_subplot(1, 2, 1)
    for j, name in enumerate(path.joints):
        ax.plot(path.s, path.q[:, j], label=name)
    for e in path.events:
        ax.axvline(path.s[e.index], color="black", ls=":", lw=1)
    ax.set_xlabel("waypoint")
    ax.set_ylabel("joint value")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    _tool_path(fig.add_subplot(1, 2, 2, projection="3d"), path.poses[:, :3, 3], "tool path",
               [e.index for e in path.events])
    fig.suptitle(title or ("path complete" if path.complete else f"path: {len(path.events)} event(s)"))
    fig.tight_layout()
    fig.savefig(png, dpi=100)
    plt.close(fig)
