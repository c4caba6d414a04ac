"""The quick start's build/ gains the Python module without compiling any library again (issue 32).

scripts/run-daemon configures a fresh build/ without the module; scripts/build-python turns it on there and
builds its target. The libraries are position-independent in every build/ (CMakeLists.txt), so turning the
module on changes no library's compile flags: make compiles python/'s own files alone. The two configure
commands are read from the scripts themselves and run on a scratch tree (configure only: seconds).
"""
import glob
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
    """{library: (its flags.make, mtime)}: what every object of a lagrange library is compiled with."""
    out = {}
    for path in glob.glob(os.path.join(tree, "*", "CMakeFiles", "lagrange_*.dir", "flags.make")):
        with open(path) as f:
            out[os.path.basename(os.path.dirname(path))] = (f.read(), os.stat(path).st_mtime_ns)
    return out


def test_turning_the_module_on_in_a_run_daemon_tree_compiles_no_library_again(tmp_path):
    tree = str(tmp_path / "build")
    run(configure_command("run-daemon", fresh=True), tree)
    before = library_flags(tree)
    assert {"lagrange_plant.dir", "lagrange_protocol.dir", "lagrange_daemon.dir"} <= set(before)
    assert not os.path.exists(os.path.join(tree, "python", "CMakeFiles", "_lagrange.dir"))
    run(configure_command("build-python", fresh=False), tree)
    assert os.path.exists(os.path.join(tree, "python", "CMakeFiles", "_lagrange.dir")), "no module target"
    assert library_flags(tree) == before  # the same flags, the files untouched: make has nothing to recompile
    for name, (flags, _) in before.items():
        cxx = re.search(r"^CXX_FLAGS = (.*)$", flags, re.M).group(1).split()
        assert "-fPIC" in cxx and "-fno-semantic-interposition" in cxx, name


def test_a_fresh_build_python_configures_build_as_run_daemon_does_with_the_module_on():
    # So a later scripts/run-daemon brings the same tree up to date (programs, no tests, no benchmarks).
    daemon = configure_command("run-daemon", fresh=True)
    python = configure_command("build-python", fresh=True)
    assert [a for a in daemon if "LAGRANGE_BUILD_PYTHON" not in a] == \
        [a for a in python if "LAGRANGE_BUILD_PYTHON" not in a]
    assert "-DLAGRANGE_BUILD_PYTHON=OFF" in daemon and "-DLAGRANGE_BUILD_PYTHON=ON" in python
