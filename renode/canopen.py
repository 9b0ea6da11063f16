# Monitor commands for the SIKO CAN bench: trace the frames on a CANHub, send frames into it,
# and feed the position-sensor stand-in.
#
# Load it in the Renode Monitor (or a .resc, or a Robot test) with
#     include @renode/canopen.py
# Renode runs it with its built-in IronPython (Python 2.7) in the Monitor's scope: every
# function named mc_<name> becomes the Monitor command <name> ("Using Python in Renode",
# renode-docs source/basic/using-python.md). String arguments must be quoted in the Monitor
# ("sgh10"), because an unquoted word is looked up as an emulation element.
#
#   can_trace "canSgh10"
#       logs every frame that crosses the hub, at Info level, as one line:
#           CAN canSgh10 581 [8] 43 00 10 00 96 01 0A 00 from sgh10.can1
#       (hub, identifier in hex, [data length], data bytes in hex, sender). The Robot tests
#       match these lines with Wait For Log Entry.
#   can_send "canSgh10" 0x601 "40 00 10 00 00 00 00 00"
#       sends a classical data frame with an 11-bit identifier into the hub, as a master on
#       the bus would: every device attached to the hub receives it. It starts the emulation
#       if it is paused (a paused hub drops frames).
#   can_send_ext "canWv58mr" 0x1C06EF00 "40 00 10 00 00 00 00 00"
#       the same with a 29-bit identifier (SAE J1939: here a CAM21 request from address 00h to
#       EFh, an SDO upload of 1000h); the trace shows such identifiers with 8 hex digits.
#   sensor_feed "sgh10" 1 4096 20000
#       queues 20000 sensor frames (turns 1, angle 4096, no error, no warning) in the
#       DummySPISlave `sysbus.spi1.sensor` of machine "sgh10". The firmware reads one frame
#       per sample; once the queue is empty the sensor answers 00h ("no sensor").
#   lss_fastscan "canSgh50" 0x20
#       an LSS master on the hub (CiA 305): finds every node without node-ID by LSS Fastscan,
#       gives the first node-ID 20h, the next 21h ..., and switches it back to LSS waiting, so
#       that it boots up with that node-ID and drops out of the next scan. It runs with the
#       emulation, one request every 10 ms of virtual time (a third argument changes that),
#       and returns at once; each find is logged at Info level as
#           LSS fastscan canSgh50: found serial 1A2B3C4D (vendor 00000195, product ...,
#           revision ...), node-ID 32
#       and the end as "LSS fastscan canSgh50: done, 2 found".
#   bench_speed 60 "can0"
#       measures the emulation's speed (renode/README.md, "Speed"): runs it 100 ms so that every
#       board boots, sends one frame into the hub given (if any: an AP10T detecting the bit
#       rate waits for one), then runs it 60 virtual seconds and logs at Info level
#           bench speed: 60.000 virtual s in 48.210 wall s = 1.245 virtual s per wall s
#       Run it on a paused emulation, with `emulation SetGlobalAdvanceImmediately true` for the
#       figure without Renode's pacing to real time.
#
# What it relies on, all in renode master 06854d4d / renode-infrastructure 0c7d0762:
# - `externals` (scripts/monitor.py) to find a hub by name;
# - CANHub.FrameReceived, an event (IExternal hub, ICAN sender, CANMessageFrame frame) raised
#   for every frame a hub receives (src/Emulator/Extensions/Tools/Network/CANHub.cs); Python
#   functions attach to C# events with += (using-python.md, "Python enabled classes");
# - Antmicro.Renode.Testing.CANTester, the ICAN that Renode's Robot keyword Create CAN Tester
#   attaches to a hub; its SendFrame hands a frame to the hub (src/Emulator/Main/Testing/
#   CANTester.cs). It exists in Renode builds from 2026-06-19 on;
# - Mocks.DummySPISlave.EnqueueValue (src/Emulator/Peripherals/Peripherals/Mocks/
#   DummySPISlave.cs);
# - TimeSourceBase.ExecuteInSyncedState(action, TimeStamp) on the emulation's master time
#   source (src/Emulator/Main/Time/TimeSourceBase.cs), which runs an action at a virtual time
#   while every machine is synchronised: CANTester schedules its ISO-TP frames the same way.
#
# The pure helpers (parse_hex, format_frame, crc8, sensor_frame, the Fastscan state machine)
# use no .NET type, so they can be checked with any Python (tests-host/py/
# test_renode_helpers.py).


def parse_hex(text):
    """Bytes of a hex string such as "40 00 10 00" or "40001000" (at most 8)."""
    digits = "".join(str(text).split())
    if len(digits) % 2 != 0:
        raise ValueError("odd number of hex digits in %r" % text)
    data = [int(digits[i:i + 2], 16) for i in range(0, len(digits), 2)]
    if len(data) > 8:
        raise ValueError("a classical CAN frame carries at most 8 data bytes, not %d" % len(data))
    return data


def format_frame(can_id, data, extended=False, remote=False):
    """One frame as text: identifier in hex, [data length], the data bytes in hex."""
    text = ("%08X" if extended else "%03X") % can_id
    text += " [%d]" % len(data)
    if remote:
        return text + " remote"
    for byte in data:
        text += " %02X" % int(byte)
    return text


def speed_line(virtual_s, wall_s):
    """The log line of bench_speed."""
    rate = virtual_s / wall_s if wall_s > 0 else float("inf")
    return "bench speed: %.3f virtual s in %.3f wall s = %.3f virtual s per wall s" % (virtual_s, wall_s, rate)


def check_id(can_id, extended=False):
    """The identifier as an int, refused if it does not fit 11 bits (29 bits when extended)."""
    can_id = int(can_id)
    limit = 0x1FFFFFFF if extended else 0x7FF
    if can_id < 0 or can_id > limit:
        raise ValueError("0x%X is no %d-bit identifier" % (can_id, 29 if extended else 11))
    return can_id


def crc8(data):
    """CRC-8 of the sensor frame: polynomial 1Dh, initial value FFh, final XOR FFh
    (boards/plan/src/sensor.rs, crc8)."""
    crc = 0xFF
    for byte in data:
        crc ^= byte
        for _ in range(8):
            if crc & 0x80:
                crc = ((crc << 1) ^ 0x1D) & 0xFF
            else:
                crc = (crc << 1) & 0xFF
    return crc ^ 0xFF


def sensor_frame(turns, angle, error=False, warning=False):
    """The 5 bytes the sensor answers (boards/plan/src/sensor.rs, encode): turn counter (16
    bits), then angle (14 bits) << 2 | error << 1 | warning, most significant byte first, then
    the CRC-8 over the first four bytes."""
    word = ((angle & 0x3FFF) << 2) | (2 if error else 0) | (1 if warning else 0)
    frame = [(turns >> 8) & 0xFF, turns & 0xFF, (word >> 8) & 0xFF, word & 0xFF]
    frame.append(crc8(frame))
    return frame


LSS_MASTER_ID = 0x7E5
LSS_SLAVE_ID = 0x7E4
LSS_FASTSCAN = 0x51
LSS_IDENTIFY_SLAVE = 0x4F
LSS_CONFIGURE_NODE_ID = 0x11
LSS_SWITCH_GLOBAL = 0x04
# Fastscan's BitChecked value that restarts every non-configured slave's scan (LSSPos = vendor).
FASTSCAN_RESTART = 0x80


def fastscan_request(id_number, bit_checked, sub, next_sub):
    """The 8 bytes of an LSS Fastscan request (CiA 305): 51h, IDNumber (LSB first),
    BitChecked, LSSSub, LSSNext."""
    return [LSS_FASTSCAN, id_number & 0xFF, (id_number >> 8) & 0xFF, (id_number >> 16) & 0xFF,
            (id_number >> 24) & 0xFF, bit_checked, sub, next_sub]


class Fastscan(object):
    """An LSS master that finds every non-configured slave by Fastscan (CiA 305) and gives each
    a node-ID, as a state machine without I/O: `request()` is the next frame for 7E5h (None
    once finished), `answered(replies)` takes the 7E4h payloads that came back for it.

    One scan: a restart (BitChecked 80h) that any non-configured slave confirms; then for each
    part of the LSS address (vendor, product, revision, serial) the bits from 31 down to 0,
    each asked as 0 and taken as 1 when no slave confirms; then the part confirmed with
    BitChecked 0 and LSSNext the next part (after the serial LSSNext 0 < LSSSub, so the one slave
    whose address that is enters LSS configuration). The master configures its node-ID and
    switches every slave to LSS waiting: the slave boots up with the node-ID, is configured,
    and the next scan's restart finds the others. A restart nobody confirms ends the search."""

    def __init__(self, first_node_id=0x20, last_node_id=0x7F):
        self.next_node_id = int(first_node_id)
        self.last_node_id = int(last_node_id)
        self.found = []
        self.error = None
        self.done = False
        self._scan()

    def _scan(self):
        self._step = "restart"
        self._address = [0, 0, 0, 0]
        self._sub = 0
        self._bit = 31

    def request(self):
        if self.done:
            return None
        if self._step == "restart":
            return fastscan_request(0, FASTSCAN_RESTART, 0, 0)
        if self._step == "bit":
            return fastscan_request(self._address[self._sub], self._bit, self._sub, self._sub)
        if self._step == "confirm":
            return fastscan_request(self._address[self._sub], 0, self._sub, (self._sub + 1) & 3)
        if self._step == "configure":
            return [LSS_CONFIGURE_NODE_ID, self.next_node_id, 0, 0, 0, 0, 0, 0]
        # "waiting": switch state global, LSS waiting (no answer)
        return [LSS_SWITCH_GLOBAL, 0, 0, 0, 0, 0, 0, 0]

    def answered(self, replies):
        confirmed = any(len(r) > 0 and r[0] == LSS_IDENTIFY_SLAVE for r in replies)
        if self.done:
            return
        if self._step == "restart":
            if confirmed:
                self._step = "bit"
            else:
                self.done = True
        elif self._step == "bit":
            if not confirmed:
                self._address[self._sub] |= 1 << self._bit
            if self._bit == 0:
                self._step = "confirm"
            else:
                self._bit -= 1
        elif self._step == "confirm":
            if not confirmed:
                self._fail("no slave confirmed part %d = %08X" % (self._sub, self._address[self._sub]))
            elif self._sub == 3:
                self._step = "configure"
            else:
                self._sub += 1
                self._bit = 31
                self._step = "bit"
        elif self._step == "configure":
            answers = [r for r in replies if len(r) > 1 and r[0] == LSS_CONFIGURE_NODE_ID]
            if len(answers) != 1 or answers[0][1] != 0:
                self._fail("configure node-ID %d: answers %r" % (self.next_node_id, answers))
            else:
                self.found.append(tuple(self._address) + (self.next_node_id,))
                self._step = "waiting"
        else:
            if self.next_node_id >= self.last_node_id:
                self.done = True
            else:
                self.next_node_id += 1
                self._scan()

    def _fail(self, why):
        self.error = why
        self.done = True


def format_found(found):
    """One find as the log line shows it: serial first, then vendor, product, revision and the
    node-ID given."""
    vendor, product, revision, serial, node_id = found
    return "found serial %08X (vendor %08X, product %08X, revision %08X), node-ID %d" % (
        serial, vendor, product, revision, node_id)


def _hub(name):
    hub = externals[name]
    if hub is None:
        raise ValueError("no CAN hub named %s (create it with: emulation CreateCANHub \"%s\")" % (name, name))
    return hub


def _machine(name):
    found, machine = emulationManager.CurrentEmulation.TryGetMachineByName(name)
    if not found:
        raise ValueError("no machine named %s" % name)
    return machine


def _sender_name(sender):
    try:
        return sender.GetName()
    except Exception:
        # A CANTester belongs to no machine; CANHub itself calls it "CANTester".
        return sender.GetType().Name


_traced_hubs = {}


def mc_can_trace(hub_name):
    from Antmicro.Renode.Logging import Logger, LogLevel
    hub = _hub(hub_name)
    if hub in _traced_hubs:
        return

    def on_frame(external, sender, frame):
        try:
            line = "CAN %s %s from %s" % (
                hub_name,
                format_frame(int(frame.Id), list(frame.Data), frame.ExtendedFormat, frame.RemoteFrame),
                _sender_name(sender))
            Logger.Log(LogLevel.Info, line)
        except Exception as e:
            # Never let the trace break the hub's delivery of the frame.
            Logger.Log(LogLevel.Warning, "can_trace %s: %s" % (hub_name, e))

    hub.FrameReceived += on_frame
    _traced_hubs[hub] = on_frame


def _send(hub_name, can_id, data, extended):
    import System
    from Antmicro.Renode.Core.CAN import CANMessageFrame
    from Antmicro.Renode.Testing import CANTester
    from Antmicro.Renode.Time import TimeInterval
    hub = _hub(hub_name)
    can_id = check_id(can_id, extended)
    payload = System.Array[System.Byte](parse_hex(data))
    # CANMessageFrame(id, data, extendedFormat): a 29-bit id whole when extended
    # (src/Emulator/Main/Peripherals/CAN/CANMessageFrame.cs).
    frame = CANMessageFrame(System.UInt32(can_id), payload, extended)
    # A tester per frame, attached only while it sends, so that it does not collect the bus's
    # frames afterwards. SendFrame starts the emulation first if it is paused.
    tester = CANTester(TimeInterval.FromSeconds(1.0))
    hub.AttachTo(tester)
    try:
        tester.SendFrame(frame)
    finally:
        hub.DetachFrom(tester)


def mc_can_send(hub_name, can_id, data=""):
    _send(hub_name, can_id, data, False)


def mc_can_send_ext(hub_name, can_id, data=""):
    _send(hub_name, can_id, data, True)


def mc_sensor_feed(machine_name, turns, angle, count=1):
    machine = _machine(machine_name)
    sensor = machine["sysbus.spi1.sensor"]
    frame = sensor_frame(int(turns), int(angle))
    emulation = emulationManager.CurrentEmulation
    running = emulation.IsStarted
    # The queue is not meant to be filled while the machine reads it: pause around the feed.
    if running:
        emulation.PauseAll()
    try:
        for _ in range(int(count)):
            for byte in frame:
                sensor.EnqueueValue(byte)
    finally:
        if running:
            emulation.StartAll()


def mc_lss_fastscan(hub_name, first_node_id=0x20, window_ms=10):
    import System
    from Antmicro.Renode.Core.CAN import CANMessageFrame
    from Antmicro.Renode.Logging import Logger, LogLevel
    from Antmicro.Renode.Testing import CANTester
    from Antmicro.Renode.Time import TimeInterval, TimeStamp
    hub = _hub(hub_name)
    master = emulationManager.CurrentEmulation.MasterTimeSource
    window = TimeInterval.FromMicroseconds(System.UInt64(int(window_ms) * 1000))
    scan = Fastscan(int(first_node_id))
    tester = CANTester(TimeInterval.FromSeconds(1.0))
    replies = []

    def on_frame(external, sender, frame):
        if int(frame.Id) == LSS_SLAVE_ID and not frame.ExtendedFormat and not frame.RemoteFrame:
            replies.append([int(b) for b in frame.Data])

    def log(text):
        Logger.Log(LogLevel.Info, "LSS fastscan %s: %s" % (hub_name, text))

    def later(action):
        # At the first synchronisation point one window from now (virtual time).
        master.ExecuteInSyncedState(System.Action[TimeStamp](action),
                                    TimeStamp(master.ElapsedVirtualTime + window, master.Domain))

    def step(timestamp, first=False):
        try:
            if not first:
                found_before = len(scan.found)
                scan.answered(list(replies))
                if len(scan.found) > found_before:
                    log(format_found(scan.found[-1]))
            del replies[:]
            request = scan.request()
            if request is None:
                hub.FrameReceived -= on_frame
                hub.DetachFrom(tester)
                if scan.error is not None:
                    log("failed: %s" % scan.error)
                log("done, %d found" % len(scan.found))
                return
            frame = CANMessageFrame(System.UInt32(LSS_MASTER_ID), System.Array[System.Byte](request))
            tester.SendFrame(frame)
            later(step)
        except Exception as e:
            log("failed: %s" % e)

    hub.AttachTo(tester)
    hub.FrameReceived += on_frame
    # The first request goes out once the emulation runs (a paused hub drops frames).
    later(lambda timestamp: step(timestamp, True))


def mc_bench_speed(seconds, wake_hub=None):
    from System.Diagnostics import Stopwatch
    from Antmicro.Renode.Logging import Logger, LogLevel
    from Antmicro.Renode.Time import TimeInterval
    emulation = emulationManager.CurrentEmulation
    if emulation.IsStarted:
        emulation.PauseAll()
    # Emulation.RunFor starts, runs the master time source for the period, pauses.
    emulation.RunFor(TimeInterval.FromSeconds(0.1))
    if wake_hub is not None:
        # can_send starts the emulation (a paused hub drops frames); pause it again to measure.
        _send(wake_hub, 0x000, "80 00", False)
        emulation.PauseAll()
    seconds = float(seconds)
    watch = Stopwatch.StartNew()
    emulation.RunFor(TimeInterval.FromSeconds(seconds))
    watch.Stop()
    Logger.Log(LogLevel.Info, speed_line(seconds, watch.Elapsed.TotalSeconds))
