"""A system FMU for every platform its parts carry (issue 34): built on Linux for Windows, Linux on ARM and macOS, its
win64 DLL run under wine and its aarch64 binary under qemu-user give the x86_64 binary's outputs.

The quarter car with a damper, both FMUs built for every platform a compiler here builds, packed into one system FMU.
A small FMI 2 master in C (system_platform_driver.c, built for each platform) steps each binary 500 times at 1 ms
with the same drive (computed without libm, the same bits everywhere) and its slopes and prints every output.
- With a linear damper the system is arithmetic alone: every platform's run must give the x86_64 run bit for bit.
- With the trained damper-hysteresis network (tests/models/data) the aarch64 run must too (glibc's tanh on both);
  the win64 one takes msvcrt's tanh, which differs from glibc's in the last bit for some arguments (the network FMU's
  own open-loop test: 2.9e-16 of the peak, tests/fmu/test_win64.py). In the closed loop every output carries that
  from the first step, most the accelerations, sums of nearly cancelling forces: measured up to 6.6e-14 of the
  spindle acceleration's peak, 2.3e-14 of the damper force's, not growing over the run. The bound there is 1e-13.
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import onnx
import pytest

sys.path.insert(0, str(Path(__file__).parents[2] / "fmu"))  # the C masters' shared helpers (tests/fmu/)
from platform_drivers import compile_driver, glibc_versions  # noqa: E402

from nnfmu.cosim.container.build import build_system_fmu
from nnfmu.cosim.master import CosimError, CosimSettings
from nnfmu.cosim.ssp import connect_by_name, open_system, write_ssd
from nnfmu.export.linear_damper import linear_damper_graph
from nnfmu.fmu.build import build_fmu
from nnfmu.fmu.errors import PlatformSkippedWarning
from nnfmu.fmu.native import toolchain
from nnfmu.fmu.options import BuildOptions
from nnfmu.vehicle.fmu import VehicleBuildSettings, build_vehicle_fmu

pytestmark = [
    pytest.mark.slow,
    pytest.mark.skipif(shutil.which("cc") is None and shutil.which("gcc") is None, reason="no C compiler"),
]

NETWORK = Path(__file__).parents[2] / "models" / "data" / "damper-hysteresis-default.onnx"
H = 1e-3  # [s]
STEPS = 500
MSVCRT_TANH = 1e-13  # of each output's peak: the network's loop on win64 against glibc (see above)
MINGW = shutil.which(toolchain.WIN64_COMPILER)
ZIG = importlib.util.find_spec(toolchain.ZIG_MODULE) is not None
WINE = next(
    (f for f in (shutil.which("wine64"), shutil.which("wine"), "/usr/lib/wine/wine64") if f and os.access(f, os.X_OK)),
    None,
)
QEMU = shutil.which("qemu-aarch64")
ARM64_SYSROOT = Path("/usr/aarch64-linux-gnu")  # Debian's libc6-arm64-cross
FOLDERS = {"x86_64-linux": "linux64", "x86_64-windows": "win64", "aarch64-linux": "aarch64-linux"}
FOLDERS |= {"x86_64-darwin": "darwin64", "aarch64-darwin": "aarch64-darwin"}


def _platforms() -> tuple[str, ...]:
    """x86_64-linux, and each other platform a compiler here builds."""
    found = ["x86_64-linux"]
    if MINGW or ZIG:
        found.append("x86_64-windows")
    if ZIG:
        found += ["aarch64-linux", "x86_64-darwin", "aarch64-darwin"]
    return tuple(found)


def quarter_car(folder: Path, platforms: tuple[str, ...], damper_kind: str = "network") -> Path:
    """The quarter car (sampling at 1 ms) and the damper (the network, or linear: 2400 N.s/m), each FMU with binaries
    for `platforms`."""
    folder.mkdir(parents=True, exist_ok=True)
    graph = NETWORK
    if damper_kind == "linear":
        graph = folder / "linear.onnx"
        onnx.save(linear_damper_graph(2400.0), graph)
    damper = build_fmu(graph, BuildOptions(out=folder / "damper.fmu", platforms=platforms))
    settings = VehicleBuildSettings(sample_period=H, platforms=platforms)
    vehicle = build_vehicle_fmu("quarter-car", folder / "car.fmu", settings)
    return write_ssd(
        connect_by_name("quarter car", ("vehicle", vehicle), {"damper": damper}, folder), folder / "system.ssd"
    )


@pytest.fixture(scope="module", params=["linear", "network"])
def system_fmu(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    """(the system FMU, its damper's kind)."""
    folder = tmp_path_factory.mktemp(f"system_platforms_{request.param}")
    platforms = _platforms()
    with open_system(quarter_car(folder, platforms, request.param)) as system:
        build_system_fmu(
            system, folder / "car.fmu", H, None, CosimSettings(port_derivatives=False), platforms=platforms
        )
    return folder / "car.fmu", request.param


def unpacked(fmu: Path, folder: Path) -> tuple[Path, str, int, int]:
    """The FMU unpacked into `folder`: (folder, GUID, inputs, outputs)."""
    from fmpy import read_model_description

    with zipfile.ZipFile(fmu) as archive:
        archive.extractall(folder)
    description = read_model_description(str(fmu))
    n_in = sum(v.causality == "input" for v in description.modelVariables)
    n_out = sum(v.causality == "output" for v in description.modelVariables)
    return folder, description.guid, n_in, n_out


def driver(compiler: list[str], target: Path) -> Path:
    """system_platform_driver.c compiled by `compiler` into `target` (`compile_driver`), no fused multiply-adds."""
    # On Windows MinGW's own printf (msvcrt's prints %.17g inexactly) and no DLL of MinGW's runtime beside it.
    windows = ["-D__USE_MINGW_ANSI_STDIO=1", *(["-static"] if compiler == [MINGW] else [])]
    extra = ["-ffp-contract=off", *(windows if target.suffix == ".exe" else ["-ldl"])]
    return compile_driver(Path(__file__).with_name("system_platform_driver.c"), compiler, target, extra)


def outputs(run: subprocess.CompletedProcess) -> np.ndarray:
    """The rows a driver printed, after checking that it passed every status check."""
    assert run.returncode == 0 and "0 unexpected statuses" in run.stderr, run.stderr[-3000:]
    rows = [line.split() for line in run.stdout.replace("\r", "").splitlines()]
    assert [int(row[1]) for row in rows] == list(range(1, STEPS + 1))
    return np.array([[float(v) for v in row[2:]] for row in rows])


def assert_same(expected: np.ndarray, got: np.ndarray, bound: float, what: str) -> None:
    """Every output within `bound` of its peak (0: bit for bit)."""
    assert expected.shape == got.shape and expected.shape[1] > 5
    assert np.ptp(expected, axis=0).min() > 0  # every output moved
    relative = np.max(np.abs(got - expected), axis=0) / np.max(np.abs(expected), axis=0)
    assert np.all(relative <= bound), f"{what}, largest difference / peak per output: {relative}"


def linux_run(fmu: Path, tmp_path: Path) -> np.ndarray:
    folder, guid, n_in, n_out = unpacked(fmu, tmp_path / "fmu")
    identifier = fmu.stem
    library = folder / "binaries" / "linux64" / f"{identifier}.so"
    native = driver(["gcc"], tmp_path / "driver")
    args = [guid, (folder / "resources").as_uri(), str(n_in), str(n_out), str(STEPS)]
    return outputs(subprocess.run([str(native), str(library), *args], capture_output=True, text=True, timeout=120))


@pytest.mark.skipif(not (MINGW or ZIG), reason="no win64 compiler (MinGW-w64 or pip install 'nnfmu[cross]')")
@pytest.mark.skipif(WINE is None, reason="wine not installed (Debian: wine64 wine): cannot run win64 code")
def test_the_win64_system_fmu_under_wine_gives_the_linux64_outputs(system_fmu, tmp_path: Path) -> None:  # noqa: ANN001
    system_fmu, kind = system_fmu
    expected = linux_run(system_fmu, tmp_path)
    folder = tmp_path / "fmu"
    compiler = [MINGW] if MINGW else [sys.executable, "-m", "ziglang", "cc", "-target", "x86_64-windows-gnu"]
    exe = driver(compiler, tmp_path / "driver.exe")
    # wine maps / to Z:, so the resources' URI names them by drive letter, as a Windows master would.
    uri = "file:///Z:" + (folder / "resources").as_posix()
    _, guid, n_in, n_out = unpacked(system_fmu, folder)
    library = "Z:" + (folder / "binaries" / "win64" / f"{system_fmu.stem}.dll").as_posix()
    env = {**os.environ, "WINEPREFIX": str(tmp_path / "wineprefix"), "WINEDEBUG": "-all", "DISPLAY": ""}
    try:
        run = subprocess.run(
            [WINE, str(exe), library, guid, uri, str(n_in), str(n_out), str(STEPS)],
            env=env,
            capture_output=True,
            text=True,
            timeout=300,
        )
    finally:
        server = shutil.which("wineserver") or "/usr/lib/wine/wineserver64"
        if os.access(server, os.X_OK):
            subprocess.run([server, "-k"], env=env, capture_output=True, timeout=60, check=False)
    bound = 0.0 if kind == "linear" else MSVCRT_TANH
    assert_same(expected, outputs(run), bound, f"{kind} damper: win64 (wine) vs linux64")


@pytest.mark.skipif(not ZIG, reason="Zig not installed (pip install 'nnfmu[cross]'): no aarch64 build")
@pytest.mark.skipif(QEMU is None, reason="qemu-user not installed (Debian: qemu-user): cannot run aarch64 code")
@pytest.mark.skipif(not (ARM64_SYSROOT / "lib").is_dir(), reason="no aarch64 glibc (Debian: libc6-arm64-cross)")
def test_the_aarch64_system_fmu_under_qemu_gives_the_x86_64_outputs(system_fmu, tmp_path: Path) -> None:  # noqa: ANN001
    system_fmu, kind = system_fmu
    expected = linux_run(system_fmu, tmp_path)
    folder, guid, n_in, n_out = tmp_path / "fmu", *unpacked(system_fmu, tmp_path / "fmu")[1:]
    arm = driver([sys.executable, "-m", "ziglang", "cc", "-target", "aarch64-linux-gnu.2.17"], tmp_path / "driver-arm")
    library = folder / "binaries" / "aarch64-linux" / f"{system_fmu.stem}.so"
    args = [str(library), guid, (folder / "resources").as_uri(), str(n_in), str(n_out), str(STEPS)]
    run = subprocess.run([QEMU, "-L", str(ARM64_SYSROOT), str(arm), *args], capture_output=True, text=True, timeout=300)
    assert_same(expected, outputs(run), 0.0, f"{kind} damper: aarch64-linux (qemu) vs x86_64-linux")


@pytest.mark.skipif(not ZIG, reason="Zig not installed (pip install 'nnfmu[cross]'): no macOS build")
def test_the_macos_system_binaries_are_dylibs_loading_only_libsystem(system_fmu, tmp_path: Path) -> None:  # noqa: ANN001
    lief = pytest.importorskip("lief")
    system_fmu, _ = system_fmu
    folder = unpacked(system_fmu, tmp_path / "fmu")[0]
    cpus = {"darwin64": lief.MachO.Header.CPU_TYPE.X86_64, "aarch64-darwin": lief.MachO.Header.CPU_TYPE.ARM64}
    for platform, cpu in cpus.items():
        fat = lief.MachO.parse(str(folder / "binaries" / platform / f"{system_fmu.stem}.dylib"))
        dylib = fat.at(0)
        assert fat.size == 1 and dylib.header.cpu_type == cpu
        assert dylib.header.file_type == lief.MachO.Header.FILE_TYPE.DYLIB
        load = lief.MachO.LoadCommand.TYPE
        imported = {lib.name for lib in dylib.libraries if lib.command == load.LOAD_DYLIB}
        assert imported == {"/usr/lib/libSystem.B.dylib"}, (platform, imported)
        exported = {s.name.removeprefix("_") for s in dylib.exported_symbols} - {"_mh_dylib_header", "__dso_handle"}
        assert {"fmi2Instantiate", "fmi2DoStep"} <= exported and all(n.startswith("fmi2") for n in exported)
        parts = [p.name for p in (folder / "resources" / "fmus").iterdir()]
        assert all((folder / "resources" / "fmus" / p / "binaries" / platform).is_dir() for p in parts)


def test_a_platform_a_part_lacks_is_left_out_naming_the_part(tmp_path: Path) -> None:
    """The damper network built for Linux alone: a system FMU asked for Linux and Windows gets Linux and a warning
    naming the element; asked for Windows alone, it is refused naming it."""
    if not (MINGW or ZIG):
        pytest.skip("no win64 compiler (MinGW-w64 or pip install 'nnfmu[cross]')")
    folder = tmp_path / "system"
    folder.mkdir()
    damper = build_fmu(NETWORK, BuildOptions(out=folder / "damper.fmu", platforms=("x86_64-linux",)))
    both = ("x86_64-linux", "x86_64-windows")
    vehicle = build_vehicle_fmu(
        "quarter-car", folder / "car.fmu", VehicleBuildSettings(sample_period=H, platforms=both)
    )
    ssd = write_ssd(connect_by_name("quarter car", ("vehicle", vehicle), {"damper": damper}, folder), folder / "s.ssd")
    settings = CosimSettings(port_derivatives=False)
    with open_system(ssd) as system:
        with pytest.warns(PlatformSkippedWarning, match=r"x86_64-windows \(element 'damper' has no binary for it\)"):
            build_system_fmu(system, tmp_path / "car.fmu", H, None, settings, platforms=both)
        with pytest.raises(CosimError, match="element 'damper' has no binary for it"):
            build_system_fmu(system, tmp_path / "win.fmu", H, None, settings, platforms=("x86_64-windows",))
    with zipfile.ZipFile(tmp_path / "car.fmu") as archive:
        assert {n.split("/")[1] for n in archive.namelist() if n.startswith("binaries/")} == {"linux64"}
    assert not (tmp_path / "win.fmu").exists()
    command = [sys.executable, "-m", "nnfmu.cli", "system", "build", str(ssd), "--out", str(tmp_path / "cli.fmu")]
    done = subprocess.run([*command, "--platforms", ",".join(both)], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "binaries: linux64" in done.stdout.splitlines()
    assert "warning: no system FMU binary for x86_64-windows (element 'damper' has no binary for it)" in done.stderr


def test_the_fmi3_build_description_links_libdl_on_linux_only(tmp_path: Path) -> None:
    """An FMI 3 system FMU's sources/buildDescription.xml: one configuration per FMI 3 platform, its sources, the
    math library, and libdl on Linux alone (Windows and macOS have no libdl to link)."""
    from xml.etree import ElementTree

    with open_system(quarter_car(tmp_path / "system", ("x86_64-linux",), "linear")) as system:
        build_system_fmu(system, tmp_path / "car.fmu", H, None, CosimSettings(port_derivatives=False), fmi=3)
    with zipfile.ZipFile(tmp_path / "car.fmu") as archive:
        root = ElementTree.fromstring(archive.read("sources/buildDescription.xml"))
    libraries = {
        c.get("platform"): {library.get("name") for library in c.iter("Library")}
        for c in root.iter("BuildConfiguration")
    }
    assert set(libraries) == {p.name for p in toolchain.PLATFORMS}
    assert {p for p, names in libraries.items() if "dl" in names} == {"x86_64-linux", "aarch64-linux"}
    assert all("m" in names for names in libraries.values())
    sources = {s.get("name") for s in root.iter("SourceFile")}
    assert sources == {"system_fmu3.c", "inner_loop.c"}


@pytest.mark.skipif(not ZIG, reason="Zig not installed (pip install 'nnfmu[cross]'): no glibc-2.17 build")
def test_the_linux_system_binaries_need_no_glibc_newer_than_2_17(system_fmu, tmp_path: Path) -> None:  # noqa: ANN001
    """Built by Zig for the manylinux2014 baseline, as the network FMUs are: libc, libm and libdl (where glibc 2.17
    keeps dlopen) and no newer symbol version; the FMI functions alone exported."""
    lief = pytest.importorskip("lief")
    if os.environ.get("CC", "").strip():
        pytest.skip("$CC set: the host compiler builds the x86_64 binary, for this machine's glibc")
    folder = unpacked(system_fmu[0], tmp_path / "fmu")[0]
    for platform in ("linux64", "aarch64-linux"):
        library = lief.ELF.parse(str(folder / "binaries" / platform / f"{system_fmu[0].stem}.so"))
        assert set(library.libraries) <= {"libc.so.6", "libm.so.6", "libdl.so.2"}, (platform, library.libraries)
        versions, newest = glibc_versions(library)
        assert versions and newest <= (2, 17), (platform, sorted(versions))
        exported = {symbol.name for symbol in library.exported_symbols}
        assert "fmi2DoStep" in exported and all(name.startswith("fmi2") for name in exported), platform
