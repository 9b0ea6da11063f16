"""Reads every checked-in EDS (eds/*.eds) with python-canopen, as an integrator's tool would,
and checks that each (index, sub-index) of the device table (the JSON dump next to it, written
by the Rust generator's test) is there with its name, data type, access, PDO mapping, default
and limits; and checks every EDS with `dcfchk` of Lely's dcf-tools, a CiA 306 checker, which
must pass without a warning. Run: pytest tests-host/py/test_eds.py
"""

import json
import pathlib
import shutil
import subprocess
import sys

import canopen
import pytest

EDS_DIR = pathlib.Path(__file__).resolve().parents[2] / "eds"
EDS_FILES = sorted(EDS_DIR.glob("*.eds"))
NODE_ID = 5


def entries(eds):
    return json.loads(eds.with_suffix(".json").read_text())


def test_there_is_an_eds():
    assert EDS_FILES, f"no EDS in {EDS_DIR}"


@pytest.mark.parametrize("eds", EDS_FILES, ids=[p.name for p in EDS_FILES])
def test_every_table_entry_is_in_the_eds(eds):
    od = canopen.import_od(str(eds), node_id=NODE_ID)
    table = entries(eds)
    assert table
    for e in table:
        where = f"{e['index']:04X}h.{e['sub']}"
        assert e["index"] in od, where
        obj = od[e["index"]]
        if isinstance(obj, canopen.objectdictionary.ODVariable):
            assert e["sub"] == 0, where
            var = obj
        else:
            assert obj.name == e["object"], where
            assert e["sub"] in obj, where
            var = obj[e["sub"]]
        assert var.name == e["name"], where
        assert var.data_type == e["data_type"], where
        assert var.access_type == e["access"], where
        assert var.pdo_mappable == e["pdo"], where
        if e["node_id_relative"]:
            assert var.relative, where
            assert var.default == e["default"] + NODE_ID, where
        else:
            assert not var.relative, where
            assert var.default == e["default"], where
        assert var.min == e["low"], where
        assert var.max == e["high"], where


@pytest.mark.parametrize("eds", EDS_FILES, ids=[p.name for p in EDS_FILES])
def test_nothing_beyond_the_table(eds):
    od = canopen.import_od(str(eds), node_id=NODE_ID)
    keys = {(e["index"], e["sub"]) for e in entries(eds)}
    for obj in od.values():
        if isinstance(obj, canopen.objectdictionary.ODVariable):
            assert (obj.index, 0) in keys, f"{obj.index:04X}h"
        else:
            for sub in obj.subindices:
                assert (obj.index, sub) in keys, f"{obj.index:04X}h.{sub}"


@pytest.mark.parametrize("eds", EDS_FILES, ids=[p.name for p in EDS_FILES])
def test_device_info(eds):
    od = canopen.import_od(str(eds), node_id=NODE_ID)
    info = od.device_information
    table = {(e["index"], e["sub"]): e for e in entries(eds)}
    assert info.vendor_number == table[(0x1018, 1)]["default"] & 0xFFFFFFFF
    assert info.product_name == table[(0x1008, 0)]["default"]
    assert info.allowed_baudrates
    assert info.nr_of_TXPDO == len({i for (i, _) in table if 0x1800 <= i <= 0x19FF})


def dcfchk():
    """The dcfchk of the environment running the tests (the virtual environment's)."""
    here = pathlib.Path(sys.executable).parent / "dcfchk"
    return str(here) if here.exists() else shutil.which("dcfchk")


def test_dcfchk_is_installed():
    assert dcfchk(), "dcfchk not found: pip install -r tests-host/py/requirements.txt"


@pytest.mark.parametrize("eds", EDS_FILES, ids=[p.name for p in EDS_FILES])
def test_dcfchk_passes(eds):
    # Node-ID 5 resolves the $NODEID defaults; every warning (a DefaultValue outside its
    # limits, say) is a failure too.
    run = subprocess.run(
        [sys.executable, "-W", "error", dcfchk(), "-n", str(NODE_ID), str(eds)],
        capture_output=True,
        text=True,
    )
    assert run.returncode == 0 and not run.stderr.strip() and not run.stdout.strip(), run.stdout + run.stderr
