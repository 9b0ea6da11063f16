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
