"""win64 binaries: the FMU's DLL, cross-compiled with MinGW-w64, runs under wine and gives the linux64 binary's
outputs; without the cross compiler a default build warns and still lands, an explicit request fails.

The C masters of test_memcheck.py (fmi2_driver.c, fmi3_driver.c: every glue path, outputs printed after each step,
directional derivatives every 500 steps) are built twice: for linux64 (dlopen of the .so) and, cross-compiled, for
win64 (LoadLibrary of the .dll, run by wine). Both must pass every status check and print the same outputs.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description

from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.errors import CompilerError, PlatformSkippedWarning
from nnfmu.fmu.native import compiler
from nnfmu.fmu.native.backend import fmi_headers_dir
from nnfmu.fmu.options import BuildOptions

MINGW = shutil.which(compiler.WIN64_COMPILER)
MINGW_OBJDUMP = shutil.which("x86_64-w64-mingw32-objdump")
WINE = next(
    (
        found
        for found in (shutil.which("wine64"), shutil.which("wine"), "/usr/lib/wine/wine64")
        if found and os.access(found, os.X_OK)
    ),
    None,
)
needs_mingw = pytest.mark.skipif(
    MINGW is None,
    reason=f"{compiler.WIN64_COMPILER} not installed (Debian: gcc-mingw-w64-x86-64): no win64 binary to test",
)
needs_wine = pytest.mark.skipif(WINE is None, reason="wine not installed (Debian: wine64 wine): cannot run win64 code")
FOLDERS = {2: ("linux64", "win64"), 3: ("x86_64-linux", "x86_64-windows")}
# The brief's bound, relative to each output's largest magnitude over the run. msvcrt's tanh and glibc's differ in
# the last bit for some arguments: measured 1.6e-16 and 2.9e-16 of the peak (8.5e-15 of a value near a zero crossing).
RELATIVE = 1e-15


def _counts(path: Path) -> tuple[str, str, int, int]:
    md = read_model_description(str(path))
    n_in = sum(v.causality == "input" for v in md.modelVariables)
    n_out = sum(v.causality == "output" and v.type in ("Real", "Float64") for v in md.modelVariables)
    return md.coSimulation.modelIdentifier, md.guid, n_in, n_out


def _driver(cc: str, fmi: int, target: Path, extra: list[str]) -> Path:
    source = Path(__file__).with_name(f"fmi{fmi}_driver.c")
    subprocess.run(
        [
            cc,
            "-std=c99",
            "-O2",
            "-Wall",
            "-Wextra",
            "-Werror",
            *extra,
            f"-I{fmi_headers_dir()}",
            "-o",
            str(target),
            str(source),
            "-lm",
        ],
        check=True,
        capture_output=True,
        text=True,
    )
    return target


def _outputs(stdout: str) -> list[tuple[str, int, list[float]]]:
    rows = []
    for line in stdout.splitlines():
        tag, k, *values = line.split()
        rows.append((tag, int(k), [float(v) for v in values]))
    return rows


@pytest.fixture(scope="module")
def wine_env(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    """A private wine prefix (made on first use, ~20 s), its wineserver shut down after the module."""
    env = {
        **os.environ,
        "WINEPREFIX": str(tmp_path_factory.mktemp("wineprefix") / "prefix"),
        "WINEDEBUG": "-all",
        "DISPLAY": "",
    }
    yield env
    server = shutil.which("wineserver") or "/usr/lib/wine/wineserver64"
    if os.access(server, os.X_OK):
        subprocess.run([server, "-k"], env=env, capture_output=True, timeout=60, check=False)


@needs_mingw
@pytest.mark.parametrize("fmi", [2, 3])
def test_default_build_carries_both_binaries_and_the_dll_exports_only_fmi_functions(delay_fmus, tmp_path, fmi):
    identifier, *_ = _counts(delay_fmus[fmi])
    linux, windows = FOLDERS[fmi]
    with zipfile.ZipFile(delay_fmus[fmi]) as archive:
        names = set(archive.namelist())
        assert f"binaries/{linux}/{identifier}.so" in names and f"binaries/{windows}/{identifier}.dll" in names
        (tmp_path / "fmu.dll").write_bytes(archive.read(f"binaries/{windows}/{identifier}.dll"))
    if MINGW_OBJDUMP is None:
        pytest.skip("x86_64-w64-mingw32-objdump not installed: cannot list the DLL's exports")
    listing = subprocess.run(
        [MINGW_OBJDUMP, "-p", str(tmp_path / "fmu.dll")], capture_output=True, text=True, check=True
    ).stdout
    table = listing[listing.index("[Ordinal/Name Pointer] Table") :]
    exported = [line.split("]")[-1].strip() for line in table.splitlines()[1:] if line.strip().startswith("[")]
    assert exported and all(name.startswith(f"fmi{fmi}") for name in exported), exported
    imported = {line.split(":")[1].strip() for line in listing.splitlines() if "DLL Name:" in line}
    assert imported == {"KERNEL32.dll", "msvcrt.dll"}  # no MinGW runtime DLL to ship beside it


@needs_mingw
@needs_wine
@pytest.mark.parametrize("fmi", [2, 3])
def test_win64_binary_under_wine_gives_the_linux64_outputs(delay_fmus, tmp_path, wine_env, fmi):
    identifier, token, n_in, n_out = _counts(delay_fmus[fmi])
    linux, windows = FOLDERS[fmi]
    with zipfile.ZipFile(delay_fmus[fmi]) as archive:
        (tmp_path / "fmu.so").write_bytes(archive.read(f"binaries/{linux}/{identifier}.so"))
        (tmp_path / "fmu.dll").write_bytes(archive.read(f"binaries/{windows}/{identifier}.dll"))
    args = [token, str(n_in), str(n_out)]
    native = _driver("gcc", fmi, tmp_path / "driver", [])
    _driver(MINGW, fmi, tmp_path / "driver.exe", ["-D__USE_MINGW_ANSI_STDIO=1", "-static"])
    on_linux = subprocess.run(
        [str(native), str(tmp_path / "fmu.so"), *args], capture_output=True, text=True, timeout=120
    )
    # The DLL is loaded by its bare name from the program's folder (Windows search order); no path conversion.
    on_wine = subprocess.run(
        [WINE, "driver.exe", "fmu.dll", *args], cwd=tmp_path, env=wine_env, capture_output=True, text=True, timeout=300
    )
    for run in (on_linux, on_wine):
        assert run.returncode == 0, run.stderr[-3000:]
        assert "0 unexpected statuses" in run.stderr
    expected, got = _outputs(on_linux.stdout), _outputs(on_wine.stdout.replace("\r", ""))
    # 2001 rows of outputs (initialisation, 2000 steps) and 4 of directional derivatives
    assert len(expected) == 2005 and [row[:2] for row in got] == [row[:2] for row in expected]
    assert sum(row[0] == "derivative" for row in expected) == 4
    want = np.array([row[2] for row in expected])
    have = np.array([row[2] for row in got])
    assert want.shape == have.shape == (2005, n_out)
    relative = np.max(np.abs(have - want), axis=0) / np.max(np.abs(want), axis=0)
    assert np.all(relative <= RELATIVE), f"win64 vs linux64, largest difference / peak per output: {relative}"


def test_missing_cross_compiler_warns_once_and_still_builds_linux64(delay_onnx, tmp_path, monkeypatch):
    monkeypatch.delenv("CC_WIN64", raising=False)
    monkeypatch.setattr(compiler, "WIN64_COMPILER", "x86_64-w64-mingw32-gcc-not-installed")
    with pytest.warns(PlatformSkippedWarning, match="x86_64-w64-mingw32-gcc.*gcc-mingw-w64-x86-64") as caught:
        path = build_fmu(delay_onnx, BuildOptions(out=tmp_path / "linux.fmu"))
    assert len(caught) == 1
    binaries = [n for n in zipfile.ZipFile(path).namelist() if n.startswith("binaries/")]
    assert binaries == ["binaries/linux64/damper.so"]


def test_asking_for_win64_without_the_cross_compiler_fails_naming_it(delay_onnx, tmp_path, monkeypatch):
    monkeypatch.delenv("CC_WIN64", raising=False)
    monkeypatch.setattr(compiler, "WIN64_COMPILER", "x86_64-w64-mingw32-gcc-not-installed")
    with pytest.raises(CompilerError, match="x86_64-w64-mingw32-gcc"):
        build_fmu(delay_onnx, BuildOptions(out=tmp_path / "both.fmu", platforms=("linux64", "win64")))
    assert not (tmp_path / "both.fmu").exists()


def test_unknown_platform_and_platforms_for_pythonfmu_are_refused(delay_onnx, tmp_path):
    with pytest.raises(CompilerError, match="'win32'.*linux64, win64"):
        build_fmu(delay_onnx, BuildOptions(out=tmp_path / "x.fmu", platforms=("win32",)))
    with pytest.raises(Exception, match="native backend"):
        BuildOptions(backend="pythonfmu", platforms=("win64",))
    assert list(tmp_path.iterdir()) == []


@needs_mingw
def test_platforms_choose_the_binaries(delay_onnx, tmp_path):
    only_windows = build_fmu(delay_onnx, BuildOptions(out=tmp_path / "w.fmu", fmi_version=3, platforms=("win64",)))
    only_linux = build_fmu(delay_onnx, BuildOptions(out=tmp_path / "l.fmu", platforms=("linux64",)))
    assert [n for n in zipfile.ZipFile(only_windows).namelist() if n.startswith("binaries/")] == [
        "binaries/x86_64-windows/damper.dll"
    ]
    assert [n for n in zipfile.ZipFile(only_linux).namelist() if n.startswith("binaries/")] == [
        "binaries/linux64/damper.so"
    ]


def test_cli_says_in_one_warning_line_that_win64_was_left_out(delay_onnx, tmp_path, monkeypatch):
    from typer.testing import CliRunner

    from nnfmu.cli import app

    monkeypatch.delenv("CC_WIN64", raising=False)
    monkeypatch.setattr(compiler, "WIN64_COMPILER", "x86_64-w64-mingw32-gcc-not-installed")
    result = CliRunner().invoke(app, ["build", str(delay_onnx), "--out", str(tmp_path / "d.fmu")])
    assert result.exit_code == 0, result.output
    warnings = [line for line in result.output.splitlines() if line.startswith("warning:")]
    assert len(warnings) == 1 and "apt-get install gcc-mingw-w64-x86-64" in warnings[0]
    refused = CliRunner().invoke(
        app, ["build", str(delay_onnx), "--out", str(tmp_path / "e.fmu"), "--platforms", "linux64,win64"]
    )
    assert refused.exit_code == 2 and "x86_64-w64-mingw32-gcc" in refused.output
    assert not (tmp_path / "e.fmu").exists()
