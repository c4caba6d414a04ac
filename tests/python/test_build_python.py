"""The quick start's build/ gains the Python module without compiling any library again (issue 32).

scripts/run-daemon configures a fresh build/ without the module; scripts/build-python turns it on there and
builds its target. The libraries are position-independent in every build/ (CMakeLists.txt), so turning the
module on changes no library's compile command: the build (Make or Ninja) compiles python/'s own files alone. The two configure
commands are read from the scripts themselves and run on a scratch tree (configure only: seconds).
"""
import json
import os
import re
import shlex
import shutil
import subprocess
import time

from bus_support import SOURCE


def configure_command(script, fresh):
    """The script's `cmake -S . -B build ...` line for a fresh build/ (fresh) or one configured before."""
    with open(os.path.join(SOURCE, "scripts", script)) as f:
        lines = [line.strip() for line in f if line.strip().startswith("cmake -S . -B build")]
    line = next(line for line in lines if ("CMAKE_BUILD_TYPE" in line) == fresh)
    return shlex.split(line)


def run(command, tree):
    args = [SOURCE if a == "." and command[k - 1] == "-S" else tree if a == "build" and command[k - 1] == "-B" else a
            for k, a in enumerate(command)]
    r = subprocess.run(args, capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr


def library_flags(tree):
    """{object of a lagrange library: its compile command}, from the tree's compile_commands.json (any generator:
    Make and Ninja alike recompile an object exactly when its command changes)."""
    with open(os.path.join(tree, "compile_commands.json")) as f:
        entries = json.load(f)
    out = {}
    for e in entries:
        m = re.search(r" -o (\S*CMakeFiles/(lagrange_[a-z_]+)\.dir/\S+)", e["command"])
        if m:
            out[(m.group(2), m.group(1))] = e["command"]
    return out


def libraries(flags):
    return {library for library, _ in flags}


def test_turning_the_module_on_in_a_run_daemon_tree_compiles_no_library_again(tmp_path):
    tree = str(tmp_path / "build")
    run(configure_command("run-daemon", fresh=True), tree)
    before = library_flags(tree)
    assert {"lagrange_plant", "lagrange_protocol", "lagrange_daemon"} <= libraries(before)
    assert not os.path.exists(os.path.join(tree, "python", "CMakeFiles", "_lagrange.dir"))
    run(configure_command("build-python", fresh=False), tree)
    assert os.path.exists(os.path.join(tree, "python", "CMakeFiles", "_lagrange.dir")), "no module target"
    assert library_flags(tree) == before  # the same commands: nothing of a library to recompile
    for (library, output), command in before.items():
        words = shlex.split(command)
        assert "-fPIC" in words and "-fno-semantic-interposition" in words, output


def test_a_fresh_build_python_configures_build_as_run_daemon_does_with_the_module_on():
    # So a later scripts/run-daemon brings the same tree up to date (programs, no tests, no benchmarks).
    daemon = configure_command("run-daemon", fresh=True)
    python = configure_command("build-python", fresh=True)
    assert [a for a in daemon if "LAGRANGE_BUILD_PYTHON" not in a] == \
        [a for a in python if "LAGRANGE_BUILD_PYTHON" not in a]
    assert "-DLAGRANGE_BUILD_PYTHON=OFF" in daemon and "-DLAGRANGE_BUILD_PYTHON=ON" in python


# scripts/run-daemon starts lagranged before the other programs are built, and the builds of build/ never overlap.
# Both scripts run as written on a scratch copy of scripts/, with a stand-in `cmake` first on PATH that records what
# it was asked to build, at which priority and whether build/.build-lock was held; the stand-in lagranged records
# what existed when it started. (setup-deps runs for real: with the packages installed it only checks them.)
FAKE_CMAKE = r"""#!/bin/bash
log="$FAKE_LOG"
locked() { flock -n build/.build-lock true && echo no || echo yes; }
if [ "$1" = -S ]; then
  mkdir -p build
  printf 'LAGRANGE_BUILD_TESTS:BOOL=OFF\nPython_EXECUTABLE:FILEPATH=/bin/true\n' > build/CMakeCache.txt
  echo "configure locked=$(locked)" >> "$log"
elif [[ " $* " == *" --target lagranged "* ]]; then
  echo "build lagranged locked=$(locked)" >> "$log"
  mkdir -p build/daemon
  cp "$FAKE_DAEMON" build/daemon/lagranged
elif [[ " $* " == *" --target "* ]]; then
  echo "build ${*: -1} locked=$(locked)" >> "$log"
  mkdir -p build/python/lagrange
else
  echo "build rest nice=$(ps -o ni= -p $$ | tr -d ' ') locked=$(locked)" >> "$log"
  sleep "${FAKE_REST_SECONDS:-0.5}"
  mkdir -p build/tools && touch build/tools/lagrangectl
  echo "rest built" >> "$log"
fi
"""

FAKE_DAEMON = r"""#!/bin/bash
tools=no; [ -e build/tools/lagrangectl ] && tools=yes
echo "lagranged $* lagrangectl=$tools lock-descriptors=$(ls -l /proc/$$/fd | grep -c build-lock)" >> "$FAKE_LOG"
for _ in $(seq 100); do [ -e build/tools/lagrangectl ] && break; sleep 0.1; done
"""


def scratch_checkout(tmp_path):
    root = tmp_path / "checkout"
    shutil.copytree(os.path.join(SOURCE, "scripts"), root / "scripts")
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    for name, text in (("cmake", FAKE_CMAKE), ("lagranged", FAKE_DAEMON)):
        (bin_dir / name).write_text(text)
        (bin_dir / name).chmod(0o755)
    log = tmp_path / "log"
    env = dict(os.environ, PATH=f"{bin_dir}:{os.environ['PATH']}", FAKE_LOG=str(log),
               FAKE_DAEMON=str(bin_dir / "lagranged"))
    return root, env, log


def test_run_daemon_starts_lagranged_before_the_other_programs_and_builds_them_after_at_the_lowest_priority(tmp_path):
    root, env, log = scratch_checkout(tmp_path)
    r = subprocess.run([str(root / "scripts" / "run-daemon"), "--config", "config/default.yaml"], env=env,
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stdout + r.stderr
    lines = log.read_text().splitlines()
    assert lines[0] == "configure locked=yes"
    assert lines[1] == "build lagranged locked=yes"
    started = next(k for k, line in enumerate(lines) if line.startswith("lagranged "))
    # The daemon gets its arguments, starts with no lagrangectl built yet and holds no lock descriptor.
    assert lines[started] == "lagranged --config config/default.yaml lagrangectl=no lock-descriptors=0"
    assert "build rest nice=19 locked=yes" in lines
    assert lines.index("rest built") > started
    assert "run-daemon: the other programs are built" in r.stderr


def test_build_python_waits_for_run_daemons_background_build_of_build(tmp_path):
    root, env, log = scratch_checkout(tmp_path)
    env["FAKE_REST_SECONDS"] = "3"
    daemon = subprocess.Popen([str(root / "scripts" / "run-daemon")], env=env, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)
    try:
        for _ in range(200):
            if log.exists() and "build rest" in log.read_text():
                break
            time.sleep(0.05)
        assert "build rest" in log.read_text(), log.read_text()
        python = subprocess.run([str(root / "scripts" / "build-python")], env=env, capture_output=True, text=True,
                                timeout=60)
        assert python.returncode == 0, python.stdout + python.stderr
        assert "waiting for another build of build/ to finish" in python.stderr
        lines = log.read_text().splitlines()
        # build-python configured and built only after the background build had ended, holding the lock itself.
        after = lines[lines.index("rest built") + 1:]
        assert "configure locked=yes" in after and "build _lagrange locked=yes" in after, lines
    finally:
        daemon.wait(timeout=30)
