"""Re-run of issue 30's attack classes against the `nnfmu` CLI as shipped: every attack is set up in a temporary
folder and run as a user or an attacker would, the real CLI in a subprocess with a timeout (a hang = the timeout),
and its outcome classified: held (a clear one-line error naming the thing with a nonzero exit, a correct refusal, or
a correct result), data loss, escape, hang, wrong/non-finite with OK, or traceback ('Traceback' on stderr).

Fixtures (a rig record, a trained network, FMUs, a quarter-car system) are made once, through the CLI where it has
a command for them. Prints a table and, on the last line, a JSON summary; writes bench/results/hostile.json.

Usage: nice python bench/hostile.py [--only SUBSTRING ...] [--rows 10000000] [--no-memory] [--keep DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import signal
import socket
import stat
import subprocess
import sys
import tempfile
import time
import zipfile
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "bench" / "results" / "hostile.json"
ENV = dict(os.environ, PYTHONPATH=str(ROOT))
MARKER = ".nnfmu-output"
HELD, LOSS, ESCAPE, HANG, WRONG, TRACE, SETUP = (
    "held",
    "data loss",
    "escape",
    "hang",
    "wrong with OK",
    "traceback",
    "setup failed",
)


@dataclass
class Ran:
    """One CLI run: exit status (None when it hung and was killed), its output and how long it took."""

    code: int | None
    out: str
    err: str
    seconds: float

    @property
    def text(self) -> str:
        return self.out + self.err

    @property
    def hung(self) -> bool:
        return self.code is None

    @property
    def error_line(self) -> str:
        """The first `error:` line, or the last line of stderr."""
        lines = [line for line in self.text.splitlines() if line.startswith("error:")]
        return (lines or self.err.strip().splitlines()[-1:] or [""])[0]


def nnfmu(*args: object, timeout: float = 120, cwd: Path | None = None, **popen) -> Ran:
    """Run `nnfmu ARGS` (this checkout's) and wait at most `timeout` seconds."""
    started = time.monotonic()
    process = subprocess.Popen(
        [sys.executable, "-m", "nnfmu.cli", *map(str, args)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=cwd or ENV["PYTHONPATH"],  # `python -m` puts its folder first on sys.path: the code under test's
        env=popen.pop("env", ENV),
        start_new_session=True,
        **popen,
    )
    try:
        out, err = process.communicate(timeout=timeout)
        return Ran(process.returncode, out, err, time.monotonic() - started)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        out, err = process.communicate()
        return Ran(None, out, err, time.monotonic() - started)


@dataclass
class Outcome:
    """An attack's class, name, verdict and what was seen."""

    kind: str
    name: str
    verdict: str
    detail: str
    seconds: float = 0.0


def judge(ran: Ran, *words: str, ok_allowed: bool = False) -> tuple[str, str]:
    """Held when the run refused with an `error:` line containing every word (or, with `ok_allowed`, ended 0);
    traceback and hang are what they say; anything else is returned as 'wrong with OK' when it exited 0."""
    if ran.hung:
        return HANG, f"no end within {ran.seconds:.0f} s"
    if "Traceback" in ran.text:
        return TRACE, ran.err.strip().splitlines()[-1][:300]
    if ran.code == 0:
        return (HELD if ok_allowed else WRONG), f"exit 0: {ran.out.strip().splitlines()[-1:]}"
    lines = ran.err.strip().splitlines()
    after = lines[next((i for i, line in enumerate(lines) if line.startswith("error:")), len(lines)) :]
    if len([line for line in after if line.strip()]) > 1:
        return "unclear error", f"exit {ran.code}, an error of {len(after)} lines: {' / '.join(after)[:300]}"
    missing = [w for w in words if w not in ran.error_line]
    if missing or not ran.error_line.startswith("error:"):
        return "unclear error", f"exit {ran.code}, missing {missing}: {ran.error_line[:300]}"
    return HELD, f"exit {ran.code}: {ran.error_line[:300]}"


ATTACKS: list[tuple[str, str, Callable]] = []


def attack(kind: str, name: str):
    def register(function: Callable) -> Callable:
        ATTACKS.append((kind, name, function))
        return function

    return register


# ---------------------------------------------------------------------------------------------------------- fixtures


@dataclass
class Fixtures:
    """What the attacks start from, made once in `root`."""

    root: Path
    made: dict[str, Path] = field(default_factory=dict)

    def fresh(self, name: str) -> Path:
        folder = self.root / "attacks" / name
        shutil.rmtree(folder, ignore_errors=True)
        folder.mkdir(parents=True)
        return folder


def must(ran: Ran, what: str) -> Ran:
    if ran.code != 0:
        raise RuntimeError(f"fixture {what} failed: {ran.text[-800:]}")
    return ran


def make_fixtures(root: Path) -> Fixtures:
    """A 20 s damper dyno record and a small network trained on it, its native and pythonfmu FMUs, a quarter car
    system (vehicle + linear damper FMUs) with a 1 s drive, and a loop-vehicle quarter car with a 3 s drive."""
    import onnx

    from nnfmu.cosim.ssp import connect_by_name, write_ssd
    from nnfmu.export.linear_damper import linear_damper_graph
    from nnfmu.workflows.campaign.quarter_car import build_quarter_car_system

    fx = Fixtures(root)
    base = root / "fixtures"
    m = fx.made
    if (base / "made.json").is_file():  # --keep DIR of an earlier run: its fixtures again
        m.update({k: Path(v) for k, v in json.loads((base / "made.json").read_text()).items()})
        return fx
    base.mkdir()
    m["dyno"] = base / "dyno.csv"
    must(nnfmu("rig", "damper", "--out", m["dyno"], "--duration", "20", "--seed", "2", "--excitation", "random"), "rig")
    m["model"] = base / "model.onnx"
    must(
        nnfmu(
            "train", m["dyno"], "--preset", "damper-spline", "--out", m["model"], "--max-epochs", "5", "--restarts",
            "1", "--hidden", "3", timeout=600,
        ),
        "train",
    )  # fmt: skip
    m["fmu"] = base / "model.fmu"
    must(nnfmu("build", m["model"], "--out", m["fmu"], timeout=300), "build")
    m["pyfmu"] = base / "model-py.fmu"
    must(nnfmu("build", m["model"], "--out", m["pyfmu"], "--backend", "pythonfmu", timeout=300), "build pythonfmu")
    qc = build_quarter_car_system(base / "qc", {"linear": 2400.0, "firm": 3600.0})
    m.update({f"qc_{k}": v for k, v in qc.items()})
    m["qc_drive"] = base / "qc" / "drive.csv"
    must(nnfmu("drive", "generate", "--out", m["qc_drive"], "--duration", "1"), "drive")
    lv = base / "lv"
    lv.mkdir()
    must(nnfmu("vehicle", "build", "quarter-car", "--out", lv / "car.fmu", "--sample-period", "1e-3"), "vehicle")
    must(nnfmu("drive", "generate", "--out", lv / "drive.csv", "--duration", "2"), "lv drive")
    onnx.save(linear_damper_graph(2400.0, name="damper"), lv / "damper.onnx")
    must(nnfmu("build", lv / "damper.onnx", "--out", lv / "damper.fmu"), "lv damper")
    (lv / "damper.onnx").unlink()  # the FMU carries its own step graph
    onnx.save(linear_damper_graph(900.0, name="damper"), base / "other.onnx")
    m["other_onnx"] = base / "other.onnx"
    m["lv_system"] = write_ssd(
        connect_by_name("quarter car", ("vehicle", lv / "car.fmu"), {"damper": lv / "damper.fmu"}, lv),
        lv / "SystemStructure.ssd",
    )
    m["lv_drive"] = lv / "drive.csv"
    (base / "made.json").write_text(json.dumps({k: str(v) for k, v in m.items()}))
    return fx


def snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def copy_system(fx: Fixtures, folder: Path) -> Path:
    """The quarter car's files copied into `folder`; its SystemStructure.ssd there."""
    for name in ("system", "vehicle", "linear", "firm"):
        shutil.copy(fx.made[f"qc_{name}"], folder / fx.made[f"qc_{name}"].name)
    return folder / "SystemStructure.ssd"


def campaign(fx: Fixtures, folder: Path, events: str, variants: str = "", metrics: str = "") -> Path:
    """`folder/campaign.toml` on the quarter car (copied into `folder/sys`) with the given event and variant text."""
    (folder / "sys").mkdir(exist_ok=True)
    copy_system(fx, folder / "sys")
    text = (
        'name = "hostile"\n[coupling]\nstep = 1e-3\n'
        f'[metrics]\nchannels = ["damper_force", "body_acceleration"]\n{metrics}\n'
        "[drive]\nduration = 1.0\n"
        f"{events}\n"
        '[[variants]]\nname = "linear"\nsystem = "sys/SystemStructure.ssd"\n'
        f"{variants}\n"
    )
    path = folder / "campaign.toml"
    path.write_text(text, encoding="utf-8")
    return path


GENERATED = '[[events]]\nname = "C-20"\nclass = "C"\nspeed = 20.0\nrepeats = {n}\n'


def zip_replace(fmu: Path, target: Path, files: dict[str, bytes], drop: tuple[str, ...] = ()) -> Path:
    with zipfile.ZipFile(fmu) as source, zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as out:
        for name in source.namelist():
            if name not in files and name not in drop:
                out.writestr(name, source.read(name))
        for name, content in files.items():
            out.writestr(name, content)
    return target


def special_node(path: Path, kind: str) -> Path:
    if kind == "fifo":
        os.mkfifo(path)
    else:
        os.mknod(path, 0o666 | stat.S_IFCHR, os.makedev(1, 3))
    return path


def still_special(path: Path) -> bool:
    mode = path.lstat().st_mode
    return stat.S_ISFIFO(mode) or stat.S_ISCHR(mode)


# --------------------------------------------------------------------------------------------------------- data loss

OUT_COMMANDS = {
    "build": lambda fx, out: ("build", fx.made["model"], "--out", out),
    "rig": lambda fx, out: ("rig", "damper", "--out", out, "--duration", "1"),
    "drive generate": lambda fx, out: ("drive", "generate", "--out", out, "--duration", "1"),
    "cosim": lambda fx, out: ("cosim", fx.made["qc_system"], "--drive", fx.made["qc_drive"], "--out", out),
}


def _out_special(fx: Fixtures, name: str, kind: str) -> tuple[str, str]:
    folder = fx.fresh(name)
    seen = []
    for command, args in OUT_COMMANDS.items():
        node = special_node(folder / f"node-{command.replace(' ', '-')}.csv", kind)
        ran = nnfmu(*args(fx, node), timeout=120)
        if not still_special(node):
            return LOSS, f"{command}: {node.name} replaced by a {stat.filemode(node.lstat().st_mode)} file"
        verdict, detail = judge(ran, str(node), "regular file")
        if verdict != HELD:
            return verdict, f"{command}: {detail}"
        seen.append(command)
    return HELD, f"{', '.join(seen)} refused, node kept; e.g. {ran.error_line}"


@attack("data loss", "--out a FIFO")
def out_fifo(fx: Fixtures) -> tuple[str, str]:
    return _out_special(fx, "fifo", "fifo")


@attack("data loss", "--out a char device made with mknod")
def out_chardev(fx: Fixtures) -> tuple[str, str]:
    if os.geteuid() != 0:
        return SETUP, "not root: mknod needs root"
    return _out_special(fx, "chardev", "chr")


@attack("data loss", "--out /dev/null")
def out_devnull(fx: Fixtures) -> tuple[str, str]:
    """Only run once the mknod'ed copy held (a replaced /dev/null is put back at once)."""
    if os.geteuid() != 0:
        return SETUP, "not root"
    folder = fx.fresh("devnull-probe")
    probe = special_node(folder / "null.fmu", "chr")
    nnfmu("build", fx.made["model"], "--out", probe)
    if not still_special(probe):
        return LOSS, "a mknod'ed null was replaced: /dev/null not tried"
    results = []
    for command in ("build", "drive generate"):
        ran = nnfmu(*OUT_COMMANDS[command](fx, "/dev/null"))
        if not stat.S_ISCHR(os.lstat("/dev/null").st_mode):
            os.unlink("/dev/null")
            os.mknod("/dev/null", 0o666 | stat.S_IFCHR, os.makedev(1, 3))
            os.chmod("/dev/null", 0o666)
            return LOSS, f"{command}: /dev/null replaced by a regular file (put back)"
        verdict, detail = judge(ran, "/dev/null")
        if verdict != HELD:
            return verdict, f"{command}: {detail}"
        results.append(ran.error_line)
    return HELD, f"/dev/null still a char device; {results[0]}"


def _loop(fx: Fixtures, out: Path) -> Ran:
    return nnfmu("loop", fx.made["dyno"], "--model", fx.made["model"], "--out", out, "--max-effects", "0", timeout=400)


@attack("data loss", "loop re-run into its own folder with a user file added")
def loop_rerun(fx: Fixtures) -> tuple[str, str]:
    out = fx.fresh("loop-rerun") / "loop"
    must(_loop(fx, out), "first loop")
    (out / "precious_notes.txt").write_text("my notes")
    (out / "mine").mkdir()
    (out / "mine" / "plot.png").write_bytes(b"mine")
    ran = _loop(fx, out)
    kept = (out / "precious_notes.txt").is_file() and (out / "mine" / "plot.png").is_file()
    if not kept:
        return LOSS, f"user files gone after the re-run (exit {ran.code})"
    verdict, detail = judge(ran, ok_allowed=True)
    if verdict == HELD and ran.code == 0 and not (out / "report.json").is_file():
        return WRONG, "exit 0 without report.json"
    return verdict, f"user files kept; {detail}"


@attack("data loss", "a copied .nnfmu-output marker")
def copied_marker(fx: Fixtures) -> tuple[str, str]:
    folder = fx.fresh("copied-marker")
    source = folder / "source"
    must(_loop(fx, source), "loop")
    thesis = folder / "thesis"
    thesis.mkdir()
    (thesis / "chapter.tex").write_text("do not lose me")
    (thesis / "report.json").write_text("my own report")
    (thesis / "report.html").write_text("my own page")
    shutil.copy(source / MARKER, thesis / MARKER)
    before = snapshot(thesis)
    ran = _loop(fx, thesis)
    after = snapshot(thesis)
    lost = [name for name in before if name != MARKER and after.get(name) != before[name]]
    if lost:
        return LOSS, f"changed or deleted: {lost} (exit {ran.code})"
    return judge(ran, ok_allowed=True)


# ----------------------------------------------------------------------------------------------------------- escapes


@attack("escape", 'campaign drive = "/etc/passwd"')
def campaign_passwd(fx: Fixtures) -> tuple[str, str]:
    folder = fx.fresh("passwd")
    path = campaign(fx, folder, '[[events]]\nname = "secret"\ndrive = "/etc/passwd"\n')
    ran = nnfmu("batch", path, "--out", folder / "out", "--workers", "0")
    if ran.code == 0:
        return ESCAPE, "exit 0: /etc/passwd read as a drive"
    verdict, detail = judge(ran, "/etc/passwd", "outside", "--allow-outside")
    return (ESCAPE if verdict == "unclear error" else verdict), detail


@attack("escape", 'variant fmus = {damper = "../../x.fmu"}')
def campaign_up_fmu(fx: Fixtures) -> tuple[str, str]:
    top = fx.fresh("up-fmu")
    shutil.copy(fx.made["qc_firm"], top / "x.fmu")
    folder = top / "a" / "b"
    folder.mkdir(parents=True)
    path = campaign(fx, folder, GENERATED.format(n=1), 'fmus = { damper = "../../x.fmu" }')
    ran = nnfmu("batch", path, "--out", folder / "out", "--workers", "0")
    if ran.code == 0:
        return ESCAPE, "exit 0: an FMU two folders up was run"
    verdict, detail = judge(ran, "x.fmu", "outside", "--allow-outside")
    return (ESCAPE if verdict == "unclear error" else verdict), detail


def _ssd_sources(
    fx: Fixtures, name: str, source: Callable[[Path, str], str], words: tuple[str, ...] = ("outside", "--allow-outside")
) -> tuple[str, str]:
    folder = fx.fresh(name)
    (folder / "fmus").mkdir()
    (folder / "sys").mkdir()
    for f in ("vehicle", "linear"):
        shutil.copy(fx.made[f"qc_{f}"], folder / "fmus" / fx.made[f"qc_{f}"].name)
    text = fx.made["qc_system"].read_text(encoding="utf-8")
    for f in ("vehicle", "linear"):
        fname = fx.made[f"qc_{f}"].name
        assert f'source="{fname}"' in text, text[:500]
        text = text.replace(f'source="{fname}"', f'source="{source(folder, fname)}"')
    ssd = folder / "sys" / "SystemStructure.ssd"
    ssd.write_text(text, encoding="utf-8")
    ran = nnfmu("cosim", ssd, "--drive", fx.made["qc_drive"], "--out", folder / "r.csv")
    if ran.code == 0:
        return ESCAPE, "exit 0: FMUs outside the system's folder were run"
    verdict, detail = judge(ran, *words)
    return (ESCAPE if verdict == "unclear error" else verdict), detail


@attack("escape", ".ssd with file:// URI FMU sources")
def ssd_uri(fx: Fixtures) -> tuple[str, str]:
    """Read as a path below the system's folder ('sys/file:/...'), which holds no such FMU: refused, nothing loaded."""
    return _ssd_sources(fx, "ssd-uri", lambda folder, name: f"file://{folder / 'fmus' / name}", ("not found",))


@attack("escape", "campaign system inside its folder naming an FMU two folders up")
def campaign_ssd_up(fx: Fixtures) -> tuple[str, str]:
    top = fx.fresh("campaign-ssd-up")
    shutil.copy(fx.made["qc_linear"], top / fx.made["qc_linear"].name)
    folder = top / "a" / "b"
    folder.mkdir(parents=True)
    path = campaign(fx, folder, GENERATED.format(n=1))
    ssd = folder / "sys" / "SystemStructure.ssd"
    name = fx.made["qc_linear"].name
    ssd.write_text(ssd.read_text(encoding="utf-8").replace(f'source="{name}"', f'source="../../../{name}"'))
    (folder / "sys" / name).unlink()
    ran = nnfmu("batch", path, "--out", folder / "out", "--workers", "0")
    if ran.code == 0:
        return ESCAPE, "exit 0: the system's FMU two folders up was run"
    verdict, detail = judge(ran, name, "outside")
    return (ESCAPE if verdict == "unclear error" else verdict), detail


@attack("escape", ".ssd with ../ FMU sources")
def ssd_up(fx: Fixtures) -> tuple[str, str]:
    return _ssd_sources(fx, "ssd-up", lambda folder, name: f"../fmus/{name}")


@attack("escape", ".ssd with absolute FMU sources")
def ssd_absolute(fx: Fixtures) -> tuple[str, str]:
    return _ssd_sources(fx, "ssd-abs", lambda folder, name: str(folder / "fmus" / name))


# ------------------------------------------------------------------------------------------------------------- hangs


def _capped() -> None:
    """A 6 GiB address-space cap for a child that might read without end (a link to /dev/zero)."""
    import resource

    resource.setrlimit(resource.RLIMIT_AS, (6 << 30, 6 << 30))


INPUT_COMMANDS = {
    "check FMU": (".fmu", lambda fx, x, d: ("check", x)),
    "build ONNX": (".onnx", lambda fx, x, d: ("build", x, "--out", d / "o.fmu")),
    "data check": (".csv", lambda fx, x, d: ("data", "check", x)),
    "cosim --drive": (".csv", lambda fx, x, d: ("cosim", fx.made["qc_system"], "--drive", x, "--out", d / "r.csv")),
    "cosim system .ssd": (".ssd", lambda fx, x, d: ("cosim", x, "--drive", fx.made["qc_drive"], "--out", d / "r.csv")),
    "vehicle --params": (
        ".toml",
        lambda fx, x, d: ("vehicle", "build", "quarter-car", "--params", x, "--out", d / "c.fmu"),
    ),
    "validate": (".csv", lambda fx, x, d: ("validate", x, fx.made["dyno"], "--out", d / "v")),
}


def _special_input(fx: Fixtures, command: str, kind: str) -> tuple[str, str]:
    """An input that is a FIFO (nobody writes: an open waits for ever) or a link to /dev/zero (never ends)."""
    suffix, args = INPUT_COMMANDS[command]
    folder = fx.fresh(re.sub(r"\W+", "-", f"input-{kind}-{command}"))
    node = folder / f"input{suffix}"
    if kind == "FIFO":
        os.mkfifo(node)
    else:
        node.symlink_to("/dev/zero")
    ran = nnfmu(*args(fx, node, folder), timeout=150, preexec_fn=_capped)
    if ran.code is not None and ran.code < 0:
        return HANG, f"killed by signal {-ran.code} (the 6 GiB memory cap?) after {ran.seconds:.0f} s"
    verdict, detail = judge(ran, str(node), "not a regular file")
    return verdict, f"{detail} ({ran.seconds:.0f} s)"


for _command in INPUT_COMMANDS:
    for _kind in ("FIFO", "link to /dev/zero"):
        attack("hang", f"input {_kind}: {_command}")(lambda fx, c=_command, k=_kind: _special_input(fx, c, k))


@attack("hang", "batch repeats = 1e9")
def repeats_billion(fx: Fixtures) -> tuple[str, str]:
    folder = fx.fresh("repeats-1e9")
    ran = nnfmu("batch", campaign(fx, folder, GENERATED.format(n=1_000_000_000)), "--out", folder / "out", timeout=60)
    verdict, detail = judge(ran, "1000000000")
    return verdict, f"{detail} ({ran.seconds:.1f} s)"


@attack("hang", "batch repeats = 20000 (reading linear, stoppable)")
def repeats_20000(fx: Fixtures) -> tuple[str, str]:
    """The campaign is read and its first case finished within 60 s; then SIGTERM stops it with 130."""
    folder = fx.fresh("repeats-20000")
    out = folder / "out"
    started = time.monotonic()
    process = subprocess.Popen(
        [sys.executable, "-m", "nnfmu.cli", "batch", str(campaign(fx, folder, GENERATED.format(n=20000))), "--out",
         str(out), "--workers", "0"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV, cwd=ENV["PYTHONPATH"],
        start_new_session=True,
    )  # fmt: skip
    first = None
    while time.monotonic() - started < 90 and process.poll() is None:
        if (out / "parts").is_dir() and any((out / "parts").glob("*.parquet")):
            first = time.monotonic() - started
            break
        time.sleep(0.1)
    if process.poll() is not None:
        _, err = process.communicate()
        verdict, detail = judge(Ran(process.returncode, "", err, time.monotonic() - started))
        return (verdict if verdict != HELD else WRONG), f"ended before its first case: {detail}"
    process.send_signal(signal.SIGTERM)
    try:
        _, err = process.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        return HANG, "ignored SIGTERM for 60 s"
    if first is None:
        return HANG, "no case finished within 90 s of the start (reading 20000 repeats)"
    if "Traceback" in err:
        return TRACE, err.strip().splitlines()[-1]
    if process.returncode != 130:
        return WRONG, f"first part after {first:.1f} s but exit {process.returncode} on SIGTERM"
    return HELD, f"first case done {first:.1f} s after the start; SIGTERM -> exit 130"


@attack("hang", 'campaign drive = "/dev/zero"')
def drive_dev_zero(fx: Fixtures) -> tuple[str, str]:
    folder = fx.fresh("dev-zero")
    path = campaign(fx, folder, '[[events]]\nname = "endless"\ndrive = "/dev/zero"\n')
    ran = nnfmu("batch", path, "--out", folder / "out", "--workers", "0", "--allow-outside", timeout=60)
    verdict, detail = judge(ran, "/dev/zero", "not a regular file")
    return verdict, f"{detail} ({ran.seconds:.1f} s)"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@attack("hang", "a Dask campaign whose only worker dies")
def dask_worker_dies(fx: Fixtures) -> tuple[str, str]:
    """A scheduler and one worker of our own; the worker is killed (SIGKILL) once the campaign has started: the run
    must end with an error naming the wait (nnfmu waits WAIT_FOR_WORKERS = 60 s), not wait for ever."""
    if shutil.which("dask") is None:
        return SETUP, "no dask command"
    folder = fx.fresh("dask")
    path = campaign(fx, folder, GENERATED.format(n=200))
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    log = (folder / "dask.log").open("w")
    scheduler = subprocess.Popen(
        ["dask", "scheduler", "--host", "127.0.0.1", "--port", str(port), "--dashboard-address", ":0"],
        stdout=log, stderr=log, env=ENV, cwd=ENV["PYTHONPATH"], start_new_session=True,
    )  # fmt: skip
    worker = subprocess.Popen(
        ["dask", "worker", address, "--nworkers", "1", "--nthreads", "1", "--no-dashboard"],
        stdout=log, stderr=log, env=ENV, cwd=ENV["PYTHONPATH"], start_new_session=True,
    )  # fmt: skip
    try:
        time.sleep(8)
        started = time.monotonic()
        process = subprocess.Popen(
            [sys.executable, "-m", "nnfmu.cli", "batch", str(path), "--out", str(folder / "out"), "--scheduler",
             address],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV, cwd=ENV["PYTHONPATH"],
        start_new_session=True,
        )  # fmt: skip
        while time.monotonic() - started < 60 and process.poll() is None:
            if (folder / "out" / "parts").is_dir() and any((folder / "out" / "parts").glob("*.parquet")):
                break
            time.sleep(0.2)
        os.killpg(worker.pid, signal.SIGKILL)
        killed = time.monotonic() - started
        try:
            out, err = process.communicate(timeout=180)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            return HANG, f"worker killed at {killed:.0f} s; no end 180 s later"
        ran = Ran(process.returncode, out, err, time.monotonic() - started)
        verdict, detail = judge(ran, "no workers")
        return verdict, f"worker killed at {killed:.0f} s; {detail} (after {ran.seconds:.0f} s)"
    finally:
        for p in (worker, scheduler):
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGKILL)
            p.wait()
        log.close()


def _check_experiment(fx: Fixtures, where: str, attribute: str, value: str) -> tuple[str, str]:
    """`nnfmu check` on the FMU with its reference experiment's `attribute` set to `value` (`where` = 'exp'), or
    with it removed there and given by the model description's default experiment (`where` = 'default'); the
    manifest's SHA3-256 of reference.exp recomputed, as an attacker would."""
    import hashlib

    folder = fx.fresh(f"check-{where}-{attribute}-{value}")
    with zipfile.ZipFile(fx.made["fmu"]) as archive:
        names = archive.namelist()
        exp = next(n for n in names if n.endswith("reference.exp"))
        manifest = next(n for n in names if n.endswith("fmi-ls-manifest.xml"))
        text, description, listing = (archive.read(n).decode() for n in (exp, "modelDescription.xml", manifest))
    files = {}
    if where == "exp":
        changed = re.sub(rf' {attribute}="[^"]*"', f' {attribute}="{value}"', text)
    else:
        changed = re.sub(rf' {attribute}="[^"]*"', "", text)
        described = re.sub(rf'(<DefaultExperiment\b[^>]*?) {attribute}="[^"]*"', r"\1", description)
        files["modelDescription.xml"] = described.replace(
            "<DefaultExperiment", f'<DefaultExperiment {attribute}="{value}"'
        )
        files["modelDescription.xml"] = files["modelDescription.xml"].encode()
    old, new = (hashlib.sha3_256(t.encode()).hexdigest() for t in (text, changed))
    files[exp] = changed.encode()
    files[manifest] = listing.replace(old, new).encode()
    hostile = zip_replace(fx.made["fmu"], folder / "h.fmu", files)
    ran = nnfmu("check", hostile, timeout=90)
    said = {"1e9": "1e+09", "1e-12": "1e-12", "nan": "nan"}[value]  # how the message writes the value
    verdict, detail = judge(ran, "h.fmu", said, ok_allowed=True)
    return verdict, f"{detail} ({ran.seconds:.1f} s)"


for _where, _said in (("exp", "reference.exp"), ("default", "default experiment (none in reference.exp)")):
    for _attribute, _value in (("stopTime", "1e9"), ("stepSize", "1e-12"), ("stopTime", "nan")):
        attack("hang", f"check, {_said} {_attribute}={_value}")(
            lambda fx, w=_where, a=_attribute, v=_value: _check_experiment(fx, w, a, v)
        )


FMPY_PROBE = """
import math, sys, time
from fmpy import read_model_description, extract
from fmpy.fmi2 import FMU2Slave
path, start, gain = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
md = read_model_description(path)
refs = {v.name: v.valueReference for v in md.modelVariables}
outs = [v.valueReference for v in md.modelVariables if v.causality == "output"]
ins = [v.valueReference for v in md.modelVariables if v.causality == "input"]
fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(path), modelIdentifier=md.coSimulation.modelIdentifier,
                instanceName="probe")
fmu.instantiate()
if gain != 1.0:
    fmu.setReal([refs["output_gain"]], [gain])
fmu.setupExperiment(startTime=start)
fmu.enterInitializationMode(); fmu.exitInitializationMode()
t, statuses, values = start, [], []
for k in range(200):
    fmu.setReal(ins, [0.3 * math.sin(k / 7.0)] * len(ins))
    try:
        fmu.doStep(t, 1e-3)
        statuses.append("ok")
    except Exception as error:
        statuses.append(type(error).__name__)
        break
    values.extend(fmu.getReal(outs))
    t += 1e-3
print("RESULT", len(statuses), statuses[-1], all(math.isfinite(v) for v in values), len(values))
"""


def _fmpy_probe(fx: Fixtures, start: float, gain: float) -> tuple[str, str]:
    started = time.monotonic()
    try:
        done = subprocess.run(
            [sys.executable, "-c", FMPY_PROBE, str(fx.made["pyfmu"]), repr(start), repr(gain)],
            capture_output=True, text=True, timeout=120, env=ENV,
        )  # fmt: skip
    except subprocess.TimeoutExpired:
        return HANG, "200 steps not done within 120 s"
    line = next((s for s in done.stdout.splitlines() if s.startswith("RESULT")), None)
    if line is None:
        return TRACE, (done.stderr.strip().splitlines() or ["no output"])[-1][:300]
    _, steps, last, finite, count = line.split()
    took = time.monotonic() - started
    if last == "ok" and finite == "False":
        return WRONG, f"{steps} steps with OK status, outputs not finite"
    if last == "ok":
        return HELD, f"{steps} steps OK, {count} finite outputs ({took:.1f} s)"
    return HELD, f"step {steps} refused with an FMI error ({last}) ({took:.1f} s)"


@attack("hang", "pythonfmu FMU at start time 1e300 (fmpy, 200 steps)")
def pythonfmu_1e300(fx: Fixtures) -> tuple[str, str]:
    return _fmpy_probe(fx, 1e300, 1.0)


# ------------------------------------------------------------------------------------------------ wrong with an OK


def _lab_record(fx: Fixtures, path: Path, start: float) -> Path:
    from nnfmu.data import Measurement, save_measurement
    from nnfmu.data.drive_files import read_drive

    drive = read_drive(fx.made["lv_drive"])
    rng = np.random.default_rng(0)
    n = len(drive.time)
    channels = {"damper_force": rng.normal(0, 100, n), "damper_displacement": rng.normal(0, 0.01, n)}
    units = {"damper_force": "N", "damper_displacement": "m"}
    return save_measurement(Measurement.uniform(start, drive.sample_period, channels, units), path)


def _loop_vehicle(fx: Fixtures, system: Path, record: Path, out: Path, *extra: object) -> Ran:
    args = ("loop", "vehicle", record, "--system", system, "--drive", fx.made["lv_drive"], "--out", out, *extra)
    return nnfmu(*args, timeout=500)


@attack("wrong with OK", "loop vehicle: a different step graph beside the FMU")
def loop_vehicle_other_graph(fx: Fixtures) -> tuple[str, str]:
    folder = fx.fresh("lv-other")
    lv = folder / "lv"
    shutil.copytree(fx.made["lv_system"].parent, lv)
    shutil.copy(fx.made["other_onnx"], lv / "damper.onnx")
    record = _lab_record(fx, folder / "lab.csv", 0.0)
    ran = _loop_vehicle(fx, lv / "SystemStructure.ssd", record, folder / "out")
    verdict, detail = judge(ran, ok_allowed=True)
    if verdict == HELD and ran.code == 0:
        if "ignored" not in ran.text or "not the network" not in ran.text:
            return WRONG, "exit 0 and no word that the network beside the FMU was ignored"
        return HELD, next(line for line in ran.text.splitlines() if "ignored" in line)[:300]
    return verdict, detail


@attack("data loss", "loop vehicle re-run into its own folder with a user file added")
def loop_vehicle_rerun(fx: Fixtures) -> tuple[str, str]:
    folder = fx.fresh("lv-rerun")
    record = _lab_record(fx, folder / "lab.csv", 0.0)
    out = folder / "out"
    must(_loop_vehicle(fx, fx.made["lv_system"], record, out), "loop vehicle")
    (out / "precious_notes.txt").write_text("my notes")
    ran = _loop_vehicle(fx, fx.made["lv_system"], record, out)
    if not (out / "precious_notes.txt").is_file():
        return LOSS, f"the user's file is gone after the re-run (exit {ran.code})"
    verdict, detail = judge(ran, ok_allowed=True)
    return verdict, f"user file kept; {detail}"


@attack("wrong with OK", "loop vehicle: lab record whose time starts at 3 s")
def loop_vehicle_late_record(fx: Fixtures) -> tuple[str, str]:
    folder = fx.fresh("lv-late")
    record = _lab_record(fx, folder / "late.csv", 3.0)
    ran = _loop_vehicle(fx, fx.made["lv_system"], record, folder / "out")
    if ran.code == 0:
        summary = [line for line in ran.text.splitlines() if "consistent" in line]
        return WRONG, f"exit 0: {summary[:1]}"
    return judge(ran, "late.csv", "drive.csv")


@attack("wrong with OK", "batch resume with truncated, swapped and edited parts")
def batch_resume(fx: Fixtures) -> tuple[str, str]:
    import pyarrow as pa
    import pyarrow.parquet as pq

    folder = fx.fresh("resume")
    path = campaign(fx, folder, GENERATED.format(n=4))
    out = folder / "out"
    must(nnfmu("batch", path, "--out", out, "--workers", "0", timeout=300), "batch")
    first = pq.read_table(out / "results.parquet")
    parts = sorted((out / "parts").glob("*.parquet"))
    if len(parts) != 4:
        return SETUP, f"{len(parts)} parts"
    truncated, swapped, doubled, _ = parts
    truncated.write_bytes(truncated.read_bytes()[:100])
    swapped.write_bytes(parts[3].read_bytes())
    table = pq.read_table(doubled)
    pq.write_table(pa.concat_tables([table, table.slice(0, 1)]), doubled)
    ran = nnfmu("batch", path, "--out", out, "--workers", "0", timeout=300)
    verdict, detail = judge(ran, ok_allowed=True)
    if verdict != HELD:
        return verdict, detail
    rows = pq.read_table(out / "results.parquet")
    keys = list(zip(rows.column("case").to_pylist(), rows.column("channel").to_pylist()))
    if len(keys) != len(set(keys)) or rows.num_rows != first.num_rows:
        return WRONG, f"exit 0 with {rows.num_rows} rows ({len(set(keys))} distinct), first run {first.num_rows}"
    named = [p.name for p in (truncated, swapped, doubled) if p.name in ran.text]
    if len(named) != 3:
        return WRONG, f"exit 0, parts named in warnings: {named} of 3"
    return HELD, f"3 bad parts named and rerun, {rows.num_rows} rows, none twice"


@attack("wrong with OK", "Basquin slope 1e308 (campaign [metrics])")
def basquin_campaign(fx: Fixtures) -> tuple[str, str]:
    folder = fx.fresh("basquin-campaign")
    path = campaign(fx, folder, GENERATED.format(n=1), metrics="basquin_slope = 1e308")
    ran = nnfmu("batch", path, "--out", folder / "out", "--workers", "0", timeout=200)
    return judge(ran, "basquin_slope")


@attack("wrong with OK", "Basquin slope 1e308 (validate --slope)")
def basquin_validate(fx: Fixtures) -> tuple[str, str]:
    folder = fx.fresh("basquin-validate")
    ran = nnfmu("validate", fx.made["dyno"], fx.made["dyno"], "--out", folder / "v", "--slope", "1e308")
    return judge(ran, "1e+308")


def _gain_ssd(fx: Fixtures, folder: Path) -> Path:
    ssd = copy_system(fx, folder)
    text = ssd.read_text(encoding="utf-8")
    assert text.count('name="filter_cutoff"') == 1, text
    text = re.sub(r'name="filter_cutoff"(\s*>\s*<ssv:Real\s+value=)"[^"]*"', r'name="output_gain"\1"1e308"', text)
    if "1e308" not in text:
        text = text.replace('name="filter_cutoff"', 'name="output_gain"').replace('value="0.0"', 'value="1e308"')
    ssd.write_text(text, encoding="utf-8")
    return ssd


def _gain_cosim(fx: Fixtures, master: str) -> tuple[str, str]:
    folder = fx.fresh(f"gain-{master}")
    ssd = _gain_ssd(fx, folder)
    plain = ("--scheme", "jacobi", "--no-extrapolate", "--no-refresh") if master == "libcosim" else ()
    result = folder / "r.csv"
    ran = nnfmu("cosim", ssd, "--drive", fx.made["qc_drive"], "--out", result, "--master", master, *plain)
    if ran.code is not None and ran.code < 0:
        return TRACE, f"killed by signal {-ran.code}"
    if ran.code == 0:
        data = np.genfromtxt(result, delimiter=",", skip_header=1)
        if not np.isfinite(data).all():
            return WRONG, "exit 0 with non-finite values in the result"
        return WRONG, "exit 0 with a finite result at output_gain 1e308 (force should overflow)"
    return judge(ran, "output_gain" if master == "fmpy" else "SystemStructure")


@attack("wrong with OK", "SSD output_gain = 1e308, fmpy master")
def gain_fmpy(fx: Fixtures) -> tuple[str, str]:
    return _gain_cosim(fx, "fmpy")


@attack("wrong with OK", "SSD output_gain = 1e308, libcosim master")
def gain_libcosim(fx: Fixtures) -> tuple[str, str]:
    return _gain_cosim(fx, "libcosim")


@attack("wrong with OK", "pythonfmu FMU with output_gain = 1e308 (fmpy)")
def pythonfmu_gain(fx: Fixtures) -> tuple[str, str]:
    return _fmpy_probe(fx, 0.0, 1e308)


# -------------------------------------------------------------------------------------------------------- tracebacks


@attack("traceback", "deeply nested campaign TOML")
def deep_toml(fx: Fixtures) -> tuple[str, str]:
    folder = fx.fresh("deep")
    path = folder / "deep.toml"
    path.write_text("name = " + "[" * 100_000 + "\n", encoding="utf-8")
    return judge(nnfmu("batch", path, "--out", folder / "out", "--workers", "0"), "deep.toml")


@attack("traceback", "deeply nested vehicle parameter TOML")
def deep_vehicle_toml(fx: Fixtures) -> tuple[str, str]:
    folder = fx.fresh("deep-vehicle")
    path = folder / "params.toml"
    path.write_text("mass = " + "[" * 100_000 + "\n", encoding="utf-8")
    ran = nnfmu("vehicle", "build", "quarter-car", "--params", path, "--out", folder / "car.fmu")
    if "No such option" in ran.text:
        return SETUP, "no --params option"
    return judge(ran, "params.toml")


@attack("traceback", '--scheduler "not a url"')
def scheduler_not_url(fx: Fixtures) -> tuple[str, str]:
    folder = fx.fresh("scheduler")
    ran = nnfmu(
        "batch", campaign(fx, folder, GENERATED.format(n=1)), "--out", folder / "out", "--scheduler", "not a url"
    )
    return judge(ran, "not a url")


@attack("traceback", "check on an FMU without modelDescription.xml")
def check_no_md(fx: Fixtures) -> tuple[str, str]:
    folder = fx.fresh("no-md")
    broken = zip_replace(fx.made["fmu"], folder / "nomd.fmu", {}, drop=("modelDescription.xml",))
    return judge(nnfmu("check", broken), "nomd.fmu", "modelDescription.xml")


@attack("traceback", "loop vehicle with a garbage ONNX")
def loop_vehicle_garbage(fx: Fixtures) -> tuple[str, str]:
    folder = fx.fresh("lv-garbage")
    garbage = folder / "garbage.onnx"
    garbage.write_bytes(b"not an onnx model\n" * 10)
    record = _lab_record(fx, folder / "lab.csv", 0.0)
    ran = _loop_vehicle(fx, fx.made["lv_system"], record, folder / "out", "--model", f"damper={garbage}")
    return judge(ran, "garbage.onnx")


@attack("traceback", "loop vehicle with a garbage ONNX beside the FMU")
def loop_vehicle_garbage_beside(fx: Fixtures) -> tuple[str, str]:
    folder = fx.fresh("lv-garbage-beside")
    lv = folder / "lv"
    shutil.copytree(fx.made["lv_system"].parent, lv)
    (lv / "damper.onnx").write_bytes(b"not an onnx model\n" * 10)
    record = _lab_record(fx, folder / "lab.csv", 0.0)
    ran = _loop_vehicle(fx, lv / "SystemStructure.ssd", record, folder / "out")
    return judge(ran, ok_allowed=True)


def _rsp(fx: Fixtures, folder: Path) -> Path:
    rsp = folder / "drive.rsp"
    must(nnfmu("drive", "convert", fx.made["qc_drive"], rsp), "drive convert")
    return rsp


def _set_field(rsp: Path, key: bytes, value: bytes) -> None:
    data = bytearray(rsp.read_bytes())
    at = data.index(key.ljust(32, b"\0")[:32]) if key.ljust(32, b"\0")[:32] in data else data.index(key)
    data[at + 32 : at + 128] = value.ljust(96, b"\0")
    rsp.write_bytes(bytes(data))


def _rpc_field(fx: Fixtures, name: str, key: bytes, value: bytes, *words: str) -> tuple[str, str]:
    folder = fx.fresh(f"rpc-{name}")
    rsp = _rsp(fx, folder)
    _set_field(rsp, key, value)
    ran = nnfmu("cosim", fx.made["qc_system"], "--drive", rsp, "--out", folder / "r.csv")
    verdict, detail = judge(ran, "drive.rsp", *words)
    if verdict == HELD and (folder / "r.csv").exists():
        return WRONG, "refused but a result was written"
    return verdict, detail


RPC_ATTACKS = [
    ("DELTA_T 1e300 in cosim", b"DELTA_T", b"1.0e300", ("DELTA_T",)),
    ("DELTA_T 1e-300 in cosim", b"DELTA_T", b"1.0e-300", ("DELTA_T",)),
    ("DELTA_T nan", b"DELTA_T", b"nan", ("DELTA_T",)),
    ("FORMAT garbage", b"FORMAT", b"ASCII_PLEASE", ("FORMAT",)),
    ("NUM_PARAMS 99999999", b"NUM_PARAMS", b"99999999", ("NUM_PARAMS",)),
    ("CHANNELS not a number", b"CHANNELS", b"four", ("CHANNELS",)),
    ("CHANNELS 100000", b"CHANNELS", b"100000", ("CHANNELS",)),
    ("DATA_TYPE unknown", b"DATA_TYPE", b"COMPLEX", ("DATA_TYPE",)),
    ("PTS_PER_FRAME 0", b"PTS_PER_FRAME", b"0", ("PTS_PER_FRAME",)),
    ("FRAMES 1e12", b"FRAMES", b"1000000000000", ("FRAMES",)),
    ("SCALE.CHAN_1 nan", b"SCALE.CHAN_1", b"nan", ("SCALE.CHAN_1",)),
    ("UNITS.CHAN_1 empty", b"UNITS.CHAN_1", b"", ("unit ''",)),
    ("DESC.CHAN_1 empty", b"DESC.CHAN_1", b"", ("DESC.CHAN_1",)),
]
for _name, _key, _value, _words in RPC_ATTACKS:
    attack("traceback", f"RPC III header {_name}")(
        lambda fx, n=_name, k=_key, v=_value, w=_words: _rpc_field(fx, re.sub(r"\W+", "-", n), k, v, *w)
    )


@attack("traceback", "RPC III file truncated in its data")
def rpc_truncated(fx: Fixtures) -> tuple[str, str]:
    folder = fx.fresh("rpc-truncated")
    rsp = _rsp(fx, folder)
    rsp.write_bytes(rsp.read_bytes()[: len(rsp.read_bytes()) // 2])
    ran = nnfmu("cosim", fx.made["qc_system"], "--drive", rsp, "--out", folder / "r.csv")
    return judge(ran, "drive.rsp")


@attack("traceback", "RPC III file truncated in its header")
def rpc_truncated_header(fx: Fixtures) -> tuple[str, str]:
    folder = fx.fresh("rpc-truncated-header")
    rsp = _rsp(fx, folder)
    rsp.write_bytes(rsp.read_bytes()[:700])
    ran = nnfmu("cosim", fx.made["qc_system"], "--drive", rsp, "--out", folder / "r.csv")
    return judge(ran, "drive.rsp")


# -------------------------------------------------------------------------------------------------------- interrupts


def _train_args(fx: Fixtures, out: Path) -> list[str]:
    return [sys.executable, "-m", "nnfmu.cli", "train", str(fx.made["dyno"]), "--preset", "damper-spline", "--out",
            str(out), "--max-epochs", "100000", "--restarts", "1"]  # fmt: skip


def _loaded(pid: int, library: str) -> bool:
    try:
        return library in Path(f"/proc/{pid}/maps").read_text()
    except OSError:
        return False


def _sigterm_train(fx: Fixtures, name: str, moment: str, ignore: bool = False) -> tuple[str, str]:
    folder = fx.fresh(f"sigterm-{name}")
    scratch = folder / "tmp"
    scratch.mkdir()
    out = folder / "out" / "m.onnx"
    process = subprocess.Popen(
        _train_args(fx, out),
        env=dict(ENV, TMPDIR=str(scratch)),
        cwd=ENV["PYTHONPATH"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        preexec_fn=(lambda: signal.signal(signal.SIGTERM, signal.SIG_IGN)) if ignore else None,
    )
    started = time.monotonic()
    if moment == "torch":
        while not _loaded(process.pid, "libtorch") and process.poll() is None and time.monotonic() - started < 120:
            time.sleep(0.002)
    else:
        time.sleep(float(moment))
    if process.poll() is not None:
        return SETUP, f"train ended before the signal (exit {process.returncode})"
    at = time.monotonic() - started
    process.send_signal(signal.SIGTERM)
    try:
        _, err = process.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        return HANG, f"SIGTERM at {at:.1f} s ignored for 120 s"
    # onnxruntime keeps a session id in TMPDIR/.ses on import (tests/test_cli_signals.py): not nnfmu's
    left = [str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file() and p.name != ".ses"]
    if "Traceback" in err:
        return TRACE, err.strip().splitlines()[-1]
    if process.returncode not in (130, -signal.SIGTERM):
        return WRONG, f"SIGTERM at {at:.1f} s: exit {process.returncode}, left {left}"
    if left:
        return LOSS if out.exists() else WRONG, f"SIGTERM at {at:.1f} s: exit {process.returncode}, left {left}"
    return HELD, f"SIGTERM at {at:.1f} s -> exit {process.returncode}, nothing left"


for _name, _moment, _ignore in (
    ("at 0.3 s", "0.3", False),
    ("while torch loads", "torch", False),
    ("at 3 s", "3", False),
    ("at 6 s", "6", False),
    ("at 3 s, parent ignored SIGTERM", "3", True),
    ("at 6 s, parent ignored SIGTERM", "6", True),
):
    attack("interrupt", f"SIGTERM to train {_name}")(
        lambda fx, n=_name, m=_moment, i=_ignore: _sigterm_train(fx, re.sub(r"\W+", "-", n), m, i)
    )


# ------------------------------------------------------------------------------------------------------------ memory


def _peak(command: list[str], timeout: float) -> tuple[Ran, float | None, float | None]:
    """Run `command` under /usr/bin/time -v: the run, its max RSS [MB] and user+sys CPU [s]."""
    started = time.monotonic()
    try:
        done = subprocess.run(
            ["nice", "/usr/bin/time", "-v", *command],
            capture_output=True,
            text=True,
            env=ENV,
            cwd=ENV["PYTHONPATH"],
            timeout=timeout,
        )
    except subprocess.TimeoutExpired:
        return Ran(None, "", "", time.monotonic() - started), None, None
    rss = re.search(r"Maximum resident set size \(kbytes\): (\d+)", done.stderr)
    user = re.search(r"User time \(seconds\): ([\d.]+)", done.stderr)
    system = re.search(r"System time \(seconds\): ([\d.]+)", done.stderr)
    cpu = float(user.group(1)) + float(system.group(1)) if user and system else None
    return (
        Ran(done.returncode, done.stdout, done.stderr, time.monotonic() - started),
        int(rss.group(1)) / 1024 if rss else None,
        cpu,
    )


MEMORY: dict[str, object] = {}


@attack("memory", "data check on a 10 M-row CSV <= 1 GB peak")
def data_check_memory(fx: Fixtures) -> tuple[str, str]:
    sys.path.insert(0, str(ROOT / "bench"))
    from csv_memory import write_csv

    rows = fx.made["rows"]
    csv = fx.root / "large.csv"
    if not csv.exists():
        write_csv(csv, int(rows))
    ran, rss, cpu = _peak([sys.executable, "-m", "nnfmu.cli", "data", "check", str(csv)], timeout=1800)
    MEMORY.update(
        rows=int(rows), file_mb=round(csv.stat().st_size / 1e6, 1), data_check_peak_mb=rss, data_check_cpu_s=cpu,
        data_check_wall_s=round(ran.seconds, 1), load=os.getloadavg()[0],
    )  # fmt: skip
    if ran.hung:
        return HANG, "no end within 30 min"
    if "Traceback" in ran.text:
        return TRACE, ran.err.strip().splitlines()[-1]
    if ran.code != 0:
        return WRONG, f"exit {ran.code}: {ran.error_line}"
    verdict = HELD if rss is not None and rss <= 1000 else "over the limit"
    return verdict, f"peak {rss:.0f} MB, {cpu:.0f} s CPU, {ran.seconds:.0f} s wall on {int(rows)} rows"


@attack("memory", "train (one epoch) on a large record: peak measured")
def train_memory(fx: Fixtures) -> tuple[str, str]:
    """No target of its own (training holds features, tensors and the optimiser besides the record): the peak is
    reported; held when it ends, finite, within the timeout."""
    sys.path.insert(0, str(ROOT / "bench"))
    from csv_memory import write_csv

    rows = int(fx.made["train_rows"])
    csv = fx.root / f"train-{rows}.csv"
    if not csv.exists():
        write_csv(csv, rows)
    out = fx.fresh("train-memory") / "m.onnx"
    command = [sys.executable, "-m", "nnfmu.cli", "train", str(csv), "--preset", "damper-spline", "--out", str(out)]
    ran, rss, cpu = _peak([*command, "--max-epochs", "1", "--restarts", "1"], timeout=2400)
    MEMORY.update(
        train_rows=rows, train_peak_mb=rss, train_cpu_s=cpu, train_wall_s=round(ran.seconds, 1),
        train_float64_mb=rows * 4 * 8 / 1e6, train_load=os.getloadavg()[0],
    )  # fmt: skip
    if ran.hung:
        return HANG, "no end within 40 min"
    verdict, detail = judge(ran, ok_allowed=True)
    return verdict, f"peak {rss:.0f} MB, {cpu:.0f} s CPU, {ran.seconds:.0f} s wall on {rows} rows; {detail[:120]}"


# -------------------------------------------------------------------------------------------------------------- main


def save(outcomes: list[Outcome], out: Path, merge: bool, started: float) -> tuple[dict, list[Outcome]]:
    """Write the outcomes so far and their summary to `out` (with `merge`, beside the other attacks' outcomes
    already there); returns the summary and the outcomes written."""
    if merge and out.is_file():  # a partial re-run: the other attacks' outcomes as the file has them
        earlier = json.loads(out.read_text(encoding="utf-8"))
        ran_now = {o.name for o in outcomes}
        order = [name for _, name, _ in ATTACKS]
        kept = [Outcome(**o) for o in earlier["outcomes"] if o["name"] not in ran_now]
        outcomes = sorted(kept + outcomes, key=lambda o: order.index(o.name) if o.name in order else len(order))
        MEMORY.update({k: v for k, v in earlier["summary"].get("memory", {}).items() if k not in MEMORY})
    counts: dict[str, int] = {}
    for o in outcomes:
        counts[o.verdict] = counts.get(o.verdict, 0) + 1
    summary = {
        "attacks": len(outcomes),
        "verdicts": counts,
        "not_held": [o.name for o in outcomes if o.verdict not in (HELD, SETUP)],
        "setup_failed": [o.name for o in outcomes if o.verdict == SETUP],
        "memory": MEMORY,
        "load": [round(x, 2) for x in os.getloadavg()],
        "wall_s": round(time.monotonic() - started, 1),
    }
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(
        json.dumps({"summary": summary, "outcomes": [asdict(o) for o in outcomes]}, indent=1) + "\n", encoding="utf-8"
    )
    return summary, outcomes


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="*", default=[], help="run the attacks whose name contains one of these")
    parser.add_argument("--rows", type=float, default=1e7, help="rows of the large CSV of the memory attack")
    parser.add_argument("--train-rows", type=float, default=1e6, help="rows of the record `train` is measured on")
    parser.add_argument("--no-memory", action="store_true", help="leave out the (slow) memory attack")
    parser.add_argument("--keep", type=Path, help="work in this folder and keep it")
    parser.add_argument("--out", type=Path, default=RESULTS, help="JSON results file")
    parser.add_argument("--code", type=Path, help="run the nnfmu package found here (an older checkout, say)")
    parser.add_argument("--merge", action="store_true", help="keep the outcomes of other attacks already in --out")
    args = parser.parse_args()
    if args.code:
        ENV["PYTHONPATH"] = str(args.code.resolve())
    root = args.keep or Path(tempfile.mkdtemp(prefix="nnfmu-hostile-"))
    root.mkdir(parents=True, exist_ok=True)
    chosen = [
        a
        for a in ATTACKS
        if (not args.only or any(s in a[1] for s in args.only)) and not (args.no_memory and a[0] == "memory")
    ]
    started = time.monotonic()
    outcomes: list[Outcome] = []
    try:
        fx = make_fixtures(root)
        fx.made["rows"] = args.rows  # type: ignore[assignment]
        fx.made["train_rows"] = args.train_rows  # type: ignore[assignment]
        print(f"fixtures ready in {time.monotonic() - started:.0f} s ({root})", flush=True)
        for kind, name, function in chosen:
            began = time.monotonic()
            try:
                verdict, detail = function(fx)
            except Exception as error:  # the attack's own set-up broke: reported, not counted as nnfmu's
                verdict, detail = SETUP, f"{type(error).__name__}: {error}"[:300]
            outcomes.append(Outcome(kind, name, verdict, detail, round(time.monotonic() - began, 1)))
            print(f"[{verdict:>13}] {kind:>13} | {name}: {detail} ({time.monotonic() - began:.0f} s)", flush=True)
            save(outcomes, args.out, args.merge, started)
    finally:
        if args.keep is None:
            shutil.rmtree(root, ignore_errors=True)
    summary, outcomes = save(outcomes, args.out, args.merge, started)
    print()
    print(f"{'class':<14}{'attack':<62}{'verdict':<15}")
    for o in outcomes:
        print(f"{o.kind:<14}{o.name[:60]:<62}{o.verdict:<15}")
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
