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
import subprocess

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
