"""lagrange.read_log against lagrangectl log2csv: one decoding
(protocol/log_records.hpp), so the same columns and the same values; and the
same one-line errors. The log is a live run on a private port (8328)."""
import math
import os
import re
import shutil
import struct
import subprocess
import sys

import numpy as np
import pytest

import lagrange
from bus_support import LAGRANGECTL, config, read_csv, record_run

PORT = 8328


@pytest.fixture(scope="module")
def log(tmp_path_factory):
    path = str(tmp_path_factory.mktemp("log") / "run.lcm")

    def act(client):
        # Setpoints, a command and its reply, beside the states, statuses and telemetry.
        for _ in range(20):
            client.send_setpoint("arm", q=[0.6, -0.2])
        assert client.command("arm", "pause").accepted
        assert client.command("arm", "resume").accepted

    return record_run(config("default.yaml"), PORT, path, 0.5, act,
                      until=lambda rows: rows.get("ARM_STATE", 0) >= 50 and rows.get("CARTPOLE_STATE", 0) >= 50)


def columns_of(record):
    """log2csv's column names from read_log's fields, in order."""
    names = []
    for name, values in record.columns.items():
        if isinstance(values, np.ndarray) and values.ndim == 2:
            names += ["%s%d" % (name, i) for i in range(values.shape[1])]
        else:
            names.append(name)
    return names


def same(value, text):
    if isinstance(value, (float, np.floating)):
        return (math.isnan(value) and text == "nan") or value == float(text)
    return str(value) == text


def test_read_log_decodes_every_channel_as_log2csv_writes_it(log, tmp_path):
    out = tmp_path / "csv"
    r = subprocess.run([LAGRANGECTL, "log2csv", log, "-o", str(out)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    records = lagrange.read_log(log)
    written = {os.path.splitext(f)[0]: str(out / f) for f in os.listdir(out)}
    lagrange_channels = {c for c, rec in records.items() if rec.type is not None}
    assert lagrange_channels == set(written)
    # Which channels the logger caught is the bus's business (a loaded machine drops datagrams); the states came.
    assert "ARM_STATE" in records and "CARTPOLE_STATE" in records
    assert len(lagrange_channels) >= 4  # and more than states: status, telemetry, setpoints, commands, replies
    for channel, path in written.items():
        rec = records[channel]
        csv = read_csv(path)
        assert list(csv) == columns_of(rec), channel
        assert rec.rows == len(csv["log_utime"]) and len(rec) == rec.rows
        for name, values in rec.columns.items():
            if isinstance(values, list):  # text: the CSV's field, unquoted
                assert values == csv[name], (channel, name)
                continue
            kind_id = name in ("run_id", "request_id", "last_foreign_run_id")
            flat = values.reshape(rec.rows, -1)
            for j in range(flat.shape[1]):
                column = csv[name] if values.ndim == 1 else csv["%s%d" % (name, j)]
                for v, text in zip(flat[:, j], column):
                    if kind_id:
                        assert format(int(v) & (2**64 - 1), "016x") == text, (channel, name)
                    else:
                        assert same(v, text), (channel, name, v, text)


def test_a_state_channel_has_numpy_columns_of_the_instances_shape(log):
    arm = lagrange.read_log(log, channel="ARM_STATE")
    assert list(arm) == ["ARM_STATE"]
    s = arm["ARM_STATE"]
    # How many states the logger caught is the bus's business on a loaded machine; some did.
    assert s.type == "state_t" and s.rows >= 2 and s.skipped == 0, (s.type, s.rows, s.skipped)
    assert s.q.shape == (s.rows, 2) and s.q.dtype == np.float64
    assert s.tick.dtype == np.int64 and np.all(np.diff(s.tick) > 0), s.tick  # one run, in order
    assert s["controller"][0] == "computed-torque"
    # Simulated time never runs back (it stands while the arm is paused).
    assert np.all(np.diff(s.t) >= 0), s.t
    assert np.all(np.isfinite(s.q))
    with pytest.raises(AttributeError, match="has no field 'nope'"):
        s.nope
    with pytest.raises(ValueError, match="not a regular expression"):
        lagrange.read_log(log, channel="([")


def test_a_log_cut_short_raises_naming_the_byte_offset_as_log2csv_refuses_it(log, tmp_path):
    # Issue 32: it gave the events before the cut silently. It raises log2csv's line, naming where the cut event
    # starts; partial=True reads the events before it (a logger still writing), as many as log2csv wrote.
    cut = str(tmp_path / "cut.lcm")
    with open(log, "rb") as f:
        data = f.read()
    with open(cut, "wb") as f:
        f.write(data[: len(data) // 2 + 7])
    with pytest.raises(ValueError) as e:
        lagrange.read_log(cut, channel="ARM_STATE")
    assert re.fullmatch(re.escape(cut) + r": cut short inside the event at byte (\d+)(: .*| \(.*\))", str(e.value))
    at = int(re.search(r"at byte (\d+)", str(e.value)).group(1))
    assert data[at:at + 4] == b"\xed\xa1\xda\x01" and at < len(data) // 2 + 7  # a sync word: the event's start
    out = tmp_path / "csv"
    r = subprocess.run([LAGRANGECTL, "log2csv", cut, "-o", str(out), "--channel", "ARM_STATE"],
                       capture_output=True, text=True)
    assert r.returncode == 1 and r.stderr.strip() == "lagrangectl log2csv: " + str(e.value)
    arm = lagrange.read_log(cut, channel="ARM_STATE", partial=True)["ARM_STATE"]
    assert arm.rows == len(read_csv(str(out / "ARM_STATE.csv"))["log_utime"])
    assert 0 < arm.rows < lagrange.read_log(log, channel="ARM_STATE")["ARM_STATE"].rows


def event(channel, payload, declared=None):
    """One lcm-logger event (big-endian): sync word, number, utime, channel length, payload length, both."""
    size = len(payload) if declared is None else declared
    return struct.pack(">IqqiI", 0xEDA1DA01, 0, 1, len(channel), size) + channel + payload


def test_a_log_declaring_a_2_gib_body_or_a_huge_channel_raises_naming_the_byte_offset(tmp_path):
    # Issue 32: each read as {} without a word. The first event is whole; the second lies.
    first = event(b"ARM_STATE", b"\0" * 16)
    cases = {
        "body.lcm": (first + event(b"ARM_STATE", b"\0" * 8, declared=0x7FFFFFFF),
                     "cut short inside the event at byte %d: it declares a 2147483647-byte payload, of which the "
                     "file holds 8" % len(first)),
        "channel.lcm": (first + struct.pack(">IqqiI", 0xEDA1DA01, 1, 2, 5000, 0) + b"X" * 64,
                        "the event at byte %d declares a 5000-byte channel name (an LCM log's are 1 to 999 bytes)"
                        % len(first)),
        "negative.lcm": (first + event(b"X", b"", declared=0xFFFFFFFF),
                         "the event at byte %d declares a payload of -1 bytes" % len(first)),
        "header.lcm": (first + event(b"ARM_STATE", b"")[:10],
                       "cut short inside the event at byte %d (in its header)" % len(first)),
    }
    for name, (data, why) in cases.items():
        path = tmp_path / name
        path.write_bytes(data)
        with pytest.raises(ValueError) as e:
            lagrange.read_log(str(path))
        assert str(e.value) == "%s: %s" % (path, why)
        r = subprocess.run([LAGRANGECTL, "log2csv", str(path), "-o", str(tmp_path / "csv")],
                           capture_output=True, text=True)
        assert r.returncode == 1 and r.stderr.strip() == "lagrangectl log2csv: " + str(e.value)
    # partial reads a log cut short to its last whole event; a corrupt one raises all the same.
    assert lagrange.read_log(str(tmp_path / "body.lcm"), partial=True)["ARM_STATE"].skipped == 1
    with pytest.raises(ValueError, match="5000-byte channel name"):
        lagrange.read_log(str(tmp_path / "channel.lcm"), partial=True)


def test_read_log_refuses_a_fifo_at_once_instead_of_waiting_for_a_writer(tmp_path):
    # Issue 32: opening a FIFO for reading blocked forever. In a child process, so a hang fails the test.
    fifo = str(tmp_path / "run.lcm")
    os.mkfifo(fifo)
    code = ("import lagrange, sys\n"
            "try:\n    lagrange.read_log(sys.argv[1])\nexcept ValueError as e:\n    print(e)\n")
    r = subprocess.run([sys.executable, "-c", code, fifo], capture_output=True, text=True, timeout=30)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "cannot read %s: not a regular file (a FIFO)" % fifo
    log2csv = subprocess.run([LAGRANGECTL, "log2csv", fifo, "-o", str(tmp_path / "csv")], capture_output=True,
                             text=True, timeout=30)
    assert log2csv.stderr.strip() == "lagrangectl log2csv: " + r.stdout.strip()


def test_what_is_not_a_log_raises_log2csvs_one_line(tmp_path):
    missing = str(tmp_path / "missing.lcm")
    with pytest.raises(FileNotFoundError) as e:
        lagrange.read_log(missing)
    r = subprocess.run([LAGRANGECTL, "log2csv", missing, "-o", str(tmp_path)], capture_output=True, text=True)
    assert r.stderr.strip() == "lagrangectl log2csv: " + str(e.value)
    text = tmp_path / "notes.txt"
    text.write_text("not a log\n")
    with pytest.raises(ValueError) as e:
        lagrange.read_log(str(text))
    r = subprocess.run([LAGRANGECTL, "log2csv", str(text), "-o", str(tmp_path)], capture_output=True, text=True)
    assert r.stderr.strip() == "lagrangectl log2csv: " + str(e.value)


def test_a_channel_name_that_is_not_utf8_reads_with_its_bytes_escaped(log, tmp_path):
    # lcm-logger records whatever channel a datagram names: a hostile one is a key like any other, never an error.
    with open(log, "rb") as f:
        data = f.read()
    bad = str(tmp_path / "bad_channel.lcm")
    with open(bad, "wb") as f:
        f.write(data.replace(b"CARTPOLE_STATE", b"\xff\xfeRTPOLE_STATE"))  # the same length: still a log
    records = lagrange.read_log(bad)
    escaped = "\\xff\\xfeRTPOLE_STATE"
    assert "CARTPOLE_STATE" not in records and records[escaped].channel == escaped
    want = lagrange.read_log(log, channel="CARTPOLE_STATE")["CARTPOLE_STATE"]
    assert records[escaped].rows == want.rows > 0
    np.testing.assert_array_equal(records[escaped].q, want.q)
    assert escaped in repr(records[escaped])


def test_a_log_path_may_be_bytes_or_a_file_name_that_is_not_utf8(log, tmp_path):
    name = os.path.join(os.fsencode(tmp_path), b"run\xff.lcm")
    shutil.copyfile(log, name)
    want = lagrange.read_log(log, channel="ARM_STATE")["ARM_STATE"].q
    np.testing.assert_array_equal(lagrange.read_log(name, channel="ARM_STATE")["ARM_STATE"].q, want)
    np.testing.assert_array_equal(lagrange.read_log(os.fsdecode(name), channel="ARM_STATE")["ARM_STATE"].q, want)
    with pytest.raises(FileNotFoundError, match=r"nothing\\xff\.lcm"):
        lagrange.read_log(os.path.join(os.fsencode(tmp_path), b"nothing\xff.lcm"))


def test_text_that_is_not_utf8_reads_with_its_bytes_escaped(log, tmp_path):
    # A hostile or broken recording: the controller's name replaced by bytes that are not UTF-8 (the same length).
    with open(log, "rb") as f:
        data = f.read()
    assert b"computed-torque" in data
    bad = str(tmp_path / "bad.lcm")
    with open(bad, "wb") as f:
        f.write(data.replace(b"computed-torque", b"\xff\xfe" + b"x" * 13))
    arm = lagrange.read_log(bad, channel="ARM_STATE")["ARM_STATE"]
    assert arm.rows == lagrange.read_log(log, channel="ARM_STATE")["ARM_STATE"].rows
    assert arm.controller[0] == "\\xff\\xfe" + "x" * 13


LIVE_PORT = 8329


def test_a_live_lagranged_publishes_the_rows_simulate_computes_bit_for_bit(tmp_path):
    # One Instance code: the states lagranged published (read back from the log) are simulate's rows at the
    # same step, and its telemetry's ε is simulate's, with no tolerance, whatever the machine's timing did.
    enough = lambda rows: all(rows.get(c, 0) >= 20 for c in  # noqa: E731
                              ("ARM_STATE", "CARTPOLE_STATE", "ARM_TELEMETRY", "CARTPOLE_TELEMETRY"))
    log = record_run(config("default.yaml"), LIVE_PORT, str(tmp_path / "live.lcm"), 0.5, until=enough)
    records = lagrange.read_log(log)
    for name in ("arm", "cartpole"):
        states = records[name.upper() + "_STATE"]
        telemetry = records[name.upper() + "_TELEMETRY"]
        assert states.rows >= 2 and set(states.mode.tolist()) == {0}  # running its scene trajectory throughout
        run = lagrange.simulate(config("default.yaml"), float(states.t.max()) + 0.01)[name]
        step = np.rint(states.t / 0.001).astype(int)  # the row of the same simulated time
        np.testing.assert_array_equal(run.t[step], states.t)
        for field in ("q", "qd", "tau", "q_des"):
            np.testing.assert_array_equal(getattr(run, field)[step], getattr(states, field), err_msg=field)
        np.testing.assert_array_equal(run.kinetic_energy[step], states.kinetic_energy)
        np.testing.assert_array_equal(run.potential_energy[step], states.potential_energy)
        at = np.rint(telemetry.t / 0.001).astype(int)
        np.testing.assert_array_equal(run.energy_residual[at], telemetry.energy_residual)
