"""Interop: the simulated WV58MR (`sim --device wv58mr`) on can1 with a can-j1939 ECU joining
through python-can's socketcand interface, as a J1939 tool would (issue 12): it sees the
address claims, requests the address claimed, contends for the WV58MR's address and wins or
loses by NAME as J1939-81 says, receives EPOS through its subscription, reads and writes
parameters through CAM21/CAM11, and decodes the frames the node produced with the checked-in
DBC (cantools) into the values the dictionary holds.

Run: pytest tests-host/py/test_j1939.py
"""

import pathlib
import threading
import time

import can
import cantools
import j1939
import pytest

from test_sim import Sim

ROOT = pathlib.Path(__file__).resolve().parents[2]
DBC = ROOT / "dbc" / "WV58MR.dbc"
SERIAL = 0x12345  # the NAME's identity number
POSITION = 74565  # 12345h: 6004h with the default scaling, 12-bit multiturn

# The WV58MR's default NAME with identity number 12345h (digest D26).
WV58MR_NAME = 0xB0008E008E200000 | SERIAL


def start_wv58mr(*extra):
    return Sim("--device", f"wv58mr:serial={SERIAL},position={POSITION}" + "".join(extra))


class Trace:
    """Every frame on can1, as python-can sees it through socketcand."""

    def __init__(self, port):
        self.bus = can.Bus(interface="socketcand", channel="can1", host="127.0.0.1", port=port)
        self.frames = []
        self.lock = threading.Lock()
        self.notifier = can.Notifier(self.bus, [self._on])

    def _on(self, msg):
        with self.lock:
            self.frames.append(msg)

    def wait(self, pred, timeout=3.0):
        end = time.time() + timeout
        while time.time() < end:
            with self.lock:
                for m in self.frames:
                    if pred(m):
                        return m
            time.sleep(0.02)
        return None

    def send(self, arbitration_id, data):
        self.bus.send(can.Message(arbitration_id=arbitration_id, data=bytes(data), is_extended_id=True))

    def close(self):
        self.notifier.stop()
        self.bus.shutdown()


@pytest.fixture
def sim():
    s = start_wv58mr()
    yield s
    s.stop()


@pytest.fixture
def trace(sim):
    t = Trace(sim.port)
    yield t
    t.close()


def ecu_with_ca(port, name, address):
    ecu = j1939.ElectronicControlUnit()
    ecu.connect(interface="socketcand", channel="can1", host="127.0.0.1", port=port)
    ca = j1939.ControllerApplication(name, address)
    ecu.add_ca(controller_application=ca)
    return ecu, ca


def tool_name(identity):
    return j1939.Name(
        arbitrary_address_capable=0,
        industry_group=j1939.Name.IndustryGroup.Industrial,
        vehicle_system_instance=0,
        vehicle_system=0,
        function=0x81,
        function_instance=0,
        ecu_instance=0,
        manufacturer_code=0x0471,
        identity_number=identity,
    )


def test_address_claim_and_request_for_address_claimed(trace):
    # The power-on claim went out before this client connected: a global Request for Address
    # Claimed (PGN 60928) gets it again.
    assert trace.wait(lambda m: m.arbitration_id == 0x0CFC5FEF) is not None
    trace.send(0x18EAFF00, [0x00, 0xEE, 0x00])
    claim = trace.wait(lambda m: m.arbitration_id == 0x18EEFFEF)
    assert claim is not None, "no Address Claimed from EFh"
    assert int.from_bytes(claim.data, "little") == WV58MR_NAME
    # A restart (3002h.02) claims anew: the claim, then 250 ms of nothing else, then EPOS.
    assert cam(trace, [0x2F, 0x02, 0x30, 0x02, 0x01, 0, 0, 0]) == bytes([0x60, 0x02, 0x30, 0x02, 0, 0, 0, 0])
    n = len(trace.frames)
    claim = trace.wait(lambda m: m.arbitration_id == 0x18EEFFEF and trace.frames.index(m) >= n)
    assert claim is not None and int.from_bytes(claim.data, "little") == WV58MR_NAME
    epos = trace.wait(lambda m: m.arbitration_id == 0x0CFC5FEF and trace.frames.index(m) > trace.frames.index(claim))
    assert epos is not None and epos.timestamp - claim.timestamp >= 0.2


def test_epos_reaches_a_can_j1939_subscriber(sim, trace):
    ecu = j1939.ElectronicControlUnit()
    ecu.connect(interface="socketcand", channel="can1", host="127.0.0.1", port=sim.port)
    got = []
    ecu.subscribe(lambda priority, pgn, sa, timestamp, data: got.append((priority, pgn, sa, bytes(data))))
    try:
        end = time.time() + 3
        while time.time() < end and not any(p == 64607 for _, p, _, _ in got):
            time.sleep(0.05)
        epos = [g for g in got if g[1] == 64607]
        assert epos, f"no EPOS among {got[:5]}"
        priority, _, sa, data = epos[0]
        assert (priority, sa) == (3, 0xEF)
        assert int.from_bytes(data[:4], "little") == POSITION
        assert data[4:] == b"\xff\xff\xff\xff"
    finally:
        ecu.disconnect()


def test_a_lower_name_takes_the_address_and_the_wv58mr_moves(sim, trace):
    assert trace.wait(lambda m: m.arbitration_id == 0x0CFC5FEF) is not None
    # A NAME below the WV58MR's (industry group 0, not arbitrary address capable) claims EFh.
    name = j1939.Name(
        arbitrary_address_capable=0, industry_group=0, vehicle_system_instance=0, vehicle_system=0,
        function=0, function_instance=0, ecu_instance=0, manufacturer_code=0x0471, identity_number=1,
    )
    assert name.value < WV58MR_NAME
    ecu, ca = ecu_with_ca(sim.port, name, 0xEF)
    try:
        ca.start()
        moved = trace.wait(lambda m: m.arbitration_id == 0x18EEFF80, timeout=4)
        assert moved is not None, "the WV58MR did not move to 80h"
        assert trace.wait(lambda m: m.arbitration_id == 0x0CFC5F80, timeout=3) is not None
        end = time.time() + 3
        while time.time() < end and ca.state != j1939.ControllerApplication.State.NORMAL:
            time.sleep(0.05)
        assert ca.state == j1939.ControllerApplication.State.NORMAL and ca.device_address == 0xEF
    finally:
        ca.stop()
        ecu.disconnect()


def test_a_higher_name_loses_and_the_wv58mr_keeps_its_address(sim, trace):
    assert trace.wait(lambda m: m.arbitration_id == 0x0CFC5FEF) is not None
    name = j1939.Name(
        arbitrary_address_capable=1, industry_group=7, vehicle_system_instance=0, vehicle_system=0,
        function=0xFF, function_instance=0, ecu_instance=0, manufacturer_code=0x7FF, identity_number=2,
    )
    assert name.value > WV58MR_NAME
    ecu, ca = ecu_with_ca(sim.port, name, 0xEF)
    try:
        n = len(trace.frames)
        ca.start()
        # The WV58MR defends EFh with its claim; the tool moves on.
        defended = trace.wait(
            lambda m: m.arbitration_id == 0x18EEFFEF and trace.frames.index(m) >= n
            and int.from_bytes(m.data, "little") == WV58MR_NAME,
            timeout=4,
        )
        assert defended is not None
        end = time.time() + 3
        while time.time() < end and ca.state != j1939.ControllerApplication.State.NORMAL:
            time.sleep(0.05)
        assert ca.device_address != 0xEF
        m = len(trace.frames)
        time.sleep(0.3)
        assert any(f.arbitration_id == 0x0CFC5FEF for f in trace.frames[m:])
    finally:
        ca.stop()
        ecu.disconnect()


def cam(trace, request, address=0xEF, master=0x21):
    n = len(trace.frames)
    trace.send(0x1C060000 | address << 8 | master, request)
    answer = trace.wait(
        lambda m: m.arbitration_id == (0x1C050000 | master << 8 | address) and trace.frames.index(m) >= n
    )
    assert answer is not None, f"no CAM11 answer to {bytes(request).hex()}"
    return bytes(answer.data)


def test_parameters_through_cam21_and_cam11(sim, trace):
    assert trace.wait(lambda m: m.arbitration_id == 0x0CFC5FEF) is not None
    # Read 3000h.02 (ESPD cycle, 50 ms), 1018h.01 (vendor-ID), the NAME's identity number.
    assert cam(trace, [0x40, 0x00, 0x30, 0x02, 0, 0, 0, 0]) == bytes([0x4B, 0x00, 0x30, 0x02, 0x32, 0, 0, 0])
    assert cam(trace, [0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0]) == bytes([0x43, 0x18, 0x10, 0x01, 0x95, 0x01, 0, 0])
    assert cam(trace, [0x40, 0x01, 0x30, 0x01, 0, 0, 0, 0])[4:7] == SERIAL.to_bytes(3, "little")
    # Switch Proprietary B on at 100 ms; it arrives with position and speed.
    assert cam(trace, [0x2B, 0x00, 0x30, 0x01, 0x64, 0x00, 0, 0]) == bytes([0x60, 0x00, 0x30, 0x01, 0, 0, 0, 0])
    b = trace.wait(lambda m: m.arbitration_id == 0x18FFAAEF)
    assert b is not None and int.from_bytes(b.data[:4], "little") == POSITION and b.data[6:] == b"\x00\x00"
    # A missing object: CiA 301 abort 06020000h.
    assert cam(trace, [0x40, 0x00, 0x70, 0x00, 0, 0, 0, 0]) == bytes([0x80, 0x00, 0x70, 0x00, 0x00, 0x00, 0x02, 0x06])


def test_dbc_decodes_what_the_node_sends(sim, trace):
    db = cantools.database.load_file(str(DBC))
    # Proprietary B on, so every process-data group is on the bus.
    assert trace.wait(lambda m: m.arbitration_id == 0x0CFC5FEF) is not None
    cam(trace, [0x2B, 0x00, 0x30, 0x01, 0x32, 0x00, 0, 0])
    assert trace.wait(lambda m: m.arbitration_id == 0x18FFAAEF) is not None
    trace.send(0x18EAEF00, [0x00, 0xEE, 0x00])
    assert trace.wait(lambda m: m.arbitration_id == 0x18EEFFEF) is not None
    by_pgn = {}
    with trace.lock:
        for m in trace.frames:
            by_pgn.setdefault(m.arbitration_id & 0x03FFFF00, m)

    def decode(name, frame):
        msg = db.get_message_by_name(name)
        assert frame.arbitration_id & 0x03FFFF00 == msg.frame_id & 0x03FFFF00
        return msg.decode(bytes(frame.data))

    assert decode("EPOS", by_pgn[0x00FC5F00]) == {"PositionValue": POSITION}
    assert decode("ESPD", by_pgn[0x00FC6100]) == {"SpeedValue": 0}
    assert decode("ProprietaryB", by_pgn[0x00FFAA00]) == {"PositionValue": POSITION, "SpeedValue": 0}
    claim = decode("AddressClaimed", by_pgn[0x00EEFF00])
    assert claim["IdentityNumber"] == SERIAL and claim["ManufacturerCode"] == 0x471
    assert claim["Function"] == 0x8E and claim["IndustryGroup"] == 3 and claim["ArbitraryAddressCapable"] == 1
