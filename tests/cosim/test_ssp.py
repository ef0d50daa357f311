"""SSP system structure files: write -> read round trip, hostile names, clear errors for connectors that do not fit."""

from __future__ import annotations

import os
import re
import xml.etree.ElementTree as ET
import zipfile
from dataclasses import replace
from pathlib import Path

import pytest

from nnfmu import safe_zip
from nnfmu.cosim.ssp import (
    SSD,
    Connection,
    Connector,
    Element,
    SspError,
    SystemStructure,
    check_against_fmus,
    open_system,
    read_ssd,
    write_ssd,
)

HOSTILE = "a\"b<c>&d'e\nf\tg ü — ∂"


def test_round_trip_of_a_written_system(systems: dict[float, Path]) -> None:
    ssd = systems[1e-3]
    with open_system(ssd) as system:
        assert [e.name for e in system.elements] == ["vehicle", "damper"]
        assert set(map(str, system.connections)) == {
            "vehicle.damper_velocity -> damper.velocity",
            "damper.force -> vehicle.damper_force",
        }
        assert system.element("damper").parameters == {"filter_cutoff": 0.0}
        assert system.fmu_path("damper").resolve().is_file()
        copy = write_ssd(replace(system, stop_time=2.5), ssd.parent / "copy.ssd")
    again = read_ssd(copy)
    assert again.elements == system.elements
    assert again.connections == system.connections
    assert (again.start_time, again.stop_time) == (0.0, 2.5)
    assert ET.parse(copy).getroot().tag == f"{{{SSD}}}SystemStructureDescription"


def test_hostile_names_are_escaped_and_come_back(tmp_path: Path) -> None:
    system = SystemStructure(
        name=HOSTILE,
        elements=[
            Element(HOSTILE, f"{HOSTILE}.fmu", (Connector(HOSTILE, "output"),), {HOSTILE: -1.5e-300}),
            Element("b&", "b.fmu", (Connector("in<", "input"),)),
        ],
        connections=[Connection(HOSTILE, HOSTILE, "b&", "in<")],
        start_time=0.25,
        stop_time=1.0,
    )
    path = write_ssd(system, tmp_path / "SystemStructure.ssd")
    text = path.read_text(encoding="utf-8")
    assert "&lt;" in text and "&amp;" in text and "&quot;" in text  # escaped, so the file is well-formed XML
    again = read_ssd(path)
    assert again.name == HOSTILE
    assert again.elements == system.elements
    assert again.connections == system.connections
    assert again.element(HOSTILE).parameters[HOSTILE] == -1.5e-300


def _edited(ssd: Path, target: Path, old: str, new: str) -> Path:
    text = ssd.read_text(encoding="utf-8")
    assert old in text
    target.write_text(text.replace(old, new), encoding="utf-8")
    return target


def test_connector_missing_in_the_fmu_names_element_and_connector(systems: dict[float, Path]) -> None:
    ssd = systems[1e-3]
    bad = _edited(ssd, ssd.parent / "bad_connector.ssd", 'name="velocity"', 'name="piston_speed"')
    bad = _edited(bad, bad, 'endConnector="velocity"', 'endConnector="piston_speed"')
    with pytest.raises(SspError, match=r"element 'damper': connector 'piston_speed' is not a variable of damper\.fmu"):
        check_against_fmus(read_ssd(bad))


def test_connection_to_an_undeclared_connector_names_it(systems: dict[float, Path]) -> None:
    ssd = systems[1e-3]
    bad = _edited(ssd, ssd.parent / "bad_connection.ssd", 'endConnector="velocity"', 'endConnector="speed"')
    with pytest.raises(SspError, match=r"element 'damper' declares no connector 'speed' \(has: velocity, force"):
        read_ssd(bad)


def test_connector_of_the_wrong_kind_is_refused(systems: dict[float, Path]) -> None:
    ssd = systems[1e-3]
    bad = _edited(
        ssd,
        ssd.parent / "bad_kind.ssd",
        '<ssd:Connector name="force" kind="output">',
        '<ssd:Connector name="force" kind="input">',
    )
    with pytest.raises(SspError, match=r"connector damper\.force is an input, expected an output"):
        read_ssd(bad)


def test_missing_fmu_is_named(systems: dict[float, Path]) -> None:
    ssd = systems[1e-3]
    bad = _edited(ssd, ssd.parent / "bad_source.ssd", 'source="quarter_car.fmu"', 'source="nowhere.fmu"')
    with pytest.raises(SspError, match=r"element 'vehicle': FMU .*nowhere\.fmu not found"):
        check_against_fmus(read_ssd(bad))


def test_ssp_archive_opens_with_fmus_inside(systems: dict[float, Path], tmp_path: Path) -> None:
    with open_system(systems[1e-3]) as system:
        archive = tmp_path / "system.ssp"
        with zipfile.ZipFile(archive, "w") as zf:
            inside = replace(system, elements=[replace(e, source=f"resources/{e.name}.fmu") for e in system.elements])
            write_ssd(inside, tmp_path / "SystemStructure.ssd")
            zf.write(tmp_path / "SystemStructure.ssd", "SystemStructure.ssd")
            for element in system.elements:
                zf.write(system.fmu_path(element), f"resources/{element.name}.fmu")
    with open_system(archive) as opened:
        assert [e.name for e in opened.elements] == ["vehicle", "damper"]
        assert opened.fmu_path("vehicle").is_file()
        folder = opened.base
    assert not folder.exists()  # the extracted archive is removed afterwards


def _archive(
    systems: dict[float, Path],
    target: Path,
    sources: dict[str, str] | None = None,
    extra: dict[str, bytes] | None = None,
    compression: int = zipfile.ZIP_DEFLATED,
) -> Path:
    """An .ssp of the 1 ms system with its FMUs under resources/, element sources replaced by `sources` (element ->
    source) and the `extra` members added as they are named."""
    with open_system(systems[1e-3]) as system:
        inside = replace(
            system,
            elements=[
                replace(e, source=(sources or {}).get(e.name, f"resources/{e.name}.fmu")) for e in system.elements
            ],
        )
        ssd = write_ssd(inside, target.parent / f"{target.stem}.ssd")
        with zipfile.ZipFile(target, "w", compression) as zf:
            zf.write(ssd, "SystemStructure.ssd")
            for element in system.elements:
                zf.write(system.fmu_path(element), f"resources/{element.name}.fmu")
            for name, data in (extra or {}).items():
                zf.writestr(name, data)
    return target


@pytest.mark.parametrize(
    "member",
    [
        "../../../../../../../../tmp/{}/escaped",
        "/tmp/{}/escaped",
        "resources/../../{}",
        "C:/{}",
        "resources\\..\\..\\{}",
    ],
)
def test_an_archive_member_outside_its_folder_is_refused_before_anything_is_written(
    systems: dict[float, Path], tmp_path: Path, member: str
) -> None:
    unique = tmp_path.name + "-zip-slip"
    name = member.format(unique)
    archive = _archive(systems, tmp_path / "system.ssp", extra={name: b"payload"})
    with pytest.raises(SspError, match=rf"system\.ssp: member {re.escape(repr(name))} .*refusing"):
        with open_system(archive):
            pass
    assert not (Path("/tmp") / unique).exists()


def test_a_zip_bomb_and_an_archive_too_large_are_refused(
    systems: dict[float, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    bomb = _archive(systems, tmp_path / "bomb.ssp", extra={"resources/zeros.bin": bytes(4 * 1024 * 1024)})
    with pytest.raises(SspError, match=r"member 'resources/zeros\.bin' inflates \d+-fold .* limit"):
        with open_system(bomb):
            pass
    monkeypatch.setattr(safe_zip, "MAX_TOTAL_BYTES", 1024 * 1024)  # the FMUs alone are below it
    large = _archive(
        systems,
        tmp_path / "large.ssp",
        extra={"resources/noise.bin": os.urandom(1024 * 1024)},
        compression=zipfile.ZIP_STORED,
    )
    with pytest.raises(SspError, match=r"unpack to more than the limit of 1048576 bytes"):
        with open_system(large):
            pass


def test_element_sources_outside_the_archive_are_refused_naming_element_and_source(
    systems: dict[float, Path], tmp_path: Path
) -> None:
    with open_system(systems[1e-3]) as system:
        outside = str(system.fmu_path("damper").resolve())  # an FMU that exists, outside the archive
    for source in (outside, "../" * 12 + outside.lstrip("/"), "resources/../../damper.fmu", f"file://{outside}"):
        archive = _archive(systems, tmp_path / "system.ssp", sources={"damper": source})
        with pytest.raises(
            SspError,
            match=rf"element 'damper': source {re.escape(repr(source))} .*only use FMUs "
            r"inside itself",
        ):
            with open_system(archive):
                pass


def test_a_checked_archive_opens_from_its_extracted_folder(systems: dict[float, Path], tmp_path: Path) -> None:
    archive = _archive(systems, tmp_path / "system.ssp")
    with open_system(archive) as system:
        assert system.path == system.base / "SystemStructure.ssd" and system.path.is_file()
        assert all(system.base.resolve() in system.fmu_path(e).resolve().parents for e in system.elements)


def test_a_connection_between_different_units_is_refused_naming_both(
    systems: dict[float, Path], tmp_path: Path
) -> None:
    """The master passes values as they are: a force in N fed to a velocity input in m/s is a wiring mistake."""
    with open_system(systems[1e-3]) as system:
        wired = [
            c
            if str(c) != "vehicle.damper_velocity -> damper.velocity"
            else Connection("damper", "force", "damper", "velocity")
            for c in system.connections
        ]
        assert wired != system.connections
        ssd = write_ssd(replace(system, connections=wired), systems[1e-3].parent / "miswired.ssd")
    with pytest.raises(
        SspError,
        match=r"connection damper\.force -> damper\.velocity: the output is in 'N', the "
        r"input in 'm/s'",
    ):
        with open_system(ssd):
            pass


def test_an_element_fmu_that_is_a_zip_bomb_is_refused_before_fmpy_reads_it(
    systems: dict[float, Path], tmp_path: Path
) -> None:
    with open_system(systems[1e-3]) as system:
        bomb = tmp_path / "bomb.fmu"
        with (
            zipfile.ZipFile(system.fmu_path("damper")) as source,
            zipfile.ZipFile(bomb, "w", zipfile.ZIP_DEFLATED) as out,
        ):
            for name in source.namelist():
                out.writestr(name, source.read(name))
            out.writestr("resources/zeros.bin", bytes(4 * 1024 * 1024))
        elements = [replace(e, source=str(bomb)) if e.name == "damper" else e for e in system.elements]
        ssd = write_ssd(replace(system, elements=elements), systems[1e-3].parent / "bomb.ssd")
    with pytest.raises(SspError, match=r"element 'damper': cannot read .*bomb\.fmu: .*'resources/zeros\.bin' inflates"):
        with open_system(ssd, allow_outside=True):
            pass


def test_a_plain_ssd_loads_fmus_only_from_its_own_folder_unless_allowed(
    systems: dict[float, Path], tmp_path: Path
) -> None:
    """An FMU is native code: an element source leading out of the system's folder (absolute, `../`, or through a
    link) is refused naming the element, the source and the opt-in, which then opens it."""
    with open_system(systems[1e-3]) as system:
        fmus = {e.name: system.fmu_path(e).resolve() for e in system.elements}
    folder = tmp_path / "system"
    folder.mkdir()
    os.link(fmus["vehicle"], folder / "vehicle.fmu")
    (folder / "linked.fmu").symlink_to(fmus["damper"])
    for source in (str(fmus["damper"]), os.path.relpath(fmus["damper"], folder), "linked.fmu"):
        elements = [replace(e, source=source if e.name == "damper" else "vehicle.fmu") for e in system.elements]
        ssd = write_ssd(replace(system, elements=elements, base=folder), folder / "SystemStructure.ssd")
        with pytest.raises(SspError, match=rf"element 'damper': source {re.escape(repr(source))} .*--allow-outside"):
            with open_system(ssd):
                pass
        with open_system(ssd, allow_outside=True) as opened:
            assert opened.fmu_path("damper").resolve() == fmus["damper"]


def test_file_uri_sources_open_and_network_sources_are_refused_by_name(
    systems: dict[float, Path], tmp_path: Path
) -> None:
    """An SSD's `source` is a URI reference (SSP 1.0): a `file:` URI (absolute or relative) names the FMU it says,
    it read "not found" before; an http: source is refused when the file is read, naming element and source."""
    with open_system(systems[1e-3]) as system:
        fmus = {e.name: system.fmu_path(e).resolve() for e in system.elements}
    folder = tmp_path / "my system"
    folder.mkdir()
    for name, fmu in fmus.items():
        os.link(fmu, folder / f"{name} model.fmu")
    uris = {"damper": (folder / "damper model.fmu").as_uri(), "vehicle": "file:vehicle%20model.fmu"}
    elements = [replace(e, source=uris[e.name]) for e in system.elements]
    ssd = write_ssd(replace(system, elements=elements, base=folder), folder / "SystemStructure.ssd")
    with open_system(ssd) as opened:
        assert {e.name: opened.fmu_path(e) for e in opened.elements} == {
            name: folder / f"{name} model.fmu" for name in fmus
        }
    remote = write_ssd(
        replace(system, elements=[replace(e, source=f"https://example.org/{e.name}.fmu") for e in system.elements]),
        folder / "remote.ssd",
    )
    with pytest.raises(SspError, match=r"element 'vehicle': source 'https://example.org/vehicle.fmu' is a https: URI"):
        read_ssd(remote)
