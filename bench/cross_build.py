"""Benchmark of the cross-platform builds: per FMI platform, the time its compiler takes on one FMU's sources, with
Zig's cache empty (`first_s`: the first build on a machine), holding its runtime but not these sources (`new_s`:
every later build of another FMU) and holding these very sources (`cached_s`: a rebuild); the last stdout line is JSON.

The sources are those `nnfmu build ONNX` writes (the FMU is built for this machine first and its `sources/` read
back). Zig's cold runs use a fresh cache folder (`ZIG_GLOBAL_CACHE_DIR`), so they pay for Zig's own C runtime
pieces once per target; its Windows target is left out unless `--zig-windows` is given (its first build compiles
the MinGW C runtime: over half an hour on a loaded 2-core machine). Then one whole `build_fmu` per platform choice.

Usage: python bench/cross_build.py ONNX [--fmi 2|3] [--zig-windows] [--out FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import tempfile
import time
import zipfile
from pathlib import Path

from nnfmu.fmu.native import toolchain
from nnfmu.fmu.native.backend import source_files
from nnfmu.fmu.native.compiler import compile_shared_library
from nnfmu.workflows.fmu_build import BuildOptions, build_fmu


def _timed(target: toolchain.Target, sources: Path, fmi: int, out: Path) -> float:
    start = time.perf_counter()
    compile_shared_library(target, [sources / s for s in source_files(fmi)], sources, out / f"lib{target.suffix}")
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("onnx", type=Path)
    parser.add_argument("--fmi", type=int, default=2, choices=(2, 3))
    parser.add_argument("--zig-windows", action="store_true")
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch)
        fmu = build_fmu(args.onnx, BuildOptions(out=folder / "host.fmu", fmi_version=args.fmi, platforms=("host",)))
        with zipfile.ZipFile(fmu) as archive:
            for name in archive.namelist():
                if name.startswith("sources/"):
                    archive.extract(name, folder)
        sources = folder / "sources"
        cold_cache = folder / "zig-cache"
        for target_platform in toolchain.PLATFORMS:
            for target in toolchain.candidates(target_platform):
                zig = target.label.startswith("Zig")
                if zig and target_platform.name == "x86_64-windows" and not args.zig_windows:
                    continue
                row = {"platform": target_platform.name, "compiler": target.label}
                if zig:
                    os.environ["ZIG_GLOBAL_CACHE_DIR"] = str(cold_cache)
                    row["first_s"] = round(_timed(target, sources, args.fmi, folder), 2)
                    for name in ("graph.c", "graph.h", "config.h"):  # sources Zig has not seen: every file
                        with (sources / name).open("a", encoding="utf-8") as changed:  # includes one of these
                            changed.write(f"/* {target_platform.name} */\n")
                    row["new_s"] = round(_timed(target, sources, args.fmi, folder), 2)
                row["cached_s" if zig else "s"] = round(_timed(target, sources, args.fmi, folder), 2)
                os.environ.pop("ZIG_GLOBAL_CACHE_DIR", None)
                rows.append(row)
                print(row, flush=True)
        whole = {}
        for choice in (("host",), None):
            start = time.perf_counter()
            build_fmu(args.onnx, BuildOptions(out=folder / "whole.fmu", fmi_version=args.fmi, platforms=choice))
            whole["default" if choice is None else ",".join(choice)] = round(time.perf_counter() - start, 2)
            (folder / "whole.fmu").unlink()
    result = {
        "onnx": str(args.onnx),
        "fmi": args.fmi,
        "cpus": os.cpu_count(),
        "load_1min": round(os.getloadavg()[0], 1),
        "machine": platform.machine(),
        "compiles": rows,
        "build_fmu_s": whole,
    }
    if args.out:
        args.out.write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")
    print(json.dumps(result))


if __name__ == "__main__":
    main()
