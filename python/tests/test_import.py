"""What an interpreter that cannot run the module is told (#43: the first python3 on a typical
PATH, a pyenv or venv one, has no NumPy or another version than the one the module is built for)."""

import os
import subprocess
import sys


def _import_in_a_fresh_interpreter(prelude):
    code = prelude + "\nimport multibond\n"
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, env=os.environ)


def test_the_readmes_line_imports_the_module():
    r = _import_in_a_fresh_interpreter("")
    assert r.returncode == 0, r.stderr


def test_an_interpreter_without_numpy_is_told_which_it_is_and_what_to_do():
    r = _import_in_a_fresh_interpreter("import sys; sys.modules['numpy'] = None")
    assert r.returncode != 0
    assert "multibond needs NumPy" in r.stderr
    assert sys.executable in r.stderr
    assert "/usr/bin/python3" in r.stderr and "python3-numpy" in r.stderr


def test_a_compiled_module_that_does_not_load_names_the_interpreter_it_was_built_for():
    r = _import_in_a_fresh_interpreter("import sys; sys.modules['multibond._multibond'] = None")
    assert r.returncode != 0
    assert "does not load into this Python" in r.stderr
    assert "_multibond" in r.stderr and ".so" in r.stderr
    assert "/usr/bin/python3" in r.stderr
