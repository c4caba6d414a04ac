"""Section 7: the hostile bus, from hostile_bench."""

import math


from .common import percentile, read_csv, table, us, write_csv, yes


HOSTILE_CASES = ["quiet", "setpoints", "malformed", "commands", "fragments", "foreign"]
HOSTILE_WHAT = {
    "quiet": "no flood (the baseline)",
    "setpoints": "valid ARM_SETPOINT",
    "malformed": "refusable ARM_SETPOINT and non-LCM datagrams",
    "commands": "valid ARM_COMMAND: switch, pause, resume",
    "fragments": "LC03 fragments on ARM_STATE: offset wrap, short, 256 MiB declared",
    "foreign": "15 unused channels + 1 in 16 a spoofed ARM_STATE",
}


RSS_LIMIT_KIB = 1024


def hostile_data(out):
    rows = read_csv(out / "hostile_cases.csv")
    for r in rows:
        for k, v in r.items():
            if k not in ("bus", "case", "logger_exit"):
                r[k] = float(v)
    probes, estops = {}, {}
    for r in read_csv(out / "hostile_probe.csv"):
        probes.setdefault((r["bus"], r["case"]), []).append(float(r["latency_ns"]) / 1e3)
    for r in read_csv(out / "hostile_estops.csv"):
        estops.setdefault((r["bus"], r["case"]), []).append(float(r["state_latency_ns"]) / 1e3)
    summary = {r["key"]: r["value"] for r in read_csv(out / "hostile_summary.csv")}
    return rows, probes, estops, summary


def rss_growth(r):
    return max(r["rss_end_kib"], r["rss_peak_kib"]) - r["rss_start_kib"]


def lost(r):
    return int(r["lost_arm"] + r["lost_cartpole"])


def times_quiet(x, q):
    """' (×r)' against the quiet case's figure."""
    if not math.isfinite(x) or not math.isfinite(q):
        return ""
    if q == 0:
        return "" if x == 0 else " (quiet: 0)"
    return f" (×{x / q:.1f})"


def hostile_case_targets(r):
    """(no crash, RSS growth ≤ 1 MiB, every estop applied, 0 records dropped) for one case."""
    return (r["daemon_alive"] == 1, rss_growth(r) <= RSS_LIMIT_KIB,
            r["estops"] > 0 and r["estops_applied"] == r["estops"], r["state_messages_dropped"] == 0)


def hostile_table(rows, probes, estops, bus):
    by_case = {r["case"]: r for r in rows if r["bus"] == bus}
    quiet = by_case.get("quiet")
    q_p99 = percentile([v for v in probes.get((bus, "quiet"), []) if v >= 0], 99)
    body, counters = [], []
    for c in HOSTILE_CASES:
        r = by_case.get(c)
        if r is None:
            continue
        seen = [v for v in probes.get((bus, c), []) if v >= 0]
        p99 = percentile(seen, 99)
        applied = [v for v in estops.get((bus, c), []) if v >= 0]
        ok = hostile_case_targets(r)
        ticks = int(r["ticks"])
        body.append([
            c, f"{r['flood_rate_per_s'] / 1e3:.0f} k/s" if r["flood_datagrams"] else "—",
            f"{lost(r)} of {2 * ticks} ({100 * lost(r) / max(2 * ticks, 1):.1f} %)"
            + ("" if r["logger_exit"] == "exit 0" else f", logger: {r['logger_exit']}"),
            f"{int(r['overruns'])}" + times_quiet(r["overruns"], quiet["overruns"] if quiet else math.nan),
            f"{rss_growth(r):.0f} KiB",
            f"{int(r['estops_applied'])} / {int(r['estops'])} (state {int(r['estops_seen_in_state'])}, "
            f"reply {int(r['estop_replies_accepted'])})",
            us(percentile(applied, 50)) if applied else "n/a",
            f"{int(r['state_messages_dropped'])}",
            f"{us(p99)}{times_quiet(p99, q_p99)}; {len(seen)}/{int(r['probe_sent'])} seen",
            "yes" if all(ok) else "**no** (" + ", ".join(
                n for n, good in zip(("crash", "RSS", "estop", "records"), ok) if not good) + ")"])
        counters.append([c] + [str(int(r[k])) for k in (
            "setpoints_accepted", "setpoints_rejected", "commands_accepted", "commands_rejected", "decode_errors",
            "datagrams_dropped_kernel", "datagrams_malformed", "fragments_dropped", "foreign_messages",
            "replies_suppressed")])
    main = table(["case", "flood rate", "states lost at lcm-logger (both instances)", "overruns", "RSS growth",
                  "estops applied", "estop → state p50", "records dropped", "setpoint → state p99", "targets met"],
                 body)
    counts = table(["case", "setpoints accepted", "setpoints rejected", "commands accepted", "commands rejected",
                    "decode errors", "datagrams dropped (kernel)", "datagrams malformed", "fragments dropped",
                    "foreign messages", "replies suppressed"], counters)
    return main, counts


def hostile_section(out, data):
    rows, probes, estops, summary = data
    seconds = float(summary["seconds_per_case"])
    port, port_in = summary["port"], summary["input_port_separate"]
    md = ["## 7. The hostile bus\n",
          f"lagranged on config/default.yaml under one flood after another, {seconds:.0f} s each, every flood one "
          "thread sending prepared datagrams on a raw UDP socket as fast as it can (the rate it reached is given). "
          "During every case, the quiet one too: Debian's `lcm-logger` records the output channels (a new log per "
          "case; its states of this run, per instance, are counted against the ticks the daemon ran in the window, "
          "from its status just after the window opened to just after it closed), an estop goes to the arm every "
          "1 s with a request_id (applied: a state shows the arm in MODE_ESTOP, or its reply says accepted; then "
          "clear_estop, until the arm leaves the estop once its 0.5 s estop_dwell is over), a prober sends a cart-pole setpoint every 20 ms and times it to the first state carrying "
          "it, and the daemon's VmRSS is read every 0.1 s. Counters are status_t deltas over the window; "
          "`records dropped` is status_t.state_messages_dropped, the daemon's total. Multiples in brackets are "
          "against the quiet case of the same bus in the same run.\n",
          "| case | flood |\n|---|---|\n" + "".join(f"| {c} | {HOSTILE_WHAT[c]} |\n" for c in HOSTILE_CASES)]
    for bus, title in (("shared", f"### One bus: the daemon, the floods and lcm-logger on port {port}\n"),
                       ("separate", f"### Separate buses: outputs on port {port} (lcm-logger), inputs and floods "
                                    f"on port {port_in} (`--input-lcm-url`)\n")):
        main, counts = hostile_table(rows, probes, estops, bus)
        md += [title, main, "\nStatus counters over the window:\n", counts,
               f"\nlagranged was started {summary.get(bus + '_daemon_starts', '?')} time(s) (a restart means it "
               f"died in a case) and ended with {summary.get(bus + '_daemon_exit', '?')} at SIGTERM; "
               f"VmRSS {summary.get(bus + '_rss_first_kib', '?')} KiB at its first status, "
               f"{summary.get(bus + '_rss_last_kib', '?')} KiB after the last case.\n"]
    if any(not hostile_case_targets(r)[2] for r in rows):
        md.append("An estop is sent once, as `lagrangectl estop` sends it. One that neither showed in a state nor got "
                  "an accepted reply most likely never reached the daemon: under a flood the kernel drops datagrams "
                  "at the daemon's full receive buffer (`datagrams dropped (kernel)`) before it reads them, and the "
                  "latest-wins flags protect an estop only once it has been read.\n")
    md.append("### One bus against two: states lost at lcm-logger under the same input flood\n")
    shared = {r["case"]: r for r in rows if r["bus"] == "shared"}
    separate = {r["case"]: r for r in rows if r["bus"] == "separate"}
    body = []
    for c in HOSTILE_CASES:
        if c in shared and c in separate:
            a, b = shared[c], separate[c]
            body.append([c, f"{lost(a)} of {2 * int(a['ticks'])}" + ("" if a["logger_exit"] == "exit 0"
                                                                  else f" ({a['logger_exit']})"),
                         f"{lost(b)} of {2 * int(b['ticks'])}" + ("" if b["logger_exit"] == "exit 0"
                                                                  else f" ({b['logger_exit']})"),
                         f"{int(a['overruns'])} / {int(b['overruns'])}"])
    md.append(table(["case", "one bus", "separate buses", "overruns, one bus / separate"], body))
    write_csv(out / "hostile_targets.csv", ["bus", "case", "no_crash", "rss_growth_le_1MiB", "every_estop_applied",
                                            "no_records_dropped"],
              [[r["bus"], r["case"]] + [int(x) for x in hostile_case_targets(r)] for r in rows])
    return "\n".join(md)


def hostile_targets(data):
    rows, _, _, summary = data
    clean = all(summary.get(f"{b}_daemon_starts") == "1" and summary.get(f"{b}_daemon_exit") == "exit 0"
                for b in ("shared", "separate"))
    worst = max(rows, key=rss_growth)
    missed = [r for r in rows if not hostile_case_targets(r)[2]]
    dropped = max(int(r["state_messages_dropped"]) for r in rows)
    applied = sum(int(r["estops_applied"]) for r in rows)
    sent = sum(int(r["estops"]) for r in rows)
    return [
        ["hostile bus: no daemon crash (every case, both buses)", "0 crashes",
         "none" if clean else "; ".join(f"{b}: {summary.get(b + '_daemon_starts')} start(s), "
                                         f"{summary.get(b + '_daemon_exit')}" for b in ("shared", "separate")),
         yes(clean)],
        ["hostile bus: daemon RSS growth in a case (worst)", "≤ 1 MiB",
         f"{rss_growth(worst):.0f} KiB ({worst['bus']}, {worst['case']})", yes(rss_growth(worst) <= RSS_LIMIT_KIB)],
        ["hostile bus: estops applied", "every one", f"{applied} of {sent}"
         + (" (short in: " + ", ".join(f"{r['bus']} {r['case']}" for r in missed) + ")" if missed else ""),
         yes(not missed)],
        ["hostile bus: records dropped by the daemon", "0", str(dropped), yes(dropped == 0)],
    ]
