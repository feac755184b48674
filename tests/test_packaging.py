"""A built wheel carries the zoo and everything the runtime needs (issue 11 item 8).

The wheel is built from a copy of the files the build reads (so the checkout gets no ``build/``), with
pip's ordinary build isolation: the same registry access as the set-up command ``pip install -e .``.
It is installed with ``pip install --target`` into a folder of its own and run from another working
directory with only that folder on ``PYTHONPATH``: the zoo must be found in the installed package
(``ikcompiler/robots/``), not in the checkout, and a zoo robot must compile into a module that solves.
About 20 s on a loaded 2-core machine, most of it pip.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from ikcompiler.inputs.zoo import zoo_names

REPO = Path(__file__).resolve().parents[1]
BUILD_INPUTS = ("pyproject.toml", "setup.py", "README.md", "ikcompiler", "subproblems", "robots")
JUNK = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info", "build", "dist", ".*")


def _run(cmd: list[str], *, cwd: Path, env: dict[str, str] | None = None) -> str:
    done = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, f"{' '.join(cmd)} failed ({done.returncode}):\n{done.stdout}\n{done.stderr}"
    return done.stdout


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("pkg")
    src = root / "src"
    src.mkdir()
    for name in BUILD_INPUTS:
        path = REPO / name
        if path.is_dir():
            shutil.copytree(path, src / name, ignore=JUNK)
        else:
            shutil.copy2(path, src / name)
    dist = root / "dist"
    _run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(dist), str(src)], cwd=root)
    (found,) = dist.glob("ikcompiler-*.whl")
    return found


@pytest.fixture(scope="module")
def installed(wheel, tmp_path_factory) -> Path:
    target = tmp_path_factory.mktemp("site")
    _run(
        [sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target", str(target), str(wheel)],
        cwd=target,
    )
    return target


def _checkout_files(folder: str, suffixes: tuple[str, ...] = ()) -> set[str]:
    """Files under ``folder`` of the checkout (all of them, or those ending in ``suffixes``)."""
    return {
        p.relative_to(REPO).as_posix()
        for p in (REPO / folder).rglob("*")
        if p.is_file()
        and not any(part.startswith(".") or part == "__pycache__" for part in p.relative_to(REPO).parts)
        and p.suffix != ".pyc"
        and (not suffixes or p.name.endswith(suffixes))
    }


def test_wheel_holds_every_module_data_file_and_robot(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    # Every file of the two packages: a package folder without __init__.py is not found by setup.py's
    # find_packages, and a data file (not .py) needs its pattern in pyproject's package-data; either
    # would be missing from the wheel although the checkout runs.
    code = _checkout_files("ikcompiler") | _checkout_files("subproblems")
    assert {"ikcompiler/cli.py", "subproblems/fast_kernels.h", "subproblems/plan_runtime.py"} <= code
    assert code - names == set(), "add an __init__.py, or the pattern to [tool.setuptools.package-data]"
    # The zoo, sub-folders included (a hand task names its fingers' files relative to itself).
    robots = _checkout_files("robots", (".toml", ".urdf"))
    assert len(robots) >= 14
    assert {"ikcompiler/" + r for r in robots} - names == set()


def _env(site: Path, tmp: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("IKC_ROBOTS", "PYTHONPATH")}
    env["PYTHONPATH"] = str(site)
    env["IKC_CACHE"] = str(tmp / "cache")  # the C build of the compiled module, away from the user's cache
    return env


def test_installed_wheel_lists_the_zoo_and_compiles_rhino(installed, tmp_path):
    env = _env(installed, tmp_path)
    where = _run(
        [sys.executable, "-c", "import ikcompiler.inputs.zoo as z; print(z.__file__, z.zoo_dir())"],
        cwd=tmp_path,
        env=env,
    ).split()
    # The package and its zoo come from the install folder, not from the checkout on this machine.
    assert Path(where[0]).is_relative_to(installed), where
    assert Path(where[1]) == installed / "ikcompiler" / "robots", where

    listed = _run([sys.executable, "-m", "ikcompiler", "zoo"], cwd=tmp_path, env=env).split()
    assert listed == zoo_names()

    ikc = installed / "bin" / "ikc"  # the console script of the wheel
    _run([str(ikc), "compile", "rhino", "-o", "rhino_ik.py"], cwd=tmp_path, env=env)
    check = (
        "import numpy as np, rhino_ik as m\n"
        "q = np.array([120.0, 0.3, -0.7, 0.9, 0.4, -1.1])\n"
        "T = m.fk(q)\n"
        "Q = m.solve(T)\n"
        "err = max(np.abs(m.fk(r) - T).max() for r in Q)\n"
        "hit = min(np.abs(Q - q).max(axis=1))\n"
        "print(len(Q), err, hit)\n"
    )
    k, err, hit = _run([sys.executable, "-c", check], cwd=tmp_path, env=env).split()
    # Rhino (mm): residual from forward kinematics, 1e-9 of its ~600 mm size; the drawn q is a solution.
    assert int(k) >= 1 and float(err) < 1e-9 * 600 and float(hit) < 1e-6, (k, err, hit)
