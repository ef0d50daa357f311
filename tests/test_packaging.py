"""The wheel must carry what an installed nnfmu needs at run time: FMI templates, report template, slave sources."""

import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_wheel_ships_templates_and_package_data(tmp_path: Path) -> None:
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            str(ROOT),
            "--no-deps",
            "--no-build-isolation",
            "-q",
            "-w",
            str(tmp_path),
        ],
        check=True,
    )
    (wheel,) = tmp_path.glob("nnfmu-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    for template in (ROOT / "templates").rglob("*"):
        if template.is_file():
            assert f"nnfmu/templates/{template.relative_to(ROOT / 'templates').as_posix()}" in names
    assert {"nnfmu/templates/reports/base.html.j2", "nnfmu/templates/reports/validate.html.j2"} <= names
    assert {
        "nnfmu/diagnosis/__init__.py",
        "nnfmu/diagnosis/effects/__init__.py",
        "nnfmu/diagnosis/effects/friction.py",
    } <= names  # subpackages found by find_packages
    assert not any(n.startswith(("tests/", "bench/", "exported/")) for n in names)
