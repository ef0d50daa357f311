"""A build-and-simulate cycle of the native FMU runs clean under valgrind and under ASan+UBSan, FMI 2 and FMI 3.

Small C masters (fmi2_driver.c, fmi3_driver.c) load the FMU's binary and drive every path of the glue; any invalid
read/write, use of uninitialised memory, undefined behaviour or leak fails the test.
"""

from __future__ import annotations

import shutil
import subprocess
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import pytest
from fmpy import read_model_description

from nnfmu.fmu.native.backend import fmi_headers_dir

pytestmark = pytest.mark.slow

BINARY_FOLDER = {2: "linux64", 3: "x86_64-linux"}


def _counts(path: Path):
    md = read_model_description(str(path))
    n_in = sum(v.causality == "input" for v in md.modelVariables)
    n_out = sum(v.causality == "output" and v.type in ("Real", "Float64") for v in md.modelVariables)
    return md, n_in, n_out


def _driver(fmi: int, target: Path, extra: list[str]) -> Path:
    source = Path(__file__).with_name(f"fmi{fmi}_driver.c")
    subprocess.run(
        [
            "gcc",
            "-std=c99",
            "-g",
            "-Wall",
            "-Wextra",
            "-Werror",
            *extra,
            f"-I{fmi_headers_dir()}",
            "-o",
            str(target),
            str(source),
            "-ldl",
            "-lm",
        ],
        check=True,
        capture_output=True,
        text=True,
    )
    return target


@pytest.mark.skipif(shutil.which("valgrind") is None, reason="valgrind is not installed")
@pytest.mark.parametrize("fmi", [2, 3])
def test_cycle_is_clean_under_valgrind(delay_fmus, tmp_path, fmi):
    md, n_in, n_out = _counts(delay_fmus[fmi])
    with zipfile.ZipFile(delay_fmus[fmi]) as archive:
        binary = tmp_path / "fmu.so"
        binary.write_bytes(archive.read(f"binaries/{BINARY_FOLDER[fmi]}/{md.coSimulation.modelIdentifier}.so"))
    driver = _driver(fmi, tmp_path / "driver", [])
    result = subprocess.run(
        [
            "valgrind",
            "--error-exitcode=99",
            "--leak-check=full",
            "--errors-for-leak-kinds=definite,indirect,possible",
            "--show-leak-kinds=definite,indirect,possible",
            str(driver),
            str(binary),
            md.guid,
            str(n_in),
            str(n_out),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr[-4000:]
    assert "0 unexpected statuses" in result.stderr
    assert "ERROR SUMMARY: 0 errors" in result.stderr


@pytest.mark.parametrize("fmi", [2, 3])
def test_shipped_sources_build_from_build_description_and_run_clean_under_asan_ubsan(delay_fmus, tmp_path, fmi):
    """The FMU's sources/ alone (files named in buildDescription.xml) compile elsewhere; ASan+UBSan find nothing."""
    md, n_in, n_out = _counts(delay_fmus[fmi])
    with zipfile.ZipFile(delay_fmus[fmi]) as archive:
        archive.extractall(tmp_path / "fmu")
    sources = tmp_path / "fmu" / "sources"
    build = ET.parse(sources / "buildDescription.xml").getroot()
    files = [sources / f.get("name") for f in build.iter("SourceFile")]
    sanitize = ["-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer"]
    library = tmp_path / "asan.so"
    compiled = subprocess.run(
        [
            "gcc",
            "-std=c99",
            "-g",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-fPIC",
            "-shared",
            *sanitize,
            f"-I{sources}",
            "-o",
            str(library),
            *map(str, files),
            "-lm",
        ],
        capture_output=True,
        text=True,
    )
    assert compiled.returncode == 0, compiled.stderr
    driver = _driver(fmi, tmp_path / "driver", sanitize)
    result = subprocess.run(
        [str(driver), str(library), md.guid, str(n_in), str(n_out)],
        capture_output=True,
        text=True,
        timeout=300,
        env={"ASAN_OPTIONS": "detect_leaks=1", "PATH": "/usr/bin:/bin"},
    )
    assert result.returncode == 0, result.stderr[-4000:]
    assert "0 unexpected statuses" in result.stderr and "runtime error" not in result.stderr
