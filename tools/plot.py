"""lagrangectl plot: joint angles against setpoints, torques, energy and
tracking error over time, from a CSV of `lagrangectl simulate` or of a
state channel from `lagrangectl log2csv`. Run by lagrangectl as
`python3 -c <this> CSV PNG TITLE`. A reset or restart (the simulated time
t goes backwards, the tick does not follow on, or the run id changes) starts
a new segment: the lines break there instead of drawing back to t = 0. On
success it prints one line to stdout: "N rows in K segment(s)"."""
import csv
import math
import re
import sys


def fail(message):
    print("plot: " + message, file=sys.stderr)
    sys.exit(2)


def load(path):
    try:
        with open(path, newline="") as f:
            rows = list(csv.reader(f))
    except OSError as e:
        fail("cannot read %s: %s" % (path, e.strerror))
    except (UnicodeDecodeError, csv.Error):
        fail("%s is neither a CSV nor an LCM log" % path)
    if len(rows) < 2:
        fail("%s has no data rows" % path)
    header = rows[0]
    columns = {name: [] for name in header}
    for number, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            fail("%s line %d has %d fields, the header %d" % (path, number, len(row), len(header)))
        for name, value in zip(header, row):
            columns[name].append(value)
    return header, columns


def numbers(columns, name, path):
    try:
        return [float(v) for v in columns[name]]
    except ValueError:
        fail("%s: column %s is not numeric" % (path, name))


def indexed(header, pattern):
    found = []
    for name in header:
        m = re.fullmatch(pattern, name)
        if m:
            found.append((int(m.group(1)), name))
    return [name for _, name in sorted(found)]


def segment_starts(columns, t, path):
    """Rows that begin a new segment (row 0 always does)."""
    tick = numbers(columns, "tick", path) if "tick" in columns else None
    run = columns.get("run_id")
    starts = [0]
    for k in range(1, len(t)):
        if (t[k] < t[k - 1] or (tick is not None and tick[k] != tick[k - 1] + 1)
                or (run is not None and run[k] != run[k - 1])):
            starts.append(k)
    return starts


def with_gaps(values, starts):
    """values with a NaN before every segment but the first: matplotlib breaks the line there."""
    out = []
    bounds = starts + [len(values)]
    for i in range(len(starts)):
        if i:
            out.append(math.nan)
        out.extend(values[bounds[i]:bounds[i + 1]])
    return out


def main():
    if len(sys.argv) != 4:
        fail("usage: plot.py CSV PNG TITLE")
    path, png, title = sys.argv[1:4]
    header, columns = load(path)
    q = indexed(header, r"q(\d+)")
    qdes = indexed(header, r"q_?des(\d+)")
    tau = indexed(header, r"tau(\d+)")
    kinetic = "T" if "T" in columns else "kinetic_energy"
    potential = "V" if "V" in columns else "potential_energy"
    missing = [n for n, ok in (("t", "t" in columns), ("q0..", bool(q)), ("qdes0.. or q_des0..", len(qdes) == len(q) and q),
                               ("tau0..", len(tau) == len(q) and q), ("T or kinetic_energy", kinetic in columns),
                               ("V or potential_energy", potential in columns)) if not ok]
    if missing:
        fail("%s lacks the columns %s (a CSV from lagrangectl simulate, or a *_STATE.csv from log2csv)"
             % (path, ", ".join(missing)))

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = numbers(columns, "t", path)
    starts = segment_starts(columns, t, path)
    t_gapped = with_gaps(t, starts)

    def draw(axis, name, values, **style):
        axis.plot(t_gapped, with_gaps(values, starts), label=name, linewidth=1.2, **style)

    fig, axes = plt.subplots(4, 1, sharex=True, figsize=(10, 11))
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, (qn, dn) in enumerate(zip(q, qdes)):
        color = colors[i % len(colors)]
        draw(axes[0], "q%d" % i, numbers(columns, qn, path), color=color)
        draw(axes[0], "qdes%d" % i, numbers(columns, dn, path), color=color, linestyle="--")
    axes[0].set_ylabel("q, q_des (rad or m)")
    axes[0].set_title("joint positions (solid) and setpoints (dashed)")
    for i, name in enumerate(tau):
        draw(axes[1], "tau%d" % i, numbers(columns, name, path), color=colors[i % len(colors)])
    axes[1].set_ylabel("tau (N·m or N)")
    axes[1].set_title("applied generalized forces")
    T = numbers(columns, kinetic, path)
    V = numbers(columns, potential, path)
    draw(axes[2], "T", T)
    draw(axes[2], "V", V)
    draw(axes[2], "E", [a + b for a, b in zip(T, V)], color="black")
    axes[2].set_ylabel("energy (J)")
    axes[2].set_title("kinetic T, potential V and total E")
    for i, (qn, dn) in enumerate(zip(q, qdes)):
        err = [d - x for d, x in zip(numbers(columns, dn, path), numbers(columns, qn, path))]
        draw(axes[3], "e%d" % i, err, color=colors[i % len(colors)])
    axes[3].set_ylabel("q_des - q (rad or m)")
    axes[3].set_title("tracking error")
    axes[3].set_xlabel("t (s)")
    for axis in axes:
        axis.grid(True, alpha=0.3)
        axis.legend(loc="upper right", fontsize="small", ncol=4)
    fig.suptitle(title)
    fig.tight_layout()
    try:
        fig.savefig(png, dpi=80)
    except OSError as e:
        fail("cannot write %s: %s" % (png, e.strerror))
    print("%d rows in %d segment%s" % (len(t), len(starts), "" if len(starts) == 1 else "s"))


try:
    main()
except Exception as e:  # anything unforeseen is still one line
    fail("%s: %s" % (type(e).__name__, e))
