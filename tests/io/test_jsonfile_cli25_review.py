"""Two commands at once (cli25): two commands moving their outputs into one ``--out``
folder through :func:`terrain.io.jsonfile.staged_outputs`."""

from __future__ import annotations

import time

from terrain.io import jsonfile
from terrain.io.jsonfile import staged_outputs
from tests.threads import at_once


def _slow_listing(monkeypatch):
    """Path.glob lists, then waits (the window in which another command moves its files)."""
    real = jsonfile.Path.glob

    def glob(self, pattern):
        found = list(real(self, pattern))
        time.sleep(0.05)
        return iter(found)

    monkeypatch.setattr(jsonfile.Path, "glob", glob)


def test_two_commands_writing_one_out_folder_at_once_leave_one_commands_files(
        tmp_path, monkeypatch):
    # the two moved their files in at the same time: the folder ended with a mix (the
    # summary of one beside tables of both, as neither removed the other's tables it had
    # not listed yet); now the folder ends as one command's outputs, whole
    _slow_listing(monkeypatch)
    out = tmp_path / "out"
    out.mkdir()
    (out / "tuning_old.csv").write_text("earlier run\n")
    (out / "notes.txt").write_text("not ours\n")
    sets = {0: ["tuning_a.csv", "tuning_shared.csv", "summary.json"],
            1: ["tuning_b.csv", "tuning_c.csv", "tuning_shared.csv", "summary.json"]}

    def command(i):
        with staged_outputs(out, ["tuning_*.csv"]) as stage:
            for name in sets[i]:
                (stage / name).write_text(f"run {i}\n")
        return i

    for _ in range(3):
        results = at_once(2, command)
        assert results == [0, 1], results
        names = sorted(p.name for p in out.iterdir())
        winner = {(out / "summary.json").read_text()}
        assert len(winner) == 1
        i = int(winner.pop().split()[1])
        assert names == sorted(sets[i] + ["notes.txt"])
        assert {(out / n).read_text() for n in sets[i]} == {f"run {i}\n"}


def test_a_file_system_without_locks_still_takes_the_outputs(tmp_path, monkeypatch):
    import errno
    import fcntl

    def no_locks(fd, op):
        raise OSError(errno.ENOLCK, "No locks available")

    monkeypatch.setattr(fcntl, "flock", no_locks)
    with staged_outputs(tmp_path, ["*.csv"]) as stage:
        (stage / "a.csv").write_text("x\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.csv"]
