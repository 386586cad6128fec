"""Issue 26 §7: every file robodcn writes is written whole or not at all (robodcn._files):
a write that fails midway, a directory that vanished, a full disk or a ``kill -9`` between
write and rename keep the old file; taught poses that cannot be written are saved elsewhere
and the message says where."""

from __future__ import annotations

import errno
import json
import os
import re
import signal
import stat
import subprocess
import sys
import time

import pytest
from conftest import ROOT
from workflow_helpers import ARM3R, backdrive, run_cli

from robodcn import _files
from robodcn.errors import FileWriteError
from robodcn.workflow import files

pytest_plugins = ["workflow_fixtures"]     # fixtures: sim

OLD = '{"old": "plan"}\n'


def leftovers(directory) -> list[str]:
    """The temporary files a write left in ``directory``."""
    return sorted(p.name for p in directory.iterdir() if p.name.endswith(".tmp"))


def test_a_new_file_is_written_and_an_old_one_replaced_keeping_its_mode(tmp_path):
    path = tmp_path / "plan.json"
    _files.write_file(path, "first\n")
    os.chmod(path, 0o640)
    _files.write_file(path, "second θ\n")
    assert path.read_text(encoding="utf-8") == "second θ\n"
    assert os.stat(path).st_mode & 0o777 == 0o640
    assert leftovers(tmp_path) == []


def test_a_new_file_gets_the_umask_mode_as_open_would(tmp_path):
    old = os.umask(0o027)
    try:
        _files.write_file(tmp_path / "a.toml", "x")
        with open(tmp_path / "b.toml", "w") as out:
            out.write("x")
    finally:
        os.umask(old)
    assert os.stat(tmp_path / "a.toml").st_mode == os.stat(tmp_path / "b.toml").st_mode


def test_a_symlink_is_followed_and_kept(tmp_path):
    real = tmp_path / "real.toml"
    real.write_text("old")
    link = tmp_path / "link.toml"
    link.symlink_to(real)
    _files.write_file(link, "new")
    assert link.is_symlink() and real.read_text() == "new"


def test_a_write_that_fails_midway_keeps_the_old_file(tmp_path):
    path = tmp_path / "plan.json"
    path.write_text(OLD)

    def disk_fills(out):
        out.write(b"[" * 4096)
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    with pytest.raises(FileWriteError) as caught:
        _files.replace_file(path, disk_fills, field="--out")
    err = caught.value
    assert path.read_text() == OLD and leftovers(tmp_path) == []
    assert err.path == str(path) and err.errno == errno.ENOSPC and err.field == "--out"
    assert err.message == (f"--out {path}: cannot write (No space left on device); the "
                           "existing file is unchanged")


def test_an_error_of_the_writer_itself_is_raised_as_it_is_and_the_old_file_kept(tmp_path):
    path = tmp_path / "plot.png"
    path.write_bytes(b"old image")

    def broken(out):
        out.write(b"half")
        raise ValueError("cannot draw")

    with pytest.raises(ValueError, match="cannot draw"):
        _files.replace_file(path, broken)
    assert path.read_bytes() == b"old image" and leftovers(tmp_path) == []


def test_an_unwritable_directory_is_named_with_the_reason(tmp_path):
    (tmp_path / "a_file").write_text("")
    for path, reason in ((tmp_path / "gone" / "p.json", "No such file or directory"),
                         (tmp_path / "a_file" / "p.json", "Not a directory")):
        with pytest.raises(FileWriteError) as caught:
            _files.write_file(path, "x")
        assert caught.value.message == (f"{path}: cannot write ({reason}); nothing was "
                                        "written")


def test_a_failed_sync_keeps_the_old_file(tmp_path, monkeypatch):
    """The data are written but the disk refuses them at fsync (a full or failing disk)."""
    path = tmp_path / "plan.json"
    path.write_text(OLD)

    def fsync(fd):
        raise OSError(errno.EIO, os.strerror(errno.EIO))

    monkeypatch.setattr(_files.os, "fsync", fsync)
    with pytest.raises(FileWriteError, match=r"\(Input/output error\); the existing file"):
        _files.write_file(path, "new")
    assert path.read_text() == OLD and leftovers(tmp_path) == []


def test_write_or_rescue_saves_the_content_elsewhere_and_says_where(tmp_path, monkeypatch):
    here = tmp_path / "here"
    here.mkdir()
    monkeypatch.chdir(here)
    target = tmp_path / "gone" / "poses.toml"
    with pytest.raises(FileWriteError) as caught:
        _files.write_or_rescue(target, "poses\n", field="--out", what="the 3 poses")
    saved = caught.value.saved_to
    assert saved is not None and os.path.dirname(saved) == str(here)
    assert open(saved).read() == "poses\n"
    assert caught.value.message.endswith(f"nothing was written; the 3 poses saved in {saved}")


def limit_file_size(limit: int = 1024):
    """In the child: files may not grow past ``limit`` bytes (RLIMIT_FSIZE; a write past it
    fails with EFBIG, as a full disk fails with ENOSPC)."""
    import resource

    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))


def test_plan_out_that_cannot_be_written_whole_keeps_the_old_plan(tmp_path):
    out = tmp_path / "plan.json"
    out.write_text(OLD)
    done = subprocess.run(
        [sys.executable, "-m", "robodcn", "plan", "--arm", ARM3R, "--to", "0.12,0.24,60",
         "--format", "json", "--out", str(out), "-q"], cwd=ROOT, capture_output=True,
        text=True, env={**os.environ, "PYTHONPATH": str(ROOT)}, preexec_fn=limit_file_size,
        timeout=120)
    assert done.returncode == 2, done.stderr
    assert done.stderr == (f"robodcn: --out {out}: cannot write (File too large); the "
                           "existing file is unchanged\n")
    assert out.read_text() == OLD and leftovers(tmp_path) == []


#: ``robodcn plan`` in a child that stops for good once the new plan is written, before it
#: is renamed: the moment a ``kill -9`` used to leave a truncated file.
STALL_BEFORE_RENAME = """
import os, sys, time
import robodcn._files as files
real_fsync = os.fsync
def fsync(fd):
    real_fsync(fd)
    open(sys.argv[1], "w").close()          # tell the test: the data are written
    time.sleep(600)
files.os.fsync = fsync
from robodcn import cli
sys.exit(cli.main(sys.argv[2:]))
"""


def test_plan_out_killed_before_the_rename_keeps_the_old_plan(tmp_path):
    out = tmp_path / "plan.json"
    out.write_text(OLD)
    ready = tmp_path / "ready"
    child = subprocess.Popen(
        [sys.executable, "-c", STALL_BEFORE_RENAME, str(ready), "plan", "--arm", ARM3R,
         "--to", "0.12,0.24,60", "--format", "json", "--out", str(out), "-q"],
        cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)})
    try:
        deadline = time.monotonic() + 120
        while not ready.exists():
            assert child.poll() is None and time.monotonic() < deadline, "no write started"
            time.sleep(0.02)
        (partial,) = leftovers(tmp_path)
        assert json.loads((tmp_path / partial).read_text())["t"]     # the new plan, whole
        child.send_signal(signal.SIGKILL)
        assert child.wait(timeout=30) == -signal.SIGKILL
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
    assert out.read_text() == OLD


def test_plan_out_killed_at_any_moment_leaves_the_old_plan_or_the_new(tmp_path):
    """The issue's probe: ``kill -9`` at moments spread over the whole write."""
    out = tmp_path / "plan.json"
    argv = [sys.executable, "-m", "robodcn", "plan", "--arm", ARM3R, "--to", "0.12,0.24,60",
            "--format", "json", "--out", str(out), "-q"]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    subprocess.run(argv, cwd=ROOT, env=env, check=True, timeout=120)
    new = out.read_text()
    started = time.monotonic()
    subprocess.run(argv, cwd=ROOT, env=env, check=True, timeout=120)
    whole = time.monotonic() - started
    for k in range(8):
        out.write_text(OLD)
        child = subprocess.Popen(argv, cwd=ROOT, env=env)
        time.sleep(whole * (0.55 + 0.06 * k))
        child.send_signal(signal.SIGKILL)
        child.wait(timeout=30)
        assert out.read_text() in (OLD, new), k


def test_teach_whose_file_cannot_be_written_saves_the_poses_elsewhere(sim, monkeypatch,
                                                                      tmp_path, capsys):
    """The USB stick holding --out is pulled while the hand teaches: the poses go to a
    timestamped file in the current directory, the message says where, no traceback."""
    stick = tmp_path / "stick"
    stick.mkdir()
    here = tmp_path / "here"
    here.mkdir()
    monkeypatch.chdir(here)
    out = stick / "poses.toml"

    def pull_the_stick():
        backdrive(sim, {1: 2300, 2: 1500, 3: 2600})
        stick.rmdir()
        return ""

    code = run_cli(monkeypatch, ["teach", "--arm", ARM3R, "--device", sim.port_path,
                                 "--out", str(out), "--method", "sclerp"],
                   ["", pull_the_stick, "q"])
    err = capsys.readouterr().err
    assert code == 2, err
    assert "Traceback" not in err
    (saved,) = here.iterdir()
    assert saved.name.startswith("poses-unsaved-") and saved.suffix == ".toml"
    assert err.endswith(f"robodcn: --out {out}: cannot write (No such file or directory); "
                        f"nothing was written; the 2 taught waypoints saved in {saved}\n")
    waypoints = files.load_waypoints(saved)
    assert len(waypoints.waypoints) == 2 and waypoints.options["method"] == "sclerp"


def test_teach_with_a_method_list_of_the_wrong_length_keeps_the_poses(sim, monkeypatch,
                                                                       tmp_path, capsys):
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "poses.toml"
    code = run_cli(monkeypatch, ["teach", "--arm", ARM3R, "--device", sim.port_path,
                                 "--out", str(out), "--method", "sclerp,dlb"],
                   ["", lambda: backdrive(sim, {1: 2300, 2: 1500, 3: 2600}) or "", "q"])
    err = capsys.readouterr().err
    assert code == 2 and not out.exists()
    (saved,) = tmp_path.glob("poses-unsaved-*.toml")
    assert err.endswith(f"robodcn: --method lists 2 values for 1 segments; the 2 taught "
                        f"waypoints are saved in {saved} (without --method)\n")
    assert len(files.load_waypoints(saved).waypoints) == 2


def test_teach_with_nowhere_to_save_prints_the_poses(sim, monkeypatch, tmp_path, capsys):
    """--out, the current directory and the temporary directory all gone: the file's text
    goes to standard output, the last place left."""
    gone = [tmp_path / name for name in ("stick", "here", "tmp")]
    for directory in gone:
        directory.mkdir()
    monkeypatch.chdir(gone[1])
    monkeypatch.setattr(_files.tempfile, "gettempdir", lambda: str(gone[2]))
    out = gone[0] / "poses.toml"

    def everything_goes():
        backdrive(sim, {1: 2300, 2: 1500, 3: 2600})
        for directory in gone:
            directory.rmdir()
        return ""

    code = run_cli(monkeypatch, ["teach", "--arm", ARM3R, "--device", sim.port_path,
                                 "--out", str(out)], ["", everything_goes, "q"])
    captured = capsys.readouterr()
    assert code == 2 and "Traceback" not in captured.err
    # the one error line (the CLI shortens a long line in its middle, so a long temporary
    # path, as under xdist, cuts the text between these parts)
    last = captured.err.splitlines()[-1]
    line = last[last.index("robodcn: --out"):]           # after the last prompt's text
    assert line.startswith(f"robodcn: --out {out}: cannot write (No such file or directory); "
                           "nothing was written; the 2 taught waypoints could not be saved"), line
    assert line.endswith(f"{gone[2].name}: No such file or directory); it is printed on "
                         "standard output"), line
    (tmp_path / "again.toml").write_text(captured.out)
    assert len(files.load_waypoints(tmp_path / "again.toml").waypoints) == 2


def test_a_fifo_is_written_in_place_not_replaced(tmp_path):
    """``--out /dev/stdout`` or a named pipe: no old content to keep, and a rename would
    replace the node itself (as root, even /dev/null) with a regular file."""
    import threading

    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got: list[bytes] = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_bytes()))
    reader.start()
    _files.write_file(fifo, "through the pipe\n")
    reader.join(timeout=10)
    assert got == [b"through the pipe\n"]
    assert stat.S_ISFIFO(os.stat(fifo).st_mode) and leftovers(tmp_path) == []


#: The modules allowed to write a file other than through robodcn._files: the helper itself,
#: and the FTDI latency timer (a sysfs attribute: written in place, it cannot be renamed).
WRITERS_ALLOWED = {"robodcn/_files.py", "robodcn/bus/latency.py"}
#: A call that writes a file: open(..., "w"/"a"/"x"), write_text/write_bytes, savefig to a
#: path, tomlkit.dump, numpy's save/savetxt.
WRITES = re.compile(r"""\bopen\([^)]*['"][wax]b?\+?['"]|\.write_text\(|\.write_bytes\(|"""
                    r"""savefig\((?!out\b)|tomlkit\.dump\(|np\.save(txt)?\(""")


def test_every_file_robodcn_writes_goes_through_the_helper():
    offenders = []
    for path in sorted((ROOT / "robodcn").rglob("*.py")):
        name = path.relative_to(ROOT).as_posix()
        if name in WRITERS_ALLOWED:
            continue
        for number, line in enumerate(path.read_text().splitlines(), start=1):
            if WRITES.search(line.split("#", 1)[0]):
                offenders.append(f"{name}:{number}: {line.strip()}")
    assert offenders == []
