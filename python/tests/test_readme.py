"""The README's Python commands, run as written with this package's interpreter.

The `$ rom` commands of the documentation are run by `cli/tests/docs.rs`; its `$ python`
lines need the installed package, so they are run here.
"""

import shlex
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def python_commands(page):
    """(command, shown output) for each `$ python` line of the page's console blocks."""
    found, lines = [], page.read_text().splitlines()
    in_console = False
    for i, line in enumerate(lines):
        if line.startswith("```"):
            in_console = not in_console and line[3:].startswith("console")
        elif in_console and line.startswith("$ python "):
            out = []
            for later in lines[i + 1 :]:
                if later.startswith("$ ") or later.startswith("```"):
                    break
                out.append(later)
            found.append((line[2:], "\n".join(out)))
    return found


def test_the_readme_python_commands_print_what_it_shows():
    commands = python_commands(REPO / "README.md")
    assert commands, "README.md shows no `$ python` command"
    for command, shown in commands:
        args = shlex.split(command)
        p = subprocess.run([sys.executable, *args[1:]], capture_output=True, text=True, cwd=REPO)
        assert p.returncode == 0, f"{command}: {p.stderr}"
        assert p.stdout.rstrip("\n") == shown, f"{command} printed {p.stdout!r}, README shows {shown!r}"
