"""Section 10: the two-process loop under a flood, from flood_bench."""

from .common import read_csv, table, yes


FLOOD_WHAT = {
    "quiet": "no flood (the baseline)",
    "refused": "refused ARM_STATE (the plant's run id copied, a tick that does not grow; signed: a wrong tag)",
    "garbage": "200-byte datagrams that are not LCM",
}


def flood_data(out):
    rows = read_csv(out / "flood_cases.csv")
    for r in rows:
        for k, v in r.items():
            if k not in ("bus", "case", "problem", "controller_reason"):
                r[k] = float(v)
    return rows


def buffer_name(r):
    return "lagranged's (2 MiB)" if r["daemon_recv_buf_size"] == 0 else f"{r['daemon_recv_buf_size']:.0f} B"


def ratio(a, b):
    return f"{a / b:.3f}" if b > 0 else "-"


def flood_section(rows):
    body = [[r["bus"], r["case"], buffer_name(r), f"{r['flood_rate_per_s']:.0f}", yes(r["loop_kept_running"] == 1),
             f"{r['controller_statuses_not_running']:.0f} of {r['controller_statuses']:.0f}",
             ratio(r["measured_accepted"], r["controller_ticks"]), f"{r['controller_kernel_drops']:.0f}",
             f"{r['plant_states_not_running']:.0f} of {r['plant_states_seen']:.0f}",
             ratio(r["torques_accepted"], r["plant_ticks"]), f"{r['plant_kernel_drops']:.0f}"] for r in rows]
    return "\n".join([
        "## 10. The two-process loop under a flood\n",
        "flood_bench: lagranged on arm_external_plant.yaml and on arm_external_controller.yaml (CTRL_), a fresh pair "
        "per case, while one thread floods their bus. Cases: "
        + "; ".join(f"{k}: {v}" for k, v in FLOOD_WHAT.items())
        + ". Each with lagranged's receive buffer and with the baseline buffer in the same run. Accepted per tick: "
        "the controller's measured states accepted over its ticks, the plant's torques over its ticks (window ends "
        "read from the statuses, so about 1 ± 0.02 when nothing is lost).\n",
        table(["bus", "case", "daemons' receive buffer", "flood /s", "loop kept running",
               "controller not running (statuses)", "states accepted / tick", "controller kernel drops",
               "plant not running (states)", "torques accepted / tick", "plant kernel drops"], body),
    ])


def flood_targets(rows):
    flooded = [r for r in rows if r["case"] != "quiet" and r["daemon_recv_buf_size"] == 0]
    if not flooded:
        return []
    kept = all(r["loop_kept_running"] == 1 for r in flooded)
    slowest = min(r["flood_rate_per_s"] for r in flooded)
    drops = max(max(r["controller_kernel_drops"], r["plant_kernel_drops"]) for r in flooded)
    return [
        ["two-process loop under a flood (140 k/s asked): it keeps running", "every case",
         f"{'every' if kept else 'not every'} case; slowest flood {slowest:.0f}/s", yes(kept)],
        ["two-process loop under a flood: datagrams the kernel dropped at a daemon (worst case)", "0",
         f"{drops:.0f}", yes(drops == 0)],
    ]
