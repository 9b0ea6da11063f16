"""The pure helpers of renode/canopen.py (Renode runs it with IronPython; these functions use no
.NET type): the sensor frames it feeds the firmware must be the frames board-plan decodes
(boards/plan/src/sensor.rs), and the trace lines are what the Robot tests match."""

import importlib.util
import pathlib

import pytest

_PATH = pathlib.Path(__file__).resolve().parents[2] / "renode" / "canopen.py"
_SPEC = importlib.util.spec_from_file_location("renode_canopen", _PATH)
renode = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(renode)


def test_crc8_is_sae_j1850_as_board_plan():
    # The check value board_plan::sensor's test asserts for "123456789".
    assert renode.crc8(b"123456789") == 0x4B


def test_sensor_frame_layout():
    # turns 3, angle 1234h, warning: word = (1234h << 2) | 1 = 48D1h, big-endian, then the CRC.
    frame = list(renode.sensor_frame(3, 0x1234, False, True))
    assert frame[:4] == [0x00, 0x03, 0x48, 0xD1]
    assert frame[4] == renode.crc8(bytes(frame[:4]))
    # The error bit is bit 1 of the angle word.
    assert list(renode.sensor_frame(0, 5, True, False))[:4] == [0x00, 0x00, 0x00, 0x16]


def test_identifiers_and_extended_trace_lines():
    # can_send takes 11-bit identifiers, can_send_ext 29-bit ones (J1939).
    assert renode.check_id(0x7FF) == 0x7FF
    assert renode.check_id(0x1C06EF00, True) == 0x1C06EF00
    with pytest.raises(ValueError):
        renode.check_id(0x800)
    with pytest.raises(ValueError):
        renode.check_id(0x20000000, True)
    # An Address Claimed of EFh as the Robot tests wait for it: 8 hex digits for 29 bits.
    claim = [0x0A, 0x56, 0x39, 0x8E, 0x00, 0x8E, 0x00, 0xB0]
    assert renode.format_frame(0x18EEFFEF, claim, extended=True) == "18EEFFEF [8] 0A 56 39 8E 00 8E 00 B0"


def test_speed_line():
    # What bench_speed logs and renode/README.md asks to keep: virtual seconds per wall second.
    assert renode.speed_line(60.0, 48.0) == (
        "bench speed: 60.000 virtual s in 48.000 wall s = 1.250 virtual s per wall s"
    )
    assert renode.speed_line(60.0, 120.0).endswith("= 0.500 virtual s per wall s")


def test_trace_lines_and_hex_parsing():
    assert renode.parse_hex("40 00 10 00") == [0x40, 0x00, 0x10, 0x00]
    assert renode.parse_hex("2B1710006400") == [0x2B, 0x17, 0x10, 0x00, 0x64, 0x00]
    assert renode.format_frame(0x581, [0x43, 0x00, 0x10, 0x00, 0x96, 0x01, 0x0A, 0x00]) == (
        "581 [8] 43 00 10 00 96 01 0A 00"
    )
    assert renode.format_frame(0x701, [0x00]) == "701 [1] 00"
    with pytest.raises(ValueError):
        renode.parse_hex("123")
    with pytest.raises(ValueError):
        renode.parse_hex("00" * 9)


class FakeSlave:
    """An LSS slave as CiA 305 and docs/decisions.md D-LSS-5, D-LSS-7 and D-LSS-11 describe it
    (od-core/src/lss.rs): Fastscan only in LSS waiting and while it has no node-ID, active or
    pending; a restart (BitChecked 80h) sets LSSPos to the vendor-ID; a match of bits
    31..BitChecked of part LSSPos = LSSSub confirms and moves LSSPos to LSSNext, and after
    BitChecked 0 with LSSNext < LSSSub enters configuration; switched back to waiting with a
    pending node-ID it takes it (and boots up)."""

    def __init__(self, address, node_id=None):
        self.address = list(address)
        self.node_id = node_id
        self.pending = node_id
        self.state = "waiting"
        self.pos = 0

    def handle(self, req):
        cs = req[0]
        if cs == renode.LSS_FASTSCAN:
            if self.node_id is not None or self.pending is not None:
                return []
            if self.state != "waiting":
                return []
            id_number = req[1] | req[2] << 8 | req[3] << 16 | req[4] << 24
            bit, sub, nxt = req[5], req[6], req[7]
            if bit == renode.FASTSCAN_RESTART:
                self.pos = 0
                return [[renode.LSS_IDENTIFY_SLAVE] + [0] * 7]
            mask = (0xFFFFFFFF << bit) & 0xFFFFFFFF
            if self.pos != sub or (self.address[sub] ^ id_number) & mask:
                return []
            self.pos = nxt
            if bit == 0 and nxt < sub:
                self.state = "configuration"
            return [[renode.LSS_IDENTIFY_SLAVE] + [0] * 7]
        if cs == renode.LSS_CONFIGURE_NODE_ID and self.state == "configuration":
            self.pending = req[1]
            return [[renode.LSS_CONFIGURE_NODE_ID, 0, 0, 0, 0, 0, 0, 0]]
        if cs == renode.LSS_SWITCH_GLOBAL:
            if req[1] == 0:
                if self.state == "configuration" and self.node_id is None and self.pending is not None:
                    self.node_id = self.pending
                self.state = "waiting"
            elif req[1] == 1:
                self.state = "configuration"
        return []


def run_fastscan(slaves, first=0x20):
    scan = renode.Fastscan(first)
    requests = 0
    while True:
        req = scan.request()
        if req is None:
            return scan, requests
        requests += 1
        assert requests < 2000, "the scan does not end"
        replies = []
        for s in slaves:
            replies += s.handle(req)
        scan.answered(replies)


SGH50 = (0x00000195, 0x0000C350, 0x00010000)


def test_fastscan_finds_boards_that_differ_in_the_serial_only():
    a = FakeSlave(SGH50 + (0x9E3779B9,))
    b = FakeSlave(SGH50 + (0x1234ABCD,))
    scan, requests = run_fastscan([a, b])
    assert scan.error is None
    # The lower address first: it answers every bit asked as 0 that the other does not.
    assert scan.found == [SGH50 + (0x1234ABCD, 0x20), SGH50 + (0x9E3779B9, 0x21)]
    assert (a.node_id, b.node_id) == (0x21, 0x20)
    # Two scans of 1 + 4 x 33 requests, each find configured and switched, and the last
    # restart that nobody confirms.
    assert requests == 2 * (1 + 4 * 33 + 2) + 1
    assert renode.format_found(scan.found[0]) == (
        "found serial 1234ABCD (vendor 00000195, product 0000C350, revision 00010000), node-ID 32")


def test_fastscan_cannot_part_boards_with_one_serial():
    # Two blank boards whose unique IDs read alike derive one serial number: both enter
    # configuration on the same address and both answer the node-ID, which the master refuses.
    a = FakeSlave(SGH50 + (0x7BD5C66F,))
    b = FakeSlave(SGH50 + (0x7BD5C66F,))
    scan, _ = run_fastscan([a, b])
    assert scan.found == []
    assert scan.error is not None and "configure node-ID 32" in scan.error


def test_fastscan_skips_configured_nodes_and_ends_on_silence():
    scan, requests = run_fastscan([FakeSlave(SGH50 + (5,), node_id=1)])
    assert (scan.found, scan.error, requests) == ([], None, 1)
    assert renode.fastscan_request(0x12345678, 0x80, 0, 0) == [0x51, 0x78, 0x56, 0x34, 0x12, 0x80, 0, 0]
