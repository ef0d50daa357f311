"""win64 binaries: the FMU's DLL, cross-compiled with MinGW-w64, runs under wine and gives the linux64 binary's
outputs; without the cross compiler a default build warns and still lands, an explicit request fails.

The C masters of test_memcheck.py (fmi2_driver.c, fmi3_driver.c: every glue path, outputs printed after each step,
directional derivatives every 500 steps) are built twice: for linux64 (dlopen of the .so) and, cross-compiled, for
win64 (LoadLibrary of the .dll, run by wine). Both must pass every status check and print the same outputs.
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from platform_drivers import assert_same_outputs, build_driver, counts

from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.errors import CompilerError, PlatformSkippedWarning
from nnfmu.fmu.native import toolchain
from nnfmu.fmu.options import BuildOptions

MINGW = shutil.which(toolchain.WIN64_COMPILER)
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
    reason=f"{toolchain.WIN64_COMPILER} not installed (Debian: gcc-mingw-w64-x86-64): no win64 binary to test",
)
needs_wine = pytest.mark.skipif(WINE is None, reason="wine not installed (Debian: wine64 wine): cannot run win64 code")
FOLDERS = {2: ("linux64", "win64"), 3: ("x86_64-linux", "x86_64-windows")}
NO_ZIG = "nnfmu_test_no_zig"  # a module name that is not installed: the toolchain then finds no Zig


def _without_cross_compilers(monkeypatch: pytest.MonkeyPatch) -> None:
    """Neither MinGW-w64 nor Zig found: what a machine without the apt package and the cross extra has."""
    monkeypatch.delenv("CC_WIN64", raising=False)
    monkeypatch.delenv(toolchain.PLATFORMS_VARIABLE, raising=False)  # the default choice (tests/conftest.py sets it)
    monkeypatch.setattr(toolchain, "WIN64_COMPILER", "x86_64-w64-mingw32-gcc-not-installed")
    monkeypatch.setattr(toolchain, "ZIG_MODULE", NO_ZIG)


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
    identifier, *_ = counts(delay_fmus[fmi])
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


def _assert_wine_gives_linux_outputs(
    fmu: Path, fmi: int, driver_compiler: list[str], driver_flags: list[str], tmp_path: Path, wine_env: dict, what: str
) -> None:
    """The FMU's Linux .so driven natively and its DLL driven under wine by a driver `driver_compiler` builds: both
    runs pass every status check and print the same outputs."""
    identifier, token, n_in, n_out = counts(fmu)
    linux, windows = FOLDERS[fmi]
    with zipfile.ZipFile(fmu) as archive:
        (tmp_path / "fmu.so").write_bytes(archive.read(f"binaries/{linux}/{identifier}.so"))
        (tmp_path / "fmu.dll").write_bytes(archive.read(f"binaries/{windows}/{identifier}.dll"))
    args = [token, str(n_in), str(n_out)]
    native = build_driver(["gcc"], fmi, tmp_path / "driver", [])
    build_driver(driver_compiler, fmi, tmp_path / "driver.exe", driver_flags)
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
    assert_same_outputs(on_linux.stdout, on_wine.stdout, n_out, what)


@pytest.mark.slow
@needs_mingw
@needs_wine
@pytest.mark.parametrize("fmi", [2, 3])
def test_win64_binary_under_wine_gives_the_linux64_outputs(delay_fmus, tmp_path, wine_env, fmi):
    flags = ["-D__USE_MINGW_ANSI_STDIO=1", "-static"]
    _assert_wine_gives_linux_outputs(delay_fmus[fmi], fmi, [MINGW], flags, tmp_path, wine_env, "win64 vs linux64")


def _zig_windows_runtime_built() -> bool:
    """Zig is installed and has compiled its MinGW-w64 runtime into its cache (its first x86_64-windows build: 80 s on
    2 idle cores, far longer on a loaded machine, so not inside the suite: `.ci/run` does it first, as any
    `python -m ziglang cc -target x86_64-windows-gnu -shared` does once)."""
    if importlib.util.find_spec(toolchain.ZIG_MODULE) is None:
        return False
    cache = Path(os.environ.get("ZIG_GLOBAL_CACHE_DIR", Path.home() / ".cache" / "zig"))
    return any((cache / "o").glob("*/libmingw32.lib"))


@needs_wine
@pytest.mark.slow
@pytest.mark.skipif(not _zig_windows_runtime_built(), reason="Zig's Windows runtime is not compiled in its cache here")
@pytest.mark.parametrize("fmi", [2, 3])
def test_zig_built_win64_binary_under_wine_gives_the_linux64_outputs(delay_onnx, tmp_path, wine_env, monkeypatch, fmi):
    """What a machine with the pip extra alone (no MinGW) ships for Windows: Zig's DLL, run by a Zig-built driver."""
    monkeypatch.setattr(toolchain, "WIN64_COMPILER", "x86_64-w64-mingw32-gcc-not-installed")
    monkeypatch.delenv("CC_WIN64", raising=False)
    (windows_target,) = [p for p in toolchain.PLATFORMS if p.name == "x86_64-windows"]
    assert [t.label.split()[0] for t in toolchain.candidates(windows_target)] == ["Zig"]
    built = build_fmu(
        delay_onnx, BuildOptions(out=tmp_path / "zig.fmu", fmi_version=fmi, platforms=("host", "x86_64-windows"))
    )
    identifier = counts(built)[0]
    linux, windows = FOLDERS[fmi]
    with zipfile.ZipFile(built) as archive:
        binaries = sorted(n for n in archive.namelist() if n.startswith("binaries/"))
    assert binaries == [f"binaries/{linux}/{identifier}.so", f"binaries/{windows}/{identifier}.dll"]  # no .pdb/.lib
    zig = [sys.executable, "-m", toolchain.ZIG_MODULE, "cc", "-target", windows_target.zig_target]
    flags = ["-D__USE_MINGW_ANSI_STDIO=1"]
    _assert_wine_gives_linux_outputs(built, fmi, zig, flags, tmp_path, wine_env, "Zig win64 vs linux64")


def test_missing_cross_compilers_warn_once_and_still_build_linux64(delay_onnx, tmp_path, monkeypatch):
    _without_cross_compilers(monkeypatch)
    with pytest.warns(PlatformSkippedWarning, match="x86_64-windows.*nnfmu.cross.*gcc-mingw-w64-x86-64") as caught:
        path = build_fmu(delay_onnx, BuildOptions(out=tmp_path / "linux.fmu"))
    assert len(caught) == 1
    binaries = [n for n in zipfile.ZipFile(path).namelist() if n.startswith("binaries/")]
    assert binaries == ["binaries/linux64/damper.so"]


def test_asking_for_win64_without_the_cross_compilers_fails_naming_it(delay_onnx, tmp_path, monkeypatch):
    _without_cross_compilers(monkeypatch)
    with pytest.raises(CompilerError, match="x86_64-windows.*gcc-mingw-w64-x86-64"):
        build_fmu(delay_onnx, BuildOptions(out=tmp_path / "both.fmu", platforms=("linux64", "win64")))
    assert not (tmp_path / "both.fmu").exists()


def test_unknown_platform_and_platforms_for_pythonfmu_are_refused(delay_onnx, tmp_path):
    with pytest.raises(CompilerError, match="'win32'.*x86_64-linux .linux64.*x86_64-windows .win64."):
        build_fmu(delay_onnx, BuildOptions(out=tmp_path / "x.fmu", platforms=("win32",)))
    with pytest.raises(Exception, match="native backend"):
        BuildOptions(backend="pythonfmu", platforms=("win64",))
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
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

    _without_cross_compilers(monkeypatch)
    result = CliRunner().invoke(app, ["build", str(delay_onnx), "--out", str(tmp_path / "d.fmu")])
    assert result.exit_code == 0, result.output
    warnings = [line for line in result.output.splitlines() if line.startswith("warning:")]
    assert len(warnings) == 1 and "apt-get install gcc-mingw-w64-x86-64" in warnings[0]
    assert "binaries: linux64" in result.output.splitlines()
    refused = CliRunner().invoke(
        app, ["build", str(delay_onnx), "--out", str(tmp_path / "e.fmu"), "--platforms", "linux64,win64"]
    )
    assert refused.exit_code == 2 and "x86_64-windows" in refused.output and "nnfmu[cross]" in refused.output
    assert not (tmp_path / "e.fmu").exists()
