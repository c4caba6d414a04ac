"""What the simulator and bus tests share: the checkout, the programs, CSV
reading at full precision, and lagranged on a private LCM port (this host only)."""
import contextlib
import csv
import os
import subprocess
import time

import numpy as np

SOURCE = os.environ.get("LAGRANGE_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
BUILD = os.environ.get("LAGRANGE_BUILD_DIR", os.path.join(SOURCE, "build"))
LAGRANGED = os.environ.get("LAGRANGED", os.path.join(BUILD, "daemon", "lagranged"))
LAGRANGECTL = os.environ.get("LAGRANGECTL", os.path.join(BUILD, "tools", "lagrangectl"))


def config(name):
    return os.path.join(SOURCE, "config", name)


def read_csv(path):
    """{column: list of str}; numbers are parsed by the caller with float(),
    which reads lagrange's shortest round-trip text back to the same double."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    return {name: [row[k] for row in body] for k, name in enumerate(header)}


def numbers(columns, name):
    return np.array([float(x) for x in columns[name]])


def joint_block(columns, field, n):
    return np.stack([numbers(columns, "%s%d" % (field, i)) for i in range(n)], axis=1)


def lcm_url(port):
    return "udpm://239.255.76.67:%d?ttl=0" % port


def prepare_loopback_multicast():
    """As tests/support/lcm_testing.cpp: as root, add the loopback multicast route when it is missing."""
    routes = subprocess.run(["ip", "route", "show", "table", "all"], capture_output=True, text=True).stdout
    if "239.255.0.0/16 dev lo" in routes or os.geteuid() != 0:
        return
    subprocess.run(["ip", "link", "set", "lo", "multicast", "on"], check=False)
    subprocess.run(["ip", "route", "add", "239.255.0.0/16", "dev", "lo"], check=False)


@contextlib.contextmanager
def lagranged(scene, port, *extra, log=None):
    """lagranged on `scene` at udpm://239.255.76.67:PORT?ttl=0, stopped (SIGTERM) on exit."""
    prepare_loopback_multicast()
    out = open(log, "w") if log else subprocess.DEVNULL
    p = subprocess.Popen([LAGRANGED, "--config", scene, "--lcm-url", lcm_url(port), *extra],
                         stdout=out, stderr=subprocess.STDOUT)
    try:
        yield p
    finally:
        p.terminate()
        try:
            p.wait(timeout=10)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()
        if log:
            out.close()


def wait_until(predicate, timeout):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(0.01)
    return predicate()


@contextlib.contextmanager
def lcm_logger(port, path):
    """lcm-logger recording udpm://239.255.76.67:PORT?ttl=0 to `path` until exit (SIGINT: it closes the file)."""
    import signal
    p = subprocess.Popen(["lcm-logger", "--lcm-url=" + lcm_url(port), "-f", path],
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        yield p
    finally:
        p.send_signal(signal.SIGINT)
        try:
            p.wait(timeout=10)
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()


def record_run(scene, port, path, seconds, act=None, *extra, until=None):
    """lagranged on `scene`, recorded by lcm-logger to `path`; `act(client)` runs while it records. Then it
    records for `seconds`, and further until `until({channel: rows})` holds (the rows lcm-logger has caught
    so far per channel: a loaded machine's logger drops datagrams), 60 s at most."""
    import lagrange
    with lagranged(scene, port, *extra):
        client = lagrange.Client(url=lcm_url(port), wait=5.0)
        client.state(_first_instance(scene), timeout=5.0)
        with lcm_logger(port, path):
            # Recording once the file grows (the logger flushes every 0.1 s), so what `act` sends is in it.
            assert wait_until(lambda: os.path.exists(path) and os.path.getsize(path) > 0, 20.0), "lcm-logger wrote nothing"
            if act is not None:
                act(client)
            time.sleep(seconds)
            if until is not None:
                # partial: the logger is still writing, so the file may end inside an event.
                caught = lambda: {c: r.rows for c, r in lagrange.read_log(path, partial=True).items()}  # noqa: E731
                wait_until(lambda: until(caught()), 60.0)
    return path


def _first_instance(scene):
    return _instance_names(scene)[0]


def _instance_names(scene):
    import re
    with open(scene) as f:
        return re.findall(r"^\s*- name:\s*(\w+)", f.read(), flags=re.M)
