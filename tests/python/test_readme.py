"""Every Python command in the README, and its two-daemon loop, run as written (issue 32), so a stale line fails here.

What runs, found in README.md itself (nothing listed here):
  - the "## Python" section: every fenced block, in order, as one shell session, as a user following it runs
    them: a ```python block by the interpreter the section names (PYTHONPATH=build/python /usr/bin/python3),
    any other block line by line by bash; a daemon a block starts with `&` lives on into the blocks after it,
    until a `kill $!`;
  - every other section: each fenced block in which a line runs python3, alone in a session of its own;
  - every inline `PYTHONPATH=build/python /usr/bin/python3 ...` command, alone.
Each session must exit 0 (bash -e: every line must succeed). It runs from a copy of the checkout (so what a
command writes, a CSV or a PNG, lands there) whose `build` is this build tree, with LCM on a private port of
this host (LCM_DEFAULT_URL: lagranged, lcm-logger and lagrange.Client() all take it) and no bus key.
"""
import os
import re
import shutil
import subprocess
import sys

import pytest

from bus_support import BUILD, SOURCE, prepare_loopback_multicast

PORT = 8501  # the README's daemons and clients, through LCM_DEFAULT_URL
PYTHON = "PYTHONPATH=build/python /usr/bin/python3"
SECTION_TIMEOUT = 300  # s: a command that hangs fails the test instead of holding CI


def readme_blocks(text):
    """[(section, kind, code)]: kind "python" or "shell" for a fenced block, "inline" for an inline command."""
    items, section, fence, lines = [], "", None, []
    for line in text.splitlines():
        if fence is not None:
            if line.startswith("```"):
                items.append((section, "python" if fence == "python" else "shell", "\n".join(lines) + "\n"))
                fence, lines = None, []
            else:
                lines.append(line)
            continue
        if line.startswith("```"):
            fence = line[3:].strip()
            continue
        if line.startswith("## "):
            section = line[3:].strip()
        for command in re.findall(r"`(%s [^`]*)`" % re.escape(PYTHON), line):
            if "…" not in command:
                items.append((section, "inline", command + "\n"))
    return items


def runs_python(code):
    return any(re.search(r"(^|\s|/)python3(\s|$)|PYTHONPATH=", line) for line in code.splitlines())


def sessions(text):
    """[(name, [(kind, code)])]: what runs together, in order."""
    out, python = [], []
    for section, kind, code in readme_blocks(text):
        if section == "Python" and kind != "inline":
            python.append((kind, code))
        elif kind == "python" or kind == "inline" or runs_python(code):
            out.append(("%s: %s" % (section, code.strip().splitlines()[0][:60]), [(kind, code)]))
    return [("Python", python)] + out


with open(os.path.join(SOURCE, "README.md")) as f:
    SESSIONS = sessions(f.read())


@pytest.fixture(scope="module")
def root(tmp_path_factory):
    """A copy of the checkout (without its build trees and .git) whose build/ is this build tree."""
    root = tmp_path_factory.mktemp("checkout")
    ignore = shutil.ignore_patterns(".git", "build*", "__pycache__")
    for entry in os.listdir(SOURCE):
        if entry == ".git" or entry.startswith("build"):
            continue
        source = os.path.join(SOURCE, entry)
        if os.path.isdir(source):
            shutil.copytree(source, root / entry, ignore=ignore, symlinks=True)
        else:
            shutil.copy2(source, root / entry)
    os.symlink(os.path.abspath(BUILD), root / "build")
    return root


def script(blocks, scratch):
    """The session as one bash script: shell lines as written, each python block a file the interpreter runs."""
    lines = ["set -e -o pipefail", "trap 'kill $(jobs -p) 2> /dev/null || true' EXIT"]
    for k, (kind, code) in enumerate(blocks):
        if kind == "python":
            path = os.path.join(scratch, "block%d.py" % k)
            with open(path, "w") as f:
                f.write(code)
            lines.append("%s %s" % (PYTHON, path))
        else:
            lines.append(code)
    return "\n".join(lines) + "\n"


def test_the_readme_has_python_commands_to_run():
    # The parser finds what it should: the Python section's blocks and the commands elsewhere.
    kinds = [kind for kind, _ in SESSIONS[0][1]]
    assert kinds.count("python") >= 3 and kinds.count("shell") >= 3
    assert any("python_bench.py" in code for _, blocks in SESSIONS for _, code in blocks)
    assert any("worst()" in code for _, blocks in SESSIONS for _, code in blocks)


@pytest.mark.parametrize("name,blocks", SESSIONS, ids=[s[0] for s in SESSIONS])
def test_the_readmes_python_commands_run_as_written(name, blocks, root, tmp_path):
    prepare_loopback_multicast()
    env = {k: v for k, v in os.environ.items() if k not in ("LAGRANGE_BUS_KEY_FILE", "PYTHONPATH")}
    env["LCM_DEFAULT_URL"] = "udpm://239.255.76.67:%d?ttl=0" % PORT
    r = subprocess.run(["bash", "-c", script(blocks, str(tmp_path))], cwd=root, env=env, capture_output=True,
                       text=True, timeout=SECTION_TIMEOUT)
    assert r.returncode == 0, "%s\n--- stdout\n%s\n--- stderr\n%s" % (name, r.stdout[-4000:], r.stderr[-4000:])


def two_daemon_block(text):
    """The README's two-daemon loop: the fenced block that starts the plant and the controller under CTRL_."""
    blocks = [code for _, kind, code in readme_blocks(text)
              if kind == "shell" and "arm_external_plant.yaml" in code and "--channel-prefix CTRL_" in code]
    assert len(blocks) == 1, "expected one block with the two-daemon loop, found %d" % len(blocks)
    return blocks[0]


def test_the_readmes_two_daemon_loop_runs_as_written(root, tmp_path):
    # Line by line as a user types them, on a private port: both daemons start (with the real-time options the
    # block sets; they warn and go on where not permitted), watch finds the controller's instance by the name the
    # block gives, and clear either re-arms it or is refused in lagranged's words (it re-arms only a stopped one).
    prepare_loopback_multicast()
    with open(os.path.join(SOURCE, "README.md")) as f:
        block = two_daemon_block(f.read())
    lines = [line for line in block.splitlines() if line.strip() and not line.lstrip().startswith("#")]
    watch = [k for k, line in enumerate(lines) if "lagrangectl watch" in line]
    clear = [k for k, line in enumerate(lines) if "lagrangectl command" in line and " clear" in line]
    assert len(watch) == 1 and len(clear) == 1, lines
    env = {k: v for k, v in os.environ.items() if k not in ("LAGRANGE_BUS_KEY_FILE", "PYTHONPATH")}
    env["LCM_DEFAULT_URL"] = "udpm://239.255.76.67:%d?ttl=0" % (PORT + 1)
    steps = ["trap 'kill $(jobs -p) 2> /dev/null || true' EXIT"]
    for k, line in enumerate(lines):
        steps.append(line)
        if k in (watch[0], clear[0]):
            steps.append("echo \"== exit $? after line %d\"" % k)
    r = subprocess.run(["bash", "-c", "\n".join(steps) + "\n"], cwd=root, env=env, capture_output=True, text=True,
                       timeout=SECTION_TIMEOUT)
    out = r.stdout + r.stderr
    assert "== exit 0 after line %d" % watch[0] in out, out[-4000:]
    assert re.search(r"arm_controller\s.*(running|stopped|waiting)", out), out[-4000:]  # watch's row of it
    cleared = "== exit 0 after line %d" % clear[0] in out
    assert cleared or "refused: clear" in out, out[-4000:]
