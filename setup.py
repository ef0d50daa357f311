"""Package list for setuptools: every `nnfmu*` package plus the top-level `templates/` shipped as `nnfmu.templates`.

`templates/` lives at the repository's top level (the design card), so automatic discovery cannot see it as part of
nnfmu; it is added here by name and mapped in pyproject.toml's `package-dir`.
"""

from setuptools import find_packages, setup

setup(packages=find_packages(include=["nnfmu*"]) + ["nnfmu.templates", "nnfmu.templates.c", "nnfmu.templates.reports"])
