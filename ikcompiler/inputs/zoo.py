"""The robot zoo: the robot files in the repository's ``robots/`` folder, loadable by bare name.

A file's zoo name is its name without extension(s): ``puma560.dh.toml`` is ``puma560``.  The folder is,
first found:

1. the folder named by the environment variable ``IKC_ROBOTS``;
2. the package data ``ikcompiler/robots/`` of an installed package: a wheel or ``pip install .``
   installs the checkout's top-level ``robots/`` there (``setup.py`` maps the package
   ``ikcompiler.robots`` to that folder, ``pyproject.toml`` lists ``**/*.toml`` and ``**/*.urdf`` as
   its data);
3. the checkout's ``robots/`` beside the package folder (an editable install or ``PYTHONPATH``).
"""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

from ikcompiler.errors import UnknownRobotError

SUFFIXES = (".urdf", ".toml")
MANIPULATION_HINT = 'it is a manipulation task (kind = "manipulation"), not a robot: run `ikc manipulate {}`'


def is_manipulation_spec(path: Path) -> bool:
    """True for a hand task file (top-level ``kind = "manipulation"``, see ``ikcompiler/hands/spec.py``)."""
    if not str(path).lower().endswith(".toml"):
        return False
    try:
        import tomllib

        return tomllib.loads(Path(path).read_text(encoding="utf-8")).get("kind") == "manipulation"
    except (OSError, ValueError):
        return False  # unreadable or malformed: the robot loader reports it


def _installed_dir() -> Path | None:
    """``ikcompiler/robots/`` inside the installed package, when it is a folder on disk (not in a
    checkout, where ``robots/`` sits beside the package; not inside a zip import)."""
    folder = Path(str(resources.files("ikcompiler") / "robots"))
    return folder if folder.is_dir() else None


def zoo_dir() -> Path:
    """The zoo folder: ``$IKC_ROBOTS`` if set, else the installed package data, else the checkout's
    ``robots/``.

    >>> zoo_dir().name
    'robots'
    """
    env = os.environ.get("IKC_ROBOTS")
    if env:
        return Path(env)
    return _installed_dir() or Path(__file__).resolve().parents[2] / "robots"


def _files() -> dict[str, Path]:
    folder = zoo_dir()
    if not folder.is_dir():
        return {}
    out: dict[str, Path] = {}
    for p in sorted(folder.iterdir()):
        if p.is_file() and p.name.lower().endswith(SUFFIXES) and not p.name.startswith("."):
            if not is_manipulation_spec(p):
                out.setdefault(p.name.split(".")[0], p)
    return out


def zoo_names() -> list[str]:
    """Sorted names of the zoo robots.

    >>> "rhino" in zoo_names()
    True
    """
    return sorted(_files())


def resolve(name: str) -> Path:
    """The file of zoo robot ``name``; :class:`UnknownRobotError` listing the zoo when there is none."""
    files = _files()
    if name in files:
        return files[name]
    task = zoo_dir() / f"{name}.toml"
    if is_manipulation_spec(task):
        raise UnknownRobotError(f"zoo file {task.name}: " + MANIPULATION_HINT.format(task))
    names = ", ".join(sorted(files)) or f"(none: the zoo folder {zoo_dir()} is empty or missing)"
    raise UnknownRobotError(
        f"no robot file or zoo robot named {name!r}. Give a path to a .urdf or .toml file, "
        f"or one of the zoo names: {names}"
    )
