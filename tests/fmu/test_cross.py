"""Binaries for every FMI platform from this Linux machine (docs/platforms.md): which compiler builds which platform,
the aarch64-linux binary run under qemu-user giving the x86_64-linux outputs, the macOS dylibs read as Mach-O, the
Linux binaries' glibc baseline, and a five-platform FMU that fmpy validates.

The cross builds need Zig (`pip install 'nnfmu[cross]'`); they skip without it. The qemu test also needs Debian's
qemu-user and libc6-arm64-cross (.ci/run installs them). The FMUs are the session's default builds (conftest.py's
`delay_fmus`), whose win64 DLL MinGW-w64 builds where installed; without it Zig's first Windows build compiles its
C runtime into Zig's cache once (half an hour on a loaded 2-core machine), which is why .ci/run installs the cross
extra only beside MinGW-w64.
"""

from __future__ import annotations

import importlib.util
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from platform_drivers import assert_same_outputs, build_driver, counts, glibc_versions

from nnfmu.errors import NnfmuError
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.errors import CompilerError
from nnfmu.fmu.native import toolchain
from nnfmu.fmu.options import BuildOptions

pytestmark = pytest.mark.slow  # every platform's binaries built and run under wine and qemu

ZIG = importlib.util.find_spec("ziglang") is not None
MINGW = shutil.which(toolchain.WIN64_COMPILER)
QEMU = shutil.which("qemu-aarch64")
ARM64_SYSROOT = Path("/usr/aarch64-linux-gnu")  # Debian's libc6-arm64-cross: the aarch64 glibc qemu-user loads
needs_zig = pytest.mark.skipif(not ZIG, reason="Zig not installed (pip install 'nnfmu[cross]'): no cross builds")
FOLDERS = {
    2: {"x86_64-linux": "linux64", "aarch64-linux": "aarch64-linux", "x86_64-windows": "win64"}
    | {"x86_64-darwin": "darwin64", "aarch64-darwin": "aarch64-darwin"},
    3: {p.name: p.name for p in toolchain.PLATFORMS},
}
NO_ZIG = "nnfmu_test_no_zig"


@pytest.fixture(scope="module")
def cross_fmus(delay_fmus: dict[int, Path]) -> dict[int, Path]:
    """The session's default builds of the damper graph (FMI 2 and 3): with Zig they carry every platform."""
    if not ZIG:
        pytest.skip("Zig not installed (pip install 'nnfmu[cross]'): no cross builds")
    return delay_fmus


def _binary(fmu: Path, fmi: int, platform: str, folder: Path) -> Path:
    """The FMU's library for `platform`, written into `folder`."""
    identifier = counts(fmu)[0]
    suffix = toolchain.BY_NAME[platform].suffix
    target = folder / f"{platform}{suffix}"
    with zipfile.ZipFile(fmu) as archive:
        target.write_bytes(archive.read(f"binaries/{FOLDERS[fmi][platform]}/{identifier}{suffix}"))
    return target


def test_the_toolchain_prefers_mingw_for_windows_and_zig_for_the_linux_baseline(monkeypatch):
    monkeypatch.delenv("CC", raising=False)
    linux, windows = toolchain.BY_NAME["linux64"], toolchain.BY_NAME["win64"]
    assert (linux.folder(2), linux.folder(3), windows.folder(2), windows.folder(3)) == (
        "linux64",
        "x86_64-linux",
        "win64",
        "x86_64-windows",
    )
    assert toolchain.BY_NAME["aarch64-darwin"].folder(2) == "aarch64-darwin"  # FMI 2.0.4 section 2.3: FMI 3 tuples
    if MINGW:
        assert toolchain.candidates(windows)[0].label.startswith("MinGW-w64")
    if ZIG:
        assert [t.label.split()[0] for t in toolchain.candidates(toolchain.BY_NAME["aarch64-darwin"])] == ["Zig"]
        if toolchain.host_platform_of() == linux:
            assert toolchain.candidates(linux)[0].label.endswith("glibc 2.17")
            monkeypatch.setenv("CC", "gcc")  # a compiler the user names comes first
            assert toolchain.candidates(linux)[0].label == "host compiler gcc"


def test_without_zig_a_default_build_names_what_it_left_out_and_all_is_refused(monkeypatch):
    monkeypatch.setattr(toolchain, "ZIG_MODULE", NO_ZIG)
    monkeypatch.delenv(toolchain.PLATFORMS_VARIABLE, raising=False)  # the default choice (tests/conftest.py sets it)
    targets, warning = toolchain.select_targets(None)
    host = toolchain.host_platform_of().name
    assert [t.name for t in targets] == [host] + (["x86_64-windows"] if MINGW else [])
    left_out = [p.name for p in toolchain.PLATFORMS if p.name not in (host, "x86_64-windows")]
    assert warning is not None and all(name in warning for name in left_out) and "nnfmu[cross]" in warning
    with pytest.raises(CompilerError, match="--platforms all: no compiler here builds aarch64-linux.*nnfmu.cross"):
        toolchain.select_targets(("all",))
    assert [t.name for t in toolchain.select_targets(("host",))[0]] == [host]
    with toolchain.host_binaries_only():
        assert toolchain.select_targets(None) == (toolchain.select_targets(("host",))[0], None)


def test_binaries_that_never_leave_this_machine_are_built_by_the_host_compiler(monkeypatch):
    monkeypatch.delenv("CC", raising=False)
    monkeypatch.delenv(toolchain.PLATFORMS_VARIABLE, raising=False)
    host = toolchain.host_platform_of()
    with toolchain.host_binaries_only():
        (target,), warning = toolchain.select_targets(None)
    assert warning is None and target.name == host.name and target.label.startswith("host compiler")
    if ZIG and host.name.endswith("linux"):  # outside it a Linux host keeps Zig first (the glibc baseline)
        assert toolchain.candidates(host)[0].label.startswith("Zig")


def test_nnfmu_platforms_is_the_default_choice(monkeypatch):
    host = toolchain.host_platform_of().name
    monkeypatch.setenv(toolchain.PLATFORMS_VARIABLE, " host, ")
    assert [t.name for t in toolchain.select_targets(None)[0]] == [host]
    assert [t.name for t in toolchain.select_targets(("x86_64-linux",))[0]] == ["x86_64-linux"]  # named ones win
    monkeypatch.setenv(toolchain.PLATFORMS_VARIABLE, "armv7-linux")
    with pytest.raises(CompilerError, match=r"\$NNFMU_PLATFORMS: unknown platform 'armv7-linux'"):
        toolchain.select_targets(None)


def test_platform_names_are_checked_before_anything_is_built(delay_onnx, tmp_path):
    for bad in (("armv7-linux",), ()):
        with pytest.raises(NnfmuError, match="--platforms: .*choose from host, all, or x86_64-linux"):
            build_fmu(delay_onnx, BuildOptions(out=tmp_path / "x.fmu", platforms=bad))
    assert list(tmp_path.iterdir()) == []


@needs_zig
@pytest.mark.skipif(QEMU is None, reason="qemu-user not installed (Debian: qemu-user): cannot run aarch64 code")
@pytest.mark.skipif(
    not (ARM64_SYSROOT / "lib" / "ld-linux-aarch64.so.1").is_file(),
    reason="no aarch64 glibc for qemu-user (Debian: libc6-arm64-cross)",
)
@pytest.mark.slow
@pytest.mark.parametrize("fmi", [2, 3])
def test_aarch64_linux_binary_under_qemu_gives_the_x86_64_linux_outputs(cross_fmus, tmp_path, fmi):
    _, token, n_in, n_out = counts(cross_fmus[fmi])
    x86, arm = (_binary(cross_fmus[fmi], fmi, p, tmp_path) for p in ("x86_64-linux", "aarch64-linux"))
    zig = [sys.executable, "-m", "ziglang", "cc", "-target"]
    # glibc 2.17 keeps dlopen in libdl. -ffp-contract=off, as the FMU is built: clang fuses the driver's input
    # 0.01 * k + i into one fma on aarch64 otherwise, and the two runs then start from inputs a bit apart.
    extra = ["-ffp-contract=off", "-ldl"]
    native = build_driver(["gcc"], fmi, tmp_path / "driver", extra)
    arm_driver = build_driver([*zig, "aarch64-linux-gnu.2.17"], fmi, tmp_path / "driver-arm", extra)
    args = [token, str(n_in), str(n_out)]
    on_x86 = subprocess.run([str(native), str(x86), *args], capture_output=True, text=True, timeout=120)
    on_arm = subprocess.run(
        [QEMU, "-L", str(ARM64_SYSROOT), str(arm_driver), str(arm), *args],
        capture_output=True,
        text=True,
        timeout=300,
    )
    for run in (on_x86, on_arm):
        assert run.returncode == 0, run.stderr[-3000:]
        assert "0 unexpected statuses" in run.stderr
    assert_same_outputs(on_x86.stdout, on_arm.stdout, n_out, "aarch64-linux (qemu) vs x86_64-linux")


@needs_zig
@pytest.mark.parametrize("fmi", [2, 3])
def test_macos_binaries_are_dylibs_exporting_the_fmi_functions_and_importing_only_libsystem(cross_fmus, tmp_path, fmi):
    lief = pytest.importorskip("lief")
    identifier = counts(cross_fmus[fmi])[0]
    # What the Linux binary of the same sources exports (test_memcheck.py runs it through every FMI call)
    linux = lief.ELF.parse(str(_binary(cross_fmus[fmi], fmi, "x86_64-linux", tmp_path)))  # kept alive: lief's
    functions = {symbol.name for symbol in linux.exported_symbols}  # iterators do not hold their binary
    assert len(functions) > 25 and {f"fmi{fmi}FreeInstance", f"fmi{fmi}DoStep"} <= functions
    assert all(name.startswith(f"fmi{fmi}") for name in functions), functions
    cpus = {"x86_64-darwin": lief.MachO.Header.CPU_TYPE.X86_64, "aarch64-darwin": lief.MachO.Header.CPU_TYPE.ARM64}
    for platform, cpu in cpus.items():
        fat = lief.MachO.parse(str(_binary(cross_fmus[fmi], fmi, platform, tmp_path)))
        assert fat.size == 1  # one architecture, not a universal binary
        dylib = fat.at(0)
        assert dylib.header.cpu_type == cpu and dylib.header.file_type == lief.MachO.Header.FILE_TYPE.DYLIB
        load = lief.MachO.LoadCommand.TYPE
        imported = {lib.name for lib in dylib.libraries if lib.command == load.LOAD_DYLIB}
        assert imported == {"/usr/lib/libSystem.B.dylib"}, (platform, imported)
        own = [c for c in dylib.commands if c.command == load.ID_DYLIB]
        assert len(own) == 1 and own[0].name == f"@rpath/{identifier}.dylib"
        assert dylib.build_version.minos == [11, 0, 0]
        exported = {s.name.removeprefix("_") for s in dylib.exported_symbols}
        linker_made = {"_mh_dylib_header", "__dso_handle"}
        assert exported - linker_made == functions, (platform, exported ^ functions)
        if platform == "aarch64-darwin":  # Apple silicon loads only signed code; the linker signs ad hoc
            assert dylib.has_code_signature


@needs_zig
def test_linux_binaries_need_no_glibc_newer_than_2_17(cross_fmus, tmp_path):
    lief = pytest.importorskip("lief")
    machines = {"x86_64-linux": lief.ELF.ARCH.X86_64, "aarch64-linux": lief.ELF.ARCH.AARCH64}
    for platform, machine in machines.items():
        library = lief.ELF.parse(str(_binary(cross_fmus[3], 3, platform, tmp_path)))
        assert library.header.machine_type == machine
        assert set(library.libraries) <= {"libc.so.6", "libm.so.6"}, (platform, library.libraries)
        versions, newest = glibc_versions(library)
        assert versions and newest <= (2, 17), (platform, sorted(versions))


@needs_zig
@pytest.mark.parametrize("fmi", [2, 3])
def test_a_default_build_carries_all_five_platforms_and_validates_with_fmpy(cross_fmus, fmi):
    from fmpy.validation import validate_fmu

    with zipfile.ZipFile(cross_fmus[fmi]) as archive:
        binaries = [n for n in archive.namelist() if n.startswith("binaries/")]
    folders = [n.split("/")[1] for n in binaries]
    assert sorted(folders) == sorted(FOLDERS[fmi].values()), binaries  # one library per folder, no linker by-products
    assert validate_fmu(str(cross_fmus[fmi])) == []
