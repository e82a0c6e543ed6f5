"""Output sets are written whole: one run per folder, devices and links never replaced, failures leave the old set: the tests that run in-process."""
from __future__ import annotations

import json
import os
import stat
from pathlib import Path


def test_a_user_may_write_to_a_device_in_a_folder_they_cannot_write(tmp_path):
    """Non-root --json /dev/null: the device's own permission counts, not its folder's (a forked child drops to
    uid 65534 and runs the same check and write the command runs)."""
    import shutil
    import tempfile

    from bhr.output._atomic import check_output_file, write_json

    folder = Path(tempfile.mkdtemp(prefix="bhr-dev-", dir="/tmp"))  # pytest's tmp_path is closed to other users
    folder.chmod(0o755)  # root's folder: not writable by the user
    null = folder / "null"
    os.mknod(null, 0o666 | stat.S_IFCHR, os.makedev(1, 3))
    null.chmod(0o666)  # as /dev/null (mknod's mode passes through the umask)
    plain = folder / "plain.json"
    pid = os.fork()
    if pid == 0:  # the child: never returns into pytest
        code = 1
        try:
            os.setgid(65534)
            os.setuid(65534)
            check_output_file(null, "JSON")
            write_json(null, {"ok": True})
            try:
                check_output_file(plain, "JSON")
            except ValueError as exc:
                code = 0 if "not a writable folder" in str(exc) else 3
            else:
                code = 2
        except BaseException as exc:  # noqa: BLE001 - reported through the exit status
            os.write(2, repr(exc).encode())
        finally:
            os._exit(code)
    _, status = os.waitpid(pid, 0)
    try:
        assert os.waitstatus_to_exitcode(status) == 0
        assert stat.S_ISCHR(null.lstat().st_mode)
    finally:
        shutil.rmtree(folder)


def test_output_folder_always_holds_the_last_whole_set(tmp_path_factory):
    """Property: after any sequence of runs, some failing half-way, the folder holds exactly the files of the
    last run that finished, with their contents, and no staging folder is left beside it."""
    from hypothesis import given, settings
    from hypothesis import strategies as st

    from bhr.output._atomic import OutputFolder, write_text

    names = st.sets(st.sampled_from(["run.json", "codes.csv", "a.png", "b.png"]), min_size=1)

    @settings(max_examples=60, deadline=None)
    @given(runs=st.lists(st.tuples(names, st.booleans(), st.integers(0, 3)), min_size=1, max_size=6))
    def check(runs):
        parent = tmp_path_factory.mktemp("p")
        target = parent / "o"
        last: dict[str, str] | None = None
        for k, (files, fail, fail_after) in enumerate(runs):
            try:
                with OutputFolder(target, "test") as of:
                    for i, name in enumerate(sorted(files)):
                        if fail and i == min(fail_after, len(files) - 1):
                            raise OSError(28, "No space left on device")
                        write_text(of.path(name), f"run {k} {name}\n")
                last = {name: f"run {k} {name}\n" for name in files}
            except OSError:
                pass
            if last is None:
                assert not target.exists()
            else:
                got = {p.name: p.read_text() for p in target.iterdir() if p.name != "manifest.json"}
                assert got == last
                assert set(json.loads((target / "manifest.json").read_text())["files"]) == set(last)
            assert [p.name for p in parent.iterdir()] in ([], ["o"])

    check()
