"""The simulator under abuse, as figures (issue 15, docs/reliability.md): one simulator (an SGH10,
node 10, on can0 at 500 kbit/s) with, at the same time,

- CLIENTS socketcand clients that open can0 in rawmode and never read,
- clients that drop mid-message (a `< send` cut off, then the connection closed), over and over,
- clients that send garbage (random bytes) and oversized input (a 1 MiB message without `>`),
- one client sending 8,000 frames a second (zero-length frames on 123h, which the bus at 500
  kbit/s can carry at that rate), paced in 10 ms batches,
- a reader that counts the frames the bus carries,

and python-canopen reading 1018h.01 from node 10 by SDO, idle before and under the load. It
prints the simulator's CPU share and memory (from /proc), the flood's rate as sent and as carried,
and the SDO round trip (median, 99th percentile, worst). It fails (exit 1) only if the simulator
died or stopped answering; the figures are measurements, not checks.

    target/py-venv/bin/python tests-host/py/abuse.py [--seconds 10] [--clients 200]

The simulator is $SIM_BIN, else the release binary (built here by cargo).
"""

import argparse
import logging
import os
import pathlib
import random
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time

ROOT = pathlib.Path(__file__).resolve().parents[2]
if "SIM_BIN" not in os.environ:
    subprocess.run(["cargo", "build", "-q", "--release", "-p", "tests-host", "--bin", "sim"], cwd=ROOT, check=True)
    os.environ["SIM_BIN"] = str(ROOT / "target" / "release" / "sim")
sys.path.insert(0, str(pathlib.Path(__file__).parent))

from test_sim import NODE, SGH10_EDS, Sim, raw_client, send_text  # noqa: E402

CLK_TCK = os.sysconf("SC_CLK_TCK")
# python-can warns on every TCP read that ends mid-message: noise here.
logging.getLogger("can").setLevel(logging.ERROR)


def proc_cpu_s(pid):
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLK_TCK  # utime + stime


def proc_mem_kib(pid, key):
    with open(f"/proc/{pid}/status") as f:
        return next(int(line.split()[1]) for line in f if line.startswith(key + ":"))


def sdo_round_trips(sim, n):
    net = sim.network()
    try:
        node = net.add_node(NODE, SGH10_EDS)
        times = []
        for _ in range(n):
            t = time.perf_counter()
            assert node.sdo[0x1018][1].raw == 0x195
            times.append(time.perf_counter() - t)
            time.sleep(0.005)
        return times
    finally:
        net.disconnect()


def ms(times):
    s = sorted(times)
    p99 = s[min(len(s) - 1, int(len(s) * 0.99))]
    return f"median {statistics.median(s) * 1000:.2f} ms, p99 {p99 * 1000:.2f} ms, worst {s[-1] * 1000:.2f} ms"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=10)
    ap.add_argument("--clients", type=int, default=200)
    ap.add_argument("--rate", type=int, default=8000)
    args = ap.parse_args()

    with tempfile.TemporaryDirectory() as state:
        sim = Sim("--device", f"sgh10:node={NODE}", "--state-dir", state)
        pid = sim.proc.pid
        try:
            run(sim, pid, args)
        finally:
            alive = sim.proc.poll() is None
            sim.stop()
        if not alive:
            print("the simulator died", file=sys.stderr)
            sys.exit(1)


def run(sim, pid, args):
    idle = sdo_round_trips(sim, 200)
    rss_idle = proc_mem_kib(pid, "VmRSS")
    stop = threading.Event()
    counts = {"sent": 0, "carried": 0, "dropped_mid": 0, "garbage_bytes": 0, "oversized": 0}
    lock = threading.Lock()

    def add(key, n):
        with lock:
            counts[key] += n

    # Clients that open the bus and never read.
    silent = [raw_client(sim) for _ in range(args.clients)]

    def reader():
        s = raw_client(sim)
        s.settimeout(0.2)
        tail = b""
        while not stop.is_set():
            try:
                data = s.recv(1 << 16)
            except OSError:
                continue
            if not data:
                break
            data = tail + data
            add("carried", data.count(b"< frame 123 "))
            tail = data[-16:]
        s.close()

    def flooder():
        s = raw_client(sim)
        s.settimeout(1)
        batch = args.rate // 100
        msg = send_text(0x123, []).encode() * batch
        next_t = time.perf_counter()
        while not stop.is_set():
            try:
                s.sendall(msg)
                add("sent", batch)
            except OSError:
                pass
            next_t += 0.01
            time.sleep(max(0.0, next_t - time.perf_counter()))
        s.close()

    def dropper():
        while not stop.is_set():
            try:
                s = raw_client(sim)
                s.sendall(b"< send 60A 8 40 18 10 01 0")  # cut off mid-message
                s.close()
                add("dropped_mid", 1)
            except OSError:
                pass
            time.sleep(0.01)

    def garbage(seed):
        rng = random.Random(seed)
        while not stop.is_set():
            try:
                s = socket.create_connection(("127.0.0.1", sim.port), timeout=1)
                if rng.random() < 0.2:
                    s.sendall(b"< open can0 >< rawmode >< send 123 8 " + b"1" * (1 << 20))
                    add("oversized", 1)
                else:
                    junk = bytes(rng.getrandbits(8) for _ in range(4096))
                    s.sendall(junk)
                    add("garbage_bytes", len(junk))
                s.close()
            except OSError:
                pass
            time.sleep(0.02)

    peak = [0]

    def sampler():
        while not stop.is_set():
            peak[0] = max(peak[0], proc_mem_kib(pid, "VmRSS"))
            time.sleep(0.1)

    threads = [threading.Thread(target=reader), threading.Thread(target=flooder), threading.Thread(target=sampler)]
    threads += [threading.Thread(target=dropper) for _ in range(4)]
    threads += [threading.Thread(target=garbage, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    time.sleep(1)  # the load settles
    cpu0, t0 = proc_cpu_s(pid), time.perf_counter()
    sent0, carried0 = counts["sent"], counts["carried"]
    loaded = sdo_round_trips(sim, 200)
    remaining = args.seconds - (time.perf_counter() - t0)
    if remaining > 0:
        time.sleep(remaining)
    cpu1, t1 = proc_cpu_s(pid), time.perf_counter()
    sent, carried = counts["sent"] - sent0, counts["carried"] - carried0
    rss_load = proc_mem_kib(pid, "VmRSS")
    stop.set()
    for t in threads:
        t.join()
    for s in silent:
        s.close()
    after = sdo_round_trips(sim, 20)
    hwm = proc_mem_kib(pid, "VmHWM")
    span = t1 - t0

    print(f"simulator under abuse for {span:.1f} s ({os.cpu_count()} CPUs):")
    print(f"  clients: {args.clients} silent (never read), 4 dropping mid-message ({counts['dropped_mid']} connections),")
    print(f"           4 sending garbage ({counts['garbage_bytes']} random bytes) and oversized input "
          f"({counts['oversized']} messages of 1 MiB without '>'), 1 flooding, 1 reading")
    print(f"  flood: {sent / span:.0f} frames/s sent, {carried / span:.0f} frames/s carried by the bus")
    print(f"  simulator CPU: {100 * (cpu1 - cpu0) / span:.0f} % of one core")
    print(f"  simulator memory (RSS): {rss_idle} KiB idle, {rss_load} KiB at the end of the load, "
          f"{peak[0]} KiB at most (sampled every 0.1 s; VmHWM {hwm} KiB)")
    print(f"  machine load average: {os.getloadavg()[0]:.1f}")
    print(f"  SDO 1018h.01 round trip idle:       {ms(idle)} (200 reads)")
    print(f"  SDO 1018h.01 round trip under load: {ms(loaded)} (200 reads)")
    print(f"  SDO after the load: {len(after)} of 20 reads answered, {ms(after)}")


if __name__ == "__main__":
    main()
