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
#   sensor_feed "sgh10" 1 4096 20000
#       queues 20000 sensor frames (turns 1, angle 4096, no error, no warning) in the
#       DummySPISlave `sysbus.spi1.sensor` of machine "sgh10". The firmware reads one frame
#       per sample; once the queue is empty the sensor answers 00h ("no sensor").
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
#   DummySPISlave.cs).
#
# The pure helpers (parse_hex, format_frame, crc8, sensor_frame) use no .NET type, so they can
# be checked with any Python.


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


def mc_can_send(hub_name, can_id, data=""):
    import System
    from Antmicro.Renode.Core.CAN import CANMessageFrame
    from Antmicro.Renode.Testing import CANTester
    from Antmicro.Renode.Time import TimeInterval
    hub = _hub(hub_name)
    can_id = int(can_id)
    if can_id < 0 or can_id > 0x7FF:
        raise ValueError("can_send sends 11-bit identifiers only, not 0x%X" % can_id)
    payload = System.Array[System.Byte](parse_hex(data))
    frame = CANMessageFrame(System.UInt32(can_id), payload)
    # A tester per frame, attached only while it sends, so that it does not collect the bus's
    # frames afterwards. SendFrame starts the emulation first if it is paused.
    tester = CANTester(TimeInterval.FromSeconds(1.0))
    hub.AttachTo(tester)
    try:
        tester.SendFrame(frame)
    finally:
        hub.DetachFrom(tester)


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
