"""The package refuses, with one sentence, an interpreter it was not built for."""
import subprocess
import sys

import lagrange


def test_the_package_names_the_interpreter_it_was_built_for():
    assert lagrange.python_version == "%d.%d" % sys.version_info[:2]
    assert lagrange.python_executable == sys.executable or sys.executable.endswith("python3")


def test_an_interpreter_without_numpy_gets_an_import_error_naming_the_right_interpreter():
    # numpy made unimportable, as under a pyenv shim without it: an ImportError, never a crash.
    code = "import sys; sys.modules['numpy'] = None; import lagrange"
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 1
    last = r.stderr.strip().splitlines()[-1]
    assert last.startswith("ImportError: lagrange needs numpy")
    assert lagrange.python_executable in last
