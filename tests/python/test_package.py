"""The installed package: its typing (the stub file and py.typed), the console script and
`python -m keypose` running the command line."""

import signal
import subprocess
import sys
from pathlib import Path

import keypose
from conftest import cli, keypose_command, repo

PACKAGE = Path(keypose.__file__).parent


def test_the_package_is_typed():
    assert (PACKAGE / "py.typed").exists()
    assert (PACKAGE / "_keypose.pyi").exists()


def test_the_stub_is_the_native_modules_as_mypys_stubtest_sees_it(tmp_path):
    # Every name, class, method, property and parameter of keypose._keypose against the stub
    # (mypy's cache goes to the test's own folder). keypose.teleop is left out: its classes
    # subclass LeRobot's, which ship no types, so mypy cannot see the dataclass fields they
    # inherit; tests/python/test_lerobot_teleop.py checks them against LeRobot itself.
    allowlist = tmp_path / "allowlist.txt"
    allowlist.write_text("keypose\\.teleop\\..*\n")
    done = subprocess.run(
        [sys.executable, "-m", "mypy.stubtest", "keypose", "--allowlist", str(allowlist)],
        capture_output=True, text=True, timeout=600, cwd=tmp_path,
    )
    assert done.returncode == 0, done.stdout + done.stderr


USER_CODE = """
import keypose
import numpy as np
import numpy.typing as npt

sequence: keypose.Sequence = keypose.load("wave.json", robot_id="my_follower")
t, q = sequence.sample(rate=30)
first: npt.NDArray[np.float64] = q[0]
report = sequence.check()
worst = max((v.excess for v in report.violations), default=0.0)
arm = keypose.Robot("so101")
joints = arm.solve([0.25, 0.0, 0.15], seed=arm.home)
x, y, z = arm.tool(joints).xyz
try:
    sequence.retime().save("out.json")
except keypose.InputError as error:
    print(error.path, error.reason)
"""


def test_code_using_the_api_type_checks_and_a_wrong_call_does_not(tmp_path):
    good = tmp_path / "good.py"
    good.write_text(USER_CODE)
    bad = tmp_path / "bad.py"
    bad.write_text(USER_CODE + "sequence.sample(rate='fast')\nkeypose.Robot('so101').tool(3)\n")
    run = lambda path: subprocess.run(
        [sys.executable, "-m", "mypy", "--strict", "--no-incremental", str(path)],
        capture_output=True, text=True, timeout=600, cwd=tmp_path,
    )
    checked = run(good)
    assert checked.returncode == 0, checked.stdout + checked.stderr
    refused = run(bad)
    assert refused.returncode == 1, refused.stdout
    assert refused.stdout.count("error:") == 2, refused.stdout


def test_import_keypose_gives_keypose_lerobot_without_importing_lerobot():
    # A fresh interpreter: `keypose.lerobot.play` as the README writes it, with no
    # `import keypose.lerobot`, and neither LeRobot nor torch imported by `import keypose`.
    code = (
        "import sys, keypose\n"
        "assert callable(keypose.lerobot.play)\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('lerobot', 'torch')))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"


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
