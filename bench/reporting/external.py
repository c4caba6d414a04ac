"""Section 8: the two-process loop, from external_bench's external.json."""

import json
import math


from .common import ratio, table, yes


def external_data(out):
    return json.loads((out / "external.json").read_text())


def amount(x, unit="µs", digits=1):
    """A figure from external.json ("n/a" when there were no samples: JSON null)."""
    if x is None or not math.isfinite(x):
        return "n/a"
    return f"{x:.{digits}f} {unit}" if unit else f"{x:.{digits}f}"


def num(x):
    return math.nan if x is None else float(x)


def external_target_rows(e):
    """(target, limit, measured, met): the issue's 'at most 1 tick + the LCM round trip', read two ways:
    whole ticks added at application, and time from the state's tick to its torque on the bus."""
    t = e["two_process"]
    period_us = 1e6 * e["settings"]["period_s"]
    recv_limit = period_us + num(e["round_trip_us"]["p50"])
    added, recv = t["added_ticks"], t["state_to_torque_us"]
    return [
        ["two-process loop: ticks of delay added to one process (j − k − 1), p99", "≤ 1 tick",
         f"p50 {amount(added['p50'], '', 0)}, p99 {amount(added['p99'], '', 0)}, max {amount(added['max'], '', 0)}; "
         f"mean {amount(num(t.get('added_ticks_mean')), '', 3)} over every phase drawn", yes(num(added["p99"]) <= 1)],
        ["two-process loop: state → torque on the bus, p99", f"≤ 1 tick + RTT p50 = {amount(recv_limit)}",
         f"p50 {amount(recv['p50'])}, p99 {amount(recv['p99'])} ({ratio(num(recv['p99']), recv_limit):.2f} of the limit)",
         yes(num(recv["p99"]) <= recv_limit)],
    ]


def external_scheduling(st):
    p = st.get("rt_priority", 0)
    if not p:
        return "Every daemon SCHED_OTHER (no real-time options), as this program. "
    return (f"Every daemon with `--mlockall --rt-priority {p}`; this program's receiving threads and the echo at "
            f"SCHED_FIFO {max(1, p - 2)}, as a daemon's receive thread. ")


def external_row(name, s, unit="µs", note="", digits=1):
    return [name, s["n"], amount(s["p50"], unit, digits), amount(s["p99"], unit, digits), amount(s["max"], unit, digits), note]


def external_figure_rows(e):
    """The section's table of figures: the round trip, one process, then the two-process loop."""
    st, t, one = e["settings"], e["two_process"], e["single_process"]["timing"]
    rtt = e["round_trip_us"]
    rtt50 = num(rtt["p50"])
    one50 = num(one["compute_us"]["p50"])
    return [
        external_row(f"LCM round trip (ping → a second process → back, one a ms; {e['round_trips_lost']} lost)", rtt),
        external_row("one process: tick compute (the default scene: the arm and the cart-pole)", one["compute_us"]),
        external_row("one process: wake-up latency", one["wake_us"]),
        ["one process: delay j − k (the tau of tick j is computed from state j − 1)", "", "1 tick", "1 tick",
         "1 tick", "by construction: 0 ticks added"],
        external_row("two processes: plant (#1) tick compute", t["plant_timing"]["compute_us"],
                     note=f"p50 {ratio(num(t['plant_timing']['compute_us']['p50']), one50):.2f} × one process"),
        external_row("two processes: controller (#2) tick compute", t["controller_timing"]["compute_us"],
                     note=f"p50 {ratio(num(t['controller_timing']['compute_us']['p50']), one50):.2f} × one process"),
        external_row("two processes: plant (#1) wake-up latency", t["plant_timing"]["wake_us"]),
        external_row("state → torque: plant tick k began → the torque from state k arrives here",
                     t["state_to_torque_us"],
                     note=f"p50 {ratio(num(t['state_to_torque_us']['p50']), rtt50):.1f} × RTT p50"),
        external_row("state → torque, bus-observed: state k arrives here → its torque arrives here",
                     t["state_arrival_to_torque_us"]),
        external_row("the controller's tick after plant tick k began (the phase of the two loops)",
                     t["controller_tick_after_state_us"]),
        external_row("plant tick began → its state arrives here (compute, publish thread, one way)",
                     t["state_publication_us"],
                     note=f"p50 {ratio(num(t['state_publication_us']['p50']), rtt50 / 2):.1f} × RTT p50 / 2"),
        external_row("controller tick began → its torque arrives here (compute, publish thread, one way)",
                     t["torque_publication_us"],
                     note=f"p50 {ratio(num(t['torque_publication_us']['p50']), rtt50 / 2):.1f} × RTT p50 / 2"),
        external_row("torque arrives here → the plant tick that applied it began", t["arrival_to_application_us"]),
        external_row("application: delay j − k, ticks", t["delay_ticks"], "", digits=0),
        external_row("application: ticks added to one process, j − k − 1", t["added_ticks"], "", digits=0),
        external_row("application: time added, utime(j) − utime(k + 1)", t["added_us"],
                     note="ticks added × period, plus the plant's tick jitter"),
        external_row(f"SIGKILL of #2 → the plant's first tick in hold ({len(t['segments'])} kills)",
                     t["kill_to_hold_ms"], "ms", note=f"torque_timeout {1e3 * st['torque_timeout_s']:.0f} ms",
                     digits=2),
    ]


def external_segment_table(t):
    """One row per segment: a new controller process, a new phase."""
    rows = [[s["segment"], amount(s.get("controller_tick_after_state_us_p50"), "µs", 0),
             f"{amount(s.get('state_to_torque_us_p50'), 'µs', 0)} / {amount(s.get('state_to_torque_us_p99'), 'µs', 0)}",
             f"{amount(s.get('delay_ticks_p50'), '', 0)} / {amount(s.get('delay_ticks_p99'), '', 0)} / "
             f"{amount(s.get('delay_ticks_max'), '', 0)}",
             f"{s['torques'] - s['applied']} of {s['torques']}", s["plant_ticks_in_hold"],
             amount(s.get("kill_to_hold_ms"), "ms", 2), s["controller_exit"]] for s in t["segments"]]
    return table(["segment", "controller tick after plant tick k, p50", "state → torque p50 / p99",
                  "delay j − k p50 / p99 / max", "never applied", "plant ticks in hold", "kill → hold", "#2 ended"],
                 rows)


def external_section(e):
    st, t, one = e["settings"], e["two_process"], e["single_process"]["timing"]
    rtt = e["round_trip_us"]
    rtt50 = num(rtt["p50"])
    limits = ", ".join(f"{x:g}" for x in st["torque_limits"])
    tau_max = ", ".join(f"{x:.3g}" for x in t["tau_abs_max"])
    histogram = ", ".join(f"{k}: {v}" for k, v in t["delay_ticks_histogram"].items())
    md = ["## 8. Two-process loop (external controller / external plant)\n",
          f"`external_bench`, on one private LCM URL ({st['url']}), one after another: the LCM round trip (this "
          "program pings a copy of itself through lagrange's Bus once a millisecond); lagranged on "
          f"config/{st['scenes']['single']} for {st['duration_s']:g} s with `--timing-csv` (computed torque inside "
          "the tick: the torque applied in tick j is computed from state j − 1); then the two-process loop for "
          f"{st['duration_s']:g} s: lagranged #1 on config/{st['scenes']['plant']} (the simulated arm under an "
          f"`external` controller, applying the latest torque_t from {st['channels']['torque']}) and lagranged #2 on "
          f"config/{st['scenes']['controller']} with `--channel-prefix CTRL_` (computed torque on the measured "
          f"{st['channels']['state']}), both with `--timing-csv`, #2 in {st['segments']} segments, each a new "
          "process ended by SIGKILL. Two free-running 1 kHz loops would keep the phase between their ticks for as "
          "long as they run, and that phase decides whether a torque makes the plant's next tick, so each segment "
          "starts at a new one; the controller scene's `phase_lock` then moves #2's deadlines (at most 50 µs a "
          "tick) until each tick starts `phase_lag` (0.2 ms) after the state it answers arrived. The benchmark timestamps every state and torque it receives with the wall clock (the clock of "
          "the messages' utime). A torque computed from state k counts as applied at the first plant state j > k "
          "whose tau is bit-equal to it; in one process j − k = 1, so the loop adds j − k − 1 ticks. Windows open "
          f"{st['settle_s']:g} s after a controller's first torque is applied. {external_scheduling(st)}The issue's "
          "target, at most 1 tick + "
          f"the LCM round trip (RTT p50 {amount(rtt50)} in this run), is read two ways: whole ticks added at "
          "application, and the time from the state's tick to its torque on the bus. That time is the state's "
          "publication, the wait for the controller's next tick (the phase: up to one tick) and the torque's "
          "publication; each publication is a tick's compute, the hand-off to the daemon's publish thread and one "
          "way on the bus, so without the phase lock the second reading exceeds 1 tick + RTT by the two hand-offs "
          "whenever a segment draws a phase near a whole tick. Per-torque rows: `external_torques.csv`.\n",
          table(["target", "limit", "measured", "met"], external_target_rows(e)),
          table(["figure", "samples", "p50", "p99", "max", "note"], external_figure_rows(e)),
          f"- Torques from the windows' states: {t['torques']}; applied {t['applied']}, never applied "
          f"(superseded before a plant tick took them) {t['never_applied']} "
          f"({100 * t['never_applied_fraction']:.2f} %). Delay j − k in ticks (count): {histogram}.",
          f"- Plant ticks in the windows: {t['plant_ticks_in_windows']}; in hold {t['plant_ticks_in_hold']}, in "
          f"another mode {t['plant_ticks_other_mode']}, applying the same torque as the tick before (no new one in "
          f"time) {t['plant_ticks_reusing_torque']}, running on a torque this program never saw "
          f"{t['plant_ticks_unmatched']}.",
          f"- Daemon checks (a message seen here {t['receive_guard_us']} µs before a tick began is one that tick "
          f"should have taken): torques that waited a plant tick in the mailbox {t['torques_waited_a_tick']}; "
          "torques computed from an older state than the newest one on the bus when the controller's tick began "
          f"{t['torques_from_older_state']}.",
          f"- Largest |tau| applied: {tau_max} N·m, against the torque limits {limits} N·m (plant ticks at a limit: "
          f"{t['plant_ticks_at_torque_limit']}).",
          f"- The plant accepted {t.get('plant_torques_accepted', '?')} torques and refused "
          f"{t.get('plant_torques_rejected', '?')}; missed by this program: {t['states_missed_here']} states, "
          f"{t['torques_missed_here']} torques (kernel drops {t['kernel_drops_here']}). Plant: {t['plant_exit']}; "
          f"one process: {e['single_process']['exit']}; echo: {e['echo_exit']}. Overruns: one process "
          f"{one['overruns']}, plant {t['plant_timing']['overruns']}, controllers "
          f"{t['controller_timing']['overruns']}. Load average before {st['load_average_before']}, after "
          f"{st['load_average_after']} ({st['cores']} cores).\n",
          "Per segment (a new controller process, a new phase):\n"]
    md.append("The phase decides (until the lock has settled, within the first 20 ticks): a controller tick that "
              "begins before state k has reached it uses state k − 1 "
              "(the phase column then reads a tick more), and a torque that reaches the plant after its next tick "
              "began waits one more tick.\n")
    md.append(external_segment_table(t))
    if t.get("problem"):
        md.append(f"\n**The run stopped early: {t['problem']}.**\n")
    return "\n".join(md)
