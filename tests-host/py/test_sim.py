"""Interop: the simulator (`sim`) driven as a real master would, through python-can's socketcand
interface and python-canopen, with each device's checked-in EDS as the node's dictionary.

The simulator binary is $SIM_BIN, else target/debug/sim as `cargo build -p tests-host --bin sim`
leaves it. Run: pytest tests-host/py/test_sim.py
"""

import os
import pathlib
import socket
import subprocess
import threading
import time

import can
import canopen
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
EDS = ROOT / "eds"
SGH10_EDS = str(EDS / "SGH10.eds")
NODE = 10

# Every CANopen device the simulator has, with its EDS (if checked in yet), a fixed sensor value
# (`position=`) and the position value it gives in TPDO2 with the default scaling.
DEVICES = {
    "sgh10": ("SGH10.eds", 466000, 4660),  # um of wire, 0.1 mm steps
    "sgh50": ("SGH50.eds", 466000, 4660),
    "wv5800m": ("WV5800M.eds", 8192, 8192),  # half a revolution, 16384 steps a turn
}
KINDS = [k for k, (eds, _, _) in DEVICES.items() if (EDS / eds).exists()]


_built = []


def sim_binary():
    env = os.environ.get("SIM_BIN")
    if env:
        return env
    if not _built:
        # Up to date with the sources (a no-op when nothing changed).
        subprocess.run(["cargo", "build", "-q", "-p", "tests-host", "--bin", "sim"], cwd=ROOT, check=True)
        _built.append(True)
    return str(ROOT / "target" / "debug" / "sim")


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Sim:
    """A running simulator with its arguments; `restart()` is a power cycle of every device."""

    def __init__(self, *args):
        self.args = list(args)
        self.port = free_port()
        self.proc = None
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

    def restart(self):
        self.stop()
        self.start()

    def bus(self, channel="can0"):
        return can.Bus(interface="socketcand", channel=channel, host="127.0.0.1", port=self.port)

    def network(self, channel="can0"):
        net = canopen.Network()
        net.connect(interface="socketcand", channel=channel, host="127.0.0.1", port=self.port)
        return net


@pytest.fixture
def state_dir(tmp_path):
    return str(tmp_path / "state")


@pytest.fixture(params=KINDS)
def kind(request):
    return request.param


@pytest.fixture
def eds(kind):
    return str(EDS / DEVICES[kind][0])


@pytest.fixture
def sim(state_dir, kind):
    s = Sim("--device", f"{kind}:node={NODE},serial=0x1234,position={DEVICES[kind][1]}", "--state-dir", state_dir)
    yield s
    s.stop()


@pytest.fixture
def one_sim(state_dir):
    """One SGH10, for the tests of the server itself."""
    s = Sim("--device", f"sgh10:node={NODE}", "--state-dir", state_dir)
    yield s
    s.stop()


@pytest.fixture
def net(sim):
    n = sim.network()
    yield n
    n.disconnect()


@pytest.fixture
def node(net, eds):
    return net.add_node(NODE, eds)


def sdo_server_present(net):
    """Does the node answer an SDO upload at all?"""
    answered = threading.Event()

    def on_answer(*_):
        answered.set()

    net.subscribe(0x580 + NODE, on_answer)
    net.send_message(0x600 + NODE, bytes([0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0]))
    ok = answered.wait(1.0)
    # Only this callback: the node's SDO client listens on the same identifier.
    net.unsubscribe(0x580 + NODE, on_answer)
    return ok


@pytest.fixture
def sdo(net, node):
    assert sdo_server_present(net), "no SDO answer from the node"
    return node


def expect_abort(code, fn):
    with pytest.raises(canopen.SdoAbortedError) as e:
        fn()
    assert e.value.code == code


# ---- SDO ----


def test_identity_and_device_name(sdo, eds):
    od = canopen.import_od(eds, NODE)
    for sub in (1, 2, 3):
        assert sdo.sdo[0x1018][sub].raw == od[0x1018][sub].default
    assert sdo.sdo[0x1018][4].raw == 0x1234, "the serial number the command line configured"
    # 1008h "SGH10": five bytes, a segmented upload.
    assert sdo.sdo["Manufacturer device name"].raw == od["Manufacturer device name"].default
    assert sdo.sdo[0x1009].raw == od[0x1009].default


def test_write_read_back_and_abort_codes(sdo):
    sdo.sdo["Producer heartbeat time"].raw = 250
    assert sdo.sdo["Producer heartbeat time"].raw == 250
    expect_abort(0x06010002, lambda: sdo.sdo.download(0x1018, 1, b"\x00\x00\x00\x00"))
    expect_abort(0x06020000, lambda: sdo.sdo.upload(0x2000, 0))
    # The node still answers after the aborts.
    assert sdo.sdo["Producer heartbeat time"].raw == 250


def test_store_and_power_cycle_keep_a_value(sim, eds, sdo):
    sdo.sdo["Producer heartbeat time"].raw = 321
    sdo.sdo[0x1010][1].raw = 0x65766173  # "save"
    sdo.network.disconnect()
    sim.restart()
    net = sim.network()
    try:
        node = net.add_node(NODE, eds)
        assert node.sdo["Producer heartbeat time"].raw == 321
    finally:
        net.disconnect()


def test_nmt_start_and_heartbeats(sdo):
    sdo.sdo["Producer heartbeat time"].raw = 100
    sdo.nmt.state = "OPERATIONAL"
    assert sdo.nmt.wait_for_heartbeat(timeout=2) == "OPERATIONAL"
    sdo.nmt.state = "PRE-OPERATIONAL"
    assert sdo.nmt.wait_for_heartbeat(timeout=2) == "PRE-OPERATIONAL"


# ---- NMT, PDO (no SDO needed: the configuration comes from the EDS) ----


def test_reset_gives_a_boot_up(node):
    node.nmt.send_command(0x82)
    node.nmt.wait_for_bootup(timeout=2)


def test_tpdo_on_sync_through_subscriptions(net, node, kind):
    node.tpdo.read(from_od=True)
    tpdo = node.pdo.tx[2]
    assert tpdo.enabled and tpdo.trans_type == 1 and tpdo.cob_id == 0x280 + NODE
    got = []
    tpdo.add_callback(lambda m: got.append((m[0].raw, m[1].raw)))
    node.nmt.state = "OPERATIONAL"
    time.sleep(0.3)  # the encoder fills its speed window
    got.clear()
    for _ in range(3):
        net.sync.transmit()
        tpdo.wait_for_reception(timeout=1)
    time.sleep(0.05)
    assert len(got) == 3
    # The sensor stands still at position=.
    assert all(pos == DEVICES[kind][2] and speed == 0 for pos, speed in got), got
    # No SYNC, no TPDO; stopped, no TPDO on SYNC either.
    node.nmt.state = "STOPPED"
    time.sleep(0.05)
    got.clear()
    net.sync.transmit()
    time.sleep(0.3)
    assert got == []


# ---- LSS ----


def test_lss_fastscan_configure_store_and_power_cycle(state_dir):
    sim = Sim("--device", "sgh10:node=unconfigured,serial=4242", "--state-dir", state_dir)
    try:
        net = sim.network()
        net.lss.RESPONSE_TIMEOUT = 0.1
        net.lss.send_switch_state_global(net.lss.WAITING_STATE)
        found, ident = net.lss.fast_scan()
        assert found
        od = canopen.import_od(SGH10_EDS, 1)
        assert ident == [od[0x1018][1].default, od[0x1018][2].default, od[0x1018][3].default, 4242]
        # The fastscan left the node in configuration state.
        net.lss.configure_node_id(42)
        net.lss.store_configuration()
        node = net.add_node(42, SGH10_EDS)
        net.lss.send_switch_state_global(net.lss.WAITING_STATE)
        node.nmt.wait_for_bootup(timeout=2)
        net.disconnect()

        sim.restart()
        net = sim.network()
        node = net.add_node(42, SGH10_EDS)
        node.nmt.send_command(0x81)
        node.nmt.wait_for_bootup(timeout=2)
        # Configured now: a new fastscan finds nobody.
        net.lss.RESPONSE_TIMEOUT = 0.1
        assert net.lss.fast_scan() == (False, None)
        net.disconnect()
    finally:
        sim.stop()


# ---- the socketcand server ----


def test_a_second_client_sees_the_same_traffic(one_sim):
    a, b = one_sim.bus(), one_sim.bus()
    try:
        a.send(can.Message(arbitration_id=0x000, data=[0x82, NODE], is_extended_id=False))
        seen_b = [b.recv(1) for _ in range(2)]
        assert [(m.arbitration_id, bytes(m.data)) for m in seen_b] == [(0x000, b"\x82\x0a"), (0x70A, b"\x00")]
        m = a.recv(1)
        assert (m.arbitration_id, bytes(m.data)) == (0x70A, b"\x00"), "a sees the boot-up, not its own frame"
        b.send(can.Message(arbitration_id=0x18FEF100, data=[1, 2, 3], is_extended_id=True))
        m = a.recv(1)
        assert m.is_extended_id and m.arbitration_id == 0x18FEF100 and bytes(m.data) == b"\x01\x02\x03"
    finally:
        a.shutdown()
        b.shutdown()


def test_bad_input_gets_an_error_and_stops_nothing(one_sim):
    other = one_sim.bus()
    try:
        with socket.create_connection(("127.0.0.1", one_sim.port)) as s:
            f = s.makefile("rwb", buffering=0)

            def ask(msg):
                s.sendall(msg.encode())
                return s.recv(256).decode()

            assert s.recv(64) == b"< hi >"
            assert ask("< open can9 >") == "< error unknown bus can9 >"
            assert ask("< open can0 >") == "< ok >"
            assert ask("< rawmode >") == "< ok >"
            assert ask("< send 60A 9 1 2 3 4 5 6 7 8 9 >") == "< error DLC 9 over 8 >"
            assert ask("< sned 1 0 >") == "< error unknown command sned >"
            f.close()
        other.send(can.Message(arbitration_id=0x000, data=[0x81, NODE], is_extended_id=False))
        m = other.recv(2)
        assert (m.arbitration_id, bytes(m.data)) == (0x70A, b"\x00")
    finally:
        other.shutdown()
