"""Sections 5 and 6: the loop (lagranged beside cyclictest, from loop_bench,
with tick_bench's tick outside the daemon) and the delivery and SIGTERM
figures of the same run."""

import json
import math
import re
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from .common import ns, percentile, ratio, read_csv, table, us, write_csv, yes


TICK_P99_LIMIT_US = 20.0


class Histogram:
    """cyclictest's wake-up latencies (µs bins, thread 0) from its --json file."""

    def __init__(self, path):
        d = json.loads(Path(path).read_text())
        t = d["thread"]["0"]
        self.bins = sorted((int(k), int(v)) for k, v in t["histogram"].items())
        self.cycles = int(t["cycles"])
        self.overflows = self.cycles - sum(v for _, v in self.bins)  # later than the histogram's range
        self.max = float(t["max"])
        m = re.search(r"-h\s*(\d+)", d.get("cmdline:", d.get("cmdline", "")))
        self.limit = float(m.group(1)) if m else math.inf

    def __len__(self):
        return self.cycles

    def percentile(self, p):
        """µs; inf when it falls among the overflows."""
        target, seen = p / 100.0 * self.cycles, 0
        for value, count in self.bins:
            seen += count
            if seen >= target:
                return float(value)
        return math.inf

    def later_than(self, x):
        return sum(c for v, c in self.bins if v > x) + self.overflows


def load_histogram(out, phase, sfx):
    path = out / f"cyclictest_{phase}{sfx}.json"
    return Histogram(path) if path.exists() else None


def loop_data(out, tag=""):
    sfx = "_" + tag if tag else ""
    ticks = read_csv(out / f"loop_ticks{sfx}.csv")
    setpoints = read_csv(out / f"setpoint_latency{sfx}.csv")
    summary = {r["key"]: r["value"] for r in read_csv(out / f"loop_summary{sfx}.csv")}
    log = out / f"lagranged{sfx}.log"
    d = {
        "rt_refused": log.exists() and "not permitted" in log.read_text(),
        "compute": np.array([float(r["compute_ns"]) for r in ticks]) / 1e3,
        "wake": np.array([float(r["wake_latency_ns"]) for r in ticks]) / 1e3,
        "overruns": int(ticks[-1]["overruns"]) if ticks else 0,
        "ticks": len(ticks),
        "setpoint": np.array([float(r["latency_ns"]) for r in setpoints if float(r["latency_ns"]) >= 0]) / 1e3,
        "setpoints_sent": len(setpoints),
        "summary": summary,
        "threads": read_csv(out / f"loop_threads{sfx}.csv"),
        "noise": read_csv(out / f"loop_noise{sfx}.csv"),
        "sigterm": read_csv(out / f"sigterm{sfx}.csv") if (out / f"sigterm{sfx}.csv").exists() else [],
    }
    for phase in ("alone", "concurrent", "alone-slack-1ns"):
        d["cyclictest_" + phase] = load_histogram(out, phase, sfx)
    return d


def pct(v, p):
    """Percentile of an array of µs or of a Histogram."""
    if v is None:
        return math.nan
    return v.percentile(p) if isinstance(v, Histogram) else percentile(v, p)


def us_limit(x, v=None):
    """us(), with 'beyond the histogram' for a cyclictest percentile past its range."""
    if x == math.inf and isinstance(v, Histogram):
        return f"> {us(v.limit)}"
    return us(x)


def late(v):
    """Wakes later than 1 ms, per 10⁴."""
    if v is None or not len(v):
        return "n/a"
    n = v.later_than(1000.0) if isinstance(v, Histogram) else int(np.sum(np.asarray(v) > 1000.0))
    return f"{1e4 * n / len(v):.1f}"


def stats_row(name, v):
    if v is None:
        return [name, 0, "n/a", "n/a", "n/a"]
    biggest = v.max if isinstance(v, Histogram) else (float(np.max(v)) if len(v) else math.nan)
    return [name, len(v), us_limit(pct(v, 50), v), us_limit(pct(v, 99), v), us(biggest)]


THREAD_ROLES = {"lagranged-tick": "tick", "lagranged-recv": "receive (setpoints, commands)",
                "lagranged-pub": "publish (states, status, replies)"}


SYSCALL_ROLES = {"rt_sigtimedwait": "main (waits for signals)", "futex": "spdlog's flush thread or the timing CSV writer",
                 "clock_nanosleep": "a sleeping helper thread (spdlog's flush or the timing CSV writer)"}


def thread_role(t):
    """From the name lagranged gave the thread, else from the system call it usually waits in."""
    return THREAD_ROLES.get(t.get("name", ""), SYSCALL_ROLES.get(t["usually_in"], ""))


def loop_rows(d):
    """The loop's percentiles: lagranged's tick, cyclictest beside it and alone, the setpoint prober."""
    return [stats_row("tick compute time (lagranged)", d["compute"]),
            stats_row("wake-up latency (lagranged)", d["wake"]),
            stats_row("wake-up latency, cyclictest, same time", d["cyclictest_concurrent"]),
            stats_row("wake-up latency, cyclictest alone, before", d["cyclictest_alone"]),
            stats_row("wake-up latency, cyclictest alone, timer slack 1 ns", d["cyclictest_alone-slack-1ns"]),
            stats_row("setpoint publication → first state with it", d["setpoint"])]


def loop_findings(d, tick_runs):
    """The loop's bullets: lagranged against cyclictest, overruns, CPU, late wakes, the tick outside the daemon
    and the timer slack."""
    s = d["summary"]
    cyc = d["cyclictest_concurrent"]
    wake99, cyc99 = percentile(d["wake"], 99), pct(cyc, 99)
    hot = tick_runs.get("tick/default/hot", {}).get("real_ns", math.nan)
    slept = tick_runs.get("tick/default/after-sleep", {}).get("real_ns", math.nan)
    alone, slack = d["cyclictest_alone"], d["cyclictest_alone-slack-1ns"]
    return [
        f"\n- Wake-up latency p99, lagranged / cyclictest at the same time: {ratio(wake99, cyc99):.2f}.",
        f"- Overruns (missed deadlines): {d['overruns']} in {d['ticks']} ticks; ARM_STATE messages received "
        f"{s['arm_states_received']}, tick gaps {s['arm_state_tick_gaps']}.",
        f"- Setpoints sent {d['setpoints_sent']}, seen in a state {len(d['setpoint'])}.",
        f"- lagranged CPU: {float(s['daemon_cpu_window_percent']):.2f} % of one core over the steady window "
        f"({float(s['window_s']):.1f} s from 2 s after its first state), "
        f"{float(s['daemon_cpu_total_percent']):.2f} % over its whole life "
        f"({float(s['daemon_cpu_total_s']):.2f} s CPU in {float(s['daemon_wall_s']):.1f} s, wait4 rusage).",
        f"- Wakes later than one period (1 ms): lagranged {late(d['wake'])}, cyclictest at the same time "
        f"{late(cyc)} (per 10⁴ wakes); a wake that late is an overrun. Both loops are placed by the scheduler "
        "(not pinned); late wakes of that size come with the machine's load rather than the thread: see the "
        "pinned run below.",
        f"- The same tick outside the daemon (`tick_bench`, default scene): {ns(hot)} back to back with warm "
        f"caches, {ns(slept)} when each tick follows a 1 ms sleep as in the daemon (caches and branch "
        f"predictors go cold while the thread sleeps); lagranged's median, {us(percentile(d['compute'], 50))}, "
        "compares with the second figure.",
        f"- Timer slack: SCHED_OTHER threads get Linux's default 50 µs (SCHED_FIFO threads, `--rt-priority`, "
        f"none). cyclictest alone wakes with a median of {us_limit(pct(alone, 50), alone)} with the default "
        f"slack and {us_limit(pct(slack, 50), slack)} with its slack set to 1 ns (inherited from the "
        "benchmark's fork, kept across exec); the difference is what the slack adds to the floor that "
        "lagranged and cyclictest share.\n",
    ]


def loop_machine(d):
    """lagranged's threads and the machine's largest CPU users over the steady window."""
    s = d["summary"]
    trows = [[t["thread"], t.get("name", ""), t["usually_in"], f"{float(t['percent_of_one_core']):.2f} %",
              thread_role(t)] for t in d["threads"]]
    return ["lagranged's threads over the steady window (role from the name lagranged gave the thread, else from "
            "the system call it was seen blocked in most):\n",
            table(["thread (creation order)", "name", "usually blocked in", "CPU, % of one core", "role"], trows),
            "\nThe machine during the run (the largest CPU users from the daemon's first state to 1 s before its "
            f"end; load average before {s['load_average_before']}, after {s['load_average_after']}):\n",
            table(["process", "CPU, % of one core"],
                  [[n["process"], f"{float(n['percent_of_one_core']):.1f} %"] for n in d["noise"]])]


def loop_section(out, d, tick_runs):
    s = d["summary"]
    plot_loop(out, d)
    rows = loop_rows(d)
    write_csv(out / "loop_stats.csv", ["metric", "samples", "p50", "p99", "max"], rows)
    md = ["## 5. The loop\n",
          f"`lagranged --config config/default.yaml --duration {float(s['duration_s']):.0f}` (arm under computed "
          "torque and cart-pole under LQR, both RK4, 1 kHz; no real-time options: SCHED_OTHER, default timer slack) "
          "on a private LCM URL, with `--timing-csv` (every tick's wake-up latency and compute time, written by a "
          "writer thread). Beside it, in the same window: `cyclictest -t1 -i1000 --default-system` (Debian "
          "rt-tests; a 1 kHz absolute-deadline `clock_nanosleep` loop doing no work, at the tick's policy, "
          "SCHED_OTHER; `--default-system` so that it does not lower the machine's wake-up latency through "
          "`/dev/cpu_dma_latency` for the daemon as well), a setpoint prober (a new arm setpoint every 100 ms "
          "plus up to 1 ms of seeded jitter) and `lcm-logger` recording the states. cyclictest also ran alone "
          "before the daemon, once with the default timer slack and once with 1 ns.\n",
          table(["metric", "samples", "p50", "p99", "max"], rows)]
    md += loop_findings(d, tick_runs) + [tick_subsection(tick_runs)] + loop_machine(d)
    md.append("\n![loop latency](loop_latency.png)\n")
    if (out / "loop_ticks_rt.csv").exists():
        md.append(loop_rt_section(loop_data(out, "rt")))
    return "\n".join(md)


TICK_SCENES = {"default": "config/default.yaml: arm2 under computed torque, cart-pole under LQR",
               "panda": "config/panda_minjerk.yaml: 7-DOF Panda (URDF) under computed torque, min-jerk move"}


def tick_subsection(tick_runs):
    """tick_bench's scenes: the tick outside the daemon, with its distribution after a sleep."""
    body = []
    for scene, what in TICK_SCENES.items():
        hot, slept = tick_runs.get(f"tick/{scene}/hot"), tick_runs.get(f"tick/{scene}/after-sleep")
        if not slept:
            body.append([scene, what, "not measured", "", "", "", ""])
            continue
        body.append([scene, what, ns(hot["cpu_ns"]) if hot else "n/a", ns(slept["real_ns"]),
                     ns(slept.get("p50_ns", math.nan)), ns(slept.get("p99_ns", math.nan)),
                     ns(slept.get("max_ns", math.nan))])
    return "\n".join([
        "\nThe tick outside the daemon, by scene (`tick_bench`; RK4, 1 kHz): `hot` is the mean CPU time of ticks "
        "back to back; `after sleep` ticks once per absolute 1 ms deadline and times each from the wake to the end of "
        "`Runtime::Tick`, as lagranged times its compute (daemon/loop.cpp: a clock read after the wake and one "
        "after the tick, written to the timing CSV), with no LCM threads beside it: its mean, and the "
        "percentiles of its ticks (the median of each over the repetitions). The loop above runs only the "
        "default scene in lagranged.\n",
        table(["scene", "what", "hot (mean CPU)", "after sleep (mean)", "p50", "p99", "max"], body)]) + "\n"


def tick_target(tick_runs):
    slept = tick_runs.get("tick/panda/after-sleep")
    p99 = slept.get("p99_ns", math.nan) / 1e3 if slept else math.nan
    return ["7-DOF scene (Panda, computed torque, RK4), tick compute p99 (tick_bench, after a 1 ms sleep)",
            f"≤ {TICK_P99_LIMIT_US:.0f} µs", us(p99) if slept else "not measured",
            yes(p99 <= TICK_P99_LIMIT_US)]


def loop_rt_section(d):
    s = d["summary"]
    cyc = d["cyclictest_concurrent"]
    wake99, cyc99 = percentile(d["wake"], 99), pct(cyc, 99)
    rows = [stats_row("tick compute time (lagranged)", d["compute"]),
            stats_row("wake-up latency (lagranged)", d["wake"]),
            stats_row("wake-up latency, cyclictest (SCHED_FIFO, same CPU, same time)", cyc),
            stats_row("setpoint publication → first state with it", d["setpoint"])]
    refused = (" **lagranged could not apply them (not permitted): this run is not what it says.**"
               if d["rt_refused"] else "")
    return "\n".join([
        "\n### The loop with the service's real-time options, pinned\n",
        f"`--mlockall --rt-priority {s['rt_priority']} --cpu {s['cpu']}` (as config/lagranged.service, plus the "
        f"tick pinned to CPU {s['cpu']}) for {float(s['duration_s']):.0f} s; cyclictest runs on the same CPU "
        f"(`-a {s['cpu']} -m`), SCHED_FIFO one priority higher (`-p {int(s['rt_priority']) + 1}`, so the two loops "
        f"never queue behind each other's work), and both see the same CPU.{refused}\n",
        table(["metric", "samples", "p50", "p99", "max"], rows),
        f"\n- Wake-up latency p99, lagranged / cyclictest: {ratio(wake99, cyc99):.2f}.",
        f"- Overruns: {d['overruns']} in {d['ticks']} ticks. Wakes later than 1 ms per 10⁴: lagranged "
        f"{late(d['wake'])}, cyclictest {late(cyc)}.",
        f"- lagranged CPU: {float(s['daemon_cpu_window_percent']):.2f} % of one core over the steady window.\n"])


def ccdf(ax, name, v):
    if v is None or not len(v):
        return
    if isinstance(v, Histogram):
        x = np.array([b for b, _ in v.bins], dtype=float)
        later = v.cycles - np.cumsum([c for _, c in v.bins])  # wakes later than each bin
        ax.semilogx(x, np.maximum(later, 0.5) / v.cycles, label=name, drawstyle="steps-post")
    else:
        x = np.sort(v)
        ax.semilogx(x, 1.0 - np.arange(len(x)) / len(x), label=name)


def plot_loop(out, d):
    fig, axes = plt.subplots(1, 3, figsize=(16, 4.5))
    for name, v in (("lagranged", d["wake"]), ("cyclictest, same time", d["cyclictest_concurrent"]),
                    ("cyclictest alone", d["cyclictest_alone"]),
                    ("cyclictest alone, slack 1 ns", d["cyclictest_alone-slack-1ns"])):
        ccdf(axes[0], name, v)
    axes[0].set_yscale("log")
    axes[0].set_xlabel("wake-up latency (µs)")
    axes[0].set_ylabel("fraction of wakes later than x")
    axes[0].legend(fontsize=8)
    axes[1].hist(d["compute"], bins=np.logspace(0, 3, 80))
    axes[1].set_xscale("log")
    axes[1].set_yscale("log")
    axes[1].set_xlabel("tick compute time (µs)")
    axes[1].set_ylabel("ticks")
    axes[2].hist(d["setpoint"], bins=40)
    axes[2].set_xlabel("setpoint publication → first state with it (µs)")
    axes[2].set_ylabel("setpoints")
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
    fig.suptitle("The loop: lagranged on config/default.yaml at 1 kHz")
    fig.tight_layout()
    fig.savefig(out / "loop_latency.png", dpi=110)
    plt.close(fig)


SIGTERM_LIMIT_MS = 200.0
OVERRUN_LIMIT = 0.01


def delivery_rows(d):
    """(target, limit, measured, met) for the figures the tests no longer assert."""
    s = d["summary"]
    run = int(s.get("ticks_run", 0))
    rows = []
    for channel in ("ARM_STATE", "CARTPOLE_STATE"):
        missing = s.get(f"logger_missing_{channel}")
        if missing is None or run == 0:
            rows.append([f"{channel} states lost at lcm-logger, quiet bus", "0", "not measured", "**no**"])
            continue
        rows.append([f"{channel} states lost at lcm-logger, quiet bus ({float(s['duration_s']):.0f} s)", "0",
                     f"{int(missing)} of {run} ticks (logged {s[f'logger_states_{channel}']})",
                     yes(int(missing) == 0)])
    fraction = d["overruns"] / d["ticks"] if d["ticks"] else math.nan
    rows.append(["overrun fraction (plain loop run)", "< 1 %", f"{100 * fraction:.3f} % ({d['overruns']} in {d['ticks']})",
                 yes(fraction < OVERRUN_LIMIT)])
    times = [float(r["exit_ms"]) for r in d["sigterm"]]
    if times:
        failed = sum(1 for r in d["sigterm"] if float(r["exit_ms"]) < 0 or int(r["exit_status"]) != 0)
        good = [t for t in times if t >= 0]
        worst = max(good) if good else math.nan
        rows.append([f"SIGTERM → exit, {len(times)} starts", f"≤ {SIGTERM_LIMIT_MS:.0f} ms",
                     f"p50 {percentile(good, 50):.1f} ms, max {worst:.1f} ms"
                     + (f"; {failed} did not exit cleanly" if failed else ""),
                     yes(failed == 0 and worst <= SIGTERM_LIMIT_MS)])
    return rows


def delivery_section(d):
    s = d["summary"]
    md = ["## 6. Delivery and timing\n",
          "Figures the tests no longer assert (tests assert protocol facts; timing lives here). From the plain loop "
          f"run above: Debian's `lcm-logger` recorded ARM_STATE, CARTPOLE_STATE and LAGRANGE_STATUS on the same "
          f"bus from before the daemon's first tick to after its exit; its states of this run, per instance, against "
          f"the ticks the daemon ran (its final status: {s.get('ticks_run', '?')}); lcm-logger ended with "
          f"{s.get('logger_exit', '?')}. Then lagranged was started {len(d['sigterm'])} times more and sent SIGTERM "
          "0.3 s after its first state; the time is from `kill` to the process being gone (its pidfd readable).\n",
          table(["figure", "target", "measured", "met"], delivery_rows(d))]
    return "\n".join(md)
