"""Interop: the AP10T in the simulator (`sim --device ap10t`), driven through python-can's
socketcand interface and python-canopen with eds/AP10T.eds: a factory display detects the bus's
rate from the master's traffic and boots up, answers expedited SDO, takes set points by RPDO and
reports them by TPDO, and keeps a saved setting over a power cycle (a restart with the same
--state-dir). Through the simulator's control port (--control, D-SIM-18) a key is pressed and the
screen read: the acknowledgement of a set point and the Auto-ID end to end.

The simulator binary is $SIM_BIN, else target/debug/sim. Run: pytest tests-host/py/test_ap10t.py
"""

import pathlib
import socket
import threading
import time

import canopen
import pytest

from test_sim import Sim

ROOT = pathlib.Path(__file__).resolve().parents[2]
EDS = str(ROOT / "eds" / "AP10T.eds")
NODE = 0x7D  # factory node-ID


class Control:
    """A client of the simulator's control port: one command, one reply line."""

    def __init__(self, port):
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=2)
        self.file = self.sock.makefile("rw", encoding="utf-8", newline="\n")

    def ask(self, command):
        self.file.write(command + "\n")
        self.file.flush()
        return self.file.readline().rstrip("\n")

    def screen(self, device="AP10T"):
        reply = self.ask(f"screen {device}")
        assert reply.startswith("ok ["), reply
        return reply[3:]

    def rows_over(self, seconds, device="AP10T"):
        """The distinct `[row 1|row 2]` texts the screen shows within `seconds` (flashing shows
        both phases: the blink period is 1 s)."""
        seen = set()
        deadline = time.time() + seconds
        while time.time() < deadline:
            seen.add(self.screen(device).split("]")[0] + "]")
            time.sleep(0.05)
        return seen

    def close(self):
        self.file.close()
        self.sock.close()


def join(net, node_id=NODE, seconds=8.0):
    """Talks on the bus (NMT "enter PRE-OPERATIONAL" to all nodes) until the display's boot-up
    arrives: a factory AP10T listens silently until it has heard a frame at its rate."""
    booted = []
    net.subscribe(0x700 + node_id, lambda _id, data, _t: booted.append(bytes(data)))
    deadline = time.time() + seconds
    while not booted and time.time() < deadline:
        net.send_message(0x000, bytes([0x80, 0x00]))
        time.sleep(0.1)
    assert booted and booted[0] == b"\x00", "no boot-up"


@pytest.fixture
def state_dir(tmp_path):
    return str(tmp_path / "state")


@pytest.fixture
def sim(state_dir):
    s = Sim("--device", "ap10t", "--bitrate", "can0=250", "--state-dir", state_dir, control=True)
    yield s
    s.stop()


@pytest.fixture
def node(sim):
    net = sim.network()
    join(net)
    yield net.add_node(NODE, EDS)
    net.disconnect()


def test_identity_over_expedited_sdo(node):
    od = canopen.import_od(EDS, NODE)
    assert node.sdo[0x1000].raw == 0x196
    assert node.sdo[0x1018][1].raw == od[0x1018][1].default
    # 1008h "AP10T" in one expedited answer: its first four bytes (D-AP-21).
    assert node.sdo.upload(0x1008, 0) == b"AP10"
    assert node.sdo[0x5F0A][3].raw == 2, "the detected rate, 250 kbit/s"
    with pytest.raises(canopen.SdoAbortedError) as e:
        node.sdo.upload(0x5F1D, 1)
    assert e.value.code == 0x06010000


def test_set_point_by_rpdo_and_back_by_tpdo(node):
    net = node.network
    received = []
    net.subscribe(0x280 + NODE, lambda _id, data, _t: received.append(bytes(data)))
    node.nmt.state = "OPERATIONAL"
    time.sleep(0.1)
    # RPDO2: set point 2 = -5, valid (control word 0204h).
    net.send_message(0x300 + NODE, bytes([0xFB, 0xFF, 0xFF, 0xFF, 0, 0, 0x04, 0x02]))
    time.sleep(0.1)
    net.sync.transmit()
    deadline = time.time() + 2
    while not received and time.time() < deadline:
        time.sleep(0.02)
    assert received[0] == bytes([0xFB, 0xFF, 0xFF, 0xFF, 0, 0, 0x04, 0x04])
    assert node.sdo[0x5F19].raw == 0x0404


def test_a_saved_setting_survives_a_power_cycle(sim, node):
    node.sdo[0x5F11].raw = 2
    node.sdo[0x1010][1].raw = 0x65766173  # "save": also keeps the detected rate
    node.network.disconnect()
    sim.stop()
    sim.start()
    net = sim.network()
    try:
        # The saved rate needs no detection: the boot-up is already past; SDO answers.
        node = net.add_node(NODE, EDS)
        assert node.sdo[0x5F11].raw == 2
        assert node.sdo[0x5F0A][3].raw == 2
    finally:
        net.disconnect()


@pytest.fixture
def control(sim):
    c = Control(sim.control_port)
    yield c
    c.close()


def status_by_sync(net, tpdo_id):
    """The status word (bytes 6-7) of the TPDO `tpdo_id` a SYNC triggers (TPDO2 by default;
    the status word is one for both set points)."""
    received = []
    net.subscribe(tpdo_id, lambda _id, data, _t: received.append(bytes(data)))
    net.sync.transmit()
    deadline = time.time() + 2
    while not received and time.time() < deadline:
        time.sleep(0.02)
    net.unsubscribe(tpdo_id)
    assert received, "no TPDO"
    return int.from_bytes(received[0][6:8], "little")


SP1_VALID = 1 << 2
SP1_ACK = 1 << 5


def test_a_set_point_is_acknowledged_at_the_key(node, control):
    net = node.network
    assert control.ask("list") == f"ok can0:AP10T#{NODE}"
    node.nmt.state = "OPERATIONAL"
    time.sleep(0.1)
    # RPDO1: set point 1 = 1234, valid (control word 0004h), not acknowledged by the master.
    net.send_message(0x200 + NODE, (1234).to_bytes(4, "little") + bytes([0, 0, 0x04, 0x00]))
    time.sleep(0.1)
    # Unacknowledged: row 1 flashes (D-AP-6), the status word says valid, not acknowledged.
    flashing = control.rows_over(1.2)
    assert "[  1234|   ---]" in flashing and "[      |   ---]" in flashing, flashing
    status = status_by_sync(net, 0x280 + NODE)
    assert status & (SP1_VALID | SP1_ACK) == SP1_VALID, hex(status)
    assert node.sdo[0x5F19].raw & SP1_ACK == 0
    unacknowledged = control.screen()
    # The front key acknowledges always (5F1Ch, D-AP-8).
    assert control.ask(f"press can0:AP10T#{NODE} front") == "ok"
    assert control.rows_over(1.2) == {"[  1234|   ---]"}, "steady once acknowledged"
    status = status_by_sync(net, 0x280 + NODE)
    assert status & (SP1_VALID | SP1_ACK) == SP1_VALID | SP1_ACK, hex(status)
    assert node.sdo[0x5F19].raw & SP1_ACK == SP1_ACK
    # The LEDs follow the acknowledgement (Table 1): green once acknowledged.
    acknowledged = control.screen()
    assert "LED green/" in acknowledged, acknowledged
    assert "LED green/" not in unacknowledged, unacknowledged


def test_auto_id_with_the_key(node, control):
    net = node.network
    new_id = 7
    booted = []
    net.subscribe(0x700 + new_id, lambda _id, data, _t: booted.append(bytes(data)))
    # The SDO answer waits for the key (D-AP-18): the write runs in a thread of its own.
    node.sdo.RESPONSE_TIMEOUT = 10.0
    outcome = []

    def write():
        try:
            node.sdo[0x5F0A][2].raw = new_id
            outcome.append("answered")
        except Exception as e:  # noqa: BLE001 - reported by the assertion below
            outcome.append(e)

    writer = threading.Thread(target=write)
    writer.start()
    deadline = time.time() + 3
    while "New ID" not in control.screen() and time.time() < deadline:
        time.sleep(0.05)
    assert control.screen().startswith("[New ID|      ]"), control.screen()
    time.sleep(0.3)
    assert not outcome, "no answer before the key"
    # Another key does nothing while "New ID" shows (D-AP-10).
    assert control.ask("press AP10T up") == "ok"
    assert "New ID" in control.screen()
    assert control.ask("press AP10T auto_id") == "ok"
    writer.join(5)
    assert outcome == ["answered"], outcome
    deadline = time.time() + 2
    while not booted and time.time() < deadline:
        time.sleep(0.02)
    assert booted == [b"\x00"], "boot-up on the new node-ID"
    assert control.ask("list") == f"ok can0:AP10T#{new_id}"
    assert "New ID" not in control.screen(f"AP10T#{new_id}")
    renamed = net.add_node(new_id, EDS)
    assert renamed.sdo[0x5F0A][1].raw == new_id
    assert renamed.sdo[0x1000].raw == 0x196
