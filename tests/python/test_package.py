"""The installed package: its typing (the stub file and py.typed), the console script and
`python -m keypose` running the command line."""

import ast
import signal
import subprocess
import sys
from pathlib import Path

import keypose
from conftest import cli, keypose_command, repo

PACKAGE = Path(keypose.__file__).parent


def test_the_package_is_typed():
    assert (PACKAGE / "py.typed").exists()
    assert (PACKAGE / "__init__.pyi").exists()


def _stub_classes():
    tree = ast.parse((PACKAGE / "__init__.pyi").read_text())
    classes = {}
    functions = set()
    for node in tree.body:
        if isinstance(node, ast.ClassDef):
            classes[node.name] = {
                n.name for n in node.body if isinstance(n, ast.FunctionDef) and n.name != "__init__"
            } | {n.target.id for n in node.body if isinstance(n, ast.AnnAssign)}
        elif isinstance(node, ast.FunctionDef):
            functions.add(node.name)
    return classes, functions


def test_the_stub_types_every_public_name_and_nothing_else():
    classes, functions = _stub_classes()
    public = set(keypose.__all__) - {"__version__"}
    assert set(classes) | functions == public
    for name, members in classes.items():
        cls = getattr(keypose, name)
        if issubclass(cls, BaseException):
            continue  # exception attributes are set on each instance
        runtime = {m for m in dir(cls) if not m.startswith("_")}
        assert members == runtime, name


def test_the_console_script_is_the_command_line():
    out = cli("--version", check_code=0)
    assert out.stdout == f"keypose {keypose.__version__}\n"
    assert cli("check", repo("sequences/so101_wave.json"), check_code=0).stdout.startswith(
        f"{repo('sequences/so101_wave.json')}: robot so101 (built-in)"
    )
    assert "Usage:" in cli("check", check_code=2).stderr


def test_python_dash_m_keypose_runs_it_too():
    done = subprocess.run(
        [sys.executable, "-m", "keypose", "--version"], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0 and done.stdout == f"keypose {keypose.__version__}\n"


def test_the_command_lines_exit_codes_come_through(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text("{")
    assert cli("check", bad).returncode == 2
    assert keypose_command().name == "keypose"


def test_the_packages_version_is_the_crates():
    text = repo("Cargo.toml").read_text()
    package = text.split("[package]", 1)[1].split("\n[", 1)[0]
    (line,) = [l for l in package.splitlines() if l.startswith("version")]
    assert keypose.__version__ == line.split("=", 1)[1].strip().strip('"')


def test_ctrl_c_stops_the_console_scripts_playback_softly():
    # The command line handles SIGINT itself inside the Python process: the arm (emulated
    # servos behind the real serial code) brakes along its path and the exit code is 130.
    process = subprocess.Popen(
        [str(keypose_command()), "play", str(repo("sequences/so101_wave.json")), "--port", "virtual"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    seen = b""
    try:
        # The progress line shows once playback runs; then the stop request.
        while b"loop 1/1" not in seen:
            chunk = process.stderr.read1(4096)
            assert chunk, f"keypose play ended before playing: {seen.decode(errors='replace')}"
            seen += chunk
        process.send_signal(signal.SIGINT)
        out, err = process.communicate(timeout=600)
    finally:
        if process.poll() is None:
            process.kill()
    said = (seen + err + out).decode(errors="replace")
    assert process.returncode == 130, said[-2000:]
    assert "stopped on request: the arm decelerated along its path" in said
