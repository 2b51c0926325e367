"""Opening a user's file (:mod:`regen.promises.files`): every way a file can be wrong is one
ConfigError line that names the file (and the line or row) and says what to do."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from regen.errors import AssetDatabaseError, ConfigError
from regen.promises import files

GIVE = "give a test file"


def _one_line(exc: pytest.ExceptionInfo, *says: str) -> str:
    text = str(exc.value)
    assert "\n" not in text and "\r" not in text, text
    for phrase in says:
        assert phrase in text, (phrase, text)
    return text


def test_a_missing_path_a_folder_and_a_path_with_a_nul(tmp_path: Path) -> None:
    with pytest.raises(ConfigError) as err:
        files.read_text(tmp_path / "nope.csv", what="trajectory", give=GIVE)
    _one_line(err, f"trajectory {tmp_path / 'nope.csv'}", "is not an existing file", GIVE)
    with pytest.raises(ConfigError) as err:
        files.read_text(tmp_path, give=GIVE)
    _one_line(err, "is a folder", GIVE)
    with pytest.raises(ConfigError) as err:
        files.read_bytes(str(tmp_path / "a\x00b"), give=GIVE)
    _one_line(err, GIVE)
    with pytest.raises(ConfigError) as err:  # a name that would fake a line on the terminal
        files.read_text(tmp_path / "x\nerror: all good", give=GIVE)
    _one_line(err, "x\\nerror: all good'", "is not an existing file")


@pytest.mark.skipif(not Path("/proc/self/mem").exists(), reason="no /proc")
def test_a_special_file_that_answers_with_an_io_error() -> None:
    with pytest.raises(ConfigError) as err:
        files.read_text("/proc/self/mem", what="map", give=GIVE)
    _one_line(err, "map /proc/self/mem cannot be read (Input/output error)", GIVE)


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root reads everything")
def test_a_file_without_permission(tmp_path: Path) -> None:
    f = tmp_path / "locked.csv"
    f.write_text("t,x,y\n")
    f.chmod(0)
    with pytest.raises(ConfigError) as err:
        files.read_text(f, give=GIVE)
    _one_line(err, "Permission denied", "check its permissions")


def test_the_size_cap_holds_for_files_whose_size_says_nothing(tmp_path: Path) -> None:
    f = tmp_path / "big.csv"
    f.write_bytes(b"x" * 101)
    with pytest.raises(ConfigError) as err:
        files.read_bytes(f, give=GIVE, limit=100)
    _one_line(err, "is larger than 0.0001 MB", GIVE)
    if Path("/dev/zero").exists():  # st_size 0, endless: read only up to the cap
        with pytest.raises(ConfigError, match="is larger than"):
            files.read_bytes("/dev/zero", give=GIVE, limit=1000)


def test_utf8_with_or_without_a_byte_order_mark(tmp_path: Path) -> None:
    f = tmp_path / "a.txt"
    f.write_bytes(b"\xef\xbb\xbft,x,y\n")
    assert files.read_text(f, give=GIVE) == "t,x,y\n"
    f.write_bytes("t,x,y\ncafé\n".encode())
    assert files.read_text(f, give=GIVE).endswith("café\n")


def test_bytes_that_are_not_utf8_name_the_byte_its_offset_and_line(tmp_path: Path) -> None:
    f = tmp_path / "a.txt"
    f.write_bytes(b"\xef\xbb\xbfok\ncaf\xe9\n")
    with pytest.raises(ConfigError) as err:
        files.read_text(f, what="labeled set", give=GIVE)
    _one_line(err, f"labeled set {f}, line 2: not UTF-8 text (byte 0xe9 at offset 9): save it as UTF-8")
    f.write_bytes("t,x,y\n".encode("utf-16"))
    with pytest.raises(ConfigError) as err:
        files.read_text(f, give=GIVE)
    _one_line(err, "is UTF-16 text, not UTF-8: save it as UTF-8")


def test_json_lines_name_the_line(tmp_path: Path) -> None:
    f = tmp_path / "a.jsonl"
    f.write_text('{"a": 1}\n\n# note\n{"a": \n' + "[" * 100_000 + "\n" + "1" * 5000 + "\n")
    with pytest.raises(ConfigError) as err:
        files.json_lines(f, give=GIVE, skip=lambda line: line.startswith("#"))
    _one_line(err, f"{f}, line 4: not valid JSON (Expecting value at column 7)", GIVE)
    f.write_text('{"a": 1}\n' + "[" * 100_000 + "\n")
    with pytest.raises(ConfigError) as err:
        files.json_lines(f, give=GIVE)
    _one_line(err, "line 2: JSON nested too deeply", GIVE)
    f.write_text("1" * 5000 + "\n")
    with pytest.raises(ConfigError) as err:
        files.json_lines(f, give=GIVE)
    _one_line(err, "line 1: not valid JSON (Exceeds the limit (4300 digits)")
    f.write_text('"a\u2028b"\r\n{"b": 2}\n')  # a line separator inside a string is not a line break
    assert files.json_lines(f, give=GIVE) == [(1, "a\u2028b"), (2, {"b": 2})]


def test_a_whole_json_file_raises_the_callers_error(tmp_path: Path) -> None:
    with pytest.raises(AssetDatabaseError, match=r"db.json: not valid JSON at line 2, column 6: Expecting property name .*; give a test file"):
        files.parse_json('{"a":\n  1, }', "db.json", give=GIVE, error=AssetDatabaseError)
    with pytest.raises(ConfigError, match="nested too deeply"):
        files.parse_json("[" * 100_000, "x.json", give=GIVE)


def test_a_resume_drops_a_cut_off_last_line_and_says_so(tmp_path: Path) -> None:
    f = tmp_path / "results.jsonl"
    assert files.resume_json_lines(f, give=GIVE) == ([], None)  # nothing yet
    whole = json.dumps({"id": "a"}) + "\n"
    f.write_bytes(whole.encode() + b'{"id": "caf' + "é".encode()[:1])  # cut inside a character
    rows, note = files.resume_json_lines(f, what="results file", give=GIVE)
    assert rows == [(1, {"id": "a"})]
    assert note is not None and "dropped its cut-off last line 2" in note and str(f) in note
    assert f.read_text() == whole  # cut back: the next row starts a line of its own
    f.write_text(whole + json.dumps({"id": "b"}))  # whole, only its newline missing: kept, and finished
    rows, note = files.resume_json_lines(f, give=GIVE)
    assert [v["id"] for _, v in rows] == ["a", "b"] and note is None
    assert f.read_text().endswith('"b"}\n')
    f.write_text('{"id": \n' + whole)
    with pytest.raises(ConfigError) as err:
        files.resume_json_lines(f, give=GIVE)
    _one_line(err, f"{f}, line 1: not valid JSON", GIVE)


def test_csv_rows_are_numbered_as_the_files_lines(tmp_path: Path) -> None:
    f = tmp_path / "a.csv"
    f.write_bytes(b"\xef\xbb\xbft,x\r\n\r\n1,\"two\nlines\"\r\n3,4\r\n")
    assert files.csv_rows(f, give=GIVE) == [(1, ["t", "x"]), (3, ["1", "two\nlines"]), (5, ["3", "4"])]
    f.write_text("t,x\n1,2\n3," + "9" * 200_000 + "\n")
    with pytest.raises(ConfigError) as err:
        files.csv_rows(f, what="trajectory", give=GIVE)
    _one_line(err, f"trajectory {f}: row 3: a field longer than 131072 characters", GIVE)


def test_xml_that_cannot_be_read(tmp_path: Path) -> None:
    f = tmp_path / "a.xosc"
    f.write_text("<a>\n  <b>\n</a>")
    with pytest.raises(ConfigError) as err:
        files.parse_xml(f, give=GIVE)
    _one_line(err, "is not readable XML (mismatched tag at line 3, column 3)", GIVE)
    f.write_text('<!DOCTYPE a [<!ENTITY e "x">]><a>&e;</a>')
    with pytest.raises(ConfigError) as err:
        files.parse_xml(f, give=GIVE)
    _one_line(err, "declares XML entities", "Give a test file")
    f.write_text('<!DOCTYPE a SYSTEM "http://example.com/a.dtd"><a>&ext;</a>')  # nothing is fetched
    with pytest.raises(ConfigError, match="undefined entity"):
        files.parse_xml(f, give=GIVE)
    f.write_text("<a>" * 5000 + "</a>" * 5000)
    with pytest.raises(ConfigError) as err:
        files.parse_xml(f, give=GIVE)
    _one_line(err, f"nests its elements more than {files.MAX_XML_DEPTH} deep")
    f.write_bytes('<?xml version="1.0" encoding="UTF-16"?><a x="é"/>'.encode("utf-16"))  # XML declares its own
    assert files.parse_xml(f, give=GIVE).get("x") == "é"


def test_shown_escapes_and_cuts() -> None:
    assert files.shown("a\nb\x1b[31m") == "'a\\nb\\x1b[31m'"
    assert files.shown("x" * 500, 10) == "'" + "x" * 10 + "...'"
