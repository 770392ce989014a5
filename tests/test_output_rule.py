"""The one output rule (records/files.py): an output never aliases an input, an
existing one is kept unless overwrite, and it appears only when complete."""
import os

import pytest

from records.files import existing_files, filled, output_file, output_folder, written
from rig.errors import UsageError


def test_an_output_is_never_an_input_by_path_link_or_folder(tmp_path):
    src = tmp_path / "in.mcap"
    src.write_bytes(b"recording")
    os.link(src, tmp_path / "hard.mcap")
    (tmp_path / "soft.mcap").symlink_to(src)
    for out in (src, tmp_path / "hard.mcap", tmp_path / "soft.mcap", tmp_path / "." / "in.mcap"):
        with pytest.raises(UsageError, match="that is an input"):
            output_file(out, [src], overwrite=True)
    with pytest.raises(UsageError, match="holds the input"):
        output_folder(tmp_path, [src], overwrite=True)
    with pytest.raises(UsageError, match="holds the input"):
        output_folder(tmp_path.parent, [src], overwrite=True)
    assert output_folder(tmp_path / "new", [src]) == tmp_path / "new"
    assert src.read_bytes() == b"recording"


def test_an_existing_output_is_kept_unless_overwrite(tmp_path):
    f = tmp_path / "m.json"
    f.write_text("old")
    with pytest.raises(UsageError, match="exists; give --overwrite"):
        output_file(f)
    assert output_file(f, overwrite=True) == f
    (tmp_path / "empty").mkdir()
    assert output_folder(tmp_path / "empty") == tmp_path / "empty"  # an empty folder holds nothing to lose
    (tmp_path / "busy").mkdir()
    (tmp_path / "busy" / "mine.txt").write_text("mine")
    with pytest.raises(UsageError, match="not empty"):
        output_folder(tmp_path / "busy")


def test_a_write_that_fails_halfway_leaves_the_old_file_and_no_temporary(tmp_path):
    f = tmp_path / "m.json"
    f.write_text("old")
    os.chmod(f, 0o640)
    with pytest.raises(ZeroDivisionError):
        with written(f) as tmp:
            tmp.write_text("half")
            raise ZeroDivisionError
    assert f.read_text() == "old" and os.listdir(tmp_path) == ["m.json"]
    with written(f) as tmp:
        tmp.write_text("new")
        assert f.read_text() == "old"  # not until the block ends
    assert f.read_text() == "new" and os.listdir(tmp_path) == ["m.json"]
    assert f.stat().st_mode & 0o777 == 0o640  # the replaced file's mode is kept


def test_a_folder_is_filled_when_complete_and_keeps_what_it_did_not_write(tmp_path):
    out = tmp_path / "report"
    out.mkdir()
    (out / "mine.txt").write_text("mine")
    (out / "index.html").write_text("old")
    with pytest.raises(RuntimeError):
        with filled(out) as tmp:
            (tmp / "index.html").write_text("half")
            raise RuntimeError
    assert (out / "index.html").read_text() == "old"
    with filled(out) as tmp:
        (tmp / "index.html").write_text("new")
        (tmp / "sub").mkdir()
        (tmp / "sub" / "a.png").write_bytes(b"png")
    assert (out / "index.html").read_text() == "new" and (out / "mine.txt").read_text() == "mine"
    assert (out / "sub" / "a.png").read_bytes() == b"png"
    assert sorted(os.listdir(tmp_path)) == ["report"]  # no temporary folder left
    with filled(tmp_path / "fresh") as tmp:
        (tmp / "x").write_text("x")
    assert (tmp_path / "fresh" / "x").read_text() == "x"
    mask = os.umask(0)
    os.umask(mask)
    assert (tmp_path / "fresh").stat().st_mode & 0o777 == 0o777 & ~mask  # as mkdir would make it


def test_inputs_are_found_in_plain_paths_name_value_and_kind_path(tmp_path):
    a, b, c = (tmp_path / n for n in ("a.csv", "b.json", "c.csv"))
    for p in (a, b, c):
        p.write_text("x")
    found = existing_files(str(a), ["target=" + str(b)], "file:" + str(c), None, "koni", str(tmp_path / "none"))
    assert sorted(found) == sorted([a, b, c])
