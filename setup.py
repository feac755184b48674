"""Packaging beyond what pyproject.toml can say: the zoo.

The top-level ``robots/`` folder is installed as the package data ``ikcompiler/robots/`` (the package
``ikcompiler.robots`` mapped to that folder), so that a wheel and ``pip install .`` carry the zoo;
``ikcompiler/inputs/zoo.py`` finds it there.  pyproject.toml's ``packages.find`` cannot add a mapped
package, hence this file; everything else is in pyproject.toml.
"""

from setuptools import find_packages, setup

setup(
    packages=[*find_packages(include=["ikcompiler*", "subproblems*"]), "ikcompiler.robots"],
    package_dir={"ikcompiler.robots": "robots"},
)
