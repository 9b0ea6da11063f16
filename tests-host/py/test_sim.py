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
    """A running simulator with its arguments; `restart()` is a power cycle of every device.
    With `control=True` it also serves its control port on `control_port`."""

    def __init__(self, *args, control=False):
        self.args = list(args)
        self.port = free_port()
        self.control_port = free_port() if control else None
        self.proc = None
        self.start()

    def start(self):
        cmd = [sim_binary(), "--quiet", "--listen", f"127.0.0.1:{self.port}"]
        if self.control_port is not None:
            cmd += ["--control", f"127.0.0.1:{self.control_port}"]
        cmd += self.args
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


def boot_up_of(net, node_id):
    """An event set when node `node_id` sends its boot-up. Subscribe before causing it:
    python-canopen's `wait_for_bootup` only sees a boot-up that arrives after the call, and the
    simulator answers within a millisecond, often before the call."""
    booted = threading.Event()

    def on_message(_id, data, _t):
        if bytes(data) == b"\x00":
            booted.set()

    net.subscribe(0x700 + node_id, on_message)
    return booted


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


def test_reset_gives_a_boot_up(net, node):
    booted = boot_up_of(net, NODE)
    node.nmt.send_command(0x82)
    assert booted.wait(2)


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
        booted = boot_up_of(net, 42)
        net.lss.send_switch_state_global(net.lss.WAITING_STATE)
        assert booted.wait(2)
        net.disconnect()

        sim.restart()
        net = sim.network()
        node = net.add_node(42, SGH10_EDS)
        booted = boot_up_of(net, 42)
        node.nmt.send_command(0x81)
        assert booted.wait(2)
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


def test_bad_input_is_dropped_or_refused_as_socketcand_does(one_sim):
    """Issue 13 point 4: a malformed frame is dropped without an answer, an unknown command gets
    socketcand's fixed `< error unknown command >`, an unknown bus `< error could not open bus >`
    and the end of the connection; nothing the client sent comes back."""
    other = one_sim.bus()
    try:
        with socket.create_connection(("127.0.0.1", one_sim.port)) as s:
            s.settimeout(2)

            def ask(msg):
                s.sendall(msg.encode())
                return s.recv(256).decode()

            assert s.recv(64) == b"< hi >"
            assert ask("< rawmode >") == "< error unknown command >"
            assert ask("< open can0 >") == "< ok >"
            assert ask("< rawmode >") == "< ok >"
            assert ask("< send 60A 9 1 2 3 4 5 6 7 8 9 >< sned 1 0 >") == "< error unknown command >"
        with socket.create_connection(("127.0.0.1", one_sim.port)) as s:
            s.settimeout(2)
            assert s.recv(64) == b"< hi >"
            s.sendall(b"< open can9 >")
            assert s.recv(256) == b"< error could not open bus >"
            assert s.recv(256) == b"", "socketcand ends the connection"
        other.send(can.Message(arbitration_id=0x000, data=[0x81, NODE], is_extended_id=False))
        m = other.recv(2)
        assert (m.arbitration_id, bytes(m.data)) == (0x70A, b"\x00")
    finally:
        other.shutdown()


def raw_client(sim, channel="can0"):
    """A socketcand client on a plain socket, in rawmode."""
    s = socket.create_connection(("127.0.0.1", sim.port))
    s.settimeout(2)
    assert s.recv(64) == b"< hi >"
    s.sendall(f"< open {channel} >".encode())
    assert s.recv(64) == b"< ok >"
    s.sendall(b"< rawmode >")
    assert s.recv(64) == b"< ok >"
    return s


def send_text(frame_id, data):
    return f"< send {frame_id:03X} {len(data):X} {' '.join(f'{b:x}' for b in data)} >"


READ_1018_1 = send_text(0x600 + NODE, [0x40, 0x18, 0x10, 0x01, 0, 0, 0, 0])


def rss_kib(pid):
    try:
        with open(f"/proc/{pid}/status") as f:
            return next(int(line.split()[1]) for line in f if line.startswith("VmRSS:"))
    except OSError:
        return None


def test_a_python_can_client_survives_malformed_input(one_sim):
    """Issue 13 point 4: python-can takes any `< error ... >` for an error frame and cannot parse
    the text; the simulator answers a malformed frame with nothing, so the client reads on."""
    bus = one_sim.bus()
    try:
        sock = bus._SocketCanDaemonBus__socket
        sock.sendall(b"< send 60A 9 1 2 3 4 5 6 7 8 9 >< send 60A 2 1 >< send 800 0 >")
        bus.send(can.Message(arbitration_id=0x000, data=[0x81, NODE], is_extended_id=False))
        m = bus.recv(2)
        assert m is not None and (m.arbitration_id, bytes(m.data)) == (0x70A, b"\x00")
    finally:
        bus.shutdown()


def test_a_burst_of_a_thousand_reads_gets_a_thousand_answers(one_sim):
    """Issue 13 point 1: 1000 SDO reads written at once, 1000 answers."""
    observer = one_sim.bus()
    s = raw_client(one_sim)
    try:
        s.sendall((READ_1018_1 * 1000).encode())
        answers, deadline = 0, time.time() + 20
        while answers < 1000 and time.time() < deadline:
            m = observer.recv(0.5)
            if m is not None and m.arbitration_id == 0x580 + NODE:
                answers += 1
        assert answers == 1000
    finally:
        s.close()
        observer.shutdown()


def test_a_save_behind_forty_reads_is_kept(state_dir):
    """Issue 13 point 1: 40 reads and a 1010h "save" in one write: the save is answered, the
    flash written, the value there after a power cycle."""
    sim = Sim("--device", f"sgh10:node={NODE}", "--state-dir", state_dir)
    try:
        net = sim.network()
        node = net.add_node(NODE, SGH10_EDS)
        node.sdo["Producer heartbeat time"].raw = 777
        answers = []
        net.subscribe(0x580 + NODE, lambda _id, data, _t: answers.append(bytes(data)))
        s = raw_client(sim)
        save = send_text(0x600 + NODE, [0x23, 0x10, 0x10, 0x01, *b"save"])
        s.sendall((READ_1018_1 * 40 + save).encode())
        deadline = time.time() + 10
        while len(answers) < 41 and time.time() < deadline:
            time.sleep(0.05)
        s.close()
        assert len(answers) == 41
        assert answers[-1] == bytes([0x60, 0x10, 0x10, 0x01, 0, 0, 0, 0]), "the save is answered"
        net.disconnect()
        sim.restart()
        net = sim.network()
        node = net.add_node(NODE, SGH10_EDS)
        assert node.sdo["Producer heartbeat time"].raw == 777
        net.disconnect()
    finally:
        sim.stop()


def test_a_flooding_client_delays_no_one_else(one_sim):
    """Issue 13 point 2: a client that writes frames as fast as it can waits for the bus; another
    client's SDO reads are answered promptly and the simulator's memory stays bounded."""
    before = rss_kib(one_sim.proc.pid)
    s = raw_client(one_sim)
    s.settimeout(0.1)
    flood = (send_text(0x123, [0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77, 0x88]) * 100).encode()
    stop = threading.Event()

    def run():
        while not stop.is_set():
            try:
                s.sendall(flood)
            except OSError:
                pass

    flooder = threading.Thread(target=run)
    flooder.start()
    net = one_sim.network()
    try:
        time.sleep(0.5)
        node = net.add_node(NODE, SGH10_EDS)
        worst = 0.0
        for _ in range(10):
            t = time.time()
            assert node.sdo[0x1018][1].raw == 0x195
            worst = max(worst, time.time() - t)
            time.sleep(0.1)
        assert worst < 0.5, f"an SDO read waited {worst:.3f} s"
        after = rss_kib(one_sim.proc.pid)
        if before is not None and after is not None:
            assert after < before + 40 * 1024, f"{before} KiB -> {after} KiB"
    finally:
        stop.set()
        flooder.join()
        s.close()
        net.disconnect()


def test_clients_that_send_garbage_and_never_read_cost_bounded_memory(one_sim):
    """Issue 13 point 3: 20 clients sending garbage (text outside < >, unknown commands, bad
    frames) and never reading: the simulator's memory stays bounded and it still serves."""
    before = rss_kib(one_sim.proc.pid)
    if before is None:
        pytest.skip("no /proc")
    garbage = (("x" * 1000) + "< bogus >< send 601 1 zz >< echo >").encode() * 200
    socks = []

    def run():
        s = socket.create_connection(("127.0.0.1", one_sim.port))
        s.settimeout(0.3)
        socks.append(s)
        deadline = time.time() + 3
        while time.time() < deadline:
            try:
                s.sendall(garbage)
            except OSError:
                pass

    threads = [threading.Thread(target=run) for _ in range(20)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    try:
        after = rss_kib(one_sim.proc.pid)
        assert after < before + 40 * 1024, f"{before} KiB -> {after} KiB"
        net = one_sim.network()
        try:
            assert net.add_node(NODE, SGH10_EDS).sdo[0x1018][1].raw == 0x195
        finally:
            net.disconnect()
    finally:
        for s in socks:
            s.close()


def test_node_guarding_through_python_canopen(one_sim):
    """Issue 13 point 5: python-canopen's node guarding (a remote frame, which python-can writes
    as `< send 70A 0 >`) is answered, the toggle bit alternating."""
    net = one_sim.network()
    observer = one_sim.bus()
    try:
        node = net.add_node(NODE, SGH10_EDS)
        assert node.sdo["Producer heartbeat time"].raw == 0, "guarding needs the heartbeat off"
        node.nmt.start_node_guarding(0.1)
        assert node.nmt.wait_for_heartbeat(timeout=2) == "PRE-OPERATIONAL"
        answers, deadline = [], time.time() + 3
        while len(answers) < 4 and time.time() < deadline:
            m = observer.recv(0.5)
            if m is not None and m.arbitration_id == 0x700 + NODE and len(m.data) == 1:
                answers.append(m.data[0])
        node.nmt.stop_node_guarding()
        assert len(answers) == 4
        assert [a & 0x7F for a in answers] == [0x7F] * 4
        assert all((a ^ b) & 0x80 for a, b in zip(answers, answers[1:])), f"toggle: {answers}"
    finally:
        observer.shutdown()
        net.disconnect()


def test_python_can_remote_frames_and_sendrtr(one_sim):
    """Issue 13 point 5: a remote frame as python-can writes it (`< send ID DLC >` without bytes)
    and as socketcand's `< sendrtr ID DLC >`; clients receive `< rtr ID SEC.USEC DLC >`."""
    bus = one_sim.bus()
    s = raw_client(one_sim)
    try:
        bus.send(can.Message(arbitration_id=0x700 + NODE, is_remote_frame=True, dlc=1, is_extended_id=False))
        got = s.recv(256).decode()
        got = got[: got.index(">") + 1]  # the node's answer may follow in the same read
        assert got.startswith(f"< rtr {0x700 + NODE:03X} ") and got.endswith(" 1 >"), got
        m = bus.recv(1)
        assert m.arbitration_id == 0x700 + NODE and bytes(m.data) == b"\x7f"
        s.sendall(f"< sendrtr {0x700 + NODE:03X} 1 >".encode())
        m = bus.recv(1)
        assert m.arbitration_id == 0x700 + NODE and bytes(m.data) == b"\xff"
    finally:
        s.close()
        bus.shutdown()


def test_lss_fastscan_finds_both_sgh50_channels(state_dir):
    """Issue 13 point 6: the two channels of a redundant SGH50 have their own serial numbers, so
    LSS fastscan finds them one after the other and configures each on its own."""
    sim = Sim("--device", "sgh50:redundant=true,node=unconfigured", "--state-dir", state_dir)
    try:
        net = sim.network()
        found = []
        for node_id in (40, 41):
            net.lss.send_switch_state_global(net.lss.WAITING_STATE)
            # Short: a fastscan waits this long for every bit nobody answers.
            net.lss.RESPONSE_TIMEOUT = 0.1
            ok, ident = net.lss.fast_scan()
            assert ok, f"fastscan {len(found) + 1}"
            found.append(ident)
            net.lss.RESPONSE_TIMEOUT = 1.0
            net.lss.configure_node_id(node_id)
            net.lss.store_configuration()
            net.lss.send_switch_state_global(net.lss.WAITING_STATE)
            net.nmt.send_command(0x82)  # reset communication: the new node-ID applies
            time.sleep(0.2)
        assert found[0][3] != found[1][3], found
        net.lss.send_switch_state_global(net.lss.WAITING_STATE)
        net.lss.RESPONSE_TIMEOUT = 0.1
        assert net.lss.fast_scan() == (False, None), "nobody left unconfigured"
        for node_id, ident in zip((40, 41), found):
            node = net.add_node(node_id, str(EDS / "SGH50.eds"))
            assert node.sdo[0x1018][4].raw == ident[3]
        net.disconnect()
    finally:
        sim.stop()
