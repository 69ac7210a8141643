"""The documents' commands and scripts run as written: docs/tutorial.md from its first command to
its last, and the README's Python lines.

The tutorial's fenced blocks are read in order:
  ```yaml file=NAME / ```python file=NAME   written to NAME in a fresh folder;
  ```sh                                      each line a command, run there as an argument vector
                                             (no shell): `multibond ...` is the built CLI,
                                             `python3 ...` this interpreter (with the build's
                                             module on PYTHONPATH); `export` lines set up a
                                             reader's shell and are skipped; a trailing
                                             `# exit N` is the exit status it must give (else 0);
  ```text right after an sh block            what those commands print: every line but `...` must
                                             appear, in order, within the lines of their output
                                             (stdout and stderr; a trailing ` ...` marks a line
                                             shown in part).
"""

import os
import re
import shlex
import subprocess
import sys

import pytest

from conftest import CLI, SOURCE

FENCE = re.compile(r"^```([a-z]*)([^\n]*)\n(.*?)^```\s*$", re.S | re.M)


def blocks(path):
    """(language, info, body) of every fenced block of the document, in order."""
    return [(m.group(1), m.group(2).strip(), m.group(3)) for m in FENCE.finditer(path.read_text())]


def run_line(line, cwd):
    """Runs one command line of an sh block; returns (expected exit, completed process)."""
    expected = 0
    m = re.search(r"\s#\s*exit (\d+)\s*$", line)
    if m:
        expected = int(m.group(1))
    words = shlex.split(line, comments=True)
    if words[0] == "multibond":
        argv = [CLI, *words[1:]]
    elif words[0] == "python3":
        argv = [sys.executable, *words[1:]]
    else:
        raise AssertionError(f"the tutorial runs multibond and python3 only: {line!r}")
    env = dict(os.environ, MULTIBOND_JIT_KEEP="0")
    return expected, subprocess.run(argv, cwd=cwd, capture_output=True, text=True, timeout=300, env=env)


def expect_in_order(shown, output, where):
    lines = [l.strip() for l in output.splitlines()]
    at = 0
    for want in shown.splitlines():
        want = want.strip()
        if not want or want == "...":
            continue
        if want.endswith(" ..."):
            want = want[:-4].rstrip()
        while at < len(lines) and want not in lines[at]:
            at += 1
        assert at < len(lines), f"{where}: the output has no line with {want!r} (in order); it was:\n{output}"
        at += 1


def test_the_tutorial_runs_as_written(tmp_path):
    doc = SOURCE / "docs/tutorial.md"
    commands = 0
    files = 0
    pending = None  # the output of the last sh block, until a text block is compared with it
    for lang, info, body in blocks(doc):
        if info.startswith("file="):
            (tmp_path / info[len("file="):]).write_text(body)
            files += 1
        elif lang == "sh":
            output = ""
            for line in body.splitlines():
                if not line.strip() or line.startswith("export ") or line.lstrip().startswith("#"):
                    continue
                expected, p = run_line(line, tmp_path)
                assert p.returncode == expected, f"{line}: exit {p.returncode}, expected {expected}\n{p.stdout}\n{p.stderr}"
                output += p.stdout + p.stderr
                commands += 1
            pending = (body.strip(), output)
        elif lang == "text":
            assert pending is not None, "a text block follows no sh block"
            expect_in_order(body, pending[1], pending[0])
            pending = None
    # The tutorial's scripts ran (their asserts are the closed-form checks) and wrote their folders.
    assert files >= 5 and commands >= 10, (files, commands)
    for d in ("run1", "run2", "run3", "modes2", "modes3", "sweep1"):
        assert (tmp_path / d).is_dir(), d
    assert (tmp_path / "run3/index.html").is_file()


def test_the_readme_python_lines_run_as_written():
    """The README's Python block, verbatim, from the repository's root (its paths are relative
    to it), with the module the build made: the README's PYTHONPATH=build/main/python names the
    same folder of the main preset's build."""
    text = (SOURCE / "README.md").read_text()
    m = re.search(r"## Using it from Python\n```python\n(.*?)^```", text, re.S | re.M)
    assert m, "README.md has no Python block under 'Using it from Python'"
    code = m.group(1)
    assert "PYTHONPATH=build/main/python /usr/bin/python3" in code
    p = subprocess.run([sys.executable, "-c", code], cwd=SOURCE, capture_output=True, text=True, timeout=300,
                       env=dict(os.environ, MULTIBOND_JIT_KEEP="0"))
    assert p.returncode == 0, p.stderr
    # The build's module folder is <build>/python, as the README's line says for build/main.
    assert os.environ["PYTHONPATH"].split(os.pathsep)[0].rstrip("/").endswith("/python")
