"""The PNG of ``ikc singularities --png``: sigma_min against each joint (seed 004's Fig. 2-5) and a map.

matplotlib is imported here, lazily: ``pip install "ikcompiler[plot]"`` when it is missing.
"""

from __future__ import annotations

import math
from collections import Counter

import numpy as np

from ikcompiler.errors import IkcError


class PlotUnavailable(IkcError):
    """matplotlib is not installed."""


def _pyplot():
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise PlotUnavailable(
            'the PNG needs matplotlib: pip install "ikcompiler[plot]" (or drop --png)'
        ) from exc
    return plt


def map_joints(report) -> tuple[int, int]:
    """Indices of the two joints that appear in most conditions (ties: chain order)."""
    names = list(report.joints)
    counts = Counter(j for c in report.conditions for j in c.joints)
    order = sorted(range(len(names)), key=lambda i: (-counts.get(names[i], 0), i))
    return (order[0], order[1]) if len(order) > 1 else (order[0], order[0])


def write_png(report, chain, path: str, grid: int = 121) -> str:
    """Scatter sigma_min over the samples against each joint, and sigma_min over a grid of two joints."""
    from ikcompiler.analysis.singularities import _Numeric

    plt = _pyplot()
    s = report.sampling
    if s.Q is None or s.sigma is None:
        raise IkcError("the report carries no samples to plot (run the analysis with samples > 0)")
    dof = len(report.joints)
    cols = min(dof, 4)
    rows = math.ceil(dof / cols) + 1
    fig = plt.figure(figsize=(3.2 * cols, 2.6 * rows), dpi=100)
    deg = ["R" == chain.joints[i].kind for i in chain.independent]
    for k in range(dof):
        ax = fig.add_subplot(rows, cols, k + 1)
        x = np.degrees(s.Q[:, k]) if deg[k] else s.Q[:, k]
        ax.scatter(x, s.sigma, s=2, alpha=0.4, color="tab:blue", linewidths=0)
        ax.axhline(s.threshold, color="tab:red", lw=0.8, ls="--")
        ax.set_xlabel(f"{report.joints[k]} ({'deg' if deg[k] else chain.units or 'length'})", fontsize=8)
        ax.set_ylabel("sigma_min", fontsize=8)
        ax.tick_params(labelsize=7)
    # the map: sigma_min over two joints, the others at the best-conditioned sample (not on a condition)
    i, j = map_joints(report)
    num = _Numeric(chain)
    lo, hi = num.box()
    base = s.Q[int(np.argmax(s.sigma))]
    gi, gj = np.linspace(lo[i], hi[i], grid), np.linspace(lo[j], hi[j], grid)
    Q = np.tile(base, (grid * grid, 1))
    Q[:, i] = np.repeat(gi, grid)
    Q[:, j] = np.tile(gj, grid)
    sig = num.sv(Q)[:, report.generic_rank - 1].reshape(grid, grid)
    ax = fig.add_subplot(rows, 1, rows)
    ext = [*(np.degrees([gj[0], gj[-1]]) if deg[j] else [gj[0], gj[-1]]),
           *(np.degrees([gi[0], gi[-1]]) if deg[i] else [gi[0], gi[-1]])]
    im = ax.imshow(sig, origin="lower", extent=ext, aspect="auto", cmap="viridis")
    fig.colorbar(im, ax=ax, label="sigma_min")
    others = ", ".join(f"{report.joints[k]}={base[k]:.3g}" for k in range(dof) if k not in (i, j))
    ax.set_xlabel(report.joints[j], fontsize=8)
    ax.set_ylabel(report.joints[i], fontsize=8)
    title = f"sigma_min over {report.joints[i]}, {report.joints[j]}"
    ax.set_title(title + (f" ({others})" if others else ""), fontsize=8)
    fig.suptitle(f"{report.robot}: smallest singular value of the size-free Jacobian, {s.samples} samples",
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
    return path
