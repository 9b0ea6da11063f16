"""Interop: the AP10T in the simulator (`sim --device ap10t`), driven through python-can's
socketcand interface and python-canopen with eds/AP10T.eds: a factory display detects the bus's
rate from the master's traffic and boots up, answers expedited SDO, takes set points by RPDO and
reports them by TPDO, and keeps a saved setting over a power cycle (a restart with the same
--state-dir).

The simulator binary is $SIM_BIN, else target/debug/sim. Run: pytest tests-host/py/test_ap10t.py
"""

import os
import pathlib
import socket
import subprocess
import time

import can
import canopen
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
EDS = str(ROOT / "eds" / "AP10T.eds")
NODE = 0x7D  # factory node-ID

_built = []


def sim_binary():
    env = os.environ.get("SIM_BIN")
    if env:
        return env
    if not _built:
        subprocess.run(["cargo", "build", "-q", "-p", "tests-host", "--bin", "sim"], cwd=ROOT, check=True)
        _built.append(True)
    return str(ROOT / "target" / "debug" / "sim")


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Sim:
    def __init__(self, *args):
        self.args = list(args)
        self.port = free_port()
        self.start()

    def start(self):
        cmd = [sim_binary(), "--quiet", "--listen", f"127.0.0.1:{self.port}", *self.args]
        self.proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        deadline = time.time() + 10
        while True:
            try:
                socket.create_connection(("127.0.0.1", self.port), timeout=0.2).close()
                return
            except OSError:
                if self.proc.poll() is not None:
                    raise RuntimeError(f"sim exited: {self.proc.stderr.read().decode()}")
                if time.time() > deadline:
                    raise RuntimeError("sim does not listen")
                time.sleep(0.05)

    def stop(self):
        self.proc.kill()
        self.proc.wait()
        self.proc.stderr.close()

    def network(self):
        net = canopen.Network()
        net.connect(interface="socketcand", channel="can0", host="127.0.0.1", port=self.port)
        return net


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
    s = Sim("--device", "ap10t", "--bitrate", "can0=250", "--state-dir", state_dir)
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
