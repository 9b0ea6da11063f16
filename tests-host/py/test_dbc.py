"""Decodes the WV58MR's J1939 frames with cantools through the checked-in DBC
(dbc/WV58MR.dbc), as an integrator's tool would: every frame in dbc/WV58MR.vectors.json (emitted
by od-core's wire formats, kept current by its `dbc_vectors_are_current` test) must decode to the
values it was built from, whatever its source address and priority, and encoding those values
must give its bytes back, padding included. Run: pytest tests-host/py/test_dbc.py
"""

import json
import pathlib

import cantools
import pytest

DBC_DIR = pathlib.Path(__file__).resolve().parents[2] / "dbc"
VECTORS = json.loads((DBC_DIR / "WV58MR.vectors.json").read_text())
# EDP, DP, PF and PS: any source address, any priority (D-J1939-11).
PGN_MASK = 0x03FFFF00
# Messages whose unused bytes are FFh ("not available"); Proprietary B pads with 00h.
PADDED_FF = {"EPOS", "ESPD", "EMCY"}


@pytest.fixture(scope="module")
def db():
    return cantools.database.load_file(str(DBC_DIR / "WV58MR.dbc"), frame_id_mask=PGN_MASK)


def test_every_message_has_vectors(db):
    assert {m.name for m in db.messages} == {v["message"] for v in VECTORS}
    for m in db.messages:
        assert m.is_extended_frame and m.protocol == "j1939" and m.length == 8, m.name


@pytest.mark.parametrize("v", VECTORS, ids=[f"{v['message']}-{v['id']:08X}-{v['data']}" for v in VECTORS])
def test_vector_decodes_and_encodes_back(db, v):
    msg = db.get_message_by_frame_id(v["id"])
    assert msg.name == v["message"]
    data = bytes.fromhex(v["data"])
    assert msg.decode(data, decode_choices=False) == v["signals"]
    assert msg.encode(v["signals"], padding=msg.name in PADDED_FF) == data
