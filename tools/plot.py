"""lagrangectl plot: joint angles against setpoints, torques, energy and
tracking error over time, from a CSV of `lagrangectl simulate` or of a
state channel from `lagrangectl log2csv`. Run by lagrangectl as
`python3 -c <this> CSV PNG TITLE [TELEMETRY_CSV FORCES_CSV [STATUS_CSV [JOINTS_CSV [TASK_CSV [TASK_SPACE [MPC_CSV
[BASE_CSV]]]]]]]`
(any may be ""; TASK_SPACE: the task-space controllers' names, comma-separated): with a status CSV (log2csv of LAGRANGE_STATUS) the joints are
named as the daemon names them, and a dotted vertical line marks each switch
of the integrator or the dynamics method; with a joints CSV (simulate's
FILE.joints.csv beside FILE.csv) they are named by it; with a task CSV
(simulate's FILE.task.csv, or log2csv of <NAME>_TASK: the frame a task-space
controller moves) two panels: the tracking error of that frame to its task
target, |p_des - p| in mm with the rotation error in mrad on a right-hand
axis, and the frame's position against its target. The joint setpoint q_des
(dashed, and q_des - q in the joints' tracking panel) is drawn only on rows
where a controller followed it: not under a task-space controller (a row with
a task row of the same run and tick, or the same t, or a task-space
controller's name), not while the external controller applied streamed
torques (controller "external", mode running); the joints' tracking panel is
left out when no row followed it and a task target was tracked instead, and
says so when neither was. With a telemetry CSV
(log2csv of <NAME>_TELEMETRY) two more panels, the energy residual ε(t)
against ± the quadrature bound and the cost per tick (evaluations, compute
µs); with a forces CSV (<NAME>_FORCES) one panel per joint, each effect that
was on as a line; with an mpc CSV (log2csv of <NAME>_MPC: an mpc controller's
plans) one panel of each joint's actual path (solid) beside the paths the
optimiser predicted (dotted, the knots each plan carries, up to 12 plans
evenly chosen, drawn up to the last state row); with a floating base's
columns in the CSV (simulate's position0.., orientation0.., com0..,
linear_momentum0.., angular_momentum0..), or a base CSV (log2csv of
<NAME>_BASE: the same columns, on its own time axis), three panels: the
base's and the centre of mass's height, the base's quaternion, and the
momentum's magnitudes. A reset or restart (the simulated
time t goes backwards, the tick does not follow on, or the run id changes)
starts a new segment: the lines break there instead of drawing back to
t = 0. On success it prints "N rows in K segment(s)" to stdout, then
"joints: NAME, .." when it named the joints (else they are q0, q1, ..), what
its tracking panels measured unless every row followed its joint setpoint
("tracking: joints to q_des on N of M rows, max |q_des - q| X", "tracking:
FRAME to its task target on N rows, max |p_des - p| X mm, rotation Y mrad",
or "tracking: none (...)"), "task: N rows of FRAME",
"telemetry: N rows", "forces: N rows of EFFECT, ..", "mpc: N plans (F followed), K drawn" and
"base: N rows, height A to B m"
for what it drew."""
import bisect
import csv
import math
import os
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


# forces_t's rows in the order of its balance, each with its *_on flag (None:
# always drawn) and its legend; gravity and coriolis are G and C q̇ as
# published, which enter M q̈ with a minus.
FORCE_ROWS = (("gravity", "gravity_on", "G (gravity)"), ("coriolis", "coriolis_on", "C qd (coriolis)"),
              ("damping", "damping_on", "damping"), ("friction", "friction_on", "friction"),
              ("limits", "limits_on", "limits"), ("constraint", "constraint_on", "constraint (contacts, equalities)"),
              ("disturbance", "disturbance_on", "disturbance"),
              ("tau_cmd", "saturation_on", "tau_cmd (before saturation)"), ("tau_applied", None, "tau_applied"))
# Rows a CSV of an earlier lagrange lacks: not drawn there.
OPTIONAL_FORCE_ROWS = ("constraint",)


def series(path, columns):
    """A telemetry or forces CSV's time axis with gaps at its segments, and the function that gaps a column alike."""
    t = numbers(columns, "t", path)
    starts = segment_starts(columns, t, path)
    return with_gaps(t, starts), (lambda values: with_gaps(values, starts))


def telemetry_panels(axes, path):
    header, columns = load(path)
    missing = [n for n in ("t", "energy_residual", "quadrature_bound", "evaluations", "compute_us") if n not in columns]
    if missing:
        fail("%s lacks the columns %s (a *_TELEMETRY.csv from log2csv)" % (path, ", ".join(missing)))
    t, gap = series(path, columns)
    eps, bound = numbers(columns, "energy_residual", path), numbers(columns, "quadrature_bound", path)
    axes[0].plot(t, gap(eps), label="ε = E - E(0) - W", linewidth=1.2, color="black")
    axes[0].plot(t, gap(bound), label="± quadrature bound", linewidth=1.0, color="gray", linestyle="--")
    axes[0].plot(t, gap([-b for b in bound]), linewidth=1.0, color="gray", linestyle="--")
    axes[0].set_ylabel("ε (J)")
    # Tick labels that carry their own exponent: no offset text to sit over the title.
    import matplotlib.ticker
    axes[0].yaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%.2g"))
    axes[0].set_title("energy-balance residual: the integrator's drift (dashed: the quadrature's own error)")
    # One legend for both axes (place_legends), each entry naming its side.
    axes[1].plot(t, gap(numbers(columns, "evaluations", path)), label="evaluations (left axis)", linewidth=1.2,
                 color="C0")
    axes[1].set_ylabel("evaluations per tick")
    right = axes[1].twinx()
    right.plot(t, gap(numbers(columns, "compute_us", path)), label="compute µs (right axis)", linewidth=0.8,
               color="C3", alpha=0.7)
    right.set_ylabel("compute (µs per tick)")
    axes[1].set_title("cost per tick")
    return "telemetry: %d rows" % len(eps), right


def load_task(path):
    header, columns = load(path)
    wanted = (["t", "frame"] + ["position%d" % i for i in range(3)] + ["position_des%d" % i for i in range(3)]
              + ["error%d" % i for i in range(6)])
    missing = [n for n in wanted if n not in columns]
    if missing:
        fail("%s lacks the columns %s (a FILE.task.csv from lagrangectl simulate, or a *_TASK.csv from log2csv)"
             % (path, ", ".join(missing)))
    return columns


def task_rows(state_columns, task_columns, task_space_names):
    """Which state rows a task-space controller commanded: those with a task row of the same run
    and tick (a log), else of the same t (simulate writes both with one format), and those whose
    controller is a task-space controller by name."""
    rows = len(state_columns["t"])
    if task_columns is None:
        keys, own = set(), None
    elif all(c in task_columns and c in state_columns for c in ("run_id", "tick")):
        keys = set(zip(task_columns["run_id"], task_columns["tick"]))
        own = list(zip(state_columns["run_id"], state_columns["tick"]))
    else:
        keys, own = set(task_columns["t"]), state_columns["t"]
    controller = state_columns.get("controller")
    return [(own is not None and own[k] in keys) or (controller is not None and controller[k] in task_space_names)
            for k in range(rows)]


def followed_rows(columns, under_task):
    """Rows whose joint setpoint q_des a controller followed: not under a task-space controller, not
    while the external controller applied streamed torques (controller external, mode running: 0)."""
    controller, mode = columns.get("controller"), columns.get("mode")
    return [not under_task[k] and not (controller is not None and mode is not None and controller[k] == "external"
                                       and mode[k] == "0") for k in range(len(columns["t"]))]


def task_panels(axes, path, columns):
    """The commanded frame's tracking error to its task target: |p_des - p| (mm, left axis) and
    |rotation vector| (mrad, right axis: returned with the summary lines); then its position and
    target. A row with no measurement yet (simulate's first: nan) is a gap."""
    t, gap = series(path, columns)
    frames = list(dict.fromkeys(columns["frame"]))  # in order of appearance: one unless its controller changed
    error = [numbers(columns, "error%d" % i, path) for i in range(6)]
    position_mm = [1e3 * math.hypot(*e) for e in zip(*error[:3])]
    rotation_mrad = [1e3 * math.hypot(*e) for e in zip(*error[3:])]
    axes[0].plot(t, gap(position_mm), label="|p_des - p| (left axis)", linewidth=1.2, color="C0")
    axes[0].set_ylabel("position error (mm)")
    right = axes[0].twinx()
    right.plot(t, gap(rotation_mrad), label="rotation error (right axis)", linewidth=0.8, color="C3", alpha=0.7)
    right.set_ylabel("rotation error (mrad)")
    axes[0].set_title("tracking error: %s to its task target, |p_des − p| (mm) and rotation (mrad)" % ", ".join(frames))
    for i, name in enumerate("xyz"):
        color = "C%d" % i
        axes[1].plot(t, gap(numbers(columns, "position%d" % i, path)), label=name, linewidth=1.2, color=color)
        axes[1].plot(t, gap(numbers(columns, "position_des%d" % i, path)), label=name + " target", linewidth=1.0,
                     color=color, linestyle="--")
    axes[1].set_ylabel("x, y, z (m)")
    axes[1].set_title("end effector: %s position (solid) and target (dashed)" % ", ".join(frames))
    finite = [(p, r) for p, r in zip(position_mm, rotation_mrad) if math.isfinite(p) and math.isfinite(r)]
    tracking = "tracking: %s to its task target on %d rows, max |p_des - p| %.3g mm, rotation %.3g mrad" % (
        ", ".join(frames), len(finite), max([p for p, _ in finite], default=0.0),
        max([r for _, r in finite], default=0.0))
    return [tracking, "task: %d rows of %s" % (len(columns["t"]), ", ".join(frames))], right


def forces_panels(axes, path, joint_names):
    header, columns = load(path)
    joints = len(indexed(header, r"tau_applied_(\d+)"))
    rows = [r for r in FORCE_ROWS if r[0] not in OPTIONAL_FORCE_ROWS or "%s_0" % r[0] in columns]
    missing = [n for n in ["t"] + ["%s_%d" % (row, j) for row, _, _ in rows for j in range(joints)]
               if n not in columns]
    if missing or joints != len(axes):
        fail("%s lacks the columns %s (a *_FORCES.csv from log2csv)" % (path, ", ".join(missing[:3]) or "tau_applied_0.."))
    t, gap = series(path, columns)
    drawn = []
    for row, flag, label in rows:
        on = numbers(columns, flag, path) if flag else [1.0] * len(t)
        if not any(on):
            continue  # off throughout: not computed, not drawn
        drawn.append(row)
        for j, axis in enumerate(axes):
            values = [v if o else math.nan for v, o in zip(numbers(columns, "%s_%d" % (row, j), path), on)]
            axis.plot(t, gap(values), label=label, linewidth=1.2 if row != "tau_cmd" else 0.9,
                      linestyle="--" if row == "tau_cmd" else "-")
    joint = joint_names if joint_names and len(joint_names) == joints else ["joint %d" % j for j in range(joints)]
    for j, axis in enumerate(axes):
        axis.set_ylabel("%s (N·m or N)" % joint[j])
        axis.set_title("%s: M qdd = tau_applied + disturbance + damping + friction + limits + constraint - C qd - G"
                       % joint[j])
    return "forces: %d rows of %s" % (len(columns["t"]), ", ".join(drawn))


MPC_PLANS_DRAWN = 12  # predicted paths in the mpc panel: more would hide the actual one


def mpc_panel(axis, path, draw, state_columns, state_path, q, joint, colors):
    """Each joint's actual path (solid) and the paths the optimiser's plans predicted for it (dotted,
    their knots marked), for up to MPC_PLANS_DRAWN followed plans evenly chosen; the summary line."""
    header, columns = load(path)
    knots = indexed(header, r"knot_t(\d+)")
    missing = [n for n in ("t", "plan", "followed", "num_states") if n not in columns]
    if missing or not knots:
        fail("%s lacks the columns %s (a *_MPC.csv from log2csv)" % (path, ", ".join(missing) or "knot_t0.."))
    states = int(numbers(columns, "num_states", path)[0])
    if states != 2 * len(q):
        fail("%s plans %d states, the state CSV has %d joints" % (path, states, len(q)))
    for i, name in enumerate(q):
        draw(axis, joint[i], numbers(state_columns, name, state_path), color=colors[i % len(colors)])
    t_end = max(numbers(state_columns, "t", state_path))
    followed = [k for k, f in enumerate(numbers(columns, "followed", path)) if f]
    count = min(len(followed), MPC_PLANS_DRAWN)
    chosen = [followed[round(j * (len(followed) - 1) / max(count - 1, 1))] for j in range(count)]
    times = [numbers(columns, name, path) for name in knots]
    for i in range(len(q)):
        values = [numbers(columns, "knot%d_x_%d" % (j, i), path) for j in range(len(knots))]
        for c, row in enumerate(chosen):
            points = [(times[j][row], values[j][row]) for j in range(len(knots)) if times[j][row] <= t_end]
            axis.plot([p[0] for p in points], [p[1] for p in points], linestyle=":", marker=".", markersize=3,
                      linewidth=1.0, color=colors[i % len(colors)], alpha=0.8,
                      label=joint[i] + " predicted" if c == 0 else None)
    axis.set_ylabel("q, planned q (rad or m)")
    axis.set_title("mpc: actual path (solid) and the optimiser's predicted paths (dotted, %d of %d plans)"
                   % (count, len(columns["t"])))
    return "mpc: %d plans (%d followed), %d drawn" % (len(columns["t"]), len(followed), count)


LEGEND_ROWS = 8  # entries in one column of a legend: eight fit beside a panel


def place_legends(fig, axes, twins):
    """Each panel's legend outside every panel's data: to the right of the
    panels, all in one column past the widest right-hand axis (the cost
    panel's, the task error panel's: ticks and label), each level with its
    panel's top. `twins` maps a panel
    to its right-hand axis, whose lines join the panel's legend. The figure
    is laid out afterwards (tight_layout counts the legends in)."""
    import matplotlib.transforms
    renderer = fig.canvas.get_renderer()
    past = max([0.0] + [twin.get_tightbbox(renderer).x1 - twin.get_window_extent(renderer).x1
                        for twin in twins.values()])
    # In inches, so the column stays put whatever the layout does to the panels' size.
    shift = matplotlib.transforms.ScaledTranslation(past / fig.dpi + 0.1, 0, fig.dpi_scale_trans)
    for axis in axes:
        handles, labels = axis.get_legend_handles_labels()
        if axis in twins:
            more_handles, more_labels = twins[axis].get_legend_handles_labels()
            handles, labels = handles + more_handles, labels + more_labels
        if handles:
            axis.legend(handles, labels, loc="upper left", bbox_to_anchor=(1, 1),
                        bbox_transform=axis.transAxes + shift, borderaxespad=0, fontsize="small",
                        ncol=math.ceil(len(handles) / LEGEND_ROWS))


def by_instance(text):
    """'arm=a;cartpole=b' (log2csv's per-instance status columns) -> {'arm': 'a', 'cartpole': 'b'}."""
    out = {}
    for part in text.split(";"):
        name, _, value = part.partition("=")
        if name:
            out[name] = value
    return out


def status_facts(status_path, state_path, state_columns, joints):
    """From the daemon's status CSV: the instance's joint names (None when it names none
    or not `joints` of them) and [(t, label)] at each change of its integrator or method,
    placed at the first state row logged after the status that showed it."""
    header, columns = load(status_path)
    if any(n not in columns for n in ("log_utime", "integrators", "methods", "joints")):
        fail("%s lacks the columns log_utime, integrators, methods, joints (LAGRANGE_STATUS.csv from log2csv)"
             % status_path)
    base = os.path.basename(state_path)
    base = base[:-len("_STATE.csv")] if base.endswith("_STATE.csv") else ""
    names = set()
    for text in columns["integrators"]:
        names.update(by_instance(text))
    matches = [n for n in names if base.upper().endswith(n.upper())]
    if not matches:
        return None, []
    instance = max(matches, key=len)
    joint_names = None
    for text in columns["joints"]:
        listed = by_instance(text).get(instance, "")
        if listed and len(listed.split(",")) == joints:
            joint_names = listed.split(",")
            break
    switches = []
    if "log_utime" in state_columns:
        state_utime = numbers(state_columns, "log_utime", state_path)
        state_t = numbers(state_columns, "t", state_path)
        previous = None
        for utime, integrators, methods in zip(columns["log_utime"], columns["integrators"], columns["methods"]):
            now = {"integrator": by_instance(integrators).get(instance), "method": by_instance(methods).get(instance)}
            if previous is not None and now != previous:
                at = bisect.bisect_left(state_utime, float(utime))
                if at < len(state_t):
                    label = ", ".join("%s %s" % (k, now[k]) for k in ("integrator", "method") if now[k] != previous[k])
                    switches.append((state_t[at], label))
            previous = now
    return joint_names, switches


def named_joints(path, joints):
    """A simulate CSV's joint names from its FILE.joints.csv (columns joint, name:
    tools/log_csv.hpp); None when it does not name joints 0 .. `joints` - 1 in
    order (the CSV was written again since, by something else)."""
    header, columns = load(path)
    if "joint" not in columns or "name" not in columns:
        fail("%s lacks the columns joint, name (a FILE.joints.csv from lagrangectl simulate)" % path)
    if columns["joint"] != [str(i) for i in range(joints)]:
        return None
    return columns["name"]


BASE_COLUMNS = ["position2", "com2"] + ["orientation%d" % i for i in range(4)] + \
    ["linear_momentum%d" % i for i in range(3)] + ["angular_momentum%d" % i for i in range(3)]


def base_columns(path):
    """A base CSV's columns (log2csv of <NAME>_BASE), checked."""
    header, columns = load(path)
    missing = [n for n in ["t"] + BASE_COLUMNS if n not in columns]
    if missing:
        fail("%s lacks the columns %s (a *_BASE.csv from log2csv)" % (path, ", ".join(missing[:3])))
    return columns


def base_panels(axes, draw, columns, path):
    """A floating base's three panels (simulate's base columns, or a base CSV's with `draw` on its own time
    axis): the base's and the centre of mass's height, the base's quaternion, the momentum's magnitudes
    (linear, and angular about the centre of mass)."""
    z = numbers(columns, "position2", path)
    draw(axes[0], "base z", z)
    draw(axes[0], "centre of mass z", numbers(columns, "com2", path))
    axes[0].set_ylabel("height (m)")
    axes[0].set_title("floating base: the base origin's and the centre of mass's height")
    for i, name in enumerate("xyzw"):
        draw(axes[1], "q" + name, numbers(columns, "orientation%d" % i, path))
    axes[1].set_ylabel("quaternion")
    axes[1].set_title("the base's orientation (unit quaternion x, y, z, w)")

    def norm(prefix):
        rows = zip(*(numbers(columns, "%s%d" % (prefix, i), path) for i in range(3)))
        return [math.sqrt(a * a + b * b + c * c) for a, b, c in rows]

    draw(axes[2], "|p| (N·s)", norm("linear_momentum"))
    draw(axes[2], "|L about com| (N·m·s)", norm("angular_momentum"))
    axes[2].set_ylabel("momentum")
    axes[2].set_title("the momentum's magnitude: linear, and angular about the centre of mass")
    finite = [v for v in z if not math.isnan(v)]
    return "base: %d rows, height %.4g to %.4g m" % (len(z), finite[0], finite[-1])


def joint_tracking_panel(axis, draw, columns, path, q, qdes, joint, colors, followed):
    """q_des - q on the rows where a controller followed q_des (a gap elsewhere); the summary line
    when some row did not follow it (None when every row did: the common case says nothing)."""
    worst = 0.0
    for i, (qn, dn) in enumerate(zip(q, qdes)):
        err = [d - x if f else math.nan
               for d, x, f in zip(numbers(columns, dn, path), numbers(columns, qn, path), followed)]
        worst = max([worst] + [abs(e) for e in err if math.isfinite(e)])
        draw(axis, joint[i], err, color=colors[i % len(colors)])
    axis.set_ylabel("q_des - q (rad or m)")
    axis.set_title("tracking error: q_des − q (where a controller followed the joint setpoint)")
    count = sum(followed)
    if count == 0:
        axis.text(0.5, 0.5, "no row followed the joint setpoint (the external controller's torques came from the bus)",
                  transform=axis.transAxes, ha="center", va="center", color="dimgray")
        return "tracking: none (no row followed a joint setpoint or a task target)"
    if count == len(followed):
        return None
    return "tracking: joints to q_des on %d of %d rows, max |q_des - q| %.3g" % (count, len(followed), worst)


def main():
    if len(sys.argv) not in (4, 6, 7, 8, 9, 10, 11, 12):
        fail("usage: plot.py CSV PNG TITLE [TELEMETRY_CSV FORCES_CSV [STATUS_CSV [JOINTS_CSV [TASK_CSV [TASK_SPACE "
             "[MPC_CSV [BASE_CSV]]]]]]]")
    path, png, title = sys.argv[1:4]
    telemetry, forces = sys.argv[4:6] if len(sys.argv) >= 6 else ("", "")
    status = sys.argv[6] if len(sys.argv) >= 7 else ""
    joints_csv = sys.argv[7] if len(sys.argv) >= 8 else ""
    task = sys.argv[8] if len(sys.argv) >= 9 else ""
    task_space_names = set(filter(None, sys.argv[9].split(","))) if len(sys.argv) >= 10 else set()
    mpc = sys.argv[10] if len(sys.argv) >= 11 else ""
    base_csv = sys.argv[11] if len(sys.argv) >= 12 else ""
    header, columns = load(path)
    q = indexed(header, r"q(\d+)")
    qdes = indexed(header, r"q_des(\d+)")
    tau = indexed(header, r"tau(\d+)")
    kinetic, potential = "kinetic_energy", "potential_energy"  # simulate's and log2csv's names (tools/log_csv.hpp)
    missing = [n for n, ok in (("t", "t" in columns), ("q0..", bool(q)), ("q_des0..", len(qdes) == len(q) and q),
                               ("tau0..", len(tau) == len(q) and q), (kinetic, kinetic in columns),
                               (potential, potential in columns)) if not ok]
    if missing:
        fail("%s lacks the columns %s (a CSV from lagrangectl simulate, or a *_STATE.csv from log2csv)"
             % (path, ", ".join(missing)))
    task_columns = load_task(task) if task else None
    followed = followed_rows(columns, task_rows(columns, task_columns, task_space_names))

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = numbers(columns, "t", path)
    starts = segment_starts(columns, t, path)
    t_gapped = with_gaps(t, starts)

    def draw(axis, name, values, **style):
        axis.plot(t_gapped, with_gaps(values, starts), label=name, linewidth=1.2, **style)

    # The tracking panels follow the energy: the joints' (unless only a task target was tracked), the task's two.
    force_joints = len(indexed(load(forces)[0], r"tau_applied_(\d+)")) if forces else 0
    joint_tracking = any(followed) or not task
    task_at = 3 + (1 if joint_tracking else 0)
    telemetry_at = task_at + (2 if task else 0)
    mpc_at = telemetry_at + (2 if telemetry else 0)
    # A floating base's columns: simulate's in the CSV, or a log's <NAME>_BASE beside its state.
    base_source = base_columns(base_csv) if base_csv else None
    base = base_source is not None or all(c in columns for c in BASE_COLUMNS)
    base_at = mpc_at + (1 if mpc else 0)
    panels = base_at + (3 if base else 0) + force_joints
    # The legends stand beside the panels (place_legends): 2.5 in wider than the panels alone were.
    fig, axes = plt.subplots(panels, 1, sharex=True, figsize=(12.5, 2.75 * panels), squeeze=False)
    axes = [row[0] for row in axes]
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    joint_names, switches = status_facts(status, path, columns, len(q)) if status else (None, [])
    if joints_csv:
        joint_names = named_joints(joints_csv, len(q)) or joint_names
    joint = joint_names or ["q%d" % i for i in range(len(q))]
    for i, (qn, dn) in enumerate(zip(q, qdes)):
        color = colors[i % len(colors)]
        draw(axes[0], joint[i], numbers(columns, qn, path), color=color)
        if any(followed):
            setpoint = [d if f else math.nan for d, f in zip(numbers(columns, dn, path), followed)]
            draw(axes[0], joint[i] + " setpoint", setpoint, color=color, linestyle="--")
    axes[0].set_ylabel("q, q_des (rad or m)")
    axes[0].set_title("joint positions (solid) and setpoints (dashed, where a controller followed them)"
                      if any(followed) else "joint positions (no controller followed a joint setpoint)")
    # A segment's first row carries no applied torque yet (a row's tau is the
    # one held over the tick that led to it): not drawn, so no line from 0.
    first_rows = set(starts)
    for i, name in enumerate(tau):
        values = [math.nan if k in first_rows else v for k, v in enumerate(numbers(columns, name, path))]
        draw(axes[1], joint[i], values, color=colors[i % len(colors)])
    axes[1].set_ylabel("tau (N·m or N)")
    axes[1].set_title("applied generalized forces")
    T = numbers(columns, kinetic, path)
    V = numbers(columns, potential, path)
    draw(axes[2], "T", T)
    draw(axes[2], "V", V)
    draw(axes[2], "E", [a + b for a, b in zip(T, V)], color="black")
    axes[2].set_ylabel("energy (J)")
    axes[2].set_title("kinetic T, potential V and total E")
    extra, twins = [], {}
    if joint_tracking:
        line = joint_tracking_panel(axes[3], draw, columns, path, q, qdes, joint, colors, followed)
        extra += [line] if line else []
    if task:
        lines, twins[axes[task_at]] = task_panels(axes[task_at:task_at + 2], task, task_columns)
        extra += lines
    if telemetry:
        line, twins[axes[telemetry_at + 1]] = telemetry_panels(axes[telemetry_at:telemetry_at + 2], telemetry)
        extra.append(line)
    if mpc:
        extra.append(mpc_panel(axes[mpc_at], mpc, draw, columns, path, q, joint, colors))
    if base and base_source is not None:
        base_t, base_gap = series(base_csv, base_source)

        def draw_base(axis, name, values, **style):
            axis.plot(base_t, base_gap(values), label=name, linewidth=1.2, **style)

        extra.append(base_panels(axes[base_at:base_at + 3], draw_base, base_source, base_csv))
    elif base:
        extra.append(base_panels(axes[base_at:base_at + 3], draw, columns, path))
    if forces:
        extra.append(forces_panels(axes[panels - force_joints:], forces, joint_names))
    axes[-1].set_xlabel("t (s)")
    for t_switch, label in switches:
        for axis in axes:
            axis.axvline(t_switch, color="dimgray", linestyle=":", linewidth=1.0)
        axes[0].annotate(label, xy=(t_switch, 1.0), xycoords=("data", "axes fraction"), xytext=(2, -2),
                         textcoords="offset points", va="top", fontsize="small", color="dimgray")
    for axis in axes:
        axis.grid(True, alpha=0.3)
    place_legends(fig, axes, twins)
    fig.suptitle(title)
    fig.tight_layout(rect=(0, 0, 1, 1 - 0.3 / fig.get_figheight()))  # 0.3 in kept for the title however tall
    try:
        fig.savefig(png, dpi=80)
    except OSError as e:
        fail("cannot write %s: %s" % (png, e.strerror))
    print("%d rows in %d segment%s" % (len(t), len(starts), "" if len(starts) == 1 else "s"))
    if joint_names:
        print("joints: " + ", ".join(joint_names))
    for line in extra:
        print(line)


try:
    main()
except Exception as e:  # anything unforeseen is still one line
    fail("%s: %s" % (type(e).__name__, e))
